//! Wire-EDM manufacturability of the outline: parts not connected to a port (islands),
//! ligaments thinner than the minimum hinge, gaps narrower than the kerf, and pockets (holes
//! inside the part) that the wire can only reach through a drilled start hole.
//!
//! Widths come from the medial discs of [`crate::feature`]: a ligament is a solid disc that
//! spans the part ([`crate::feature::Ball::is_across`]), its width the disc's diameter, its
//! place the disc's centre; gaps likewise in the void. Narrow samples that are neighbours along
//! the outline, or the two sides of one disc, form one finding.

use serde::Serialize;

use crate::feature::{Balls, Boundary};
use crate::geometry::Geometry;

/// How serious a finding is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Severity {
    /// The part cannot be made (or would fail) as drawn.
    Error,
    /// A manufacturing step to plan (e.g. a start hole).
    Note,
}

/// What a finding is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FindingKind {
    /// Solid not connected to any port or support.
    Island,
    /// A ligament thinner than the minimum hinge.
    ThinLigament,
    /// A gap narrower than the minimum slot (kerf).
    NarrowGap,
    /// A closed pocket: the wire needs a start hole.
    Pocket,
    /// A pocket too small for the start hole.
    PocketTooSmall,
}

/// One finding, with its place in millimetres.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding {
    /// What.
    pub kind: FindingKind,
    /// How serious.
    pub severity: Severity,
    /// Where \[mm\].
    pub at_mm: [f64; 2],
    /// The measured size: width \[mm\] for ligaments and gaps, area \[mm²\] for islands and
    /// pockets.
    pub size: f64,
    /// The message for the user.
    pub message: String,
}

/// A measured width.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Width {
    /// Width \[m\].
    pub width: f64,
    /// Centre of the spanning disc \[m\].
    pub at: [f64; 2],
}

/// The manufacturability check.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Manufacturability {
    /// Thinnest ligament of the parts that are kept.
    pub min_ligament: Option<Width>,
    /// Narrowest gap.
    pub min_gap: Option<Width>,
    /// Parts not connected to a port or support.
    pub islands: usize,
    /// Closed pockets.
    pub pockets: usize,
    /// Findings, errors first.
    pub findings: Vec<Finding>,
    /// Pockets too small for the start hole that the verified part has filled (left solid, as
    /// the CAD/CAM step leaves them; [`small_pockets`]). Empty when [`check`] runs on an
    /// outline as drawn.
    pub filled: Vec<FilledPocket>,
}

/// A closed pocket too small for the wire's start hole, left solid in the part as made.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FilledPocket {
    /// Index of its loop in the outline as drawn.
    pub outline_loop: usize,
    /// Centre of its largest inscribed disc \[m\].
    pub at: [f64; 2],
    /// Area \[m²\].
    pub area: f64,
    /// Diameter of its largest inscribed disc \[m\] (smaller than the start hole).
    pub inscribed: f64,
    /// Mass the filling adds \[kg\] (area × plate thickness × density).
    pub mass: f64,
}

impl Manufacturability {
    /// No finding of severity [`Severity::Error`]?
    pub fn passes(&self) -> bool {
        self.findings.iter().all(|f| f.severity != Severity::Error)
    }
}

/// Limits of [`check`] \[m\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Minimum ligament.
    pub min_ligament: f64,
    /// Minimum gap.
    pub min_gap: f64,
    /// Start-hole diameter.
    pub start_hole: f64,
}

/// At most this many findings of one kind are listed (the count is always given).
pub const MAX_LISTED: usize = 12;

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// A narrow place: the narrowest disc of a cluster, and whether the cluster is only the apex
/// of a sharp corner (see [`narrow_places`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Narrow {
    width: Width,
    corner: bool,
}

/// Distance along loop `k` between two of its samples (the shorter way round).
fn along(b: &Boundary, i: usize, j: usize) -> f64 {
    let k = b.loop_of[i];
    if b.loop_of[j] != k {
        return f64::INFINITY;
    }
    let d = (b.arc[i] - b.arc[j]).abs();
    d.min(b.length[k] - d)
}

