//! Prints the pipeline's typed summaries: results on standard output, where they went on
//! standard error.

use std::path::Path;

use flexstage_pipeline::pea::PeaRecord;
use flexstage_pipeline::{
    AnalyzeSummary, DesignSummary, ExportSummary, PeaIdSummary, ReduceSummary, RunSummary,
    StageIdSummary, StageSummary, TrackSummary, TwinSummary,
};
use flexstage_report::html::fmt_num;

/// "wrote DIR", noting replaced results.
pub fn wrote(dir: &Path, replaced: bool) {
    let note = [" ", " (replacing its earlier results)"][replaced as usize];
    errln!("wrote {}{}", dir.display(), note.trim_end());
}

/// A point (in m) as "(x, y)" in µm with `digits` decimals.
fn um(p: [f64; 2], digits: usize) -> String {
    format!("({:.digits$}, {:.digits$})", p[0] * 1e6, p[1] * 1e6)
}

/// A stage summary of `flexstage run`.
pub fn stage(s: &StageSummary) {
    match s {
        StageSummary::Design(d) => design(d),
        StageSummary::Export(e) => export(e),
        StageSummary::Reduce(r) => reduce(r),
        StageSummary::Twin(Some(t)) => twin(t),
        StageSummary::Twin(None) => outln!("twin: not built (see the warning)"),
        StageSummary::Pea(p) => p.iter().for_each(pea_identification),
        StageSummary::IdentifyStage(i) => stage_identification(i),
        StageSummary::Track(t) => track(t),
        StageSummary::Report(p) => errln!("wrote {}", p.display()),
    }
}

pub fn design(s: &DesignSummary) {
    if let Some(k) = s.resumed_at {
        outln!("resumed at iteration {k}");
    }
    outln!(
        "{:?} after {} iterations in {:.1} s ({:.3} s/iteration)",
        s.stop,
        s.iterations,
        s.seconds,
        s.seconds_per_iteration
    );
    for line in s.design.lines() {
        outln!("{line}");
    }
    outln!(
        "grey fraction {:.3}, volume {:.3}",
        s.grey_fraction,
        s.volume
    );
    wrote(&s.dir, false);
}

pub fn analyze(s: &AnalyzeSummary) {
    outln!(
        "analyzed {} load case(s) of {} in {:.2} s ({} Newton iterations)",
        s.cases.len(),
        s.design,
        s.seconds,
        s.newton_iterations
    );
    match s.workspace {
        Some((area, corners)) => {
            outln!(
                "  workspace polygon of {} samples: area {:.6e} m² = {:.3} µm²",
                s.cases.len(),
                area,
                area * 1e12
            );
            for (name, o) in ["(+a,+a)", "(+a,-a)"].iter().zip(corners) {
                outln!("  corner {name}: u_out = {} µm", um(o, 4));
            }
        }
        None => {
            for (x, o) in &s.cases {
                outln!("  x_nom = {} µm  ->  u_out = {} µm", um(*x, 2), um(*o, 4));
            }
        }
    }
    wrote(&s.dir, s.replaced);
}

pub fn export(s: &ExportSummary) {
    outln!(
        "outline of {}: {} closed loop(s), {:.2} mm² of material",
        s.design,
        s.loops,
        s.area * 1e6
    );
    for f in &s.files {
        wrote(f, s.replaced);
    }
    if let Some(v) = &s.verification {
        for line in v.summary_lines() {
            outln!("{line}");
        }
    } else if let Some(e) = &s.verify_error {
        outln!("verdict: NOT safe: the outline could not be verified: {e}");
    }
}

