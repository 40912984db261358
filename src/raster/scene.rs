//! The renderer's scene: camera, lights, hair strands, opaque spheres and
//! the hair material. Built (and validated) from the JSON scene format by
//! `python/hairshade/scene.py`; the Rust types assume valid input and
//! guard only against what would panic or poison an image.

use crate::fiber::chiang::ChiangFarTable;
use crate::fiber::deon::DEonHair;
use crate::fiber::karis::KarisHair;
use glam::Vec3;

/// A pinhole camera.
#[derive(Debug, Clone)]
pub struct Camera {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y: f32,
    pub width: u32,
    pub height: u32,
}

/// A light source with RGB intensity.
#[derive(Debug, Clone)]
pub enum Light {
    /// Light arriving along `-direction` (direction points towards the light),
    /// `intensity` is the irradiance on a surface facing it.
    Directional {
        direction: Vec3,
        intensity: Vec3,
        shadows: bool,
    },
    /// Isotropic point light; `intensity` in W/sr (falls off as 1/d²).
    Point {
        position: Vec3,
        intensity: Vec3,
        shadows: bool,
    },
}

impl Light {
    /// `(unit direction towards the light, irradiance)` at point `p`.
    #[inline]
    pub fn incident(&self, p: Vec3) -> (Vec3, Vec3) {
        match *self {
            Light::Directional {
                direction,
                intensity,
                ..
            } => (direction, intensity),
            Light::Point {
                position,
                intensity,
                ..
            } => {
                let d = position - p;
                let r2 = d.length_squared().max(1e-12);
                (d / r2.sqrt(), intensity / r2)
            }
        }
    }

    /// Distance from `p` to the light (infinite for a directional light).
    #[inline]
    pub fn distance(&self, p: Vec3) -> f32 {
        match *self {
            Light::Directional { .. } => f32::INFINITY,
            Light::Point { position, .. } => (position - p).length(),
        }
    }
}

/// Band-2 SH environment radiance (9 RGB coefficients).
#[derive(Debug, Clone)]
pub struct Environment {
    pub sh: [[f32; 3]; 9],
}

/// Hair as polylines with per-vertex radius.
#[derive(Debug, Clone, Default)]
pub struct Strands {
    pub points: Vec<Vec3>,
    pub radii: Vec<f32>,
    /// `offsets[s]..offsets[s+1]` are strand `s`'s vertices.
    pub offsets: Vec<u32>,
}

impl Strands {
    pub fn strand_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
}

/// A grayscale alpha texture (row-major, v down the rows).
#[derive(Debug, Clone)]
pub struct AlphaTexture {
    pub width: u32,
    pub height: u32,
    pub alpha: Vec<f32>,
}

impl AlphaTexture {
    /// Bilinear sample at (u, v) in [0, 1]², clamped to the edge.
    #[inline]
    pub fn sample(&self, u: f32, v: f32) -> f32 {
        let x = (u.clamp(0.0, 1.0) * self.width as f32 - 0.5).max(0.0);
        let y = (v.clamp(0.0, 1.0) * self.height as f32 - 0.5).max(0.0);
        let (x0, y0) = (x as u32, y as u32);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let at = |xi: u32, yi: u32| self.alpha[(yi * self.width + xi) as usize];
        let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
        let bottom = at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// Hair cards: quads of ribbons along polylines, each with UVs (u across,
/// v along the fibers), the fiber tangent, and an alpha texture.
#[derive(Debug, Clone, Default)]
pub struct Cards {
    /// Corners, 4 per quad, in order around the quad.
    pub corners: Vec<Vec3>,
    /// UVs of the corners.
    pub uvs: Vec<[f32; 2]>,
    /// Fiber tangent of each quad.
    pub tangents: Vec<Vec3>,
    /// Alpha texture of each quad.
    pub texture: Vec<u32>,
    pub textures: Vec<AlphaTexture>,
    /// The fibers baked cards stand for, in world space (empty when the
    /// cards' alpha comes from images): never drawn, they give the cards
    /// their share of the fiber density grid ([`super::density`]).
    pub fibers: Strands,
}

impl Cards {
    pub fn quad_count(&self) -> usize {
        self.tangents.len()
    }
}

/// An opaque diffuse sphere.
#[derive(Debug, Clone)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    pub albedo: Vec3,
}

/// An opaque diffuse triangle (from OBJ meshes).
#[derive(Debug, Clone)]
pub struct OpaqueTri {
    pub p: [Vec3; 3],
    pub albedo: Vec3,
    /// The mesh it belongs to (back-face culling looks at whole meshes).
    pub mesh: u32,
}

/// How hair is shaded.
#[derive(Debug, Clone)]
pub enum HairShading {
    /// UE4 `HairShading()` (default).
    Karis(KarisHair<f32>),
    /// Chiang 2016 far field from its tables (for comparison with
    /// Mitsuba's `hair`).
    ChiangFar(std::sync::Arc<ChiangFarTable>),
    /// UE4 `HairShadingRef()` (slow: an N_p integral per lobe and fragment;
    /// use its `h_samples` mode for previews).
    DEon(Box<DEonHair<f32>>),
}

/// Light scattered between fibers (several fibers on its way).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MultipleScattering {
    /// Single scattering only.
    None,
    /// KarisHair's own term (its `MS` lobe: Karis 2016, UE4).
    Karis,
    /// Dual scattering through the fiber density grid ([`crate::fiber::dual`]).
    Dual,
    /// Light carried through the hair volume ([`super::volume`]).
    Volume,
}

