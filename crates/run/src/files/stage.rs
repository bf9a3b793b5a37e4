//! The stage parameter files (`reduce/params.toml`, `identify/stage/params.toml`,
//! `identify/stage/twin/params.toml`), the Table 4 comparison (`table.csv`) and the twin's
//! response (`response.csv`, `response_fit.toml`).

use flexstage_scenario::StageParams;
use serde::{Deserialize, Serialize};

use crate::format::{Format, Row, check_version, from_toml, num};

/// The key of the identified cross-axis coupling stiffness k_c \[N/m\] in a parameter file.
pub const COUPLING_KEY: &str = "coupling";

/// A stage parameter file: comment lines, the optional cross-axis coupling k_c of Eq. (30),
/// and the parameters of Eq. 31–35 (a `StageParams` table). A user may write one by hand for
/// `flexstage track --params`, so it has no version; unknown keys are refused.
#[derive(Debug, Clone, PartialEq)]
pub struct StageParamsFile {
    /// Comment lines at the head (without `# `); not read back.
    pub header: Vec<String>,
    /// Whether each parameter gets a comment saying what it is and where it comes from (the
    /// reduced model's file); not read back.
    pub documented: bool,
    /// k_c \[N/m\]: the identified coupling; `None` for a file without one (0 for the model).
    pub coupling: Option<f64>,
    /// The parameters.
    pub params: StageParams,
}

/// What a parameter of [`StageParams`] is, for the comments of a documented file.
fn doc(name: &str) -> &'static str {
    match name {
        "k_qo1" => "horizontal output stiffness K_qo1 [N/m] (each of the two springs, Eq. 30/33)",
        "k_qo2" => "vertical output stiffness K_qo2 [N/m]",
        "mass" => "moving mass M [kg] = sum(rho) * material density * element volume",
        "alpha" => "amplification ratio alpha = (alpha21 - alpha22)/2, Eq. 27-29",
        "k_pea1" | "k_pea2" => "PEA stiffness [N/m] (scenario actuators.stiffness)",
        "k_in1" | "k_in2" => "input plate stiffness [N/m] (scenario stage.guess)",
        "m_in1" | "m_in2" => "input plate mass [kg] (scenario stage.guess)",
        "c_qo1" | "c_qo2" => "output damping [N s/m] (stage.damping_ratio)",
        "c_in1" | "c_in2" => "input plate damping [N s/m] (stage.damping_ratio)",
        _ => "",
    }
}

impl Format for StageParamsFile {
    fn encode(&self) -> Result<Vec<u8>, String> {
        let mut s = String::new();
        for h in &self.header {
            s.push_str("# ");
            s.push_str(h);
            s.push('\n');
        }
        if let Some(k) = self.coupling {
            s.push_str(&format!("{COUPLING_KEY} = {k:e}\n"));
        }
        let body = toml::to_string(&self.params).map_err(|e| e.to_string())?;
        for line in body.lines() {
            if let Some((name, _)) = line.split_once(" = ")
                && self.documented
                && !doc(name.trim()).is_empty()
            {
                s.push_str("# ");
                s.push_str(doc(name.trim()));
                s.push('\n');
            }
            s.push_str(line);
            s.push('\n');
        }
        Ok(s.into_bytes())
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let mut table: toml::Table =
            from_toml(bytes).map_err(|e| format!("not a stage parameter table: {e}"))?;
        let coupling = match table.remove(COUPLING_KEY) {
            None => None,
            Some(v) => match v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) {
                Some(k) if k.is_finite() => Some(k),
                _ => {
                    return Err(format!(
                        "{COUPLING_KEY} = {v} is not a finite stiffness [N/m] (the cross-axis \
                         coupling k_c of Eq. 30)"
                    ));
                }
            },
        };
        let params: StageParams = toml::Value::Table(table)
            .try_into()
            .map_err(|e| format!("not a stage parameter table: {e}"))?;
        params.validate("params").map_err(|e| e.to_string())?;
        Ok(StageParamsFile {
            header: Vec::new(),
            documented: false,
            coupling,
            params,
        })
    }
}

/// One row of `table.csv`: a parameter's guess (or design value), estimate and truth, and
/// the estimate's error \[%\] (4 decimals).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterRow {
    /// Parameter name (e.g. `k_qo1`, `k_c`).
    pub parameter: String,
    /// Unit.
    pub unit: String,
    /// The initial guess (0 written as `0`).
    #[serde(serialize_with = "exp_or_zero")]
    pub guess: f64,
    /// The estimate.
    #[serde(serialize_with = "num::exp")]
    pub estimate: f64,
    /// The truth, when the record is simulated.
    #[serde(serialize_with = "num::opt_exp")]
    pub truth: Option<f64>,
    /// (estimate − truth)/truth \[%\], 4 decimals.
    #[serde(serialize_with = "num::opt_fixed4")]
    pub error_pct: Option<f64>,
}

impl Row for ParameterRow {
    const HEADER: &'static [&'static str] = &[
        "parameter",
        "unit",
        "guess",
        "estimate",
        "truth",
        "error_pct",
    ];
    const EXACT: bool = false;
}

/// [`num::exp`], but 0 as `0` (the coupling row's guess).
fn exp_or_zero<S: serde::Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if *v == 0.0 {
        s.serialize_str("0")
    } else {
        num::exp(v, s)
    }
}

