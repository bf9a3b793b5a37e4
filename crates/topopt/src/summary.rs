//! What a finished design delivers, in the terms users compare (DECISIONS.md, "Reference
//! result"): the amplification α and the direction θ of the differential output, the absolute
//! workspace area (and relative to the input stroke square, the meaningful reference), the
//! mass, the design-mesh peak stress against the allowable, the minimum sizes, one-node hinges
//! and the symmetry, from a final analysis with geometrically nonlinear kinematics and without
//! the additive material. The robust formulation adds the eroded and dilated workspaces.

use flexstage_fem::{Kinematics, Passive, STRESS_POINTS};
use flexstage_scenario::Scenario;
use serde::{Deserialize, Serialize};

use crate::analysis::{AnalysisParams, CaseResults, Evaluator};
use crate::error::Result;
use crate::geometry::{Field, Measured, member_sizes, mirror_asymmetry, one_node_hinges};
use crate::length_scale::LengthScale;
use crate::modal::{ModalParams, stage_modes};
use crate::problem::{Problem, perimeter_walk};
use crate::realization::{Densities, Realization};
use crate::stress::stress_measure;

/// Refinement of the geometry checks' grid (sizes resolve to about h/4).
pub const GEOMETRY_REFINE: usize = 4;

/// What a design delivers (module docs). Areas in m², lengths in m, stresses in Pa.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DesignSummary {
    /// Workspace area of the blueprint (Eq. 4) in the configuration's orientation, `sign · J`
    /// \[m²\] ([`Problem::workspace_area`]): positive for a workspace traced the way Table 2
    /// asks.
    pub area: f64,
    /// `J / (2a)²`: the workspace in units of the input stroke square (≈ |det A| ≈ |α| in the
    /// floating set-up).
    pub area_ratio: f64,
    /// Differential amplification `α = ±|D| / Δ`, `D = u_o(+a,−a) − u_o(−a,+a)`,
    /// `Δ = (x_in1 − x_in2)(+a,−a) − (x_in1 − x_in2)(−a,+a)` (actual input displacements, Eq.
    /// 24–27), positive when D points along the target axis of the configuration.
    pub alpha: f64,
    /// Direction of the differential output's axis from +y towards +x \[deg\], in (−90, 90].
    pub theta_deg: f64,
    /// Target θ of the scenario \[deg\].
    pub theta_target_deg: f64,
    /// Mass of the blueprint \[kg\]: Σ ρ_e V_e ρ0 over all elements.
    pub mass: f64,
    /// Volume fraction of the design elements of the blueprint.
    pub volume_fraction: f64,
    /// Workspace area of the eroded design \[m²\] (robust formulation).
    pub area_eroded: Option<f64>,
    /// Workspace area of the dilated design \[m²\] (robust formulation).
    pub area_dilated: Option<f64>,
    /// Largest Gauss-point von Mises stress of the blueprint's solid (ρ ≥ ½) design elements at
    /// the four corners of the stroke square, on the design mesh \[Pa\].
    pub peak_stress: f64,
    /// What the stress constraint bounds: the largest relaxed (ρ^q) Gauss-point von Mises
    /// stress of the eroded design (the blueprint without the robust formulation) at the four
    /// corners \[Pa\]; lower than `peak_stress` by the relaxation of grey boundary elements.
    #[serde(default)]
    pub constrained_stress: Option<f64>,
    /// Allowable stress `fatigue_strength / safety_factor` \[Pa\].
    pub allowable_stress: f64,
    /// The design-mesh bound `allowable / mesh_stress_factor` the optimizer enforced \[Pa\].
    pub design_allowable: f64,
    /// Number of one-node hinges at ρ = ½ ([`crate::geometry`]).
    pub one_node_hinges: usize,
    /// Thinnest solid member of the blueprint at ρ = ½ (local thickness) \[m\].
    pub thinnest_member: Option<f64>,
    /// Where the thinnest member is: (x, y) \[m\].
    #[serde(default)]
    pub thinnest_member_at: Option<[f64; 2]>,
    /// Narrowest void gap of the blueprint at ρ = ½ (local thickness) \[m\].
    pub narrowest_gap: Option<f64>,
    /// Where the narrowest gap is: (x, y) \[m\].
    #[serde(default)]
    pub narrowest_gap_at: Option<[f64; 2]>,
    /// Minimum solid size the length scale guarantees \[m\] (robust formulation).
    pub guaranteed_member: Option<f64>,
    /// Minimum void size the length scale guarantees \[m\] (robust formulation).
    pub guaranteed_gap: Option<f64>,
    /// Largest |ρ − ρ_mirror| about x = l/2.
    pub mirror_asymmetry: f64,
    /// Lowest natural frequency of the stage \[Hz\]: the design with the PEA springs and input
    /// plates, the rollers and the payload, at rest ([`crate::modal`], the eigenproblem the
    /// design loop bounds). None for a general mechanism.
    #[serde(default)]
    pub first_frequency_hz: Option<f64>,
    /// The stage's lowest natural frequencies \[Hz\] (the first is `first_frequency_hz`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub frequencies_hz: Vec<f64>,
    /// What a general mechanism (`[[ports]]`: inverter, gripper) delivers; None for the
    /// two-PEA workspace problem, whose area, α and θ are the fields above.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mechanism: Option<MechanismSummary>,
}

