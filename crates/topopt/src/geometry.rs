//! Geometry checks of a density field at the ρ = ½ level: one-node hinges, the thinnest solid
//! member and the narrowest void gap (DECISIONS.md, "Robust formulation").
//!
//! * A **one-node hinge** is two solid elements joined only at a corner: a 2 × 2 block whose
//!   diagonal is solid and whose anti-diagonal is void. FE models transmit force through the
//!   shared node with no bending stiffness; the part cannot be made.
//! * Member and gap sizes use the **local thickness** (Hildebrand & Rüegsegger, "A new method
//!   for the model-independent assessment of thickness in three-dimensional images", J.
//!   Microscopy 185 (1997) 67–75): at a point of a set, the diameter of the largest disk inside
//!   the set that contains the point. Its minimum over the solid is the thinnest member; over
//!   the void (the outside of the domain counts as void) the narrowest gap. The element
//!   densities are interpolated bilinearly between element centres (the field whose ½-contour
//!   is the exported outline) on a grid `refine` times finer than the mesh, so sizes resolve
//!   to about `h/refine`.

/// A density field on the structured mesh (element `e = i·n_w + j`).
#[derive(Debug, Clone, Copy)]
pub struct Field<'a> {
    /// Elements along x.
    pub nl: usize,
    /// Elements along y.
    pub nw: usize,
    /// Element sizes (dx, dy) \[m\].
    pub h: (f64, f64),
    /// Densities, fem order.
    pub rho: &'a [f64],
}

/// Element indices `(i, j)` of the lower-left element of every 2 × 2 block with a one-node
/// hinge at level ½ (module docs).
pub fn one_node_hinges(f: &Field) -> Vec<(usize, usize)> {
    let solid = |i: usize, j: usize| f.rho[i * f.nw + j] >= 0.5;
    let mut out = Vec::new();
    for i in 0..f.nl.saturating_sub(1) {
        for j in 0..f.nw.saturating_sub(1) {
            let (a, b, c, d) = (
                solid(i, j),
                solid(i + 1, j),
                solid(i, j + 1),
                solid(i + 1, j + 1),
            );
            if (a && d && !b && !c) || (b && c && !a && !d) {
                out.push((i, j));
            }
        }
    }
    out
}

/// Largest |ρ_e − ρ_mirror(e)| over the mesh, for the mirror about `x = l/2`.
pub fn mirror_asymmetry(f: &Field) -> f64 {
    (0..f.nl * f.nw)
        .map(|e| {
            let (i, j) = (e / f.nw, e % f.nw);
            (f.rho[e] - f.rho[(f.nl - 1 - i) * f.nw + j]).abs()
        })
        .fold(0.0, f64::max)
}

