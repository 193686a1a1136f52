//! The collocation mesh: one global LGR interval (the paper's Section 3.2) or an
//! hp mesh of several LGR intervals (as in GPOPS-II).
//!
//! τ ∈ [−1, 1] is split at breaks −1 = τ_0 < τ_1 < … < τ_M = 1, and interval
//! k carries n_k LGR points mapped affinely onto [τ_k, τ_{k+1}] ([`Mesh::new`],
//! its shape a [`MeshLayout`]). The uniform mesh ([`Mesh::uniform`], a
//! scenario's unless it gives `[discretization.mesh]`) has τ_k = −1 + 2k/M,
//! n_k = ⌊N/M⌋, and the first N mod M intervals take one more. An interval's non-collocated end point is the
//! next interval's first point, so the state is continuous by construction and
//! the mesh has N collocation points and N + 1 state nodes, as the global mesh.
//!
//! On interval k of width h_k, the collocation constraints of Eq. (24) read
//!
//! ```text
//! (2/h_k) Σ_j D^(k)_ij X_{s_k + j} − (t_f/2) f(X_i, U_i) = 0,
//! ```
//!
//! with D^(k) the n_k×(n_k + 1) LGR matrix of [`Lgr`] and s_k the interval's
//! first node. The global differentiation matrix is therefore block-banded
//! rather than dense: each state couples only to the n_k + 1 nodes of its own
//! interval, so the interior-point KKT factorization no longer fills in (the
//! cost of one subproblem grows linearly in N instead of cubically). M = 1 is
//! exactly the paper's global mesh.

use crate::collocation::radau::{interpolate, interpolate_by, Lgr};
use crate::input::mesh_layout::MeshLayout;
use crate::input::scenario::Discretization;

/// One LGR interval of the mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Interval {
    /// Index of the interval's first node (= its first collocation point).
    pub start: usize,
    /// Number of collocation points n_k.
    pub points: usize,
    /// Interval bounds in τ.
    pub tau_lo: f64,
    pub tau_hi: f64,
    /// The interval's LGR rule on [−1, 1].
    pub lgr: Lgr,
}

/// A mesh of LGR intervals with N collocation points and N + 1 state nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Number of collocation points N.
    pub n: usize,
    pub intervals: Vec<Interval>,
    /// N + 1 nodes in τ, strictly increasing: the collocation points, then +1.
    pub nodes: Vec<f64>,
    /// N quadrature weights on [−1, 1] (each interval's LGR weights × h_k/2).
    pub weights: Vec<f64>,
    /// For each collocation point i: its interval's first node s_k and the row
    /// (2/h_k)·D^(k)_i· over nodes s_k..=s_k + n_k.
    rows: Vec<(usize, Vec<f64>)>,
}

impl Mesh {
    /// The paper's global mesh: one LGR interval with `n` points.
    pub fn global(n: usize) -> Mesh {
        Mesh::uniform(n, 1)
    }

    /// `n` collocation points over `intervals` equal intervals in τ: breaks
    /// τ_k = −1 + 2k/M, n_k = ⌊N/M⌋ and the first N mod M intervals one more
    /// ([`Mesh::new`] on that layout).
    ///
    /// # Panics
    /// Panics unless 1 ≤ `intervals` and every interval has at least one
    /// point (`n ≥ intervals`); scenario validation enforces stricter bounds.
    pub fn uniform(n: usize, intervals: usize) -> Mesh {
        assert!(
            intervals >= 1 && n >= intervals,
            "a mesh needs 1 ≤ intervals ≤ N"
        );
        Mesh::from_layout(&MeshLayout::uniform(n, intervals))
    }

    /// [`Mesh::new`] on a layout's breaks and point counts.
    pub fn from_layout(layout: &MeshLayout) -> Mesh {
        Mesh::new(&layout.breaks_tau, &layout.points)
    }

