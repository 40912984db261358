//! The rasterizer from Python: the scene arrives as one dict of flat arrays
//! (built by `python/hairshade/render.py`, checked in [`super::scene_args`]),
//! the settings as one dict of render options, read and range-checked here ([`read_options`]: the only
//! place the ranges are checked; scene files are checked through
//! [`render_options`] when they load).

use super::convert::{run_polling, to_numpy};
use super::scene_args::{build_scene, SceneArgs};
use crate::fiber::number_text;
use crate::raster::guides::{GuideChoice, GuideTerms, Guides};
use crate::raster::lod::Lod;
use crate::raster::pack::LayerFormat;
use crate::raster::scene::{
    Backscatter, MultipleScattering, RenderOptions, Transparency, VolumeDirections, VolumeTransport,
};
use crate::raster::shadow::ShadowModel;
use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

pub(super) fn err(key: &str, msg: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(format!("{key}: {msg}"))
}

/// Reads settings from a dict, each by name with a default, and checks
/// that no unknown key is left.
struct OptionReader<'a, 'py> {
    d: &'a Bound<'py, PyDict>,
    known: Vec<&'static str>,
}

impl<'py> OptionReader<'_, 'py> {
    fn get(&mut self, key: &'static str) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.known.push(key);
        self.d.get_item(key)
    }

    /// A real number (not a bool, not a string), finite also as the f32
    /// the renderer uses, in `[lo, hi]`.
    fn num(&mut self, key: &'static str, default: f64) -> PyResult<f64> {
        let (lo, hi) = range(key);
        let Some(v) = self.get(key)? else {
            return Ok(default);
        };
        let x =
            number(&v).ok_or_else(|| err(key, format!("expected a number, got {}", repr(&v))))?;
        if !(x.is_finite() && (x as f32).is_finite()) {
            return Err(err(
                key,
                format!("must be finite (as a float32), got {}", number_text(x)),
            ));
        }
        if !(lo..=hi).contains(&x) {
            return Err(err(
                key,
                format!(
                    "must be in [{}, {}], got {}",
                    number_text(lo),
                    number_text(hi),
                    number_text(x)
                ),
            ));
        }
        Ok(x)
    }

    /// An integer in `[lo, hi]` (a float with an integral value is accepted).
    fn int(&mut self, key: &'static str, default: i64) -> PyResult<i64> {
        let (lo, hi) = range(key);
        let x = self.num(key, default as f64)?;
        if x.fract() != 0.0 {
            return Err(err(
                key,
                format!(
                    "must be an integer in [{}, {}], got {}",
                    number_text(lo),
                    number_text(hi),
                    number_text(x)
                ),
            ));
        }
        Ok(x as i64)
    }

    fn flag(&mut self, key: &'static str, default: bool) -> PyResult<bool> {
        match self.get(key)? {
            None => Ok(default),
            Some(v) if v.is_instance_of::<PyBool>() => v.extract(),
            Some(v) => Err(err(
                key,
                format!("expected true or false, got {}", repr(&v)),
            )),
        }
    }

    fn choice(
        &mut self,
        key: &'static str,
        default: &'static str,
        allowed: &[&'static str],
    ) -> PyResult<&'static str> {
        let Some(v) = self.get(key)? else {
            return Ok(default);
        };
        let s: Option<String> = v
            .is_instance_of::<PyString>()
            .then(|| v.extract())
            .transpose()?;
        match s.and_then(|s| allowed.iter().find(|a| **a == s)) {
            Some(a) => Ok(a),
            None => Err(err(
                key,
                format!(
                    "expected {}, got {}",
                    allowed
                        .iter()
                        .map(|a| format!("'{a}'"))
                        .collect::<Vec<_>>()
                        .join(" or "),
                    repr(&v)
                ),
            )),
        }
    }

    /// Three numbers, each finite (as f32) and >= 0.
    fn rgb(&mut self, key: &'static str, default: [f32; 3]) -> PyResult<[f32; 3]> {
        let Some(v) = self.get(key)? else {
            return Ok(default);
        };
        let items: Option<Vec<f64>> = v
            .try_iter()
            .ok()
            .and_then(|it| it.map(|x| x.ok().and_then(|x| number(&x))).collect());
        match items {
            Some(c) if c.len() == 3 && c.iter().all(|x| (*x as f32).is_finite() && *x >= 0.0) => {
                Ok([c[0] as f32, c[1] as f32, c[2] as f32])
            }
            _ => Err(err(
                key,
                format!("expected 3 finite numbers >= 0, got {}", repr(&v)),
            )),
        }
    }

    /// `"auto"` or a number in (0, 1]: the strand level of detail.
    fn lod(&mut self, key: &'static str) -> PyResult<Lod> {
        let Some(v) = self.get(key)? else {
            return Ok(Lod::default());
        };
        if v.is_instance_of::<PyString>() && v.extract::<String>()? == "auto" {
            return Ok(Lod::Auto);
        }
        match unit_fraction(&v) {
            Some(x) => Ok(Lod::Fraction(x)),
            None => Err(err(
                key,
                format!(
                    "expected 'auto' or a fraction of the strands in (0, 1], got {}",
                    repr(&v)
                ),
            )),
        }
    }

    /// A number in (0, 1] (default 1): a fraction of the strands; 1 where
    /// the key holds strand indices ([`Self::strand_list`]).
    fn fraction(&mut self, key: &'static str) -> PyResult<f32> {
        let Some(v) = self.get(key)? else {
            return Ok(1.0);
        };
        if !v.is_instance_of::<PyString>() && number(&v).is_none() && v.try_iter().is_ok() {
            return Ok(1.0);
        }
        match unit_fraction(&v) {
            Some(x) => Ok(x),
            None => Err(err(
                key,
                format!(
                    "expected a fraction of the strands in (0, 1], got {}",
                    repr(&v)
                ),
            )),
        }
    }

    /// Strand indices (a sequence of integers, each in [0, 2^32)), or None
    /// where the key is absent or holds something else (a number).
    fn strand_list(&mut self, key: &'static str) -> PyResult<Option<Arc<[u32]>>> {
        let Some(v) = self.get(key)? else {
            return Ok(None);
        };
        if v.is_instance_of::<PyString>() || number(&v).is_some() {
            return Ok(None);
        }
        let Ok(items) = v.try_iter() else {
            return Ok(None);
        };
        let mut out = Vec::new();
        for x in items {
            let x = x?;
            let i = (!x.is_instance_of::<PyBool>())
                .then(|| x.extract::<i64>().ok())
                .flatten()
                .filter(|i| (0..1i64 << 32).contains(i));
            match i {
                Some(i) => out.push(i as u32),
                None => {
                    return Err(err(
                        key,
                        format!(
                            "expected a fraction of the strands in (0, 1] or strand indices (integers >= 0), \
                             got the item {}",
                            repr(&x)
                        ),
                    ))
                }
            }
        }
        if out.is_empty() {
            return Err(err(key, "expected at least one strand index, got none"));
        }
        Ok(Some(out.into()))
    }

    /// A `ValueError` naming the first key that was not read.
    fn finish(self) -> PyResult<()> {
        for k in self.d.keys() {
            let name: String = k.str()?.extract()?;
            if !self.known.contains(&name.as_str()) {
                let mut known = self.known.clone();
                known.sort();
                return Err(err(
                    &name,
                    format!("unknown render option (allowed: {})", known.join(", ")),
                ));
            }
        }
        Ok(())
    }
}

