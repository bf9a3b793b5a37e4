//! Stage section: Table 4 of the paper for this run: the stage parameters (guess, online
//! least-squares estimate, simulated truth), the known masses and α, and the state-estimator
//! and controller gains the run used beside the paper's values.

use flexstage_run::files::stage::ParameterRow;
use flexstage_run::format::Rows;
use flexstage_run::layout::{self, stage as files};
use flexstage_run::scenario::{Controller, Scenario, StageParams};

use super::{Builder, esc, fmt_num};

/// Table 4's parts: (title, parameters in `table.csv` or `[stage.guess]`, in order).
const PARTS: [(&str, &[&str]); 3] = [
    (
        "CM (compliant mechanism)",
        &["k_qo1", "k_qo2", "mass", "alpha", "c_qo1", "c_qo2"],
    ),
    (
        "PZT set",
        &[
            "k_pea1", "k_pea2", "k_in1", "k_in2", "m_in1", "m_in2", "c_in1", "c_in2", "k_c",
        ],
    ),
    ("", &[]),
];

/// One known parameter of [`StageParams`].
type Known = fn(&StageParams) -> f64;

/// The parameters that `table.csv` does not list (known, not estimated): (name, unit,
/// quantity, value).
const KNOWN: [(&str, &str, &str, Known); 4] = [
    ("mass", "kg", "moving mass M", |p| p.mass),
    ("alpha", "–", "amplification ratio α (Eq. 27)", |p| {
        p.alpha
    }),
    ("m_in1", "kg", "input plate mass M_in1", |p| p.m_in1),
    ("m_in2", "kg", "input plate mass M_in2", |p| p.m_in2),
];

/// The values of one gain of `[controller]`.
type Gain = fn(&Controller) -> Vec<f64>;

/// The gains of Table 4 and of the retuned loop: (symbol, values, index, Table 4's value or
/// "–", role).
const GAINS: [(&str, Gain, usize, &str, &str); 11] = [
    (
        "k_e1",
        |c| c.observer_gain.to_vec(),
        0,
        "1e5",
        "state estimator (K-filter, Eq. 37–38)",
    ),
    (
        "k_e2",
        |c| c.observer_gain.to_vec(),
        1,
        "1e5",
        "state estimator (K-filter, Eq. 37–38)",
    ),
    (
        "k_ε1",
        |c| c.error_gain.to_vec(),
        0,
        "2e4",
        "error gain, s = ε̇ + k_ε ε",
    ),
    (
        "k_ε2",
        |c| c.error_gain.to_vec(),
        1,
        "1.5e4",
        "error gain, s = ε̇ + k_ε ε",
    ),
    (
        "k_1",
        |c| c.feedback_gain.to_vec(),
        0,
        "1.2e4",
        "feedback gain (A34)",
    ),
    (
        "k_2",
        |c| c.feedback_gain.to_vec(),
        1,
        "1.2e3",
        "feedback gain (A34)",
    ),
    (
        "k_η1",
        |c| c.eta_gain.to_vec(),
        0,
        "–",
        "linear feedback gain (A21) [1/s]",
    ),
    (
        "k_η2",
        |c| c.eta_gain.to_vec(),
        1,
        "–",
        "linear feedback gain (A21) [1/s]",
    ),
    (
        "κ_d",
        |c| vec![c.disturbance_gain],
        0,
        "–",
        "observer bandwidth of Δ_η [1/s]",
    ),
    (
        "k_p, k_i, k_d",
        |c| c.pid.to_vec(),
        0,
        "–",
        "PID + feedforward baseline",
    ),
    (
        "φ_s, φ_a",
        |c| c.boundary_layer.to_vec(),
        0,
        "–",
        "boundary layers of the robust terms",
    ),
];

/// Section "stage".
pub(super) fn stage(b: &mut Builder) {
    b.note(
        "Table 4 for this run: the initial guess, the online least-squares estimate \
         (Section 4.2, Eq. 54–56) and the simulated truth; the masses and α are known (the \
         paper weighs the masses and takes α from Eq. 27, we take both from the design); \
         then the estimator and controller gains this run used beside the paper's.",
    );
    parameters(b);
    if b.exists(files::CONVERGENCE_SVG) {
        b.img(files::CONVERGENCE_SVG, "Stage estimates over the record");
    }
    twin(b);
    gains(b);
}