pub fn reduce(s: &ReduceSummary) {
    let r = &s.reduction;
    let c = &r.condensation;
    let a = c.alpha;
    outln!("reduced {}", s.design);
    outln!(
        "alpha (moving frame, Eq. 24) = [[{:+.5}, {:+.5}], [{:+.5}, {:+.5}]]",
        a[0][0],
        a[0][1],
        a[1][0],
        a[1][1]
    );
    outln!(
        "  scalar alpha (Eq. 27) = {:.5}, tilt theta = {:.3} deg, |A(theta) - alpha| = {:.1e}",
        c.alpha_scalar(),
        c.theta().to_degrees(),
        c.a_theta_residual()
    );
    outln!(
        "K_qo1 = {:.4e} N/m, K_qo2 = {:.4e} N/m, M = {:.4} kg (volume fraction {:.3})",
        c.k_qo1(),
        c.k_qo2(),
        r.mass,
        r.volume_fraction
    );
    if let Some(m) = &r.modes {
        let f: Vec<String> = m.frequencies.iter().map(|f| format!("{f:.0}")).collect();
        outln!("natural frequencies [Hz]: {}", f.join(", "));
    }
    if let Some(a2) = &r.assumption2 {
        outln!("{}", a2.statement());
    }
    if let Some(v) = &r.validity {
        for s in &v.scales {
            outln!(
                "  stroke {:>5.1} um: reduced vs nonlinear FE max {:.3} % (rms {:.3} %), linear \
                 FE {:.3} %",
                s.amplitude * 1e6,
                s.max_error * 100.0,
                s.rms_error * 100.0,
                s.max_error_linear * 100.0
            );
        }
        let ok = v.max_error_within_stroke() <= 0.02;
        outln!(
            "validity: {} within the stroke (max {:.3} %); tangent model within 2 % up to {:.0} % \
             stroke",
            if ok {
                "agrees with nonlinear FE to 2 %"
            } else {
                "DOES NOT agree with nonlinear FE to 2 %"
            },
            v.max_error_within_stroke() * 100.0,
            v.valid_scale(0.02) * 100.0
        );
    }
    wrote(&s.dir, s.replaced);
}

pub fn pea_record(r: &PeaRecord) {
    let m = &r.steady;
    outln!(
        "pea{}: {} samples over {} s; steady {} V sine loop at {} Hz: stroke {:.2} µm, width \
         {:.2} % of range, max deviation from linear {:.2} %",
        r.options.pea,
        r.data.len(),
        r.duration,
        r.voltage_range[1] - r.voltage_range[0],
        r.options.frequency,
        m.range,
        m.width_pct,
        m.max_deviation_pct
    );
}

pub fn pea_identification(s: &PeaIdSummary) {
    outln!(
        "{}: {} samples, hysteresis {:.1} % of range",
        s.data.display(),
        s.samples,
        s.record_width_pct
    );
    for (name, e) in [("parallel RLS", &s.online), ("batch LS", &s.batch)] {
        let p = &e.params;
        outln!(
            "  {name:<13} d_p = {:.4e}  A_bw = {:.4e}  B_bw = {:.4e}  Γ_bw = {:.4e}  δ_bw = \
             {:.4e}  (rms {:.2} nm)",
            p.d_p,
            p.a_bw,
            p.b_bw,
            p.gamma_bw,
            p.delta_bw,
            e.rms_error * 1e3
        );
    }
    outln!("recommended: {}", s.recommended);
    let c = &s.compensation;
    outln!(
        "compensation: loop width {:.2} % → {:.3} % of the range, max error {:.3} µm",
        c.width_before_pct,
        c.width_after_pct,
        c.max_error_um
    );
    wrote(&s.dir, s.replaced);
}

pub fn stage_identification(s: &StageIdSummary) {
    let id = &s.identification;
    if let Some(p) = &s.plant {
        outln!("simulated stage: {p}");
    }
    outln!(
        "{} samples at T_s = {} s (regression at {} s), {} updates",
        s.samples,
        id.sample_time,
        id.regression_time,
        id.updates
    );
    outln!("param           guess     estimate        truth   error %  unit");
    for r in &s.rows {
        let dash = || "-".to_string();
        outln!(
            "{:<8} {:>12.4e} {:>12.4e} {:>12} {:>9}  {}",
            r.name,
            r.guess,
            r.estimate,
            r.truth.map(|v| format!("{v:.4e}")).unwrap_or_else(dash),
            r.error_pct()
                .map(|v| format!("{v:+.3}"))
                .unwrap_or_else(dash),
            r.unit
        );
    }
    let kc = id.raw.coupling;
    outln!(
        "k_c (cross terms, rows q_o1/q_o2): {:.3e} / {:.3e} N/m",
        kc[0],
        kc[1]
    );
    let c = id.conditioning;
    outln!(
        "condition numbers (q_o1, q_o2, x_in1, x_in2): {:.3e}, {:.3e}, {:.3e}, {:.3e}",
        c[0],
        c[1],
        c[2],
        c[3]
    );
    for w in &id.warnings {
        errln!("warning: {w}");
    }
    wrote(&s.dir, s.replaced);
    errln!("  (the controller's model of `flexstage track` in this run folder)");
}

