//! A model's LGR transcription evaluated at a given answer, for any model
//! behind the seam ([`Dynamics`]): how far the answer is from satisfying
//! it, constraint by constraint, in physical units. It checks an answer
//! that another solver wrote (the IPOPT reference's, issue 38) against our
//! own transcription, so that a side-by-side compares the same problem.
//!
//! The transcription (Eq. 24 on the mesh, with the model's rows):
//! - defects Σ_j D_ij x_j − (t_f/2)·f(x_i, u_i) = 0 at the collocation
//!   points i < N;
//! - x_0 the initial state;
//! - the boxes of the states at the nodes after the first and of the
//!   controls at the points, and the ground z ≥ z_f;
//! - the path rows g(x, u) ≤ 0 at the points (x_i, u_i), and at the last
//!   node with the last point's control (as it is held there when flown);
//! - at the last node, the landing's fixed slots.

use crate::collocation::mesh::Mesh;
use crate::input::scenario::TerminalState;
use crate::problem::model::Dynamics;

/// An answer on a mesh: the states at its N + 1 nodes, node-major
/// ((N + 1)·NX), the controls at its N collocation points (N·NU), and t_f.
#[derive(Debug, Clone, Copy)]
pub struct Answer<'a> {
    pub states: &'a [f64],
    pub controls: &'a [f64],
    pub tf_s: f64,
}

/// The largest violation of each kind of constraint (0 where held).
#[derive(Debug, Clone, PartialEq)]
pub struct Residuals {
    /// max_i |defect_ic| per state c, in the state's unit (per unit τ).
    pub defect: Vec<f64>,
    /// max_c |x_0c − x0_c|.
    pub initial: f64,
    /// The largest excess over a box, per state then per control (physical
    /// units), the ground included in the altitude's.
    pub state_box: Vec<f64>,
    pub control_box: Vec<f64>,
    /// max(0, g_r) per path row.
    pub path: Vec<f64>,
    /// |x_N,c − fixed_c| per state (0 where the landing leaves it free).
    pub terminal_fixed: Vec<f64>,
}

/// Why an answer cannot be evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ShapeError {
    #[error("{what} has {got} values, the mesh and model need {want}")]
    Length {
        what: &'static str,
        got: usize,
        want: usize,
    },
}

fn check_len(what: &'static str, got: usize, want: usize) -> Result<(), ShapeError> {
    if got == want {
        Ok(())
    } else {
        Err(ShapeError::Length { what, got, want })
    }
}

/// The residuals of `answer` on `mesh` for `model`, from `x0`, to `target`
/// with the ground at `target.z_m`.
pub fn residuals<M: Dynamics>(
    model: &M,
    mesh: &Mesh,
    x0: &[f64],
    target: &TerminalState,
    answer: &Answer,
) -> Result<Residuals, ShapeError> {
    let (nx, nu, n) = (M::NX, M::NU, mesh.n);
    check_len("states", answer.states.len(), (n + 1) * nx)?;
    check_len("controls", answer.controls.len(), n * nu)?;
    check_len("initial state", x0.len(), nx)?;
    let x = |k: usize| &answer.states[k * nx..(k + 1) * nx];
    let u = |i: usize| &answer.controls[i * nu..(i + 1) * nu];
    let excess = |v: f64, (lo, hi): (f64, f64)| (lo - v).max(v - hi).max(0.0);

    let mut r = Residuals {
        defect: vec![0.0; nx],
        initial: 0.0,
        state_box: vec![0.0; nx],
        control_box: vec![0.0; nu],
        path: vec![0.0; M::PATH_ROWS],
        terminal_fixed: vec![0.0; nx],
    };
    let mut f = vec![0.0; nx];
    let mut g = vec![0.0; M::PATH_ROWS];
    for i in 0..n {
        model.rhs(x(i), u(i), &mut f);
        let (first, row) = mesh.d_row(i);
        for (c, (worst, fc)) in r.defect.iter_mut().zip(&f).enumerate() {
            let dx: f64 = row
                .iter()
                .enumerate()
                .map(|(j, d)| d * x(first + j)[c])
                .sum();
            *worst = worst.max((dx - 0.5 * answer.tf_s * fc).abs());
        }
        for (j, &v) in u(i).iter().enumerate() {
            r.control_box[j] = r.control_box[j].max(excess(v, model.control_box(j)));
        }
    }
    for (a, b) in x(0).iter().zip(x0) {
        r.initial = r.initial.max((a - b).abs());
    }
    for k in 1..=n {
        for (c, &v) in x(k).iter().enumerate() {
            let (lo, hi) = model.state_box(c);
            let lo = if c == M::ALTITUDE {
                lo.max(target.z_m)
            } else {
                lo
            };
            r.state_box[c] = r.state_box[c].max(excess(v, (lo, hi)));
        }
    }
    for (k, i) in (0..n).map(|i| (i, i)).chain(std::iter::once((n, n - 1))) {
        model.path_rows(x(k), u(i), &mut g);
        for (p, &v) in r.path.iter_mut().zip(&g) {
            *p = p.max(v.max(0.0));
        }
    }
    let end = x(n);
    for (c, (miss, e)) in r.terminal_fixed.iter_mut().zip(end).enumerate() {
        if let Some(v) = model.terminal_fixed(target, c) {
            *miss = (e - v).abs();
        }
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::dynamics::Model;

    /// The planar model's residuals at the direct method's own answer of
    /// the paper's case vanish to its tolerance, and a t_f off by 1 % shows
    /// in the defects: the generic evaluation is the planar transcription.
    #[test]
    fn the_direct_answer_of_the_paper_satisfies_its_transcription() {
        let mut case = crate::Case::paper();
        case.solver.method = crate::Method::Direct;
        case.solver.polish = false;
        let sol = case
            .solve(&mut crate::method::observer::Silent)
            .expect("a planar scenario");
        // The raw answer (flown, it misses: `inaccurate`).
        assert!(matches!(
            sol.status,
            crate::Status::Solved | crate::Status::Inaccurate
        ));
        let s = &case.scenario;
        let model = Model::new(&s.vehicle, &s.environment);
        let mesh = sol.mesh();
        let cols = sol.state_columns();
        let states: Vec<f64> = (0..=mesh.n)
            .flat_map(|k| cols.iter().map(move |c| c[k]))
            .collect();
        let controls: Vec<f64> = (0..mesh.n)
            .flat_map(|i| [sol.thrust_n[i], sol.gimbal_rate_radps[i]])
            .collect();
        let x0 = s.initial.state_si();
        let answer = Answer {
            states: &states,
            controls: &controls,
            tf_s: sol.tf_s,
        };
        let r = residuals(&model, &mesh, &x0, &s.terminal, &answer).unwrap();
        let worst = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
        assert!(worst(&r.defect) < 1e-6, "{r:?}");
        assert!(r.initial < 1e-9 && worst(&r.terminal_fixed) < 1e-6, "{r:?}");
        assert!(
            worst(&r.state_box) < 1e-9 && worst(&r.control_box) < 1e-6,
            "{r:?}"
        );
        let off = Answer {
            tf_s: sol.tf_s * 1.01,
            ..answer
        };
        let r = residuals(&model, &mesh, &x0, &s.terminal, &off).unwrap();
        assert!(worst(&r.defect) > 0.1, "{r:?}");
        // A wrong shape is an error, not a panic.
        let short = Answer {
            states: &states[1..],
            ..answer
        };
        assert!(residuals(&model, &mesh, &x0, &s.terminal, &short).is_err());
    }
}
