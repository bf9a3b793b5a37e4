//! The body-fitted mesh: boundary samples spaced by the local feature size, a constrained
//! Delaunay triangulation refined by Ruppert's algorithm (spade), and quadratic (T6)
//! triangles.
//!
//! # Size function
//! At every dense boundary sample the target element size is
//!
//! ```text
//! h = clamp( min( 2 r_solid / n_across ,  θ_seg / |κ| ,  h_max ),  h_min, h_max )
//! ```
//!
//! with `r_solid` the shrinking-ball radius on the solid side ([`crate::feature`]; across a
//! ligament of width `t` it is `t/2`, so `n_across` elements span it), `κ` the boundary
//! curvature (so a segment turns by at most `θ_seg` along fillets and notches), then limited
//! along the loop to grow by at most `g` per unit length (`h_i ≤ h_j + g |s_i − s_j|`). The
//! loop is resampled with `N = ⌈∫ ds/h⌉` points equally spaced in `∫ ds/h`, on the chords of
//! the outline itself (so the mesh boundary is the exported polyline, up to chord sagitta).
//! Ruppert refinement (minimum angle, maximum area `√3/4·h_max²`) grades the interior from
//! the boundary sizes.

use std::collections::HashMap;

use spade::{
    AngleLimit, ConstrainedDelaunayTriangulation, Point2, RefinementParameters, Triangulation,
};

use crate::error::{Result, VerifyError};
use crate::feature::{Balls, Boundary};

/// Sizing of the body-fitted mesh (from [`crate::VerifyParams`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sizing {
    /// Elements across a ligament.
    pub elements_across: f64,
    /// Smallest element \[m\].
    pub min_element: f64,
    /// Largest element \[m\].
    pub max_element: f64,
    /// Largest turn of one boundary segment \[rad\].
    pub segment_angle: f64,
    /// Growth of the size per unit length along the boundary.
    pub gradation: f64,
    /// Minimum angle of the refined mesh \[deg\].
    pub angle_limit_deg: f64,
    /// Node budget (T6 nodes).
    pub max_nodes: usize,
}

/// A mesh of quadratic triangles.
#[derive(Debug, Clone, PartialEq)]
pub struct TriMesh {
    /// Node coordinates \[m\]: the triangle vertices first, then the mid-side nodes.
    pub nodes: Vec<[f64; 2]>,
    /// Number of vertex nodes (the first `n_vertices` of `nodes`).
    pub n_vertices: usize,
    /// Elements: vertices `0, 1, 2` counter-clockwise, then mid-side nodes of edges 0–1, 1–2,
    /// 2–0.
    pub elements: Vec<[usize; 6]>,
    /// Boundary edges `[a, mid, b]`, the solid on the left of `a → b`.
    pub boundary: Vec<[usize; 3]>,
}

impl TriMesh {
    /// Area of element `e` \[m²\].
    pub fn element_area(&self, e: usize) -> f64 {
        let [a, b, c, ..] = self.elements[e].map(|i| self.nodes[i]);
        0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))
    }

    /// Total area \[m²\].
    pub fn area(&self) -> f64 {
        (0..self.elements.len()).map(|e| self.element_area(e)).sum()
    }

    /// Shortest and longest element edge \[m\].
    pub fn edge_range(&self) -> (f64, f64) {
        let mut lo = f64::INFINITY;
        let mut hi: f64 = 0.0;
        for el in &self.elements {
            for k in 0..3 {
                let (a, b) = (self.nodes[el[k]], self.nodes[el[(k + 1) % 3]]);
                let l = (b[0] - a[0]).hypot(b[1] - a[1]);
                lo = lo.min(l);
                hi = hi.max(l);
            }
        }
        (lo, hi)
    }
}

