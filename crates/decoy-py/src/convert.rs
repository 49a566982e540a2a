//! Values between Python and the solver's formats: a dict as the TOML text of a
//! scenario or configuration file, TOML and JSON as Python objects, and the rows
//! of a CSV file of the column schema as NumPy arrays.

use decoy_schema::{CsvFile, Quantity};
use decoy_sim::Cell;
use numpy::PyArray1;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyMapping, PyString, PyTuple};

/// The TOML text of the mapping `dict` (`what` names it in messages: `scenario
/// dict`, `config dict`): its keys in their order, each table's values before
/// its sub-tables (as TOML needs), a `None` value left out (the key's default).
/// The line numbers of the file's messages are lines of this text: for a flat
/// dict, the key's place in it.
pub fn toml_text(dict: &Bound<'_, PyAny>, what: &str) -> PyResult<String> {
    let mut text = String::new();
    write_table(&mut text, None, dict, what)?;
    Ok(text)
}

/// Writes the table `mapping` at `path` (`None`: the top level).
fn write_table(
    text: &mut String,
    path: Option<&str>,
    mapping: &Bound<'_, PyAny>,
    what: &str,
) -> PyResult<()> {
    let items = items(mapping, path, what)?;
    if let Some(path) = path {
        text.push_str(&format!("[{path}]\n"));
    }
    let mut tables = Vec::new();
    for (key, value) in items {
        let full = path.map_or_else(|| key_text(&key), |p| format!("{p}.{}", key_text(&key)));
        if value.cast::<PyMapping>().is_ok() {
            tables.push((full, value));
        } else if let Some(v) = to_value(&value, &full, what)? {
            text.push_str(&format!("{} = {v}\n", key_text(&key)));
        }
    }
    for (full, value) in tables {
        write_table(text, Some(&full), &value, what)?;
    }
    Ok(())
}

/// The (key, value) pairs of a mapping whose keys are strings.
fn items<'py>(
    mapping: &Bound<'py, PyAny>,
    path: Option<&str>,
    what: &str,
) -> PyResult<Vec<(String, Bound<'py, PyAny>)>> {
    let mapping = mapping.cast::<PyMapping>().map_err(|_| {
        PyTypeError::new_err(format!(
            "{what}: expected a dict, got {}",
            type_name(mapping)
        ))
    })?;
    let mut pairs = Vec::new();
    for item in mapping.items()?.iter() {
        let (key, value): (Bound<'py, PyAny>, Bound<'py, PyAny>) = item.extract()?;
        let key = key.cast::<PyString>().map_err(|_| {
            PyTypeError::new_err(format!(
                "{what}: the keys of {} must be strings, got {}",
                path.map_or_else(|| "the dict".to_owned(), |p| format!("`{p}`")),
                type_name(&key)
            ))
        })?;
        pairs.push((key.to_str()?.to_owned(), value));
    }
    Ok(pairs)
}

/// A key as TOML writes it: bare when it can be, else quoted.
fn key_text(key: &str) -> String {
    let bare = !key.is_empty()
        && key
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if bare {
        key.to_owned()
    } else {
        toml::Value::String(key.to_owned()).to_string()
    }
}

