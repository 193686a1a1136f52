//! R on an hp mesh: a block-tridiagonal matrix with an arrow border,
//! factored block by block.
//!
//! Order R's kept multipliers interval by interval (state-major inside an
//! interval: kept state c at the interval's point a is row (c − c0)·n_k + a),
//! then ν and t̂_f. Below, r is the number of kept states per point, 7 (z … δ)
//! when x is eliminated and 8 when the cone keeps it (c0 = 1 or 0). A defect of interval k touches only the n_k + 1 nodes of k, and
//! the last of them is the first node s_{k+1} of interval k + 1, so
//!
//! ```text
//!      [ A_0  C_0ᵀ               F_0ᵀ ]
//!      [ C_0  A_1  C_1ᵀ          F_1ᵀ ]
//! R =  [      C_1  A_2  ⋱        F_2ᵀ ]     C_k = U_k V_kᵀ,
//!      [            ⋱   ⋱        ⋮    ]
//!      [ F_0  F_1  F_2  …        Z    ]
//! ```
//!
//! with A_k = −S over interval k (dense, r·n_k square), F_k the rows of ν and
//! t̂_f, and C_k the coupling through node s_{k+1} alone: of rank r, with
//! V_k = D_{·,s_{k+1}} ⊗ I_r over k's rows and U_k[(a, c), c′] = −D_{a,s_{k+1}}
//! Q_s(c, c′) − [a = s_{k+1}] R_s(c′, c) over k + 1's (Q = E M Eᵀ, R = E M Bᵀ,
//! M = W_s⁻¹). Block elimination in interval order,
//!
//! ```text
//! Â_0 = A_0,   Â_{k+1} = A_{k+1} − U_k (V_kᵀ Â_k⁻¹ V_k) U_kᵀ,
//! F̂_{k+1} = F_{k+1} − (F̂_k Â_k⁻¹ V_k) U_kᵀ,   Ẑ = Z − Σ_k F̂_k Â_k⁻¹ F̂_kᵀ,
//! ```
//!
//! is a congruence, so In(R) = Σ_k In(Â_k) + In(Ẑ) (Sylvester). Each Â_k is
//! factored by the unpivoted LDLᵀ with the dense path's growth test; a block
//! that fails it sends the whole of R back to the dense Bunch–Kaufman path.
//! The rank-r coupling makes each step one LDLᵀ of r·n_k plus solves with
//! r + 2 right-hand sides, so the cost is Σ_k (7 n_k)³/3 instead of
//! (rN)³/3: with r = 7, on 8 intervals of 10 points, about 0.9 M multiply-adds against
//! 59 M.

use faer::linalg::matmul::matmul;
use faer::reborrow::ReborrowMut;
use faer::{Accum, MatMut, MatRef, Par};

use super::{Inertia, Ldlt, StateBlock};
use crate::collocation::mesh::Mesh;

/// What R is made of, from the node blocks (every array as in
/// [`super::KktSolver`]): the first kept state c0 (R keeps states c0 … 7:
/// z … δ, or x … δ where x is not eliminated), D (N × (N + 1),
/// column-major), per node Q (M by state, zero where a state is fixed), per
/// point (R_k, T_k) by state, ν's and t̂_f's rows state-major (g's entry
/// N·nr is ν's) and ν's diagonal.
pub(super) struct Terms<'a, const NS: usize> {
    pub c0: usize,
    pub d: &'a [f64],
    pub q: &'a [StateBlock<NS>],
    pub cross: &'a [(StateBlock<NS>, StateBlock<NS>)],
    pub s_nu: &'a [f64],
    pub g: &'a [f64],
    pub nu_diagonal: f64,
    pub a: f64,
    pub delta_c: f64,
}

/// One interval's rows of R and their factors.
struct Block {
    /// The interval's first point and its number of points n_k.
    first: usize,
    points: usize,
    /// Â_k (r·n_k square, column-major): formed in its lower triangle, then
    /// its LDLᵀ factors.
    a: Vec<f64>,
    /// F̂_kᵀ (r·n_k × 2: ν's column, then t̂_f's).
    ft: Vec<f64>,
    /// Â_k⁻¹ F̂_kᵀ.
    y: Vec<f64>,
    /// Â_k⁻¹ V_k (r·n_k × r), when there is a next interval.
    g: Vec<f64>,
    /// U_k (r·n_{k+1} × r), when there is a next interval.
    u: Vec<f64>,
    /// D's column of node s_{k+1} over this interval's points.
    v: Vec<f64>,
    /// The solve's values over the block.
    w: Vec<f64>,
}

