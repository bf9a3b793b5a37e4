//! Stage section: Table 4 of the paper for this run: the stage parameters (guess, online
//! least-squares estimate, simulated truth), the known masses and α, and the state-estimator
//! and controller gains the run used beside the paper's values.

use super::{Builder, esc, fmt_num, toml_num};
use crate::layout::{self, stage as files};
use crate::read_csv_columns as csv_cols;

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

/// Units of the parameters that `table.csv` does not list (known, not estimated).
const KNOWN: [(&str, &str, &str); 4] = [
    ("mass", "kg", "moving mass M"),
    ("alpha", "–", "amplification ratio α (Eq. 27)"),
    ("m_in1", "kg", "input plate mass M_in1"),
    ("m_in2", "kg", "input plate mass M_in2"),
];

/// The gains of Table 4 and of the retuned loop: (symbol, key in `[controller]`, index,
/// Table 4's value or "–", role).
const GAINS: [(&str, &str, usize, &str, &str); 11] = [
    (
        "k_e1",
        "observer_gain",
        0,
        "1e5",
        "state estimator (K-filter, Eq. 37–38)",
    ),
    (
        "k_e2",
        "observer_gain",
        1,
        "1e5",
        "state estimator (K-filter, Eq. 37–38)",
    ),
    ("k_ε1", "error_gain", 0, "2e4", "error gain, s = ε̇ + k_ε ε"),
    (
        "k_ε2",
        "error_gain",
        1,
        "1.5e4",
        "error gain, s = ε̇ + k_ε ε",
    ),
    ("k_1", "feedback_gain", 0, "1.2e4", "feedback gain (A34)"),
    ("k_2", "feedback_gain", 1, "1.2e3", "feedback gain (A34)"),
    (
        "k_η1",
        "eta_gain",
        0,
        "–",
        "linear feedback gain (A21) [1/s]",
    ),
    (
        "k_η2",
        "eta_gain",
        1,
        "–",
        "linear feedback gain (A21) [1/s]",
    ),
    (
        "κ_d",
        "disturbance_gain",
        0,
        "–",
        "observer bandwidth of Δ_η [1/s]",
    ),
    ("k_p, k_i, k_d", "pid", 0, "–", "PID + feedforward baseline"),
    (
        "φ_s, φ_a",
        "boundary_layer",
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
    let Some(text) = b.text(files::TWIN_TABLE) else {
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
    let rows: Vec<Vec<String>> = text
        .lines()
        .skip(1)
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            let num = |i: usize| {
                c.get(i)
                    .and_then(|v| v.parse::<f64>().ok())
                    .map(fmt_num)
                    .unwrap_or_else(|| "–".into())
            };
            vec![
                c.first().unwrap_or(&"").to_string(),
                c.get(1).unwrap_or(&"").to_string(),
                num(2),
                num(3),
                num(4),
                num(5),
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
    let Some(text) = b.text(files::TABLE) else {
        b.not_run(&format!("{} missing", files::TABLE));
        return;
    };
    let stage = b
        .toml(layout::PLANT)
        .or_else(|| b.toml(layout::SCENARIO))
        .and_then(|t| t.get("stage")?.as_table().cloned());
    let names: Vec<String> = text
        .lines()
        .skip(1)
        .filter_map(|l| Some(l.split(',').next()?.to_string()))
        .collect();
    let units: Vec<String> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap_or("").to_string())
        .collect();
    let c = csv_cols(&text, &["guess", "estimate", "truth", "error_pct"]);
    let mut html = String::from(
        "<table><thead><tr><th class=\"l\">quantity</th><th>unit</th><th>guess</th>\
         <th>estimate</th><th>truth (simulated)</th><th>error [%]</th></tr></thead><tbody>\n",
    );
    let cell = |v: f64| {
        if v.is_finite() {
            fmt_num(v)
        } else {
            "–".to_string()
        }
    };
    let mut listed = vec![false; names.len()];
    for (title, keys) in PARTS {
        let rest: Vec<&str> = names
            .iter()
            .enumerate()
            .filter(|(i, _)| !listed[*i])
            .map(|(_, n)| n.as_str())
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
            if let Some(i) = names.iter().position(|n| n == key)
                && let Some(c) = &c
            {
                listed[i] = true;
                html.push_str(&format!(
                    "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>\
                     <td>{}</td></tr>\n",
                    esc(key),
                    esc(&units[i]),
                    cell(c[0][i]),
                    cell(c[1][i]),
                    cell(c[2][i]),
                    cell(c[3][i])
                ));
            } else if let Some((_, unit, what)) = KNOWN.iter().find(|k| k.0 == key) {
                let get = |part: &str| {
                    stage
                        .as_ref()
                        .and_then(|s| toml_num(s, &[part, key]))
                        .map(fmt_num)
                        .unwrap_or_else(|| "–".into())
                };
                html.push_str(&format!(
                    "<tr><td class=\"l\">{}</td><td>{unit}</td><td>{}</td><td>— (known)</td>\
                     <td>{}</td><td>–</td></tr>\n",
                    esc(what),
                    get("guess"),
                    get("truth")
                ));
            }
        }
    }
    html.push_str("</tbody></table>\n");
    b.html.push_str(&html);
}

/// The gain part of Table 4: the run's `[controller]` values beside the paper's.
fn gains(b: &mut Builder) {
    let Some(controller) = b
        .toml(layout::SCENARIO)
        .and_then(|t| t.get("controller")?.as_table().cloned())
    else {
        b.not_run(&format!("{} has no [controller]", layout::SCENARIO));
        return;
    };
    let rows: Vec<Vec<String>> = GAINS
        .iter()
        .filter_map(|(symbol, key, index, paper, role)| {
            let value = controller.get(*key)?;
            let numbers: Vec<f64> = match value {
                toml::Value::Array(a) => a
                    .iter()
                    .filter_map(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
                    .collect(),
                v => vec![v.as_float().or_else(|| v.as_integer().map(|i| i as f64))?],
            };
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
