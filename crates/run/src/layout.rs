//! The run-folder layout: every file of a run folder, named in one place.
//!
//! A run folder (`runs/<scenario name>/` unless the user picks another) holds the scenario
//! exactly as used and one sub-folder per stage. The pipeline writes through these names and
//! the HTML report reads through them, so the two cannot drift apart. Paths are relative to
//! the run folder and use `/` (they are joined with [`crate::RunDir::path`]). No other crate
//! spells a file name of a run folder (CI checks it with `scripts/run-file-names.py`).
//!
//! ```text
//! scenario.toml  plant.toml  run_state.json  report.html  run.lock (while a command runs)
//!             tilted/ (a nested run, Figure 4b)
//! design/     design.json density.{csv,png} design.vtu cases.csv history.{csv,json}
//!             workspace_{initial,final}.csv workspace_iterNNNNN.csv workspace{,_history}.svg
//!             summary.json checkpoint.bin
//! analyze/<variant>/   cases.csv deformed.vtu summary.json workspace.svg
//! export/     outline.{dxf,svg,stl} verification.{json,txt} body_fitted.vtu
//! reduce/     params.toml summary.{toml,json} modes.{vtu,csv} mode_shapes.csv mode<K>.png
//!             validity{,_scale}.{csv,svg}
//! twin/       modes.csv bode.csv bode_{magnitude,phase}.svg validity.json
//! front/      front.{json,csv,svg} d<K>/{design.json, outline.svg, modes.vtu, mode<M>.png}
//! pea/        pea<N>.csv pea<N>_loop.svg
//! identify/pea<N>/   estimates.toml convergence.{csv,svg} loop.{csv,svg} compensation.{csv,svg}
//! identify/stage/    params.toml table.csv convergence.{csv,svg} record.csv
//! track/[<variant>/] <trajectory>_<controller>.csv <trajectory>_<controller>_error.svg
//!                    margins.csv montecarlo.csv scan_frequency.csv scan_frequency.svg
//!                    <trajectory>_2d.svg metrics.csv controllers/<controller>.{json,c,h}
//! ```

use std::path::{Component, Path, PathBuf};

/// The scenario exactly as the run used it.
pub const SCENARIO: &str = "scenario.toml";
/// The simulated stage of the run: the scenario with `stage.truth` replaced by the reduced
/// model of the run's design (written once `reduce` has run).
pub const PLANT: &str = "plant.toml";
/// The resume state of `flexstage run` (finished stages).
pub const RUN_STATE: &str = "run_state.json";
/// The self-contained HTML report.
pub const REPORT: &str = "report.html";
/// A run folder nested in this one that holds the tilted-output design of Figure 4 (b): its
/// own `scenario.toml` (with `output.tilt_deg` ≠ 0) and `design/`, e.g. made by
/// `flexstage design tilted.toml --out runs/paper/tilted`. The report shows it beside the
/// run's own design.
pub const TILTED: &str = "tilted";
/// The lock of the run folder: exists while a flexstage command works in the folder, and
/// names its process (PID, host, start time, command).
pub const LOCK: &str = "run.lock";

/// `design/`: the topology optimization (paper Section 2.2, Algorithm 1).
pub mod design {
    /// The stage folder.
    pub const DIR: &str = "design";
    /// The finished design (`flexstage_topopt::DesignFile`).
    pub const DESIGN: &str = "design/design.json";
    /// A finished design refused by the final checks (e.g. a workspace running the wrong
    /// way), kept for inspection: no later stage reads it.
    pub const REJECTED: &str = "design/rejected.json";
    /// The optimizer checkpoint of an unfinished design.
    pub const CHECKPOINT: &str = "design/checkpoint.bin";
    /// Densities as CSV (`i,j,x,y,rho`).
    pub const DENSITY_CSV: &str = "design/density.csv";
    /// Densities as a grey-scale PNG (Figure 4).
    pub const DENSITY_PNG: &str = "design/density.png";
    /// The deformed design at the compressive corner, for ParaView.
    pub const VTU: &str = "design/design.vtu";
    /// Per-load-case table of the final analysis.
    pub const CASES: &str = "design/cases.csv";
    /// Iteration history as CSV.
    pub const HISTORY_CSV: &str = "design/history.csv";
    /// Iteration history as JSON.
    pub const HISTORY_JSON: &str = "design/history.json";
    /// Output polygon of the initial design (final nonlinear analysis).
    pub const WORKSPACE_INITIAL: &str = "design/workspace_initial.csv";
    /// Output polygon of the final design (final nonlinear analysis).
    pub const WORKSPACE_FINAL: &str = "design/workspace_final.csv";
    /// Figure: initial against final workspace polygon.
    pub const WORKSPACE_SVG: &str = "design/workspace.svg";
    /// Figure: polygon snapshots during the optimization.
    pub const WORKSPACE_HISTORY_SVG: &str = "design/workspace_history.svg";
    /// Headline numbers (JSON).
    pub const SUMMARY: &str = "design/summary.json";

