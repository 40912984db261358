//! Reading a built [`ShadowMap`]: the light visibility of fibers and
//! opaque surfaces, PCF-filtered (the opacity model's deposits in front of
//! the receiver, or the exponential falloff behind the first hair).

use super::{Projection, ShadowMap, ShadowModel, LAYERS, NO_STRAND, SLABS};
use crate::raster::shade::Fiber;
use glam::Vec3;

impl ShadowMap {
    /// Light visibility of the surface point `q` of a fiber of strand
    /// `strand` whose centre line is at `p`. Opacity model: the deposits
    /// of the texels around `q` in front of `q`, except the strand's own,
    /// PCF-filtered; a receiver on no strand ([`NO_STRAND`]: cards, opaque
    /// surfaces) counts deposits more than the depth bias in front. The
    /// other models: [`Self::visibility`] at `p`.
    pub fn visibility_fiber(&self, p: Vec3, q: Vec3, fiber: &Fiber) -> f32 {
        if self.model != ShadowModel::Opacity {
            return self.visibility(p);
        }
        self.opacity_visibility(q, fiber, [0.0; 2])
    }

    /// Opacity model: visibility at `q` of `fiber`, the receiver's depth
    /// changing by `grad` per texel step.
    fn opacity_visibility(&self, q: Vec3, fiber: &Fiber, grad: [f32; 2]) -> f32 {
        let Some((u, v, zq)) = self.proj.map(q) else {
            return 1.0;
        };
        let zq0 = zq;
        let front = if fiber.strand == NO_STRAND {
            zq - self.bias
        } else {
            zq
        };
        self.pcf(u, v, zq, grad, |idx, zq| {
            // The receiver's depth under this tap (unchanged at grad 0).
            let front = front + (zq - zq0);
            let mut tau = 0.0;
            for d in &self.layers[idx * LAYERS..(idx + 1) * LAYERS] {
                if d.depth < front && !fiber.is_local(d.strand, d.segment) {
                    tau += d.tau;
                }
            }
            let behind = front - self.hair[idx];
            if behind > 0.0 {
                let s = self.slab_coord(behind);
                let k = s as usize;
                let slabs = &self.slabs[idx * SLABS..idx * SLABS + SLABS];
                tau += slabs[..k.min(SLABS)].iter().sum::<f32>();
                if k < SLABS {
                    tau += (s - k as f32) * slabs[k];
                }
            }
            (-tau).exp()
        })
    }

    /// Light visibility at `p` in [0, 1] (a point on no strand).
    pub fn visibility(&self, p: Vec3) -> f32 {
        self.visibility_at(p, [0.0; 2])
    }

    /// Light visibility at point `p` of an opaque surface with normal `n`.
    /// Each PCF tap is compared with the depth the surface's tangent plane
    /// has under that tap (receiver-plane depth bias), so that a lit
    /// surface does not shadow itself where it slopes away from the light
    /// (with one depth for all taps, a sphere lit from above lost up to
    /// half its radiance near its silhouette at PCF radius 1).
    pub fn visibility_surface(&self, p: Vec3, n: Vec3) -> f32 {
        let Some((_, _, z)) = self.proj.map(p) else {
            return 1.0;
        };
        // World size of a texel at depth z; depth change per texel step
        // along u (right) and v (−up) on the plane n·x = n·p.
        let w = match self.proj.kind {
            Projection::Ortho { half } => 2.0 * half / self.size as f32,
            Projection::Persp { tan_half } => 2.0 * z * tan_half / self.size as f32,
        };
        let nf = n.dot(self.proj.forward);
        let nf = if nf.abs() < 1e-3 {
            1e-3f32.copysign(nf)
        } else {
            nf
        };
        // At most 8 texels of depth per texel: steeper is at the light's
        // terminator, where the cosine makes the point dark anyway.
        let g = [
            (-w * n.dot(self.proj.right) / nf).clamp(-8.0 * w, 8.0 * w),
            (w * n.dot(self.proj.up) / nf).clamp(-8.0 * w, 8.0 * w),
        ];
        self.visibility_at(p, g)
    }

    /// Visibility at `p` whose depth changes by `grad` per texel step.
    fn visibility_at(&self, p: Vec3, grad: [f32; 2]) -> f32 {
        if self.model == ShadowModel::Opacity {
            return self.opacity_visibility(p, &Fiber::NONE, grad);
        }
        let Some((u, v, z)) = self.proj.map(p) else {
            return 1.0;
        };
        self.pcf(u, v, z, grad, |idx, z| {
            // Exponential model (the density model draws no hair: the
            // first-hair depth is infinite).
            let behind = z - self.hair[idx] - self.bias;
            if behind > 0.0 {
                (-self.density * behind).exp()
            } else {
                1.0
            }
        })
    }

    /// The mean over the PCF taps around texel (u, v) of `tap(texel, z')`:
    /// 1 outside the map, 0 behind opaque geometry at depth `z'`, the
    /// receiver's depth under the tap (`z` plus `grad` per texel step).
    #[inline]
    fn pcf(&self, u: f32, v: f32, z: f32, grad: [f32; 2], tap: impl Fn(usize, f32) -> f32) -> f32 {
        let n = self.size as i32;
        let (x, y) = ((u * n as f32) as i32, (v * n as f32) as i32);
        // The receiver's offset from its texel's centre, in texels: a tap
        // holds the depth at its texel's centre.
        let (fx, fy) = (u * n as f32 - x as f32 - 0.5, v * n as f32 - y as f32 - 0.5);
        let (mut sum, mut count) = (0.0, 0.0);
        for dy in -self.pcf..=self.pcf {
            for dx in -self.pcf..=self.pcf {
                let (xi, yi) = (x + dx, y + dy);
                count += 1.0;
                if xi < 0 || yi < 0 || xi >= n || yi >= n {
                    sum += 1.0;
                    continue;
                }
                let idx = (yi * n + xi) as usize;
                let zt = z + grad[0] * (dx as f32 - fx) + grad[1] * (dy as f32 - fy);
                if zt > self.opaque[idx] + self.bias {
                    continue;
                }
                sum += tap(idx, zt);
            }
        }
        sum / count
    }
}
