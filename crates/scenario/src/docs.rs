//! One comment per scenario field: meaning, unit and source. `flexstage init` writes them
//! above each key, and a test checks that no key lacks one.

/// (TOML path without array indices, comment).
pub(crate) const FIELD_DOCS: &[(&str, &str)] = &[
    ("name", "Name of the scenario, used in run-folder names."),
    ("mesh", "Design domain and Q4 mesh (paper Table 3)."),
    (
        "mesh.length",
        "Domain length l along x [m], in [1e-4, 10]. Table 3: 0.12.",
    ),
    (
        "mesh.width",
        "Domain width w along y [m], in [1e-4, 10]. Table 3: 0.06.",
    ),
    (
        "mesh.thickness",
        "Out-of-plane thickness t [m], in [1e-6, 1]. Table 3: 0.01.",
    ),
    (
        "mesh.nl",
        "Elements along x, n_l in [4, 4000], n_l·n_w ≤ 250 000. Table 3: 120.",
    ),
    (
        "mesh.nw",
        "Elements along y, n_w in [4, 4000]. Table 3: 60.",
    ),
    ("material", "Solid material, aluminium 6061 (Table 3)."),
    (
        "material.youngs_modulus",
        "Young's modulus E0 [Pa], > 0, and E0 × mesh.thickness at most half of min_modulus × thickness / (10·n·ε), n the DOFs (what the solver resolves against the void; `flexstage check` names the bound). Table 3: 73e9.",
    ),
    (
        "material.min_modulus",
        "Modulus E_min given to void [Pa], 0 < E_min < E0 (see youngs_modulus). Table 3: 1e3.",
    ),
    (
        "material.poisson_ratio",
        "Poisson ratio ν, in (-1, 0.5). Table 3: 0.33.",
    ),
    (
        "material.density",
        "Mass density ρ0 [kg/m³], > 0. Table 3: 2710.",
    ),
    (
        "actuators",
        "The two piezo actuators: grounded spring K_pea plus force K_pea·x_nom on the input node (Eq. 2-3, Table 1).",
    ),
    (
        "actuators.stiffness",
        "PEA stiffness K_pea [N/m], > 0 and at most half of min_modulus × thickness / (10·n·ε) (see material.youngs_modulus). Table 1: 250 N/µm.",
    ),
    (
        "actuators.max_stroke",
        "Maximum nominal stroke max x_nom [m], in [2e-9, 1]. Table 1: 60 µm.",
    ),
    (
        "actuators.blocking_force",
        "Blocking force f_block [N], > 0. Table 1: 1.5e4.",
    ),
    (
        "actuators.stroke_amplitude",
        "Preloaded stroke half-range a: x_nom in [-a, a] [m], 1e-9 ≤ a ≤ max_stroke/2. Section 4.1: 30 µm.",
    ),
    (
        "actuators.configuration",
        "Table 2 working conditions: \"regular\" or \"reversed\".",
    ),
    (
        "actuators.pea1",
        "Input node of PEA1 (left edge, mid-height; DECISIONS.md).",
    ),
    (
        "actuators.pea1.kind",
        "Selector kind: \"nearest\" (point), \"edge\" (edge) or \"box\" (min, max).",
    ),
    (
        "actuators.pea1.point",
        "Point (x, y) [m]; the nearest node is selected.",
    ),
    (
        "actuators.pea2",
        "Input node of PEA2 (right edge, mid-height; DECISIONS.md).",
    ),
    (
        "actuators.pea2.kind",
        "Selector kind: \"nearest\" (point), \"edge\" (edge) or \"box\" (min, max).",
    ),
    (
        "actuators.pea2.point",
        "Point (x, y) [m]; the nearest node is selected.",
    ),
    (
        "supports",
        "A support: the selected nodes have components `fix` (\"x\", \"y\" or \"xy\") held at zero. Default: rollers (u_y = 0) at both input ports; the PEA springs hold x (DECISIONS.md).",
    ),
    ("supports.fix", "Fixed components: \"x\", \"y\" or \"xy\"."),
    ("supports.at", "Selected nodes."),
    (
        "supports.at.kind",
        "Selector kind: \"nearest\" (point), \"edge\" (edge) or \"box\" (min, max).",
    ),
    (
        "supports.at.point",
        "Point (x, y) [m]; the nearest node is selected.",
    ),
    (
        "supports.at.edge",
        "Edge: \"left\", \"right\", \"bottom\" or \"top\".",
    ),
    (
        "supports.at.min",
        "Lower-left corner (x, y) of the box [m].",
    ),
    (
        "supports.at.max",
        "Upper-right corner (x, y) of the box [m].",
    ),
    (
        "output",
        "Output port (Figure 2b, Eq. 7): centre of the top edge.",
    ),
    (
        "output.direction",
        "Direction [x, y] of the output displacement maximized by objective = \"displacement\" (normalized; required with [[ports]]). Unset: the tilt axis.",
    ),
    (
        "ports",
        "An input port of a general mechanism problem (inverter, gripper), replacing the PEAs: one node, a direction along x or y, an input spring and a force or a free displacement.",
    ),
    ("ports.at", "The input node (exactly one)."),
    (
        "ports.direction",
        "Load direction along x or y: [±1, 0] or [0, ±1].",
    ),
    (
        "ports.spring",
        "Input spring k_in [N/m], > 0 (the source's stiffness).",
    ),
    (
        "ports.force",
        "Input force f [N] along direction (or give displacement).",
    ),
    (
        "ports.displacement",
        "Free stroke x_nom [m] of the source along direction; the load is spring · x_nom (or give force).",
    ),
    (
        "output.tilt_deg",
        "Tilt θ of the target output frame [deg], in [-89, 89] (Figure 4b, Eq. 22). 0: normal setup.",
    ),
    (
        "output.payload",
        "Payload the output carries [kg], in [0, 10]: the sample holder or mirror, a point mass on the output node. It lowers the stage's resonances in the design, the reduced model, the verification and the twin. Default 0.",
    ),
    ("output.at", "The output node."),
    (
        "output.at.kind",
        "Selector kind: \"nearest\" (point), \"edge\" (edge) or \"box\" (min, max).",
    ),
    (
        "output.at.point",
        "Point (x, y) [m]; the nearest node is selected.",
    ),
    (
        "regions",
        "A passive region: elements whose centroid is selected stay solid or void. Default: small solid patches at the three ports spread the point loads (DECISIONS.md).",
    ),
    ("regions.kind", "\"solid\" (ρ = 1) or \"void\" (ρ = ρ_min)."),
    ("regions.at", "Selected elements (by centroid)."),
    (
        "regions.at.kind",
        "Selector kind: \"box\" (min, max), \"edge\" or \"nearest\".",
    ),
    ("regions.at.point", "Point (x, y) [m]."),
    (
        "regions.at.edge",
        "Edge: \"left\", \"right\", \"bottom\" or \"top\".",
    ),
    ("regions.at.min", "Lower-left corner (x, y) of the box [m]."),
    (
        "regions.at.max",
        "Upper-right corner (x, y) of the box [m].",
    ),
    (
        "optimization",
        "Topology optimization (Section 2.2, Eq. 5, Table 3).",
    ),
    (
        "optimization.penalty",
        "SIMP penalty p, in [1, 6]. Table 3: 3.",
    ),
    (
        "optimization.rho_min",
        "Pseudo-density lower bound ρ_min, in (0, 0.1]. Table 3: 1e-6.",
    ),
    (
        "optimization.max_iterations",
        "Maximum design iterations. Table 3: 1000.",
    ),
    (
        "optimization.samples",
        "Input samples p_m on the perimeter of the stroke square, a multiple of 4. Table 3: 40.",
    ),
    (
        "optimization.initial_density",
        "Initial uniform density, in (ρ_min, 1]. Paper silent; default equal to volume_fraction (a feasible start).",
    ),
    (
        "optimization.filter_radius",
        "Density-filter radius in element sizes, in [0, 20]; 0 = off. Paper silent; DECISIONS.md asks for a filter. With robust = true, the smallest radius: the minimum sizes of [limits] may enlarge it.",
    ),
    (
        "optimization.volume_fraction",
        "Volume-fraction upper bound of the design domain, in (0, 1]; 1 = none (the paper states none). Default 0.235: the paper's stage weighs 46 g (Table 4), 23.5 % of the 195 g solid domain.",
    ),
    (
        "optimization.change_tolerance",
        "Stop when the largest density change is below this (stagnation test: the mean change), in (0, 1).",
    ),
    (
        "optimization.kinematics",
        "FE kinematics while optimizing: \"nonlinear\" (total Lagrangian, Eq. A1) or \"linear\" (small strain).",
    ),
    (
        "optimization.objective",
        "\"workspace\": maximize the output polygon area (Eq. 4-5), subject to min_frequency if > 0; \"resonance\": maximize the stage's first natural frequency subject to min_workspace; \"displacement\": maximize one output displacement (inverter).",
    ),
    (
        "optimization.min_frequency",
        "Lower bound on the stage's first natural frequency [Hz], in [0, 1e6]; 0 = none. The stage: the design with the PEA springs and input plates (stage.guess), the rollers and output.payload, linearized at rest (DECISIONS.md, Design for bandwidth). Default 0.",
    ),
    (
        "optimization.min_volume_fraction",
        "Lower bound on the volume fraction the made design keeps, in [0, volume_fraction); 0 = none. A design for a higher resonance tends to shed material; 0.215 keeps it within 10 % of the paper's 46 g. Default 0.",
    ),
    (
        "optimization.min_workspace",
        "Lower bound on the workspace area [m²] when objective = \"resonance\", in (0, 1] (the worst robust realization must reach it; the paper preset's default design has about 4.1e-9); 0 otherwise.",
    ),
    (
        "optimization.output_spring",
        "Stiffness [N/m] of the load the output drives, ≥ 0 and at most half of min_modulus × thickness / (10·n·ε) (see material.youngs_modulus); 0 = none. Acts on u_oy and on u_ox − ½(u_in1 + u_in2), the motion relative to the moving frame of Eq. 22. Default 4e6, the paper's measured output stiffness (Table 4, K_qo): the design must transmit force, not only motion.",
    ),
    (
        "optimization.strain_energy_limit",
        "Strain-energy bound Σ0 [J] of Eq. 5, ≥ 0; 0 = derived from the allowable stress, Σ0 = (1 − ν) σ_a² V* / E0: the most energy the material volume V* stores without exceeding σ_a = fatigue_strength / safety_factor (DECISIONS.md).",
    ),
    (
        "optimization.tilt_tolerance_deg",
        "Max angle [deg] between the differential output and the tilted axis θ, in (0, 45]; used when tilt_deg ≠ 0. Default 1.",
    ),
    (
        "optimization.kkt_tolerance",
        "Stop when the density change and the MMA KKT residual are both small; KKT bound, > 0.",
    ),
    (
        "optimization.stagnation_window",
        "At the final beta, also stop when the objective, densities and KKT stagnate over this many iterations; 0 = off.",
    ),
    (
        "optimization.stagnation_tolerance",
        "Largest relative objective variation over the stagnation window, in (0, 1). Default 1e-3 (the robust worst case wobbles by a few 1e-4 at a stationary design).",
    ),
    (
        "optimization.mirror_symmetry",
        "Mirror symmetry about x = l/2: one design variable per element pair, so the design is symmetric by construction. Needs a symmetric problem and tilt_deg = 0. Default true.",
    ),
    (
        "optimization.robust",
        "Robust formulation (Wang, Lazarov & Sigmund 2011): maximize the worst workspace of the eroded, intermediate and dilated designs; thresholds and filter radius come from limits.min_hinge_thickness and limits.min_slot_width (DECISIONS.md). Default true.",
    ),
    (
        "optimization.energy_constraint",
        "Strain-energy constraint Σ ≤ Σ0 of Eq. 5 (strain_energy_limit). Default true; the classic mechanism codes (inverter, gripper) state none.",
    ),
    (
        "optimization.stress_constraint",
        "Fatigue stress constraint: aggregated von Mises stress of the (eroded) design at the four Table 2 extreme inputs ≤ fatigue_strength / safety_factor / mesh_stress_factor (DECISIONS.md). Default true.",
    ),
    (
        "optimization.projection",
        "Heaviside projection of the filtered densities with β continuation (DECISIONS.md filtering).",
    ),
    ("optimization.projection.enabled", "Use the projection."),
    (
        "optimization.projection.beta_max",
        "Final sharpness β, in [1, 1024]; β starts at 1 and doubles every `interval` iterations.",
    ),
    (
        "optimization.projection.interval",
        "Design iterations between doublings of β, ≥ 1.",
    ),
    (
        "optimization.projection.eta",
        "Projection threshold η, in (0, 1). Default 0.5.",
    ),
    (
        "optimization.additive",
        "Additive Yeoh hyperelastic material in low-density elements, optimization only (Eq. A2-A4).",
    ),
    (
        "optimization.additive.enabled",
        "Use the additive material during optimization. Default false: at the paper's stroke (strains ≈ 1e-3) it changes neither the topology nor the area (DECISIONS.md); turn it on for large-stroke designs.",
    ),
    (
        "optimization.additive.initial_coefficient",
        "Initial hyper-elastic coefficient as a fraction of E0, ≥ 0. Table 3: 1e-5.",
    ),
    (
        "optimization.additive.strain_threshold",
        "Von Mises strain threshold ε* of the c2 update (Eq. A3), > 0. Table 3: 0.5.",
    ),
    (
        "limits",
        "What the built stage must withstand and what the workshop can make (DECISIONS.md). Defaults: aluminium 6061-T6, wire EDM.",
    ),
    (
        "limits.fatigue_strength",
        "Fatigue strength [Pa], in [1, 1e10]: fully reversed stress amplitude survived for the design life. Al 6061-T6: 96.5e6 (5e8 cycles, R. R. Moore; ASM Handbook Vol. 2).",
    ),
    (
        "limits.yield_strength",
        "Tensile yield strength [Pa], in [fatigue_strength, 1e10]. Al 6061-T6: 276e6 (ASM Handbook Vol. 2).",
    ),
    (
        "limits.safety_factor",
        "Safety factor on the fatigue strength, in [1, 10]; allowable stress = fatigue_strength / safety_factor. Default 1.5.",
    ),
    (
        "limits.mesh_stress_factor",
        "How much the design mesh under-estimates hinge peak stress, in [1, 10]: the optimizer keeps the design-mesh stress ≤ allowable / this. Default 2 (measured 2-3x); the body-fitted re-analysis checks it.",
    ),
    (
        "limits.min_hinge_thickness",
        "Smallest solid member (hinge) thickness [m], in [1e-6, 0.05]. Default 0.5 mm. Sets the robust formulation's erosion threshold and filter radius.",
    ),
    (
        "limits.min_slot_width",
        "Smallest void (slot) width [m], in [1e-6, 0.05], e.g. the wire-EDM kerf. Default 0.4 mm. Sets the dilation threshold.",
    ),
    (
        "hysteresis",
        "Piezo hysteresis, Bouc-Wen Eq. (18) with n = 1, in the paper's units: x in µm, U in V, t in s (Table A1).",
    ),
    (
        "hysteresis.voltage_min",
        "Lowest amplifier voltage [V]. DECISIONS.md: 0.",
    ),
    (
        "hysteresis.voltage_max",
        "Highest amplifier voltage [V], in [voltage_min + 1, 2000]. DECISIONS.md: 1000.",
    ),
    ("hysteresis.pea1", "PEA1, Table A1 estimates."),
    ("hysteresis.pea2", "PEA2, Table A1 estimates."),
    (
        "hysteresis.pea1.d_p",
        "Piezoelectric coefficient d_p [µm/V], > 0. Table A1: 6.2e-2.",
    ),
    ("hysteresis.pea1.a_bw", "A_bw [µm/V]. Table A1: 1.2e-2."),
    ("hysteresis.pea1.b_bw", "B_bw [1/V], ≥ 0. Table A1: 1.9e-3."),
    (
        "hysteresis.pea1.gamma_bw",
        "Γ_bw [1/V], B_bw + Γ_bw > 0. Table A1: 1.6e-3.",
    ),
    (
        "hysteresis.pea1.delta_bw",
        "Asymmetry factor δ_bw [µm/(V·s)]. Table A1: 5.015e-4.",
    ),
    (
        "hysteresis.pea2.d_p",
        "Piezoelectric coefficient d_p [µm/V], > 0. Table A1: 6.5e-2.",
    ),
    ("hysteresis.pea2.a_bw", "A_bw [µm/V]. Table A1: 2.5e-2."),
    ("hysteresis.pea2.b_bw", "B_bw [1/V], ≥ 0. Table A1: 1.8e-3."),
    (
        "hysteresis.pea2.gamma_bw",
        "Γ_bw [1/V], B_bw + Γ_bw > 0. Table A1: 5.3e-3.",
    ),
    (
        "hysteresis.pea2.delta_bw",
        "Asymmetry factor δ_bw [µm/(V·s)]. Table A1: 1.973e-4.",
    ),
    (
        "stage",
        "Reduced 8-state stage model (Eq. 31-35, Appendix C, Table 4), SI units.",
    ),
    (
        "stage.damping_ratio",
        "Modal damping ratio used for the default damping coefficients, in [0, 1). Paper silent; DECISIONS.md: 1-3 %.",
    ),
    (
        "stage.guess",
        "Table 4 \"Guess\": the controller's starting model.",
    ),
    (
        "stage.truth",
        "Table 4 \"Estimate\": the simulated plant (entries marked \"—\" keep the guess).",
    ),
    (
        "stage.guess.k_qo1",
        "Horizontal output stiffness K_qo1 [N/m], > 0. Table 4 guess: 5e6.",
    ),
    (
        "stage.guess.k_qo2",
        "Vertical output stiffness K_qo2 [N/m], > 0. Table 4 guess: 5e6.",
    ),
    (
        "stage.guess.mass",
        "Mechanism mass M [kg], > 0. Table 4: 0.046.",
    ),
    (
        "stage.guess.alpha",
        "Amplification ratio α (Eq. 27), non-zero. Table 4: 1.012.",
    ),
    (
        "stage.guess.k_pea1",
        "PEA1 stiffness K_pea1 [N/m], > 0. Table 4: 2.5e8.",
    ),
    (
        "stage.guess.k_pea2",
        "PEA2 stiffness K_pea2 [N/m], > 0. Table 4: 2.5e8.",
    ),
    (
        "stage.guess.k_in1",
        "Input plate 1 stiffness K_in1 [N/m], > 0. Table 4 guess: 1e5.",
    ),
    (
        "stage.guess.k_in2",
        "Input plate 2 stiffness K_in2 [N/m], > 0. Table 4 guess: 1e5.",
    ),
    (
        "stage.guess.m_in1",
        "Input plate 1 mass m_in1 [kg], > 0. Table 4: 0.042.",
    ),
    (
        "stage.guess.m_in2",
        "Input plate 2 mass m_in2 [kg], > 0. Table 4: 0.042.",
    ),
    (
        "stage.guess.c_qo1",
        "Horizontal output damping C_qo1 [N·s/m], ≥ 0. Paper silent: from damping_ratio.",
    ),
    (
        "stage.guess.c_qo2",
        "Vertical output damping C_qo2 [N·s/m], ≥ 0. Paper silent: from damping_ratio.",
    ),
    (
        "stage.guess.c_in1",
        "Input plate 1 damping C_in1 [N·s/m], ≥ 0. Paper silent: from damping_ratio.",
    ),
    (
        "stage.guess.c_in2",
        "Input plate 2 damping C_in2 [N·s/m], ≥ 0. Paper silent: from damping_ratio.",
    ),
    (
        "stage.truth.k_qo1",
        "Horizontal output stiffness K_qo1 [N/m], > 0. Table 4 estimate: 3.78e6.",
    ),
    (
        "stage.truth.k_qo2",
        "Vertical output stiffness K_qo2 [N/m], > 0. Table 4 estimate: 4.03e6.",
    ),
    (
        "stage.truth.mass",
        "Mechanism mass M [kg], > 0. Table 4: 0.046 (weighed).",
    ),
    (
        "stage.truth.alpha",
        "Amplification ratio α (Eq. 27), non-zero. Table 4: 1.012.",
    ),
    (
        "stage.truth.k_pea1",
        "PEA1 stiffness K_pea1 [N/m], > 0. Table 4: 2.5e8.",
    ),
    (
        "stage.truth.k_pea2",
        "PEA2 stiffness K_pea2 [N/m], > 0. Table 4: 2.5e8.",
    ),
    (
        "stage.truth.k_in1",
        "Input plate 1 stiffness K_in1 [N/m], > 0. Table 4 estimate: 0.92e5.",
    ),
    (
        "stage.truth.k_in2",
        "Input plate 2 stiffness K_in2 [N/m], > 0. Table 4 estimate: 0.89e5.",
    ),
    (
        "stage.truth.m_in1",
        "Input plate 1 mass m_in1 [kg], > 0. Table 4: 0.042 (weighed).",
    ),
    (
        "stage.truth.m_in2",
        "Input plate 2 mass m_in2 [kg], > 0. Table 4: 0.042 (weighed).",
    ),
    (
        "stage.truth.c_qo1",
        "Horizontal output damping C_qo1 [N·s/m], ≥ 0. Paper silent: from damping_ratio.",
    ),
    (
        "stage.truth.c_qo2",
        "Vertical output damping C_qo2 [N·s/m], ≥ 0. Paper silent: from damping_ratio.",
    ),
    (
        "stage.truth.c_in1",
        "Input plate 1 damping C_in1 [N·s/m], ≥ 0. Paper silent: from damping_ratio.",
    ),
    (
        "stage.truth.c_in2",
        "Input plate 2 damping C_in2 [N·s/m], ≥ 0. Paper silent: from damping_ratio.",
    ),
    (
        "stage.coupling",
        "Cross terms of Eq. (30) in the simulated plant: coupling spring between the output directions as a fraction of sqrt(2 K_qo1 K_qo2) of the truth, |c| < 1. Paper silent: 0.05.",
    ),
    (
        "controller",
        "K-filter observer and robust backstepping controller gains (Table 4, Appendix D).",
    ),
    (
        "controller.observer_gain",
        "Observer gains (k_e1, k_e2) of Eq. (37-38), > 0. Table 4: 1e5.",
    ),
    (
        "controller.error_gain",
        "Error gains (k_ε1, k_ε2) of s = dε/dt + k_ε ε, > 0. Table 4: 2e4, 1.5e4; retuned to 3e3 (unstable at 10 kHz, see flexstage-control docs).",
    ),
    (
        "controller.feedback_gain",
        "Feedback gains (k1, k2) of Eq. (A34), > 0. Table 4: 1.2e4, 1.2e3; retuned to 3e3.",
    ),
    (
        "controller.disturbance_gain",
        "Bandwidth κ_d of the K-filter's estimate of the model error Δ_η (Eq. 36) [1/s], > 0: gives the loop its integral action (flexstage-control docs).",
    ),
    (
        "controller.eta_gain",
        "Linear feedback gains (k_η1, k_η2) of Eq. (A21) [1/s], > 1. Not in Table 4; chosen for the 10 kHz loop (flexstage-control docs).",
    ),
    (
        "controller.eta_bound",
        "Disturbance bounds max|Δ_η| of Eq. (A22, A25) [m/s²], ≥ 0.",
    ),
    (
        "controller.a_bound",
        "Disturbance bounds max|Δ_ε| of Eq. (A36-A37) [m/s], ≥ 0.",
    ),
    (
        "controller.boundary_layer",
        "Boundary layers (φ_s [m/s], φ_a [m]) of the robust terms, ≥ 0; 0 selects sgn() (chattering).",
    ),
    (
        "controller.observer_velocity",
        "Take dq/dt from the observer (true) or from finite differences of the positions (false, Section 4.1).",
    ),
    (
        "controller.stroke",
        "Largest nominal displacement |x_nom| the controller commands [m], > 0. Section 4.1 preloads to ±30 µm, but 0-1000 V delivers only +30.5/-24.9 µm around the 500 V bias with Table A1: default 24 µm.",
    ),
    (
        "controller.pid",
        "PID baseline gains [kp, ki 1/s, kd s] on the output error, ≥ 0, with inverse-hysteresis feedforward.",
    ),
    (
        "sensors",
        "Capacitive position sensors of q1 and q2 (Section 4.1).",
    ),
    (
        "sensors.resolution",
        "Quantization steps [m], ≥ 0. Section 4.1: 7.5 nm and 10 nm.",
    ),
    (
        "sensors.noise_std",
        "White-noise standard deviations [m], ≥ 0. Paper silent: equal to the resolution, as capacitive-sensor resolution is usually quoted as RMS noise.",
    ),
    (
        "simulation",
        "Timing of the simulated experiment (Section 4.1, DECISIONS.md).",
    ),
    (
        "simulation.sample_time",
        "Controller sample time T_s [s], in (0, 0.1]. Section 4.1: 1e-4.",
    ),
    (
        "simulation.substeps",
        "Plant integration substeps per controller sample, ≥ 1 (DECISIONS.md: the PEA mode is ≈ 12 kHz).",
    ),
    (
        "simulation.seed",
        "Seed of the noise generator, for reproducible runs.",
    ),
    (
        "simulation.amplifier_bandwidth",
        "Amplifier bandwidth [Hz], ≥ 0, of the lumped plant without the rig (identification and the ideal-loop experiment): first-order lag of the voltage; 0 = ideal zero-order hold. The rig's amplifier is rig.amplifier.",
    ),
    (
        "rig",
        "The loop around the simulated stage, as on a rig (DECISIONS.md, Digital twin and rig). Each effect is on at a realistic value and 0 switches it off.",
    ),
    (
        "rig.delay",
        "Computation + I/O delay [controller samples], 0, 1 or 2: the command computed from sample k acts from t_k + delay·T_s. Default 1 (a real-time target that computes within one period).",
    ),
    (
        "rig.amplifier",
        "The high-voltage amplifiers (Section 4.1: PI E-472.20). Its data sheet was not available to us: the defaults are typical of 1 kV linear piezo amplifiers, set them from your amplifier's data sheet.",
    ),
    (
        "rig.amplifier.bandwidth",
        "Small-signal bandwidth with the PEA as load [Hz], first order, in [0, 1e6]; 0 = ideal zero-order hold. Default 3000 (assumption, see rig.amplifier).",
    ),
    (
        "rig.amplifier.slew_rate",
        "Slew-rate limit of the amplifier [V/s], ≥ 0; 0 = none. Default 1e7 (10 V/µs, assumption).",
    ),
    (
        "rig.amplifier.current_limit",
        "Peak output current [A], in [0, 100]; 0 = none. The PEA is a capacitor, i = C dU/dt (PI piezo tutorial, Eq. 4-15), so |dU/dt| ≤ I/C. Default 0.1 (assumption).",
    ),
    (
        "rig.amplifier.capacitance",
        "Capacitance of one PEA [F], in (0, 1e-3]. Default 1.5e-6: PI's stack estimate C ≈ n ε33 A/d_s (piezo tutorial, Eq. 4-14) for a 1000 V stack with Table 1's stiffness and stroke.",
    ),
    (
        "rig.sensor",
        "Dynamics and noise spectrum of the capacitive sensors (white level and resolution in [sensors]).",
    ),
    (
        "rig.sensor.bandwidth",
        "Bandwidth of the sensor electronics [Hz], first order, in [0, 1e7]; 0 = ideal. Default 15000 (the wide setting of common capacitive-sensor drivers).",
    ),
    (
        "rig.sensor.flicker_corner",
        "1/f corner [Hz] where the 1/f spectrum equals the white one, in [0, 1e4]; 0 = white noise only. Default 1 (assumption).",
    ),
    (
        "rig.sensor.anti_alias",
        "Corner [Hz] of the ADC's anti-aliasing filter, a 2nd-order Butterworth after the sensor electronics, in [0, 1e7]; 0 = none. Default: DECISIONS.md, \"Anti-aliasing filter\" (chosen by the twin's Monte-Carlo study at 10 kHz sampling).",
    ),
    ("rig.creep", "Logarithmic creep of the PEAs."),
    (
        "rig.creep.factor",
        "Creep factor γ per time decade, in [0, 0.1]: Δx(t) = Δx(0.1 s)(1 + γ lg(t/0.1 s)) (PI piezo tutorial, Eq. 4-2: 0.01 to 0.02); 0 = off. Default 0.01.",
    ),
    (
        "rig.floor",
        "Floor vibration as a base acceleration in x and y: one sine per 1/3-octave band, random phases.",
    ),
    (
        "rig.floor.velocity_rms",
        "RMS velocity per 1/3-octave band [m/s], in [0, 1e-2]; 0 = off. Default 12.5e-6: the VC-C criterion (Gordon 1991, SPIE 1619) of a precision lab.",
    ),
    (
        "rig.floor.bands",
        "Lowest and highest 1/3-octave band centre [Hz], in (0, 1e4]. Default 8 to 80 (the flat part of the VC curves).",
    ),
    (
        "rig.pea1",
        "The plant's own PEA1 (Bouc–Wen truth, Eq. 18; µm, V, s). [hysteresis] is the compensator's identified model. Default: Table A1 with d_p +3 % and A_bw +10 % (identification error; set equal to [hysteresis] for a perfect model).",
    ),
    ("rig.pea1.d_p", "Piezoelectric coefficient d_p [µm/V], > 0."),
    ("rig.pea1.a_bw", "A_bw [µm/V]."),
    ("rig.pea1.b_bw", "B_bw [1/V], ≥ 0."),
    ("rig.pea1.gamma_bw", "Γ_bw [1/V], B_bw + Γ_bw > 0."),
    ("rig.pea1.delta_bw", "Asymmetry δ_bw [µm/(V·s)]."),
    (
        "rig.pea2",
        "The plant's own PEA2 (Bouc–Wen truth). Default: Table A1 with d_p +3 % and A_bw +10 %.",
    ),
    ("rig.pea2.d_p", "Piezoelectric coefficient d_p [µm/V], > 0."),
    ("rig.pea2.a_bw", "A_bw [µm/V]."),
    ("rig.pea2.b_bw", "B_bw [1/V], ≥ 0."),
    ("rig.pea2.gamma_bw", "Γ_bw [1/V], B_bw + Γ_bw > 0."),
    ("rig.pea2.delta_bw", "Asymmetry δ_bw [µm/(V·s)]."),
    (
        "twin",
        "The digital twin of the designed mechanism (flexstage-twin): Craig–Bampton reduction of the design's FE model with the two PEA ports and the output as interface, Rayleigh damping, geometric nonlinearity from nonlinear FE, the PEA sets of Eq. 1-3.",
    ),
    (
        "twin.coverage",
        "The twin claims its modes up to this multiple of the first resonance or f_s + 0.3 f1 (the sampling rate plus the sweep's fastest scan), whichever is larger, in [1, 20]. Default 3.",
    ),
    (
        "twin.min_modes",
        "At least this many fixed-interface modes, in [1, 160]. Default 40 (the 50 µs step of the twin's validity within 2 % of range: 0.8 % on the quick design; 24 left it at 2.2 %, 6 at 8.6 %: the modes between f_s and 5 f1 converge slowly).",
    ),
    (
        "twin.damping_ratio",
        "Damping ratio ζ of the stage's modes, in [0, 0.5): Rayleigh damping with ζ at the first resonance and at coverage × it. Paper silent; default 0.01 (aluminium flexures: 0.5–2 %).",
    ),
    (
        "twin.nonlinear",
        "Add the geometric nonlinearity (a polynomial fitted to nonlinear FE static solves over the stroke square); false gives the linear twin.",
    ),
    (
        "twin.fit_points",
        "Grid points per axis of the nonlinear static solves, in [3, 15]. Default 5.",
    ),
    (
        "twin.fit_span",
        "The grid spans ± this multiple of actuators.stroke_amplitude, in [0.1, 3]. Default 1.2.",
    ),
    (
        "trajectories",
        "A reference trajectory of the output q, centred on the rest position (Section 4.2). kind = \"lissajous\" (ratio, amplitude, frequency) or \"circle\" (radius, frequency).",
    ),
    ("trajectories.kind", "\"lissajous\" or \"circle\"."),
    (
        "trajectories.name",
        "Name used for output files: letters, digits, '-' and '_'.",
    ),
    (
        "trajectories.ratio",
        "Frequency ratio r of q1 to q2, > 0: q1 = A1 sin(r·2πft), q2 = A2 sin(2πft). Paper: 3 and 2.",
    ),
    (
        "trajectories.amplitude",
        "Amplitudes (A1, A2) [m], each 0 or ≥ 1e-9. Paper silent; default 8 and 16 µm: at most 65 % of what the amplifier range delivers (the rest is headroom for the controller), checked before a run.",
    ),
    (
        "trajectories.radius",
        "Circle radius [m], ≥ 1e-9. Paper silent; default 8 µm, sized like the Lissajous amplitudes.",
    ),
    (
        "trajectories.frequency",
        "Base frequency f [Hz], > 0. Paper silent.",
    ),
    ("trajectories.duration", "Duration [s], > 0."),
];

