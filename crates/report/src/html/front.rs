//! Section "front": the workspace–first-resonance front of `flexstage front`
//! (`front/front.json`, `front/front.svg`): the figure, one row per design (the bound it was
//! designed for, workspace, the stage's first natural frequency on the design mesh, the
//! body-fitted outline and the twin, mass, stresses, verdict, the best controller's tracking
//! error at the named scan speed), the design the scan speed and accepted error pick, and
//! each design's outline and lowest mode shapes.

use flexstage_run::files::front::{FrontDesign, FrontFile};
use flexstage_run::layout::front as files;

use super::{Builder, Width, fmt_num};

/// A value times `scale` with its unit, or "–".
fn val(v: Option<f64>, scale: f64, unit: &str) -> String {
    v.filter(|x| x.is_finite())
        .map(|x| format!("{}{unit}", fmt_num(x * scale)))
        .unwrap_or_else(|| "–".into())
}

fn row(d: &FrontDesign) -> Vec<String> {
    vec![
        format!("d{}", d.index),
        if d.min_frequency_hz > 0.0 {
            format!("≥ {} Hz", fmt_num(d.min_frequency_hz))
        } else {
            "none".into()
        },
        val(Some(d.design.area), 1e12, " µm²"),
        val(d.design.first_frequency_hz, 1.0, " Hz"),
        val(d.body_fitted_hz, 1.0, " Hz"),
        val(d.twin_hz, 1.0, " Hz"),
        val(Some(d.design.mass), 1e3, " g"),
        val(d.body_fitted_stress, 1e-6, " MPa"),
        if d.safe { "safe" } else { "NOT safe" }.into(),
        d.best().map_or("–".into(), |b| {
            format!(
                "{}: {} % / {} %",
                b.controller,
                fmt_num(b.percent[0]),
                fmt_num(b.percent[1])
            )
        }),
    ]
}

/// Section "front".
pub(super) fn front(b: &mut Builder) {
    let Some(f) = b.load::<FrontFile>(files::JSON) else {
        b.missing(files::JSON);
        return;
    };
    b.note(&format!(
        "Designs from the workspace design d0 to a first-frequency bound, each warm-started \
         from the previous one; the stage's first natural frequency (PEA springs and plates, \
         rollers, payload) on the design mesh, on the body-fitted outline and on the twin; the \
         tracking error of the best controller (designed on each twin as `track` designs it) \
         on a 3:1 Lissajous whose fast axis runs at {} Hz, in % of each axis's range (q1 / q2).",
        fmt_num(f.scan_hz)
    ));
    b.img(
        files::SVG,
        "Workspace against the stage's first natural frequency",
    );
    let scan = format!("error at {} Hz", fmt_num(f.scan_hz));
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
        &scan,
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let rows: Vec<Vec<String>> = f.designs.iter().map(row).collect();
    b.table(&header, &rows);
    b.note(&match f.pick() {
        Some(d) => format!(
            "Picked: d{}, the largest workspace verified safe that tracks the {} Hz scan within \
             {} % of range.",
            d.index,
            fmt_num(f.scan_hz),
            fmt_num(f.max_error_pct)
        ),
        None => format!(
            "No design is verified safe and tracks the {} Hz scan within {} % of range.",
            fmt_num(f.scan_hz),
            fmt_num(f.max_error_pct)
        ),
    });
    for d in &f.designs {
        let k = d.index;
        b.h3(&format!(
            "d{k}: {}, {}",
            val(Some(d.design.area), 1e12, " µm²"),
            val(d.design.first_frequency_hz, 1.0, " Hz")
        ));
        b.grid_open();
        b.file_figure(&files::outline(k), &format!("d{k}: outline"), Width::Half);
        for m in 1..=files::MODE_PNGS {
            let freq = d.design.frequencies_hz.get(m - 1).copied();
            b.file_figure(
                &files::mode_png(k, m),
                &format!("d{k}: mode {m}, {}", val(freq, 1.0, " Hz")),
                Width::Half,
            );
        }
        b.grid_close();
    }
}