/// Narrow places of one side: clusters of samples whose spanning disc is narrower than
/// `limit`, narrowest first; and the narrowest spanning disc overall.
///
/// A cluster is only the **apex of a sharp corner** (a wedge the wire rounds off, or the
/// tip of a pointed feature) when its narrowest disc touches both flanks of the corner within
/// `2·limit` of each other along the outline and the whole cluster lies within `4·limit` of
/// that apex along the outline (wedges sharper than about 14° or longer narrow runs are
/// slots or ligaments).
fn narrow_places(
    b: &Boundary,
    balls: &[crate::feature::Ball],
    limit: f64,
) -> (Vec<Narrow>, Option<Width>) {
    let n = b.len();
    let narrow: Vec<bool> = balls
        .iter()
        .map(|s| s.is_across() && 2.0 * s.radius < limit)
        .collect();
    let mut parent: Vec<usize> = (0..n).collect();
    for i in 0..n {
        if !narrow[i] {
            continue;
        }
        let join = |j: usize, parent: &mut Vec<usize>| {
            if narrow[j] {
                let (a, c) = (find(parent, i), find(parent, j));
                parent[a] = c;
            }
        };
        join(b.neighbours(i).1, &mut parent);
        if let Some(j) = balls[i].contact {
            join(j, &mut parent);
        }
    }
    let mut members: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for i in (0..n).filter(|&i| narrow[i]) {
        let r = find(&mut parent, i);
        members.entry(r).or_default().push(i);
    }
    let mut places: Vec<Narrow> = members
        .values()
        .map(|m| {
            let &i = m
                .iter()
                .min_by(|&&x, &&y| balls[x].radius.total_cmp(&balls[y].radius))
                .expect("non-empty cluster");
            let apex = balls[i]
                .contact
                .is_some_and(|j| along(b, i, j) <= 2.0 * limit);
            let corner = apex && m.iter().all(|&x| along(b, i, x) <= 4.0 * limit);
            Narrow {
                width: Width {
                    width: 2.0 * balls[i].radius,
                    at: balls[i].center,
                },
                corner,
            }
        })
        .collect();
    places.sort_by(|a, c| a.width.width.total_cmp(&c.width.width));
    let min = balls
        .iter()
        .filter(|s| s.is_across())
        .min_by(|a, c| a.radius.total_cmp(&c.radius))
        .map(|s| Width {
            width: 2.0 * s.radius,
            at: s.center,
        });
    (places, min)
}

fn mm(p: [f64; 2]) -> [f64; 2] {
    [p[0] * 1e3, p[1] * 1e3]
}

/// The widest void disc inside hole loop `h`: its diameter and centre.
fn inscribed(b: &Boundary, balls: &Balls, h: usize) -> (f64, [f64; 2]) {
    let (lo, hi) = (b.start[h], b.start[h + 1]);
    let i = (lo..hi)
        .max_by(|&i, &j| balls.void[i].radius.total_cmp(&balls.void[j].radius))
        .expect("a hole has samples");
    (2.0 * balls.void[i].radius, balls.void[i].center)
}

/// The closed pockets of `geometry` (sampled as `b` with discs `balls`) whose largest inscribed
/// disc is narrower than `start_hole` \[m\]: no start hole fits, so the wire cannot cut them
/// and the CAD/CAM step leaves them solid. Returns each one's loop in `geometry` with its place,
/// area and inscribed diameter (`outline_loop` and `mass` are the caller's: set to the loop
/// index in `geometry` and 0).
pub fn small_pockets(
    geometry: &Geometry,
    b: &Boundary,
    balls: &Balls,
    start_hole: f64,
) -> Vec<FilledPocket> {
    let mut small = Vec::new();
    for part in &geometry.parts {
        for &h in &part.holes {
            let (d, c) = inscribed(b, balls, h);
            if d < start_hole {
                small.push(FilledPocket {
                    outline_loop: h,
                    at: c,
                    area: -crate::geometry::signed_area(&geometry.loops[h]),
                    inscribed: d,
                    mass: 0.0,
                });
            }
        }
    }
    small
}