/// A number in (0, 1] that stays above 0 in f32, as f32 (a fraction of the
/// strands: `lod`, `guides`).
fn unit_fraction(v: &Bound<'_, PyAny>) -> Option<f32> {
    number(v)
        .filter(|&x| x > 0.0 && x <= 1.0 && (x as f32) > 0.0)
        .map(|x| x as f32)
}

/// A Python int or float as f64 (None for bools, strings and the rest).
fn number(v: &Bound<'_, PyAny>) -> Option<f64> {
    if v.is_instance_of::<PyBool>() {
        return None;
    }
    if v.is_instance_of::<PyInt>() || v.is_instance_of::<PyFloat>() {
        return v.extract::<f64>().ok();
    }
    // numpy's scalars (np.int64(8), np.float32(0.5)) and other `numbers.Real`
    let real = v
        .py()
        .import("numbers")
        .and_then(|m| m.getattr("Real"))
        .ok()?;
    if v.is_instance(&real).ok()? {
        return v.call_method0("__float__").ok()?.extract::<f64>().ok();
    }
    None
}

fn repr(v: &Bound<'_, PyAny>) -> String {
    v.repr()
        .map(|r| r.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// The inclusive range of each numeric render option: the one table
/// [`read_options`] checks against and `render_option_ranges` reports.
fn range(key: &str) -> (f64, f64) {
    let int = |(lo, hi): (usize, usize)| (lo as f64, hi as f64);
    match key {
        "layers" => int(RenderOptions::LAYERS),
        "samples" => int(crate::raster::samples::SAMPLES),
        "shadow_map_size" => {
            let (lo, hi) = RenderOptions::SHADOW_MAP_SIZE;
            (lo as f64, hi as f64)
        }
        "pcf_radius" => {
            let (lo, hi) = RenderOptions::PCF_RADIUS;
            (lo as f64, hi as f64)
        }
        "density_resolution" => int(RenderOptions::DENSITY_RESOLUTION),
        "environment_directions" => int(crate::raster::env_light::DIRECTIONS_RANGE),
        "dual_forward_density" | "dual_back_density" | "hair_cull_transmittance" => (0.0, 1.0),
        "lod" | "guides" => (0.0, 1.0),
        "volume_resolution" => int(crate::raster::volume::RESOLUTION),
        "volume_photons" => int(crate::raster::volume::PHOTONS),
        "volume_bins" => int(crate::raster::volume::BINS),
        // shadow_density, light_cull_threshold
        _ => (0.0, f64::MAX),
    }
}

/// The numeric render options' ranges: name -> (lowest, highest), both
/// inclusive (`lod` and `guides` exclude 0; `f64::MAX` stands for no
/// bound).
#[pyfunction]
pub fn render_option_ranges(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    for key in [
        "layers",
        "samples",
        "shadow_map_size",
        "pcf_radius",
        "shadow_density",
        "density_resolution",
        "environment_directions",
        "dual_forward_density",
        "dual_back_density",
        "hair_cull_transmittance",
        "light_cull_threshold",
        "lod",
        "guides",
        "volume_resolution",
        "volume_photons",
        "volume_bins",
    ] {
        d.set_item(key, range(key))?;
    }
    Ok(d)
}

/// The render options a dict describes (defaults for missing keys), every
/// value checked against its type and range, and the MLAB layer count
/// (kept also when the transparency is `sorted`).
fn read_options(d: &Bound<'_, PyDict>) -> PyResult<(RenderOptions, (usize, usize))> {
    let def = RenderOptions::default();
    let mut r = OptionReader {
        d,
        known: Vec::new(),
    };
    let transparency = r.choice("transparency", "mlab", &["mlab", "sorted", "coverage"])?;
    let samples = r.int("samples", 16)? as usize;
    let multiple_scattering = match r.choice(
        "multiple_scattering",
        "auto",
        &["auto", "none", "karis", "dual", "volume"],
    )? {
        "volume" => Some(MultipleScattering::Volume),
        "none" => Some(MultipleScattering::None),
        "karis" => Some(MultipleScattering::Karis),
        "dual" => Some(MultipleScattering::Dual),
        _ => None,
    };
    let layers = r.int("layers", 4)? as usize;
    let layer_format = match r.choice("layer_format", "f32", &["f32", "r11g11b10", "rgb9e5"])? {
        "r11g11b10" => LayerFormat::R11G11B10,
        "rgb9e5" => LayerFormat::Rgb9e5,
        _ => LayerFormat::F32,
    };
    let shading = r.choice("shading", "pixel", &["pixel", "split", "vertex"])?;
    let opts = RenderOptions {
        transparency: match transparency {
            "sorted" => Transparency::Sorted,
            "coverage" => Transparency::Coverage(samples),
            _ => Transparency::Mlab(layers),
        },
        shadow_map_size: r.int("shadow_map_size", def.shadow_map_size as i64)? as u32,
        shadow_model: match r.choice(
            "shadow_model",
            "exponential",
            &["exponential", "opacity", "density", "traced"],
        )? {
            "opacity" => ShadowModel::Opacity,
            "density" => ShadowModel::Density,
            "traced" => ShadowModel::Traced,
            _ => ShadowModel::Exponential,
        },
        shadow_density: r.num("shadow_density", def.shadow_density as f64)? as f32,
        pcf_radius: r.int("pcf_radius", def.pcf_radius as i64)? as i32,
        background: r.rgb("background", def.background.to_array())?.into(),
        vertex_shading: shading == "vertex",
        split_shading: shading == "split",
        frustum_culling: r.flag("frustum_culling", def.frustum_culling)?,
        backface_culling: r.flag("backface_culling", def.backface_culling)?,
        opaque_culling: r.flag("opaque_culling", def.opaque_culling)?,
        vertices_on_demand: r.flag("vertices_on_demand", def.vertices_on_demand)?,
        nearest_first: r.flag("nearest_first", def.nearest_first)?,
        skip_unused: r.flag("skip_unused", def.skip_unused)?,
        reuse_shadow_maps: r.flag("reuse_shadow_maps", def.reuse_shadow_maps)?,
        light_cull_threshold: r.num("light_cull_threshold", def.light_cull_threshold as f64)?
            as f32,
        density_resolution: r.int("density_resolution", def.density_resolution as i64)? as usize,
        multiple_scattering,
        dual_forward_density: r.num("dual_forward_density", def.dual_forward_density as f64)?
            as f32,
        dual_back_density: r.num("dual_back_density", def.dual_back_density as f64)? as f32,
        dual_backscatter: match r.choice("dual_backscatter", "local", &["local", "two_stream"])? {
            "two_stream" => Backscatter::TwoStream,
            _ => Backscatter::Local,
        },
        volume_resolution: r.int("volume_resolution", def.volume_resolution as i64)? as usize,
        volume_photons: r.int("volume_photons", def.volume_photons as i64)? as usize,
        volume_bins: r.int("volume_bins", def.volume_bins as i64)? as usize,
        volume_transport: match r.choice("volume_transport", "strands", &["medium", "strands"])? {
            "medium" => VolumeTransport::Medium,
            _ => VolumeTransport::Strands,
        },
        volume_directions: match r.choice("volume_directions", "mean", &["mean", "centre"])? {
            "centre" => VolumeDirections::Centre,
            _ => VolumeDirections::Mean,
        },
        sphere_bounce: r.flag("sphere_bounce", def.sphere_bounce)?,
        near_field: r.flag("near_field", def.near_field)?,
        traced_own_strand_passes: r.choice(
            "traced_own_strand",
            "shadows",
            &["shadows", "passes"],
        )? == "passes",
        traced_vertices: r.flag("traced_vertices", def.traced_vertices)?,
        environment_directions: r
            .int("environment_directions", def.environment_directions as i64)?
            as usize,
        lod: r.lod("lod")?,
        guides: Guides {
            given: r.strand_list("guides")?,
            fraction: r.fraction("guides")?,
            choice: match r.choice("guide_choice", "every", &["every", "clusters"])? {
                "clusters" => GuideChoice::Clusters,
                _ => GuideChoice::Every,
            },
            terms: match r.choice("guide_terms", "scattered", &["scattered", "all"])? {
                "all" => GuideTerms::All,
                _ => GuideTerms::Scattered,
            },
        },
        hair_cull_transmittance: r.num(
            "hair_cull_transmittance",
            def.hair_cull_transmittance as f64,
        )? as f32,
        layer_format,
    };
    r.finish()?;
    Ok((opts, (layers, samples)))
}

/// The render options as a dict with every key (the form
/// [`read_options`] reads back).
fn options_dict<'py>(
    py: Python<'py>,
    o: &RenderOptions,
    (layers, samples): (usize, usize),
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let transparency = match o.transparency {
        Transparency::Mlab(_) => "mlab",
        Transparency::Sorted => "sorted",
        Transparency::Coverage(_) => "coverage",
    };
    d.set_item("transparency", transparency)?;
    d.set_item("layers", layers)?;
    d.set_item("samples", samples)?;
    d.set_item("shadow_map_size", o.shadow_map_size)?;
    d.set_item(
        "shadow_model",
        match o.shadow_model {
            ShadowModel::Opacity => "opacity",
            ShadowModel::Exponential => "exponential",
            ShadowModel::Density => "density",
            ShadowModel::Traced => "traced",
        },
    )?;
    d.set_item("shadow_density", o.shadow_density as f64)?;
    d.set_item("pcf_radius", o.pcf_radius)?;
    d.set_item("background", o.background.to_array().map(|x| x as f64))?;
    let shading = match (o.vertex_shading, o.split_shading) {
        (true, _) => "vertex",
        (false, true) => "split",
        _ => "pixel",
    };
    d.set_item("shading", shading)?;
    d.set_item("frustum_culling", o.frustum_culling)?;
    d.set_item("backface_culling", o.backface_culling)?;
    d.set_item("opaque_culling", o.opaque_culling)?;
    d.set_item("vertices_on_demand", o.vertices_on_demand)?;
    d.set_item("nearest_first", o.nearest_first)?;
    d.set_item("skip_unused", o.skip_unused)?;
    d.set_item("reuse_shadow_maps", o.reuse_shadow_maps)?;
    d.set_item("light_cull_threshold", o.light_cull_threshold as f64)?;
    d.set_item("density_resolution", o.density_resolution)?;
    d.set_item(
        "multiple_scattering",
        match o.multiple_scattering {
            None => "auto",
            Some(MultipleScattering::None) => "none",
            Some(MultipleScattering::Karis) => "karis",
            Some(MultipleScattering::Dual) => "dual",
            Some(MultipleScattering::Volume) => "volume",
        },
    )?;
    d.set_item("dual_forward_density", o.dual_forward_density as f64)?;
    d.set_item("dual_back_density", o.dual_back_density as f64)?;
    d.set_item(
        "dual_backscatter",
        match o.dual_backscatter {
            Backscatter::Local => "local",
            Backscatter::TwoStream => "two_stream",
        },
    )?;
    d.set_item("volume_resolution", o.volume_resolution)?;
    d.set_item("volume_photons", o.volume_photons)?;
    d.set_item("volume_bins", o.volume_bins)?;
    d.set_item(
        "volume_transport",
        match o.volume_transport {
            VolumeTransport::Medium => "medium",
            VolumeTransport::Strands => "strands",
        },
    )?;
    d.set_item(
        "volume_directions",
        match o.volume_directions {
            VolumeDirections::Mean => "mean",
            VolumeDirections::Centre => "centre",
        },
    )?;
    d.set_item("sphere_bounce", o.sphere_bounce)?;
    d.set_item("near_field", o.near_field)?;
    d.set_item(
        "traced_own_strand",
        if o.traced_own_strand_passes {
            "passes"
        } else {
            "shadows"
        },
    )?;
    d.set_item("traced_vertices", o.traced_vertices)?;
    d.set_item("environment_directions", o.environment_directions)?;
    d.set_item("hair_cull_transmittance", o.hair_cull_transmittance as f64)?;
    d.set_item(
        "layer_format",
        match o.layer_format {
            LayerFormat::F32 => "f32",
            LayerFormat::R11G11B10 => "r11g11b10",
            LayerFormat::Rgb9e5 => "rgb9e5",
        },
    )?;
    match o.lod {
        Lod::Auto => d.set_item("lod", "auto")?,
        Lod::Fraction(f) => d.set_item("lod", f as f64)?,
    }
    match &o.guides.given {
        Some(g) => d.set_item("guides", g.to_vec())?,
        None => d.set_item("guides", o.guides.fraction as f64)?,
    }
    d.set_item(
        "guide_choice",
        match o.guides.choice {
            GuideChoice::Every => "every",
            GuideChoice::Clusters => "clusters",
        },
    )?;
    d.set_item(
        "guide_terms",
        match o.guides.terms {
            GuideTerms::All => "all",
            GuideTerms::Scattered => "scattered",
        },
    )?;
    Ok(d)
}

/// Checks render options (a scene file's `render` section, or the
/// settings of a render) and returns them complete, defaults filled in.
/// Raises `ValueError` naming the option.
#[pyfunction]
pub fn render_options<'py>(options: &Bound<'py, PyDict>) -> PyResult<Bound<'py, PyDict>> {
    let (o, layers) = read_options(options)?;
    options_dict(options.py(), &o, layers)
}

