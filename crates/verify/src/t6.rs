//! The six-node quadratic triangle (T6, straight-sided, plane stress, thickness `t`).
//!
//! Shape functions in area coordinates `L = (L0, L1, L2)` (Zienkiewicz, Taylor & Zhu, *The
//! Finite Element Method: Its Basis and Fundamentals*, 7th ed., Sec. 6.5):
//! vertices `N_i = L_i (2 L_i − 1)`, mid-sides `N_3 = 4 L0 L1`, `N_4 = 4 L1 L2`, `N_5 = 4 L2 L0`.
//! With straight sides, `∂L_i/∂x = b_i / 2A`, `∂L_i/∂y = c_i / 2A`, so the strain
//! `ε = B u` is linear over the element: the stiffness `K = t ∫ Bᵀ D B dA` is integrated
//! exactly by the 3-point rule, and the stress at any point (the vertices included) is exact
//! for the element's displacement field.
//!
//! Plane stress: `D = E/(1 − ν²) [[1, ν, 0], [ν, 1, 0], [0, 0, (1 − ν)/2]]`, engineering
//! shear strain, DOFs `2i` (x) and `2i + 1` (y) of node `i`.

/// Isotropic linear-elastic plane-stress material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneStress {
    /// Young's modulus \[Pa\].
    pub youngs_modulus: f64,
    /// Poisson ratio.
    pub poisson_ratio: f64,
    /// Thickness \[m\].
    pub thickness: f64,
}

impl PlaneStress {
    /// The plane-stress elasticity matrix `D`.
    pub fn d(&self) -> [[f64; 3]; 3] {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        let k = e / (1.0 - nu * nu);
        [
            [k, k * nu, 0.0],
            [k * nu, k, 0.0],
            [0.0, 0.0, k * 0.5 * (1.0 - nu)],
        ]
    }
}

/// Vertex coordinates of a triangle.
pub type Corners = [[f64; 2]; 3];

/// Twice the signed area.
pub fn twice_area(x: &Corners) -> f64 {
    (x[1][0] - x[0][0]) * (x[2][1] - x[0][1]) - (x[2][0] - x[0][0]) * (x[1][1] - x[0][1])
}

/// `B` (3 × 12) at area coordinates `l`.
pub fn b_matrix(x: &Corners, l: [f64; 3]) -> [[f64; 12]; 3] {
    let a2 = twice_area(x);
    let b = [x[1][1] - x[2][1], x[2][1] - x[0][1], x[0][1] - x[1][1]];
    let c = [x[2][0] - x[1][0], x[0][0] - x[2][0], x[1][0] - x[0][0]];
    // dN_a/dL_k for the six nodes.
    let mut dn = [[0.0; 3]; 6];
    for i in 0..3 {
        dn[i][i] = 4.0 * l[i] - 1.0;
    }
    for (m, (i, j)) in [(0usize, 1usize), (1, 2), (2, 0)].into_iter().enumerate() {
        dn[3 + m][i] = 4.0 * l[j];
        dn[3 + m][j] = 4.0 * l[i];
    }
    let mut bm = [[0.0; 12]; 3];
    for a in 0..6 {
        let dx = (dn[a][0] * b[0] + dn[a][1] * b[1] + dn[a][2] * b[2]) / a2;
        let dy = (dn[a][0] * c[0] + dn[a][1] * c[1] + dn[a][2] * c[2]) / a2;
        bm[0][2 * a] = dx;
        bm[1][2 * a + 1] = dy;
        bm[2][2 * a] = dy;
        bm[2][2 * a + 1] = dx;
    }
    bm
}

/// Points of the 3-point rule (degree 2) in area coordinates; each has weight `A/3`.
pub const GAUSS3: [[f64; 3]; 3] = [
    [2.0 / 3.0, 1.0 / 6.0, 1.0 / 6.0],
    [1.0 / 6.0, 2.0 / 3.0, 1.0 / 6.0],
    [1.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0],
];