/// Target element size at every boundary sample (module docs).
pub fn size_field(b: &Boundary, balls: &Balls, s: &Sizing) -> Vec<f64> {
    let n = b.len();
    let mut h: Vec<f64> = (0..n)
        .map(|i| {
            let thick = 2.0 * balls.solid[i].radius / s.elements_across;
            // Curvature from the turn between the chords to the samples ±k away.
            let (mut a, mut c) = (i, i);
            for _ in 0..3 {
                a = b.neighbours(a).0;
                c = b.neighbours(c).1;
            }
            let (pa, p, pc) = (b.points[a], b.points[i], b.points[c]);
            let u = [p[0] - pa[0], p[1] - pa[1]];
            let v = [pc[0] - p[0], pc[1] - p[1]];
            let turn = (u[0] * v[1] - u[1] * v[0])
                .atan2(u[0] * v[0] + u[1] * v[1])
                .abs();
            let len = 0.5 * (u[0].hypot(u[1]) + v[0].hypot(v[1]));
            let curv = if turn > 1e-12 {
                s.segment_angle * len / turn
            } else {
                f64::INFINITY
            };
            thick.min(curv).clamp(s.min_element, s.max_element)
        })
        .collect();
    // Gradation along each loop: two cyclic sweeps each way.
    for k in 0..b.length.len() {
        let (lo, hi) = (b.start[k], b.start[k + 1]);
        let m = hi - lo;
        if m < 2 {
            continue;
        }
        let ds = |i: usize, j: usize| {
            let (p, q) = (b.points[i], b.points[j]);
            (q[0] - p[0]).hypot(q[1] - p[1])
        };
        for _ in 0..2 {
            for t in 0..m {
                let (i, j) = (lo + (t + 1) % m, lo + t);
                h[i] = h[i].min(h[j] + s.gradation * ds(i, j));
            }
            for t in (0..m).rev() {
                let (i, j) = (lo + t, lo + (t + 1) % m);
                h[i] = h[i].min(h[j] + s.gradation * ds(i, j));
            }
        }
    }
    h
}

/// Boundary samples where the outline turns by more than this \[rad\] (30°) are corners: they
/// are kept as mesh vertices, so resampling never cuts a sharp corner.
pub const CORNER_TURN: f64 = std::f64::consts::FRAC_PI_6;

