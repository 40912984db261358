//! The scene from Python: the dict of flat arrays that
//! `python/hairshade/render.py` builds (strands, cards and the fibers baked
//! cards stand for, opaque triangles and spheres, lights, camera, model),
//! checked and turned into a [`Scene`].

use super::convert::{slice, without_gil};
use super::models::{PyChiangHair, PyDEonHair, PyKarisHair};
use super::render::err;
use crate::raster::scene::{
    AlphaTexture, Camera, Cards, Environment, HairShading, Light, OpaqueTri, RenderOptions, Scene,
    Sphere, Strands,
};
use glam::Vec3;
use numpy::PyReadonlyArray1;
use pyo3::prelude::*;

type CameraArgs = ([f32; 3], [f32; 3], [f32; 3], f32, u32, u32);
type LightArgs = (String, [f32; 3], [f32; 3], bool);
type SphereArgs = ([f32; 3], f32, [f32; 3]);

/// Cards as flat arrays: corners (Q·4·3), UVs (Q·4·2), tangents (Q·3), a
/// texture index per quad, the textures (width, height, alpha), and the
/// fibers baked cards stand for (points, radii, offsets; or None).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct CardArgs<'py> {
    corners: PyReadonlyArray1<'py, f32>,
    uvs: PyReadonlyArray1<'py, f32>,
    tangents: PyReadonlyArray1<'py, f32>,
    texture: PyReadonlyArray1<'py, u32>,
    textures: Vec<(u32, u32, PyReadonlyArray1<'py, f32>)>,
    fibers: Option<StrandArgs<'py>>,
}

/// Strands as flat arrays: points (V·3), radii (V), offsets (S + 1).
#[derive(FromPyObject)]
pub struct StrandArgs<'py>(
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, u32>,
);

/// Opaque triangles as a tuple of flat arrays: positions (T·9), albedos
/// (T·3) and the mesh each belongs to.
#[derive(FromPyObject)]
pub struct TriangleArgs<'py>(
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, f32>,
    PyReadonlyArray1<'py, u32>,
);

/// The scene as `hairshade.render` passes it.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct SceneArgs<'py> {
    camera: CameraArgs,
    lights: Vec<LightArgs>,
    environment: Option<Vec<f32>>,
    points: PyReadonlyArray1<'py, f32>,
    radii: PyReadonlyArray1<'py, f32>,
    offsets: PyReadonlyArray1<'py, u32>,
    spheres: Vec<SphereArgs>,
    hair: Bound<'py, PyAny>,
    cards: Option<CardArgs<'py>>,
    triangles: Option<TriangleArgs<'py>>,
}

fn build_cards(cards: Option<CardArgs<'_>>) -> PyResult<Cards> {
    let Some(a) = cards else {
        return Ok(Cards::default());
    };
    let (c, u, t, ti) = (
        slice(&a.corners, "cards")?,
        slice(&a.uvs, "cards")?,
        slice(&a.tangents, "cards")?,
        slice(&a.texture, "cards")?,
    );
    let q = ti.len();
    if c.len() != 12 * q || u.len() != 8 * q || t.len() != 3 * q {
        return Err(err(
            "cards",
            format!("inconsistent array lengths for {q} quads"),
        ));
    }
    let mut tex = Vec::with_capacity(a.textures.len());
    for (k, (w, h, alpha)) in a.textures.iter().enumerate() {
        let alpha = slice(alpha, "cards")?;
        if *w == 0
            || *h == 0
            || alpha.len() != (*w as usize) * (*h as usize)
            || alpha.iter().any(|x| !x.is_finite())
        {
            return Err(err(
                "cards",
                format!("texture {k} must hold {w}x{h} finite values"),
            ));
        }
        tex.push(AlphaTexture {
            width: *w,
            height: *h,
            alpha: alpha.to_vec(),
        });
    }
    if ti.iter().any(|&i| i as usize >= tex.len()) {
        return Err(err("cards", "texture index out of range"));
    }
    let fibers = match &a.fibers {
        None => Strands::default(),
        Some(StrandArgs(p, r, o)) => build_strands(
            slice(p, "cards.fibers")?,
            slice(r, "cards.fibers")?,
            slice(o, "cards.fibers")?,
            ("cards.fibers", "cards.fibers offsets"),
        )?,
    };
    Ok(Cards {
        fibers,
        corners: c.chunks_exact(3).map(Vec3::from_slice).collect(),
        uvs: u.chunks_exact(2).map(|x| [x[0], x[1]]).collect(),
        tangents: t.chunks_exact(3).map(Vec3::from_slice).collect(),
        texture: ti.to_vec(),
        textures: tex,
    })
}

