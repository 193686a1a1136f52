//! `bellyflop._bellyflop`: the native half of the Python package.
//!
//! Thin: every result is built by the core crate's own serialization
//! (`bellyflop::output::report`, `bellyflop::output::campaign`), the same code the CLI
//! prints with, and converted to Python objects here. Long calls release the
//! GIL; a panic in the core becomes `bellyflop.InternalError`.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use bellyflop::collocation::interpolation::Interpolation;
use bellyflop::guidance::SimConfig as CoreSimConfig;
use bellyflop::output::campaign::{self, Cell, Kind, RunRow};
use bellyflop::sim::{RunOutcome, TouchdownLimits};
// The Python `Scenario` is a whole scenario file: the problem and its
// `[solver]` settings (bellyflop::Case).
use bellyflop::input::overrides::Overrides;
use bellyflop::input::scenario::ModelKind;
use bellyflop::output::{report, viewer};
use bellyflop::{Case as CoreScenario, Formulation, Method};
use numpy::PyArray1;
use pyo3::create_exception;
use pyo3::exceptions::{PyAttributeError, PyKeyError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use pyo3::IntoPyObjectExt;
use serde_json::Value;

mod convert;
mod six_dof;

use convert::{json_to_py, py_to_toml};

create_exception!(
    bellyflop,
    InputError,
    PyValueError,
    "Input that cannot describe a landing problem: the message names the field, its value and the allowed range (or the TOML line)."
);
create_exception!(
    bellyflop,
    InternalError,
    PyRuntimeError,
    "A bug in bellyflop (a Rust panic, caught before it reached the interpreter)."
);

/// The core crate's typed input error as `InputError`.
fn input_error(e: bellyflop::InputError) -> PyErr {
    InputError::new_err(e.to_string())
}

/// Run `f` with the GIL released; a panic becomes `InternalError`.
fn detached<T: Send>(py: Python<'_>, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    py.detach(|| catch_unwind(AssertUnwindSafe(f)))
        .map_err(panic_error)
}

/// A caught panic as `InternalError`.
fn panic_error(payload: Box<dyn std::any::Any + Send>) -> PyErr {
    let msg = payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "unknown panic".to_string());
    InternalError::new_err(format!("bellyflop panicked: {msg}"))
}

/// The attribute `name` of a JSON object, as Python (a nested object as a
/// read-only [`Section`]).
fn attribute(py: Python<'_>, obj: &Value, path: &str, name: &str) -> PyResult<Py<PyAny>> {
    match obj.get(name) {
        Some(Value::Object(_)) => Section {
            path: join(path, name),
            value: obj[name].clone(),
        }
        .into_py_any(py),
        Some(v) => Ok(json_to_py(py, v, false)?.unbind()),
        None => Err(PyAttributeError::new_err(format!(
            "{} has no field {name:?}",
            if path.is_empty() { "scenario" } else { path }
        ))),
    }
}

fn join(path: &str, name: &str) -> String {
    if path.is_empty() {
        name.to_string()
    } else {
        format!("{path}.{name}")
    }
}

fn keys(v: &Value) -> Vec<String> {
    v.as_object()
        .map(|m| m.keys().cloned().collect())
        .unwrap_or_default()
}

/// A read-only view of one table of a scenario or configuration
/// (`scenario.initial`, `scenario.solver.direct`): fields as attributes or
/// items.
#[pyclass(module = "bellyflop", frozen)]
struct Section {
    path: String,
    value: Value,
}

#[pymethods]
impl Section {
    fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        attribute(py, &self.value, &self.path, name)
    }

    fn __getitem__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        attribute(py, &self.value, &self.path, name)
            .map_err(|_| PyKeyError::new_err(name.to_string()))
    }

    fn __dir__(&self) -> Vec<String> {
        keys(&self.value)
    }

    /// The field names.
    fn keys(&self) -> Vec<String> {
        keys(&self.value)
    }

    /// The table as nested dicts.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.value, false)
    }

    fn __repr__(&self) -> String {
        format!("<bellyflop section {} {}>", self.path, self.value)
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Section>()
            .map(|o| o.get().path == self.path && o.get().value == self.value)
            .unwrap_or(false)
    }

    /// Rebuild from its path and JSON text (pickling).
    #[staticmethod]
    fn _from_json(path: String, text: &str) -> PyResult<Self> {
        let value = serde_json::from_str(text).map_err(|e| InputError::new_err(e.to_string()))?;
        Ok(Section { path, value })
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String, String))> {
        let ctor = py.get_type::<Section>().getattr("_from_json")?;
        Ok((ctor, (self.path.clone(), self.value.to_string())))
    }
}

