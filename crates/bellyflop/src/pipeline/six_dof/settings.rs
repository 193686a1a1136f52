//! What of a case's `[solver]` the 6-DoF solve ([`super::solve`]) reads,
//! and the refusal of what it would ignore: a setting that does not apply,
//! given a value other than its default, is bad input
//! ([`InputError::NotApplicable`]) rather than silently dropped, as a
//! planar scenario's out-of-plane field is (it needs `model = "6dof"`).
//!
//! The 6-DoF solve reads `solver.method` (which must be `direct`), all of
//! `[solver.direct]`, `solver.polish` and the landing tolerances
//! (`solver.landing_position_tolerance_m`,
//! `solver.landing_velocity_tolerance_mps`); [`NOT_READ`] lists every
//! other key, with the reason. The reasons are the ones the CLI's flags and
//! the Python binding's arguments give too, so that the three say the same.

use serde_json::Value;

use crate::input::error::InputError;
use crate::input::settings::{Method, SolverSettings};

/// Why a method other than the direct one does not apply.
pub const DIRECT_ONLY: &str =
    "only the direct method solves the 6-DoF model; SCvx is the planar model's";
/// Why a thrust-direction formulation does not apply.
pub const NO_FORMULATION: &str = "the thrust-direction formulations are the planar model's SCvx's, and a 6-DoF scenario is solved by the direct method";
/// Why a control interpolation does not apply (the planar landing check's
/// `--interpolation`).
pub const NO_INTERPOLATION: &str = "its landing check flies the controls as the solve defines them, not interpolated through the nodes: the polished controls_flown, or the raw answer's thrust and gimbal angles, linear between their times";
/// Why mesh refinement does not apply.
pub const NO_REFINEMENT: &str =
    "the 6-DoF solve does not refine its mesh: it solves on the scenario's mesh";
/// Why an SCvx setting does not apply.
const SCVX_ONLY: &str = "a setting of SCvx, the planar model's method, and a 6-DoF scenario is solved by the direct method, set by [solver.direct]";
/// Why the planar transcription's soft terms do not apply.
const NO_SOFT_TERMS: &str =
    "the 6-DoF transcription has no soft thrust margin and no soft terminal state, as the planar one has";
/// Why a setting of the planar polish does not apply.
const PLANAR_POLISH: &str = "a setting of the planar polish; the 6-DoF polish repairs no arcs and always takes the exact Hessian near the landing, and only solver.polish switches it";

/// A `[solver]` key's value (the scenario file's spelling of it).
type Read = fn(&SolverSettings) -> Value;

/// The `[solver]` keys that the 6-DoF solve does not read (under
/// `solver.`), how to read each, and why it does not apply. The
/// refinement's keys other than its tolerance act only through it, but
/// are not read either.
pub const NOT_READ: [(&str, Read, &str); 28] = [
    (
        "formulation",
        |s| s.formulation.as_str().into(),
        NO_FORMULATION,
    ),
    (
        "relaxed_first_iterations",
        |s| s.relaxed_first_iterations.into(),
        SCVX_ONLY,
    ),
    ("max_iterations", |s| s.max_iterations.into(), SCVX_ONLY),
    ("step_tolerance", |s| s.step_tolerance.into(), SCVX_ONLY),
    ("defect_tolerance", |s| s.defect_tolerance.into(), SCVX_ONLY),
    (
        "virtual_control_tolerance",
        |s| s.virtual_control_tolerance.into(),
        SCVX_ONLY,
    ),
    (
        "virtual_control_weight",
        |s| s.virtual_control_weight.into(),
        SCVX_ONLY,
    ),
    ("proximal_weight", |s| s.proximal_weight.into(), SCVX_ONLY),
    (
        "trust_region_initial",
        |s| s.trust_region_initial.into(),
        SCVX_ONLY,
    ),
    ("trust_region_min", |s| s.trust_region_min.into(), SCVX_ONLY),
    ("trust_region_max", |s| s.trust_region_max.into(), SCVX_ONLY),
    ("rho0", |s| s.rho0.into(), SCVX_ONLY),
    ("rho1", |s| s.rho1.into(), SCVX_ONLY),
    ("rho2", |s| s.rho2.into(), SCVX_ONLY),
    ("shrink", |s| s.shrink.into(), SCVX_ONLY),
    ("grow", |s| s.grow.into(), SCVX_ONLY),
    (
        "second_order_correction",
        |s| s.second_order_correction.into(),
        SCVX_ONLY,
    ),
    (
        "relaxation_gap_tolerance",
        |s| s.relaxation_gap_tolerance.into(),
        SCVX_ONLY,
    ),
    (
        "thrust_margin_frac",
        |s| s.thrust_margin_frac.into(),
        NO_SOFT_TERMS,
    ),
    (
        "thrust_margin_weight",
        |s| s.thrust_margin_weight.into(),
        NO_SOFT_TERMS,
    ),
    (
        "terminal_lateral_weight",
        |s| s.terminal_lateral_weight.into(),
        NO_SOFT_TERMS,
    ),
    ("polish_repairs", |s| s.polish_repairs.into(), PLANAR_POLISH),
    ("polish_hessian", |s| s.polish_hessian.into(), PLANAR_POLISH),
    (
        "refinement.tolerance",
        |s| s.refinement.tolerance.into(),
        NO_REFINEMENT,
    ),
    (
        "refinement.max_passes",
        |s| s.refinement.max_passes.into(),
        NO_REFINEMENT,
    ),
    (
        "refinement.min_points",
        |s| s.refinement.min_points.into(),
        NO_REFINEMENT,
    ),
    (
        "refinement.max_points",
        |s| s.refinement.max_points.into(),
        NO_REFINEMENT,
    ),
    (
        "refinement.max_total_points",
        |s| s.refinement.max_total_points.into(),
        NO_REFINEMENT,
    ),
];

