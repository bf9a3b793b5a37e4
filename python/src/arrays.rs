//! Result arrays as numpy views of the run folder's values, without a copy.
//!
//! The run folder's session (`flexstage_run::RunDir`) keeps every value it stored or loaded
//! behind an `Arc`. A numpy array here is a read-only view of such a value's buffer whose
//! base object ([`Buffer`]) holds the `Arc`: the memory stays valid as long as the array
//! lives, nothing is copied, and the same result loaded twice shares one buffer. The views
//! are read-only because the session shares the value (`np.array(view)` gives a writable
//! copy).

use std::any::Any;
use std::sync::Arc;

use numpy::ndarray::{ArrayView1, ArrayView2};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;

/// The owner of the memory behind result arrays (their numpy `base`).
#[pyclass(module = "flexstage._native", frozen)]
pub struct Buffer {
    _owner: Arc<dyn Any + Send + Sync>,
    address: usize,
    len: usize,
}

#[pymethods]
impl Buffer {
    /// The address of the first element (the numpy array's data pointer).
    #[getter]
    fn address(&self) -> usize {
        self.address
    }

    fn __len__(&self) -> usize {
        self.len
    }
}

fn buffer<'py, T: Any + Send + Sync>(
    py: Python<'py>,
    owner: &Arc<T>,
    data: &[f64],
) -> PyResult<Bound<'py, Buffer>> {
    Bound::new(
        py,
        Buffer {
            _owner: owner.clone(),
            address: data.as_ptr() as usize,
            len: data.len(),
        },
    )
}

/// A read-only 1-D view of the slice `pick` returns from the shared value `owner`.
pub fn view1<'py, T: Any + Send + Sync>(
    py: Python<'py>,
    owner: &Arc<T>,
    pick: impl FnOnce(&T) -> &[f64],
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let data = pick(owner);
    let base = buffer(py, owner, data)?;
    let view = ArrayView1::from(data);
    // SAFETY: `data` lies in the value `owner` shares, which is never mutated or moved;
    // `base` holds a clone of the `Arc`, so the memory lives as long as the array.
    let array = unsafe { PyArray1::borrow_from_array(&view, base.into_any()) };
    Ok(readonly(array))
}

/// A read-only `(rows, cols)` C-order view of the slice `pick` returns from `owner`.
pub fn view2<'py, T: Any + Send + Sync>(
    py: Python<'py>,
    owner: &Arc<T>,
    rows: usize,
    cols: usize,
    pick: impl FnOnce(&T) -> &[f64],
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let data = pick(owner);
    let base = buffer(py, owner, data)?;
    let view = ArrayView2::from_shape((rows, cols), data).map_err(|e| {
        pyo3::exceptions::PyValueError::new_err(format!(
            "{} values are not a {rows} x {cols} array: {e}",
            data.len()
        ))
    })?;
    // SAFETY: as in `view1`.
    let array = unsafe { PyArray2::borrow_from_array(&view, base.into_any()) };
    Ok(readonly(array))
}

fn readonly<D: numpy::ndarray::Dimension>(
    array: Bound<'_, numpy::PyArray<f64, D>>,
) -> Bound<'_, numpy::PyArray<f64, D>> {
    // A fresh array: nothing else borrows it.
    if let Ok(rw) = array.try_readwrite() {
        drop(rw.make_nonwriteable());
    }
    array
}

/// An owned array (a small result computed here, e.g. a polygon in metres).
pub fn owned2<'py>(py: Python<'py>, rows: &[[f64; 2]]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    PyArray1::from_vec(py, flat)
        .reshape([rows.len(), 2])
        .expect("n x 2 values")
}