/// The TOML value of `value` at the key path `path`; `None` for Python's None.
fn to_value(value: &Bound<'_, PyAny>, path: &str, what: &str) -> PyResult<Option<toml::Value>> {
    if value.is_none() {
        return Ok(None);
    }
    let v = if value.cast::<PyBool>().is_ok() {
        toml::Value::Boolean(value.extract()?)
    } else if value.cast::<PyInt>().is_ok() {
        toml::Value::Integer(value.extract()?)
    } else if value.cast::<PyFloat>().is_ok() {
        toml::Value::Float(value.extract()?)
    } else if let Ok(s) = value.cast::<PyString>() {
        toml::Value::String(s.to_str()?.to_owned())
    } else if value.hasattr("__fspath__")? {
        let path: std::path::PathBuf = value.extract()?;
        toml::Value::String(path.to_string_lossy().into_owned())
    } else if value.cast::<PyList>().is_ok() || value.cast::<PyTuple>().is_ok() {
        let mut array = Vec::new();
        for (i, element) in value.try_iter()?.enumerate() {
            let element = element?;
            let at = format!("{path}[{i}]");
            match to_value(&element, &at, what)? {
                Some(v) => array.push(v),
                None => {
                    return Err(PyTypeError::new_err(format!(
                        "{what}: `{at}` is None, which a TOML array cannot hold"
                    )));
                }
            }
        }
        toml::Value::Array(array)
    } else if value.cast::<PyMapping>().is_ok() {
        // A table inside an array (inline).
        let mut table = toml::Table::new();
        for (key, element) in items(value, Some(path), what)? {
            if let Some(v) = to_value(&element, &format!("{path}.{key}"), what)? {
                table.insert(key, v);
            }
        }
        toml::Value::Table(table)
    } else if value.hasattr("__index__")? {
        // NumPy's integers.
        toml::Value::Integer(value.extract()?)
    } else if value.hasattr("__float__")? {
        // NumPy's other floats.
        toml::Value::Float(value.extract()?)
    } else {
        return Err(PyTypeError::new_err(format!(
            "{what}: `{path}` is {}, which TOML cannot hold",
            type_name(value)
        )));
    };
    Ok(Some(v))
}

/// `a str`, `an object of type X`: a value's type for messages.
fn type_name(value: &Bound<'_, PyAny>) -> String {
    let name = value
        .get_type()
        .name()
        .map_or_else(|_| "?".to_owned(), |n| n.to_string());
    format!("a {name}")
}

/// A TOML document as Python objects: tables as dicts, arrays as lists, dates
/// as strings.
pub fn toml_to_py<'py>(py: Python<'py>, value: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        toml::Value::String(s) => PyString::new(py, s).into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => PyFloat::new(py, *f).into_any(),
        toml::Value::Boolean(b) => PyBool::new(py, *b).to_owned().into_any(),
        toml::Value::Datetime(d) => PyString::new(py, &d.to_string()).into_any(),
        toml::Value::Array(a) => {
            let list = PyList::empty(py);
            for v in a {
                list.append(toml_to_py(py, v)?)?;
            }
            list.into_any()
        }
        toml::Value::Table(t) => table_to_py(py, t)?.into_any(),
    })
}

/// A TOML table as a dict.
pub fn table_to_py<'py>(py: Python<'py>, table: &toml::Table) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for (k, v) in table {
        dict.set_item(k, toml_to_py(py, v)?)?;
    }
    Ok(dict)
}

/// `value` as the command line's `--json` prints it, read back by Python's
/// `json` module: the same keys in the same order, the same numbers (the
/// shortest text that reads back to each f64, so bit for bit), `null` for a
/// non-finite number.
pub fn json_to_py<'py>(
    py: Python<'py>,
    value: &impl serde::Serialize,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value)
        .map_err(|e| PyTypeError::new_err(format!("cannot convert the result: {e}")))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// The columns of `file` as a dict of 1-D float64 arrays, column name to the
/// values of its `rows` rows (`cell(row, quantity)`: what the CSV file's row
/// writes in that column, at full precision; counts and codes as floats).
pub fn columns<'py>(
    py: Python<'py>,
    file: &CsvFile,
    rows: usize,
    cell: impl Fn(usize, Quantity) -> Option<Cell>,
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for column in file.columns {
        let values: Vec<f64> = (0..rows)
            .map(|row| match cell(row, column.quantity) {
                Some(Cell::Time(v) | Cell::Value(v)) => v,
                Some(Cell::Count(n)) => n as f64,
                // Every writer has every column of its file (decoy-sim's tests).
                None => f64::NAN,
            })
            .collect();
        dict.set_item(column.name, PyArray1::from_vec(py, values))?;
    }
    Ok(dict)
}
