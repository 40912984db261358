//! hairshade: hair fiber BSDFs and a CPU hair renderer, validated against
//! Mitsuba 3.
//!
//! - [`fiber`]: scattering models (Chiang 2016 near/far field), generic over
//!   `f32` / `f64`, in Mitsuba's hair frame.
//! - [`batch`]: parallel evaluation over flat `(N, 3)` arrays.
//! - [`math`]: the special functions and quadrature the models share.
//!
//! The Python extension (`hairshade._native`, cargo feature `python`) is a
//! thin layer over these modules; nothing here depends on Python.

pub mod batch;
pub mod fiber;
pub mod image_io;
pub mod lighting;
pub mod math;
pub mod raster;
pub mod simd;

#[cfg(feature = "python")]
mod python;
