//! A cloud of points in the plane summarized for a figure: its mean, its covariance ellipse
//! and its convex hull. Used for the tracking error e = q − q_ref in the plane (Figure 11's
//! error view), where 10⁴–10⁶ samples would make a heavy and unreadable scatter plot: the
//! mean shows a bias, the ellipse the spread and its direction (lag along the path, noise),
//! the hull every extreme sample.

/// Mean, covariance and convex hull of a point cloud.
#[derive(Debug, Clone, PartialEq)]
pub struct Cloud {
    /// Mean (x̄, ȳ).
    pub mean: (f64, f64),
    /// Covariance [[σxx, σxy], [σxy, σyy]] (divided by n).
    pub cov: [[f64; 2]; 2],
    /// Convex hull, counter-clockwise, without repeating the first point.
    pub hull: Vec<(f64, f64)>,
}

impl Cloud {
    /// Summarizes the finite points; `None` when there is none.
    pub fn of(points: &[(f64, f64)]) -> Option<Cloud> {
        let pts: Vec<(f64, f64)> = points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        if pts.is_empty() {
            return None;
        }
        let n = pts.len() as f64;
        let mean = (
            pts.iter().map(|p| p.0).sum::<f64>() / n,
            pts.iter().map(|p| p.1).sum::<f64>() / n,
        );
        let mut cov = [[0.0; 2]; 2];
        for (x, y) in &pts {
            let (dx, dy) = (x - mean.0, y - mean.1);
            cov[0][0] += dx * dx / n;
            cov[0][1] += dx * dy / n;
            cov[1][1] += dy * dy / n;
        }
        cov[1][0] = cov[0][1];
        Some(Cloud {
            mean,
            cov,
            hull: convex_hull(pts),
        })
    }

    /// `n` points of the ellipse (p − x̄)ᵀ Σ⁻¹ (p − x̄) = k² (k standard deviations), from the
    /// eigen-decomposition of the 2 × 2 covariance; closed (first point repeated).
    pub fn ellipse(&self, k: f64, n: usize) -> Vec<(f64, f64)> {
        let [[a, b], [_, d]] = self.cov;
        let half_trace = 0.5 * (a + d);
        let root = (0.25 * (a - d).powi(2) + b * b).sqrt();
        let (l1, l2) = (half_trace + root, (half_trace - root).max(0.0));
        // Eigenvector of l1: (b, l1 − a), or an axis when the matrix is diagonal.
        let angle = if b.abs() > 1e-300 {
            (l1 - a).atan2(b)
        } else if a >= d {
            0.0
        } else {
            std::f64::consts::FRAC_PI_2
        };
        let (c, s) = (angle.cos(), angle.sin());
        let (r1, r2) = (k * l1.sqrt(), k * l2.sqrt());
        (0..=n)
            .map(|i| {
                let t = std::f64::consts::TAU * i as f64 / n as f64;
                let (u, v) = (r1 * t.cos(), r2 * t.sin());
                (self.mean.0 + c * u - s * v, self.mean.1 + s * u + c * v)
            })
            .collect()
    }
}

/// Convex hull by Andrew's monotone chain (Andrew, Information Processing Letters 9(5),
/// 1979), counter-clockwise, collinear points dropped.
pub fn convex_hull(mut pts: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(2 * pts.len());
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &(f64, f64)>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_a_square_with_inner_points_is_its_corners_andrew_1979() {
        // Reference: the convex hull of the unit square's corners, its edge midpoints and
        // inner points is the four corners, counter-clockwise (Andrew 1979).
        let mut pts = vec![(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.5, 0.0)];
        pts.extend((1..10).map(|i| (0.1 * i as f64, 0.05 + 0.09 * i as f64)));
        let hull = convex_hull(pts);
        assert_eq!(hull, [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]);
        assert_eq!(convex_hull(vec![(1.0, 2.0)]), [(1.0, 2.0)]);
    }

    #[test]
    fn covariance_ellipse_is_the_k_sigma_level_set() {
        // Reference: for a cloud with covariance Σ, the k-σ ellipse is the level set
        // (p − x̄)ᵀ Σ⁻¹ (p − x̄) = k². Goal: on the four points (±3, ±1) rotated by 30° and
        // shifted, the mean, the covariance (σ² = 9 and 1 along the rotated axes) and every
        // ellipse point match to 1e-12.
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let pts: Vec<(f64, f64)> = [(3.0, 1.0), (-3.0, 1.0), (3.0, -1.0), (-3.0, -1.0)]
            .iter()
            .map(|&(u, v)| (5.0 + c * u - s * v, -2.0 + s * u + c * v))
            .collect();
        let cloud = Cloud::of(&pts).unwrap();
        assert!((cloud.mean.0 - 5.0).abs() < 1e-12 && (cloud.mean.1 + 2.0).abs() < 1e-12);
        let [[a, b], [_, d]] = cloud.cov;
        assert!((a + d - 10.0).abs() < 1e-12 && (a * d - b * b - 9.0).abs() < 1e-12);
        let det = a * d - b * b;
        for (x, y) in cloud.ellipse(2.0, 36) {
            let (dx, dy) = (x - 5.0, y + 2.0);
            let q = (d * dx * dx - 2.0 * b * dx * dy + a * dy * dy) / det;
            assert!((q - 4.0).abs() < 1e-12, "{q}");
        }
        assert_eq!(cloud.hull.len(), 4);
        assert!(Cloud::of(&[(f64::NAN, 0.0)]).is_none());
    }
}