/// The methods [`Scenario`] and [`SimConfig`] share, written once: the
/// constructors from TOML and dicts, the TOML and dict views, attribute
/// access, equality, pickling and `json`.
///
/// `$ty` is the pyclass (a frozen struct holding the validated core value in
/// `inner`, of type `$inner`); `$what` names the value in the docstrings and
/// `$dict` in the error of `from_dict` ("scenario dict: ..."). The methods
/// of its own (the default constructor, `__repr__`) go in the braces.
macro_rules! toml_input_methods {
    ($ty:ident($inner:ty), what = $what:literal, dict = $dict:literal, { $($own:tt)* }) => {
        #[pymethods]
        impl $ty {
            $($own)*

            /// Read, parse and validate the TOML file at `path` (str or
            /// os.PathLike). The argument is always a path, never TOML text
            /// (`from_toml_text` parses text): a missing file is an
            /// `InputError` naming it.
            #[staticmethod]
            fn from_toml(path: std::path::PathBuf) -> PyResult<Self> {
                Self::from_toml_file(path)
            }

            /// Parse and validate TOML text.
            #[staticmethod]
            fn from_toml_text(text: &str) -> PyResult<Self> {
                <$inner>::from_toml_str(text)
                    .map(|inner| $ty { inner })
                    .map_err(input_error)
            }

            /// Read, parse and validate a TOML file (as `from_toml`).
            #[staticmethod]
            fn from_toml_file(path: std::path::PathBuf) -> PyResult<Self> {
                <$inner>::from_file(&path)
                    .map(|inner| $ty { inner })
                    .map_err(input_error)
            }

            /// Build and validate from nested dicts with the TOML's tables and keys.
            #[staticmethod]
            fn from_dict(d: &Bound<'_, PyAny>) -> PyResult<Self> {
                let inner: $inner = from_dict_value(d, $dict)?;
                inner.validate().map_err(input_error)?;
                Ok($ty { inner })
            }

            #[doc = concat!("The ", $what, " as TOML text (reads back to an equal ", $what, ").")]
            fn to_toml(&self) -> PyResult<String> {
                to_toml_text(&self.inner)
            }

            #[doc = concat!("The ", $what, " as nested dicts (the TOML's tables and keys).")]
            fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
                json_to_py(py, &self.json()?, false)
            }

            fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
                attribute(py, &self.json()?, "", name)
            }

            fn __dir__(&self) -> PyResult<Vec<String>> {
                Ok(keys(&self.json()?))
            }

            fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
                other
                    .cast::<$ty>()
                    .map(|o| o.get().inner == self.inner)
                    .unwrap_or(false)
            }

            fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
                let ctor = py.get_type::<$ty>().getattr("from_toml_text")?;
                Ok((ctor, (self.to_toml()?,)))
            }
        }

        impl $ty {
            /// The value as JSON (the attribute views and `to_dict`).
            fn json(&self) -> PyResult<Value> {
                to_json(&self.inner)
            }
        }
    };
}

/// A landing problem: vehicle, environment, boundary states, mesh and
/// solver settings, validated on construction.
#[pyclass(module = "bellyflop", frozen)]
#[derive(Clone)]
pub struct Scenario {
    inner: CoreScenario,
}

toml_input_methods!(
    Scenario(CoreScenario),
    what = "scenario",
    dict = "scenario",
    {
        /// The paper's case (`scenarios/paper.toml`).
        #[staticmethod]
        fn paper() -> Self {
            Scenario {
                inner: CoreScenario::paper(),
            }
        }

        /// What reading it changed, one sentence each: a given guess outside
        /// its range, clamped into it (as the CLI prints on stderr and in its
        /// JSON's `warnings`); empty for the paper's case.
        #[getter]
        fn warnings(&self) -> Vec<String> {
            self.inner.warnings.clone()
        }

        fn __repr__(&self) -> String {
            format!(
                "<bellyflop.Scenario {:?}, N = {}, {}>",
                self.inner.scenario.name,
                self.inner.scenario.discretization.nodes,
                self.inner.solver.method.as_str()
            )
        }
    }
);

/// A value of `T` from nested dicts with its TOML tables and keys (not yet
/// validated); `what` names it in the error.
fn from_dict_value<T: serde::de::DeserializeOwned>(
    d: &Bound<'_, PyAny>,
    what: &str,
) -> PyResult<T> {
    py_to_toml(d)?
        .try_into()
        .map_err(|e: toml::de::Error| InputError::new_err(format!("{what} dict: {e}")))
}