    const SNAPSHOT_PREFIX: &str = "workspace_iter";

    /// The polygon snapshot of one iteration.
    pub fn snapshot(iteration: usize) -> String {
        format!("{DIR}/workspace_iter{iteration:05}.csv")
    }

    /// The iteration of a snapshot file name (the name only, e.g. `workspace_iter00025.csv`).
    pub fn snapshot_iteration(file_name: &str) -> Option<usize> {
        file_name
            .strip_prefix(SNAPSHOT_PREFIX)?
            .strip_suffix(".csv")?
            .parse()
            .ok()
    }
}

/// `front/`: the workspace–first-resonance front of the scenario (`flexstage front`).
pub mod front {
    /// The stage folder.
    pub const DIR: &str = "front";
    /// Every design with its checks ([`crate::files::front::FrontFile`]).
    pub const JSON: &str = "front/front.json";
    /// One row per design.
    pub const CSV: &str = "front/front.csv";
    /// Figure: workspace against first resonance, the tracking error at the scan speed.
    pub const SVG: &str = "front/front.svg";

    /// The design file of design `k` (a design source for the other commands).
    pub fn design(k: usize) -> String {
        format!("{DIR}/d{k}/design.json")
    }

    /// The exported outline of design `k` (SVG, millimetres).
    pub fn outline(k: usize) -> String {
        format!("{DIR}/d{k}/outline.svg")
    }

    /// The stage's mode shapes of design `k` (VTU).
    pub fn modes(k: usize) -> String {
        format!("{DIR}/d{k}/modes.vtu")
    }

    /// Mode shapes of each design drawn as pictures.
    pub const MODE_PNGS: usize = 2;

    /// The picture of mode `m` (from 1) of design `k`.
    pub fn mode_png(k: usize, m: usize) -> String {
        format!("{DIR}/d{k}/mode{m}.png")
    }
}

/// `export/`: the manufacturing outline (Section 4.1).
pub mod export {
    /// The stage folder.
    pub const DIR: &str = "export";
    /// R2000 DXF outline.
    pub const DXF: &str = "export/outline.dxf";
    /// SVG outline.
    pub const SVG: &str = "export/outline.svg";
    /// Binary STL, extruded by the thickness.
    pub const STL: &str = "export/outline.stl";
    /// The body-fitted verification of the outline, every value in SI units.
    pub const VERIFICATION_JSON: &str = "export/verification.json";
    /// The verification's summary lines (ending with the verdict).
    pub const VERIFICATION_TXT: &str = "export/verification.txt";
    /// The body-fitted mesh with the worst corner's displacement and stress, for ParaView.
    pub const BODY_FITTED_VTU: &str = "export/body_fitted.vtu";
}

/// `reduce/`: the reduced model (Section 3.2.1).
pub mod reduce {
    /// The stage folder.
    pub const DIR: &str = "reduce";
    /// The stage parameters of the reduced model (a `StageParams` TOML).
    pub const PARAMS: &str = "reduce/params.toml";
    /// Summary as TOML.
    pub const SUMMARY_TOML: &str = "reduce/summary.toml";
    /// Summary as JSON.
    pub const SUMMARY_JSON: &str = "reduce/summary.json";
    /// Mode shapes for ParaView.
    pub const MODES_VTU: &str = "reduce/modes.vtu";
    /// Natural frequencies.
    pub const MODES_CSV: &str = "reduce/modes.csv";
    /// Mode shapes as data: node coordinates `x_m`, `y_m`, then `ux_<k>`, `uy_<k>` of each
    /// mode k (from 1), mass-normalized (φᵀMφ = 1).
    pub const MODE_SHAPES_CSV: &str = "reduce/mode_shapes.csv";
    /// The most mode shapes drawn as pictures ([`mode_png`]).
    pub const MODE_PNGS: usize = 4;

