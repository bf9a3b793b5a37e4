//! Structured Q4 mesh of an `l × w` rectangle (paper Fig. A1a, Table 3).
//!
//! # Numbering (column-major, x along `l`)
//!
//! With `i ∈ 0..=n_l` the column (x) index and `j ∈ 0..=n_w` the row (y) index:
//!
//! * node id    `n = i·(n_w+1) + j`, at `(x, y) = (i·l/n_l, j·w/n_w)`;
//! * element id `e = i·n_w + j` for `i ∈ 0..n_l`, `j ∈ 0..n_w`;
//! * DOFs of node `n`: `2n` (x) and `2n+1` (y).
//!
//! Element connectivity is counter-clockwise, starting bottom-left:
//!
//! ```text
//!   y
//!   ^   n3 = (i, j+1) ------- n2 = (i+1, j+1)
//!   |        |                    |
//!   |        |     element e      |
//!   |        |   e = i·n_w + j    |
//!   |        |                    |
//!   |   n0 = (i, j) --------- n1 = (i+1, j)
//!   +-----------------------------------------> x
//!
//!   nodes of a 3×2-element mesh (n_w + 1 = 3 nodes per column):
//!
//!   2 --- 5 --- 8 --- 11
//!   |  1  |  3  |  5  |
//!   1 --- 4 --- 7 --- 10
//!   |  0  |  2  |  4  |
//!   0 --- 3 --- 6 --- 9
//! ```
//!
//! Column-major numbering with the short side (`n_w`) running fastest keeps the
//! bandwidth at about `2(n_w+2)` DOFs (only matters before AMD reordering).

use crate::error::{ParamError, check_open};

/// An edge of the rectangular domain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Edge {
    /// `x = 0`.
    Left,
    /// `x = l`.
    Right,
    /// `y = 0`.
    Bottom,
    /// `y = w`.
    Top,
}

/// Passive-element flag: whether an element's density is a design variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Passive {
    /// Ordinary design element.
    #[default]
    Design,
    /// Passive solid (ρ = 1), e.g. the load-spreading patches at the ports (DECISIONS.md).
    Solid,
    /// Passive void (ρ = ρ_min).
    Void,
}

/// Structured mesh of identical rectangular bilinear (Q4) elements.
#[derive(Debug, Clone)]
pub struct Mesh {
    /// Number of elements along x (`n_l`).
    pub nl: usize,
    /// Number of elements along y (`n_w`).
    pub nw: usize,
    /// Domain length along x, m.
    pub length: f64,
    /// Domain width along y, m.
    pub width: f64,
    /// Out-of-plane thickness, m.
    pub thickness: f64,
    /// Per-element passive flag (length `n_elements`).
    pub passive: Vec<Passive>,
}

impl Mesh {
    /// Nested-dissection order of the nodes (George 1973): the grid is split recursively
    /// across its longer side by a line of nodes, and each separator follows the nodes it
    /// separates. For the Cholesky factor of a 2D grid this gives O(N log N) fill, less than
    /// minimum degree; [`crate::SymbolicFactor::for_model`] uses it.
    pub fn nested_dissection(&self) -> Vec<usize> {
        fn split(m: &Mesh, i: (usize, usize), j: (usize, usize), out: &mut Vec<usize>) {
            let (ni, nj) = (i.1 - i.0, j.1 - j.0); // half-open ranges of node indices
            if ni == 0 || nj == 0 {
                return;
            }
            if ni * nj <= 16 {
                for a in i.0..i.1 {
                    for b in j.0..j.1 {
                        out.push(m.node(a, b));
                    }
                }
                return;
            }
            if ni >= nj {
                let s = i.0 + ni / 2;
                split(m, (i.0, s), j, out);
                split(m, (s + 1, i.1), j, out);
                out.extend((j.0..j.1).map(|b| m.node(s, b)));
            } else {
                let s = j.0 + nj / 2;
                split(m, i, (j.0, s), out);
                split(m, i, (s + 1, j.1), out);
                out.extend((i.0..i.1).map(|a| m.node(a, s)));
            }
        }
        let mut out = Vec::with_capacity(self.n_nodes());
        split(self, (0, self.nl + 1), (0, self.nw + 1), &mut out);
        out
    }

    /// Build an `nl × nw` mesh of the `length × width` rectangle with the given thickness.
    pub fn new(
        length: f64,
        width: f64,
        thickness: f64,
        nl: usize,
        nw: usize,
    ) -> Result<Self, ParamError> {
        check_open("Mesh::length", length, 0.0, f64::INFINITY, "(0, ∞) m")?;
        check_open("Mesh::width", width, 0.0, f64::INFINITY, "(0, ∞) m")?;
        check_open("Mesh::thickness", thickness, 0.0, f64::INFINITY, "(0, ∞) m")?;
        for (field, n) in [("Mesh::nl", nl), ("Mesh::nw", nw)] {
            if n == 0 || n > 1 << 14 {
                return Err(ParamError::OutOfRange {
                    field,
                    value: n as f64,
                    range: "[1, 16384]",
                });
            }
        }
        Ok(Self {
            nl,
            nw,
            length,
            width,
            thickness,
            passive: vec![Passive::Design; nl * nw],
        })
    }