/// The output of a general mechanism problem, from a final analysis with the scenario's own
/// kinematics (the problem's one load case).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MechanismSummary {
    /// Unit output direction d.
    pub direction: [f64; 2],
    /// Output displacement along d, `d · u_out`, of the blueprint \[m\].
    pub output_displacement: f64,
    /// The full output displacement (u_x, u_y) of the blueprint \[m\].
    pub output: [f64; 2],
    /// Displacement of each input port along its driven DOF \[m\].
    pub inputs: Vec<f64>,
    /// Geometric advantage `d · u_out / u_in` of the first port.
    pub geometric_advantage: f64,
    /// `d · u_out` of the eroded design \[m\] (robust formulation).
    pub eroded: Option<f64>,
    /// `d · u_out` of the dilated design \[m\] (robust formulation).
    pub dilated: Option<f64>,
}

/// The final analysis of a design: its summary, the blueprint's case results and the
/// displacements of the compressive corner `(+a, −a)` (for plots).
#[derive(Debug, Clone)]
pub struct FinalAnalysis {
    /// The summary.
    pub summary: DesignSummary,
    /// Blueprint case results (the perimeter walk).
    pub response: CaseResults,
    /// Full displacement vector of the blueprint at `(+a, −a)`.
    pub corner_displacement: Vec<f64>,
}

/// α and θ of the differential output (see [`DesignSummary::alpha`]).
fn amplification(problem: &Problem, r: &CaseResults, theta_target: f64, sign: f64) -> (f64, f64) {
    let (kc, kt) = problem.differential_corners();
    let d = [
        r.outputs[kc][0] - r.outputs[kt][0],
        r.outputs[kc][1] - r.outputs[kt][1],
    ];
    let din = |k: usize| r.inputs[k][0] - r.inputs[k].get(1).copied().unwrap_or(0.0);
    let delta = din(kc) - din(kt);
    let axis = [sign * theta_target.sin(), sign * theta_target.cos()];
    let along = d[0] * axis[0] + d[1] * axis[1];
    let alpha = along.signum() * d[0].hypot(d[1]) / delta.abs().max(f64::MIN_POSITIVE);
    let theta = if d[1] == 0.0 {
        90.0
    } else {
        // `+ 0.0`: a zero tilt is +0 (a reversed design's D points along −y).
        (d[0] / d[1]).atan().to_degrees() + 0.0
    };
    (alpha, theta)
}

/// Peak Gauss-point von Mises stress of the solid design elements at the four corners.
fn peak_stress(problem: &Problem, ev: &Evaluator, rho: &[f64]) -> f64 {
    let model = &problem.model;
    let mesh = model.mesh();
    let mut vm2 = vec![[0.0; STRESS_POINTS]; mesh.n_elements()];
    let mut peak = 0.0f64;
    for k in problem.corner_cases() {
        model.solid_von_mises_squared(&ev.cases[k].u, &mut vm2);
        for (e, p) in vm2.iter().enumerate() {
            if mesh.passive[e] == Passive::Design && rho[e] >= 0.5 {
                peak = p.iter().fold(peak, |a, s| a.max(s.sqrt()));
            }
        }
    }
    peak
}

