//! How the stages' summaries read: `Display` gives the result lines (the CLI prints them on
//! standard output), [`Summary`] says what was written and what to warn about.
//!
//! One place formats every summary, so `flexstage run`, the single-stage commands and any
//! other caller of the pipeline show the same numbers with the same units.

pub mod verdict;

use flexstage_control::tuning::FeedForwardFit;
use std::fmt;
use std::path::Path;

use flexstage_report::fmt_num;

use crate::pea::PeaRecord;
use crate::{
    AnalyzeSummary, DesignSummary, ExportSummary, PeaIdSummary, PlantKind, ReduceSummary,
    RunSummary, StageIdSummary, StageSummary, TrackSummary, TwinSummary,
};

/// A stage's summary: its result lines (`Display`), the files and folders it wrote, and its
/// warnings.
pub trait Summary: fmt::Display {
    /// Where the results went, and whether they replaced earlier results.
    fn written(&self) -> (Vec<&Path>, bool);
    /// Warnings to show beside the result (none by default).
    fn warnings(&self) -> &[String] {
        &[]
    }
}

/// A point (in m) as "(x, y)" in µm with `digits` decimals.
fn um(p: [f64; 2], digits: usize) -> String {
    format!("({:.digits$}, {:.digits$})", p[0] * 1e6, p[1] * 1e6)
}

impl fmt::Display for DesignSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(k) = self.resumed_at {
            writeln!(f, "resumed at iteration {k}")?;
        }
        writeln!(
            f,
            "design {} after {} iterations in {:.1} s ({:.3} s/iteration)",
            verdict::stop_in_words(&format!("{:?}", self.stop)),
            self.iterations,
            self.seconds,
            self.seconds_per_iteration
        )?;
        for line in self.design.lines() {
            writeln!(f, "{line}")?;
        }
        let (grey, volume) = (self.grey_fraction, self.volume);
        writeln!(f, "grey fraction {grey:.3}, volume fraction {volume:.3}")
    }
}

impl Summary for DesignSummary {
    fn written(&self) -> (Vec<&Path>, bool) {
        (vec![&self.dir], false)
    }
    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}

impl fmt::Display for AnalyzeSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "analyzed {} load case(s) of {} in {:.2} s ({} Newton iterations)",
            self.cases.len(),
            self.design,
            self.seconds,
            self.newton_iterations
        )?;
        let Some((area, corners)) = self.workspace else {
            for (x, o) in &self.cases {
                writeln!(
                    f,
                    "  x_nom = {} µm  ->  u_out = {} µm",
                    um(*x, 2),
                    um(*o, 4)
                )?;
            }
            return Ok(());
        };
        writeln!(
            f,
            "  workspace polygon of {} samples: area {area:.6e} m² = {:.3} µm²",
            self.cases.len(),
            area * 1e12
        )?;
        for (name, o) in ["(+a,+a)", "(+a,-a)"].iter().zip(corners) {
            writeln!(f, "  corner {name}: u_out = {} µm", um(o, 4))?;
        }
        Ok(())
    }
}

impl Summary for AnalyzeSummary {
    fn written(&self) -> (Vec<&Path>, bool) {
        (vec![&self.dir], self.replaced)
    }
}

impl fmt::Display for ExportSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "outline of {}: {} closed loop(s), {:.2} mm² of material",
            self.design,
            self.loops,
            self.area * 1e6
        )?;
        if let Some(v) = &self.verification {
            for line in v.summary_lines() {
                writeln!(f, "{line}")?;
            }
        } else if let Some(e) = &self.verify_error {
            writeln!(
                f,
                "verdict: NOT safe: the outline could not be verified: {e}"
            )?;
        }
        Ok(())
    }
}

impl Summary for ExportSummary {
    fn written(&self) -> (Vec<&Path>, bool) {
        (
            self.files.iter().map(|p| p.as_path()).collect(),
            self.replaced,
        )
    }
}