/// The block-tridiagonal LDLᵀ of R with its border, and its storage.
pub(super) struct Banded {
    n: usize,
    /// Kept states per point (7, or 8 with x).
    nr: usize,
    blocks: Vec<Block>,
    ldlt: Ldlt,
    /// Ẑ, and its inverse (2 × 2).
    z: [[f64; 2]; 2],
    z_inv: [[f64; 2]; 2],
    /// Work space: P for the D ⊗ I products, r·n_max × (n_max + 1), and
    /// U_k H_k, r·n_max × r.
    p: Vec<f64>,
    uh: Vec<f64>,
}

impl Banded {
    /// Storage for `mesh` (two or more intervals), `nr` kept states per
    /// point.
    pub(super) fn new(mesh: &Mesh, nr: usize) -> Self {
        let ivs = &mesh.intervals;
        let blocks: Vec<Block> = ivs
            .iter()
            .enumerate()
            .map(|(k, iv)| {
                let m = nr * iv.points;
                let next = ivs.get(k + 1);
                let v = match next {
                    Some(nx) => (0..iv.points)
                        .map(|a| {
                            let (first, row) = mesh.d_row(iv.start + a);
                            row[nx.start - first]
                        })
                        .collect(),
                    None => vec![],
                };
                Block {
                    first: iv.start,
                    points: iv.points,
                    a: vec![0.0; m * m],
                    ft: vec![0.0; 2 * m],
                    y: vec![0.0; 2 * m],
                    g: vec![0.0; if next.is_some() { nr * m } else { 0 }],
                    u: vec![0.0; next.map_or(0, |nx| nr * nr * nx.points)],
                    v,
                    w: vec![0.0; m],
                }
            })
            .collect();
        let n_max = ivs.iter().map(|iv| iv.points).max().unwrap_or(0);
        Banded {
            n: mesh.n,
            nr,
            blocks,
            ldlt: Ldlt::new(nr * n_max),
            z: [[0.0; 2]; 2],
            z_inv: [[0.0; 2]; 2],
            p: vec![0.0; nr * n_max * (n_max + 1)],
            uh: vec![0.0; nr * n_max * nr],
        }
    }

    /// Back to the state of [`Banded::new`] (the structure, D's columns
    /// `v` among it, stays).
    pub(super) fn reset(&mut self) {
        for b in &mut self.blocks {
            for v in [&mut b.a, &mut b.ft, &mut b.y, &mut b.g, &mut b.u, &mut b.w] {
                v.fill(0.0);
            }
        }
        self.ldlt.reset();
        self.z = [[0.0; 2]; 2];
        self.z_inv = [[0.0; 2]; 2];
        self.p.fill(0.0);
        self.uh.fill(0.0);
    }

