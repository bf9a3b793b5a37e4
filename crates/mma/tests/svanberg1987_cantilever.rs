// Reference: K. Svanberg, "The method of moving asymptotes — a new method for structural
// optimization", Int. J. Numer. Meth. Engng 24 (1987) 359–373, section 6: five-segment
// cantilever, min 0.0624 Σ xj s.t. 61/x1³ + 37/x2³ + 19/x3³ + 7/x4³ + 1/x5³ <= 1,
// 1 <= x <= 10, x0 = (5, ..., 5).
// Goal: MMA reaches the paper's x* ≈ (6.016, 5.309, 4.494, 3.502, 2.153), f* ≈ 1.33996 (which
// equal the closed-form optimum xj = S^(1/3) cj^(1/4), S = Σ cj^(1/4)), with the constraint
// active and the KKT residual below 1e-6.

use flexstage_mma::{MmaParams, StopCriteria, samples};

#[test]
fn cantilever_reaches_paper_optimum() {
    let s = samples::cantilever();
    // The closed form agrees with the values printed in the paper.
    let paper = [6.016, 5.309, 4.494, 3.502, 2.153];
    for (a, b) in s.x_star.iter().zip(paper) {
        assert!((a - b).abs() < 1e-3, "closed form {a} vs paper {b}");
    }
    assert!((s.f_star - 1.33996).abs() < 1e-5, "f* = {}", s.f_star);

    let sol = s
        .solve(
            MmaParams::default(),
            StopCriteria {
                max_iterations: 50,
                kkt_tolerance: 1e-6,
            },
        )
        .unwrap();
    assert!(
        sol.converged,
        "KKT {:?} after {} iterations",
        sol.kkt, sol.iterations
    );
    assert!(sol.iterations <= 30, "took {} iterations", sol.iterations);
    for (j, (x, xs)) in sol.x.iter().zip(&s.x_star).enumerate() {
        assert!((x - xs).abs() < 1e-3, "x[{j}] = {x}, expected {xs}");
        assert!((1.0..=10.0).contains(x));
    }
    assert!((sol.f0 - s.f_star).abs() < 1e-5, "f0 = {}", sol.f0);
    assert!(sol.f[0].abs() < 1e-5, "constraint not active: {}", sol.f[0]);
    assert!(sol.lambda[0] > 0.0);
}
