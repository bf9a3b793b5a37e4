//! Reference: the front's own definition (DECISIONS.md, "Design for bandwidth"): designs by
//! continuation on the first-frequency bound, each with the stage's frequency on the design
//! mesh, the body-fitted outline and the twin, and the controllers' error at the named scan
//! speed. Goal, on a 24 × 12 quick stage with short designs: three designs whose bounds rise
//! and hold (within 1 %), whose twin frequencies equal the design's (within 1 %), each with
//! an outline, mode shapes and a design file, a scan error per controller, the files the
//! report shows, and a report with the section; and the options refused by name.

mod common;

use flexstage_pipeline::{FrontOptions, RunFolder, Silent, front};

#[test]
fn a_small_front_is_designed_verified_and_reported() {
    let dir = std::env::temp_dir().join(format!("flexstage-front-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let mut s = common::tiny();
    s.optimization.max_iterations = 40;
    let folder = RunFolder::open(s, &dir, false).unwrap();
    let options = FrontOptions {
        designs: 3,
        max_ratio: 1.2,
        scan_hz: 150.0,
        iterations: Some(30),
        ..FrontOptions::default()
    };
    let f = front(&folder, &options, &Silent).unwrap();
    print!("{f}");
    assert_eq!(f.front.designs.len(), 3);
    let f0 = f.front.designs[0].design.first_frequency_hz.unwrap();
    for (k, d) in f.front.designs.iter().enumerate() {
        let f1 = d.design.first_frequency_hz.unwrap();
        if k > 0 {
            assert!(
                f1 >= 0.99 * d.min_frequency_hz,
                "d{k}: {f1} Hz < {}",
                d.min_frequency_hz
            );
            assert!(d.min_frequency_hz > f.front.designs[k - 1].min_frequency_hz.max(f0));
        }
        let twin = d.twin_hz.unwrap();
        assert!(
            (twin - f1).abs() <= 0.01 * f1,
            "d{k}: twin {twin} vs design {f1}"
        );
        assert!(
            d.body_fitted_hz.is_some(),
            "d{k} not verified: {:?}",
            d.reasons
        );
        assert!(!d.scan.is_empty(), "d{k} has no scan errors");
        for file in [
            flexstage_run::layout::front::design(k),
            flexstage_run::layout::front::outline(k),
            flexstage_run::layout::front::modes(k),
        ] {
            assert!(dir.join(&file).is_file(), "{file} missing");
        }
    }
    use flexstage_run::layout::front::{CSV, JSON, SVG};
    for file in [JSON, CSV, SVG] {
        assert!(dir.join(file).is_file(), "{file} missing");
    }
    for k in 0..3 {
        let png = flexstage_run::layout::front::mode_png(k, 1);
        assert!(dir.join(&png).is_file(), "{png} missing");
    }
    let html = std::fs::read_to_string(flexstage_pipeline::write_report(&folder).unwrap()).unwrap();
    assert!(html.contains("id=\"front\"") && html.contains(SVG));
    drop(folder);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn front_options_are_refused_by_name() {
    for (o, name) in [
        (
            FrontOptions {
                designs: 1,
                ..FrontOptions::default()
            },
            "front.designs",
        ),
        (
            FrontOptions {
                max_ratio: 1.0,
                ..FrontOptions::default()
            },
            "front.max_ratio",
        ),
        (
            FrontOptions {
                scan_hz: f64::NAN,
                ..FrontOptions::default()
            },
            "front.scan_hz",
        ),
        (
            FrontOptions {
                max_error_pct: 0.0,
                ..FrontOptions::default()
            },
            "front.max_error_pct",
        ),
        (
            FrontOptions {
                iterations: Some(0),
                ..FrontOptions::default()
            },
            "front.iterations",
        ),
    ] {
        let e = o.validate().unwrap_err().to_string();
        assert!(e.contains(name), "{e}");
    }
}
