//! Array arguments: any array-like converted with `numpy.asarray(x, float64)` (integer and
//! float arrays of any width; other dtypes refused) and checked for its shape (one row of
//! `width` values, or `N` rows), made C-contiguous and borrowed read-only for the kernels;
//! results back as numpy arrays.

use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArray};
use numpy::{PyUntypedArrayMethods, prelude::IntoPyArray};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// `N` rows of `width` float64 values (a `(width,)` argument is one row, `single`).
pub struct Rows<'py> {
    arr: PyReadonlyArrayDyn<'py, f64>,
    /// Number of rows.
    pub rows: usize,
    /// The argument was one row of shape `(width,)`.
    pub single: bool,
}

impl Rows<'_> {
    /// The values, row-major (`rows * width`).
    pub fn values(&self) -> PyResult<&[f64]> {
        self.arr
            .as_slice()
            .map_err(|e| PyValueError::new_err(format!("array not contiguous: {e}")))
    }
}

/// A `ValueError`.
pub fn value_error(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// Checks argument `name`: a float64 array (or a list convertible to one) of shape
/// `(N, width)` or `(width,)`; `what` says what a row holds, for the error message.
pub fn rows<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    width: usize,
    what: &str,
) -> PyResult<Rows<'py>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let arr = if let Ok(u) = obj.cast::<PyUntypedArray>() {
        // Integer and other float arrays convert exactly as numpy.asarray(x, float64) does
        // (int64 points, float32 twists); anything else (complex, objects, strings) would
        // lose data or mean nothing, and is refused by its dtype.
        let kind: String = u.dtype().getattr("kind")?.extract()?;
        if !matches!(kind.as_str(), "i" | "u" | "f") {
            return Err(value_error(format!(
                "{name}: expected a float64 array of shape (N, {width}) or ({width},) ({what}), \
                 got dtype {}",
                u.dtype()
            )));
        }
        np.call_method1("asarray", (obj, "float64"))?
    } else {
        np.call_method1("asarray", (obj, "float64")).map_err(|e| {
            value_error(format!(
                "{name}: expected a float64 array of shape (N, {width}) or ({width},) ({what}): \
                 {e}"
            ))
        })?
    };
    let arr = np.call_method1("ascontiguousarray", (arr,))?;
    let a = arr
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|e| value_error(format!("{name}: {e}")))?;
    let shape = a.shape().to_vec();
    let (rows, single) = match shape[..] {
        [w] if w == width => (1, true),
        [n, w] if w == width => (n, false),
        _ => {
            let got: Vec<String> = shape.iter().map(|s| s.to_string()).collect();
            return Err(value_error(format!(
                "{name}: expected shape (N, {width}) or ({width},) ({what}), got ({}{})",
                got.join(", "),
                if got.len() == 1 { "," } else { "" }
            )));
        }
    };
    Ok(Rows {
        arr: a.readonly(),
        rows,
        single,
    })
}

/// An optional per-row argument that must match `n` rows (one row of shape `(width,)` is used
/// for every row).
pub fn matching<'py>(
    obj: Option<&Bound<'py, PyAny>>,
    name: &str,
    width: usize,
    what: &str,
    n: usize,
    of: &str,
) -> PyResult<Option<Rows<'py>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    let r = rows(obj, name, width, what)?;
    if !r.single && r.rows != n {
        return Err(value_error(format!(
            "{name}: {} rows, but {of} has {n} (give one row per {of} row, or one ({width},) \
             row for all)",
            r.rows
        )));
    }
    Ok(Some(r))
}

/// Row `i` of an optional broadcast argument.
pub fn row(values: Option<&[f64]>, width: usize, single: bool, i: usize) -> Option<&[f64]> {
    values.map(|v| {
        let k = if single { 0 } else { i };
        &v[k * width..(k + 1) * width]
    })
}

/// `rows * width` values as an array of shape `(rows, width)`, or `(width,)` when `single`.
pub fn to_array<'py>(
    py: Python<'py>,
    v: Vec<f64>,
    rows: usize,
    width: usize,
    single: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let a: Bound<'py, PyArray1<f64>> = v.into_pyarray(py);
    if single {
        Ok(a.into_any())
    } else {
        Ok(a.reshape([rows, width])?.into_any())
    }
}