/// The final analysis (module docs) of the densities of an optimization of scenario `s`,
/// with the length scale of its robust formulation (if any). A general mechanism
/// (`[[ports]]`) is analysed by [`mechanism_analysis`].
pub fn final_analysis(
    s: &Scenario,
    dens: &Densities,
    length_scale: Option<LengthScale>,
) -> Result<FinalAnalysis> {
    if Problem::is_mechanism(s) {
        return mechanism_analysis(s, dens, length_scale);
    }
    let mut problem = Problem::from_scenario(s, Some(Kinematics::TotalLagrangian))?;
    let a = s.actuators.stroke_amplitude;
    problem.cases = perimeter_walk(s.optimization.samples, a);
    let area_of = |rho: &[f64]| -> Result<(f64, CaseResults, Evaluator)> {
        let mut ev = Evaluator::new(&problem, AnalysisParams::default())?;
        let r = ev.solve_cases(rho, None)?;
        Ok((problem.workspace_area(&r.outputs), r, ev))
    };
    let (area, response, ev) = area_of(&dens.physical)?;
    let eroded = dens
        .of(Realization::Eroded)
        .map(|r| area_of(r).map(|x| (r, x)))
        .transpose()?;
    let area_dilated = dens
        .of(Realization::Dilated)
        .map(|r| area_of(r).map(|x| x.0))
        .transpose()?;
    // The constrained measure, on the eroded design (or the blueprint without it).
    let constrained_stress = problem.stress.as_ref().map(|sc| {
        let (rho_s, cases) = match &eroded {
            Some((rho_e, (_, _, ev_e))) => (*rho_e, &ev_e.cases),
            None => (dens.physical.as_slice(), &ev.cases),
        };
        stress_measure(&problem.model, sc, rho_s, cases).max * sc.allowable
    });
    let sign = match s.actuators.configuration {
        flexstage_scenario::Configuration::Regular => 1.0,
        flexstage_scenario::Configuration::Reversed => -1.0,
    };
    let theta_target = s.output.tilt_deg.to_radians();
    let (alpha, theta) = amplification(&problem, &response, theta_target, sign);
    let summary = DesignSummary {
        area,
        area_ratio: area / (2.0 * a).powi(2),
        alpha,
        theta_deg: theta,
        area_eroded: eroded.as_ref().map(|(_, x)| x.0),
        area_dilated,
        peak_stress: peak_stress(&problem, &ev, &dens.physical),
        constrained_stress,
        ..base_summary(s, &problem, &dens.physical, length_scale)
    };
    let modes = stage_modes(&problem, &dens.physical, &ModalParams::default(), false)?;
    let summary = DesignSummary {
        first_frequency_hz: modes.frequencies.first().copied(),
        frequencies_hz: modes.frequencies,
        ..summary
    };
    let corner_displacement = ev.cases[problem.differential_corners().0].u.clone();
    Ok(FinalAnalysis {
        summary,
        response,
        corner_displacement,
    })
}

/// The summary fields every problem shares (mass, sizes, symmetry, allowables); the
/// response fields zero or None.
fn base_summary(
    s: &Scenario,
    problem: &Problem,
    rho: &[f64],
    length_scale: Option<LengthScale>,
) -> DesignSummary {
    let mesh = problem.mesh();
    let design: Vec<usize> = problem.design_elements();
    let field = Field {
        nl: mesh.nl,
        nw: mesh.nw,
        h: (mesh.dx(), mesh.dy()),
        rho,
    };
    let (thinnest, gap) = member_sizes(&field, GEOMETRY_REFINE);
    let element_volume = mesh.dx() * mesh.dy() * mesh.thickness;
    DesignSummary {
        area: 0.0,
        area_ratio: 0.0,
        alpha: 0.0,
        theta_deg: 0.0,
        theta_target_deg: s.output.tilt_deg,
        mass: rho.iter().sum::<f64>() * element_volume * s.material.density,
        volume_fraction: design.iter().map(|&e| rho[e]).sum::<f64>() / design.len() as f64,
        area_eroded: None,
        area_dilated: None,
        peak_stress: 0.0,
        constrained_stress: None,
        allowable_stress: s.limits.allowable_stress(),
        design_allowable: s.limits.allowable_stress() / s.limits.mesh_stress_factor,
        one_node_hinges: one_node_hinges(&field).len(),
        thinnest_member: thinnest.map(|m| m.size),
        thinnest_member_at: thinnest.map(|m| m.at),
        narrowest_gap: gap.map(|m| m.size),
        narrowest_gap_at: gap.map(|m: Measured| m.at),
        guaranteed_member: length_scale.map(|l| l.solid_size),
        guaranteed_gap: length_scale.map(|l| l.void_size),
        mirror_asymmetry: mirror_asymmetry(&field),
        first_frequency_hz: None,
        frequencies_hz: Vec::new(),
        mechanism: None,
    }
}