    /// A general hp mesh: interval k spans [`breaks_tau[k]`, `breaks_tau[k+1]`]
    /// and carries `points[k]` LGR points, mapped affinely,
    /// τ = τ_k + (h_k/2)(τ̂ + 1) with h_k = τ_{k+1} − τ_k, weights (h_k/2)·ŵ
    /// and differentiation rows (2/h_k)·D^(k) (Eq. 24 on each interval).
    ///
    /// With one interval the nodes are the LGR rule's own, bit for bit.
    ///
    /// # Panics
    /// Panics unless there is at least one interval, `breaks_tau` has one
    /// more entry than `points`, runs from −1 to +1 strictly increasing and
    /// every interval has at least one point. Scenario validation
    /// ([`crate::input::validate`]) enforces this, and more, on input.
    pub fn new(breaks_tau: &[f64], points: &[usize]) -> Mesh {
        let m = points.len();
        assert!(
            m >= 1 && breaks_tau.len() == m + 1,
            "a mesh needs M ≥ 1 intervals and M + 1 breaks"
        );
        assert!(
            breaks_tau[0] == -1.0
                && breaks_tau[m] == 1.0
                && breaks_tau.windows(2).all(|w| w[0] < w[1]),
            "mesh breaks must run from -1 to 1, strictly increasing"
        );
        assert!(
            points.iter().all(|&p| p >= 1),
            "every interval needs a point"
        );
        let n: usize = points.iter().sum();
        let mut out = Vec::with_capacity(m);
        let mut nodes = Vec::with_capacity(n + 1);
        let mut weights = Vec::with_capacity(n);
        let mut rows = Vec::with_capacity(n);
        let mut start = 0;
        for (k, &points) in points.iter().enumerate() {
            let (tau_lo, tau_hi) = (breaks_tau[k], breaks_tau[k + 1]);
            let half = 0.5 * (tau_hi - tau_lo);
            let lgr = Lgr::new(points);
            for i in 0..points {
                // One interval is the LGR rule itself, bit for bit.
                nodes.push(if m == 1 {
                    lgr.nodes[i]
                } else {
                    tau_lo + half * (lgr.nodes[i] + 1.0)
                });
                weights.push(half * lgr.weights[i]);
                rows.push((start, (0..=points).map(|j| lgr.d(i, j) / half).collect()));
            }
            out.push(Interval {
                start,
                points,
                tau_lo,
                tau_hi,
                lgr,
            });
            start += points;
        }
        nodes.push(1.0);
        Mesh {
            n,
            intervals: out,
            nodes,
            weights,
            rows,
        }
    }

    /// The mesh's breaks and point counts, as a serializable value
    /// ([`Mesh::from_layout`] rebuilds the same mesh from it).
    pub fn layout(&self) -> MeshLayout {
        let mut breaks_tau: Vec<f64> = self.intervals.iter().map(|iv| iv.tau_lo).collect();
        breaks_tau.extend(self.intervals.last().map(|iv| iv.tau_hi));
        MeshLayout {
            breaks_tau,
            points: self.intervals.iter().map(|iv| iv.points).collect(),
        }
    }

    /// Whether `layout` is this mesh's ([`Self::layout`]), compared without
    /// building it.
    pub fn has_layout(&self, layout: &MeshLayout) -> bool {
        let ivs = &self.intervals;
        layout.points.len() == ivs.len()
            && layout.breaks_tau.len() == ivs.len() + 1
            && ivs
                .iter()
                .zip(&layout.points)
                .all(|(iv, &p)| iv.points == p)
            && ivs
                .iter()
                .zip(&layout.breaks_tau)
                .all(|(iv, &b)| iv.tau_lo.to_bits() == b.to_bits())
            && ivs.last().map(|iv| iv.tau_hi.to_bits())
                == layout.breaks_tau.last().map(|b| b.to_bits())
    }

    /// Row i of the global differentiation matrix: (first node, entries).
    /// Entry j of the slice multiplies state node `first + j`.
    #[inline]
    pub fn d_row(&self, i: usize) -> (usize, &[f64]) {
        let (s, ref r) = self.rows[i];
        (s, r)
    }

    /// D by columns: for each node k, the collocation points i with
    /// D_ik ≠ 0 and D_ik (the transpose products of a KKT solve).
    pub fn d_columns(&self) -> Vec<Vec<(usize, f64)>> {
        let mut cols = vec![Vec::new(); self.n + 1];
        for row in 0..self.n {
            let (first, entries) = self.d_row(row);
            for (j, &v) in entries.iter().enumerate() {
                if v != 0.0 {
                    cols[first + j].push((row, v));
                }
            }
        }
        cols
    }

    /// Physical time of node `k` (`k ≤ n`): t_k = (τ_k + 1)·t_f/2.
    #[inline]
    pub fn time_s(&self, k: usize, tf_s: f64) -> f64 {
        (self.nodes[k] + 1.0) * tf_s / 2.0
    }

    /// Index of the interval containing `tau` (clamped to the mesh).
    pub fn interval_of(&self, tau: f64) -> usize {
        self.intervals
            .iter()
            .position(|iv| tau < iv.tau_hi)
            .unwrap_or(self.intervals.len() - 1)
    }

    /// The piecewise state interpolant: on interval k, the degree-n_k
    /// polynomial through its n_k + 1 nodes (`values` has N + 1 entries).
    pub fn interpolate_states(&self, values: &[f64], tau: f64) -> f64 {
        assert_eq!(values.len(), self.n + 1, "need N + 1 state values");
        let iv = &self.intervals[self.interval_of(tau)];
        let r = iv.start..=iv.start + iv.points;
        interpolate(&self.nodes[r.clone()], &iv.lgr.bary, &values[r], tau)
    }

