//! The Hessian of the 6-DoF polish's Lagrangian in its parameters p, exact
//! to rounding through the RK4 steps of the shot (as the planar
//! [`crate::polish::hessian`]).
//!
//! Λ(p) = λ_fᵀ·x(t_f; p) + Σ_i ζ_i·z(s_i; p), with λ_f and ζ from the last
//! QP's multipliers ([`super::lagrangian_gradient`] is ∇Λ). One RK4 step of
//! node interval k (duration d_k) in its normalized time σ with step h,
//!
//!   x' = x + (h/6)·(K₁ + 2K₂ + 2K₃ + K₄),   K_i = d_k·f(Y_i, u(σ_i; p)),
//!   Y₁ = x,  Y₂ = x + (h/2)·K₁,  Y₃ = x + (h/2)·K₂,  Y₄ = x + h·K₃,
//!
//! is linear in (x, K) except for the four stage equations. With κ_i =
//! ∂Λ/∂K_i, from λ' = ∂Λ/∂x' backwards (G_i = d_k·∂f/∂x at stage i),
//!
//!   κ₄ = (h/6)·λ',  κ₃ = (h/3)·λ' + h·G₄ᵀκ₄,  κ₂ = (h/3)·λ' + (h/2)·G₃ᵀκ₃,
//!   κ₁ = (h/6)·λ' + (h/2)·G₂ᵀκ₂,   λ = λ' + Σ G_iᵀκ_i (+ ζ at a ground point),
//!
//! the Hessian is the sum over every stage of
//!
//!   Z_iᵀ · ∇²_{(Y, u, d_k)} [d_k·κ_iᵀ f(Y, u)] · Z_i  +  Σ_j g_ij·∇²χ_j(p),
//!
//! Z_i = ∂(Y_i, u_i, d_k)/∂p the stage's forward sensitivities, and the last
//! term the curvature of the secant rate χ_j = Δδ_j/d_k in p, weighted
//! by g_ij = d_k·κ_iᵀ ∂f/∂χ_j (u's thrust is linear in p). On node
//! interval k, Z_i = Z_loc,i·E_k with Z_loc,i the stage's sensitivities in
//! (x_k, p_local) (the shot's condensed ones) and E_k = ∂(x_k,
//! p_local)/∂p, so the sum is taken in (x_k, p_local) over the interval's
//! stages and mapped once at its end (`Pass`). The weighted
//! second derivatives of f come from the model's term-by-term
//! [`Differentiable::point_derivatives`].

use super::{
    control_partials, shoot_visiting, Controls6, Local, Setup, Shot, Stage, StatesOnly, Visit, NT,
};
use crate::collocation::derivatives::{Differentiable, PointDerivatives};
use crate::problem::six_dof::{self as six, su, NU, NX};

/// The stage's inputs (Y, u) and its interval's duration d_k.
const NV: usize = NX + NU + 1;
const D: usize = NX + NU;

/// ∇²Λ(p) (P², row-major, symmetric) for λ(t_f) = `lambda_f` and the
/// ground's weights ζ at step points `ground` (module docs).
pub(super) fn hessian(
    setup: &Setup,
    p: &[f64],
    lambda_f: &[f64; NX],
    ground: &[(usize, f64)],
) -> Vec<f64> {
    let kappa = stage_multipliers(setup, p, lambda_f, ground);
    let np = setup.par.len();
    let mut pass = Pass {
        setup,
        c: setup.controls(p),
        kappa,
        at: 0,
        partials: Vec::with_capacity(8),
        point: PointDerivatives::default(),
        z: vec![0.0; NV * NT],
        wz: vec![0.0; NV * NT],
        local: vec![0.0; NT * NT],
        e: vec![0.0; NT * np],
        we: vec![0.0; NT * np],
        h: vec![0.0; np * np],
    };
    let _: Shot = shoot_visiting(setup, p, &mut pass);
    let mut h = pass.h;
    // Symmetric to the last bit (the two triangles summed in different
    // orders differ by rounding).
    for i in 0..np {
        for j in 0..i {
            let v = 0.5 * (h[i * np + j] + h[j * np + i]);
            h[i * np + j] = v;
            h[j * np + i] = v;
        }
    }
    h
}