/// Order-independent transparency.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transparency {
    /// Multi-Layer Alpha Blending with `k` layers.
    Mlab(usize),
    /// Every fragment kept and sorted: the exact result MLAB approximates.
    Sorted,
    /// Hair as opaque sub-pixel geometry: the nearest fragment per coverage
    /// sample, `n` samples per pixel ([`super::samples`]).
    Coverage(usize),
}

/// Renderer settings.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    pub transparency: Transparency,
    /// Shadow-map resolution (square).
    pub shadow_map_size: u32,
    /// How hair attenuates light in shadow maps.
    pub shadow_model: super::shadow::ShadowModel,
    /// Optical density of hair for the exponential shadow model:
    /// transmittance `exp(−density · depth behind the first hair)`.
    pub shadow_density: f32,
    /// Shadow-map PCF kernel radius in texels (0 = one tap).
    pub pcf_radius: i32,
    /// Background radiance.
    pub background: Vec3,
    /// Shade strands once per vertex and interpolate along segments
    /// (cards are always shaded per pixel).
    pub vertex_shading: bool,
    /// Shade strands per fragment with only each light's unscattered
    /// light (its shadow, the near field), and read the environment and
    /// the scattered light at the vertices, interpolated along segments
    /// (`shading = "split"`; see `shade/at_vertices.rs`).
    pub split_shading: bool,
    /// Frustum culling: drop strand segments that reach no tile before
    /// shading them (per-vertex shading then shades only the vertices of
    /// the remaining segments); exact: such segments are never binned.
    pub frustum_culling: bool,
    /// Back-face culling: skip the back-facing triangles of a mesh that is
    /// closed, consistently oriented outwards, seen from outside and wholly
    /// in front of the near plane (a back face of such a mesh is always
    /// behind one of its front faces); other meshes stay two-sided.
    pub backface_culling: bool,
    /// Skip hair behind a tile's farthest opaque surface (exact: such hair
    /// fails every pixel's depth test anyway).
    pub opaque_culling: bool,
    /// Per-vertex shading with MLAB or sorted transparency: shade a vertex
    /// when a tile first draws a fragment of a segment ending at it, not
    /// every vertex in view before the tiles (exact: the same radiance,
    /// bit for bit; `shade::VertexColors`).
    pub vertices_on_demand: bool,
    /// Coverage samples: each tile's strand segments drawn nearest first,
    /// and a pixel skipped for a segment where every sample already lies
    /// nearer than the segment can reach (exact: the samples' owners do
    /// not depend on the order, `samples::SampleBuffer`).
    pub nearest_first: bool,
    /// Compile out model terms that cannot contribute (KarisHair's MS block
    /// at Scatter 0), and build no shadow map for a light that light
    /// culling skips at every hair point; exact.
    pub skip_unused: bool,
    /// Reuse the shadow maps of an earlier render when the geometry, the
    /// light and the shadow settings are unchanged (exact: maps are
    /// deterministic); see `shadow::CACHE_MAPS` for the memory held. The
    /// fiber counts, environment directions and traced grid of the last
    /// render likewise ([`super::lighting`]).
    pub reuse_shadow_maps: bool,
    /// Light culling: radiance below which a light's bounded contribution
    /// (irradiance × the BSDF's upper bound) at a shading point is skipped
    /// (KarisHair; 0 = off). Changes pixels by at most this × lights.
    pub light_cull_threshold: f32,
    /// Voxels along the longest side of the hair's bounding box in the
    /// fiber density grid ([`super::density`]).
    pub density_resolution: usize,
    /// Multiple scattering; `None`: the model's default (KarisHair: its
    /// own term, ChiangHair and DEonHair: none).
    pub multiple_scattering: Option<MultipleScattering>,
    /// Zinke's density factors d_f (forward-scattered light, default 0.7)
    /// and d_b (local back scattering, default 1) of dual scattering.
    /// Against path-traced dense heads (`docs/dense_hair.md`), d_b = 1 was
    /// closer than 0.7 on every scene, and d_f = 1 made backlit blond
    /// hair 5-17% too bright.
    pub dual_forward_density: f32,
    pub dual_back_density: f32,
    /// Dual scattering's back scattering: Zinke's local `A_b` or the
    /// two-stream slab of [`crate::fiber::dual::two_stream`] (which needs
    /// the fiber count away from each light as well).
    pub dual_backscatter: Backscatter,
    /// Multiple scattering through the volume ([`super::volume`]): cells
    /// along the hair's longest side, photons per light (the environment
    /// counted as one), and octahedral direction bins per side.
    pub volume_resolution: usize,
    pub volume_photons: usize,
    pub volume_bins: usize,
    /// How the volume's photons fly (`render.volume_transport`).
    pub volume_transport: VolumeTransport,
    /// Which direction each bin's light is read from
    /// (`render.volume_directions`).
    pub volume_directions: VolumeDirections,
    /// Under dual scattering, the light opaque spheres reflect into the
    /// hair ([`super::bounce`]).
    pub sphere_bounce: bool,
    /// With coverage samples, ChiangHair's single scattering of each light
    /// by the near field at each sample's offset across its fiber
    /// ([`super::shade`]'s `near`).
    pub near_field: bool,
    /// Traced shadows: whether a ray passes its whole own strand (as
    /// Cycles, which skips every hit on the curve a ray leaves) instead of
    /// only until it leaves the strand's tube
    /// ([`super::traced::SegmentGrid::occluded_with`]; the volume's
    /// transport keeps the tube's rule).
    pub traced_own_strand_passes: bool,
    /// Traced shadows: a light's ray traced from each strand vertex, and a
    /// fragment taking its segment's two vertices' answer where they agree
    /// (its own ray only where they differ; [`super::shade`]'s
    /// `vertex_shadows`).
    pub traced_vertices: bool,
    /// Quadrature directions of the environment light for far-field models
    /// ([`super::env_light`]).
    pub environment_directions: usize,
    /// Strand level of detail: the fraction of the strands drawn
    /// ([`super::lod`]).
    pub lod: super::lod::Lod,
    /// Hair culling ([`super::cull::BehindHair`]): a pixel's hair behind
    /// the depth where its transmittance falls below this is skipped (0:
    /// off; MLAB and sorted transparency).
    pub hair_cull_transmittance: f32,
    /// How MLAB stores its layers ([`super::pack`]).
    pub layer_format: super::pack::LayerFormat,
    /// Guide-strand lighting ([`super::guides`]): under `vertex` or
    /// `split` shading, what is computed at vertices is computed at the
    /// guides' alone.
    pub guides: super::guides::Guides,
}

