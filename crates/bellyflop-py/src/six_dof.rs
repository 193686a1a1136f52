//! `solve()` on a 6-DoF scenario (`model = "6dof"`, issue 38): the core
//! crate's 6-DoF pipeline (`bellyflop::pipeline::six_dof::solve`), its
//! answer as the object `bellyflop solve --json` prints, with the node
//! states and controls as named numpy arrays.

use std::time::Instant;

use bellyflop::input::overrides::Overrides;
use bellyflop::method::observer::Silent;
use bellyflop::pipeline::six_dof::check_settings;
use bellyflop::pipeline::six_dof::settings::{
    DIRECT_ONLY, NO_FORMULATION, NO_INTERPOLATION, NO_REFINEMENT,
};
use bellyflop::problem::six_dof::start_state;
use bellyflop::{Case, Method};
use pyo3::exceptions::PyAttributeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::Value;

use crate::convert::json_to_py;
use crate::{detached, input_error, keys, InputError};

/// The arguments of `solve()` as given (None when left out), to refuse
/// those that do not apply to the 6-DoF model.
pub struct Given<'a> {
    pub method: Option<&'a str>,
    pub formulation: Option<&'a str>,
    pub interpolation: Option<&'a str>,
    pub mesh_tolerance: Option<f64>,
}

/// `InputError` naming an argument that the 6-DoF solve does not take: the
/// core crate's [`bellyflop::InputError::NotApplicable`], with its reason
/// (the CLI gives the same for its flags) and what to pass instead.
fn not_applicable(field: &str, value: String, why: &str, hint: &str) -> PyErr {
    input_error(bellyflop::InputError::NotApplicable {
        field: field.into(),
        value,
        reason: format!("{why} ({hint})"),
    })
}

impl Given<'_> {
    /// `Err` naming the first argument that does not apply: a method other
    /// than the direct one, any formulation or interpolation (planar
    /// only), a refinement tolerance other than 0 (the CLI refuses its
    /// flags in the same order).
    pub fn check(&self) -> PyResult<()> {
        if let Some(m) = self.method.filter(|m| *m != Method::Direct.as_str()) {
            let hint = "method = \"direct\" or None";
            return Err(not_applicable(
                "method",
                format!("{m:?}"),
                DIRECT_ONLY,
                hint,
            ));
        }
        if let Some(f) = self.formulation {
            let value = format!("{f:?}");
            return Err(not_applicable(
                "formulation",
                value,
                NO_FORMULATION,
                "leave it None",
            ));
        }
        if let Some(i) = self.interpolation {
            let value = format!("{i:?}");
            return Err(not_applicable(
                "interpolation",
                value,
                NO_INTERPOLATION,
                "leave it None",
            ));
        }
        if let Some(t) = self.mesh_tolerance.filter(|t| *t != 0.0) {
            let hint = "leave it None or 0";
            return Err(not_applicable(
                "mesh_tolerance",
                format!("{t:?}"),
                NO_REFINEMENT,
                hint,
            ));
        }
        Ok(())
    }
}

/// Solve the 6-DoF `case` with `overrides` (nodes, intervals, fast, and the
/// method and mesh tolerance that [`Given::check`] let through), as
/// `bellyflop solve --json` does; the file's settings that the 6-DoF solve
/// does not read must be at their defaults, its `solver.method` the direct
/// one ([`check_settings`]), as the CLI requires.
pub fn solve(py: Python<'_>, case: Case, overrides: Overrides) -> PyResult<SixDofSolution> {
    let s = overrides.apply(case).map_err(input_error)?;
    check_settings(&s.solver).map_err(input_error)?;
    let (value, core_ms) = detached(py, move || {
        let start = Instant::now();
        let sol = bellyflop::pipeline::six_dof::solve(
            &s.scenario,
            start_state(&s.scenario.initial),
            &s.solver,
            &mut Silent,
        );
        let mut v = sol.to_json();
        // As the CLI adds them (only when there are any).
        bellyflop::output::report::add_warnings(&mut v, &s.warnings);
        (v, start.elapsed().as_secs_f64() * 1e3)
    })?;
    Ok(SixDofSolution { value, core_ms })
}

/// The column `k` of a table's JSON rows (a null, the JSON of a
/// non-finite value, as NaN).
fn column(rows: &Value, k: usize) -> Vec<f64> {
    rows.as_array()
        .map(|rows| {
            rows.iter()
                .map(|r| r.get(k).and_then(Value::as_f64).unwrap_or(f64::NAN))
                .collect()
        })
        .unwrap_or_default()
}

