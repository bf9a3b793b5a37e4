//! Local feature size of the outline by the shrinking-ball algorithm (Ma, Bai & Wang 2012,
//! "3D medial axis point approximation using nearest neighbors and the normal field", The
//! Visual Computer 28:7–19): for every boundary sample `p` with unit normal `n` into one side,
//! the largest disc tangent at `p` that contains no other boundary sample. Its centre lies on
//! the medial axis of that side, its diameter is the local width there.
//!
//! Starting from a disc of radius `r_cap`, the disc through `p` and the nearest sample `q`
//! inside it, `r = |q − p|² / (2 n·(q − p))`, replaces it until no sample is inside.
//! Nearest-neighbour queries search a uniform grid of the samples ring by ring. (A walk on
//! spade's Delaunay triangulation was tried first: along the long straight runs of collinear
//! samples on the domain edges its greedy walk took seconds.)
//!
//! A disc is **across** the part when its two contact points are at least 120° apart as seen
//! from its centre: it then spans the solid (a ligament) or the void (a gap) from one side to
//! the other, rather than fitting the curvature of a corner (contacts close together) — a
//! right-angle corner has 90°, a parallel-sided neck 180°, a wedge sharper than 60° counts.

use rayon::prelude::*;

use crate::geometry::Geometry;

/// Smallest contact angle (as its cosine) of a disc that spans the part: 120°.
pub const ACROSS_COS: f64 = -0.5;

/// Dense samples of every loop with normals into the solid.
#[derive(Debug, Clone)]
pub struct Boundary {
    /// Sample points \[m\].
    pub points: Vec<[f64; 2]>,
    /// Unit normals into the solid (left of the loop direction).
    pub normals: Vec<[f64; 2]>,
    /// Loop of each sample.
    pub loop_of: Vec<usize>,
    /// Samples of loop `k` are `start[k]..start[k + 1]`.
    pub start: Vec<usize>,
    /// Arc length of each sample from its loop's first sample \[m\].
    pub arc: Vec<f64>,
    /// Length of each loop \[m\].
    pub length: Vec<f64>,
}

impl Boundary {
    /// Samples every loop: its vertices plus equal subdivisions of edges longer than `spacing`.
    pub fn sample(geometry: &Geometry, spacing: f64) -> Self {
        let mut b = Boundary {
            points: Vec::new(),
            normals: Vec::new(),
            loop_of: Vec::new(),
            start: vec![0],
            arc: Vec::new(),
            length: Vec::new(),
        };
        for (k, lp) in geometry.loops.iter().enumerate() {
            let n = lp.len();
            let first = b.points.len();
            let mut s = 0.0;
            for i in 0..n {
                let (p, q) = (lp[i], lp[(i + 1) % n]);
                let len = (q[0] - p[0]).hypot(q[1] - p[1]);
                let m = (len / spacing).ceil().max(1.0) as usize;
                for j in 0..m {
                    let t = j as f64 / m as f64;
                    b.points
                        .push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
                    b.arc.push(s + t * len);
                    b.loop_of.push(k);
                }
                s += len;
            }
            b.length.push(s);
            let m = b.points.len() - first;
            for i in 0..m {
                let a = b.points[first + (i + m - 1) % m];
                let c = b.points[first + (i + 1) % m];
                let t = [c[0] - a[0], c[1] - a[1]];
                let l = t[0].hypot(t[1]).max(f64::MIN_POSITIVE);
                b.normals.push([-t[1] / l, t[0] / l]);
            }
            b.start.push(b.points.len());
        }
        b
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// No samples?
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The samples of loop `k` before and after sample `i` (cyclic).
    pub fn neighbours(&self, i: usize) -> (usize, usize) {
        let k = self.loop_of[i];
        let (a, b) = (self.start[k], self.start[k + 1]);
        let prev = if i == a { b - 1 } else { i - 1 };
        let next = if i + 1 == b { a } else { i + 1 };
        (prev, next)
    }
}

/// A maximal disc tangent to the boundary at one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    /// Radius \[m\] (`r_cap` if nothing limited it).
    pub radius: f64,
    /// Centre \[m\].
    pub center: [f64; 2],
    /// The other sample it touches (`None`: capped).
    pub contact: Option<usize>,
    /// Cosine of the angle between the two contacts seen from the centre (1 when capped).
    pub contact_cos: f64,
}