/// Runs the checks on the kept parts (`geometry`, sampled as `b` with discs `balls`) and
/// reports `islands` (parts of the full outline that no port or support holds: area \[m²\] and
/// centroid \[m\]).
pub fn check(
    geometry: &Geometry,
    b: &Boundary,
    balls: &Balls,
    islands: &[(f64, [f64; 2])],
    limits: &Limits,
) -> Manufacturability {
    let mut findings = Vec::new();
    for &(area, c) in islands {
        findings.push(Finding {
            kind: FindingKind::Island,
            severity: Severity::Error,
            at_mm: mm(c),
            size: area * 1e6,
            message: format!(
                "island of {:.2} mm² at ({:.2}, {:.2}) mm is not connected to any port: it falls \
                 out when cut",
                area * 1e6,
                c[0] * 1e3,
                c[1] * 1e3
            ),
        });
    }
    let (thin, min_ligament) = narrow_places(b, &balls.solid, limits.min_ligament);
    let (narrow, min_gap) = narrow_places(b, &balls.void, limits.min_gap);
    let listed = |places: &[Narrow], kind, what: &str, limit: f64, findings: &mut Vec<Finding>| {
        let errors: Vec<&Narrow> = places.iter().filter(|p| !p.corner).collect();
        for w in errors.iter().take(MAX_LISTED) {
            let w = w.width;
            findings.push(Finding {
                kind,
                severity: Severity::Error,
                at_mm: mm(w.at),
                size: w.width * 1e3,
                message: format!(
                    "{what} {:.3} mm wide at ({:.2}, {:.2}) mm (minimum {:.3} mm)",
                    w.width * 1e3,
                    w.at[0] * 1e3,
                    w.at[1] * 1e3,
                    limit * 1e3
                ),
            });
        }
        if errors.len() > MAX_LISTED {
            findings.push(Finding {
                kind,
                severity: Severity::Error,
                at_mm: mm(errors[MAX_LISTED].width.at),
                size: errors[MAX_LISTED].width.width * 1e3,
                message: format!("… and {} more {what}s", errors.len() - MAX_LISTED),
            });
        }
        for w in places.iter().filter(|p| p.corner).take(MAX_LISTED) {
            let w = w.width;
            findings.push(Finding {
                kind,
                severity: Severity::Note,
                at_mm: mm(w.at),
                size: w.width * 1e3,
                message: format!(
                    "sharp corner at ({:.2}, {:.2}) mm: narrower than {:.3} mm ({what}) only at \
                     its apex; the cut rounds it",
                    w.at[0] * 1e3,
                    w.at[1] * 1e3,
                    limit * 1e3
                ),
            });
        }
    };
    listed(
        &thin,
        FindingKind::ThinLigament,
        "ligament",
        limits.min_ligament,
        &mut findings,
    );
    listed(
        &narrow,
        FindingKind::NarrowGap,
        "gap",
        limits.min_gap,
        &mut findings,
    );
    let mut pockets = 0;
    for part in &geometry.parts {
        for &h in &part.holes {
            pockets += 1;
            let (d, c) = inscribed(b, balls, h);
            let area = -crate::geometry::signed_area(&geometry.loops[h]);
            let fits = d >= limits.start_hole;
            findings.push(Finding {
                kind: if fits {
                    FindingKind::Pocket
                } else {
                    FindingKind::PocketTooSmall
                },
                severity: if fits {
                    Severity::Note
                } else {
                    Severity::Error
                },
                at_mm: mm(c),
                size: area.abs() * 1e6,
                message: if fits {
                    format!(
                        "closed pocket of {:.1} mm²: the wire needs a start hole, e.g. Ø {:.2} mm \
                         at ({:.2}, {:.2}) mm (room for Ø {:.2} mm)",
                        area.abs() * 1e6,
                        limits.start_hole * 1e3,
                        c[0] * 1e3,
                        c[1] * 1e3,
                        d * 1e3
                    )
                } else {
                    format!(
                        "closed pocket of {:.2} mm² at ({:.2}, {:.2}) mm is too small for a Ø \
                         {:.2} mm start hole (largest inscribed Ø {:.3} mm)",
                        area.abs() * 1e6,
                        c[0] * 1e3,
                        c[1] * 1e3,
                        limits.start_hole * 1e3,
                        d * 1e3
                    )
                },
            });
        }
    }
    findings.sort_by_key(|f| f.severity != Severity::Error);
    Manufacturability {
        min_ligament,
        min_gap,
        islands: islands.len(),
        pockets,
        findings,
        filled: Vec::new(),
    }
}
