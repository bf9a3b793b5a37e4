//! Section "front": the workspace–first-resonance front of `flexstage front`
//! (`front/front.json`, `front/front.svg`): the figure, one row per design (the bound it was
//! designed for, workspace, the stage's first natural frequency on the design mesh, the
//! body-fitted outline and the twin, mass, stresses, verdict, the best controller's tracking
//! error at the named scan speed), the design the scan speed and accepted error pick, and
//! each design's outline and lowest mode shapes.

use serde_json::Value;

use super::reduce::mode_shape_pngs;
use super::{Builder, Width, fmt_num, num};
use crate::layout::front as files;

/// A number at a JSON path scaled and formatted with a unit, or "–".
fn val(v: &Value, path: &[&str], scale: f64, unit: &str) -> String {
    num(v, path)
        .filter(|x| x.is_finite())
        .map(|x| format!("{}{unit}", fmt_num(x * scale)))
        .unwrap_or_else(|| "–".into())
}

/// The best controller's error at the scan speed: the smallest worse-axis error.
fn best(d: &Value) -> Option<(String, f64, f64)> {
    d.get("scan")?
        .as_array()?
        .iter()
        .filter_map(|e| {
            let p = [num(e, &["percent", "0"])?, num(e, &["percent", "1"])?];
            let name = e.get("controller")?.as_str()?.to_string();
            p.iter()
                .all(|x| x.is_finite())
                .then_some((name, p[0], p[1]))
        })
        .min_by(|a, b| a.1.max(a.2).total_cmp(&b.1.max(b.2)))
}

fn row(d: &Value) -> Vec<String> {
    let bound = num(d, &["min_frequency_hz"]).unwrap_or(0.0);
    let safe = d.get("safe").and_then(Value::as_bool).unwrap_or(false);
    vec![
        format!("d{}", num(d, &["index"]).unwrap_or(0.0)),
        if bound > 0.0 {
            format!("≥ {} Hz", fmt_num(bound))
        } else {
            "none".into()
        },
        val(d, &["design", "area"], 1e12, " µm²"),
        val(d, &["design", "first_frequency_hz"], 1.0, " Hz"),
        val(d, &["body_fitted_hz"], 1.0, " Hz"),
        val(d, &["twin_hz"], 1.0, " Hz"),
        val(d, &["design", "mass"], 1e3, " g"),
        val(d, &["body_fitted_stress"], 1e-6, " MPa"),
        if safe {
            "safe".into()
        } else {
            "NOT safe".into()
        },
        best(d).map_or("–".into(), |(c, a, b)| {
            format!("{c}: {} % / {} %", fmt_num(a), fmt_num(b))
        }),
    ]
}

/// Section "front".
pub(super) fn front(b: &mut Builder) {
    let Some(f) = b.json(files::JSON) else {
        b.not_run(&format!("{} missing (`flexstage front`)", files::JSON));
        return;
    };
    let scan = num(&f, &["scan_hz"]).unwrap_or(0.0);
    let designs: Vec<Value> = f
        .get("designs")
        .and_then(Value::as_array)
        .cloned()
        .unwrap_or_default();
    b.note(&format!(
        "Designs from the workspace design d0 to a first-frequency bound, each warm-started \
         from the previous one; the stage's first natural frequency (PEA springs and plates, \
         rollers, payload) on the design mesh, on the body-fitted outline and on the twin; the \
         tracking error of the best controller (designed on each twin as `track` designs it) \
         on a 3:1 Lissajous whose fast axis runs at {} Hz, in % of each axis's range (q1 / q2).",
        fmt_num(scan)
    ));
    b.img(
        files::SVG,
        "Workspace against the stage's first natural frequency",
    );
    let header: Vec<String> = [
        "design",
        "bound",
        "workspace",
        "f1 design mesh",
        "f1 body-fitted",
        "f1 twin",
        "mass",
        "stress body-fitted",
        "verdict",
        &format!("error at {} Hz", fmt_num(scan)),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let rows: Vec<Vec<String>> = designs.iter().map(row).collect();
    b.table(&header, &rows);
    for d in &designs {
        let k = num(d, &["index"]).unwrap_or(0.0) as usize;
        b.h3(&format!(
            "d{k}: {} µm², {}",
            val(d, &["design", "area"], 1e12, ""),
            val(d, &["design", "first_frequency_hz"], 1.0, " Hz")
        ));
        b.grid_open();
        b.file_figure(&files::outline(k), &format!("d{k}: outline"), Width::Half);
        if let Some(vtu) = b.text(&files::modes(k)) {
            for (name, png) in mode_shape_pngs(&vtu, 2, 480) {
                let label = format!("d{k}: {}", name.replace('_', " ").replacen("Hz", " Hz", 1));
                b.png(&png, &label, Some(&files::modes(k)), Width::Half);
            }
        }
        b.grid_close();
    }
}