/// Element stiffness `K = t ∫ Bᵀ D B dA` (12 × 12).
pub fn stiffness(x: &Corners, m: &PlaneStress) -> [[f64; 12]; 12] {
    let d = m.d();
    let w = m.thickness * 0.5 * twice_area(x) / 3.0;
    let mut k = [[0.0; 12]; 12];
    for l in GAUSS3 {
        let b = b_matrix(x, l);
        // db = D B (3 × 12)
        let mut db = [[0.0; 12]; 3];
        for r in 0..3 {
            for c in 0..12 {
                db[r][c] = d[r][0] * b[0][c] + d[r][1] * b[1][c] + d[r][2] * b[2][c];
            }
        }
        for i in 0..12 {
            for j in i..12 {
                let v = b[0][i] * db[0][j] + b[1][i] * db[1][j] + b[2][i] * db[2][j];
                k[i][j] += w * v;
            }
        }
    }
    // Mirror the upper triangle.
    for i in 1..12 {
        let (upper, lower) = k.split_at_mut(i);
        for (j, row) in upper.iter().enumerate() {
            lower[0][j] = row[i];
        }
    }
    k
}

/// Consistent scalar mass matrix `∫ ρ t N Nᵀ dA` (6 × 6; the same for x and y), in closed
/// form for a straight-sided T6: `ρ t A / 180 ·` the matrix below (its entries sum to 180).
pub fn mass(x: &Corners, density: f64, thickness: f64) -> [[f64; 6]; 6] {
    const M: [[f64; 6]; 6] = [
        [6.0, -1.0, -1.0, 0.0, -4.0, 0.0],
        [-1.0, 6.0, -1.0, 0.0, 0.0, -4.0],
        [-1.0, -1.0, 6.0, -4.0, 0.0, 0.0],
        [0.0, 0.0, -4.0, 32.0, 16.0, 16.0],
        [-4.0, 0.0, 0.0, 16.0, 32.0, 16.0],
        [0.0, -4.0, 0.0, 16.0, 16.0, 32.0],
    ];
    let s = density * thickness * 0.5 * twice_area(x) / 180.0;
    M.map(|row| row.map(|v| v * s))
}

/// Stress `σ = D B u` \[Pa\] (σxx, σyy, τxy) at area coordinates `l`.
pub fn stress(x: &Corners, m: &PlaneStress, u: &[f64; 12], l: [f64; 3]) -> [f64; 3] {
    let b = b_matrix(x, l);
    let d = m.d();
    let mut e = [0.0; 3];
    for r in 0..3 {
        e[r] = (0..12).map(|c| b[r][c] * u[c]).sum();
    }
    [
        d[0][0] * e[0] + d[0][1] * e[1],
        d[1][0] * e[0] + d[1][1] * e[1],
        d[2][2] * e[2],
    ]
}

/// Plane-stress von Mises stress `√(σx² − σx σy + σy² + 3 τ²)`.
pub fn von_mises(s: [f64; 3]) -> f64 {
    (s[0] * s[0] - s[0] * s[1] + s[1] * s[1] + 3.0 * s[2] * s[2])
        .max(0.0)
        .sqrt()
}

