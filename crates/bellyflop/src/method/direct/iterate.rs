//! The primal–dual iterate (w, λ, z_L, z_U) and the simple bounds l ≤ w ≤ u
//! that the barrier keeps it inside.

#![allow(clippy::needless_range_loop)] // Dense block algebra indexes several arrays by one index.

use crate::collocation::derivatives::Differentiable;
use crate::method::direct::nlp::Transcription;

/// The primal–dual iterate.
pub(super) struct Iterate {
    pub(super) w: Vec<f64>,
    pub(super) lambda: Vec<f64>,
    pub(super) zl: Vec<f64>,
    pub(super) zu: Vec<f64>,
    /// The multipliers of the operational rows ([`super::rows`]).
    pub(super) zr: Vec<f64>,
}

/// Which bounds each variable has (fixed variables have neither).
pub(super) struct Bounds {
    pub(super) lo: Vec<f64>,
    pub(super) hi: Vec<f64>,
    pub(super) has_lo: Vec<bool>,
    pub(super) has_hi: Vec<bool>,
    pub(super) free: Vec<bool>,
}

impl Bounds {
    pub(super) fn new<M: Differentiable, const NS: usize, const NL: usize>(
        nlp: &Transcription<M, NS, NL>,
    ) -> Self {
        let n = nlp.n_var();
        let free: Vec<bool> = (0..n).map(|j| !nlp.is_fixed(j)).collect();
        Bounds {
            has_lo: (0..n).map(|j| free[j] && nlp.lo[j].is_finite()).collect(),
            has_hi: (0..n).map(|j| free[j] && nlp.hi[j].is_finite()).collect(),
            lo: nlp.lo.clone(),
            hi: nlp.hi.clone(),
            free,
        }
    }

    /// Set to `nlp`'s bounds in place (as [`Bounds::new`], without
    /// allocating once the vectors have their size).
    pub(super) fn refill<M: Differentiable, const NS: usize, const NL: usize>(
        &mut self,
        nlp: &Transcription<M, NS, NL>,
    ) {
        let n = nlp.n_var();
        self.free.clear();
        self.free.extend((0..n).map(|j| !nlp.is_fixed(j)));
        let free = &self.free;
        self.has_lo.clear();
        self.has_lo
            .extend((0..n).map(|j| free[j] && nlp.lo[j].is_finite()));
        self.has_hi.clear();
        self.has_hi
            .extend((0..n).map(|j| free[j] && nlp.hi[j].is_finite()));
        self.lo.clone_from(&nlp.lo);
        self.hi.clone_from(&nlp.hi);
    }

    /// Push a point strictly inside the bounds by `push` (relative, §3.6)
    /// and set fixed values.
    pub(super) fn push_inside(&self, w: &mut [f64], push: f64) {
        for j in 0..w.len() {
            if !self.free[j] {
                w[j] = self.lo[j];
                continue;
            }
            let (l, u) = (self.lo[j], self.hi[j]);
            let gap = if self.has_lo[j] && self.has_hi[j] {
                u - l
            } else {
                f64::INFINITY
            };
            if self.has_lo[j] {
                let p = (push * l.abs().max(1.0)).min(push * gap);
                w[j] = w[j].max(l + p);
            }
            if self.has_hi[j] {
                let p = (push * u.abs().max(1.0)).min(push * gap);
                w[j] = w[j].min(u - p);
            }
        }
    }

    /// The barrier term −μ Σ ln(slack) of φ_μ.
    pub(super) fn barrier(&self, w: &[f64], mu: f64) -> f64 {
        let mut b = 0.0;
        for j in 0..w.len() {
            if self.has_lo[j] {
                b -= mu * (w[j] - self.lo[j]).ln();
            }
            if self.has_hi[j] {
                b -= mu * (self.hi[j] - w[j]).ln();
            }
        }
        b
    }

    /// Largest α ≤ 1 with w + α·dw keeping a fraction τ of each slack.
    pub(super) fn max_step(&self, w: &[f64], dw: &[f64], tau: f64) -> f64 {
        let mut a = 1.0f64;
        for j in 0..w.len() {
            if self.has_lo[j] && dw[j] < 0.0 {
                a = a.min(-tau * (w[j] - self.lo[j]) / dw[j]);
            }
            if self.has_hi[j] && dw[j] > 0.0 {
                a = a.min(tau * (self.hi[j] - w[j]) / dw[j]);
            }
        }
        a
    }
}

pub(super) fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

pub(super) fn l1_norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x.abs()).sum()
}