    /// Form and factor R; its inertia, or None when a block's unpivoted
    /// LDLᵀ meets a zero pivot or grows beyond `growth_max`.
    pub(super) fn factor<const NS: usize>(
        &mut self,
        t: &Terms<NS>,
        growth_max: f64,
    ) -> Option<Inertia> {
        let (n, nr) = (self.n, self.nr);
        let nu = nr * n;
        self.z = [[t.nu_diagonal, t.g[nu]], [t.g[nu], t.a]];
        let mut inertia = Inertia::default();
        form_block(&mut self.blocks[0], &mut self.p, t, n, nr);
        for k in 0..self.blocks.len() {
            let (head, tail) = self.blocks.split_at_mut(k + 1);
            let b = &mut head[k];
            let (np, m) = (b.points, nr * b.points);
            inertia = inertia + self.ldlt.factor(&mut b.a, m, growth_max)?;
            b.y.copy_from_slice(&b.ft);
            Ldlt::solve_cols(&b.a, &mut b.y, 2);
            for i in 0..2 {
                for j in 0..2 {
                    self.z[i][j] -= dot(&b.ft[i * m..(i + 1) * m], &b.y[j * m..(j + 1) * m]);
                }
            }
            let Some(next) = tail.first_mut() else {
                break;
            };
            // G = Â⁻¹V, H = VᵀG and VᵀY (V = v ⊗ I_r).
            b.g.iter_mut().for_each(|x| *x = 0.0);
            for c in 0..nr {
                b.g[c * m + c * np..c * m + (c + 1) * np].copy_from_slice(&b.v);
            }
            Ldlt::solve_cols(&b.a, &mut b.g, nr);
            let vt = |col: &[f64], c: usize| dot(&b.v, &col[c * np..(c + 1) * np]);
            let mut h = [[0.0; NS]; NS];
            let mut vy = [[0.0; 2]; NS];
            for c in 0..nr {
                for c2 in 0..nr {
                    h[c][c2] = vt(&b.g[c2 * m..(c2 + 1) * m], c);
                }
                for j in 0..2 {
                    vy[c][j] = vt(&b.y[j * m..(j + 1) * m], c);
                }
            }
            coupling(&mut b.u, next.first, next.points, t, (n, nr));
            form_block(next, &mut self.p, t, n, nr);
            // Â_{k+1} −= U H Uᵀ (lower block triangle), F̂_{k+1}ᵀ −= U VᵀY.
            let mn = nr * next.points;
            for r in 0..mn {
                for c2 in 0..nr {
                    self.uh[c2 * mn + r] = (0..nr).map(|c| b.u[c * mn + r] * h[c][c2]).sum();
                }
                for j in 0..2 {
                    next.ft[j * mn + r] -= (0..nr).map(|c| b.u[c * mn + r] * vy[c][j]).sum::<f64>();
                }
            }
            let uh = MatRef::from_column_major_slice(&self.uh[..mn * nr], mn, nr);
            let u = MatRef::from_column_major_slice(&b.u, mn, nr);
            let mut an = MatMut::from_column_major_slice_mut(&mut next.a, mn, mn);
            let npn = next.points;
            for c2 in 0..nr {
                let lo = c2 * npn;
                matmul(
                    an.rb_mut().submatrix_mut(lo, lo, mn - lo, npn),
                    Accum::Add,
                    uh.subrows(lo, mn - lo),
                    u.subrows(lo, npn).transpose(),
                    -1.0,
                    Par::Seq,
                );
            }
        }
        let [[z00, z01], [_, z11]] = self.z;
        // Ẑ's eigenvalues, and its inverse by its determinant.
        let (mid, rad) = (
            0.5 * (z00 + z11),
            (0.25 * (z00 - z11).powi(2) + z01 * z01).sqrt(),
        );
        let scale = mid.abs() + rad;
        inertia.count_pivot(mid + rad, scale);
        inertia.count_pivot(mid - rad, scale);
        let det = z00 * z11 - z01 * z01;
        self.z_inv = [[z11 / det, -z01 / det], [-z01 / det, z00 / det]];
        Some(inertia)
    }

