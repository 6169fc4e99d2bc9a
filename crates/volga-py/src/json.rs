//! JSON values (the kernel's serde reports) as Python objects: dicts, lists, floats, ints,
//! strings, booleans and `None` — the same structure `json.loads` of the CLI's output gives.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde_json::Value;

use crate::errors::value_error;

/// Parses JSON text made by the Python layer from the caller's dict, with errors naming the
/// argument and the field path (`stroke.tool.Sphere.radius: …`), not a text position.
pub fn parse<T: serde::de::DeserializeOwned>(what: &str, text: &str) -> PyResult<T> {
    let mut de = serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner().to_string();
        let inner = match inner.find(" at line ") {
            Some(i) => &inner[..i],
            None => &inner[..],
        };
        if path == "." || path.is_empty() {
            value_error(format!("{what}: {inner}"))
        } else {
            value_error(format!("{what}.{path}: {inner}"))
        }
    })
}

pub fn to_py(py: Python<'_>, value: &Value) -> PyResult<Py<PyAny>> {
    Ok(match value {
        Value::Null => py.None(),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any().unbind(),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any().unbind()
            } else if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any().unbind()
            } else {
                n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any().unbind()
            }
        }
        Value::String(s) => s.into_pyobject(py)?.into_any().unbind(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(to_py(py, item)?)?;
            }
            list.into_any().unbind()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, v) in map {
                dict.set_item(k, to_py(py, v)?)?;
            }
            dict.into_any().unbind()
        }
    })
}

/// Any serializable report as a Python object.
pub fn report_to_py<T: serde::Serialize>(py: Python<'_>, report: &T) -> PyResult<Py<PyAny>> {
    let value = serde_json::to_value(report).map_err(|e| value_error(format!("report: {e}")))?;
    to_py(py, &value)
}
