//! Manufacturing outline of a density field (paper Section 4.1: the stage is wire-cut from a
//! plate): the ρ = 0.5 iso-contour by marching squares, smoothed, as closed polylines, written
//! as DXF (R2000 `LWPOLYLINE`), SVG and a binary STL extruded by the plate thickness.
//!
//! The field is sampled at element centroids and padded with a ring of void (ρ = 0), so every
//! contour is closed and a solid element on the domain edge is cut exactly on that edge.
//! Every loop has the solid on its left: outer boundaries run counter-clockwise, holes
//! clockwise.

use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;

/// Errors of the outline export.
#[derive(Debug, thiserror::Error)]
pub enum OutlineError {
    /// The density field does not match the grid.
    #[error("density field has {got} values; expected {nl} x {nw} = {}", nl * nw)]
    Size {
        /// Values given.
        got: usize,
        /// Elements along x.
        nl: usize,
        /// Elements along y.
        nw: usize,
    },
    /// The DXF writer failed.
    #[error("DXF: {0}")]
    Dxf(String),
}

/// Length unit of the exported drawings (the geometry itself is in metres).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// Metres.
    Metres,
    /// Millimetres.
    Millimetres,
}

impl Unit {
    /// Scale factor from metres to this unit.
    pub fn scale(self) -> f64 {
        match self {
            Unit::Metres => 1.0,
            Unit::Millimetres => 1e3,
        }
    }

    /// Short name ("m", "mm").
    pub fn symbol(self) -> &'static str {
        match self {
            Unit::Metres => "m",
            Unit::Millimetres => "mm",
        }
    }
}

/// The iso-contour of a density field on a regular grid of `nl × nw` elements of size
/// `dx × dy` \[m\].
#[derive(Debug, Clone)]
pub struct Outline {
    /// Closed loops (first point not repeated), metres, solid on the left.
    pub loops: Vec<Vec<[f64; 2]>>,
    /// Domain size \[m\] (`nl·dx`, `nw·dy`).
    pub domain: [f64; 2],
    /// Cap triangles of the solid region (unit-free indices into `cap_points`), counter-
    /// clockwise, for the STL extrusion.
    cap_triangles: Vec<[usize; 3]>,
    cap_points: Vec<[f64; 2]>,
    /// Loops as indices into `cap_points` (same order as `loops`).
    loop_indices: Vec<Vec<usize>>,
}

/// Padded sample grid: points `(a, b)` with `a ∈ 0..nl+2`, `b ∈ 0..nw+2`; point `(a, b)` is
/// the centroid of element `(a−1, b−1)`, or void outside the mesh.
struct Samples<'a> {
    nl: usize,
    nw: usize,
    dx: f64,
    dy: f64,
    rho: &'a dyn Fn(usize, usize) -> f64,
}

impl Samples<'_> {
    fn nx(&self) -> usize {
        self.nl + 2
    }
    fn value(&self, a: usize, b: usize) -> f64 {
        if a == 0 || b == 0 || a > self.nl || b > self.nw {
            0.0
        } else {
            (self.rho)(a - 1, b - 1)
        }
    }
    /// Position [m] of sample point `(a, b)`; the void ring sits on the domain edge so that
    /// the 0.5 crossing between a solid edge element and the ring is exactly on the edge.
    fn position(&self, a: usize, b: usize) -> [f64; 2] {
        let x = if a == 0 {
            -0.5 * self.dx
        } else {
            (a as f64 - 0.5) * self.dx
        };
        let y = if b == 0 {
            -0.5 * self.dy
        } else {
            (b as f64 - 0.5) * self.dy
        };
        [x, y]
    }
}