impl fmt::Display for crate::front::FrontSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let front = &self.front;
        writeln!(
            f,
            "workspace–first-resonance front: {} designs in {:.0} s",
            front.designs.len(),
            front.seconds
        )?;
        for d in &front.designs {
            writeln!(f, "{}", crate::front::line(d, front.scan_hz))?;
        }
        match front.pick() {
            Some(d) => writeln!(
                f,
                "pick d{}: the largest workspace ({:.0} µm²) verified safe that tracks a {:.0} Hz \
                 scan within {} % of range",
                d.index,
                d.design.area * 1e12,
                front.scan_hz,
                front.max_error_pct
            ),
            None => writeln!(
                f,
                "no design is verified safe and tracks a {:.0} Hz scan within {} % of range: \
                 raise --max-ratio, lower the scan speed or accept a larger error",
                front.scan_hz, front.max_error_pct
            ),
        }
    }
}

impl Summary for crate::front::FrontSummary {
    fn written(&self) -> (Vec<&Path>, bool) {
        (vec![self.dir.as_path()], false)
    }
}

impl fmt::Display for ReduceSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.reduction;
        let c = &r.condensation;
        let a = c.alpha;
        writeln!(f, "reduced {}", self.design)?;
        writeln!(
            f,
            "alpha (moving frame, Eq. 24) = [[{:+.5}, {:+.5}], [{:+.5}, {:+.5}]]",
            a[0][0], a[0][1], a[1][0], a[1][1]
        )?;
        writeln!(
            f,
            "  scalar alpha (Eq. 27) = {:.5}, tilt theta = {:.3} deg, |A(theta) - alpha| = {:.1e}",
            c.alpha_scalar(),
            c.theta().to_degrees(),
            c.a_theta_residual()
        )?;
        writeln!(
            f,
            "K_qo1 = {:.4e} N/m, K_qo2 = {:.4e} N/m, M = {:.4} kg (volume fraction {:.3})",
            c.k_qo1(),
            c.k_qo2(),
            r.mass,
            r.volume_fraction
        )?;
        if let Some(m) = &r.modes {
            let hz: Vec<String> = m.frequencies.iter().map(|f| format!("{f:.0}")).collect();
            writeln!(f, "natural frequencies [Hz]: {}", hz.join(", "))?;
        }
        if let Some(a2) = &r.assumption2 {
            writeln!(f, "{}", a2.statement())?;
        }
        let Some(v) = &r.validity else {
            return Ok(());
        };
        for s in &v.scales {
            writeln!(
                f,
                "  stroke {:>5.1} um: reduced vs nonlinear FE max {:.3} % (rms {:.3} %), linear \
                 FE {:.3} %",
                s.amplitude * 1e6,
                s.max_error * 100.0,
                s.rms_error * 100.0,
                s.max_error_linear * 100.0
            )?;
        }
        let worst = v.max_error_within_stroke();
        let agrees = ["DOES NOT agree", "agrees"][(worst <= 0.02) as usize];
        writeln!(
            f,
            "validity: {agrees} with nonlinear FE to 2 % within the stroke (max {:.3} %); \
             tangent model within 2 % up to {:.0} % stroke",
            worst * 100.0,
            v.valid_scale(0.02) * 100.0
        )
    }
}

impl Summary for ReduceSummary {
    fn written(&self) -> (Vec<&Path>, bool) {
        (vec![&self.dir], self.replaced)
    }
}

impl fmt::Display for PeaRecord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = &self.steady;
        writeln!(
            f,
            "pea{}: {} samples over {} s; steady {} V sine loop at {} Hz: stroke {:.2} µm, width \
             {:.2} % of range, max deviation from linear {:.2} %",
            self.options.pea,
            self.data.len(),
            self.duration,
            self.voltage_range[1] - self.voltage_range[0],
            self.options.frequency,
            m.range,
            m.width_pct,
            m.max_deviation_pct
        )
    }
}