/// The Hessian's pass over the shot: each stage's Z_locᵀ·W·Z_loc summed
/// over an interval in (x_k, p_local) (NT²), then mapped to p at the
/// interval's end by E_k = ∂(x_k, p_local)/∂p: H += E_kᵀ·M_k·E_k. The
/// stages' Z = Z_loc·E_k, so this is Σ Zᵀ·W·Z at NT² per stage, not P².
struct Pass<'a> {
    setup: &'a Setup<'a>,
    c: Controls6,
    kappa: Vec<[f64; NX]>,
    at: usize,
    partials: Vec<(usize, usize, f64)>,
    point: PointDerivatives<NX, { NX + NU }>,
    /// Z_loc = ∂(Y, u, d_k)/∂(x_k, p_local) (NV rows of NT), and W·Z_loc.
    z: Vec<f64>,
    wz: Vec<f64>,
    /// M_k (NT²).
    local: Vec<f64>,
    /// E_k (NT rows of P), and M_k·E_k.
    e: Vec<f64>,
    we: Vec<f64>,
    h: Vec<f64>,
}

impl Visit for Pass<'_> {
    fn stage(&mut self, st: &Stage) {
        let (setup, c) = (self.setup, &self.c);
        let kap = &self.kappa[self.at];
        self.at += 1;
        let u = c.at_fraction(st.k, st.a);
        let dk = c.interval_s(st.k);
        let di = st.local.column(setup.par.duration(st.k));
        let input: [f64; NX + NU] =
            std::array::from_fn(|i| if i < NX { st.y[i] } else { u[i - NX] });
        let point = &mut self.point;
        setup
            .model
            .point_derivatives::<NX, { NX + NU }>(&input, &[1.0; NX + NU], kap, &[], point);
        // W = ∇²_{(Y, u, d_k)} [d_k·κᵀf].
        let mut w = [[0.0; NV]; NV];
        for a in 0..NX + NU {
            for b in 0..NX + NU {
                w[a][b] = dk * point.hess[a][b];
            }
            let g: f64 = (0..NX).map(|r| kap[r] * point.jac[r][a]).sum();
            w[a][D] = g;
            w[D][a] = g;
        }
        // Z_loc.
        self.z.fill(0.0);
        self.z[..NX * NT].copy_from_slice(st.t);
        control_partials(setup, c, st.k, st.a, &mut self.partials);
        for &(ui, pi, v) in &self.partials {
            self.z[(NX + ui) * NT + st.local.column(pi)] += v;
        }
        self.z[D * NT + di] = 1.0;
        add_quadratic_form(&mut self.local, NT, NT, &w, &self.z, &mut self.wz);
        // The secant rates' own curvature in (δ_k, δ_{k+1}, d_k).
        for j in 0..2 {
            let g = dk * w[NX + su::CHI + j][D];
            let chi = u[su::CHI + j];
            let m = &mut self.local;
            let mut add = |a: usize, b: usize, v: f64| {
                m[a * NT + b] += v;
                if a != b {
                    m[b * NT + a] += v;
                }
            };
            add(
                st.local.column(setup.par.delta(j, st.k + 1)),
                di,
                -g / (dk * dk),
            );
            if st.k >= 1 {
                add(st.local.column(setup.par.delta(j, st.k)), di, g / (dk * dk));
            }
            add(di, di, g * 2.0 * chi / (dk * dk));
        }
    }

    fn interval(&mut self, k: usize, s: &[f64], local: &Local) {
        let np = self.setup.par.len();
        let live = self.setup.par.live(k);
        self.e.fill(0.0);
        self.e[..NX * np].copy_from_slice(s);
        for j in 0..local.len {
            self.e[(NX + j) * np + local.params[j]] = 1.0;
        }
        let m: [[f64; NT]; NT] =
            std::array::from_fn(|a| std::array::from_fn(|b| self.local[a * NT + b]));
        add_quadratic_form(&mut self.h, np, live, &m, &self.e, &mut self.we);
        self.local.fill(0.0);
    }
}