    /// The piecewise control interpolant: on interval k, the degree-(n_k − 1)
    /// polynomial through its n_k collocation points, extrapolated to the
    /// interval's end (`values` has N entries).
    pub fn interpolate_controls(&self, values: &[f64], tau: f64) -> f64 {
        assert_eq!(values.len(), self.n, "need N control values");
        let iv = &self.intervals[self.interval_of(tau)];
        let r = iv.start..iv.start + iv.points;
        interpolate(
            &self.nodes[r.clone()],
            &iv.lgr.control_bary,
            &values[r],
            tau,
        )
    }

    /// [`Self::interpolate_states`] with node k's value given by
    /// `value(k)`, called only on the interval of `tau` (no buffer).
    pub fn interpolate_states_by(&self, value: impl Fn(usize) -> f64, tau: f64) -> f64 {
        let iv = &self.intervals[self.interval_of(tau)];
        let r = iv.start..=iv.start + iv.points;
        interpolate_by(&self.nodes[r], &iv.lgr.bary, |j| value(iv.start + j), tau)
    }

    /// [`Self::interpolate_controls`] with collocation point i's value
    /// given by `value(i)`, called only on the interval of `tau`.
    pub fn interpolate_controls_by(&self, value: impl Fn(usize) -> f64, tau: f64) -> f64 {
        let iv = &self.intervals[self.interval_of(tau)];
        let r = iv.start..iv.start + iv.points;
        interpolate_by(
            &self.nodes[r],
            &iv.lgr.control_bary,
            |j| value(iv.start + j),
            tau,
        )
    }
}