impl fmt::Display for PeaIdSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: {} samples, hysteresis {:.1} % of range",
            self.data.display(),
            self.samples,
            self.record_width_pct
        )?;
        for (name, e) in [("parallel RLS", &self.online), ("batch LS", &self.batch)] {
            let p = &e.params;
            writeln!(
                f,
                "  {name:<13} d_p = {:.4e}  A_bw = {:.4e}  B_bw = {:.4e}  Γ_bw = {:.4e}  δ_bw = \
                 {:.4e}  (rms {:.2} nm)",
                p.d_p,
                p.a_bw,
                p.b_bw,
                p.gamma_bw,
                p.delta_bw,
                e.rms_error * 1e3
            )?;
        }
        writeln!(f, "recommended: {}", self.recommended)?;
        let c = &self.compensation;
        writeln!(
            f,
            "compensation: loop width {:.2} % → {:.3} % of the range, max error {:.3} µm",
            c.width_before_pct, c.width_after_pct, c.max_error_um
        )
    }
}

impl Summary for PeaIdSummary {
    fn written(&self) -> (Vec<&Path>, bool) {
        (vec![&self.dir], self.replaced)
    }
}

impl fmt::Display for StageIdSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(p) = &self.plant {
            match self.simulated {
                Some(PlantKind::Twin) => writeln!(
                    f,
                    "simulated stage: the twin of the design ({p}), identified by its frequency \
                     response"
                )?,
                _ => writeln!(f, "simulated stage: {p}")?,
            }
        }
        if let Some(b) = &self.band {
            writeln!(
                f,
                "band: {:.0}–{:.0} Hz every {:.0} Hz, peak {:.2} µm",
                b.f_lo,
                b.f_hi,
                b.spacing,
                b.amplitude * 1e6
            )?;
        }
        if let Some((r, exact)) = &self.response {
            writeln!(
                f,
                "{} samples at {:.0} kHz, {} whole periods averaged, {} lines",
                self.samples,
                1e-3 / self.sample_time,
                r.periods,
                r.lines.len()
            )?;
            let g = r.fit.dc_gain;
            writeln!(
                f,
                "static gain x_nom → q: [[{:.6}, {:.6}], [{:.5}, {:.5}]]",
                g[0][0], g[0][1], g[1][0], g[1][1]
            )?;
            for m in &r.modes {
                writeln!(
                    f,
                    "  peak of q_o{}: {:.1} Hz, ζ {:.4}, share of the axis's static gain {:+.3}",
                    m.axis + 1,
                    m.frequency,
                    m.damping,
                    m.share
                )?;
            }
            for i in 0..2 {
                let mode = |fit: &flexstage_identify::response::ResponseFit| {
                    fit.frequency[i].map_or("none".to_string(), |fr| {
                        format!("{fr:.1} Hz, ζ {:.4}", fit.damping[i])
                    })
                };
                writeln!(
                    f,
                    "q_o{} mode kept for the model: {} (exact: {})",
                    i + 1,
                    mode(&r.fit),
                    mode(exact)
                )?;
            }
        }
        if let Some(id) = &self.identification {
            writeln!(
                f,
                "{} samples at T_s = {} s (regression at {} s), {} updates",
                self.samples, id.sample_time, id.regression_time, id.updates
            )?;
        }
        writeln!(
            f,
            "param    {:>12}     estimate        truth   error %  unit",
            if self.response.is_some() {
                "design"
            } else {
                "guess"
            }
        )?;
        let dash = || "-".to_string();
        for r in &self.rows {
            writeln!(
                f,
                "{:<8} {:>12.4e} {:>12.4e} {:>12} {:>9}  {}",
                r.name,
                r.guess,
                r.estimate,
                r.truth.map(|v| format!("{v:.4e}")).unwrap_or_else(dash),
                r.error_pct()
                    .map(|v| format!("{v:+.3}"))
                    .unwrap_or_else(dash),
                r.unit
            )?;
        }
        let truth = self
            .truth
            .as_ref()
            .map(|t| format!(" (truth {:.3e} N/m)", t.coupling))
            .unwrap_or_default();
        match &self.identification {
            Some(id) => {
                let kc = id.raw.coupling;
                writeln!(
                    f,
                    "k_c (cross terms, rows q_o1/q_o2): {:.3e} / {:.3e} N/m, kept: {:.3e} N/m{truth}",
                    kc[0], kc[1], self.coupling,
                )?;
                let c = id.conditioning;
                writeln!(
                    f,
                    "condition numbers (q_o1, q_o2, x_in1, x_in2): {:.3e}, {:.3e}, {:.3e}, {:.3e}",
                    c[0], c[1], c[2], c[3]
                )?;
            }
            None => writeln!(
                f,
                "k_c (from the static gain's cross terms): {:.3e} N/m{truth}",
                self.coupling
            )?,
        }
        match self.response {
            Some(_) => writeln!(
                f,
                "(track on the twin sets the backstepping up from response_fit.toml)"
            )?,
            None => writeln!(
                f,
                "(params.toml is the controller's model of `track` in this run folder)"
            )?,
        }
        if let Some(t) = &self.on_twin {
            writeln!(f, "then on the twin of the design:")?;
            t.fmt(f)?;
        }
        Ok(())
    }
}