/// `v` as TOML text.
fn to_toml_text<T: serde::Serialize>(v: &T) -> PyResult<String> {
    toml::to_string(v).map_err(|e| InternalError::new_err(e.to_string()))
}

/// `v` as a JSON value (the attribute views and `to_dict`).
fn to_json<T: serde::Serialize>(v: &T) -> PyResult<Value> {
    serde_json::to_value(v).map_err(|e| InternalError::new_err(e.to_string()))
}

/// The closed-loop configuration: `[dispersions]`, `[guidance]`, `[plant]`,
/// `[touchdown]`, every field optional.
#[pyclass(module = "bellyflop", frozen)]
#[derive(Clone)]
pub struct SimConfig {
    inner: CoreSimConfig,
}

toml_input_methods!(
    SimConfig(CoreSimConfig),
    what = "configuration",
    dict = "config",
    {
        /// Every field at its default.
        #[new]
        fn new() -> Self {
            SimConfig {
                inner: CoreSimConfig::default(),
            }
        }

        fn __repr__(&self) -> String {
            "<bellyflop.SimConfig>".to_string()
        }
    }
);

/// The answer of one solve: the object `bellyflop solve --json` prints.
/// Every key is an attribute; node arrays are numpy float64 arrays.
#[pyclass(module = "bellyflop", frozen)]
pub struct Solution {
    value: Value,
    /// Time spent in Rust for this call (solve, re-propagation, JSON) \[ms\].
    core_ms: f64,
    /// The data of its viewer page (`bellyflop::output::viewer::solve_data`);
    /// null after unpickling, which keeps only the JSON.
    viewer: Value,
}

#[pymethods]
impl Solution {
    /// Rebuild from the JSON text of `to_json()` (pickling).
    #[staticmethod]
    fn _from_json(text: &str) -> PyResult<Self> {
        let value = serde_json::from_str(text).map_err(|e| InputError::new_err(e.to_string()))?;
        Ok(Solution {
            value,
            core_ms: f64::NAN,
            viewer: Value::Null,
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

    /// Milliseconds spent in Rust by the call that made this solution
    /// (solve, re-propagation and serialization; NaN after unpickling).
    #[getter]
    fn _core_ms(&self) -> f64 {
        self.core_ms
    }

    fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        match self.value.get(name) {
            Some(v) => Ok(json_to_py(py, v, true)?.unbind()),
            // Serialized only when not empty.
            None if name == "direct_history" => Ok(PyList::empty(py).into_any().unbind()),
            None => Err(PyAttributeError::new_err(format!(
                "Solution has no field {name:?}"
            ))),
        }
    }

    fn __dir__(&self) -> Vec<String> {
        keys(&self.value)
    }

    /// Equal answers: the same `--json` object (the timing and viewer data
    /// aside, which unpickling drops).
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Solution>()
            .map(|o| o.get().value == self.value)
            .unwrap_or(false)
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let ctor = py.get_type::<Solution>().getattr("_from_json")?;
        Ok((ctor, (self.to_json(),)))
    }

    /// The viewer page (as `bellyflop solve --out` writes viewer.html) in an
    /// iframe, for Jupyter.
    fn _repr_html_(&self) -> PyResult<String> {
        Ok(iframe(&viewer_page(&self.viewer, "Solution")?))
    }

    /// Write the viewer page (viewer.html of `bellyflop solve --out`) to `path`.
    fn save_html(&self, path: std::path::PathBuf) -> PyResult<()> {
        save_page(&path, &viewer_page(&self.viewer, "Solution")?)
    }

    fn __repr__(&self) -> String {
        format!(
            "<bellyflop.Solution {}, t_f {} s, final mass {} kg>",
            self.value["status"].as_str().unwrap_or("?"),
            self.value["tf_s"],
            self.value["final_mass_kg"]
        )
    }
}

/// One closed-loop landing: the object `bellyflop sim --json` prints, the
/// flown trace (the columns of flight.csv) and the run's runs.csv row.
#[pyclass(module = "bellyflop", frozen)]
pub struct Flight {
    /// {"flight": sim --json object, "trace": {column: [..]}, "row": {..}}
    value: Value,
    /// The data of its viewer page (`bellyflop::output::viewer::flight_data`);
    /// null after unpickling.
    viewer: Value,
}

#[pymethods]
impl Flight {
    #[staticmethod]
    fn _from_json(text: &str) -> PyResult<Self> {
        let value = serde_json::from_str(text).map_err(|e| InputError::new_err(e.to_string()))?;
        Ok(Flight {
            value,
            viewer: Value::Null,
        })
    }