/// The documentation of a scenario field (meaning, unit, source) by its TOML path without
/// array indices (`mesh.nl`, `trajectories.frequency`), as `flexstage init` comments it;
/// `None` for a path the built-in scenarios do not have.
pub fn field_doc(path: &str) -> Option<&'static str> {
    FIELD_DOCS.iter().find(|(p, _)| *p == path).map(|(_, d)| *d)
}

/// Inserts a `# comment` line above every table header and key of `toml_text`, looking the
/// comments up by TOML path.
pub(crate) fn annotate(toml_text: &str) -> String {
    let mut out = String::with_capacity(toml_text.len() * 3);
    let mut table = String::new();
    for line in toml_text.lines() {
        let trimmed = line.trim();
        let header = trimmed
            .strip_prefix("[[")
            .and_then(|s| s.strip_suffix("]]"))
            .or_else(|| trimmed.strip_prefix('[').and_then(|s| s.strip_suffix(']')));
        if let Some(h) = header {
            table = h.trim().to_string();
            if !out.is_empty() && !out.ends_with("\n\n") {
                out.push('\n');
            }
            if let Some(doc) = field_doc(&table) {
                push_comment(&mut out, doc);
            }
        } else if let Some((key, _)) = trimmed.split_once('=') {
            let key = key.trim().trim_matches('"');
            let path = if table.is_empty() {
                key.to_string()
            } else {
                format!("{table}.{key}")
            };
            if let Some(doc) = field_doc(&path) {
                push_comment(&mut out, doc);
            }
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

fn push_comment(out: &mut String, doc: &str) {
    out.push_str("# ");
    out.push_str(doc);
    out.push('\n');
}
