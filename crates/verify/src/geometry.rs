//! The outline as a planar region: closed loops with the solid on their left (outer
//! boundaries counter-clockwise, holes clockwise, as [`crate::outline`] writes them),
//! grouped into connected solid parts.

use crate::error::{Result, VerifyError};

/// One connected solid part: an outer loop and the holes inside it.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    /// Index of the outer (counter-clockwise) loop.
    pub outer: usize,
    /// Indices of its holes (clockwise loops).
    pub holes: Vec<usize>,
    /// Area \[m²\] (outer minus holes).
    pub area: f64,
    /// Area centroid \[m\].
    pub centroid: [f64; 2],
}

/// The outline: loops and the parts they bound.
#[derive(Debug, Clone, PartialEq)]
pub struct Geometry {
    /// Closed loops (first point not repeated) \[m\], solid on the left.
    pub loops: Vec<Vec<[f64; 2]>>,
    /// Connected solid parts.
    pub parts: Vec<Part>,
    /// Part of each loop.
    pub part_of_loop: Vec<usize>,
}

/// Shoelace area and first moments of a closed polygon.
fn moments(p: &[[f64; 2]]) -> (f64, [f64; 2]) {
    let n = p.len();
    let (mut a, mut sx, mut sy) = (0.0, 0.0, 0.0);
    for i in 0..n {
        let (u, v) = (p[i], p[(i + 1) % n]);
        let c = u[0] * v[1] - v[0] * u[1];
        a += c;
        sx += (u[0] + v[0]) * c;
        sy += (u[1] + v[1]) * c;
    }
    (0.5 * a, [sx / 6.0, sy / 6.0])
}

/// Shoelace signed area of a closed polygon \[m²\] (positive counter-clockwise).
pub fn signed_area(p: &[[f64; 2]]) -> f64 {
    moments(p).0
}

/// Winding number of the closed polygon `poly` around `p` (Sunday's crossing rule).
pub fn winding_number(poly: &[[f64; 2]], p: [f64; 2]) -> i32 {
    let n = poly.len();
    let mut w = 0;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        let side = (b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1]);
        if a[1] <= p[1] {
            if b[1] > p[1] && side > 0.0 {
                w += 1;
            }
        } else if b[1] <= p[1] && side < 0.0 {
            w -= 1;
        }
    }
    w
}

/// Distance from `p` to the segment `a`–`b` and the nearest point.
pub fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> (f64, [f64; 2]) {
    let d = [b[0] - a[0], b[1] - a[1]];
    let l2 = d[0] * d[0] + d[1] * d[1];
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [a[0] + t * d[0], a[1] + t * d[1]];
    ((p[0] - q[0]).hypot(p[1] - q[1]), q)
}

impl Geometry {
    /// Groups the loops into parts. Each loop needs at least three finite points and a
    /// non-zero area; each hole must lie inside an outer loop.
    pub fn new(loops: Vec<Vec<[f64; 2]>>) -> Result<Self> {
        if loops.is_empty() {
            return Err(VerifyError::Outline("the outline has no loop".into()));
        }
        let mut areas = Vec::with_capacity(loops.len());
        for (k, lp) in loops.iter().enumerate() {
            if lp.len() < 3 || lp.iter().flatten().any(|v| !v.is_finite()) {
                return Err(VerifyError::Outline(format!(
                    "loop {k} has {} points or a non-finite coordinate (needs ≥ 3 finite points)",
                    lp.len()
                )));
            }
            let (a, _) = moments(lp);
            if a == 0.0 {
                return Err(VerifyError::Outline(format!("loop {k} encloses no area")));
            }
            areas.push(a);
        }
        let outers: Vec<usize> = (0..loops.len()).filter(|&k| areas[k] > 0.0).collect();
        let mut parts: Vec<Part> = outers
            .iter()
            .map(|&k| Part {
                outer: k,
                holes: Vec::new(),
                area: 0.0,
                centroid: [0.0; 2],
            })
            .collect();
        let mut part_of_loop = vec![usize::MAX; loops.len()];
        for (i, &k) in outers.iter().enumerate() {
            part_of_loop[k] = i;
        }
        for k in (0..loops.len()).filter(|&k| areas[k] < 0.0) {
            // The smallest outer loop that contains the hole.
            let p = loops[k][0];
            let owner = outers
                .iter()
                .enumerate()
                .filter(|&(_, &o)| winding_number(&loops[o], p) != 0)
                .min_by(|a, b| areas[*a.1].total_cmp(&areas[*b.1]))
                .map(|(i, _)| i)
                .ok_or_else(|| {
                    VerifyError::Outline(format!(
                        "hole loop {k} at ({:.3}, {:.3}) mm lies in no outer loop",
                        p[0] * 1e3,
                        p[1] * 1e3
                    ))
                })?;
            parts[owner].holes.push(k);
            part_of_loop[k] = owner;
        }
        for part in &mut parts {
            let (mut a, mut s) = (0.0, [0.0; 2]);
            for &k in std::iter::once(&part.outer).chain(&part.holes) {
                let (ak, sk) = moments(&loops[k]);
                a += ak;
                s = [s[0] + sk[0], s[1] + sk[1]];
            }
            part.area = a;
            part.centroid = [s[0] / a, s[1] / a];
        }
        Ok(Self {
            loops,
            parts,
            part_of_loop,
        })
    }

