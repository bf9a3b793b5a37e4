//! Reduced-model sections: the lumped parameters of Section 3.2.1 with the validity map, and
//! the mode shapes of the design (the pictures `flexstage reduce` draws).

use flexstage_run::files::reduce::ReduceSummaryJson;
use flexstage_run::layout::reduce as files;

use super::{Builder, Width, fmt_num};

/// Section "reduce": α, θ, stiffnesses, mass, frequencies, checks, validity map.
pub(super) fn reduce(b: &mut Builder) {
    match b.load::<ReduceSummaryJson>(files::SUMMARY_JSON) {
        Some(r) => {
            let r = &r.0;
            let mut rows = vec![
                ("α (scalar, Eq. 27)".to_string(), fmt_num(r.alpha_scalar)),
                ("tilt θ [°]".into(), fmt_num(r.theta_deg)),
                ("K_qo1 [N/m]".into(), fmt_num(r.k_qo1)),
                ("K_qo2 [N/m]".into(), fmt_num(r.k_qo2)),
                ("moving mass M [kg]".into(), fmt_num(r.mass_kg)),
                ("volume fraction".into(), fmt_num(r.volume_fraction)),
            ];
            if let Some(m) = &r.modal {
                let list: Vec<String> = m.frequencies_hz.iter().copied().map(fmt_num).collect();
                rows.push(("natural frequencies [Hz]".into(), list.join(", ")));
                rows.push(("Assumption 2".into(), m.assumption2.clone()));
            }
            if let Some(v) = &r.validity {
                rows.push((
                    "reduced vs nonlinear FE within the stroke".into(),
                    format!("max {} %", fmt_num(100.0 * v.max_error_within_stroke)),
                ));
            }
            b.kv(&rows);
        }
        None => b.missing(files::SUMMARY_JSON),
    }
    for (rel, caption) in [
        (
            files::VALIDITY_SVG,
            "Validity map: reduced model vs nonlinear FE",
        ),
        (
            files::VALIDITY_SCALE_SVG,
            "Model error against stroke scale",
        ),
    ] {
        if b.exists(rel) {
            b.img(rel, caption);
        }
    }
}

/// Section "modes": the lowest mode shapes, two per row.
pub(super) fn modes(b: &mut Builder) {
    let Some(r) = b.load::<ReduceSummaryJson>(files::SUMMARY_JSON) else {
        b.missing(files::SUMMARY_JSON);
        return;
    };
    let frequencies = r.0.modal.as_ref().map(|m| m.frequencies_hz.clone());
    let shapes: Vec<(String, String)> = frequencies
        .unwrap_or_default()
        .iter()
        .take(files::MODE_PNGS)
        .enumerate()
        .map(|(k, f)| (files::mode_png(k + 1), format!("mode {} {f:.0} Hz", k + 1)))
        .filter(|(rel, _)| b.exists(rel))
        .collect();
    if shapes.is_empty() {
        b.not_run(&format!("{} has no mode shapes", files::DIR));
        return;
    }
    b.note(
        "Solid cells (ρ ≥ 0.5) drawn deformed by each mode (largest displacement 6 % of the \
         domain length), shaded by displacement magnitude (blue: still, red: largest).",
    );
    b.grid_open();
    for (rel, label) in shapes {
        b.file_figure(&rel, &label, Width::Half);
    }
    b.grid_close();
}
