//! Conversions between Python objects and the core crate's serde values.

use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
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

/// Nested dicts, lists and scalars as a TOML value (which, unlike JSON,
/// holds NaN and infinities, so the core crate's validation names the field
/// that has one). `path` names the key for errors.
pub fn py_to_toml(ob: &Bound<'_, PyAny>, path: &str) -> PyResult<toml::Value> {
    if ob.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(ob.extract()?));
    }
    if ob.is_instance_of::<PyInt>() {
        let i: i64 = ob
            .extract()
            .map_err(|_| InputError::new_err(format!("{path}: integer out of range")))?;
        return Ok(toml::Value::Integer(i));
    }
    if ob.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(ob.extract()?));
    }
    if ob.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(ob.extract()?));
    }
    if let Ok(d) = ob.cast::<PyDict>() {
        let mut table = toml::Table::new();
        for (k, v) in d.iter() {
            let key: String = k.extract().map_err(|_| {
                PyTypeError::new_err(format!("{path}: keys must be str, got {k:?}"))
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
            table.insert(key, py_to_toml(&v, &sub)?);
        }
        return Ok(toml::Value::Table(table));
    }
    if ob.is_instance_of::<PyList>() || ob.is_instance_of::<PyTuple>() {
        let mut out = Vec::new();
        for (i, v) in ob.try_iter()?.enumerate() {
            out.push(py_to_toml(&v?, &format!("{path}[{i}]"))?);
        }
        return Ok(toml::Value::Array(out));
    }
    // numpy scalars and anything else float-like.
    if let Ok(x) = ob.extract::<f64>() {
        return Ok(toml::Value::Float(x));
    }
    Err(PyTypeError::new_err(format!(
        "{path}: cannot use a {} in a scenario or configuration",
        ob.get_type().name()?
    )))
}