    /// Mode shape `k` (from 1) drawn deformed, as PNG.
    pub fn mode_png(k: usize) -> String {
        format!("{DIR}/mode{k}.png")
    }
    /// Validity map samples.
    pub const VALIDITY_CSV: &str = "reduce/validity.csv";
    /// Validity map per stroke scale.
    pub const VALIDITY_SCALE_CSV: &str = "reduce/validity_scale.csv";
    /// Figure: workspace, nonlinear FE against the reduced model.
    pub const VALIDITY_SVG: &str = "reduce/validity.svg";
    /// Figure: model error against stroke.
    pub const VALIDITY_SCALE_SVG: &str = "reduce/validity_scale.svg";
}

/// `twin/`: the digital twin of the designed stage (its modes, its frequency response beside
/// the lumped model, its validity against the full nonlinear transient).
pub mod twin {
    /// The stage folder.
    pub const DIR: &str = "twin";
    /// The twin's modes: mode, frequency \[Hz\], FE frequency \[Hz\], relative difference.
    pub const MODES: &str = "twin/modes.csv";
    /// Frequency \[Hz\], then magnitude \[dB\] and phase \[deg\] of each input→output pair
    /// (x_nom_j → q_i) of the twin and of the lumped model.
    pub const BODE: &str = "twin/bode.csv";
    /// Figure: Bode magnitude, twin beside the lumped model, both axes.
    pub const BODE_MAGNITUDE_SVG: &str = "twin/bode_magnitude.svg";
    /// Figure: Bode phase, twin beside the lumped model, both axes.
    pub const BODE_PHASE_SVG: &str = "twin/bode_phase.svg";
    /// Step and sine errors against the full transient (% of range), mode errors, the
    /// twin's order and modes, build seconds (JSON).
    pub const VALIDITY: &str = "twin/validity.json";
}

/// `pea/`: simulated PEA records.
pub mod pea {
    /// The stage folder.
    pub const DIR: &str = "pea";

    /// The simulated record of PEA `n` (columns t, U, x).
    pub fn record(n: u8) -> String {
        format!("{DIR}/pea{n}.csv")
    }

    /// Figure: the simulated record as x(U).
    pub fn loop_svg(n: u8) -> String {
        format!("{DIR}/pea{n}_loop.svg")
    }
}

/// `identify/pea<N>/`: the Bouc–Wen identification of PEA `N` (Appendix B).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PeaIdentification {
    /// The PEA (1 or 2).
    pub pea: u8,
}

impl PeaIdentification {
    /// The folder.
    pub fn dir(self) -> String {
        format!("identify/pea{}", self.pea)
    }
    fn file(self, name: &str) -> String {
        format!("{}/{name}", self.dir())
    }
    /// The estimates (TOML, `[recommended_params]` among others).
    pub fn estimates(self) -> String {
        self.file("estimates.toml")
    }
    /// Convergence history (CSV).
    pub fn convergence_csv(self) -> String {
        self.file("convergence.csv")
    }
    /// Figure A2: convergence.
    pub fn convergence_svg(self) -> String {
        self.file("convergence.svg")
    }
    /// Record against the identified model (CSV).
    pub fn loop_csv(self) -> String {
        self.file("loop.csv")
    }
    /// Figure: record against the identified model.
    pub fn loop_svg(self) -> String {
        self.file("loop.svg")
    }
    /// Hysteresis without and with inverse compensation (CSV).
    pub fn compensation_csv(self) -> String {
        self.file("compensation.csv")
    }
    /// Figure: hysteresis without and with inverse compensation.
    pub fn compensation_svg(self) -> String {
        self.file("compensation.svg")
    }
}

/// `identify/stage/`: the stage identification (Section 4.2, Table 4).
pub mod stage {
    /// The stage folder.
    pub const DIR: &str = "identify/stage";
    /// The identified stage parameters (a `StageParams` TOML).
    pub const PARAMS: &str = "identify/stage/params.toml";
    /// Guess / estimate / truth table (Table 4).
    pub const TABLE: &str = "identify/stage/table.csv";
    /// Convergence history (CSV).
    pub const CONVERGENCE_CSV: &str = "identify/stage/convergence.csv";
    /// Figure: convergence.
    pub const CONVERGENCE_SVG: &str = "identify/stage/convergence.svg";
    /// The simulated excitation record (on the lumped model).
    pub const RECORD: &str = "identify/stage/record.csv";
    /// The identification on the twin (`--plant twin`, and `run` once the twin is built).
    pub const TWIN_DIR: &str = "identify/stage/twin";
    /// Its parameter set (the response fit on the design's reduced model).
    pub const TWIN_PARAMS: &str = "identify/stage/twin/params.toml";
    /// Its identified quantities, guess / estimate / truth.
    pub const TWIN_TABLE: &str = "identify/stage/twin/table.csv";
    /// The measured frequency response per line.
    pub const RESPONSE_CSV: &str = "identify/stage/twin/response.csv";
    /// The identified response fit, the backstepping's model of `track` on the twin.
    pub const RESPONSE_FIT: &str = "identify/stage/twin/response_fit.toml";
    /// Figure: the measured response against the twin's exact one.
    pub const RESPONSE_SVG: &str = "identify/stage/twin/response.svg";
}