impl Summary for StageIdSummary {
    fn written(&self) -> (Vec<&Path>, bool) {
        let mut dirs = vec![self.dir.as_path()];
        if let Some(t) = &self.on_twin {
            dirs.push(t.dir.as_path());
        }
        (dirs, self.replaced)
    }
    fn warnings(&self) -> &[String] {
        &self.warnings
    }
}

impl fmt::Display for TwinSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = &self.validity;
        writeln!(
            f,
            "twin: {} modes ({} fixed-interface), built in {:.1} s, nonlinear correction {}",
            v.order,
            v.fixed_interface_modes,
            v.build_seconds,
            ["off", "on"][v.nonlinear as usize]
        )?;
        for m in &v.modes {
            writeln!(
                f,
                "  mode {}: twin {:.1} Hz, FE {:.1} Hz ({:+.4} %)",
                m.index,
                m.twin,
                m.fe,
                100.0 * m.relative
            )?;
        }
        let t = &v.transient;
        if !t.ran {
            return writeln!(f, "  full-transient check not run: {}", t.reason);
        }
        for c in &t.cases {
            writeln!(
                f,
                "  {}: twin vs full nonlinear transient {:.3} / {:.3} % of range (q1 / q2); \
                 full model {} DOF, {:.1} s",
                c.name, c.error_pct[0], c.error_pct[1], c.dofs, c.reference_seconds
            )?;
        }
        Ok(())
    }
}

impl Summary for TwinSummary {
    fn written(&self) -> (Vec<&Path>, bool) {
        (vec![&self.dir], self.replaced)
    }
}

/// The head of the tracking table of [`TrackSummary`]'s `Display`.
const TRACK_HEADER: &str = "trajectory     variant                 RMS q1/q2 [nm]   RMS [% range]    \
max q1/q2 [nm]   max [% range] settle[s] peak [V]   sat  status";