impl RenderOptions {
    /// Whether tiles draw their strand segments nearest first (nearest
    /// depth, then scene order): under hair culling (MLAB and sorted
    /// transparency), and under coverage samples with `nearest_first`.
    pub fn draws_nearest_first(&self) -> bool {
        match self.transparency {
            Transparency::Coverage(_) => self.nearest_first,
            Transparency::Mlab(_) | Transparency::Sorted => self.hair_cull_transmittance > 0.0,
        }
    }

    /// Inclusive range of the MLAB layer count.
    pub const LAYERS: (usize, usize) = (1, 64);
    /// Inclusive range of the shadow-map resolution.
    pub const SHADOW_MAP_SIZE: (u32, u32) = (16, 8192);
    /// Inclusive range of the PCF radius.
    pub const PCF_RADIUS: (i32, i32) = (0, 8);
    /// Inclusive range of the density grid's resolution.
    pub const DENSITY_RESOLUTION: (usize, usize) = (8, 512);
    /// Largest image side.
    pub const MAX_RESOLUTION: u32 = 16384;
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            transparency: Transparency::Mlab(4),
            shadow_map_size: 1024,
            shadow_model: super::shadow::ShadowModel::Exponential,
            shadow_density: 20.0,
            pcf_radius: 1,
            background: Vec3::ZERO,
            vertex_shading: false,
            split_shading: false,
            frustum_culling: true,
            backface_culling: true,
            opaque_culling: true,
            vertices_on_demand: true,
            nearest_first: true,
            skip_unused: true,
            reuse_shadow_maps: true,
            light_cull_threshold: 1e-4,
            density_resolution: 128,
            multiple_scattering: None,
            dual_forward_density: 0.7,
            dual_back_density: 1.0,
            dual_backscatter: Backscatter::Local,
            volume_resolution: 48,
            volume_photons: 1 << 18,
            volume_bins: 8,
            volume_transport: VolumeTransport::Strands,
            volume_directions: VolumeDirections::Mean,
            sphere_bounce: true,
            near_field: true,
            traced_own_strand_passes: false,
            traced_vertices: false,
            environment_directions: super::env_light::DIRECTIONS,
            lod: super::lod::Lod::default(),
            hair_cull_transmittance: 1e-3,
            layer_format: super::pack::LayerFormat::F32,
            guides: super::guides::Guides::default(),
        }
    }
}