    /// Solve R x = b in place, `rl` in the dense path's order (state-major
    /// over the points, then ν and t̂_f).
    pub(super) fn solve<const NS: usize>(&mut self, rl: &mut [f64]) {
        let (n, nr) = (self.n, self.nr);
        let nu = nr * n;
        let mut bz = [rl[nu], rl[nu + 1]];
        for b in &mut self.blocks {
            gather(b, rl, n, nr);
        }
        // Forward: w_k = Â_k⁻¹ b̂_k, b̂_{k+1} = b_{k+1} − U_k Vᵀ w_k, b̂_z −= F̂_k w_k.
        for k in 0..self.blocks.len() {
            let (head, tail) = self.blocks.split_at_mut(k + 1);
            let b = &mut head[k];
            let (np, m) = (b.points, nr * b.points);
            Ldlt::solve_cols(&b.a, &mut b.w, 1);
            for (j, z) in bz.iter_mut().enumerate() {
                *z -= dot(&b.ft[j * m..(j + 1) * m], &b.w);
            }
            if let Some(next) = tail.first_mut() {
                let mut vw = [0.0; NS];
                for (c, v) in vw.iter_mut().enumerate().take(nr) {
                    *v = dot(&b.v, &b.w[c * np..(c + 1) * np]);
                }
                let mn = nr * next.points;
                for (r, x) in next.w.iter_mut().enumerate() {
                    *x -= (0..nr).map(|c| b.u[c * mn + r] * vw[c]).sum::<f64>();
                }
            }
        }
        let zi = &self.z_inv;
        let uz = [
            zi[0][0] * bz[0] + zi[0][1] * bz[1],
            zi[1][0] * bz[0] + zi[1][1] * bz[1],
        ];
        // Backward: x_k = w_k − G_k U_kᵀ x_{k+1} − Y_k x_z.
        for k in (0..self.blocks.len()).rev() {
            let (head, tail) = self.blocks.split_at_mut(k + 1);
            let b = &mut head[k];
            let m = nr * b.points;
            for (r, x) in b.w.iter_mut().enumerate() {
                *x -= b.y[r] * uz[0] + b.y[m + r] * uz[1];
            }
            if let Some(next) = tail.first() {
                let mn = nr * next.points;
                let mut ux = [0.0; NS];
                for (c, v) in ux.iter_mut().enumerate().take(nr) {
                    *v = dot(&b.u[c * mn..(c + 1) * mn], &next.w);
                }
                for (r, x) in b.w.iter_mut().enumerate() {
                    *x -= (0..nr).map(|c| b.g[c * m + r] * ux[c]).sum::<f64>();
                }
            }
        }
        for b in &self.blocks {
            for c in 0..nr {
                let (s, np) = (b.first, b.points);
                rl[c * n + s..c * n + s + np].copy_from_slice(&b.w[c * np..(c + 1) * np]);
            }
        }
        rl[nu] = uz[0];
        rl[nu + 1] = uz[1];
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The block's right-hand side, from `rl` (state-major over all points).
fn gather(b: &mut Block, rl: &[f64], n: usize, nr: usize) {
    let (s, np) = (b.first, b.points);
    for c in 0..nr {
        b.w[c * np..(c + 1) * np].copy_from_slice(&rl[c * n + s..c * n + s + np]);
    }
}

/// A_k = −S over the block's rows (lower block triangle: state c ≥ c2) and
/// F_kᵀ:
///
/// S[(a, c), (b, c2)] = Σ_ℓ D_aℓ D_bℓ Q_ℓ(c, c2) + D_ab R_b(c, c2)
///                      + D_ba R_a(c2, c) + [a = b] T_a(c, c2) + δ_c [a = b, c = c2],
///
/// ℓ over the interval's n_k + 1 nodes; the D ⊗ Q part is one product
/// P·D_kᵀ per block column (faer's matmul), as on the dense path.
fn form_block<const NS: usize>(b: &mut Block, p: &mut [f64], t: &Terms<NS>, n: usize, nr: usize) {
    let (s, np) = (b.first, b.points);
    let c0 = t.c0;
    let m = nr * np;
    let dk = MatRef::from_column_major_slice(t.d, n, n + 1).submatrix(s, s, np, np + 1);
    let mut a = MatMut::from_column_major_slice_mut(&mut b.a, m, m);
    for c2 in 0..nr {
        for l in 0..=np {
            let col = &t.d[(s + l) * n + s..(s + l) * n + s + np];
            for c in c2..nr {
                let q = t.q[s + l][c + c0][c2 + c0];
                for (x, d) in p[l * m + c * np..l * m + (c + 1) * np].iter_mut().zip(col) {
                    *x = d * q;
                }
            }
        }
        let pm = MatRef::from_column_major_slice(&p[..m * (np + 1)], m, np + 1);
        let lo = c2 * np;
        matmul(
            a.rb_mut().submatrix_mut(lo, lo, m - lo, np),
            Accum::Replace,
            pm.subrows(lo, m - lo),
            dk.transpose(),
            -1.0,
            Par::Seq,
        );
    }
    let a = &mut b.a;
    for c2 in 0..nr {
        for bb in 0..np {
            let j = s + bb;
            let (rj, tj) = &t.cross[j];
            let base = (c2 * np + bb) * m;
            for c in c2..nr {
                let col = &mut a[base + c * np..base + (c + 1) * np];
                for (aa, x) in col.iter_mut().enumerate() {
                    let i = s + aa;
                    *x -= t.d[j * n + i] * rj[c + c0][c2 + c0]
                        + t.d[i * n + j] * t.cross[i].0[c2 + c0][c + c0];
                }
                col[bb] -= tj[c + c0][c2 + c0];
            }
            a[base + c2 * np + bb] -= t.delta_c;
        }
    }
    for c in 0..nr {
        for aa in 0..np {
            let i = c * n + s + aa;
            b.ft[c * np + aa] = -t.s_nu[i];
            b.ft[m + c * np + aa] = t.g[i];
        }
    }
}

/// U_k over the next interval's rows (first point `s`, `np` points):
/// U[(a, c), c′] = −(D_{s+a,s} Q_s(c, c′) + [a = 0] R_s(c′, c)).
fn coupling<const NS: usize>(
    u: &mut [f64],
    s: usize,
    np: usize,
    t: &Terms<NS>,
    (n, nr): (usize, usize),
) {
    let mn = nr * np;
    let c0 = t.c0;
    let (q, r) = (&t.q[s], &t.cross[s].0);
    for c2 in 0..nr {
        for c in 0..nr {
            for aa in 0..np {
                u[c2 * mn + c * np + aa] = -t.d[s * n + s + aa] * q[c + c0][c2 + c0];
            }
            u[c2 * mn + c * np] -= r[c2 + c0][c + c0];
        }
    }
}