/// `Err` naming the first setting of `settings` that the 6-DoF solve would
/// ignore (module docs): a method other than the direct one, or a key of
/// [`NOT_READ`] at a value other than its default. The front ends refuse
/// their own flags and arguments first, naming them as given (`--formulation`,
/// `formulation`), and then call this on the settings those made.
pub fn check_settings(settings: &SolverSettings) -> Result<(), InputError> {
    if settings.method != Method::Direct {
        return Err(InputError::NotApplicable {
            field: "solver.method".into(),
            value: format!("{:?}", settings.method.as_str()),
            reason: format!("{DIRECT_ONLY} (remove it, or set its default \"direct\")"),
        });
    }
    let default = SolverSettings::default();
    for (key, read, why) in NOT_READ {
        let value = read(settings);
        if value != read(&default) {
            return Err(InputError::NotApplicable {
                field: format!("solver.{key}"),
                value: value.to_string(),
                reason: format!("{why} (remove it, or set its default {})", read(&default)),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The leaves of a JSON object as dotted keys, with their values.
    fn leaves(prefix: &str, v: &Value, out: &mut Vec<(String, Value)>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    let key = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    leaves(&key, x, out);
                }
            }
            _ => out.push((prefix.to_string(), v.clone())),
        }
    }

    /// Another value of a leaf's type (a string: another formulation or
    /// strategy name the settings take).
    fn other(key: &str, v: &Value) -> Value {
        match v {
            Value::Bool(b) => Value::Bool(!b),
            Value::Number(n) if n.is_u64() => (n.as_u64().unwrap() + 1).into(),
            Value::Number(n) => (n.as_f64().unwrap() * 2.0 + 0.5).into(),
            Value::String(_) => match key {
                "method" => "scvx".into(),
                "formulation" => "paper".into(),
                "direct.mu_strategy" => "adaptive".into(),
                _ => panic!("{key}: which other value?"),
            },
            _ => panic!("{key}: {v}"),
        }
    }

    /// Every `[solver]` key, changed alone from its default: refused naming
    /// it exactly when it is one the 6-DoF solve does not read (or the
    /// method), accepted when it reads it. A key added to the settings
    /// fails here until it is sorted into one or the other.
    #[test]
    fn every_solver_key_is_read_or_refused_by_name() {
        let read = [
            "method",
            "polish",
            "landing_position_tolerance_m",
            "landing_velocity_tolerance_mps",
        ];
        let default = serde_json::to_value(SolverSettings::default()).unwrap();
        assert_eq!(check_settings(&SolverSettings::default()), Ok(()));
        let mut keys = Vec::new();
        leaves("", &default, &mut keys);
        let mut refused = Vec::new();
        for (key, value) in keys {
            let mut changed = default.clone();
            let at = format!("/{}", key.replace('.', "/"));
            *changed.pointer_mut(&at).unwrap() = other(&key, &value);
            let s: SolverSettings = serde_json::from_value(changed).unwrap();
            match check_settings(&s) {
                Ok(()) => assert!(
                    read.contains(&key.as_str()) || key.starts_with("direct."),
                    "{key}: changed, yet accepted: sort it into NOT_READ or the read keys"
                ),
                Err(InputError::NotApplicable {
                    field,
                    value: given,
                    ..
                }) => {
                    assert_eq!(field, format!("solver.{key}"));
                    assert_eq!(given, other(&key, &value).to_string());
                    refused.push(key);
                }
                Err(e) => panic!("{key}: {e}"),
            }
        }
        let mut want: Vec<String> = NOT_READ.iter().map(|r| r.0.to_string()).collect();
        want.push("method".into());
        want.sort();
        refused.sort();
        assert_eq!(refused, want);
    }

    #[test]
    fn the_message_names_the_key_its_value_and_its_default() {
        let mut s = SolverSettings::default();
        s.refinement.tolerance = 1e-6;
        let msg = check_settings(&s).unwrap_err().to_string();
        assert!(
            msg.starts_with("solver.refinement.tolerance = 1e-6 does not apply to a 6-DoF scenario (model = \"6dof\"): the 6-DoF solve does not refine its mesh"),
            "{msg}"
        );
        assert!(
            msg.ends_with("(remove it, or set its default 0.0)"),
            "{msg}"
        );
        s = SolverSettings {
            method: Method::Scvx,
            ..SolverSettings::default()
        };
        let msg = check_settings(&s).unwrap_err().to_string();
        assert!(
            msg.starts_with("solver.method = \"scvx\" does not apply"),
            "{msg}"
        );
    }
}