/// H += Zᵀ·W·Z (Z: R rows of P, zero past column `live`; `wz` scratch of
/// the same size).
fn add_quadratic_form<const R: usize>(
    h: &mut [f64],
    np: usize,
    live: usize,
    w: &[[f64; R]; R],
    z: &[f64],
    wz: &mut [f64],
) {
    for a in 0..R {
        let out = &mut wz[a * np..a * np + live];
        out.fill(0.0);
        for b in 0..R {
            let wab = w[a][b];
            if wab != 0.0 {
                for (o, v) in out.iter_mut().zip(&z[b * np..b * np + live]) {
                    *o += wab * v;
                }
            }
        }
    }
    for a in 0..R {
        let (za, wza) = (&z[a * np..a * np + live], &wz[a * np..a * np + live]);
        for i in 0..live {
            let zi = za[i];
            if zi != 0.0 {
                let row = &mut h[i * np..i * np + live];
                for (o, v) in row.iter_mut().zip(wza) {
                    *o += zi * v;
                }
            }
        }
    }
}

/// κ_i of every stage in the order [`shoot_visiting`] shows them (module
/// docs), by one pass of the shot for the stage states (without
/// sensitivities) and one backwards.
fn stage_multipliers(
    setup: &Setup,
    p: &[f64],
    lambda_f: &[f64; NX],
    ground: &[(usize, f64)],
) -> Vec<[f64; NX]> {
    let c = setup.controls(p);
    // G_i = d_k·∂f/∂x at each stage.
    let mut g: Vec<[[f64; NX]; NX]> = Vec::new();
    let mut states = StatesOnly(|st: &Stage| {
        let u = c.at_fraction(st.k, st.a);
        let (_, jac) = six::jacobian(setup.model, st.y, &u);
        let dk = c.interval_s(st.k);
        g.push(std::array::from_fn(|r| {
            std::array::from_fn(|m| dk * jac[r][m])
        }));
    });
    shoot_visiting(setup, p, &mut states);
    let steps: Vec<f64> = (0..setup.par.n)
        .flat_map(|k| {
            let m = setup.substeps[k];
            let h = 1.0 / m as f64;
            std::iter::repeat_n(h, m)
        })
        .collect();
    // ζ by step: step n ≥ 1 starts at ground point n − 1.
    let mut zeta = vec![0.0; steps.len()];
    for &(point, weight) in ground {
        zeta[point + 1] += weight;
    }
    let gt = |g: &[[f64; NX]; NX], v: &[f64; NX]| -> [f64; NX] {
        std::array::from_fn(|m| (0..NX).map(|r| g[r][m] * v[r]).sum())
    };
    let mut kappa = vec![[0.0; NX]; 4 * steps.len()];
    let mut lambda = *lambda_f;
    for n in (0..steps.len()).rev() {
        let h = steps[n];
        let gs = &g[4 * n..4 * n + 4];
        let k4: [f64; NX] = std::array::from_fn(|r| h / 6.0 * lambda[r]);
        let g4 = gt(&gs[3], &k4);
        let k3: [f64; NX] = std::array::from_fn(|r| h / 3.0 * lambda[r] + h * g4[r]);
        let g3 = gt(&gs[2], &k3);
        let k2: [f64; NX] = std::array::from_fn(|r| h / 3.0 * lambda[r] + 0.5 * h * g3[r]);
        let g2 = gt(&gs[1], &k2);
        let k1: [f64; NX] = std::array::from_fn(|r| h / 6.0 * lambda[r] + 0.5 * h * g2[r]);
        let g1 = gt(&gs[0], &k1);
        for r in 0..NX {
            lambda[r] += g1[r] + g2[r] + g3[r] + g4[r];
        }
        lambda[crate::problem::six_dof::sx::Z] += zeta[n];
        kappa[4 * n..4 * n + 4].copy_from_slice(&[k1, k2, k3, k4]);
    }
    kappa
}