/// Resamples loop `k` with spacing `h` (module docs): points equally spaced in `∫ ds/h`
/// between consecutive corners (every corner kept).
pub fn resample_loop(b: &Boundary, h: &[f64], k: usize) -> Vec<[f64; 2]> {
    let (lo, hi) = (b.start[k], b.start[k + 1]);
    let m = hi - lo;
    let turn = |i: usize| {
        let (a, c) = b.neighbours(i);
        let (pa, p, pc) = (b.points[a], b.points[i], b.points[c]);
        let u = [p[0] - pa[0], p[1] - pa[1]];
        let v = [pc[0] - p[0], pc[1] - p[1]];
        (u[0] * v[1] - u[1] * v[0])
            .atan2(u[0] * v[0] + u[1] * v[1])
            .abs()
    };
    let mut corners: Vec<usize> = (0..m).filter(|&t| turn(lo + t) > CORNER_TURN).collect();
    if corners.is_empty() {
        corners.push(0);
    }
    // φ(t) = ∫ ds/h from sample lo to lo + t (t = 0..=m, cyclic).
    let mut phi = Vec::with_capacity(m + 1);
    phi.push(0.0);
    for t in 0..m {
        let (i, j) = (lo + t, lo + (t + 1) % m);
        let (p, q) = (b.points[i], b.points[j]);
        let ds = (q[0] - p[0]).hypot(q[1] - p[1]);
        phi.push(phi[t] + ds * 0.5 * (1.0 / h[i] + 1.0 / h[j]));
    }
    let total = phi[m];
    let at = |x: f64| -> [f64; 2] {
        // Point at φ = x (mod total).
        let x = x.rem_euclid(total);
        let t = phi.partition_point(|&v| v <= x).clamp(1, m) - 1;
        let (i, j) = (lo + t, lo + (t + 1) % m);
        let w = if phi[t + 1] > phi[t] {
            ((x - phi[t]) / (phi[t + 1] - phi[t])).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (p, q) = (b.points[i], b.points[j]);
        [p[0] + w * (q[0] - p[0]), p[1] + w * (q[1] - p[1])]
    };
    let mut out = Vec::new();
    let nc = corners.len();
    for c in 0..nc {
        let (a, z) = (phi[corners[c]], phi[corners[(c + 1) % nc]]);
        let span = if c + 1 == nc { z + total - a } else { z - a };
        let min_pieces = if nc == 1 { 6.0 } else { 1.0 };
        let count = span.ceil().max(min_pieces) as usize;
        for p in 0..count {
            out.push(at(a + span * p as f64 / count as f64));
        }
    }
    out
}

/// The body-fitted T6 mesh of a region: samples its boundary, sizes the elements from the
/// medial discs and curvature, resamples and triangulates (module docs).
pub fn body_fitted(geometry: &crate::geometry::Geometry, s: &Sizing) -> Result<TriMesh> {
    let spacing = (0.1 * s.min_element.max(0.25 * s.max_element / s.elements_across))
        .max(s.min_element * 0.5);
    let b = Boundary::sample(geometry, spacing);
    let balls = crate::feature::medial_balls(&b, 2.0 * s.max_element * s.elements_across);
    let h = size_field(&b, &balls, s);
    let loops: Vec<Vec<[f64; 2]>> = (0..geometry.loops.len())
        .map(|k| resample_loop(&b, &h, k))
        .collect();
    triangulate(&loops, s)
}

/// Triangulates the region bounded by `loops` (solid on the left; other loops are not part
/// of it) with Ruppert refinement and builds quadratic triangles.
pub fn triangulate(loops: &[Vec<[f64; 2]>], s: &Sizing) -> Result<TriMesh> {
    let mut vertices = Vec::new();
    let mut edges = Vec::new();
    for lp in loops {
        let first = vertices.len();
        let n = lp.len();
        for (i, p) in lp.iter().enumerate() {
            vertices.push(Point2::new(p[0], p[1]));
            edges.push([first + i, first + (i + 1) % n]);
        }
    }
    if vertices.len() * 4 > s.max_nodes {
        return Err(VerifyError::Budget { limit: s.max_nodes });
    }
    let mut conflicts = Vec::new();
    let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::try_bulk_load_cdt(
        vertices.clone(),
        edges,
        |e| conflicts.push(e),
    )
    .map_err(|e| VerifyError::Outline(format!("cannot triangulate: {e:?}")))?;
    if let Some(e) = conflicts.first() {
        let p = vertices[e[0].min(vertices.len() - 1)];
        return Err(VerifyError::Outline(format!(
            "the outline crosses itself near ({:.3}, {:.3}) mm",
            p.x * 1e3,
            p.y * 1e3
        )));
    }
    let max_area = 3f64.sqrt() / 4.0 * s.max_element * s.max_element;
    let min_area = 0.25 * 3f64.sqrt() / 4.0 * s.min_element * s.min_element;
    let budget = (s.max_nodes / 4).saturating_sub(cdt.num_vertices());
    let result = cdt.refine(
        RefinementParameters::<f64>::new()
            .exclude_outer_faces(true)
            .with_angle_limit(AngleLimit::from_deg(s.angle_limit_deg))
            .with_max_allowed_area(max_area)
            .with_min_required_area(min_area)
            .with_max_additional_vertices(budget),
    );
    if !result.refinement_complete {
        return Err(VerifyError::Budget { limit: s.max_nodes });
    }
    let excluded: std::collections::HashSet<_> = result.excluded_faces.into_iter().collect();
    let mut index = vec![usize::MAX; cdt.num_vertices()];
    let mut nodes: Vec<[f64; 2]> = Vec::new();
    let mut corners: Vec<[usize; 3]> = Vec::new();
    for face in cdt.inner_faces() {
        if excluded.contains(&face.fix()) {
            continue;
        }
        let vs = face.vertices().map(|v| {
            let k = v.fix().index();
            if index[k] == usize::MAX {
                let p = v.position();
                index[k] = nodes.len();
                nodes.push([p.x, p.y]);
            }
            index[k]
        });
        corners.push(vs);
    }
    if corners.is_empty() {
        return Err(VerifyError::Outline("the outline encloses no area".into()));
    }
    Ok(quadratic(nodes, &corners))
}

/// Adds mid-side nodes to linear triangles and finds the boundary edges.
pub fn quadratic(mut nodes: Vec<[f64; 2]>, corners: &[[usize; 3]]) -> TriMesh {
    let n_vertices = nodes.len();
    let mut mid: HashMap<(usize, usize), (usize, u32)> = HashMap::new();
    let mut elements = Vec::with_capacity(corners.len());
    for c in corners {
        let mut el = [c[0], c[1], c[2], 0, 0, 0];
        for k in 0..3 {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            let key = (a.min(b), a.max(b));
            let entry = mid.entry(key).or_insert_with(|| {
                let (p, q) = (nodes[a], nodes[b]);
                nodes.push([0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1])]);
                (nodes.len() - 1, 0)
            });
            entry.1 += 1;
            el[3 + k] = entry.0;
        }
        elements.push(el);
    }
    let mut boundary = Vec::new();
    for el in &elements {
        for k in 0..3 {
            let (a, b) = (el[k], el[(k + 1) % 3]);
            if mid[&(a.min(b), a.max(b))].1 == 1 {
                boundary.push([a, el[3 + k], b]);
            }
        }
    }
    TriMesh {
        nodes,
        n_vertices,
        elements,
        boundary,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::feature::medial_balls;
    use crate::geometry::Geometry;

    #[test]
    fn plate_with_a_hole_is_meshed_exactly_and_refined_at_the_neck() {
        // Goal: the triangulation tiles the resampled loops exactly (every element inside,
        // every boundary vertex on a loop, the same area), which follow the outline within
        // their chords' sagitta, and makes elements about t/n_across at a neck of width
        // t = 1 mm between the hole and the plate edge.
        let (w, h) = (20e-3, 10e-3);
        let hole: Vec<[f64; 2]> = (0..200)
            .map(|k| {
                let t = -2.0 * std::f64::consts::PI * k as f64 / 200.0;
                [10e-3 + 4e-3 * t.cos(), 5e-3 + 4e-3 * t.sin()]
            })
            .collect();
        let outer = vec![[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]];
        let g = Geometry::new(vec![outer, hole]).unwrap();
        let b = Boundary::sample(&g, 0.02e-3);
        let balls = medial_balls(&b, 0.05);
        let s = Sizing {
            elements_across: 4.0,
            min_element: 20e-6,
            max_element: 1e-3,
            segment_angle: 15f64.to_radians(),
            gradation: 0.3,
            angle_limit_deg: 25.0,
            max_nodes: 1_000_000,
        };
        let hs = size_field(&b, &balls, &s);
        let loops: Vec<_> = (0..2).map(|k| resample_loop(&b, &hs, k)).collect();
        let m = triangulate(&loops, &s).unwrap();
        // The triangles tile the resampled loops exactly; those follow the outline's chords.
        let resampled: f64 = loops.iter().map(|l| crate::geometry::signed_area(l)).sum();
        let rg = Geometry::new(loops.clone()).unwrap();
        for (e, el) in m.elements.iter().enumerate() {
            let c = el[..3].iter().fold([0.0; 2], |a, &i| {
                [a[0] + m.nodes[i][0] / 3.0, a[1] + m.nodes[i][1] / 3.0]
            });
            assert!(
                rg.contains(c),
                "element {e} at {c:?} outside, area {}",
                m.element_area(e)
            );
        }
        let mut worst = 0.0f64;
        for e in &m.boundary {
            for &n in &[e[0], e[2]] {
                let p = m.nodes[n];
                let d = (0..loops.len())
                    .map(|k| rg.loop_distance(k, p).0)
                    .fold(f64::INFINITY, f64::min);
                worst = worst.max(d);
            }
        }
        assert!(
            (m.area() - resampled).abs() < 1e-9 * resampled,
            "{} vs {resampled}",
            m.area()
        );
        assert!(worst < 1e-12, "boundary vertex off the loops by {worst}");
        // Chords turning ≤ 15° on the R = 4 mm hole cut ≈ θ²/12 of its area.
        assert!(
            (m.area() - g.area()).abs() < 6e-4 * g.area(),
            "{} vs {}",
            m.area(),
            g.area()
        );
        // Elements near the neck (x = 10 mm, y between 9 and 10 mm) are within 2× the target
        // size t/n_across = 0.25 mm (Ruppert grades the interior from the boundary spacing).
        let mut neck = 0.0f64;
        for (e, el) in m.elements.iter().enumerate() {
            let c = el[..3].iter().fold([0.0; 2], |a, &i| {
                [a[0] + m.nodes[i][0] / 3.0, a[1] + m.nodes[i][1] / 3.0]
            });
            if (c[0] - 10e-3).abs() < 0.2e-3 && c[1] > 9e-3 {
                neck = neck.max((2.0 * m.element_area(e)).sqrt());
            }
        }
        assert!(
            neck > 0.0 && neck < 0.5e-3,
            "neck element size {neck} (target 0.25 mm)"
        );
        let (lo, hi) = m.edge_range();
        assert!(
            lo > 0.5 * s.min_element && hi < 1.6 * s.max_element,
            "{lo} {hi}"
        );
        // Every boundary edge lies on a loop: its mid node is on the plate edge or the hole.
        for e in &m.boundary {
            let p = m.nodes[e[1]];
            let on_edge = p[0].abs() < 1e-12
                || (p[0] - w).abs() < 1e-12
                || p[1].abs() < 1e-12
                || (p[1] - h).abs() < 1e-12;
            let r = ((p[0] - 10e-3).powi(2) + (p[1] - 5e-3).powi(2)).sqrt();
            // A chord of length c on the circle has its mid-point c²/(8R) inside.
            let (a, b) = (m.nodes[e[0]], m.nodes[e[2]]);
            let c = (b[0] - a[0]).hypot(b[1] - a[1]);
            let sagitta = c * c / (8.0 * 4e-3);
            assert!(
                on_edge || (r - 4e-3).abs() < 1.1 * sagitta + 1e-7,
                "boundary mid node {p:?}"
            );
        }
    }
}