fn build_triangles(triangles: Option<TriangleArgs<'_>>) -> PyResult<Vec<OpaqueTri>> {
    let Some(a) = triangles else {
        return Ok(Vec::new());
    };
    let (p, al, m) = (
        slice(&a.0, "triangles")?,
        slice(&a.1, "triangles")?,
        slice(&a.2, "triangles")?,
    );
    if p.len() != 3 * al.len() || al.len() % 3 != 0 || 3 * m.len() != al.len() {
        return Err(err(
            "triangles",
            "expected 9 position, 3 albedo values and a mesh index per triangle",
        ));
    }
    Ok((0..m.len())
        .map(|t| OpaqueTri {
            p: std::array::from_fn(|k| Vec3::from_slice(&p[9 * t + 3 * k..])),
            albedo: Vec3::from_slice(&al[3 * t..]),
            mesh: m[t],
        })
        .collect())
}

/// Strands from flat points, radii and offsets; `names` name the arrays
/// in errors: (points and radii, offsets).
fn build_strands(pts: &[f32], rad: &[f32], off: &[u32], names: (&str, &str)) -> PyResult<Strands> {
    if pts.len() != 3 * rad.len() {
        return Err(err(
            names.0,
            format!("{} points but {} radii", pts.len() / 3, rad.len()),
        ));
    }
    if off.is_empty()
        || off[0] != 0
        || off.windows(2).any(|w| w[1] < w[0])
        || *off.last().unwrap() as usize != rad.len()
    {
        return Err(err(
            names.1,
            "must start at 0, not decrease, and end at the number of points",
        ));
    }
    Ok(Strands {
        points: pts.chunks_exact(3).map(Vec3::from_slice).collect(),
        radii: rad.to_vec(),
        offsets: off.to_vec(),
    })
}

pub(super) fn build_scene(a: SceneArgs<'_>) -> PyResult<Scene> {
    let strands = build_strands(
        slice(&a.points, "points")?,
        slice(&a.radii, "radii")?,
        slice(&a.offsets, "offsets")?,
        ("points, radii", "offsets"),
    )?;
    let cam = a.camera;
    let max = RenderOptions::MAX_RESOLUTION;
    if cam.4 == 0 || cam.5 == 0 || cam.4 > max || cam.5 > max {
        return Err(err(
            "resolution",
            format!("must be in [1, {max}], got {}x{}", cam.4, cam.5),
        ));
    }
    let hair = if let Ok(k) = a.hair.cast::<PyKarisHair>() {
        HairShading::Karis(k.get().m32.clone())
    } else if let Ok(c) = a.hair.cast::<PyChiangHair>() {
        let c = c.get();
        HairShading::ChiangFar(without_gil(a.hair.py(), || c.table()))
    } else if let Ok(d) = a.hair.cast::<PyDEonHair>() {
        HairShading::DEon(Box::new(d.get().m32.clone()))
    } else {
        return Err(err(
            "hair",
            "expected a KarisHair, ChiangHair or DEonHair model",
        ));
    };
    let mut lights = Vec::with_capacity(a.lights.len());
    for (kind, v, i, shadows) in a.lights {
        lights.push(match kind.as_str() {
            "directional" => Light::Directional {
                direction: Vec3::from(v).normalize_or(Vec3::Z),
                intensity: Vec3::from(i),
                shadows,
            },
            "point" => Light::Point {
                position: Vec3::from(v),
                intensity: Vec3::from(i),
                shadows,
            },
            other => return Err(err("lights", format!("unknown light type {other:?}"))),
        });
    }
    let environment = match a.environment {
        None => None,
        Some(c) if c.len() == 27 => Some(Environment {
            sh: std::array::from_fn(|k| [c[3 * k], c[3 * k + 1], c[3 * k + 2]]),
        }),
        Some(c) => {
            return Err(err(
                "environment",
                format!("expected 27 SH values, got {}", c.len()),
            ))
        }
    };
    Ok(Scene {
        camera: Camera {
            position: cam.0.into(),
            target: cam.1.into(),
            up: cam.2.into(),
            fov_y: cam.3,
            width: cam.4,
            height: cam.5,
        },
        lights,
        environment,
        strands,
        cards: build_cards(a.cards)?,
        triangles: build_triangles(a.triangles)?,
        spheres: a
            .spheres
            .into_iter()
            .map(|(c, r, al)| Sphere {
                center: c.into(),
                radius: r,
                albedo: al.into(),
            })
            .collect(),
        hair,
    })
}
