//! Display reduction of long series: what a figure draws instead of every sample.
//!
//! A 10 s record at 10 kHz has 10⁵ samples, but a figure 800 px wide has about 700 pixel
//! columns. Two reductions keep the picture while dropping the samples a reader cannot see;
//! neither is plain decimation (every k-th sample), which hides peaks.
//!
//! * [`m4`] for series whose abscissa never decreases (time series): per pixel column the
//!   first, the lowest, the highest and the last sample (Jugel, Jerzak, Hackenbroich & Markl,
//!   "M4: A Visualization-Oriented Time Series Data Aggregation", PVLDB 7(10), 2014). A line
//!   through these at most 4 samples per column rasterizes like the line through all of them,
//!   and the min/max envelope of every column is kept exactly.
//! * [`douglas_peucker`] for curves in the plane (hysteresis loops, 2D paths): the
//!   Ramer–Douglas–Peucker simplification (Douglas & Peucker, The Canadian Cartographer
//!   10(2), 1973) with a tolerance below one pixel, so every dropped sample lies within the
//!   tolerance of the drawn polyline. It runs on windows of [`DP_WINDOW`] samples whose end
//!   points are always kept, which bounds the work at O(n · window) for any input.
//!
//! Both work on points already in pixel coordinates and return the indices of the samples
//! to draw, in order.

/// The largest number of samples one Douglas–Peucker window holds.
pub const DP_WINDOW: usize = 4096;

/// M4 aggregation (Jugel et al. 2014) of a series in pixel coordinates whose x never
/// decreases: for each pixel column ⌊x⌋ the indices of its first, lowest, highest and last
/// point, in order, without repeats. At most 4 per column.
pub fn m4(points: &[(f64, f64)]) -> Vec<usize> {
    let mut keep = Vec::new();
    let mut start = 0;
    while start < points.len() {
        let column = points[start].0.floor();
        let mut end = start + 1;
        while end < points.len() && points[end].0.floor() == column {
            end += 1;
        }
        let (mut lo, mut hi) = (start, start);
        for k in start..end {
            if points[k].1 < points[lo].1 {
                lo = k;
            }
            if points[k].1 > points[hi].1 {
                hi = k;
            }
        }
        let mut four = [start, lo, hi, end - 1];
        four.sort_unstable();
        for k in four {
            if keep.last() != Some(&k) {
                keep.push(k);
            }
        }
        start = end;
    }
    keep
}

/// Whether the abscissae never decrease (the precondition of [`m4`]).
pub fn is_monotone(points: &[(f64, f64)]) -> bool {
    points.windows(2).all(|w| w[1].0 >= w[0].0)
}

/// Distance from `p` to the segment `a`–`b`.
pub fn segment_distance(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (cx, cy) = (a.0 + t * dx, a.1 + t * dy);
    ((p.0 - cx).powi(2) + (p.1 - cy).powi(2)).sqrt()
}

/// Ramer–Douglas–Peucker simplification with tolerance `epsilon` (in the units of the
/// points), on windows of at most [`DP_WINDOW`] points. Returns the kept indices in order;
/// the first and last point are always kept, and every dropped point lies within `epsilon`
/// of the segment between the kept points around it.
pub fn douglas_peucker(points: &[(f64, f64)], epsilon: f64) -> Vec<usize> {
    let n = points.len();
    if n <= 2 {
        return (0..n).collect();
    }
    let mut keep = vec![false; n];
    let mut stack: Vec<(usize, usize)> = Vec::new();
    let mut w0 = 0;
    while w0 < n - 1 {
        let w1 = (w0 + DP_WINDOW - 1).min(n - 1);
        keep[w0] = true;
        keep[w1] = true;
        stack.push((w0, w1));
        while let Some((a, b)) = stack.pop() {
            let (mut worst, mut far) = (0.0, a);
            for k in a + 1..b {
                let d = segment_distance(points[k], points[a], points[b]);
                if d > worst {
                    worst = d;
                    far = k;
                }
            }
            if worst > epsilon {
                keep[far] = true;
                stack.push((a, far));
                stack.push((far, b));
            }
        }
        w0 = w1;
    }
    (0..n).filter(|&k| keep[k]).collect()
}