/// Renders a scene (see `hairshade.render`): `scene` is a dict of flat
/// arrays, `options` the render options (see [`render_options`]). Returns
/// (image as a flat float32 array, stats dict). `progress`, when given, is
/// called with (tiles done, tiles total) about 20 times a second; Ctrl-C
/// stops the render and raises KeyboardInterrupt.
#[pyfunction]
#[pyo3(signature = (scene, options, progress=None))]
pub fn render<'py>(
    py: Python<'py>,
    scene: SceneArgs<'py>,
    options: &Bound<'py, PyDict>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
    let scene = build_scene(scene)?;
    let (opts, _) = read_options(options)?;
    crate::raster::methods::Methods::check(&scene, &opts).map_err(|e| err(e.option, e.message))?;
    let memory = crate::raster::memory::estimate(&scene, &opts);
    if let Some(available) = crate::raster::memory::available_bytes() {
        if memory.total() > available {
            let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
            let items: Vec<String> = memory
                .items
                .iter()
                .filter(|i| i.1 > 0)
                .map(|(what, b)| format!("{what} {:.2} GiB", gib(*b)))
                .collect();
            return Err(PyMemoryError::new_err(format!(
                "render: needs about {:.2} GiB ({}), more than the {:.2} GiB available; \
                 lower the resolution, shadow_map_size or density_resolution",
                gib(memory.total()),
                items.join(", "),
                gib(available)
            )));
        }
    }
    // The estimate reserved at once and released: address space the system
    // will not give (an RLIMIT_AS cap, overcommit refused) is a MemoryError
    // here rather than an abort part-way through the render.
    if Vec::<u8>::new()
        .try_reserve_exact(memory.total() as usize)
        .is_err()
    {
        return Err(PyMemoryError::new_err(format!(
            "render: cannot reserve the {} bytes it needs (largest part: {} {} bytes)",
            memory.total(),
            memory.largest().0,
            memory.largest().1
        )));
    }
    let total = crate::raster::progress_total(&scene, &opts);
    let (done, cancel) = (AtomicUsize::new(0), AtomicBool::new(false));
    let result = run_polling(
        py,
        || crate::raster::render_with_progress(&scene, &opts, &done, &cancel),
        || {
            py.check_signals()?;
            if let Some(cb) = &progress {
                cb.call1((done.load(Ordering::Relaxed), total))?;
            }
            Ok(())
        },
        || cancel.store(true, Ordering::Relaxed),
    )?;
    let (image, stats) = result.ok_or_else(|| PyKeyboardInterrupt::new_err("render cancelled"))?;
    let d = PyDict::new(py);
    d.set_item("segments", stats.segments)?;
    d.set_item("segments_visible", stats.segments_visible)?;
    d.set_item("vertices_shaded", stats.vertices_shaded)?;
    d.set_item("backfaces_culled", stats.backfaces_culled)?;
    d.set_item("fragments", stats.fragments)?;
    d.set_item("non_finite_pixels", stats.non_finite_pixels)?;
    d.set_item("culled_behind_opaque", stats.culled_behind_opaque)?;
    d.set_item("culled_behind_hair", stats.culled_behind_hair)?;
    d.set_item("lights_culled", stats.lights_culled)?;
    d.set_item("light_cull_max_skipped", stats.light_cull_max_skipped)?;
    d.set_item("shadow_ms", stats.shadow_ms)?;
    d.set_item("shadow_maps_reused", stats.shadow_maps_reused)?;
    d.set_item("volume_ms", stats.volume_ms)?;
    d.set_item("volume_reused", stats.volume_reused)?;
    d.set_item("lighting_reused", stats.lighting_reused)?;
    d.set_item("volume_voxels", stats.volume_voxels)?;
    d.set_item("volume_transmittance", stats.volume_transmittance)?;
    d.set_item("shadow_maps_skipped", stats.shadow_maps_skipped)?;
    d.set_item("lod_fraction", stats.lod_fraction as f64)?;
    d.set_item("lod_overlap", stats.lod_overlap.map(|x| x as f64))?;
    d.set_item("strands_drawn", stats.strands_drawn)?;
    d.set_item("guide_strands", stats.guide_strands)?;
    d.set_item("guides_ms", stats.guides_ms)?;
    d.set_item("vertex_ms", stats.vertex_ms)?;
    d.set_item("setup_ms", stats.setup_ms)?;
    d.set_item("tiles_ms", stats.tiles_ms)?;
    d.set_item("tiles_busy_ms", stats.tiles_busy_ms)?;
    d.set_item("total_ms", stats.total_ms)?;
    d.set_item("memory_estimate", memory.total())?;
    Ok((to_numpy(py, image.data), d))
}
