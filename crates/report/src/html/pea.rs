//! PEA section: Table A1 (Bouc–Wen estimates of both PEAs against the scenario's values),
//! Figure A2 (identification convergence of each PEA and the hysteresis curves of both) and
//! the hysteresis before and after inverse compensation (Eq. 21).

use std::sync::Arc;

use flexstage_figures::plot::{Figure, Legend, Series};
use flexstage_run::Table;
use flexstage_run::files::pea::PeaEstimates;
use flexstage_run::layout::{self, PeaIdentification};
use flexstage_run::scenario::BoucWen;

use super::{Builder, Width, fmt_num};

/// The PEAs of the paper.
const PEAS: [u8; 2] = [1, 2];

/// One parameter of Eq. (18).
type Getter = fn(&BoucWen) -> f64;

/// Table A1's rows: (parameter, symbol, unit).
const PARAMETERS: [(Getter, &str, &str); 5] = [
    (|p| p.d_p, "d_p", "µm/V"),
    (|p| p.a_bw, "A_bw", "µm/V"),
    (|p| p.b_bw, "B_bw", "1/V"),
    (|p| p.gamma_bw, "Γ_bw", "1/V"),
    (|p| p.delta_bw, "δ_bw", "µm/(V·s)"),
];

/// Section "pea".
pub(super) fn pea(b: &mut Builder) {
    let estimates: Vec<(u8, Arc<PeaEstimates>)> = PEAS
        .iter()
        .filter_map(|&n| Some((n, b.load(&PeaIdentification { pea: n }.estimates())?)))
        .collect();
    if estimates.is_empty() {
        let records: Vec<u8> = PEAS
            .into_iter()
            .filter(|&n| b.exists(&layout::pea::loop_svg(n)))
            .collect();
        if PEAS
            .iter()
            .all(|&n| !b.exists(&PeaIdentification { pea: n }.estimates()))
        {
            b.not_run("identify/pea1/ and identify/pea2/ missing");
        }
        for n in records {
            b.img(
                &layout::pea::loop_svg(n),
                &format!("PEA{n}: simulated record"),
            );
        }
        return;
    }
    table_a1(b, &estimates);
    b.h3("Figure A2: identification of each PEA and the hysteresis curves of both");
    for (n, _) in &estimates {
        let id = PeaIdentification { pea: *n };
        if b.exists(&id.convergence_svg()) {
            let caption = format!(
                "PEA{n}: parallel RLS estimates over the record, each divided by the batch \
                 estimate (Figure A2, left)"
            );
            b.img(&id.convergence_svg(), &caption);
        }
    }
    both_loops(b, &estimates);
    b.h3("Inverse compensation (Eq. 21)");
    for (n, _) in &estimates {
        let id = PeaIdentification { pea: *n };
        if b.exists(&id.compensation_svg()) {
            b.img(
                &id.compensation_svg(),
                &format!("PEA{n}: hysteresis without and with inverse compensation"),
            );
        }
    }
    for (n, _) in &estimates {
        b.shown.push(PeaIdentification { pea: *n }.loop_svg());
    }
}

/// Table A1: each parameter's estimate for every identified PEA, the scenario's value
/// (Table A1 for the paper preset) and their difference.
fn table_a1(b: &mut Builder, estimates: &[(u8, Arc<PeaEstimates>)]) {
    let mut header = vec!["symbol".to_string(), "unit".to_string()];
    for (n, _) in estimates {
        header.push(format!("PEA{n} estimate"));
        header.push(format!("PEA{n} scenario"));
        header.push(format!("PEA{n} Δ [%]"));
    }
    let mut rows: Vec<Vec<String>> = PARAMETERS
        .iter()
        .map(|(get, symbol, unit)| {
            let mut row = vec![symbol.to_string(), unit.to_string()];
            for (_, t) in estimates {
                let (e, s) = (get(&t.recommended_params), get(&t.scenario));
                let diff = if s != 0.0 {
                    fmt_num(100.0 * (e - s) / s)
                } else {
                    "–".into()
                };
                row.push(fmt_num(e));
                row.push(fmt_num(s));
                row.push(diff);
            }
            row
        })
        .collect();
    let mut method = vec!["estimate from".to_string(), String::new()];
    let mut rms = vec!["RMS model error".to_string(), "nm".to_string()];
    for (_, t) in estimates {
        let best = if t.recommended == "batch" {
            &t.batch
        } else {
            &t.parallel_rls
        };
        method.extend([t.recommended.clone(), String::new(), String::new()]);
        rms.extend([
            fmt_num(best.rms_error_um * 1e3),
            String::new(),
            String::new(),
        ]);
    }
    rows.push(method);
    rows.push(rms);
    b.h3("Table A1: Bouc–Wen coefficients of the PEAs (Eq. 18, n = 1)");
    b.note(
        "The estimate with the lower RMS error along the record (parallel RLS, Algorithm A1, \
         or the batch least-squares fit) against the scenario's parameters that simulated the \
         record (the paper's Table A1 for the paper preset).",
    );
    b.table(&header, &rows);
}

/// The hysteresis curves of both PEAs: record and identified model, x against U.
fn both_loops(b: &mut Builder, estimates: &[(u8, Arc<PeaEstimates>)]) {
    let mut fig = Figure::new(
        "Hysteresis of the PEAs: record and identified model (Figure A2, right)",
        "U [V]",
        "x [µm]",
    )
    .with_legend(Legend::UpperLeft);
    let mut sources = Vec::new();
    for (k, (n, _)) in estimates.iter().enumerate() {
        let rel = PeaIdentification { pea: *n }.loop_csv();
        let Some(t) = b.load::<Table>(&rel) else {
            continue;
        };
        let c = match t.columns(&["U", "x", "x_model"]) {
            Ok(c) => c,
            Err(reason) => {
                b.damaged(&rel, reason);
                continue;
            }
        };
        let pairs = |y: &[f64]| c[0].iter().copied().zip(y.iter().copied()).collect();
        fig = fig
            .with(Series::line(format!("PEA{n} record"), pairs(c[1])).with_color(2 * k))
            .with(Series::line(format!("PEA{n} model"), pairs(c[2])).with_color(2 * k + 1));
        sources.push(rel);
    }
    if let Ok(svg) = fig.to_svg() {
        let caption = "Hysteresis loops of the records (10 nm sensor noise by default) and of \
                       the identified models";
        b.svg(&svg, caption, Some(&sources.join(", ")), Width::Full);
    }
}