/// Exact squared Euclidean distance transform in one dimension (Felzenszwalb & Huttenlocher,
/// "Distance transforms of sampled functions", Theory of Computing 8 (2012), Algorithm 1).
fn edt_1d(f: &[f64], out: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    let mut k = 0;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    let inter = |q: usize, p: usize| {
        ((f[q] + (q * q) as f64) - (f[p] + (p * p) as f64)) / (2.0 * q as f64 - 2.0 * p as f64)
    };
    for q in 1..n {
        if f[q] == f64::INFINITY {
            continue;
        }
        if f[v[k]] == f64::INFINITY {
            v[k] = q;
            continue;
        }
        let mut s = inter(q, v[k]);
        while s <= z[k] {
            k -= 1;
            s = inter(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    let mut k = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let d = q as f64 - v[k] as f64;
        *o = if f[v[k]] == f64::INFINITY {
            f64::INFINITY
        } else {
            d * d + f[v[k]]
        };
    }
}

/// Squared distance (in grid steps) from every point of an `nx × ny` grid to the nearest point
/// outside `inside` (row-major, x fastest).
fn distance_to_outside(inside: &[bool], nx: usize, ny: usize) -> Vec<f64> {
    let mut d: Vec<f64> = inside
        .iter()
        .map(|&s| if s { f64::INFINITY } else { 0.0 })
        .collect();
    let n = nx.max(ny);
    let (mut v, mut z, mut col, mut out) =
        (vec![0; n], vec![0.0; n + 1], vec![0.0; n], vec![0.0; n]);
    for y in 0..ny {
        edt_1d(&d[y * nx..(y + 1) * nx], &mut out[..nx], &mut v, &mut z);
        d[y * nx..(y + 1) * nx].copy_from_slice(&out[..nx]);
    }
    for x in 0..nx {
        for y in 0..ny {
            col[y] = d[y * nx + x];
        }
        edt_1d(&col[..ny], &mut out[..ny], &mut v, &mut z);
        for y in 0..ny {
            d[y * nx + x] = out[y];
        }
    }
    d
}

/// Smallest local thickness [in grid steps] over the points of `inside` that are `counted`
/// (module docs) and the grid point where it occurs; `None` if there are none. Disks are
/// painted from ridge points of the distance map (local maxima along an axis or a diagonal),
/// which contain the centres of the maximal disks.
fn min_local_thickness(
    inside: &[bool],
    counted: impl Fn(usize) -> bool,
    nx: usize,
    ny: usize,
) -> Option<(f64, usize)> {
    if inside.iter().all(|&s| s) {
        // Nothing outside (a design solid everywhere): no member has a finite thickness.
        return None;
    }
    let d2 = distance_to_outside(inside, nx, ny);
    let at = |x: isize, y: isize| -> f64 {
        if x < 0 || y < 0 || x >= nx as isize || y >= ny as isize {
            0.0
        } else {
            d2[y as usize * nx + x as usize]
        }
    };
    let mut lt = vec![0.0f64; nx * ny];
    for y in 0..ny as isize {
        for x in 0..nx as isize {
            let p = y as usize * nx + x as usize;
            if !inside[p] {
                continue;
            }
            let c = d2[p];
            let ridge = [(1, 0), (0, 1), (1, 1), (1, -1)]
                .iter()
                .any(|&(dx, dy)| c >= at(x - dx, y - dy) && c >= at(x + dx, y + dy));
            if !ridge {
                continue;
            }
            // Every grid point closer than d to the centre is inside (d is the distance to the
            // nearest outside point): the discrete inscribed disk. Its diameter counts to the
            // boundary, half a step beyond the last inside point: 2(d − ½).
            let d = c.sqrt();
            let thickness = 2.0 * d - 1.0;
            let ri = d.ceil() as isize;
            for yy in (y - ri).max(0)..=(y + ri).min(ny as isize - 1) {
                for xx in (x - ri).max(0)..=(x + ri).min(nx as isize - 1) {
                    let q = yy as usize * nx + xx as usize;
                    let dd2 = ((xx - x) * (xx - x) + (yy - y) * (yy - y)) as f64;
                    if dd2 < c {
                        lt[q] = lt[q].max(thickness);
                    }
                }
            }
        }
    }
    (0..nx * ny)
        .filter(|&p| inside[p] && counted(p))
        .map(|p| (lt[p].max(1.0), p))
        .reduce(|a, b| if b.0 < a.0 { b } else { a })
}

/// The density field bilinearly interpolated between element centres on a grid `refine` times
/// finer (row-major, x fastest), and that grid's step [m].
fn refined(f: &Field, refine: usize) -> (Vec<f64>, usize, usize, f64) {
    let (nx, ny) = (f.nl * refine, f.nw * refine);
    let r = refine as f64;
    let val = |i: isize, j: isize| {
        let i = i.clamp(0, f.nl as isize - 1) as usize;
        let j = j.clamp(0, f.nw as isize - 1) as usize;
        f.rho[i * f.nw + j]
    };
    let mut out = vec![0.0; nx * ny];
    for y in 0..ny {
        let t = (y as f64 + 0.5) / r - 0.5;
        let (j0, fy) = (t.floor() as isize, t - t.floor());
        for x in 0..nx {
            let s = (x as f64 + 0.5) / r - 0.5;
            let (i0, fx) = (s.floor() as isize, s - s.floor());
            out[y * nx + x] = (1.0 - fx) * (1.0 - fy) * val(i0, j0)
                + fx * (1.0 - fy) * val(i0 + 1, j0)
                + (1.0 - fx) * fy * val(i0, j0 + 1)
                + fx * fy * val(i0 + 1, j0 + 1);
        }
    }
    (out, nx, ny, (f.h.0 * f.h.1).sqrt() / r)
}

/// A size measured on the design and where it occurs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// The size \[m\].
    pub size: f64,
    /// Where: (x, y) \[m\] from the domain's lower-left corner.
    pub at: [f64; 2],
}

/// Thinnest solid member and narrowest void gap at level ½ (module docs), on a grid `refine`
/// times finer than the mesh. `None` where the set is empty.
pub fn member_sizes(f: &Field, refine: usize) -> (Option<Measured>, Option<Measured>) {
    let refine = refine.max(1);
    let (v, nx, ny, step) = refined(f, refine);
    let (sx, sy) = (f.h.0 / refine as f64, f.h.1 / refine as f64);
    let solid: Vec<bool> = v.iter().map(|&r| r >= 0.5).collect();
    let point = |x: usize, y: usize| [(x as f64 + 0.5) * sx, (y as f64 + 0.5) * sy];
    // A frame of `pad` points around the domain; only the domain's points count. For the solid
    // the frame continues the edge (a member cut by the domain's edge is not thin there); for
    // the void the frame is void (the outside is air, a slot may open to it).
    let pad = 2 * refine;
    let (px, py) = (nx + 2 * pad, ny + 2 * pad);
    let inner = |p: usize| {
        let (x, y) = (
            (p % px) as isize - pad as isize,
            (p / px) as isize - pad as isize,
        );
        (x, y)
    };
    let in_domain = |p: usize| {
        let (x, y) = inner(p);
        (0..nx as isize).contains(&x) && (0..ny as isize).contains(&y)
    };
    let clamped = |p: usize| {
        let (x, y) = inner(p);
        let (x, y) = (
            x.clamp(0, nx as isize - 1) as usize,
            y.clamp(0, ny as isize - 1) as usize,
        );
        solid[y * nx + x]
    };
    let framed_solid: Vec<bool> = (0..px * py).map(clamped).collect();
    let framed_void: Vec<bool> = (0..px * py).map(|p| !in_domain(p) || !clamped(p)).collect();
    let measured = |(t, p): (f64, usize)| {
        let (x, y) = inner(p);
        Measured {
            size: t * step,
            at: point(x as usize, y as usize),
        }
    };
    let thinnest = min_local_thickness(&framed_solid, in_domain, px, py).map(measured);
    let gap = min_local_thickness(&framed_void, in_domain, px, py).map(measured);
    (thinnest, gap)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(rho: &[f64]) -> Field<'_> {
        Field {
            nl: 40,
            nw: 20,
            h: (1e-3, 1e-3),
            rho,
        }
    }

    #[test]
    fn bar_and_slot_of_known_width_and_a_one_node_hinge() {
        // A 4-element-wide bar across the whole length (no corners: the local thickness of a
        // sharp corner is small by definition) in a 40 × 20 mesh of 1 mm elements.
        let (nl, nw) = (40, 20);
        let mut rho = vec![0.0; nl * nw];
        for i in 0..nl {
            for j in 8..12 {
                rho[i * nw + j] = 1.0;
            }
        }
        let (t, g) = member_sizes(&field(&rho), 4);
        let (t, g) = (t.unwrap().size, g.unwrap().size);
        println!("bar: thinnest {t:e}, gap {g:e}");
        assert!((t - 4e-3).abs() <= 0.3e-3, "bar width {t}");
        assert!(g >= 8e-3, "void above and below the bar is 8 mm: {g}");
        assert!(one_node_hinges(&field(&rho)).is_empty());
        // A 3-element-wide slot across the whole height of a solid block.
        let mut rho = vec![1.0; nl * nw];
        for i in 20..23 {
            for j in 0..nw {
                rho[i * nw + j] = 0.0;
            }
        }
        let (t, g) = member_sizes(&field(&rho), 4);
        let (t, g) = (t.unwrap().size, g.unwrap().size);
        println!("slot: thinnest {t:e}, gap {g:e}");
        assert!((g - 3e-3).abs() <= 0.3e-3, "slot width {g}");
        assert!(t >= 17e-3, "the blocks beside the slot are 17 mm wide: {t}");
        assert_eq!(mirror_asymmetry(&field(&rho)), 1.0);
        // Two solid elements that touch at a corner only.
        let mut rho = vec![0.0; nl * nw];
        rho[5 * nw + 2] = 1.0;
        rho[6 * nw + 3] = 1.0;
        assert_eq!(one_node_hinges(&field(&rho)), vec![(5, 2)]);
    }
}