    fn _to_json(&self) -> String {
        self.value.to_string()
    }

    /// The `sim --json` object as nested dicts and lists.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.value["flight"], false)
    }

    /// The flown trace: flight.csv's columns as numpy float64 arrays.
    #[getter]
    fn trace<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.value["trace"], true)
    }

    /// This run's row of runs.csv as a dict.
    #[getter]
    fn row<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.value["row"], false)
    }

    fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        match self.value["flight"].get(name) {
            Some(v) => Ok(json_to_py(py, v, true)?.unbind()),
            None => Err(PyAttributeError::new_err(format!(
                "Flight has no field {name:?}"
            ))),
        }
    }

    fn __dir__(&self) -> Vec<String> {
        let mut k = keys(&self.value["flight"]);
        k.extend(["trace".to_string(), "row".to_string()]);
        k
    }

    /// Equal flights: the same object, trace and row (the viewer data
    /// aside, which unpickling drops).
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Flight>()
            .map(|o| o.get().value == self.value)
            .unwrap_or(false)
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let ctor = py.get_type::<Flight>().getattr("_from_json")?;
        Ok((ctor, (self._to_json(),)))
    }

    /// The viewer page (as `bellyflop sim --out` writes viewer.html) in an
    /// iframe, for Jupyter.
    fn _repr_html_(&self) -> PyResult<String> {
        Ok(iframe(&viewer_page(&self.viewer, "Flight")?))
    }

    /// Write the viewer page (viewer.html of `bellyflop sim --out`) to `path`.
    fn save_html(&self, path: std::path::PathBuf) -> PyResult<()> {
        save_page(&path, &viewer_page(&self.viewer, "Flight")?)
    }

    fn __repr__(&self) -> String {
        format!(
            "<bellyflop.Flight {}, fuel {} kg>",
            self.value["flight"]["outcome_name"].as_str().unwrap_or("?"),
            self.value["flight"]["fuel_kg"]
        )
    }
}

fn parse_method(s: &str) -> PyResult<Method> {
    s.parse().map_err(|_| {
        InputError::new_err(format!(
            "method = {s:?} is not a method: allowed \"direct\" or \"scvx\""
        ))
    })
}

fn parse_formulation(s: &str) -> PyResult<Formulation> {
    s.parse().map_err(|_| {
        InputError::new_err(format!(
            "formulation = {s:?} is not a formulation: allowed \"exact\", \"paper\" or \"vector\""
        ))
    })
}

fn parse_interpolation(s: &str) -> PyResult<Interpolation> {
    match s {
        "pchip" => Ok(Interpolation::Pchip),
        "linear" => Ok(Interpolation::Linear),
        _ => Err(InputError::new_err(format!(
            "interpolation = {s:?} is not an interpolation: allowed \"pchip\" or \"linear\""
        ))),
    }
}

/// Solve `scenario` with the overrides of `bellyflop solve` and return the
/// `--json` object: a Solution for a planar scenario, a
/// [`six_dof::SixDofSolution`] for a 6-DoF one (whose solve refuses the
/// arguments that do not apply to it, naming them).
#[pyfunction]
#[pyo3(signature = (scenario, nodes=None, intervals=None, method=None, formulation=None, interpolation=None, mesh_tolerance=None, fast=false))]
#[allow(clippy::too_many_arguments)] // Python's keyword arguments, one each
fn solve(
    py: Python<'_>,
    scenario: &Scenario,
    nodes: Option<usize>,
    intervals: Option<usize>,
    method: Option<&str>,
    formulation: Option<&str>,
    interpolation: Option<&str>,
    mesh_tolerance: Option<f64>,
    fast: bool,
) -> PyResult<Py<PyAny>> {
    if scenario.inner.scenario.model == ModelKind::SixDof {
        six_dof::Given {
            method,
            formulation,
            interpolation,
            mesh_tolerance,
        }
        .check()?;
        // What is left of `method` and `mesh_tolerance` ("direct", 0) is
        // what the 6-DoF solve does: they override the file's, as the
        // CLI's flags do.
        let overrides = Overrides {
            nodes,
            intervals,
            method: method.map(parse_method).transpose()?,
            mesh_tolerance,
            fast,
            ..Overrides::default()
        };
        return six_dof::solve(py, scenario.inner.clone(), overrides)?.into_py_any(py);
    }
    let overrides = Overrides {
        nodes,
        intervals,
        formulation: formulation.map(parse_formulation).transpose()?,
        method: method.map(parse_method).transpose()?,
        mesh_tolerance,
        fast,
    };
    let interpolation = parse_interpolation(interpolation.unwrap_or("pchip"))?;
    let s = overrides
        .apply(scenario.inner.clone())
        .map_err(input_error)?;
    let (value, core_ms, viewer) = detached(py, move || {
        let start = Instant::now();
        let solution = s.solve(&mut bellyflop::method::observer::Silent)?;
        let propagation = report::propagate(&s.scenario, &solution, interpolation);
        let v = report::solve_json(&s.scenario, &solution, &propagation, &s.warnings);
        let core_ms = start.elapsed().as_secs_f64() * 1e3;
        // After the clock: the viewer's data is not part of the solve.
        let flown = propagation.as_ref().ok();
        let data = viewer::solve_data(&s.scenario, &solution, &v, flown);
        Ok::<_, bellyflop::InputError>((v, core_ms, data))
    })?
    .map_err(input_error)?;
    Solution {
        value,
        core_ms,
        viewer,
    }
    .into_py_any(py)
}

