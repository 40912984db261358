//! 64-bit MLAB layers, as Capcom's RE4 strand renderer packs them: 16-bit
//! depth, 16-bit transmittance and the premultiplied radiance in 32 bits,
//! either R11G11B10 (three small unsigned floats: 6, 6 and 5 mantissa bits,
//! 5 exponent bits each) or RGB9E5 (three 9-bit mantissas sharing a 5-bit
//! exponent), the two formats GPUs store HDR colour in. RE4 found RGB9E5
//! more faithful "except when A-B tested", and kept R11G11B10 for its cost.
//!
//! | field | encoding | largest error |
//! | --- | --- | --- |
//! | depth | unorm16 of (z − z0) / (z1 − z0) over the frame's hair | (z1 − z0) / 131070 |
//! | transmittance | unorm16 | 1 / 131070 |
//! | R11G11B10 | e5m6, e5m6, e5m5, round to nearest | 2^-7, 2^-7, 2^-6 of the value |
//! | RGB9E5 | shared e5, m9 each | 2^-9 of the largest channel |
//!
//! Both colour formats hold values from 0 to about 65 000 (larger ones are
//! clamped there); R11G11B10 keeps each channel's own precision down to
//! 2^-14 and denormals below, RGB9E5 only relative to the brightest channel.

use glam::Vec3;

/// How MLAB stores a layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LayerFormat {
    /// 20 bytes: f32 depth, transmittance and RGB.
    F32,
    /// 8 bytes: 16-bit depth and transmittance, R11G11B10 colour.
    R11G11B10,
    /// 8 bytes: 16-bit depth and transmittance, RGB9E5 colour.
    Rgb9e5,
}

impl LayerFormat {
    /// Bytes a stored layer takes.
    pub fn bytes(self) -> usize {
        match self {
            LayerFormat::F32 => 20,
            LayerFormat::R11G11B10 | LayerFormat::Rgb9e5 => 8,
        }
    }
}

/// A small unsigned float with 5 exponent bits (bias 15) and `m` mantissa
/// bits, rounded to nearest; values at or above its largest are clamped.
fn small_float(v: f32, m: u32) -> u32 {
    let max_exp = 30u32; // 31 is inf/NaN
    let largest = (2.0 - (0.5f32).powi(m as i32)) * (2.0f32).powi(max_exp as i32 - 15);
    let v = if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, largest)
    };
    let min_normal = (2.0f32).powi(-14);
    if v < min_normal {
        // denormal: value = mant / 2^m * 2^-14
        let mant = (v / min_normal * (1u32 << m) as f32).round() as u32;
        // rounded up to 2^m: the smallest normal (exponent 1, mantissa 0)
        return mant.min(1 << m);
    }
    let e = ((v.to_bits() >> 23) & 0xff) as i32 - 127; // floor(log2 v)
    let frac = v / (2.0f32).powi(e) - 1.0;
    let mut mant = (frac * (1u32 << m) as f32).round() as u32;
    let mut exp = (e + 15) as u32;
    if mant == 1 << m {
        mant = 0;
        exp += 1;
    }
    if exp > max_exp {
        return (max_exp << m) | ((1 << m) - 1);
    }
    (exp << m) | mant
}

fn small_float_value(bits: u32, m: u32) -> f32 {
    let exp = bits >> m;
    let mant = bits & ((1 << m) - 1);
    if exp == 0 {
        mant as f32 / (1u32 << m) as f32 * (2.0f32).powi(-14)
    } else {
        (1.0 + mant as f32 / (1u32 << m) as f32) * (2.0f32).powi(exp as i32 - 15)
    }
}

/// R11G11B10: red in bits 0-10, green 11-21, blue 22-31.
pub fn r11g11b10(c: Vec3) -> u32 {
    small_float(c.x, 6) | (small_float(c.y, 6) << 11) | (small_float(c.z, 5) << 22)
}

pub fn from_r11g11b10(b: u32) -> Vec3 {
    Vec3::new(
        small_float_value(b & 0x7ff, 6),
        small_float_value((b >> 11) & 0x7ff, 6),
        small_float_value(b >> 22, 5),
    )
}

/// RGB9E5 (the OpenGL EXT_texture_shared_exponent encoding): mantissas in
/// bits 0-8, 9-17, 18-26, the shared exponent (bias 15) in 27-31.
pub fn rgb9e5(c: Vec3) -> u32 {
    const N: i32 = 9;
    const BIAS: i32 = 15;
    let max_value = (511.0 / 512.0) * (2.0f32).powi(31 - BIAS);
    let clamp = |v: f32| {
        if v.is_nan() {
            0.0
        } else {
            v.clamp(0.0, max_value)
        }
    };
    let (r, g, b) = (clamp(c.x), clamp(c.y), clamp(c.z));
    let maxc = r.max(g).max(b);
    if maxc == 0.0 {
        return 0;
    }
    let floor_log2 = ((maxc.to_bits() >> 23) & 0xff) as i32 - 127;
    let mut exp = (floor_log2.max(-BIAS - 1)) + 1 + BIAS;
    let mut denom = (2.0f32).powi(exp - BIAS - N);
    if (maxc / denom).round() as i32 == 1 << N {
        denom *= 2.0;
        exp += 1;
    }
    let q = |v: f32| ((v / denom).round() as u32).min(511);
    q(r) | (q(g) << 9) | (q(b) << 18) | ((exp as u32) << 27)
}

