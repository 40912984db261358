//! Hair shading of many points at once: per light, the directions,
//! irradiance and visibility of every point, then one call of the model's
//! vector kernel over the points the light reaches (KarisHair, ChiangHair's
//! tabulated far field).

use super::visibility::Need;
use super::{CullTally, Fiber, Shader};
use crate::fiber::frame::FiberAngles;
use crate::lighting::sh9_eval;
use crate::raster::scene::HairShading;
use crate::threads::pool;
use glam::Vec3;
use rayon::prelude::*;

/// Per-point buffers of [`Shader::shade_serial`]: flat `(N, 3)` tangents,
/// view and light directions and kernel output, and per light the
/// visibility and irradiance.
struct Batch {
    level: crate::simd::Level,
    t: Vec<f32>,
    v: Vec<f32>,
    f: Vec<f32>,
    l: Vec<f32>,
    shadow: Vec<f32>,
    irradiance: Vec<Vec3>,
    /// Dual scattering's local back scattering per unit of unscattered
    /// light ([`DualTable::local_back`]), added to the kernel's far field.
    back: Vec<[f32; 3]>,
}

impl Shader<'_> {
    /// Whether [`Self::shade_batch`] and [`Self::shade_serial`] serve this
    /// model: KarisHair and ChiangHair's tabulated far field on their
    /// vector kernels, without dual scattering or the volume, or with them
    /// under `split` (the lights' unscattered light is then the far field
    /// plus dual's local back scattering; the rest is read at the vertices).
    pub fn batches(&self) -> bool {
        let terms = self.split || (self.dual.is_none() && self.volume.is_none());
        match &self.hair {
            HairShading::Karis(k) => !k.fast_asin() && terms,
            HairShading::ChiangFar(_) => terms,
            HairShading::DEon(_) => false,
        }
    }

    /// [`Self::shade`] for many points at once, in parallel chunks of
    /// [`Self::shade_serial`] (`None` unless [`Self::batches`]).
    pub fn shade_batch(
        &self,
        points: &[Vec3],
        tangent: &(dyn Fn(usize) -> Vec3 + Sync),
        fiber: &(dyn Fn(usize) -> Fiber + Sync),
        eye: Vec3,
    ) -> Option<Vec<Vec3>> {
        if !self.batches() {
            return None;
        }
        const CHUNK: usize = 4096;
        let mut out = vec![Vec3::ZERO; points.len()];
        pool().install(|| {
            out.par_chunks_mut(CHUNK).enumerate().for_each(|(c, o)| {
                let range = c * CHUNK..c * CHUNK + o.len();
                let t: Vec<Vec3> = range.clone().map(tangent).collect();
                let f: Vec<Fiber> = range.clone().map(fiber).collect();
                self.shade_serial(&points[range], &t, &f, eye, o);
            })
        });
        Some(out)
    }

    /// [`Self::shade`] for `points` with `tangents`, on this thread
    /// (requires [`Self::batches`]): per light, the directions, irradiance
    /// and visibility per point, then one call of the model's vector kernel
    /// over the points the light reaches; the environment likewise. Equal
    /// to `shade` up to the vector kernel's rounding.
    pub fn shade_serial(
        &self,
        points: &[Vec3],
        tangents: &[Vec3],
        fibers: &[Fiber],
        eye: Vec3,
        out: &mut [Vec3],
    ) {
        assert!(self.batches(), "shade_serial without a vector kernel");
        let n = points.len();
        let mut b = Batch {
            level: crate::simd::Level::detect(),
            t: tangents.iter().flat_map(|x| x.to_array()).collect(),
            v: points
                .iter()
                .flat_map(|p| (eye - *p).normalize_or_zero().to_array())
                .collect(),
            f: vec![0.0f32; 3 * n],
            l: vec![0.0f32; 3 * n],
            shadow: vec![0.0f32; n],
            irradiance: vec![Vec3::ZERO; n],
            back: vec![[0.0; 3]; if self.dual.is_some() { n } else { 0 }],
        };
        out.fill(Vec3::ZERO);
        let mut tally = CullTally::default();
        // (as `shade_impl` asks: under split the lights' unscattered light)
        let need = if self.split {
            Need::Unscattered
        } else {
            Need::All
        };
        for source in self.sources(self.split) {
            // per point: direction, irradiance, unscattered fraction (0 where culled)
            for (i, p) in points.iter().enumerate() {
                let v = Vec3::from_slice(&b.v[3 * i..]);
                let inc = self.incident(
                    source,
                    *p,
                    tangents[i],
                    v,
                    fibers[i],
                    need,
                    true,
                    &mut tally,
                );
                let (l, e, vis) = inc.as_ref().map_or((Vec3::ZERO, Vec3::ZERO, 0.0), |x| {
                    (x.dir, x.irradiance, x.unscattered)
                });
                b.l[3 * i..3 * i + 3].copy_from_slice(&l.to_array());
                (b.irradiance[i], b.shadow[i]) = (e, vis);
                // dual scattering's direct part: the local back scattering
                // where the way to the light has no `behind` (two-stream: none)
                if let (Some((dual, _)), Some(inc)) = (&self.dual, &inc) {
                    b.back[i] = if vis > 0.0 && inc.path.behind.is_none() {
                        let g = FiberAngles::new(tangents[i], v, l);
                        dual.local_back(&dual.terms(g.light.0), &g)
                    } else {
                        [0.0; 3]
                    };
                }
            }
            self.add_light(&mut b, out);
        }
        self.flush(tally);
        if self.split {
            for (i, o) in out.iter_mut().enumerate() {
                let v = Vec3::from_slice(&b.v[3 * i..]);
                *o += self.vertex_terms(points[i], tangents[i], v, fibers[i]);
            }
            return;
        }
        if let (Some(env), Some(m)) = (&self.scene.environment, &self.env_model) {
            // L = the fake normal n = normalize(V − T(T·V)); π · SH(n)⁺ · f
            use crate::fiber::karis::{simd::eval_range, KarisInputs};
            for i in 0..n {
                let (vi, ti) = (Vec3::from_slice(&b.v[3 * i..]), tangents[i]);
                let nn = (vi - ti * ti.dot(vi)).normalize_or_zero();
                b.l[3 * i..3 * i + 3].copy_from_slice(&nn.to_array());
                b.irradiance[i] = Vec3::from(sh9_eval(&env.sh, &nn.to_array())).max(Vec3::ZERO);
            }
            let inp = KarisInputs::directions(&b.l, &b.v, &b.t);
            eval_range::<false>(m, &inp, 0, &mut b.f, b.level);
            for (i, o) in out.iter_mut().enumerate() {
                *o += Vec3::from_slice(&b.f[3 * i..]) * b.irradiance[i] * std::f32::consts::PI;
            }
        }
    }

    /// Adds one light's `f · E · visibility` to `out`: the model's vector
    /// kernel over the points the light reaches (culled and fully shadowed
    /// ones add nothing; lanes are independent, so the values do not depend
    /// on which points share a batch).
    fn add_light(&self, b: &mut Batch, out: &mut [Vec3]) {
        use crate::fiber::chiang::{table_eval_range, Pairs};
        use crate::fiber::karis::{simd::eval_range, KarisInputs};
        let n = out.len();
        let active: Vec<usize> = (0..n).filter(|&i| b.shadow[i] > 0.0).collect();
        if active.is_empty() {
            return;
        }
        let picked;
        let (l, v, t, shadow) = if active.len() == n {
            (&b.l[..], &b.v[..], &b.t[..], &b.shadow[..])
        } else {
            let pick3 = |a: &[f32]| -> Vec<f32> {
                active
                    .iter()
                    .flat_map(|&i| [a[3 * i], a[3 * i + 1], a[3 * i + 2]])
                    .collect()
            };
            let s: Vec<f32> = active.iter().map(|&i| b.shadow[i]).collect();
            picked = (pick3(&b.l), pick3(&b.v), pick3(&b.t), s);
            (&picked.0[..], &picked.1[..], &picked.2[..], &picked.3[..])
        };
        let fa = &mut b.f[..3 * active.len()];
        match &self.hair {
            HairShading::Karis(k) => {
                let inp = KarisInputs {
                    shadow,
                    ..KarisInputs::directions(l, v, t)
                };
                eval_range::<false>(k, &inp, 0, fa, b.level)
            }
            // Mitsuba's convention: wi towards the viewer, wo towards the light.
            HairShading::ChiangFar(c) => table_eval_range(c, Pairs::World(v, l, t), 0, fa, b.level),
            HairShading::DEon(_) => unreachable!("DEonHair has no batch kernel"),
        }
        for (j, &i) in active.iter().enumerate() {
            let mut f = Vec3::from_slice(&fa[3 * j..]);
            if let Some(back) = b.back.get(i) {
                f += Vec3::from(*back);
            }
            out[i] += f * b.irradiance[i] * b.shadow[i];
        }
    }
}