/// Fly run `run` of campaign `seed` (as `bellyflop sim --seed S --run K`).
#[pyfunction]
#[pyo3(signature = (scenario, config, seed=0, run=0))]
fn sim(
    py: Python<'_>,
    scenario: &Scenario,
    config: &SimConfig,
    seed: u64,
    run: u64,
) -> PyResult<Flight> {
    let s = scenario.inner.clone();
    let c = config.inner.clone();
    let value = detached(
        py,
        move || -> Result<(Value, Value), bellyflop::InputError> {
            let f = c.fly(&s, seed, run, true)?;
            let outcome = c.outcome(&f);
            let mut flight = report::flight_json(&f, outcome, seed, run, &c);
            // As `sim --json` (the CLI adds them before its viewer too).
            report::add_warnings(&mut flight, &s.warnings);
            let trace: serde_json::Map<String, Value> = report::TRACE_COLUMNS
                .iter()
                .zip(report::trace_columns(&f))
                .map(|(name, col)| (name.to_string(), floats(&col)))
                .collect();
            let row = serde_json::to_value(RunRow::new(run, &f, &c.touchdown)).unwrap_or_default();
            let viewer = viewer::flight_data(&s.scenario, &f, &flight);
            let value = serde_json::json!({"flight": flight, "trace": trace, "row": row});
            Ok((value, viewer))
        },
    )?
    .map_err(input_error)?;
    let (value, viewer) = value;
    Ok(Flight { value, viewer })
}

/// The viewer page of `data`, or why there is none: a `what` rebuilt from
/// JSON (unpickled) keeps no trajectory to draw.
fn viewer_page(data: &Value, what: &str) -> PyResult<String> {
    if data.is_null() {
        return Err(PyValueError::new_err(format!(
            "this {what} was rebuilt from JSON (unpickled) and has no viewer data; solve or fly it again"
        )));
    }
    viewer::html(&data.to_string()).map_err(|e| InternalError::new_err(e.to_string()))
}

/// `page` as the `srcdoc` of an iframe: its script runs apart from the
/// notebook's page, whatever the notebook does with inline scripts.
fn iframe(page: &str) -> String {
    let escaped = page
        .replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;");
    format!(
        "<iframe srcdoc=\"{escaped}\" style=\"width: 100%; height: 1050px; border: 0\" sandbox=\"allow-scripts\"></iframe>"
    )
}

fn save_page(path: &std::path::Path, page: &str) -> PyResult<()> {
    std::fs::write(path, page)
        .map_err(|e| pyo3::exceptions::PyOSError::new_err(format!("{}: {e}", path.display())))
}

/// A float array as JSON (non-finite values as null, as serde_json writes them).
fn floats(v: &[f64]) -> Value {
    Value::Array(
        v.iter()
            .map(|&x| serde_json::Number::from_f64(x).map_or(Value::Null, Value::Number))
            .collect(),
    )
}