impl fmt::Display for TrackSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let plant = match self.simulated {
            PlantKind::Twin => "the digital twin of the design in the scenario's rig".to_string(),
            PlantKind::Lumped => format!("lumped model: {}", self.plant),
        };
        let name = self.simulated.name();
        writeln!(
            f,
            "plant: {name} ({plant}); controller's model: {}",
            self.model
        )?;
        let [c1, c2] = &self.compensator;
        writeln!(f, "hysteresis compensator: PEA1 {c1}, PEA2 {c2}")?;
        writeln!(f, "{TRACK_HEADER}")?;
        for r in &self.rows {
            let [
                rms1,
                rms2,
                rms1_pct,
                rms2_pct,
                max1,
                max2,
                max1_pct,
                max2_pct,
                settling,
                peak,
            ] = r.error_columns();
            writeln!(
                f,
                "{:<14} {:<20} {rms1:>8.1}/{rms2:<8.1} {rms1_pct:>7.3}/{rms2_pct:<7.3} \
                 {max1:>8.1}/{max2:<8.1} {max1_pct:>7.3}/{max2_pct:<7.3} {settling:>9.4} \
                 {peak:>8.0} {:>5}  {}",
                r.trajectory,
                r.variant(),
                r.metrics.saturated,
                r.metrics.status().name()
            )?;
        }
        writeln!(
            f,
            "(hysteresis compensation: {}; feed-forward of the linear controllers: {}; errors \
             against the true output)",
            crate::names::compensation(self.compensation),
            match self.feedforward {
                FeedForwardFit::Lifted => "fitted to the lifted response at the samples",
                FeedForwardFit::Sampled => "fitted to the sampled response",
                FeedForwardFit::StaticLead => "the static inverse ahead",
                FeedForwardFit::Static => "the static inverse",
            }
        )?;
        let e = &self.exported;
        if !e.written.is_empty() {
            writeln!(
                f,
                "for a real-time target (JSON, C99 source and header in controllers/; the law \
                 as simulated: PI(D) + notch, FIR feed-forward with preview, PPF, the \
                 backstepping with its observer and prediction, learned tables): {}",
                e.written.join(", ")
            )?;
        }
        f.write_str(&self.margins_table())
    }
}

impl Summary for TrackSummary {
    fn written(&self) -> (Vec<&Path>, bool) {
        (vec![&self.dir], self.replaced)
    }
}

impl fmt::Display for StageSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StageSummary::Design(d) => d.fmt(f),
            StageSummary::Export(e) => e.fmt(f),
            StageSummary::Reduce(r) => r.fmt(f),
            StageSummary::Twin(Some(t)) => t.fmt(f),
            StageSummary::Twin(None) => writeln!(f, "twin: not built (see the warning)"),
            StageSummary::Pea(p) => p.iter().try_for_each(|p| p.fmt(f)),
            StageSummary::IdentifyStage(i) => i.fmt(f),
            StageSummary::Track(t) => t.fmt(f),
            StageSummary::Report(_) => Ok(()),
        }
    }
}

impl Summary for StageSummary {
    fn written(&self) -> (Vec<&Path>, bool) {
        match self {
            StageSummary::Design(d) => d.written(),
            StageSummary::Export(e) => e.written(),
            StageSummary::Reduce(r) => r.written(),
            StageSummary::Twin(Some(t)) => t.written(),
            StageSummary::Twin(None) => (Vec::new(), false),
            StageSummary::Pea(p) => {
                let replaced = p.iter().any(|p| p.replaced);
                (p.iter().map(|p| p.dir.as_path()).collect(), replaced)
            }
            StageSummary::IdentifyStage(i) => i.written(),
            StageSummary::Track(t) => t.written(),
            StageSummary::Report(p) => (vec![p.as_path()], false),
        }
    }
    fn warnings(&self) -> &[String] {
        match self {
            StageSummary::IdentifyStage(i) => i.warnings(),
            StageSummary::Design(d) => d.warnings(),
            _ => &[],
        }
    }
}

impl fmt::Display for RunSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (root, seconds) = (self.root.display(), self.seconds);
        writeln!(f, "\n== flexstage run: {root} ({seconds:.1} s)")?;
        self.verdict.fmt(f)?;
        let worst = self
            .identified
            .iter()
            .filter_map(|r| r.error_pct())
            .filter(|v| v.is_finite())
            .fold(None, |m: Option<f64>, v| {
                Some(m.map_or(v.abs(), |m| m.max(v.abs())))
            });
        if let Some(w) = worst {
            writeln!(
                f,
                "stage identification (Table 4): largest error against the truth {} % (every \
                 parameter in identify/stage/table.csv)",
                fmt_num(w)
            )?;
        }
        writeln!(f, "report: {}", self.report.display())
    }
}
