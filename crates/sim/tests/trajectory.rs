//! Reference: Section 4.2 (Lissajous 3:1, 2:1, circle; Figures 9–11) and the smooth
//! start. Goal: the reference derivatives q̇_d, q̈_d, q⃛_d used by the law are exact (central
//! differences), the start has no jump.

use flexstage_sim::trajectory::{Reference, Shape};

#[test]
fn derivatives_match_central_differences_and_start_is_smooth() {
    let shapes = [
        Shape::Lissajous {
            ratio: 3.0,
            amplitude: [10e-6, 20e-6],
            frequency: 2.0,
        },
        Shape::Lissajous {
            ratio: 2.5,
            amplitude: [5e-6, 8e-6],
            frequency: 7.0,
        },
        Shape::Circle {
            radius: 10e-6,
            frequency: 2.0,
        },
        Shape::Step {
            target: [3e-6, -2e-6],
        },
        Shape::Ramp {
            rate: [1e-4, -5e-5],
        },
    ];
    for shape in shapes {
        let r = Reference {
            shape,
            smooth_start: 0.05,
        };
        let s0 = r.sample(0.0);
        assert_eq!(s0.q, [0.0; 2]);
        let tiny = r.sample(1e-6);
        assert!(
            tiny.q.iter().all(|q| q.abs() < 1e-18),
            "{shape:?}: no jump at t = 0"
        );
        for t in [0.013, 0.031, 0.049, 0.2] {
            let h = 1e-6;
            let (p, m, c) = (r.sample(t + h), r.sample(t - h), r.sample(t));
            for i in 0..2 {
                let check = |d: f64, fd: f64, what: &str| {
                    let scale = d.abs().max(fd.abs()).max(1e-12);
                    assert!(
                        (d - fd).abs() < 1e-5 * scale + 1e-12,
                        "{shape:?} t={t} {what}{i}: {d} vs {fd}"
                    );
                };
                check(c.dq[i], (p.q[i] - m.q[i]) / (2.0 * h), "q̇");
                check(c.ddq[i], (p.dq[i] - m.dq[i]) / (2.0 * h), "q̈");
                check(c.dddq[i], (p.ddq[i] - m.ddq[i]) / (2.0 * h), "q⃛");
            }
        }
    }
}