/// The indices of the distinct pixel cells ⌊x⌋, ⌊y⌋ of a point cloud, first point of each
/// cell, in order: markers drawn on top of each other are drawn once.
pub fn distinct_cells(points: &[(f64, f64)]) -> Vec<usize> {
    let mut seen = std::collections::HashSet::new();
    (0..points.len())
        .filter(|&k| seen.insert((points[k].0.floor() as i64, points[k].1.floor() as i64)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random sequence in [-1, 1) (64-bit LCG, Knuth's MMIX constants).
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
            })
            .collect()
    }

    #[test]
    fn m4_keeps_every_column_envelope_jugel_2014() {
        // Reference: Jugel et al., PVLDB 7(10), 2014, M4 aggregation: per pixel column the
        // first, last, minimum and maximum tuple. Goal: on 10⁵ noisy samples with one
        // single-sample spike over 700 columns, every column keeps its exact min, max, first
        // and last value, the spike survives, and at most 4 points per column are drawn.
        let n = 100_000;
        let r = noise(n, 7);
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|k| (700.0 * k as f64 / n as f64, 200.0 + 30.0 * r[k]))
            .collect();
        pts[61_234].1 = 480.0;
        let keep = m4(&pts);
        assert!(keep.len() <= 4 * 700, "{} points", keep.len());
        assert!(keep.windows(2).all(|w| w[0] < w[1]), "in order");
        assert!(keep.contains(&61_234), "the spike is drawn");
        for col in 0..700 {
            let all: Vec<usize> = (0..n)
                .filter(|&k| pts[k].0.floor() as usize == col)
                .collect();
            let kept: Vec<usize> = keep
                .iter()
                .copied()
                .filter(|&k| pts[k].0.floor() as usize == col)
                .collect();
            let ext = |ix: &[usize], f: fn(f64, f64) -> f64, init: f64| {
                ix.iter().fold(init, |m, &k| f(m, pts[k].1))
            };
            assert_eq!(
                ext(&all, f64::min, f64::MAX),
                ext(&kept, f64::min, f64::MAX)
            );
            assert_eq!(
                ext(&all, f64::max, f64::MIN),
                ext(&kept, f64::max, f64::MIN)
            );
            assert_eq!(all.first(), kept.first(), "column {col}: first");
            assert_eq!(all.last(), kept.last(), "column {col}: last");
        }
    }

    #[test]
    fn douglas_peucker_stays_within_tolerance_douglas_peucker_1973() {
        // Reference: Douglas & Peucker (1973): every removed point lies within ε of the
        // simplified polyline. Goal: on a noisy hysteresis-like loop of 10⁵ points (several
        // windows) with a one-sample peak, every dropped point is within ε = 0.5 px of the
        // chord between its kept neighbours, the peak is kept, and the loop shrinks > 10×.
        let n = 100_000;
        let r = noise(n, 3);
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|k| {
                let t = 20.0 * std::f64::consts::PI * k as f64 / n as f64;
                (
                    350.0 + 300.0 * t.sin(),
                    250.0 + 200.0 * (t + 0.3).sin() + 0.05 * r[k],
                )
            })
            .collect();
        pts[42_000].1 += 25.0;
        let eps = 0.5;
        let keep = douglas_peucker(&pts, eps);
        assert!(keep.contains(&42_000), "the peak is drawn");
        assert_eq!((keep[0], *keep.last().unwrap()), (0, n - 1));
        assert!(keep.len() * 10 < n, "{} of {n} kept", keep.len());
        for w in keep.windows(2) {
            for k in w[0] + 1..w[1] {
                let d = segment_distance(pts[k], pts[w[0]], pts[w[1]]);
                assert!(d <= eps, "point {k} is {d} px from the drawn line");
            }
        }
    }

    #[test]
    fn short_series_and_clouds() {
        assert_eq!(douglas_peucker(&[(0.0, 0.0), (1.0, 1.0)], 0.5), [0, 1]);
        assert_eq!(m4(&[]), Vec::<usize>::new());
        assert!(is_monotone(&[(0.0, 1.0), (0.0, 2.0), (1.0, 0.0)]));
        assert!(!is_monotone(&[(1.0, 1.0), (0.0, 2.0)]));
        let cloud = [(0.2, 0.2), (0.7, 0.9), (1.5, 0.1), (0.1, 0.3)];
        assert_eq!(distinct_cells(&cloud), [0, 2]);
        assert!((segment_distance((0.0, 1.0), (-1.0, 0.0), (1.0, 0.0)) - 1.0).abs() < 1e-15);
        assert!((segment_distance((3.0, 4.0), (0.0, 0.0), (0.0, 0.0)) - 5.0).abs() < 1e-15);
    }
}