/// The collocation mesh a scenario asks for (here, not in `input`, which
/// does not depend on the collocation).
impl Discretization {
    /// The collocation mesh: the explicit `[discretization.mesh]` layout
    /// when given, else the uniform split of `nodes` over `intervals`. The
    /// discretization must have passed validation.
    pub fn collocation_mesh(&self) -> Mesh {
        match &self.mesh {
            Some(layout) => Mesh::from_layout(layout),
            None => Mesh::uniform(self.nodes, self.intervals),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn global_mesh_is_the_lgr_rule() {
        let n = 12;
        let (mesh, lgr) = (Mesh::global(n), Lgr::new(n));
        assert_eq!(mesh.nodes, lgr.nodes);
        assert_eq!(mesh.weights, lgr.weights);
        for i in 0..n {
            let (s, row) = mesh.d_row(i);
            assert_eq!(s, 0);
            for (j, v) in row.iter().enumerate() {
                assert_eq!(*v, lgr.d(i, j));
            }
        }
    }

    #[test]
    fn points_split_as_documented() {
        let mesh = Mesh::uniform(22, 4);
        let pts: Vec<usize> = mesh.intervals.iter().map(|iv| iv.points).collect();
        assert_eq!(pts, [6, 6, 5, 5]);
        assert_eq!(mesh.nodes.len(), 23);
        assert!(mesh.nodes.windows(2).all(|w| w[0] < w[1]));
        // Each interval starts at its boundary.
        for iv in &mesh.intervals {
            assert!((mesh.nodes[iv.start] - iv.tau_lo).abs() < 1e-15);
        }
        assert!((mesh.weights.iter().sum::<f64>() - 2.0).abs() < 1e-13);
    }

    /// The piecewise rule differentiates any polynomial of degree ≤ min n_k
    /// exactly, and the quadrature integrates degree ≤ 2·min n_k − 2 exactly.
    #[test]
    fn differentiation_and_quadrature_are_exact() {
        for (n, m) in [(20, 4), (21, 5), (40, 8), (9, 3)] {
            let mesh = Mesh::uniform(n, m);
            let deg = mesh.intervals.iter().map(|iv| iv.points).min().unwrap();
            let p = |t: f64| {
                (0..=deg)
                    .map(|k| (0.3 + k as f64) * t.powi(k as i32))
                    .sum::<f64>()
            };
            let dp = |t: f64| {
                (1..=deg)
                    .map(|k| (0.3 + k as f64) * k as f64 * t.powi(k as i32 - 1))
                    .sum::<f64>()
            };
            let vals: Vec<f64> = mesh.nodes.iter().map(|&t| p(t)).collect();
            for i in 0..n {
                let (s, row) = mesh.d_row(i);
                let d: f64 = row.iter().enumerate().map(|(j, v)| v * vals[s + j]).sum();
                let want = dp(mesh.nodes[i]);
                assert!(
                    (d - want).abs() < 1e-8 * want.abs().max(1.0),
                    "{n}/{m} row {i}"
                );
            }
            let q = 2 * deg - 2;
            let integral: f64 = (0..n)
                .map(|i| mesh.weights[i] * mesh.nodes[i].powi(q as i32))
                .sum();
            let exact = (1.0 - (-1.0f64).powi(q as i32 + 1)) / (q as f64 + 1.0);
            assert!((integral - exact).abs() < 1e-12, "{n}/{m}");
            // Interpolation reproduces the polynomial between nodes.
            for t in [-0.95, -0.3, 0.01, 0.77, 0.999] {
                assert!((mesh.interpolate_states(&vals, t) - p(t)).abs() < 1e-9);
            }
        }
    }

    /// `Mesh::new` on breaks −1 + 2k/M written out is the uniform mesh, bit
    /// for bit, and a mesh's layout rebuilds it.
    #[test]
    fn new_on_uniform_breaks_is_the_uniform_mesh() {
        let mesh = Mesh::new(&[-1.0, -0.5, 0.0, 0.5, 1.0], &[6, 6, 5, 5]);
        assert_eq!(mesh, Mesh::uniform(22, 4));
        for (n, m) in [(12, 1), (20, 4), (21, 5), (40, 8), (9, 3), (100, 50)] {
            let uniform = Mesh::uniform(n, m);
            let layout = uniform.layout();
            assert_eq!(layout, MeshLayout::uniform(n, m), "{n}/{m}");
            assert_eq!((layout.nodes(), layout.intervals()), (n, m));
            let rebuilt = Mesh::from_layout(&layout);
            assert_eq!(rebuilt, uniform, "{n}/{m}");
            for (a, b) in rebuilt.nodes.iter().zip(&uniform.nodes) {
                assert_eq!(a.to_bits(), b.to_bits());
            }
        }
    }

    /// On non-uniform breaks and point counts: the weights sum to the span
    /// 2, each row of (2/h_k)·D^(k) annihilates constants and differentiates
    /// any polynomial of degree ≤ n_k exactly on its interval, and the state
    /// interpolant reproduces such a polynomial.
    #[test]
    fn non_uniform_mesh_differentiates_its_intervals_exactly() {
        let breaks = [-1.0, -0.93, -0.4, 0.05, 0.61, 1.0];
        let points = [3, 7, 2, 5, 4];
        let mesh = Mesh::new(&breaks, &points);
        assert_eq!(mesh.n, 21);
        assert_eq!(mesh.nodes.len(), 22);
        assert!(mesh.nodes.windows(2).all(|w| w[0] < w[1]));
        assert!((mesh.weights.iter().sum::<f64>() - 2.0).abs() < 1e-13);
        assert_eq!(mesh.layout().breaks_tau, breaks);
        assert_eq!(mesh.layout().points, points);
        for (k, iv) in mesh.intervals.iter().enumerate() {
            assert_eq!(mesh.nodes[iv.start], breaks[k]);
            assert_eq!(mesh.nodes[iv.start + iv.points], breaks[k + 1]);
            // Interval weights sum to its width h_k.
            let w: f64 = mesh.weights[iv.start..iv.start + iv.points].iter().sum();
            assert!((w - (breaks[k + 1] - breaks[k])).abs() < 1e-14, "{k}");
            let deg = iv.points as i32;
            let p = |t: f64| {
                (0..=deg)
                    .map(|j| (0.7 - 0.2 * j as f64) * t.powi(j))
                    .sum::<f64>()
            };
            let dp = |t: f64| {
                (1..=deg)
                    .map(|j| (0.7 - 0.2 * j as f64) * j as f64 * t.powi(j - 1))
                    .sum::<f64>()
            };
            let vals: Vec<f64> = mesh.nodes.iter().map(|&t| p(t)).collect();
            for i in iv.start..iv.start + iv.points {
                let (s, row) = mesh.d_row(i);
                assert_eq!(s, iv.start);
                assert_eq!(row.len(), iv.points + 1);
                let constant: f64 = row.iter().sum();
                let scale: f64 = row.iter().map(|v| v.abs()).sum();
                assert!(constant.abs() < 1e-13 * scale, "{k}/{i}: {constant}");
                let d: f64 = row.iter().enumerate().map(|(j, v)| v * vals[s + j]).sum();
                let want = dp(mesh.nodes[i]);
                assert!(
                    (d - want).abs() < 1e-9 * scale.max(1.0),
                    "{k}/{i}: {d} {want}"
                );
            }
            for a in [0.1, 0.5, 0.93] {
                let t = breaks[k] + a * (breaks[k + 1] - breaks[k]);
                assert_eq!(mesh.interval_of(t), k);
                assert!((mesh.interpolate_states(&vals, t) - p(t)).abs() < 1e-11);
            }
        }
    }
}
