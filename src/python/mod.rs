//! The Python extension module `hairshade._native`: the only code that knows
//! about Python. It converts flat numpy arrays to slices, parameter errors to
//! `ValueError`, and runs every computation with the GIL released
//! ([`convert`]). Shapes and dtypes are checked by the typed API in
//! `python/hairshade/`; lengths are re-checked here so that a direct caller
//! gets an error, never a panic.
//!
//! - [`convert`]: arrays in and out, the float-type dispatch, errors, GIL;
//! - [`models`]: ChiangHair, KarisHair, DEonHair;
//! - [`render`]: the rasterizer and its options;
//! - [`io`]: EXR and PNG;
//! - [`special`]: special functions, lobe pieces, thread settings.

mod convert;
mod io;
mod models;
mod render;
mod scene_args;
mod special;

use pyo3::prelude::*;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<models::PyChiangHair>()?;
    m.add_class::<models::PyKarisHair>()?;
    m.add_class::<models::PyDEonHair>()?;
    for f in [
        wrap_pyfunction!(models::chiang_longitudinal_variance, m)?,
        wrap_pyfunction!(models::chiang_azimuthal_scale, m)?,
        wrap_pyfunction!(render::render, m)?,
        wrap_pyfunction!(render::render_options, m)?,
        wrap_pyfunction!(render::render_option_ranges, m)?,
        wrap_pyfunction!(io::write_exr, m)?,
        wrap_pyfunction!(io::read_exr, m)?,
        wrap_pyfunction!(io::exr_layers, m)?,
        wrap_pyfunction!(io::write_png, m)?,
        wrap_pyfunction!(io::srgb8, m)?,
        wrap_pyfunction!(io::read_png, m)?,
        wrap_pyfunction!(io::default_max_pixels, m)?,
        wrap_pyfunction!(special::lobe, m)?,
        wrap_pyfunction!(special::i0e, m)?,
        wrap_pyfunction!(special::log_i0, m)?,
        wrap_pyfunction!(special::num_threads, m)?,
        wrap_pyfunction!(special::set_single_threaded, m)?,
        wrap_pyfunction!(special::simd_level, m)?,
    ] {
        m.add_function(f)?;
    }
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SH_Y00", crate::lighting::Y00)?;
    Ok(())
}