impl Ball {
    /// Does the disc span the part from one side to the other (module docs)?
    pub fn is_across(&self) -> bool {
        self.contact.is_some() && self.contact_cos <= ACROSS_COS
    }
}

/// Medial discs on both sides of every sample.
#[derive(Debug, Clone)]
pub struct Balls {
    /// Discs in the solid.
    pub solid: Vec<Ball>,
    /// Discs in the void (holes and the outside).
    pub void: Vec<Ball>,
}

/// Uniform grid of the samples for nearest-neighbour queries.
struct Grid<'a> {
    points: &'a [[f64; 2]],
    origin: [f64; 2],
    cell: f64,
    n: [usize; 2],
    /// Samples of cell `c` are `items[start[c]..start[c + 1]]`.
    start: Vec<usize>,
    items: Vec<usize>,
}

impl<'a> Grid<'a> {
    fn new(points: &'a [[f64; 2]], cell: f64) -> Self {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for p in points {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let n = [0, 1].map(|k| (((hi[k] - lo[k]) / cell).floor() as usize + 1).min(1 << 14));
        let cell = cell.max((hi[0] - lo[0]).max(hi[1] - lo[1]) / (1 << 14) as f64);
        let mut g = Grid {
            points,
            origin: lo,
            cell,
            n,
            start: vec![0; n[0] * n[1] + 1],
            items: vec![0; points.len()],
        };
        for p in points {
            let c = g.cell_of(*p);
            g.start[c + 1] += 1;
        }
        for c in 0..n[0] * n[1] {
            g.start[c + 1] += g.start[c];
        }
        let mut fill = g.start.clone();
        for (i, p) in points.iter().enumerate() {
            let c = g.cell_of(*p);
            g.items[fill[c]] = i;
            fill[c] += 1;
        }
        g
    }

    fn coords(&self, p: [f64; 2]) -> [usize; 2] {
        [0, 1].map(|k| {
            (((p[k] - self.origin[k]) / self.cell).floor().max(0.0) as usize).min(self.n[k] - 1)
        })
    }

    fn cell_of(&self, p: [f64; 2]) -> usize {
        let [i, j] = self.coords(p);
        j * self.n[0] + i
    }

    /// The sample nearest to `c` and its distance.
    fn nearest(&self, c: [f64; 2]) -> (usize, f64) {
        let [ci, cj] = self.coords(c);
        let (mut best, mut best_d) = (usize::MAX, f64::INFINITY);
        let max_ring = self.n[0].max(self.n[1]);
        for ring in 0..=max_ring {
            // Every sample in this ring or beyond is at least (ring − 1)·cell away (the clamp
            // of c onto the grid is a projection onto a convex box).
            if ring >= 1 && (ring - 1) as f64 * self.cell > best_d {
                break;
            }
            let (i0, i1) = (ci as isize - ring as isize, ci as isize + ring as isize);
            let (j0, j1) = (cj as isize - ring as isize, cj as isize + ring as isize);
            for j in j0..=j1 {
                if j < 0 || j >= self.n[1] as isize {
                    continue;
                }
                let edge_row = j == j0 || j == j1;
                let mut i = i0;
                while i <= i1 {
                    if i >= 0 && i < self.n[0] as isize {
                        let cell = j as usize * self.n[0] + i as usize;
                        for &k in &self.items[self.start[cell]..self.start[cell + 1]] {
                            let p = self.points[k];
                            let d = (p[0] - c[0]).hypot(p[1] - c[1]);
                            if d < best_d {
                                (best, best_d) = (k, d);
                            }
                        }
                    }
                    // Inner rows: only the two end cells belong to the ring.
                    i += if edge_row || i == i1 {
                        1
                    } else {
                        (i1 - i0).max(1)
                    };
                }
            }
        }
        (best, best_d)
    }
}

