//! hairshade: hair fiber BSDFs and a CPU hair renderer, validated against
//! Mitsuba 3.
//!
//! Layers, each depending only on those above it:
//!
//! - [`math`], [`simd`], [`lighting`]: special functions and quadrature,
//!   f32 vector lanes, spherical harmonics;
//! - [`fiber`]: scattering models (Chiang 2016 near/far field, d'Eon /
//!   UE's reference, Karis / UE's real-time model), generic over
//!   `f32` / `f64`, in Mitsuba's hair frame, with their vector kernels;
//! - [`threads`] and [`batch`]: the thread pool, and parallel evaluation
//!   over flat `(N, 3)` arrays; [`lru`]: what is kept between calls;
//! - [`raster`] and [`image_io`]: the software rasterizer, images in and out.
//!
//! The Python extension (`hairshade._native`, cargo feature `python`) is a
//! thin layer over these modules; nothing here depends on Python.

pub mod alloc;
pub mod batch;
pub mod fiber;
pub mod image_io;
pub mod lighting;
pub mod lru;
pub mod math;
pub mod raster;
pub mod simd;
pub mod threads;

#[cfg(feature = "python")]
mod python;