/// One line of the twin's measured frequency response (`response.csv`): q per unit x_nom of
/// the driving PEA.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResponseRow {
    /// Frequency \[Hz\].
    #[serde(serialize_with = "num::display")]
    pub f_hz: f64,
    /// The driving PEA (1 or 2).
    pub pea: usize,
    /// Re q_o1 / x_nom.
    #[serde(serialize_with = "num::exp")]
    pub h_q1_re: f64,
    /// Im q_o1 / x_nom.
    #[serde(serialize_with = "num::exp")]
    pub h_q1_im: f64,
    /// Re q_o2 / x_nom.
    #[serde(serialize_with = "num::exp")]
    pub h_q2_re: f64,
    /// Im q_o2 / x_nom.
    #[serde(serialize_with = "num::exp")]
    pub h_q2_im: f64,
}

impl Row for ResponseRow {
    const HEADER: &'static [&'static str] =
        &["f_hz", "pea", "h_q1_re", "h_q1_im", "h_q2_re", "h_q2_im"];
}

/// The format version of `response_fit.toml`.
pub const RESPONSE_FIT_VERSION: u32 = 1;

/// `identify/stage/twin/response_fit.toml`: the response fit identified on the twin, the
/// backstepping's model of `track` on the twin: the static gain x_nom → q (rows q_o1, q_o2;
/// columns PEA 1, 2), and per output axis the mode kept \[Hz\] (0: none below Nyquist) with
/// its damping ratio.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResponseFitFile {
    /// Format version ([`RESPONSE_FIT_VERSION`]).
    pub version: u32,
    /// Static gain x_nom → q.
    pub dc_gain: [[f64; 2]; 2],
    /// The mode kept per output axis \[Hz\], 0 for none.
    pub frequency: [f64; 2],
    /// Its damping ratio.
    pub damping: [f64; 2],
}

impl Format for ResponseFitFile {
    fn encode(&self) -> Result<Vec<u8>, String> {
        let (g, f, d) = (self.dc_gain, self.frequency, self.damping);
        Ok(format!(
            "# The response fit identified on the twin by `flexstage identify stage --plant twin`:\n\
             # static gain x_nom -> q (rows q_o1, q_o2; columns PEA 1, 2), and per output axis the\n\
             # mode kept for the controller's model [Hz] (0: none below Nyquist) and its damping\n\
             # ratio. `flexstage track` on the twin sets the backstepping up from it.\n\
             version = {}\n\
             dc_gain = [[{:e}, {:e}], [{:e}, {:e}]]\nfrequency = [{:e}, {:e}]\ndamping = [{:e}, {:e}]\n",
            self.version, g[0][0], g[0][1], g[1][0], g[1][1], f[0], f[1], d[0], d[1]
        )
        .into_bytes())
    }

    fn decode(bytes: &[u8]) -> Result<Self, String> {
        let f: ResponseFitFile =
            from_toml(bytes).map_err(|e| format!("not a response fit: {e}"))?;
        check_version(f.version, RESPONSE_FIT_VERSION)?;
        Ok(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parameter_file_keeps_its_coupling_and_refuses_unknown_keys() {
        // Goal: the identified k_c is a real field and reads back exactly; a file without it
        // has none; a bad value or an unknown key is refused naming it.
        let p = flexstage_scenario::Scenario::preset(flexstage_scenario::Preset::Quick)
            .stage
            .truth;
        let file = StageParamsFile {
            header: vec!["a header".into()],
            documented: true,
            coupling: Some(1234.5e-3),
            params: p.clone(),
        };
        let back = StageParamsFile::decode(&file.encode().unwrap()).unwrap();
        assert_eq!((back.params, back.coupling), (p.clone(), Some(1234.5e-3)));
        let body = toml::to_string(&p).unwrap();
        assert_eq!(
            StageParamsFile::decode(body.as_bytes()).unwrap().coupling,
            None
        );
        let e = StageParamsFile::decode(format!("{COUPLING_KEY} = \"x\"\n{body}").as_bytes())
            .unwrap_err();
        assert!(e.contains("coupling") && e.contains("\"x\""), "{e}");
        let e = StageParamsFile::decode(format!("typo = 1\n{body}").as_bytes()).unwrap_err();
        assert!(e.contains("typo"), "{e}");
        let e = StageParamsFile::decode(body.replace("mass = ", "mass = nan #").as_bytes())
            .unwrap_err();
        assert!(e.contains("mass"), "NaN is refused: {e}");
    }

    #[test]
    fn a_stored_value_is_the_value_a_reader_of_the_file_gets() {
        use crate::format::Rows;
        // Goal: a table with a stated precision (error_pct to 4 decimals) gives the same
        // numbers from this process's memory as from the file read by another process.
        let root = std::env::temp_dir().join(format!("flexstage-exact-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = crate::RunDir::create(&root).unwrap();
        let row = ParameterRow {
            parameter: "k_c".into(),
            unit: "N/m".into(),
            guess: 0.0,
            estimate: 3.3694794832e5,
            truth: Some(3.42e5),
            error_pct: Some(-1.495497_f64),
        };
        let stored = dir.store("t.csv", Rows(vec![row])).unwrap();
        let read = crate::RunDir::create(&root)
            .unwrap()
            .load::<Rows<ParameterRow>>("t.csv")
            .unwrap()
            .unwrap();
        assert_eq!(*stored, *read);
        assert_eq!(read.0[0].error_pct, Some(-1.4955));
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_response_fit_reads_back_exactly() {
        let fit = ResponseFitFile {
            version: RESPONSE_FIT_VERSION,
            dc_gain: [[0.4998, 0.4997], [2.02, -2.019]],
            frequency: [0.0, 3221.5],
            damping: [0.0, 0.0102],
        };
        assert_eq!(
            ResponseFitFile::decode(&fit.encode().unwrap()).unwrap(),
            fit
        );
    }
}