impl Outline {
    /// Extracts the `level` iso-contour of the density field `rho(i, j)` (column `i` from the
    /// left, row `j` from the bottom) and smooths it with `smoothing` Taubin passes
    /// (λ = 0.5, μ = −0.53; about shrink-free, 0 for the raw marching-squares polygon).
    pub fn extract(
        nl: usize,
        nw: usize,
        dx: f64,
        dy: f64,
        level: f64,
        smoothing: usize,
        rho: impl Fn(usize, usize) -> f64,
    ) -> Outline {
        let s = Samples {
            nl,
            nw,
            dx,
            dy,
            rho: &rho,
        };
        let nx = s.nx();
        let ny = nw + 2;
        // Crossing points, keyed by sample-grid edge: 2·(b·nx + a) is the edge from (a, b) to
        // (a+1, b), 2·(b·nx + a) + 1 the edge from (a, b) to (a, b+1).
        let mut point_of_edge: HashMap<usize, usize> = HashMap::new();
        let mut points: Vec<[f64; 2]> = Vec::new();
        let mut corner_point: HashMap<(usize, usize), usize> = HashMap::new();
        let mut next: HashMap<usize, usize> = HashMap::new();
        let mut triangles: Vec<[usize; 3]> = Vec::new();
        let inside = |v: f64| v >= level;
        for b in 0..ny - 1 {
            for a in 0..nx - 1 {
                // Corners counter-clockwise: (a,b), (a+1,b), (a+1,b+1), (a,b+1).
                let c = [(a, b), (a + 1, b), (a + 1, b + 1), (a, b + 1)];
                let v = c.map(|(p, q)| s.value(p, q));
                let ins = v.map(inside);
                let n_in = ins.iter().filter(|&&x| x).count();
                if n_in == 0 {
                    continue;
                }
                // Edge k joins corner k and corner k+1.
                let edge_key = |k: usize| -> usize {
                    match k {
                        0 => 2 * (b * nx + a),
                        1 => 2 * (b * nx + a + 1) + 1,
                        2 => 2 * ((b + 1) * nx + a),
                        _ => 2 * (b * nx + a) + 1,
                    }
                };
                // The cell's inside polygon (counter-clockwise): corners inside and crossings.
                let mut poly: Vec<usize> = Vec::with_capacity(8);
                let mut crossings: Vec<(usize, bool)> = Vec::with_capacity(4); // (edge k, exit?)
                for k in 0..4 {
                    let k1 = (k + 1) % 4;
                    if ins[k] {
                        let id = *corner_point.entry(c[k]).or_insert_with(|| {
                            points.push(s.position(c[k].0, c[k].1));
                            points.len() - 1
                        });
                        poly.push(id);
                    }
                    if ins[k] != ins[k1] {
                        let key = edge_key(k);
                        let id = *point_of_edge.entry(key).or_insert_with(|| {
                            let p0 = s.position(c[k].0, c[k].1);
                            let p1 = s.position(c[k1].0, c[k1].1);
                            let t = ((level - v[k]) / (v[k1] - v[k])).clamp(0.0, 1.0);
                            points.push([p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1])]);
                            points.len() - 1
                        });
                        poly.push(id);
                        crossings.push((k, ins[k]));
                    }
                }
                // Segments run from an exit crossing (inside → outside, counter-clockwise) to
                // an entry crossing, which puts the solid on their left.
                let m = crossings.len();
                if m > 0 {
                    let center_inside = inside(v.iter().sum::<f64>() / 4.0);
                    for (idx, &(k, exit)) in crossings.iter().enumerate() {
                        if !exit {
                            continue;
                        }
                        // Saddle: a connected inside joins each exit to the next entry
                        // (cutting off outside corners), otherwise to the previous one.
                        let j = if m == 2 || center_inside {
                            (idx + 1) % m
                        } else {
                            (idx + m - 1) % m
                        };
                        let from = point_of_edge[&edge_key(k)];
                        let to = point_of_edge[&edge_key(crossings[j].0)];
                        next.insert(from, to);
                    }
                }
                // Caps: fan triangulation; the saddle with a void centre is two triangles.
                if m == 4 && !inside(v.iter().sum::<f64>() / 4.0) {
                    // poly is [c_k, x_k, x_{k+1}... ] per inside corner: split per corner.
                    for k in 0..4 {
                        if ins[k] {
                            let corner = corner_point[&c[k]];
                            let a_edge = point_of_edge[&edge_key(k)];
                            let b_edge = point_of_edge[&edge_key((k + 3) % 4)];
                            triangles.push([corner, a_edge, b_edge]);
                        }
                    }
                } else {
                    for w in 1..poly.len() - 1 {
                        triangles.push([poly[0], poly[w], poly[w + 1]]);
                    }
                }
            }
        }
        let loop_indices = chain_loops(&next);
        taubin_smooth(&mut points, &loop_indices, smoothing);
        let loops = loop_indices
            .iter()
            .map(|lp| lp.iter().map(|&i| points[i]).collect())
            .collect();
        Outline {
            loops,
            domain: [nl as f64 * dx, nw as f64 * dy],
            cap_triangles: triangles,
            cap_points: points,
            loop_indices,
        }
    }

    /// Like [`Outline::extract`] from densities in fem order `rho[i·nw + j]`.
    #[allow(clippy::too_many_arguments)]
    pub fn from_fem_order(
        nl: usize,
        nw: usize,
        dx: f64,
        dy: f64,
        level: f64,
        smoothing: usize,
        rho: &[f64],
    ) -> Result<Outline, OutlineError> {
        if rho.len() != nl * nw {
            return Err(OutlineError::Size {
                got: rho.len(),
                nl,
                nw,
            });
        }
        Ok(Outline::extract(
            nl,
            nw,
            dx,
            dy,
            level,
            smoothing,
            |i, j| rho[i * nw + j],
        ))
    }

    /// The outline with every loop replaced by the centripetal Catmull–Rom curve through its
    /// vertices, sampled so that no chord is much longer than `max_chord` \[m\] (each polygon
    /// edge is split into `⌈length / max_chord⌉` pieces). The curve passes through every
    /// vertex, is C¹ (no kinks, so no artificial stress raisers at the vertices of the
    /// marching-squares polygon) and, with the centripetal parametrization (Yuksel, Schaefer &
    /// Keyser 2011, Computer-Aided Design 43:747–755), has no cusps or self-intersections
    /// within a segment. The cap triangles are re-fanned around the split edges, so the STL
    /// stays closed. `max_chord ≤ 0` returns a copy.
    pub fn refined(&self, max_chord: f64) -> Outline {
        if max_chord <= 0.0 || !max_chord.is_finite() {
            return self.clone();
        }
        let mut points = self.cap_points.clone();
        // Inserted points of each directed loop edge (a → b), solid on its left.
        let mut inserted: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
        let mut loop_indices = Vec::with_capacity(self.loop_indices.len());
        for lp in &self.loop_indices {
            let n = lp.len();
            let mut new_loop = Vec::with_capacity(n);
            for i in 0..n {
                let (a, b) = (lp[i], lp[(i + 1) % n]);
                let ctrl = [
                    self.cap_points[lp[(i + n - 1) % n]],
                    self.cap_points[a],
                    self.cap_points[b],
                    self.cap_points[lp[(i + 2) % n]],
                ];
                new_loop.push(a);
                let pieces = (dist(ctrl[1], ctrl[2]) / max_chord).ceil() as usize;
                let mut ids = Vec::new();
                for j in 1..pieces.max(1) {
                    points.push(catmull_rom(&ctrl, j as f64 / pieces as f64));
                    ids.push(points.len() - 1);
                }
                new_loop.extend_from_slice(&ids);
                if !ids.is_empty() {
                    inserted.insert((a, b), ids);
                }
            }
            loop_indices.push(new_loop);
        }
        let mut cap_triangles = Vec::with_capacity(self.cap_triangles.len());
        for tri in &self.cap_triangles {
            let split = (0..3).any(|k| inserted.contains_key(&(tri[k], tri[(k + 1) % 3])));
            if !split {
                cap_triangles.push(*tri);
                continue;
            }
            // Fan the refined polygon of this triangle around its centroid.
            let mut poly = Vec::new();
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                poly.push(a);
                if let Some(ids) = inserted.get(&(a, b)) {
                    poly.extend_from_slice(ids);
                }
            }
            let c = tri.map(|i| self.cap_points[i]);
            points.push([
                (c[0][0] + c[1][0] + c[2][0]) / 3.0,
                (c[0][1] + c[1][1] + c[2][1]) / 3.0,
            ]);
            let centre = points.len() - 1;
            for k in 0..poly.len() {
                cap_triangles.push([poly[k], poly[(k + 1) % poly.len()], centre]);
            }
        }
        let loops = loop_indices
            .iter()
            .map(|lp| lp.iter().map(|&i| points[i]).collect())
            .collect();
        Outline {
            loops,
            domain: self.domain,
            cap_triangles,
            cap_points: points,
            loop_indices,
        }
    }

    /// The outline with the holes `holes` (indices into [`Outline::loops`]) filled: their loops
    /// dropped and their interiors added to the cap triangles (ear clipping), so the DXF, SVG
    /// and STL draw the part with those pockets left solid and the STL stays closed. Indices
    /// that are not holes are ignored.
    pub fn with_filled(&self, holes: &[usize]) -> Outline {
        let areas = self.signed_areas();
        let fill: Vec<usize> = holes
            .iter()
            .copied()
            .filter(|&k| k < self.loops.len() && areas[k] < 0.0)
            .collect();
        let mut cap_triangles = self.cap_triangles.clone();
        for &k in &fill {
            // A hole runs clockwise; its interior, counter-clockwise, is the reversed loop.
            let ccw: Vec<usize> = self.loop_indices[k].iter().rev().copied().collect();
            cap_triangles.extend(ear_clip(&self.cap_points, &ccw));
        }
        let keep = |k: &usize| !fill.contains(k);
        Outline {
            loops: (0..self.loops.len())
                .filter(keep)
                .map(|k| self.loops[k].clone())
                .collect(),
            domain: self.domain,
            cap_triangles,
            cap_points: self.cap_points.clone(),
            loop_indices: (0..self.loops.len())
                .filter(keep)
                .map(|k| self.loop_indices[k].clone())
                .collect(),
        }
    }

    /// Signed area of each loop \[m²\] (positive: outer boundary, negative: hole).
    pub fn signed_areas(&self) -> Vec<f64> {
        self.loops.iter().map(|l| signed_area(l)).collect()
    }

    /// Area of the solid region enclosed by the loops \[m²\].
    pub fn area(&self) -> f64 {
        self.signed_areas().iter().sum()
    }

    /// The outline as a DXF drawing (AutoCAD R2000, one closed `LWPOLYLINE` per loop on layer
    /// "OUTLINE", `$INSUNITS` set), coordinates in `unit`.
    pub fn to_dxf(&self, unit: Unit) -> Result<Vec<u8>, OutlineError> {
        use dxf::entities::{Entity, EntityType, LwPolyline};
        use dxf::enums::{AcadVersion, Units};
        let mut drawing = dxf::Drawing::new();
        // dxf 0.6 writes R12 by default, which has no LWPOLYLINE and silently drops it.
        drawing.header.version = AcadVersion::R2000;
        drawing.header.default_drawing_units = match unit {
            Unit::Metres => Units::Meters,
            Unit::Millimetres => Units::Millimeters,
        };
        let k = unit.scale();
        for lp in &self.loops {
            let mut poly = LwPolyline::default();
            poly.set_is_closed(true);
            poly.vertices = lp
                .iter()
                .map(|p| dxf::LwPolylineVertex {
                    x: p[0] * k,
                    y: p[1] * k,
                    ..Default::default()
                })
                .collect();
            let mut e = Entity::new(EntityType::LwPolyline(poly));
            e.common.layer = "OUTLINE".into();
            drawing.add_entity(e);
        }
        let mut out = Vec::new();
        drawing
            .save(&mut out)
            .map_err(|e| OutlineError::Dxf(e.to_string()))?;
        add_table_handles(&out)
    }

    /// The outline as an SVG drawing: one `<path>` (even-odd fill, so holes stay open) in
    /// `unit`, y up, with the domain rectangle dashed.
    pub fn to_svg(&self, unit: Unit) -> String {
        let k = unit.scale();
        let (w, h) = (self.domain[0] * k, self.domain[1] * k);
        let m = 0.02 * w.max(h);
        let mut d = String::new();
        for lp in &self.loops {
            for (i, p) in lp.iter().enumerate() {
                let _ = write!(
                    d,
                    "{}{:.6} {:.6} ",
                    if i == 0 { "M" } else { "L" },
                    p[0] * k,
                    h - p[1] * k
                );
            }
            d.push_str("Z ");
        }
        let u = unit.symbol();
        format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{ww}{u}\" height=\"{hh}{u}\" \
             viewBox=\"{x0} {x0} {ww} {hh}\">\n\
             <title>flexstage outline, rho = 0.5 iso-contour ({u})</title>\n\
             <rect x=\"0\" y=\"0\" width=\"{w}\" height=\"{h}\" fill=\"none\" stroke=\"#999\" \
             stroke-width=\"{sw}\" stroke-dasharray=\"{dash}\"/>\n\
             <path d=\"{d}\" fill=\"#4a6fa5\" fill-opacity=\"0.35\" fill-rule=\"evenodd\" \
             stroke=\"#1b2a41\" stroke-width=\"{sw}\"/>\n</svg>\n",
            ww = w + 2.0 * m,
            hh = h + 2.0 * m,
            x0 = -m,
            sw = 0.002 * w.max(h),
            dash = 0.01 * w.max(h),
            d = d.trim_end(),
        )
    }

    /// The solid region extruded by `thickness` \[m\] as a binary STL in `unit`: top and bottom
    /// caps from the marching-squares cells and side walls along every loop. The mesh is
    /// closed (every edge is shared by two triangles) and normals point outwards.
    pub fn to_stl(&self, thickness: f64, unit: Unit) -> Vec<u8> {
        let k = unit.scale();
        let t = thickness * k;
        let p = |i: usize| [self.cap_points[i][0] * k, self.cap_points[i][1] * k];
        let mut tris: Vec<[[f64; 3]; 3]> = Vec::new();
        for tri in &self.cap_triangles {
            let [a, b, c] = tri.map(p);
            tris.push([[a[0], a[1], t], [b[0], b[1], t], [c[0], c[1], t]]);
            tris.push([[a[0], a[1], 0.0], [c[0], c[1], 0.0], [b[0], b[1], 0.0]]);
        }
        for lp in &self.loop_indices {
            let n = lp.len();
            for i in 0..n {
                let a = p(lp[i]);
                let b = p(lp[(i + 1) % n]);
                let (a0, b0) = ([a[0], a[1], 0.0], [b[0], b[1], 0.0]);
                let (a1, b1) = ([a[0], a[1], t], [b[0], b[1], t]);
                tris.push([a0, b0, b1]);
                tris.push([a0, b1, a1]);
            }
        }
        let mut out = Vec::with_capacity(84 + 50 * tris.len());
        let mut header = [0u8; 80];
        let title = format!("flexstage outline extruded, {}", unit.symbol());
        header[..title.len()].copy_from_slice(title.as_bytes());
        out.extend_from_slice(&header);
        out.extend_from_slice(&(tris.len() as u32).to_le_bytes());
        for tri in &tris {
            let n = normal(tri);
            for v in std::iter::once(n).chain(tri.iter().copied()) {
                for x in v {
                    out.extend_from_slice(&(x as f32).to_le_bytes());
                }
            }
            out.extend_from_slice(&0u16.to_le_bytes());
        }
        out
    }
}