/// Fly runs `start..stop` of campaign `seed` on `threads` threads (0: one
/// per core) and return one tuple per run, in run order, for
/// [`campaign_table`]. Plain tuples pickle, so a chunk can come back from
/// any executor's worker.
///
/// The runs fly on a thread of their own while this one, every
/// [`SIGNAL_POLL`], checks for signals: on Ctrl-C (any handler that raises)
/// no further run starts, the runs in flight finish, and the exception is
/// raised.
#[pyfunction]
#[pyo3(signature = (scenario, config, seed, start, stop, threads=1))]
fn campaign_chunk<'py>(
    py: Python<'py>,
    scenario: &Scenario,
    config: &SimConfig,
    seed: u64,
    start: u64,
    stop: u64,
    threads: usize,
) -> PyResult<Bound<'py, PyList>> {
    let s = scenario.inner.clone();
    let c = config.inner.clone();
    let stop_flag = AtomicBool::new(false);
    let fly = || -> Result<Vec<RunRow>, String> {
        use rayon::prelude::*;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| e.to_string())?;
        pool.install(|| {
            (start..stop)
                .into_par_iter()
                .filter(|_| !stop_flag.load(Ordering::SeqCst))
                .map(|k| campaign::fly_row(&s, &c, seed, k))
                .collect::<Result<Vec<RunRow>, bellyflop::InputError>>()
        })
        .map_err(|e| e.to_string())
    };
    let rows = std::thread::scope(|scope| -> PyResult<Vec<RunRow>> {
        let (tx, rx) = mpsc::channel();
        scope.spawn(move || {
            let _ = tx.send(catch_unwind(AssertUnwindSafe(fly)));
        });
        let mut rx = rx;
        loop {
            // The receiver is Send but not Sync: it goes into the detached
            // closure and comes back.
            let (back, received) = py.detach(move || {
                let r = rx.recv_timeout(SIGNAL_POLL);
                (rx, r)
            });
            rx = back;
            match received {
                Ok(result) => return result.map_err(panic_error)?.map_err(InputError::new_err),
                Err(mpsc::RecvTimeoutError::Timeout) => {
                    if let Err(e) = py.check_signals() {
                        stop_flag.store(true, Ordering::SeqCst);
                        // The runs in flight end; their rows are dropped.
                        let _ = py.detach(move || rx.recv());
                        return Err(e);
                    }
                }
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(InternalError::new_err(
                        "the campaign's thread ended without an answer",
                    ))
                }
            }
        }
    })?;
    let tuples = rows
        .iter()
        .map(|r| row_to_py(py, r))
        .collect::<PyResult<Vec<_>>>()?;
    PyList::new(py, tuples)
}

/// How often a campaign's calling thread checks for signals (Ctrl-C).
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// A run's row as a tuple: its runs.csv cells in order, then its re-plan
/// times (the tuple a Dask task hands back).
fn row_to_py<'py>(py: Python<'py>, r: &RunRow) -> PyResult<Bound<'py, PyTuple>> {
    let mut items = r
        .cells()
        .iter()
        .map(|&c| cell_to_py(py, c))
        .collect::<PyResult<Vec<_>>>()?;
    items.push(r.replan_ms.clone().into_bound_py_any(py)?);
    PyTuple::new(py, items)
}