/// The identification on the twin: what its frequency response gives the controller's
/// model, against the same quantities from the twin's exact modes.
fn twin(b: &mut Builder) {
    let Some(table) = b.load::<Rows<ParameterRow>>(files::TWIN_TABLE) else {
        return;
    };
    b.h3("On the twin: the response fit that sets the backstepping up");
    b.note(
        "The twin of the design is no lumped model, so its stage is identified by its \
         frequency response (multisine sampled at 5× the controller's rate, static gain and the \
         output modes below the controller's Nyquist frequency). Design: the reduced model \
         (the prior for what the response cannot show); truth: the same chain on the twin's \
         exact modes. `track` on the twin sets the backstepping up from this fit \
         (docs/DECISIONS.md, \"Stage identification that closes the loop\").",
    );
    let num = |v: Option<f64>| v.map_or_else(|| "–".into(), fmt_num);
    let rows: Vec<Vec<String>> = table
        .0
        .iter()
        .map(|r| {
            vec![
                r.parameter.clone(),
                r.unit.clone(),
                num(Some(r.guess)),
                num(Some(r.estimate)),
                num(r.truth),
                num(r.error_pct),
            ]
        })
        .collect();
    b.table(
        &[
            "quantity".into(),
            "unit".into(),
            "design".into(),
            "estimate".into(),
            "truth (exact modes)".into(),
            "error [%]".into(),
        ],
        &rows,
    );
    if b.exists(files::RESPONSE_SVG) {
        b.img(
            files::RESPONSE_SVG,
            "Measured frequency response of the twin",
        );
    }
}

/// The parameter part of Table 4.
fn parameters(b: &mut Builder) {
    let Some(table) = b.load::<Rows<ParameterRow>>(files::TABLE) else {
        b.missing(files::TABLE);
        return;
    };
    let stage = match b.exists(layout::PLANT) {
        true => b.load::<Scenario>(layout::PLANT),
        false => b.scenario(),
    }
    .map(|s| s.stage.clone());
    let rows = &table.0;
    let mut html = String::from(
        "<table><thead><tr><th class=\"l\">quantity</th><th>unit</th><th>guess</th>\
         <th>estimate</th><th>truth (simulated)</th><th>error [%]</th></tr></thead><tbody>\n",
    );
    let cell = |v: Option<f64>| match v {
        Some(v) if v.is_finite() => fmt_num(v),
        _ => "–".to_string(),
    };
    let mut listed = vec![false; rows.len()];
    for (title, keys) in PARTS {
        let rest: Vec<&str> = rows
            .iter()
            .enumerate()
            .filter(|(i, _)| !listed[*i])
            .map(|(_, r)| r.parameter.as_str())
            .collect();
        let keys: Vec<&str> = if title.is_empty() {
            rest
        } else {
            keys.to_vec()
        };
        if keys.is_empty() {
            continue;
        }
        let title = if title.is_empty() { "other" } else { title };
        html.push_str(&format!(
            "<tr class=\"part\"><td colspan=\"6\">{}</td></tr>\n",
            esc(title)
        ));
        for key in keys {
            if let Some(i) = rows.iter().position(|r| r.parameter == key) {
                listed[i] = true;
                let r = &rows[i];
                html.push_str(&format!(
                    "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
                     <td>{}</td></tr>\n",
                    esc(key),
                    esc(&r.unit),
                    cell(Some(r.guess)),
                    cell(Some(r.estimate)),
                    cell(r.truth),
                    cell(r.error_pct)
                ));
            } else if let Some((_, unit, what, get)) = KNOWN.iter().find(|k| k.0 == key) {
                let value =
                    |p: Option<&StageParams>| p.map_or_else(|| "–".into(), |p| fmt_num(get(p)));
                html.push_str(&format!(
                    "<tr><td class=\"l\">{}</td><td>{unit}</td><td>{}</td><td>— (known)</td>\
                     <td>{}</td><td>–</td></tr>\n",
                    esc(what),
                    value(stage.as_ref().map(|s| &s.guess)),
                    value(stage.as_ref().map(|s| &s.truth))
                ));
            }
        }
    }
    html.push_str("</tbody></table>\n");
    b.html.push_str(&html);
}

/// The gain part of Table 4: the run's `[controller]` values beside the paper's.
fn gains(b: &mut Builder) {
    let Some(scenario) = b.scenario() else {
        b.missing(layout::SCENARIO);
        return;
    };
    let controller = &scenario.controller;
    let rows: Vec<Vec<String>> = GAINS
        .iter()
        .filter_map(|(symbol, values, index, paper, role)| {
            let numbers = values(controller);
            // Several-valued gains (PID, boundary layers) are shown whole on one row.
            let used = if symbol.contains(',') {
                numbers
                    .iter()
                    .map(|v| fmt_num(*v))
                    .collect::<Vec<_>>()
                    .join(", ")
            } else {
                fmt_num(*numbers.get(*index)?)
            };
            Some(vec![
                symbol.to_string(),
                role.to_string(),
                used,
                paper.to_string(),
            ])
        })
        .collect();
    b.h3("Estimator and controller gains (Table 4, Appendices C–D)");
    b.note(
        "The gains of this run (scenario [controller]) beside Table 4's. Table 4's error and \
         feedback gains make the sampled loop at 10 kHz unstable, so the defaults are retuned \
         for it (docs/DECISIONS.md); gains without a Table 4 value are ours.",
    );
    b.table(
        &[
            "symbol".into(),
            "role".into(),
            "this run".into(),
            "Table 4".into(),
        ],
        &rows,
    );
}
