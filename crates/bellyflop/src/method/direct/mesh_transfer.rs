//! A scaled vector of one transcription carried onto another's mesh: the
//! coarse phase's answer onto the scenario's mesh.

use crate::collocation::derivatives::Differentiable;
use crate::method::direct::nlp::Transcription;

/// A scaled vector of `from` carried onto `to`'s mesh: states by the state
/// interpolant (per interval, degree n_k), controls by the control
/// interpolant, t_f as is.
pub fn interpolate<M: Differentiable, const NS: usize, const NL: usize>(
    from: &Transcription<M, NS, NL>,
    w: &[f64],
    to: &Transcription<M, NS, NL>,
) -> Vec<f64> {
    let mut out = Vec::new();
    interpolate_into(from, w, to, &mut out, &mut Vec::new());
    out
}

/// [`interpolate`] into `out`, with `values` as its work vector, both in
/// their own storage.
pub(super) fn interpolate_into<M: Differentiable, const NS: usize, const NL: usize>(
    from: &Transcription<M, NS, NL>,
    w: &[f64],
    to: &Transcription<M, NS, NL>,
    out: &mut Vec<f64>,
    values: &mut Vec<f64>,
) {
    out.clear();
    out.resize(to.n_var(), 0.0);
    values.clear();
    values.resize(from.n + 1, 0.0);
    for s in 0..NL {
        let count = if s < NS { from.n + 1 } else { from.n };
        for (k, v) in values.iter_mut().enumerate().take(count) {
            *v = from.physical(s, w[from.idx(k, s)]);
        }
        for (k, &tau) in to.mesh.nodes.iter().enumerate() {
            let phys = if s < NS {
                from.mesh.interpolate_states(values, tau)
            } else if k < to.n {
                from.mesh.interpolate_controls(&values[..from.n], tau)
            } else {
                continue;
            };
            out[to.idx(k, s)] = (phys - to.offset[s]) / to.scale[s];
        }
    }
    out[to.tf_idx()] = from.tf_s(w) / to.tf_scale;
}
