//! Manufacturability checks on outlines with known defects: each test states the defect, where
//! it is, and what the check must report.

use flexstage_verify::feature::{Boundary, medial_balls};
use flexstage_verify::geometry::Geometry;
use flexstage_verify::manufacture::{FindingKind, Limits, Manufacturability, Severity, check};
use flexstage_verify::samples::{circle, rectangle};

const LIMITS: Limits = Limits {
    min_ligament: 0.5e-3,
    min_gap: 0.4e-3,
    start_hole: 1e-3,
};

fn run(loops: Vec<Vec<[f64; 2]>>, islands: &[(f64, [f64; 2])]) -> Manufacturability {
    let g = Geometry::new(loops).unwrap();
    let b = Boundary::sample(&g, 0.02e-3);
    let balls = medial_balls(&b, 5e-3);
    check(&g, &b, &balls, islands, &LIMITS)
}

fn errors(m: &Manufacturability, kind: FindingKind) -> Vec<[f64; 2]> {
    m.findings
        .iter()
        .filter(|f| f.kind == kind && f.severity == Severity::Error)
        .map(|f| f.at_mm)
        .collect()
}

/// Two 10 × 10 mm blocks joined by a straight neck of width `t` and length 2 mm at y = 5 mm.
fn dumbbell(t: f64) -> Vec<[f64; 2]> {
    let (a, b) = (5e-3 - 0.5 * t, 5e-3 + 0.5 * t);
    vec![
        [0.0, 0.0],
        [10e-3, 0.0],
        [10e-3, a],
        [12e-3, a],
        [12e-3, 0.0],
        [22e-3, 0.0],
        [22e-3, 10e-3],
        [12e-3, 10e-3],
        [12e-3, b],
        [10e-3, b],
        [10e-3, 10e-3],
        [0.0, 10e-3],
    ]
}

#[test]
fn a_neck_thinner_than_the_minimum_hinge_is_one_error_at_its_centre() {
    // Defect: a 0.3 mm neck (minimum hinge 0.5 mm) between x = 10 and 12 mm at y = 5 mm.
    // Goal: exactly one thin-ligament error, 0.3 mm ± 1 %, located inside the neck; a 0.6 mm
    // neck passes and is reported as the thinnest ligament.
    let m = run(vec![dumbbell(0.3e-3)], &[]);
    let at = errors(&m, FindingKind::ThinLigament);
    assert_eq!(at.len(), 1, "{:#?}", m.findings);
    assert!(
        at[0][0] > 10.0 && at[0][0] < 12.0 && (at[0][1] - 5.0).abs() < 0.2,
        "{at:?}"
    );
    let w = m.min_ligament.unwrap().width;
    assert!((w - 0.3e-3).abs() < 0.003e-3, "{w}");
    assert!(!m.passes());
    let ok = run(vec![dumbbell(0.6e-3)], &[]);
    assert!(ok.passes(), "{:#?}", ok.findings);
    assert!((ok.min_ligament.unwrap().width - 0.6e-3).abs() < 0.006e-3);
}

#[test]
fn a_slot_narrower_than_the_kerf_is_an_error_and_a_wide_one_is_not() {
    // Defect: a 0.2 mm × 6 mm slot (kerf 0.4 mm) cut into a 20 × 10 mm plate from its top
    // edge at x = 10 mm. Goal: one narrow-gap error at x ≈ 10 mm, width 0.2 mm; a 0.5 mm slot
    // passes.
    let slot = |w: f64| {
        vec![
            [0.0, 0.0],
            [20e-3, 0.0],
            [20e-3, 10e-3],
            [10e-3 + 0.5 * w, 10e-3],
            [10e-3 + 0.5 * w, 4e-3],
            [10e-3 - 0.5 * w, 4e-3],
            [10e-3 - 0.5 * w, 10e-3],
            [0.0, 10e-3],
        ]
    };
    let m = run(vec![slot(0.2e-3)], &[]);
    let at = errors(&m, FindingKind::NarrowGap);
    assert_eq!(at.len(), 1, "{:#?}", m.findings);
    assert!((at[0][0] - 10.0).abs() < 0.15 && at[0][1] > 4.0, "{at:?}");
    assert!((m.min_gap.unwrap().width - 0.2e-3).abs() < 0.004e-3);
    assert!(run(vec![slot(0.5e-3)], &[]).passes());
}

#[test]
fn closed_pockets_need_a_start_hole_that_fits() {
    // Defect: a Ø 6 mm pocket (needs a start hole: a note with a place inside it) and a
    // Ø 0.8 mm pocket (too small for a Ø 1 mm start hole: an error) in a 30 × 10 mm plate.
    let m = run(
        vec![
            rectangle(0.0, 0.0, 30e-3, 10e-3),
            circle([8e-3, 5e-3], 3e-3, 300, false),
            circle([22e-3, 5e-3], 0.4e-3, 100, false),
        ],
        &[],
    );
    assert_eq!(m.pockets, 2);
    let note = m
        .findings
        .iter()
        .find(|f| f.kind == FindingKind::Pocket)
        .unwrap();
    assert_eq!(note.severity, Severity::Note);
    let d = ((note.at_mm[0] - 8.0).powi(2) + (note.at_mm[1] - 5.0).powi(2)).sqrt();
    assert!(
        d < 2.5,
        "start hole at {:?} not inside the pocket",
        note.at_mm
    );
    let small = errors(&m, FindingKind::PocketTooSmall);
    assert_eq!(small.len(), 1);
    assert!((small[0][0] - 22.0).abs() < 0.5);
}

#[test]
fn islands_are_errors_with_their_place() {
    // Defect: a solid part that no port holds (the caller found it): it must be reported as
    // an error with its centroid and area.
    let m = run(
        vec![rectangle(0.0, 0.0, 10e-3, 10e-3)],
        &[(4e-6, [30e-3, 2e-3])],
    );
    let f = &m.findings[0];
    assert_eq!((f.kind, f.severity), (FindingKind::Island, Severity::Error));
    assert_eq!(f.at_mm, [30.0, 2.0]);
    assert!((f.size - 4.0).abs() < 1e-9);
    assert!(f.message.contains("(30.00, 2.00) mm"), "{}", f.message);
}

#[test]
fn the_apex_of_a_sharp_notch_is_a_note_not_a_gap_error() {
    // Reference: a V notch of 40° cut 4 mm deep into a plate: near its apex the void is
    // narrower than the kerf, but the wire simply rounds the apex — a note. Goal: no
    // narrow-gap error, one sharp-corner note near the apex at (10, 6) mm.
    let half = 20f64.to_radians().tan() * 4e-3;
    let m = run(
        vec![vec![
            [0.0, 0.0],
            [20e-3, 0.0],
            [20e-3, 10e-3],
            [10e-3 + half, 10e-3],
            [10e-3, 6e-3],
            [10e-3 - half, 10e-3],
            [0.0, 10e-3],
        ]],
        &[],
    );
    assert!(
        errors(&m, FindingKind::NarrowGap).is_empty(),
        "{:#?}",
        m.findings
    );
    let note = m
        .findings
        .iter()
        .find(|f| f.kind == FindingKind::NarrowGap && f.severity == Severity::Note)
        .expect("a sharp-corner note");
    assert!((note.at_mm[0] - 10.0).abs() < 0.3 && (note.at_mm[1] - 6.0).abs() < 1.2);
}