/// Gives every symbol table of an ASCII DXF a handle (group 5) and an owner (330 = 0), and
/// every table record its owning table (330), then advances `$HANDSEED`.
///
/// The `dxf` crate 0.6 writes table heads without handles (a TODO in its generator), which a
/// strict reader repairs on load ("invalid table head handle", one per table; the DXF
/// reference requires group 5 on every TABLE from R13 on). New handles start at the drawing's
/// `$HANDSEED`, so they cannot collide with the handles already written.
fn add_table_handles(bytes: &[u8]) -> Result<Vec<u8>, OutlineError> {
    let text = std::str::from_utf8(bytes).map_err(|e| OutlineError::Dxf(e.to_string()))?;
    let lines: Vec<&str> = text.lines().collect();
    if lines.len() % 2 != 0 {
        return Err(OutlineError::Dxf(format!(
            "the DXF writer produced an odd number of lines ({})",
            lines.len()
        )));
    }
    let pairs: Vec<(&str, &str)> = lines.chunks(2).map(|c| (c[0].trim(), c[1])).collect();
    let seed_at = pairs
        .windows(2)
        .position(|w| w[0] == ("9", "$HANDSEED"))
        .map(|i| i + 1)
        .ok_or_else(|| OutlineError::Dxf("the DXF header has no $HANDSEED".into()))?;
    let mut seed = u64::from_str_radix(pairs[seed_at].1.trim(), 16)
        .map_err(|e| OutlineError::Dxf(format!("bad $HANDSEED: {e}")))?;
    let mut out: Vec<(String, String)> = Vec::with_capacity(pairs.len() + 64);
    let mut table: Option<String> = None;
    let mut i = 0;
    while i < pairs.len() {
        let (code, value) = pairs[i];
        out.push((code.to_string(), value.to_string()));
        if (code, value) == ("0", "TABLE") && i + 1 < pairs.len() {
            // `2 NAME` comes first; the head's handle and owner follow it.
            i += 1;
            out.push((pairs[i].0.to_string(), pairs[i].1.to_string()));
            let handle = format!("{seed:X}");
            seed += 1;
            out.push(("5".into(), handle.clone()));
            out.push(("330".into(), "0".into()));
            table = Some(handle);
        } else if (code, value) == ("0", "ENDTAB") {
            table = None;
        } else if let Some(h) = &table {
            // A record's own handle (5, or 105 for DIMSTYLE) is followed by its owner.
            let next_is_owner = pairs.get(i + 1).is_some_and(|p| p.0 == "330");
            if (code == "5" || code == "105") && !next_is_owner {
                out.push(("330".into(), h.clone()));
            }
        }
        i += 1;
    }
    let seed_text = format!("{seed:X}");
    let mut s = String::with_capacity(bytes.len() + 64 * 16);
    for (k, (code, value)) in out.iter().enumerate() {
        // The header's $HANDSEED value sits at the same pair index (the header precedes TABLES).
        let value = if k == seed_at {
            seed_text.as_str()
        } else {
            value
        };
        let _ = write!(s, "{code:>3}\r\n{value}\r\n");
    }
    Ok(s.into_bytes())
}