/// The final analysis of a general mechanism (`[[ports]]`): its one load case with the
/// scenario's own kinematics (the classic mechanism codes are linear; a 0.1 m-per-newton
/// inverter analysed nonlinearly would be another problem), for the blueprint and the eroded
/// and dilated designs. `alpha` is the geometric advantage, `theta_deg` the direction of
/// u_out from +y towards +x; the workspace fields are zero.
pub fn mechanism_analysis(
    s: &Scenario,
    dens: &Densities,
    length_scale: Option<LengthScale>,
) -> Result<FinalAnalysis> {
    let problem = Problem::from_scenario(s, None)?;
    let d = match problem.objective {
        crate::problem::Objective::Displacement { direction } => direction,
        crate::problem::Objective::Workspace { .. } => [0.0, 1.0],
    };
    let along = |o: [f64; 2]| d[0] * o[0] + d[1] * o[1];
    let solve = |rho: &[f64]| -> Result<(CaseResults, Evaluator)> {
        let mut ev = Evaluator::new(&problem, AnalysisParams::default())?;
        let r = ev.solve_cases(rho, None)?;
        Ok((r, ev))
    };
    let (response, ev) = solve(&dens.physical)?;
    let of = |which: Realization| -> Result<Option<f64>> {
        dens.of(which)
            .map(|rho| solve(rho).map(|(r, _)| along(r.outputs[0])))
            .transpose()
    };
    let output = response.outputs[0];
    let inputs = response.inputs[0].clone();
    let u_out = along(output);
    let geometric_advantage = u_out / inputs[0].abs().max(f64::MIN_POSITIVE);
    let summary = DesignSummary {
        alpha: geometric_advantage,
        theta_deg: output[0].atan2(output[1]).to_degrees(),
        theta_target_deg: d[0].atan2(d[1]).to_degrees(),
        peak_stress: peak_stress(&problem, &ev, &dens.physical),
        mechanism: Some(MechanismSummary {
            direction: d,
            output_displacement: u_out,
            output,
            inputs,
            geometric_advantage,
            eroded: of(Realization::Eroded)?,
            dilated: of(Realization::Dilated)?,
        }),
        ..base_summary(s, &problem, &dens.physical, length_scale)
    };
    let corner_displacement = ev.cases[0].u.clone();
    Ok(FinalAnalysis {
        summary,
        response,
        corner_displacement,
    })
}

impl DesignSummary {
    /// The summary as lines of text, α, θ and the absolute area first.
    pub fn lines(&self) -> Vec<String> {
        let mm = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:.2} mm", v * 1e3));
        let at = |p: Option<[f64; 2]>| {
            p.map_or(String::new(), |p| {
                format!(" at ({:.1}, {:.1}) mm", p[0] * 1e3, p[1] * 1e3)
            })
        };
        let mut out = match &self.mechanism {
            Some(m) => m.lines(),
            None => vec![
                format!(
                    "amplification α = {:.3}, output direction θ = {:.2}° (target {:.1}°)",
                    self.alpha, self.theta_deg, self.theta_target_deg
                ),
                format!(
                    "workspace area {:.0} µm² ({:.3} × the input stroke square)",
                    self.area * 1e12,
                    self.area_ratio
                ),
            ],
        };
        if let (Some(e), Some(d)) = (self.area_eroded, self.area_dilated) {
            out.push(format!(
                "eroded / dilated designs: {:.0} / {:.0} µm² ({:.0} % / {:.0} % of the blueprint)",
                e * 1e12,
                d * 1e12,
                100.0 * e / self.area,
                100.0 * d / self.area
            ));
        }
        out.push(format!(
            "mass {:.1} g (volume fraction {:.3})",
            self.mass * 1e3,
            self.volume_fraction,
        ));
        let sizes = format!(
            "thinnest member {}{}, narrowest gap {}{} (guaranteed {} / {}); one-node hinges {}",
            mm(self.thinnest_member),
            at(self.thinnest_member_at),
            mm(self.narrowest_gap),
            at(self.narrowest_gap_at),
            mm(self.guaranteed_member),
            mm(self.guaranteed_gap),
            self.one_node_hinges,
        );
        if self.mechanism.is_some() {
            // A general mechanism has no fatigue constraint (refused with [[ports]]) and no
            // mirror symmetry to keep: those lines would report numbers nobody asked for.
            out.push(sizes);
        } else {
            let over = match self.constrained_stress {
                Some(c) if c > self.design_allowable => format!(
                    " OVER its bound by {:.1} %",
                    100.0 * (c / self.design_allowable - 1.0)
                ),
                _ => String::new(),
            };
            out.push(format!(
                "design-mesh von Mises: peak of the solid {:.1} MPa, constrained (relaxed) {} \
                 MPa{over} (bound {:.1} MPa = allowable {:.1} MPa / mesh factor)",
                self.peak_stress / 1e6,
                self.constrained_stress
                    .map_or("-".into(), |v| format!("{:.1}", v / 1e6)),
                self.design_allowable / 1e6,
                self.allowable_stress / 1e6
            ));
            out.push(format!(
                "{sizes}; mirror asymmetry {:.1e}",
                self.mirror_asymmetry
            ));
        }
        if let Some(f) = self.first_frequency_hz {
            out.push(format!(
                "first natural frequency {f:.0} Hz (the stage: PEA springs and plates, rollers, \
                 payload)"
            ));
        }
        out
    }
}