fn cell_to_py(py: Python<'_>, c: Cell) -> PyResult<Bound<'_, PyAny>> {
    match c {
        Cell::Count(n) => n.into_bound_py_any(py),
        Cell::Number(x) => x.into_bound_py_any(py),
        Cell::Flag(b) => b.into_bound_py_any(py),
        Cell::Outcome(o) => o.as_str().into_bound_py_any(py),
    }
}

/// The row of a tuple from [`row_to_py`].
fn row_from_py(t: &Bound<'_, PyAny>, limits: TouchdownLimits) -> PyResult<RunRow> {
    let cells = campaign::RUNS_CSV
        .iter()
        .enumerate()
        .map(|(k, column)| {
            let item = t.get_item(k)?;
            Ok(match column.kind {
                Kind::Count => Cell::Count(item.extract()?),
                Kind::Number => Cell::Number(item.extract()?),
                Kind::Flag => Cell::Flag(item.extract()?),
                Kind::Outcome => {
                    let name: String = item.extract()?;
                    let outcome = RunOutcome::ALL
                        .into_iter()
                        .find(|o| o.as_str() == name)
                        .ok_or_else(|| {
                            InputError::new_err(format!("outcome {name:?} is not an outcome"))
                        })?;
                    Cell::Outcome(outcome)
                }
            })
        })
        .collect::<PyResult<Vec<Cell>>>()?;
    let replan_ms = t.get_item(campaign::RUNS_CSV.len())?.extract()?;
    RunRow::from_cells(&cells, replan_ms, limits).map_err(InputError::new_err)
}

/// The table of a campaign: runs.csv's columns, its text and the summary.
#[pyclass(module = "bellyflop", frozen)]
pub struct CampaignTable {
    rows: Vec<RunRow>,
    summary: Value,
}

/// Rows (tuples of [`row_to_py`]) as RunRows judged by `limits`.
fn rows_from_py(rows: &Bound<'_, PyAny>, limits: TouchdownLimits) -> PyResult<Vec<RunRow>> {
    rows.try_iter()?.map(|t| row_from_py(&t?, limits)).collect()
}

/// Assemble the rows of every chunk (in any order) into a CampaignTable
/// sorted by run, with the CLI's summary. With `runs`, every run of 0..runs
/// must be there exactly once (a duplicate equal to the first dropped), as
/// [`campaign_account`] checks; without, the rows are those that came back.
#[pyfunction]
#[pyo3(signature = (rows, config, seed, threads, wall_s, runs=None))]
fn campaign_table(
    rows: &Bound<'_, PyAny>,
    config: &SimConfig,
    seed: u64,
    threads: usize,
    wall_s: f64,
    runs: Option<u64>,
) -> PyResult<CampaignTable> {
    let rows = rows_from_py(rows, config.inner.touchdown)?;
    let total = runs.unwrap_or_else(|| rows.iter().map(|r| r.run + 1).max().unwrap_or(0));
    let accounted =
        campaign::account(rows, total).map_err(|e| InputError::new_err(e.to_string()))?;
    let out = match runs {
        Some(n) => accounted
            .complete(n)
            .map_err(|e| InputError::new_err(e.to_string()))?,
        None => accounted.rows,
    };
    let open_loop = !config.inner.guidance.replan;
    let summary = campaign::summary(
        &out,
        &config.inner.touchdown,
        seed,
        threads,
        wall_s,
        open_loop,
    );
    Ok(CampaignTable { rows: out, summary })
}

/// What [`campaign_account`] hands back: the unique rows, the missing runs,
/// the conflict's message and the missing runs' message.
type Accounting<'py> = (Bound<'py, PyList>, Vec<u64>, Option<String>, Option<String>);

/// A CampaignTable's pickle: its constructor, and the rows, the touchdown
/// limits and the summary (JSON text).
type TableReduce<'py> = (Bound<'py, PyAny>, (Bound<'py, PyList>, String, String));

/// Account for the rows of a campaign of `runs` runs that came back so far
/// (`bellyflop::output::campaign::account`): `(rows, missing, conflict,
/// missing_message)`: the unique rows in run order (tuples), the runs not
/// there, the error when a run came back twice with different results (or
/// a run outside 0..runs) and the message that names the missing runs
/// (`None` when none is).
#[pyfunction]
fn campaign_account<'py>(
    py: Python<'py>,
    rows: &Bound<'py, PyAny>,
    runs: u64,
    config: &SimConfig,
) -> PyResult<Accounting<'py>> {
    let rows = rows_from_py(rows, config.inner.touchdown)?;
    let (unique, missing, conflict) = match campaign::account(rows, runs) {
        Ok(a) => (a.rows, a.missing, None),
        Err(e) => (Vec::new(), Vec::new(), Some(e.to_string())),
    };
    let message = (!missing.is_empty()).then(|| {
        campaign::CampaignError::Missing {
            runs,
            missing: missing.clone(),
        }
        .to_string()
    });
    let tuples = unique
        .iter()
        .map(|r| row_to_py(py, r))
        .collect::<PyResult<Vec<_>>>()?;
    Ok((PyList::new(py, tuples)?, missing, conflict, message))
}