/// Unit normal of a triangle (right-hand rule); zero for a degenerate one.
fn normal(t: &[[f64; 3]; 3]) -> [f64; 3] {
    let u = [t[1][0] - t[0][0], t[1][1] - t[0][1], t[1][2] - t[0][2]];
    let v = [t[2][0] - t[0][0], t[2][1] - t[0][1], t[2][2] - t[0][2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if l > 0.0 { n.map(|x| x / l) } else { [0.0; 3] }
}

/// Twice the signed area of the triangle `a b c` (positive counter-clockwise).
fn cross(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Triangles of the simple counter-clockwise polygon `poly` (indices into `points`) by ear
/// clipping (Meisters 1975, "Polygons have ears", Amer. Math. Monthly 82:648–651): a convex
/// vertex whose triangle holds no other vertex is cut off until three remain. Where rounding
/// leaves no strict ear (collinear runs), the most convex vertex is cut, a triangle of zero
/// area at worst, so every polygon edge stays an edge of exactly one triangle.
fn ear_clip(points: &[[f64; 2]], poly: &[usize]) -> Vec<[usize; 3]> {
    let mut v = poly.to_vec();
    let mut tris = Vec::with_capacity(v.len().saturating_sub(2));
    while v.len() > 3 {
        let n = v.len();
        let corner = |i: usize| (v[(i + n - 1) % n], v[i], v[(i + 1) % n]);
        let is_ear = |i: usize| {
            let (a, b, c) = corner(i);
            let (pa, pb, pc) = (points[a], points[b], points[c]);
            cross(pa, pb, pc) > 0.0
                && v.iter().all(|&j| {
                    let q = points[j];
                    q == pa
                        || q == pb
                        || q == pc
                        || cross(pa, pb, q) < 0.0
                        || cross(pb, pc, q) < 0.0
                        || cross(pc, pa, q) < 0.0
                })
        };
        let i = (0..n).find(|&i| is_ear(i)).unwrap_or_else(|| {
            (0..n)
                .max_by(|&i, &j| {
                    let area = |i: usize| {
                        let (a, b, c) = corner(i);
                        cross(points[a], points[b], points[c])
                    };
                    area(i).total_cmp(&area(j))
                })
                .expect("more than three vertices")
        });
        let (a, b, c) = corner(i);
        tris.push([a, b, c]);
        v.remove(i);
    }
    if v.len() == 3 {
        tris.push([v[0], v[1], v[2]]);
    }
    tris
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Point at `u ∈ [0, 1]` of the centripetal Catmull–Rom segment from `p[1]` to `p[2]`
/// (neighbours `p[0]`, `p[3]`), by the Barry–Goldman pyramid with knot steps `|Δp|^½`.
fn catmull_rom(p: &[[f64; 2]; 4], u: f64) -> [f64; 2] {
    // Knot steps, kept away from zero for repeated points.
    let step = |a: [f64; 2], b: [f64; 2]| dist(a, b).sqrt().max(1e-12);
    let t0 = 0.0;
    let t1 = t0 + step(p[0], p[1]);
    let t2 = t1 + step(p[1], p[2]);
    let t3 = t2 + step(p[2], p[3]);
    let t = t1 + u * (t2 - t1);
    let lerp = |a: [f64; 2], b: [f64; 2], ta: f64, tb: f64| {
        let w = (t - ta) / (tb - ta);
        [a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1])]
    };
    let a1 = lerp(p[0], p[1], t0, t1);
    let a2 = lerp(p[1], p[2], t1, t2);
    let a3 = lerp(p[2], p[3], t2, t3);
    let b1 = lerp(a1, a2, t0, t2);
    let b2 = lerp(a2, a3, t1, t3);
    lerp(b1, b2, t1, t2)
}

/// Shoelace signed area of a closed polygon.
pub fn signed_area(p: &[[f64; 2]]) -> f64 {
    let n = p.len();
    (0..n)
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        * 0.5
}

/// Chains the boundary segments `next[from] = to` of marching squares into closed loops
/// (point indices, solid on the left), in the order of their smallest start point; chains
/// of fewer than three points are dropped.
fn chain_loops(next: &HashMap<usize, usize>) -> Vec<Vec<usize>> {
    let mut loop_indices: Vec<Vec<usize>> = Vec::new();
    let mut starts: Vec<usize> = next.keys().copied().collect();
    starts.sort_unstable();
    let mut used: HashSet<usize> = HashSet::new();
    for start in starts {
        if used.contains(&start) {
            continue;
        }
        let mut lp = vec![start];
        used.insert(start);
        let mut cur = next[&start];
        while cur != start {
            used.insert(cur);
            lp.push(cur);
            match next.get(&cur) {
                Some(&n) => cur = n,
                None => break,
            }
        }
        if lp.len() >= 3 {
            loop_indices.push(lp);
        }
    }
    loop_indices
}

/// Taubin λ|μ smoothing (λ = 0.5, μ = −0.53; Taubin 1995, SIGGRAPH, "A signal processing
/// approach to fair surface design") of the loop points, `passes` times. The points are
/// shared with the cap triangles, so the STL stays closed.
fn taubin_smooth(points: &mut [[f64; 2]], loop_indices: &[Vec<usize>], passes: usize) {
    for _ in 0..passes {
        for factor in [0.5, -0.53] {
            let mut moved: Vec<(usize, [f64; 2])> = Vec::new();
            for lp in loop_indices {
                let n = lp.len();
                for i in 0..n {
                    let p = points[lp[i]];
                    let a = points[lp[(i + n - 1) % n]];
                    let b = points[lp[(i + 1) % n]];
                    let lap = [0.5 * (a[0] + b[0]) - p[0], 0.5 * (a[1] + b[1]) - p[1]];
                    moved.push((lp[i], [p[0] + factor * lap[0], p[1] + factor * lap[1]]));
                }
            }
            for (i, p) in moved {
                points[i] = p;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A disc of density 0.5 + 0.5·tanh((R − r)/w): its 0.5 level is the circle r = R exactly.
    fn disc(n: usize, h: f64, r: f64) -> impl Fn(usize, usize) -> f64 {
        let c = 0.5 * n as f64 * h;
        move |i, j| {
            let x = (i as f64 + 0.5) * h - c;
            let y = (j as f64 + 0.5) * h - c;
            0.5 + 0.5 * ((r - (x * x + y * y).sqrt()) / (2.0 * h)).tanh()
        }
    }

    #[test]
    fn disc_contour_lies_on_the_analytic_half_level() {
        // Goal: marching squares + Taubin smoothing keep the 0.5 iso-line of a smooth disc
        // within 1 % of its radius (linear interpolation error is O(h²)).
        let (n, h, r) = (60, 1e-3, 0.02);
        let c = 0.5 * n as f64 * h;
        for smoothing in [0, 10] {
            let o = Outline::extract(n, n, h, h, 0.5, smoothing, disc(n, h, r));
            assert_eq!(o.loops.len(), 1, "one closed loop");
            for p in &o.loops[0] {
                let rr = ((p[0] - c).powi(2) + (p[1] - c).powi(2)).sqrt();
                assert!((rr - r).abs() < 0.01 * r, "radius {rr} vs {r}");
            }
            let area = o.area();
            let exact = std::f64::consts::PI * r * r;
            assert!(
                (area - exact).abs() < 0.02 * exact,
                "area {area} vs {exact}"
            );
            assert!(o.signed_areas()[0] > 0.0, "outer loop counter-clockwise");
        }
    }

    #[test]
    fn solid_block_on_the_edge_is_cut_on_the_domain_edge_and_holes_run_clockwise() {
        // Goal: padding puts the outline of a full plate on its edges (a wire-cut part keeps
        // the domain size), and a void square gives a clockwise hole.
        let (nl, nw, h) = (20, 10, 1e-3);
        let o = Outline::extract(nl, nw, h, h, 0.5, 0, |i, j| {
            if (8..12).contains(&i) && (3..7).contains(&j) {
                0.0
            } else {
                1.0
            }
        });
        assert_eq!(o.loops.len(), 2);
        let areas = o.signed_areas();
        let outer = areas.iter().cloned().fold(f64::MIN, f64::max);
        let hole = areas.iter().cloned().fold(f64::MAX, f64::min);
        // Marching squares chamfers each of the 4 plate corners by a half-cell triangle h²/8.
        let expected = 20e-3 * 10e-3 - 4.0 * h * h / 8.0;
        assert!((outer - expected).abs() < 1e-12, "outer area {outer}");
        assert!(hole < 0.0, "hole clockwise");
        let xs: Vec<f64> = o.loops.iter().flatten().map(|p| p[0]).collect();
        let min = xs.iter().cloned().fold(f64::MAX, f64::min);
        let max = xs.iter().cloned().fold(f64::MIN, f64::max);
        assert!(min.abs() < 1e-15 && (max - 0.02).abs() < 1e-15);
    }

    #[test]
    fn dxf_reads_back_closed_lwpolylines_with_the_bounding_box() {
        // Goal: the DXF opens with a DXF reader (the dxf crate) and holds closed LWPOLYLINEs
        // in millimetres spanning the disc (an R12 reader would silently drop them).
        let (n, h, r) = (40, 1e-3, 0.015);
        let o = Outline::extract(n, n, h, h, 0.5, 5, disc(n, h, r));
        let bytes = o.to_dxf(Unit::Millimetres).unwrap();
        let d = dxf::Drawing::load(&mut bytes.as_slice()).unwrap();
        let mut polys = 0;
        let (mut lo, mut hi) = ([f64::MAX; 2], [f64::MIN; 2]);
        for e in d.entities() {
            if let dxf::entities::EntityType::LwPolyline(p) = &e.specific {
                polys += 1;
                assert!(p.is_closed());
                for v in &p.vertices {
                    lo = [lo[0].min(v.x), lo[1].min(v.y)];
                    hi = [hi[0].max(v.x), hi[1].max(v.y)];
                }
            }
        }
        assert_eq!(polys, 1);
        for k in 0..2 {
            assert!((lo[k] - 5.0).abs() < 0.15, "min {lo:?}");
            assert!((hi[k] - 35.0).abs() < 0.15, "max {hi:?}");
        }
    }

    #[test]
    fn stl_is_closed_with_outward_normals_and_the_extruded_volume() {
        // Goal: a watertight solid for CAD/CAM: every edge in two triangles, divergence-theorem
        // volume = area × t, side normals horizontal, caps ±z.
        let (nl, nw, h, t) = (16, 8, 1e-3, 5e-3);
        let o = Outline::extract(nl, nw, h, h, 0.5, 3, |i, j| {
            if (5..9).contains(&i) && (2..5).contains(&j) {
                0.0
            } else {
                1.0
            }
        });
        let stl = o.to_stl(t, Unit::Millimetres);
        let n = u32::from_le_bytes(stl[80..84].try_into().unwrap()) as usize;
        assert_eq!(stl.len(), 84 + 50 * n);
        let f = |o: usize| f32::from_le_bytes(stl[o..o + 4].try_into().unwrap()) as f64;
        let mut volume = 0.0;
        let mut edges: HashMap<[[i64; 3]; 2], i32> = HashMap::new();
        let key = |v: [f64; 3]| v.map(|x| (x * 1e4).round() as i64);
        for k in 0..n {
            let base = 84 + 50 * k;
            let nrm = [f(base), f(base + 4), f(base + 8)];
            let v: Vec<[f64; 3]> = (0..3)
                .map(|m| {
                    [
                        f(base + 12 + 12 * m),
                        f(base + 16 + 12 * m),
                        f(base + 20 + 12 * m),
                    ]
                })
                .collect();
            let len = (nrm[0].powi(2) + nrm[1].powi(2) + nrm[2].powi(2)).sqrt();
            assert!((len - 1.0).abs() < 1e-5 || len == 0.0);
            // Signed volume of the tetrahedron with the origin.
            volume += (v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1])
                - v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0])
                + v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]))
                / 6.0;
            for m in 0..3 {
                let (a, b) = (key(v[m]), key(v[(m + 1) % 3]));
                // Directed edges: a closed, consistently oriented mesh cancels them pairwise.
                *edges.entry([a, b]).or_default() += 1;
                *edges.entry([b, a]).or_default() -= 1;
            }
        }
        assert!(
            edges.values().all(|&c| c == 0),
            "open or inconsistent edges"
        );
        let exact = o.area() * 1e6 * t * 1e3;
        assert!((volume - exact).abs() < 1e-6 * exact, "{volume} vs {exact}");
    }

    #[test]
    fn dxf_table_heads_have_handles_and_the_handle_seed_is_past_them() {
        // Goal: a strict reader (e.g. ezdxf's audit) finds nothing to repair: every TABLE head
        // has a unique handle (group 5) and owner 0 (group 330), every record names its table,
        // and $HANDSEED is above every handle in the file (DXF reference, R2000).
        let o = Outline::extract(20, 10, 1e-3, 1e-3, 0.5, 3, |i, j| {
            if (8..12).contains(&i) && (3..7).contains(&j) {
                0.0
            } else {
                1.0
            }
        });
        let bytes = o.to_dxf(Unit::Millimetres).unwrap();
        let text = String::from_utf8(bytes.clone()).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let pairs: Vec<(&str, &str)> = lines.chunks(2).map(|c| (c[0].trim(), c[1])).collect();
        let mut heads = 0;
        let mut handles = HashSet::new();
        let mut seed = 0;
        for (k, w) in pairs.windows(4).enumerate() {
            if w[0] == ("0", "TABLE") {
                heads += 1;
                assert_eq!(w[1].0, "2");
                assert_eq!(w[2].0, "5", "table {} has no handle", w[1].1);
                assert_eq!(w[3], ("330", "0"));
            }
            if w[0] == ("9", "$HANDSEED") {
                seed = u64::from_str_radix(w[1].1.trim(), 16).unwrap();
            }
            // Handles of objects; header variables (`9 $NAME` then the value) are not.
            let header_value = k > 0 && pairs[k - 1].0 == "9";
            if (w[0].0 == "5" || w[0].0 == "105") && !header_value {
                let h = u64::from_str_radix(w[0].1.trim(), 16).unwrap();
                assert!(handles.insert(h), "duplicate handle {h:X} at pair {k}");
            }
        }
        assert_eq!(
            heads, 7,
            "VPORT, LTYPE, LAYER, STYLE, APPID, DIMSTYLE, BLOCK_RECORD"
        );
        assert!(
            handles.iter().all(|&h| h < seed),
            "$HANDSEED {seed:X} too low"
        );
        // The dxf crate still reads it, with the same geometry.
        let d = dxf::Drawing::load(&mut bytes.as_slice()).unwrap();
        assert_eq!(d.entities().count(), 2);
    }

    #[test]
    fn refined_outline_lies_on_the_circle_and_keeps_the_stl_closed() {
        // Goal: the Catmull–Rom refinement interpolates the polygon (every old vertex kept),
        // splits chords to at most about max_chord and, for a disc, stays on the circle more
        // closely than the polygon's chords do (the chord sagitta of a 1 mm chord on a 20 mm
        // radius is 6 µm; the curve must be within 3 µm of the polygon's circle fit).
        let (n, h, r) = (60, 1e-3, 0.02);
        let c = 0.5 * n as f64 * h;
        let o = Outline::extract(n, n, h, h, 0.5, 10, disc(n, h, r));
        let fine = o.refined(0.1e-3);
        assert_eq!(fine.loops.len(), 1);
        assert!(fine.loops[0].len() > 5 * o.loops[0].len());
        for p in &o.loops[0] {
            assert!(fine.loops[0].contains(p), "vertex {p:?} dropped");
        }
        let radius = |p: &[f64; 2]| ((p[0] - c).powi(2) + (p[1] - c).powi(2)).sqrt();
        let mean = o.loops[0].iter().map(radius).sum::<f64>() / o.loops[0].len() as f64;
        for w in fine.loops[0].windows(2) {
            assert!(dist(w[0], w[1]) < 0.11e-3, "chord {}", dist(w[0], w[1]));
            let mid = [0.5 * (w[0][0] + w[1][0]), 0.5 * (w[0][1] + w[1][1])];
            assert!((radius(&mid) - mean).abs() < 0.01 * r, "off the circle");
        }
        let dev = fine.loops[0]
            .iter()
            .map(|p| (radius(p) - mean).abs())
            .fold(0.0, f64::max);
        let dev_poly = o.loops[0]
            .iter()
            .map(|p| (radius(p) - mean).abs())
            .fold(0.0, f64::max);
        assert!(dev <= dev_poly + 3e-6, "curve {dev} vs polygon {dev_poly}");
        // STL still watertight: every directed edge cancels.
        let stl = fine.to_stl(1e-3, Unit::Millimetres);
        let ntri = u32::from_le_bytes(stl[80..84].try_into().unwrap()) as usize;
        let f = |o: usize| f32::from_le_bytes(stl[o..o + 4].try_into().unwrap()) as f64;
        let key = |v: [f64; 3]| v.map(|x| (x * 1e5).round() as i64);
        let mut edges: HashMap<[[i64; 3]; 2], i32> = HashMap::new();
        for k in 0..ntri {
            let b = 84 + 50 * k + 12;
            let v: Vec<[f64; 3]> = (0..3)
                .map(|m| [f(b + 12 * m), f(b + 4 + 12 * m), f(b + 8 + 12 * m)])
                .collect();
            for m in 0..3 {
                let (a, bb) = (key(v[m]), key(v[(m + 1) % 3]));
                *edges.entry([a, bb]).or_default() += 1;
                *edges.entry([bb, a]).or_default() -= 1;
            }
        }
        assert!(edges.values().all(|&c| c == 0), "open STL");
        assert!((fine.area() - o.area()).abs() < 0.002 * o.area());
    }

    /// Directed-edge balance and divergence-theorem volume of a binary STL: a closed,
    /// consistently oriented surface has every directed edge cancelled by its reverse.
    fn stl_closed_volume(stl: &[u8]) -> (bool, f64) {
        let n = u32::from_le_bytes(stl[80..84].try_into().unwrap()) as usize;
        let f = |o: usize| f32::from_le_bytes(stl[o..o + 4].try_into().unwrap()) as f64;
        let key = |v: [f64; 3]| v.map(|x| (x * 1e5).round() as i64);
        let mut edges: HashMap<[[i64; 3]; 2], i32> = HashMap::new();
        let mut volume = 0.0;
        for k in 0..n {
            let b = 84 + 50 * k + 12;
            let v: Vec<[f64; 3]> = (0..3)
                .map(|m| [f(b + 12 * m), f(b + 4 + 12 * m), f(b + 8 + 12 * m)])
                .collect();
            volume += (v[0][0] * (v[1][1] * v[2][2] - v[1][2] * v[2][1])
                - v[0][1] * (v[1][0] * v[2][2] - v[1][2] * v[2][0])
                + v[0][2] * (v[1][0] * v[2][1] - v[1][1] * v[2][0]))
                / 6.0;
            for m in 0..3 {
                let (a, bb) = (key(v[m]), key(v[(m + 1) % 3]));
                *edges.entry([a, bb]).or_default() += 1;
                *edges.entry([bb, a]).or_default() -= 1;
            }
        }
        (edges.values().all(|&c| c == 0), volume)
    }

    #[test]
    fn filled_pocket_leaves_a_closed_part_with_the_pocket_solid() {
        // Goal: filling a hole drops its loop, adds exactly its area to the part (the signed
        // areas of the loops are exact polygon areas) and keeps the STL closed with volume =
        // area × t, for a smoothed and refined (curved, non-convex) pocket as for a square
        // one; the other hole and the outer loop stay as they were, and an index that is not
        // a hole is ignored.
        let (nl, nw, h, t) = (30, 12, 1e-3, 2e-3);
        let o = Outline::extract(nl, nw, h, h, 0.5, 5, |i, j| {
            let small = (6..8).contains(&i) && (5..7).contains(&j);
            // A C-shaped pocket: a solid tongue reaches into it from its left side.
            let tongue = (18..22).contains(&i) && (5..7).contains(&j);
            let notch = (18..24).contains(&i) && (3..9).contains(&j) && !tongue;
            if small || notch { 0.0 } else { 1.0 }
        })
        .refined(0.1e-3);
        assert_eq!(
            o.loops.len(),
            3,
            "outer, the 2 × 2 pocket, the notched pocket"
        );
        let areas = o.signed_areas();
        assert!(areas[1] < 0.0 && areas[2] < 0.0, "loops 1 and 2 are holes");
        for (k, kept) in [(1, 2), (2, 1)] {
            let filled = o.with_filled(&[k, 0, 99]);
            assert_eq!(filled.loops.len(), 2);
            assert_eq!(filled.loops[1], o.loops[kept]);
            assert_eq!(filled.loops[0], o.loops[0]);
            assert!(
                (filled.area() - (o.area() - areas[k])).abs() < 1e-12 * o.area(),
                "{} vs {}",
                filled.area(),
                o.area() - areas[k]
            );
            let (closed, volume) = stl_closed_volume(&filled.to_stl(t, Unit::Millimetres));
            assert!(closed, "open STL after filling loop {k}");
            let exact = filled.area() * 1e6 * t * 1e3;
            assert!((volume - exact).abs() < 1e-5 * exact, "{volume} vs {exact}");
        }
        let (closed, volume) = stl_closed_volume(&o.to_stl(t, Unit::Millimetres));
        assert!(closed && (volume - o.area() * 1e9 * t).abs() < 1e-5 * o.area() * 1e9 * t);
    }

    #[test]
    fn svg_has_one_path_per_drawing_with_every_loop() {
        // Goal: the SVG outline carries each loop as a closed subpath.
        let o = Outline::extract(10, 10, 1e-3, 1e-3, 0.5, 0, |i, j| {
            if (3..6).contains(&i) && (3..6).contains(&j) {
                0.0
            } else {
                1.0
            }
        });
        let svg = o.to_svg(Unit::Millimetres);
        assert!(svg.starts_with("<svg"));
        assert_eq!(svg.matches("<path").count(), 1);
        assert_eq!(svg.matches('Z').count(), o.loops.len());
        assert_eq!(o.loops.len(), 2);
    }
}