impl MechanismSummary {
    /// The mechanism's output as lines of text.
    pub fn lines(&self) -> Vec<String> {
        let mut out = vec![
            format!(
                "output displacement along d = [{:.3}, {:.3}]: {:.4e} m (u_out = [{:.4e}, {:.4e}] m)",
                self.direction[0],
                self.direction[1],
                self.output_displacement,
                self.output[0],
                self.output[1]
            ),
            format!(
                "input displacement{} {} m, geometric advantage {:.3}",
                if self.inputs.len() > 1 { "s" } else { "" },
                self.inputs
                    .iter()
                    .map(|u| format!("{u:.4e}"))
                    .collect::<Vec<_>>()
                    .join(", "),
                self.geometric_advantage
            ),
        ];
        if let (Some(e), Some(d)) = (self.eroded, self.dilated) {
            out.push(format!(
                "eroded / dilated designs: {e:.4e} / {d:.4e} m along d"
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stage() -> DesignSummary {
        DesignSummary {
            area: 2.5e-9,
            area_ratio: 40.0,
            alpha: 1.5,
            theta_deg: 0.1,
            theta_target_deg: 0.0,
            mass: 0.046,
            volume_fraction: 0.235,
            area_eroded: None,
            area_dilated: None,
            peak_stress: 80e6,
            constrained_stress: Some(70e6),
            allowable_stress: 64e6,
            design_allowable: 32e6,
            one_node_hinges: 0,
            thinnest_member: Some(5e-4),
            thinnest_member_at: Some([0.01, 0.02]),
            narrowest_gap: Some(4e-4),
            narrowest_gap_at: None,
            guaranteed_member: None,
            guaranteed_gap: None,
            mirror_asymmetry: 0.0,
            first_frequency_hz: Some(900.0),
            frequencies_hz: vec![900.0],
            mechanism: None,
        }
    }

    #[test]
    fn a_mechanism_summary_omits_the_stage_only_lines() {
        // Goal: a [[ports]] mechanism (no fatigue constraint, no mirror symmetry) is not
        // summarized with a stress line and an asymmetry it never asked for; the stage is.
        let text = stage().lines().join("\n");
        assert!(
            text.contains("von Mises") && text.contains("mirror asymmetry"),
            "{text}"
        );
        assert!(text.contains("amplification α = 1.500"), "{text}");
        // The constrained stress (70 MPa) over its bound (32 MPa) is flagged on the line.
        assert!(
            text.contains("70.0 MPa OVER its bound by 118.8 %"),
            "{text}"
        );
        let within = DesignSummary {
            constrained_stress: Some(30e6),
            ..stage()
        };
        assert!(!within.lines().join("\n").contains("OVER"));
        let mechanism = DesignSummary {
            mechanism: Some(MechanismSummary {
                direction: [-1.0, 0.0],
                output_displacement: 1.05,
                output: [-1.05, 0.0],
                inputs: vec![8.9],
                geometric_advantage: 0.118,
                eroded: None,
                dilated: None,
            }),
            ..stage()
        };
        let text = mechanism.lines().join("\n");
        assert!(text.contains("geometric advantage 0.118"), "{text}");
        assert!(text.contains("thinnest member 0.50 mm"), "{text}");
        assert!(
            !text.contains("von Mises") && !text.contains("asymmetry"),
            "{text}"
        );
        assert!(!text.contains("amplification"), "{text}");
    }
}