/// Shape functions at area coordinates `l`.
pub fn shape(l: [f64; 3]) -> [f64; 6] {
    [
        l[0] * (2.0 * l[0] - 1.0),
        l[1] * (2.0 * l[1] - 1.0),
        l[2] * (2.0 * l[2] - 1.0),
        4.0 * l[0] * l[1],
        4.0 * l[1] * l[2],
        4.0 * l[2] * l[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    const X: Corners = [[0.1, 0.2], [1.3, 0.4], [0.5, 1.1]];
    const MAT: PlaneStress = PlaneStress {
        youngs_modulus: 70e9,
        poisson_ratio: 0.3,
        thickness: 0.01,
    };

    fn node_coords() -> [[f64; 2]; 6] {
        let m = |a: usize, b: usize| [0.5 * (X[a][0] + X[b][0]), 0.5 * (X[a][1] + X[b][1])];
        [X[0], X[1], X[2], m(0, 1), m(1, 2), m(2, 0)]
    }

    #[test]
    fn quadratic_displacement_field_gives_the_exact_strain_everywhere() {
        // Reference: T6 interpolates any quadratic field exactly, so B u must equal the
        // analytic strain of u = (a x² + b xy, c y² + d x) at every point.
        let (a, b, c, d) = (1e-3, -2e-3, 0.5e-3, 3e-3);
        let nodes = node_coords();
        let mut u = [0.0; 12];
        for (i, p) in nodes.iter().enumerate() {
            u[2 * i] = a * p[0] * p[0] + b * p[0] * p[1];
            u[2 * i + 1] = c * p[1] * p[1] + d * p[0];
        }
        for l in [[0.2, 0.3, 0.5], [1.0, 0.0, 0.0], [0.0, 0.5, 0.5]] {
            let p = [
                l[0] * X[0][0] + l[1] * X[1][0] + l[2] * X[2][0],
                l[0] * X[0][1] + l[1] * X[1][1] + l[2] * X[2][1],
            ];
            let bm = b_matrix(&X, l);
            let e: Vec<f64> = (0..3)
                .map(|r| (0..12).map(|k| bm[r][k] * u[k]).sum())
                .collect();
            let exact = [2.0 * a * p[0] + b * p[1], 2.0 * c * p[1], b * p[0] + d];
            for r in 0..3 {
                assert!((e[r] - exact[r]).abs() < 1e-12, "{e:?} vs {exact:?}");
            }
        }
    }

    #[test]
    fn stiffness_is_symmetric_with_three_rigid_body_modes() {
        // Reference: K is symmetric and K r = 0 for the translations and the rotation.
        let k = stiffness(&X, &MAT);
        let scale = k[0][0].abs();
        for (i, row) in k.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!((v - k[j][i]).abs() < 1e-12 * scale);
            }
        }
        let nodes = node_coords();
        for mode in 0..3 {
            let r: Vec<f64> = (0..12)
                .map(|dof| {
                    let p = nodes[dof / 2];
                    match (mode, dof % 2) {
                        (0, 0) | (1, 1) => 1.0,
                        (2, 0) => -p[1],
                        (2, 1) => p[0],
                        _ => 0.0,
                    }
                })
                .collect();
            for row in &k {
                let f: f64 = row.iter().zip(&r).map(|(a, b)| a * b).sum();
                assert!(f.abs() < 1e-9 * scale, "mode {mode}: {f}");
            }
        }
    }

    #[test]
    fn closed_form_mass_matches_a_degree_four_quadrature() {
        // Reference: Dunavant's 6-point degree-4 rule integrates N_i N_j exactly.
        let pts = [
            (
                0.223_381_589_678_011,
                [0.108_103_018_168_070, 0.445_948_490_915_965],
            ),
            (
                0.109_951_743_655_322,
                [0.816_847_572_980_459, 0.091_576_213_509_771],
            ),
        ];
        let area = 0.5 * twice_area(&X);
        let mut q = [[0.0; 6]; 6];
        for (w, [a, b]) in pts {
            for l in [[a, b, b], [b, a, b], [b, b, a]] {
                let n = shape(l);
                for i in 0..6 {
                    for j in 0..6 {
                        q[i][j] += w * area * 2710.0 * 0.01 * n[i] * n[j];
                    }
                }
            }
        }
        let m = mass(&X, 2710.0, 0.01);
        let total: f64 = m.iter().flatten().sum();
        assert!((total - 2710.0 * 0.01 * area).abs() < 1e-12 * total);
        for i in 0..6 {
            for j in 0..6 {
                assert!((q[i][j] - m[i][j]).abs() < 1e-9 * total, "{i} {j}");
            }
        }
    }
}