/// Shrinking-ball medial discs of every sample on both sides, radii capped at `r_cap`.
pub fn medial_balls(b: &Boundary, r_cap: f64) -> Balls {
    let spacing = b.length.iter().sum::<f64>() / b.len().max(1) as f64;
    // About eight cells across the largest disc: a query scans at most ~19² cells.
    let grid = Grid::new(&b.points, (4.0 * spacing).max(r_cap / 8.0));
    let ball = |i: usize, sign: f64| -> Ball {
        let p = b.points[i];
        let n = [sign * b.normals[i][0], sign * b.normals[i][1]];
        let mut r = r_cap;
        let mut contact = None;
        for _ in 0..100 {
            let c = [p[0] + r * n[0], p[1] + r * n[1]];
            let (j, d) = grid.nearest(c);
            let q = b.points[j];
            if j == i || d >= r * (1.0 - 1e-9) {
                break;
            }
            let pq = [q[0] - p[0], q[1] - p[1]];
            let l2 = pq[0] * pq[0] + pq[1] * pq[1];
            let denom = 2.0 * (n[0] * pq[0] + n[1] * pq[1]);
            if l2 <= 1e-24 {
                // Two loops touch: a zero-width neck.
                r = 0.0;
                contact = Some(j);
                break;
            }
            if denom <= 0.0 {
                break;
            }
            let r_new = l2 / denom;
            if r_new >= r {
                break;
            }
            r = r_new;
            contact = Some(j);
        }
        let center = [p[0] + r * n[0], p[1] + r * n[1]];
        let contact_cos = match contact {
            Some(j) if r > 0.0 => {
                let q = b.points[j];
                let u = [p[0] - center[0], p[1] - center[1]];
                let w = [q[0] - center[0], q[1] - center[1]];
                (u[0] * w[0] + u[1] * w[1]) / (r * r)
            }
            Some(_) => -1.0,
            None => 1.0,
        };
        Ball {
            radius: r,
            center,
            contact,
            contact_cos,
        }
    };
    let (solid, void) = rayon::join(
        || (0..b.len()).into_par_iter().map(|i| ball(i, 1.0)).collect(),
        || {
            (0..b.len())
                .into_par_iter()
                .map(|i| ball(i, -1.0))
                .collect()
        },
    );
    Balls { solid, void }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::samples::circle;

    #[test]
    fn annulus_width_and_hole_diameter_from_the_shrinking_ball() {
        // Reference: a ring between radii 9 and 10 mm is 1 mm wide everywhere and its hole
        // has an inscribed diameter of 18 mm. Goal: every solid disc spans the ring (across)
        // with diameter 1 mm ± 0.5 %, and the largest void disc of the hole is 18 mm ± 0.5 %.
        let g = Geometry::new(vec![
            circle([0.0, 0.0], 10e-3, 400, true),
            circle([0.0, 0.0], 9e-3, 400, false),
        ])
        .unwrap();
        let b = Boundary::sample(&g, 0.02e-3);
        let balls = medial_balls(&b, 50e-3);
        for s in &balls.solid {
            assert!(s.is_across());
            assert!((2.0 * s.radius - 1e-3).abs() < 0.005e-3, "{}", s.radius);
        }
        let hole = b.start[1]..b.start[2];
        let dmax = hole.map(|i| 2.0 * balls.void[i].radius).fold(0.0, f64::max);
        assert!((dmax - 18e-3).abs() < 0.09e-3, "{dmax}");
        // Outside the ring nothing limits the disc: capped.
        assert!(balls.void[0].contact.is_none() && balls.void[0].radius == 50e-3);
    }
}