/// Dual scattering's back scattering (`render.dual_backscatter`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backscatter {
    /// Zinke's local back scattering `A_b` (`"local"`).
    Local,
    /// The two-stream slab along each light's line (`"two_stream"`).
    TwoStream,
}

/// How photons fly in the volume solve (`render.volume_transport`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VolumeTransport {
    /// Through the oriented fiber medium (`"medium"`), calibrated against
    /// the strands (faster; its bias depends on the light: docs/volume.md).
    Medium,
    /// Between the fibers they really meet, traced through the strands
    /// (`"strands"`, the default); the medium only holds the tallies.
    Strands,
}

/// Which direction a fragment reads each direction bin's light from
/// (`render.volume_directions`; [`super::volume`]'s `fold`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VolumeDirections {
    /// The light's own mean direction and spread, tallied with it
    /// (`"mean"`, the default): sharper where light in a bin runs one
    /// way, but a few photons' mean direction is noisy, and the fiber's
    /// response peaked on its cone turns that noise into error.
    Mean,
    /// The bin's centre and the spread of a uniform light over the bin
    /// (`"centre"`): the reading is linear in the tallies, so a bin's
    /// noise is only its fluence's (docs/volume.md).
    Centre,
}

/// Everything the renderer draws.
#[derive(Debug, Clone)]
pub struct Scene {
    pub camera: Camera,
    pub lights: Vec<Light>,
    pub environment: Option<Environment>,
    pub strands: Strands,
    pub cards: Cards,
    pub spheres: Vec<Sphere>,
    pub triangles: Vec<OpaqueTri>,
    pub hair: HairShading,
}

#[cfg(test)]
impl Scene {
    /// `strands` alone, KarisHair's defaults, no lights, a 16×16 camera
    /// looking at the unit box from +z (for tests).
    pub(crate) fn of_strands(strands: Strands) -> Self {
        Self {
            camera: Camera {
                position: Vec3::new(0.5, 0.5, 3.0),
                target: Vec3::splat(0.5),
                up: Vec3::Y,
                fov_y: 40.0,
                width: 16,
                height: 16,
            },
            lights: Vec::new(),
            environment: None,
            strands,
            cards: Cards::default(),
            spheres: Vec::new(),
            triangles: Vec::new(),
            hair: HairShading::Karis(crate::fiber::karis::KarisParams::default().build().unwrap()),
        }
    }
}