pub fn from_rgb9e5(b: u32) -> Vec3 {
    let scale = (2.0f32).powi((b >> 27) as i32 - 15 - 9);
    Vec3::new(
        (b & 0x1ff) as f32 * scale,
        ((b >> 9) & 0x1ff) as f32 * scale,
        ((b >> 18) & 0x1ff) as f32 * scale,
    )
}

/// A unit value in 16 bits, rounded to nearest.
pub fn unorm16(v: f32) -> u16 {
    (v.clamp(0.0, 1.0) * 65535.0).round() as u16
}

pub fn from_unorm16(b: u16) -> f32 {
    b as f32 / 65535.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1. Round trips within each format's bound, over 1e-6 to 6e4: R11G11B10
    ///    within half a unit in the last place (2^-7, 2^-7, 2^-6 relative)
    ///    of normal values and 2^-21, 2^-21, 2^-20 absolute of denormal
    ///    ones (half a step of 2^-14 / 2^m); RGB9E5
    ///    within 2^-9 of the largest channel (plus the rounding of an
    ///    exponent step, 2^-9 more), and 2^-24 absolute below its smallest
    ///    exponent (2^-15); exact on representable values.
    #[test]
    fn t01_colour_round_trips() {
        let mut worst = [0.0f32; 4];
        let mut x = 1e-6f32;
        while x < 6e4 {
            for c in [
                Vec3::new(x, x * 0.37, x * 0.011),
                Vec3::new(x * 0.9, x, x * 0.5),
            ] {
                let back = from_r11g11b10(r11g11b10(c));
                for k in 0..3 {
                    let (v, b) = (c[k], back[k]);
                    let bound = if v >= (2.0f32).powi(-14) {
                        v * if k == 2 {
                            2.0f32.powi(-6)
                        } else {
                            2.0f32.powi(-7)
                        }
                    } else if k == 2 {
                        2.0f32.powi(-20)
                    } else {
                        2.0f32.powi(-21)
                    };
                    assert!((b - v).abs() <= bound * 1.0001, "r11g11b10 {c} -> {back}");
                    worst[k] = worst[k].max((b - v).abs() / v.max(1e-30));
                }
                let back9 = from_rgb9e5(rgb9e5(c));
                let m = c.max_element();
                assert!(
                    (back9 - c).abs().max_element() <= (m * 2.0f32.powi(-8)).max(2.0f32.powi(-24)),
                    "rgb9e5 {c} -> {back9}"
                );
            }
            x *= 1.37;
        }
        // representable values come back exactly
        for v in [0.0f32, 1.0, 0.5, 3.0, 1.0 + 1.0 / 64.0] {
            assert_eq!(from_r11g11b10(r11g11b10(Vec3::splat(v))).x, v);
            assert_eq!(from_rgb9e5(rgb9e5(Vec3::splat(v))).x, v);
        }
        // clamped, not wrapped
        assert!(from_r11g11b10(r11g11b10(Vec3::splat(1e9))).x > 6e4);
        assert_eq!(from_r11g11b10(r11g11b10(Vec3::splat(-1.0))), Vec3::ZERO);
        assert!(worst[0] > 0.0);
    }

    #[test]
    fn t02_unorm16_round_trips_within_half_a_step() {
        for i in 0..=1000 {
            let v = i as f32 / 1000.0;
            assert!((from_unorm16(unorm16(v)) - v).abs() <= 0.5 / 65535.0 + 1e-7);
        }
        assert_eq!(unorm16(-3.0), 0);
        assert_eq!(unorm16(7.0), 65535);
    }

    /// 3. Rounding to nearest is unbiased: over values spread evenly in
    ///    log from 1e-4 to 1e2 the mean decoded/original ratio is 1 within
    ///    1e-3 per channel, in both formats.
    #[test]
    fn t03_rounding_is_unbiased() {
        let n = 20000;
        let mut sum = [[0.0f64; 3]; 2];
        for i in 0..n {
            let x = 10f32.powf(-4.0 + 6.0 * (i as f32 + 0.5) / n as f32);
            let c = Vec3::new(x, x * 0.613, x * 0.271);
            let a = from_r11g11b10(r11g11b10(c));
            let b = from_rgb9e5(rgb9e5(c));
            for k in 0..3 {
                sum[0][k] += (a[k] / c[k]) as f64;
                sum[1][k] += (b[k] / c[k]) as f64;
            }
        }
        for f in 0..2 {
            for k in 0..3 {
                let mean = sum[f][k] / n as f64;
                assert!((mean - 1.0).abs() < 1e-3, "format {f} channel {k}: {mean}");
            }
        }
    }
}
