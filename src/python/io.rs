//! Images in and out: EXR and PNG files as flat float32 arrays.

use super::convert::{slice, to_numpy, without_gil};
use crate::image_io::{ImageError, ImageErrorKind, DEFAULT_MAX_PIXELS};
use numpy::PyReadonlyArray1;
use pyo3::exceptions::{PyMemoryError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::PathBuf;

/// An RGB image as (width, height, flat float32 array of H·W·3 values).
#[derive(FromPyObject)]
pub struct RgbImage<'py>(usize, usize, PyReadonlyArray1<'py, f32>);

impl RgbImage<'_> {
    /// `(width, height, values)`, or a `ValueError` when the sizes disagree.
    fn checked(&self) -> PyResult<(usize, usize, &[f32])> {
        let (width, height) = (self.0, self.1);
        let d = slice(&self.2, "image")?;
        if width == 0 || height == 0 {
            // the readers refuse an image without pixels: do not write one
            return Err(PyValueError::new_err(format!(
                "image: expected at least one pixel, got {height}x{width}"
            )));
        }
        if Some(d.len()) != width.checked_mul(height).and_then(|n| n.checked_mul(3)) {
            return Err(PyValueError::new_err(format!(
                "image: expected {height}x{width}x3 values, got {}",
                d.len()
            )));
        }
        Ok((width, height, d))
    }
}

/// An image error as Python sees it: `MemoryError` when the pixels could
/// not be allocated, `ValueError` for a corrupt or oversized file,
/// `OSError` for the file system.
pub fn image_error(e: ImageError) -> PyErr {
    match e.1 {
        ImageErrorKind::Memory => PyMemoryError::new_err(e.0),
        ImageErrorKind::Format | ImageErrorKind::TooLarge => PyValueError::new_err(e.0),
        ImageErrorKind::Io => PyOSError::new_err(e.0),
    }
}

/// Writes a float RGB EXR.
#[pyfunction]
pub fn write_exr(py: Python<'_>, path: PathBuf, image: RgbImage<'_>) -> PyResult<()> {
    let (w, h, d) = image.checked()?;
    without_gil(py, || crate::image_io::write_exr(&path, w, h, d)).map_err(image_error)
}

/// `(width, height, flat float32 array)` from an image reader, run with
/// the GIL released.
type Reader = fn(&std::path::Path, usize) -> Result<(usize, usize, Vec<f32>), ImageError>;

/// `(width, height, flat float32 array)`.
type Image<'py> = PyResult<(usize, usize, Bound<'py, PyAny>)>;

fn read_with(
    py: Python<'_>,
    path: PathBuf,
    max_pixels: Option<usize>,
    read: Reader,
) -> PyResult<(usize, usize, Bound<'_, PyAny>)> {
    let max = max_pixels.unwrap_or(DEFAULT_MAX_PIXELS);
    let (w, h, d) = without_gil(py, || read(&path, max)).map_err(image_error)?;
    Ok((w, h, to_numpy(py, d)))
}

/// Reads an EXR's RGB channels, of the layer `layer` names in a multilayer
/// file: (width, height, flat float32 array); a single-channel layer comes
/// back as grey. Images over `max_pixels` (default 2^28) are refused
/// before reading.
#[pyfunction]
#[pyo3(signature = (path, max_pixels=None, layer=None))]
pub fn read_exr(
    py: Python<'_>,
    path: PathBuf,
    max_pixels: Option<usize>,
    layer: Option<String>,
) -> Image<'_> {
    let max = max_pixels.unwrap_or(DEFAULT_MAX_PIXELS);
    let (w, h, d) = without_gil(py, || {
        crate::image_io::read_exr_layer(&path, max, layer.as_deref())
    })
    .map_err(image_error)?;
    Ok((w, h, to_numpy(py, d)))
}

/// The layers of an EXR file: a list of (name, channel names, width, height).
#[pyfunction]
pub fn exr_layers(
    py: Python<'_>,
    path: PathBuf,
) -> PyResult<Vec<(String, Vec<String>, usize, usize)>> {
    let layers = without_gil(py, || crate::image_io::exr_layers(&path)).map_err(image_error)?;
    Ok(layers
        .into_iter()
        .map(|l| (l.name, l.channels, l.width, l.height))
        .collect())
}

/// Reads a PNG: (width, height, flat RGBA float32 array in [0, 1]).
/// Images over `max_pixels` (default 2^28) are refused before reading.
#[pyfunction]
#[pyo3(signature = (path, max_pixels=None))]
pub fn read_png(py: Python<'_>, path: PathBuf, max_pixels: Option<usize>) -> Image<'_> {
    read_with(py, path, max_pixels, crate::image_io::read_png)
}

/// The default pixel limit of the image readers.
#[pyfunction]
pub fn default_max_pixels() -> usize {
    DEFAULT_MAX_PIXELS
}

/// Writes an sRGB PNG preview of a linear image scaled by 2^exposure.
#[pyfunction]
pub fn write_png(
    py: Python<'_>,
    path: PathBuf,
    image: RgbImage<'_>,
    exposure: f32,
) -> PyResult<()> {
    let (w, h, d) = image.checked()?;
    without_gil(py, || crate::image_io::write_png(&path, w, h, d, exposure)).map_err(image_error)
}

/// 8-bit sRGB of a linear image scaled by 2^exposure: its H·W·3 values
/// (`png: false`) or the bytes of a PNG file (`png: true`).
#[pyfunction]
pub fn srgb8<'py>(
    py: Python<'py>,
    image: RgbImage<'py>,
    exposure: f32,
    png: bool,
) -> PyResult<Bound<'py, PyBytes>> {
    let (w, h, d) = image.checked()?;
    let bytes = without_gil(py, || match png {
        true => crate::image_io::encode_png(w, h, d, exposure),
        false => Ok(crate::image_io::srgb8(d, exposure)),
    })
    .map_err(image_error)?;
    Ok(PyBytes::new(py, &bytes))
}