/// A folder of tracking results (Section 4, Figures 9–11): `track/` for the default
/// conditions, `track/<variant>/` for others (e.g. `track/compensation-off/`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Tracking {
    dir: String,
}

impl Tracking {
    /// The folder of the default conditions.
    pub const DIR: &str = "track";

    /// The default folder, `track/`.
    pub fn main() -> Tracking {
        Tracking {
            dir: Self::DIR.to_string(),
        }
    }

    /// `track/<variant>/`, or `track/` for an empty variant. The variant must be a plain
    /// folder name (letters, digits, `-`, `_`, `.`).
    pub fn variant(variant: &str) -> Tracking {
        debug_assert!(is_plain_name(variant) || variant.is_empty(), "{variant}");
        if variant.is_empty() {
            Self::main()
        } else {
            Tracking {
                dir: format!("{}/{variant}", Self::DIR),
            }
        }
    }

    /// The folder.
    pub fn dir(&self) -> &str {
        &self.dir
    }
    /// Time series of one trajectory and controller.
    pub fn record(&self, trajectory: &str, controller: &str) -> String {
        format!("{}/{trajectory}_{controller}.csv", self.dir)
    }
    /// Figures 9–10: tracking error of one trajectory and controller.
    pub fn error_svg(&self, trajectory: &str, controller: &str) -> String {
        format!("{}/{trajectory}_{controller}_error.svg", self.dir)
    }
    /// Figure 11: 2D paths of every controller on one trajectory.
    pub fn paths_svg(&self, trajectory: &str) -> String {
        format!("{}/{trajectory}_2d.svg", self.dir)
    }
    /// The controllers exported for a real-time target.
    pub fn controllers_dir(&self) -> String {
        format!("{}/controllers", self.dir)
    }
    /// One exported controller's coefficients (JSON).
    pub fn controller_json(&self, controller: &str) -> String {
        format!("{}/controllers/{controller}.json", self.dir)
    }
    /// One exported controller's C99 source.
    pub fn controller_c(&self, controller: &str) -> String {
        format!("{}/controllers/{controller}.c", self.dir)
    }
    /// One exported controller's C99 header.
    pub fn controller_h(&self, controller: &str) -> String {
        format!("{}/controllers/{controller}.h", self.dir)
    }
    /// The metrics table, one row per trajectory and controller.
    pub fn metrics(&self) -> String {
        format!("{}/metrics.csv", self.dir)
    }
    /// Loop-at-a-time gain, phase and delay margins of every controller on the twin
    /// (`flexstage-assess`).
    pub fn margins(&self) -> String {
        format!("{}/margins.csv", self.dir)
    }
    /// Monte-Carlo robustness: one row per perturbed plant and controller.
    pub fn montecarlo(&self) -> String {
        format!("{}/montecarlo.csv", self.dir)
    }
    /// The twin's loop as measured in its rig at the controller's sample time, the response
    /// the controllers are designed from (`files::measured`).
    pub fn measured_response(&self) -> String {
        format!("{}/measured_response.csv", self.dir)
    }
    /// The twin's output between the samples as a fast ADC on the sensor measured it during
    /// the same experiments, the lifted response the linear controllers' feed-forward is
    /// fitted to (`files::lifted`).
    pub fn lifted_response(&self) -> String {
        format!("{}/lifted_response.csv", self.dir)
    }
    /// RMS error against scan frequency (Lissajous 3:1), data.
    pub fn scan_frequency_csv(&self) -> String {
        format!("{}/scan_frequency.csv", self.dir)
    }
    /// RMS error against scan frequency, figure.
    pub fn scan_frequency_svg(&self) -> String {
        format!("{}/scan_frequency.svg", self.dir)
    }
    /// The trajectory of a [`Tracking::paths_svg`] file name (the name only).
    pub fn paths_trajectory(file_name: &str) -> Option<&str> {
        file_name.strip_suffix("_2d.svg")
    }
}

