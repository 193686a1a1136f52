//! Conversions between Python objects and the core crate's serde values.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyComplex, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use pyo3::IntoPyObjectExt;
use serde_json::Value;

use crate::InputError;

/// A JSON value as Python: objects as dicts, arrays as lists, null as None.
/// With `arrays`, an array of numbers (nulls read as NaN) becomes a numpy
/// float64 array; the values are the f64s the core crate produced, bit for bit.
pub fn json_to_py<'py>(py: Python<'py>, v: &Value, arrays: bool) -> PyResult<Bound<'py, PyAny>> {
    match v {
        Value::Null => Ok(py.None().into_bound(py)),
        Value::Bool(b) => b.into_bound_py_any(py),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.into_bound_py_any(py)
            } else if let Some(u) = n.as_u64() {
                u.into_bound_py_any(py)
            } else {
                n.as_f64().unwrap_or(f64::NAN).into_bound_py_any(py)
            }
        }
        Value::String(s) => s.into_bound_py_any(py),
        Value::Array(items) => {
            if arrays && is_numeric(items) {
                let xs: Vec<f64> = items
                    .iter()
                    .map(|x| x.as_f64().unwrap_or(f64::NAN))
                    .collect();
                Ok(numpy::PyArray1::from_vec(py, xs).into_any())
            } else {
                let list = PyList::empty(py);
                for x in items {
                    list.append(json_to_py(py, x, arrays)?)?;
                }
                Ok(list.into_any())
            }
        }
        Value::Object(map) => {
            let d = PyDict::new(py);
            for (k, x) in map {
                d.set_item(k, json_to_py(py, x, arrays)?)?;
            }
            Ok(d.into_any())
        }
    }
}

/// A non-empty array of numbers (and nulls, the JSON of non-finite values)
/// with at least one number: a node array, not a list of records.
fn is_numeric(items: &[Value]) -> bool {
    items.iter().any(Value::is_number) && items.iter().all(|x| x.is_number() || x.is_null())
}

/// How deep a scenario or configuration dict may nest: the deepest real
/// key is four tables down (`solver.direct.…`), so 64 leaves room for any
/// layout while the conversion's recursion stays far from the stack's end.
pub const MAX_DEPTH: usize = 64;

/// Nested dicts, lists and scalars as a TOML value (which, unlike JSON,
/// holds NaN and infinities, so the core crate's validation names the field
/// that has one). Any value is an `InputError` naming its key path (e.g.
/// `initial.x_m[3]`) or a TOML value: a container that holds itself (a
/// cycle) or a nest deeper than [`MAX_DEPTH`] stops there, so no input
/// can overflow the stack.
pub fn py_to_toml(ob: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    Walk { open: Vec::new() }.value(ob, "")
}

/// The containers open on the current path (their ids), for cycles and depth.
struct Walk {
    open: Vec<usize>,
}

fn name_of(path: &str) -> &str {
    if path.is_empty() {
        "the dict"
    } else {
        path
    }
}

impl Walk {
    fn value(&mut self, ob: &Bound<'_, PyAny>, path: &str) -> PyResult<toml::Value> {
        let err = |what: String| InputError::new_err(format!("{}: {what}", name_of(path)));
        let numpy_type = type_name(ob);
        if ob.is_instance_of::<PyBool>()
            || numpy_type == "numpy.bool"
            || numpy_type == "numpy.bool_"
        {
            return Ok(toml::Value::Boolean(ob.is_truthy()?));
        }
        if ob.is_instance_of::<PyString>() {
            return Ok(toml::Value::String(ob.extract()?));
        }
        if ob.is_instance_of::<PyInt>() || is_numpy_integer(&numpy_type) {
            let i = ob.call_method0("__index__")?;
            return i.extract::<i64>().map(toml::Value::Integer).map_err(|_| {
                err(format!(
                    "the integer {i} is out of range: allowed {} to {}",
                    i64::MIN,
                    i64::MAX
                ))
            });
        }
        if ob.is_instance_of::<PyFloat>() {
            return Ok(toml::Value::Float(ob.extract()?));
        }
        let is_dict = ob.is_instance_of::<PyDict>();
        if is_dict || ob.is_instance_of::<PyList>() || ob.is_instance_of::<PyTuple>() {
            let id = ob.as_ptr() as usize;
            if self.open.contains(&id) {
                return Err(err(
                    "a cycle: this container holds itself (a dict or list inside its own value)"
                        .to_string(),
                ));
            }
            if self.open.len() >= MAX_DEPTH {
                return Err(err(format!(
                    "nested deeper than {MAX_DEPTH} dicts and lists (no scenario or configuration nests so deep)"
                )));
            }
            self.open.push(id);
            let v = if is_dict {
                self.table(ob, path)
            } else {
                self.array(ob, path)
            };
            self.open.pop();
            return v;
        }
        // Other numbers (numpy floats, Decimal, Fraction): anything with
        // __float__; complex and everything else is not a number here.
        let complex = ob.is_instance_of::<PyComplex>() || numpy_type.starts_with("numpy.complex");
        if !complex && ob.hasattr("__float__")? {
            if let Ok(x) = ob.extract::<f64>() {
                return Ok(toml::Value::Float(x));
            }
        }
        Err(err(format!(
            "cannot use a {} in a scenario or configuration",
            ob.get_type().name()?
        )))
    }

    fn table(&mut self, ob: &Bound<'_, PyAny>, path: &str) -> PyResult<toml::Value> {
        let d = ob.cast::<PyDict>()?;
        let mut table = toml::Table::new();
        for (k, v) in d.iter() {
            let key: String = k.extract().map_err(|_| {
                InputError::new_err(format!(
                    "{}: keys must be str, got {}",
                    name_of(path),
                    k.repr().map_or_else(|_| "?".to_string(), |r| r.to_string())
                ))
            })?;
            let sub = if path.is_empty() {
                key.clone()
            } else {
                format!("{path}.{key}")
            };
            // TOML has no null: a None is an absent key (its default, if any).
            if v.is_none() {
                continue;
            }
            table.insert(key, self.value(&v, &sub)?);
        }
        Ok(toml::Value::Table(table))
    }

    fn array(&mut self, ob: &Bound<'_, PyAny>, path: &str) -> PyResult<toml::Value> {
        let mut out = Vec::new();
        for (i, v) in ob.try_iter()?.enumerate() {
            out.push(self.value(&v?, &format!("{path}[{i}]"))?);
        }
        Ok(toml::Value::Array(out))
    }
}

/// `module.name` of `ob`'s type (`numpy.bool`, `numpy.int64`).
fn type_name(ob: &Bound<'_, PyAny>) -> String {
    let t = ob.get_type();
    match (t.module(), t.name()) {
        (Ok(m), Ok(n)) => format!("{m}.{n}"),
        _ => String::new(),
    }
}

/// A numpy integer scalar (`numpy.int8` ... `numpy.uint64`).
fn is_numpy_integer(type_name: &str) -> bool {
    type_name.starts_with("numpy.int") || type_name.starts_with("numpy.uint")
}