const TRACK_HEADER: &str = "trajectory     variant       RMS q1/q2 [nm]   RMS [% range]    \
max q1/q2 [nm]   max [% range] settle[s] peak [V]   sat";

/// The twin's modes and validity (`twin/`).
pub fn twin(s: &TwinSummary) {
    let v = &s.validity;
    outln!(
        "twin: {} modes ({} fixed-interface), built in {:.1} s, nonlinear correction {}",
        v.order,
        v.fixed_interface_modes,
        v.build_seconds,
        if v.nonlinear { "on" } else { "off" }
    );
    for m in &v.modes {
        outln!(
            "  mode {}: twin {:.1} Hz, FE {:.1} Hz ({:+.4} %)",
            m.index,
            m.twin,
            m.fe,
            100.0 * m.relative
        );
    }
    let t = &v.transient;
    if t.ran {
        for c in &t.cases {
            outln!(
                "  {}: twin vs full nonlinear transient {:.3} / {:.3} % of range (q1 / q2); \
                 full model {} DOF, {:.1} s",
                c.name,
                c.error_pct[0],
                c.error_pct[1],
                c.dofs,
                c.reference_seconds
            );
        }
    } else {
        outln!("  full-transient check not run: {}", t.reason);
    }
    wrote(&s.dir, s.replaced);
}

pub fn track(s: &TrackSummary) {
    outln!(
        "plant: {} ({}); controller's model: {}",
        s.simulated.name(),
        match s.simulated {
            flexstage_pipeline::PlantKind::Twin => {
                "the digital twin of the design in the scenario's rig".to_string()
            }
            flexstage_pipeline::PlantKind::Lumped => format!("lumped model: {}", s.plant),
        },
        s.model
    );
    outln!(
        "hysteresis compensator: PEA1 {}, PEA2 {}",
        s.compensator[0],
        s.compensator[1]
    );
    outln!("{TRACK_HEADER}");
    for r in &s.rows {
        let m = &r.metrics;
        outln!(
            "{:<14} {:<10} {:>8.1}/{:<8.1} {:>7.3}/{:<7.3} {:>8.1}/{:<8.1} {:>7.3}/{:<7.3} {:>9.4} \
             {:>8.0} {:>5}",
            r.trajectory,
            r.controller.name(),
            m.rms[0] * 1e9,
            m.rms[1] * 1e9,
            m.rms_pct[0],
            m.rms_pct[1],
            m.max[0] * 1e9,
            m.max[1] * 1e9,
            m.max_pct[0],
            m.max_pct[1],
            m.settling,
            m.peak_voltage,
            m.saturated
        );
    }
    outln!(
        "(hysteresis compensation: {}; errors against the true output)",
        flexstage_pipeline::names::compensation(s.compensation)
    );
    out!("{}", s.margins_table());
    wrote(&s.dir, s.replaced);
}

pub fn run(s: &RunSummary) {
    outln!(
        "\n== flexstage run: {} ({:.1} s)",
        s.root.display(),
        s.seconds
    );
    for (k, v) in &s.headline {
        outln!("  {k:<48} {v}");
    }
    if !s.identified.is_empty() {
        outln!("  identified stage parameters (estimate vs truth):");
    }
    for r in s.identified.iter().filter(|r| r.truth.is_some()) {
        outln!(
            "    {:<8} {:>12} vs {:>12} {:<6} ({:>6} %)",
            r.name,
            fmt_num(r.estimate),
            r.truth.map(fmt_num).unwrap_or_default(),
            r.unit,
            r.error_pct().map(fmt_num).unwrap_or_default()
        );
    }
    outln!("report: {}", s.report.display());
}