/// A folder of nonlinear analyses: `analyze/<variant>/`, e.g. `analyze/workspace/` or
/// `analyze/inputs_30_-30/`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Analysis {
    dir: String,
}

impl Analysis {
    /// The parent folder of every analysis.
    pub const DIR: &str = "analyze";

    /// `analyze/<variant>/`; the variant must be a plain folder name.
    pub fn variant(variant: &str) -> Analysis {
        debug_assert!(is_plain_name(variant), "{variant}");
        Analysis {
            dir: format!("{}/{variant}", Self::DIR),
        }
    }
    /// The folder.
    pub fn dir(&self) -> &str {
        &self.dir
    }
    /// Per-load-case table.
    pub fn cases(&self) -> String {
        format!("{}/cases.csv", self.dir)
    }
    /// The deformed mesh, for ParaView.
    pub fn vtu(&self) -> String {
        format!("{}/deformed.vtu", self.dir)
    }
    /// Headline numbers (JSON).
    pub fn summary(&self) -> String {
        format!("{}/summary.json", self.dir)
    }
    /// Figure: the output workspace polygon.
    pub fn workspace_svg(&self) -> String {
        format!("{}/workspace.svg", self.dir)
    }
}

/// A name usable as one folder or file name component: non-empty, at most 100 characters of
/// letters, digits, `-`, `_` and `.`, not `.` or `..`.
pub fn is_plain_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 100
        && name != "."
        && name != ".."
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
}

/// The run folder that `path` belongs to, when `path` is one of the layout's files that hold
/// a result another stage reads (`reduce/params.toml`, `identify/stage/params.toml`,
/// `design/design.json`) and its folder holds a `scenario.toml`.
pub fn run_of(path: &Path) -> Option<PathBuf> {
    for rel in [reduce::PARAMS, stage::PARAMS, design::DESIGN] {
        let depth = rel.split('/').count();
        let tail: Vec<Component> = path.components().rev().take(depth).collect();
        let rel_rev: Vec<&str> = rel.split('/').rev().collect();
        let matches = tail.len() == depth
            && tail
                .iter()
                .zip(&rel_rev)
                .all(|(c, r)| c.as_os_str() == std::ffi::OsStr::new(r));
        if matches {
            let mut root = path.to_path_buf();
            for _ in 0..depth {
                root.pop();
            }
            if root.as_os_str().is_empty() {
                root = PathBuf::from(".");
            }
            if root.join(SCENARIO).is_file() {
                return Some(root);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameterized_names_round_trip() {
        // Goal: the names the writers use are the names the readers parse back.
        assert_eq!(design::snapshot(25), "design/workspace_iter00025.csv");
        assert_eq!(
            design::snapshot_iteration("workspace_iter00025.csv"),
            Some(25)
        );
        assert_eq!(design::snapshot_iteration("workspace_final.csv"), None);
        let t = Tracking::variant("compensation-off");
        assert_eq!(t.dir(), "track/compensation-off");
        assert_eq!(
            t.paths_svg("circle"),
            "track/compensation-off/circle_2d.svg"
        );
        assert_eq!(Tracking::paths_trajectory("circle_2d.svg"), Some("circle"));
        assert_eq!(Tracking::variant(""), Tracking::main());
        assert_eq!(
            PeaIdentification { pea: 2 }.estimates(),
            "identify/pea2/estimates.toml"
        );
        assert_eq!(
            Analysis::variant("inputs_30_-30").vtu(),
            "analyze/inputs_30_-30/deformed.vtu"
        );
    }

    #[test]
    fn plain_names_exclude_paths() {
        for bad in ["", ".", "..", "a/b", "a b", "../x"] {
            assert!(!is_plain_name(bad), "{bad:?}");
        }
        for good in [
            "workspace",
            "inputs_30_-30",
            "uniform_0.5",
            "compensation-off",
        ] {
            assert!(is_plain_name(good), "{good:?}");
        }
    }

    #[test]
    fn run_of_finds_the_run_folder_of_a_result_file() {
        let dir = std::env::temp_dir().join(format!("flexstage-layout-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("reduce")).unwrap();
        assert_eq!(run_of(&dir.join(reduce::PARAMS)), None, "no scenario.toml");
        std::fs::write(dir.join(SCENARIO), "").unwrap();
        assert_eq!(run_of(&dir.join(reduce::PARAMS)), Some(dir.clone()));
        assert_eq!(run_of(&dir.join(stage::PARAMS)), Some(dir.clone()));
        assert_eq!(run_of(&dir.join("elsewhere/params.toml")), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
