//! Tiny dense linear solver for the reduced (m+1)×(m+1) or (n+1)×(n+1) Newton systems.

/// Solves `A x = b` in place by Gaussian elimination with partial pivoting.
///
/// `a` is `k × k` row-major and is destroyed; `b` (length `k`) is overwritten by the solution.
/// A zero pivot produces non-finite entries, which the caller detects.
pub(crate) fn solve_in_place(a: &mut [f64], b: &mut [f64], k: usize) {
    debug_assert_eq!(a.len(), k * k);
    debug_assert_eq!(b.len(), k);
    for col in 0..k {
        // Pivot search.
        let mut piv = col;
        let mut best = a[col * k + col].abs();
        for r in col + 1..k {
            let v = a[r * k + col].abs();
            if v > best {
                best = v;
                piv = r;
            }
        }
        if piv != col {
            for j in 0..k {
                a.swap(col * k + j, piv * k + j);
            }
            b.swap(col, piv);
        }
        let d = a[col * k + col];
        for r in col + 1..k {
            let f = a[r * k + col] / d;
            if f != 0.0 {
                for j in col..k {
                    a[r * k + j] -= f * a[col * k + j];
                }
                b[r] -= f * b[col];
            }
        }
    }
    for col in (0..k).rev() {
        let mut s = b[col];
        for j in col + 1..k {
            s -= a[col * k + j] * b[j];
        }
        b[col] = s / a[col * k + col];
    }
}

#[cfg(test)]
mod tests {
    use super::solve_in_place;

    #[test]
    fn solves_indefinite_bordered_system() {
        // [[4, 1, 0], [1, 3, 1], [0, 1, -2]] x = [1, 2, 3]
        let a0 = [4.0, 1.0, 0.0, 1.0, 3.0, 1.0, 0.0, 1.0, -2.0];
        let b0 = [1.0, 2.0, 3.0];
        let mut a = a0;
        let mut b = b0;
        solve_in_place(&mut a, &mut b, 3);
        for r in 0..3 {
            let s: f64 = (0..3).map(|j| a0[r * 3 + j] * b[j]).sum();
            assert!((s - b0[r]).abs() < 1e-12, "row {r}: {s} vs {}", b0[r]);
        }
    }

    #[test]
    fn needs_pivoting() {
        let a0 = [0.0, 1.0, 1.0, 0.0];
        let mut a = a0;
        let mut b = [2.0, 3.0];
        solve_in_place(&mut a, &mut b, 2);
        assert_eq!(b, [3.0, 2.0]);
    }
}