    /// Number of nodes `(n_l+1)(n_w+1)`.
    #[inline]
    pub fn n_nodes(&self) -> usize {
        (self.nl + 1) * (self.nw + 1)
    }
    /// Number of DOFs `2·n_nodes`.
    #[inline]
    pub fn n_dofs(&self) -> usize {
        2 * self.n_nodes()
    }
    /// Number of elements `n_l·n_w`.
    #[inline]
    pub fn n_elements(&self) -> usize {
        self.nl * self.nw
    }
    /// Element size along x, `l/n_l`.
    #[inline]
    pub fn dx(&self) -> f64 {
        self.length / self.nl as f64
    }
    /// Element size along y, `w/n_w`.
    #[inline]
    pub fn dy(&self) -> f64 {
        self.width / self.nw as f64
    }
    /// Node id of grid point `(i, j)`.
    #[inline]
    pub fn node(&self, i: usize, j: usize) -> usize {
        debug_assert!(i <= self.nl && j <= self.nw);
        i * (self.nw + 1) + j
    }
    /// Grid indices `(i, j)` of a node.
    #[inline]
    pub fn node_ij(&self, n: usize) -> (usize, usize) {
        (n / (self.nw + 1), n % (self.nw + 1))
    }
    /// Reference coordinates of a node.
    #[inline]
    pub fn node_coords(&self, n: usize) -> [f64; 2] {
        let (i, j) = self.node_ij(n);
        [i as f64 * self.dx(), j as f64 * self.dy()]
    }
    /// Element id of grid cell `(i, j)`.
    #[inline]
    pub fn element(&self, i: usize, j: usize) -> usize {
        debug_assert!(i < self.nl && j < self.nw);
        i * self.nw + j
    }
    /// Counter-clockwise node ids of element `e` (see the module diagram).
    #[inline]
    pub fn element_nodes(&self, e: usize) -> [usize; 4] {
        let (i, j) = (e / self.nw, e % self.nw);
        let n0 = self.node(i, j);
        let n1 = n0 + self.nw + 1;
        [n0, n1, n1 + 1, n0 + 1]
    }
    /// The 8 DOFs of element `e`, ordered `[x0, y0, x1, y1, x2, y2, x3, y3]`.
    #[inline]
    pub fn element_dofs(&self, e: usize) -> [usize; 8] {
        let n = self.element_nodes(e);
        [
            2 * n[0],
            2 * n[0] + 1,
            2 * n[1],
            2 * n[1] + 1,
            2 * n[2],
            2 * n[2] + 1,
            2 * n[3],
            2 * n[3] + 1,
        ]
    }
    /// Centroid of element `e`.
    #[inline]
    pub fn element_centroid(&self, e: usize) -> [f64; 2] {
        let (i, j) = (e / self.nw, e % self.nw);
        [(i as f64 + 0.5) * self.dx(), (j as f64 + 0.5) * self.dy()]
    }

    /// Nodes on an edge, ordered by increasing coordinate along the edge.
    pub fn nodes_on_edge(&self, edge: Edge) -> Vec<usize> {
        match edge {
            Edge::Left => (0..=self.nw).map(|j| self.node(0, j)).collect(),
            Edge::Right => (0..=self.nw).map(|j| self.node(self.nl, j)).collect(),
            Edge::Bottom => (0..=self.nl).map(|i| self.node(i, 0)).collect(),
            Edge::Top => (0..=self.nl).map(|i| self.node(i, self.nw)).collect(),
        }
    }

    /// Node nearest to `p` (ties resolved towards the lower id).
    pub fn nearest_node(&self, p: [f64; 2]) -> usize {
        let i = (p[0] / self.dx()).round().clamp(0.0, self.nl as f64) as usize;
        let j = (p[1] / self.dy()).round().clamp(0.0, self.nw as f64) as usize;
        self.node(i, j)
    }

    /// Nodes with `lo ≤ (x, y) ≤ hi` (inclusive, with a tolerance of 1e-9 element sizes).
    pub fn nodes_in_box(&self, lo: [f64; 2], hi: [f64; 2]) -> Vec<usize> {
        let tol = 1e-9 * self.dx().min(self.dy());
        (0..self.n_nodes())
            .filter(|&n| {
                let c = self.node_coords(n);
                c[0] >= lo[0] - tol
                    && c[0] <= hi[0] + tol
                    && c[1] >= lo[1] - tol
                    && c[1] <= hi[1] + tol
            })
            .collect()
    }

    /// Elements whose centroid lies in `lo ≤ (x, y) ≤ hi`.
    pub fn elements_in_box(&self, lo: [f64; 2], hi: [f64; 2]) -> Vec<usize> {
        (0..self.n_elements())
            .filter(|&e| {
                let c = self.element_centroid(e);
                c[0] >= lo[0] && c[0] <= hi[0] && c[1] >= lo[1] && c[1] <= hi[1]
            })
            .collect()
    }

    /// Mark elements as passive.
    pub fn set_passive(&mut self, elements: &[usize], flag: Passive) {
        for &e in elements {
            self.passive[e] = flag;
        }
    }

    /// Overwrite passive elements in a density vector: solid → 1, void → `rho_void`.
    pub fn apply_passive(&self, rho: &mut [f64], rho_void: f64) {
        for (r, p) in rho.iter_mut().zip(&self.passive) {
            match p {
                Passive::Design => {}
                Passive::Solid => *r = 1.0,
                Passive::Void => *r = rho_void,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbering_matches_diagram() {
        let m = Mesh::new(3.0, 2.0, 1.0, 3, 2).unwrap();
        assert_eq!(m.element_nodes(0), [0, 3, 4, 1]);
        assert_eq!(m.element_nodes(3), [4, 7, 8, 5]);
        assert_eq!(m.element_nodes(5), [7, 10, 11, 8]);
        assert_eq!(m.nodes_on_edge(Edge::Right), vec![9, 10, 11]);
        assert_eq!(m.nodes_on_edge(Edge::Top), vec![2, 5, 8, 11]);
        assert_eq!(m.nearest_node([1.4, 0.6]), 4);
        assert_eq!(m.node_coords(7), [2.0, 1.0]);
        assert_eq!(m.elements_in_box([0.0, 0.0], [1.0, 2.0]), vec![0, 1]);
    }
}