/// A JSON array of strings (empty when it is not one).
fn strings(v: &Value) -> Vec<&str> {
    v.as_array()
        .map(|n| n.iter().filter_map(Value::as_str).collect())
        .unwrap_or_default()
}

/// The names of a table (`states` or `controls`) of the JSON.
fn names(table: &Value) -> Vec<&str> {
    strings(&table["names"])
}

/// The answer of a 6-DoF solve: the object `bellyflop solve --json` prints
/// on a 6-DoF scenario. Its keys are attributes (`t_s` a numpy array); the
/// tables `states` and `controls` are dicts of numpy float64 arrays named
/// by the model's fields (the columns of trajectory.csv), and each field is
/// an attribute too (`sol.z_m`, `sol.thrust_n`). The states are at the N + 1
/// node times `t_s`; the controls at the first N.
#[pyclass(module = "bellyflop", frozen)]
pub struct SixDofSolution {
    value: Value,
    /// Time spent in Rust for this call (solve and JSON) \[ms\].
    core_ms: f64,
}

impl SixDofSolution {
    /// The table `which` (`states` or `controls`) as {name: array}.
    fn table<'py>(&self, py: Python<'py>, which: &str) -> PyResult<Bound<'py, PyDict>> {
        let table = &self.value[which];
        let d = PyDict::new(py);
        for (k, name) in names(table).into_iter().enumerate() {
            d.set_item(
                name,
                numpy::PyArray1::from_vec(py, column(&table["rows"], k)),
            )?;
        }
        Ok(d)
    }

    /// The column named `name` of the states or the controls, if any.
    fn field(&self, name: &str) -> Option<Vec<f64>> {
        ["states", "controls"].into_iter().find_map(|which| {
            let table = &self.value[which];
            let k = names(table).iter().position(|n| *n == name)?;
            Some(column(&table["rows"], k))
        })
    }
}

#[pymethods]
impl SixDofSolution {
    /// Rebuild from the JSON text of `to_json()` (pickling).
    #[staticmethod]
    fn _from_json(text: &str) -> PyResult<Self> {
        let value = serde_json::from_str(text).map_err(|e| InputError::new_err(e.to_string()))?;
        Ok(SixDofSolution {
            value,
            core_ms: f64::NAN,
        })
    }

    /// The JSON text, as `bellyflop solve --json` prints it.
    fn to_json(&self) -> String {
        self.value.to_string()
    }

    /// The `--json` object as nested dicts and lists (arrays as lists of float).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.value, false)
    }

    /// The node states, {name: numpy array of N + 1}, at `t_s`.
    #[getter]
    fn states<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.table(py, "states")
    }

    /// The controls, {name: numpy array of N}, at the first N of `t_s`.
    #[getter]
    fn controls<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.table(py, "controls")
    }

    /// The unit of each state and control, {name: unit}.
    #[getter]
    fn units<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for which in ["states", "controls"] {
            let t = &self.value[which];
            for (name, unit) in names(t).into_iter().zip(strings(&t["units"])) {
                d.set_item(name, unit)?;
            }
        }
        Ok(d)
    }

    /// Milliseconds spent in Rust by the call that made this solution
    /// (NaN after unpickling).
    #[getter]
    fn _core_ms(&self) -> f64 {
        self.core_ms
    }

    fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        if let Some(v) = self.value.get(name) {
            return Ok(json_to_py(py, v, true)?.unbind());
        }
        match self.field(name) {
            Some(xs) => Ok(numpy::PyArray1::from_vec(py, xs).into_any().unbind()),
            None => Err(PyAttributeError::new_err(format!(
                "SixDofSolution has no field {name:?}"
            ))),
        }
    }

    fn __dir__(&self) -> Vec<String> {
        let mut k = keys(&self.value);
        k.push("units".into());
        for which in ["states", "controls"] {
            k.extend(names(&self.value[which]).into_iter().map(String::from));
        }
        k
    }

    /// Equal answers: the same `--json` object (the timing aside).
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<SixDofSolution>()
            .map(|o| o.get().value == self.value)
            .unwrap_or(false)
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let ctor = py.get_type::<SixDofSolution>().getattr("_from_json")?;
        Ok((ctor, (self.to_json(),)))
    }

    fn __repr__(&self) -> String {
        format!(
            "<bellyflop.SixDofSolution {}, t_f {} s, final mass {} kg>",
            self.value["status"].as_str().unwrap_or("?"),
            self.value["tf_s"],
            self.value["final_mass_kg"]
        )
    }
}