#[pymethods]
impl CampaignTable {
    /// The summary (`bellyflop montecarlo --json`).
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        json_to_py(py, &self.summary, false)
    }

    /// The text of runs.csv, as `bellyflop montecarlo --out` writes it.
    fn runs_csv(&self) -> String {
        campaign::runs_csv(&self.rows)
    }

    /// runs.csv's columns: numbers as numpy arrays (float64, int64, bool),
    /// `outcome` as a list of str.
    fn columns<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let rows: Vec<[Cell; 17]> = self.rows.iter().map(RunRow::cells).collect();
        for (k, column) in campaign::RUNS_CSV.iter().enumerate() {
            let cells = rows.iter().map(|r| r[k]);
            let values = match column.kind {
                Kind::Count => {
                    let v = cells.map(|c| if let Cell::Count(n) = c { n as i64 } else { 0 });
                    PyArray1::from_vec(py, v.collect()).into_any()
                }
                Kind::Number => {
                    let v = cells.map(|c| if let Cell::Number(x) = c { x } else { f64::NAN });
                    PyArray1::from_vec(py, v.collect()).into_any()
                }
                Kind::Flag => {
                    let v = cells.map(|c| matches!(c, Cell::Flag(true)));
                    PyArray1::from_vec(py, v.collect()).into_any()
                }
                Kind::Outcome => cells
                    .map(|c| c.to_string())
                    .collect::<Vec<_>>()
                    .into_bound_py_any(py)?,
            };
            d.set_item(column.name, values)?;
        }
        Ok(d)
    }

    fn __len__(&self) -> usize {
        self.rows.len()
    }

    /// Equal tables: the same runs.csv text (every digit), re-plan times
    /// and summary.
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<CampaignTable>()
            .map(|o| {
                let o = o.get();
                o.summary == self.summary
                    && campaign::runs_csv(&o.rows) == campaign::runs_csv(&self.rows)
                    && o.rows.len() == self.rows.len()
                    && o.rows
                        .iter()
                        .zip(&self.rows)
                        .all(|(a, b)| a.replan_ms == b.replan_ms && a.limits == b.limits)
            })
            .unwrap_or(false)
    }

    /// Rebuild from the rows' tuples, the touchdown limits and the summary
    /// as JSON text (pickling).
    #[staticmethod]
    fn _from_state(rows: &Bound<'_, PyAny>, limits: &str, summary: &str) -> PyResult<Self> {
        let limits: TouchdownLimits =
            serde_json::from_str(limits).map_err(|e| InputError::new_err(e.to_string()))?;
        let summary =
            serde_json::from_str(summary).map_err(|e| InputError::new_err(e.to_string()))?;
        Ok(CampaignTable {
            rows: rows_from_py(rows, limits)?,
            summary,
        })
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<TableReduce<'py>> {
        let ctor = py.get_type::<CampaignTable>().getattr("_from_state")?;
        let rows = self
            .rows
            .iter()
            .map(|r| row_to_py(py, r))
            .collect::<PyResult<Vec<_>>>()?;
        let limits = self.rows.first().map(|r| r.limits).unwrap_or_default();
        let limits =
            serde_json::to_string(&limits).map_err(|e| InternalError::new_err(e.to_string()))?;
        Ok((
            ctor,
            (PyList::new(py, rows)?, limits, self.summary.to_string()),
        ))
    }
}

/// The allowed ranges of the integer arguments (`nodes`, `intervals`,
/// `runs`, `seed`, `run`, `threads`), from the core crate's range table
/// (`bellyflop::input::validate`).
#[pyfunction]
fn argument_ranges() -> Vec<(&'static str, u64, u64)> {
    use bellyflop::input::validate::{INTERVALS, NODES, RUN, RUNS, SEED, THREADS};
    vec![
        ("nodes", NODES.0 as u64, NODES.1 as u64),
        ("intervals", INTERVALS.0 as u64, INTERVALS.1 as u64),
        ("runs", RUNS.0, RUNS.1),
        ("seed", SEED.0, SEED.1),
        ("run", RUN.0, RUN.1),
        ("threads", THREADS.0, THREADS.1),
    ]
}

/// Panic inside Rust, as a bug would: the tests check that it arrives as
/// `InternalError` and the interpreter carries on.
#[pyfunction]
fn _panic_for_tests(py: Python<'_>) -> PyResult<()> {
    detached(py, || panic!("a test asked for a panic"))
}

/// The column names of runs.csv, in order.
#[pyfunction]
fn runs_csv_columns() -> Vec<&'static str> {
    campaign::RUNS_CSV_COLUMNS.to_vec()
}

#[pymodule]
fn _bellyflop(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("InternalError", py.get_type::<InternalError>())?;
    m.add_class::<Section>()?;
    m.add_class::<Scenario>()?;
    m.add_class::<SimConfig>()?;
    m.add_class::<Solution>()?;
    m.add_class::<six_dof::SixDofSolution>()?;
    m.add_class::<Flight>()?;
    m.add_class::<CampaignTable>()?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(sim, m)?)?;
    m.add_function(wrap_pyfunction!(campaign_chunk, m)?)?;
    m.add_function(wrap_pyfunction!(campaign_table, m)?)?;
    m.add_function(wrap_pyfunction!(campaign_account, m)?)?;
    m.add_function(wrap_pyfunction!(argument_ranges, m)?)?;
    m.add_function(wrap_pyfunction!(runs_csv_columns, m)?)?;
    m.add_function(wrap_pyfunction!(_panic_for_tests, m)?)?;
    Ok(())
}