    /// Is `p` inside the solid (odd total winding of all loops)?
    pub fn contains(&self, p: [f64; 2]) -> bool {
        self.loops
            .iter()
            .map(|l| winding_number(l, p))
            .sum::<i32>()
            .rem_euclid(2)
            == 1
    }

    /// Solid area \[m²\].
    pub fn area(&self) -> f64 {
        self.parts.iter().map(|p| p.area).sum()
    }

    /// Distance from `p` to loop `k` and the nearest point on it.
    pub fn loop_distance(&self, k: usize, p: [f64; 2]) -> (f64, [f64; 2]) {
        let lp = &self.loops[k];
        let n = lp.len();
        (0..n)
            .map(|i| segment_distance(p, lp[i], lp[(i + 1) % n]))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .expect("loops have ≥ 3 points")
    }

    /// Parts with a loop within `radius` of `p`, or that contain `p`.
    pub fn parts_near(&self, p: [f64; 2], radius: f64) -> Vec<usize> {
        let mut out: Vec<usize> = (0..self.loops.len())
            .filter(|&k| self.loop_distance(k, p).0 <= radius)
            .map(|k| self.part_of_loop[k])
            .collect();
        if self.contains(p) {
            for (i, part) in self.parts.iter().enumerate() {
                let inside = winding_number(&self.loops[part.outer], p) != 0
                    && part
                        .holes
                        .iter()
                        .all(|&h| winding_number(&self.loops[h], p) == 0);
                if inside {
                    out.push(i);
                }
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64, ccw: bool) -> Vec<[f64; 2]> {
        let mut r = vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        if !ccw {
            r.reverse();
        }
        r
    }

    #[test]
    fn plate_with_hole_and_an_island_in_the_hole_are_two_parts() {
        // Goal: holes go to the smallest enclosing outer loop; areas and centroids are exact.
        let g = Geometry::new(vec![
            rect(0.0, 0.0, 4.0, 2.0, true),
            rect(1.0, 0.5, 3.0, 1.5, false),
            rect(1.5, 0.75, 2.0, 1.25, true),
        ])
        .unwrap();
        assert_eq!(g.parts.len(), 2);
        assert_eq!(g.parts[0].holes, vec![1]);
        assert!((g.parts[0].area - 6.0).abs() < 1e-12);
        assert!((g.parts[0].centroid[0] - 2.0).abs() < 1e-12);
        assert!((g.parts[1].area - 0.25).abs() < 1e-12);
        assert!(g.contains([0.5, 0.5]) && !g.contains([1.2, 1.0]) && g.contains([1.7, 1.0]));
        assert_eq!(g.parts_near([1.7, 1.0], 0.01), vec![1]);
        assert_eq!(g.parts_near([0.0, 1.0], 0.01), vec![0]);
        assert!(Geometry::new(vec![rect(0.0, 0.0, 1.0, 1.0, false)]).is_err());
    }
}
