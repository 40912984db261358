//! Images in and out: OpenEXR (linear float RGB, lossless) and PNG
//! previews (tone-mapped by exposure and clamped, sRGB-encoded).

use std::path::Path;

/// An I/O or format error, with the path.
#[derive(Debug)]
pub struct ImageError(pub String);

impl std::fmt::Display for ImageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ImageError {}

/// Writes `data` (row-major RGB f32, `width × height`) as a float EXR.
pub fn write_exr(path: &Path, width: usize, height: usize, data: &[f32]) -> Result<(), ImageError> {
    assert_eq!(data.len(), width * height * 3);
    exr::prelude::write_rgb_file(path, width, height, |x, y| {
        let i = (y * width + x) * 3;
        (data[i], data[i + 1], data[i + 2])
    })
    .map_err(|e| ImageError(format!("{}: cannot write EXR: {e}", path.display())))
}

/// Reads the RGB channels of an EXR (A ignored) as row-major f32.
pub fn read_exr(path: &Path) -> Result<(usize, usize, Vec<f32>), ImageError> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![0.0f32; res.width() * res.height() * 3]),
        |(w, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let i = (pos.y() * *w + pos.x()) * 3;
            px[i] = r;
            px[i + 1] = g;
            px[i + 2] = b;
        },
    )
    .map_err(|e| ImageError(format!("{}: cannot read EXR: {e}", path.display())))?;
    let size = image.layer_data.size;
    let (_, px) = image.layer_data.channel_data.pixels;
    Ok((size.width(), size.height(), px))
}

/// Reads a PNG as row-major RGBA f32 in [0, 1] (8- or 16-bit, any color
/// type; gray and RGB get alpha 1).
pub fn read_png(path: &Path) -> Result<(usize, usize, Vec<f32>), ImageError> {
    let err =
        |e: &dyn std::fmt::Display| ImageError(format!("{}: cannot read PNG: {e}", path.display()));
    let file = std::fs::File::open(path).map_err(|e| err(&e))?;
    let mut dec = png::Decoder::new(std::io::BufReader::new(file));
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec.read_info().map_err(|e| err(&e))?;
    let mut buf = vec![
        0u8;
        reader
            .output_buffer_size()
            .ok_or_else(|| err(&"image too large"))?
    ];
    let info = reader.next_frame(&mut buf).map_err(|e| err(&e))?;
    let (w, h) = (info.width as usize, info.height as usize);
    let channels = info.color_type.samples();
    let sixteen = info.bit_depth == png::BitDepth::Sixteen;
    let sample = |i: usize| -> f32 {
        if sixteen {
            u16::from_be_bytes([buf[2 * i], buf[2 * i + 1]]) as f32 / 65535.0
        } else {
            buf[i] as f32 / 255.0
        }
    };
    let mut out = vec![0.0f32; w * h * 4];
    for p in 0..w * h {
        let base = p * channels;
        let (r, g, b, a) = match channels {
            1 => (sample(base), sample(base), sample(base), 1.0),
            2 => (sample(base), sample(base), sample(base), sample(base + 1)),
            3 => (sample(base), sample(base + 1), sample(base + 2), 1.0),
            _ => (
                sample(base),
                sample(base + 1),
                sample(base + 2),
                sample(base + 3),
            ),
        };
        out[4 * p..4 * p + 4].copy_from_slice(&[r, g, b, a]);
    }
    Ok((w, h, out))
}

/// sRGB encoding of a linear value in [0, 1].
#[inline]
pub fn srgb_encode(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Writes an 8-bit sRGB PNG of `data × 2^exposure`, clamped to [0, 1].
pub fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    data: &[f32],
    exposure: f32,
) -> Result<(), ImageError> {
    assert_eq!(data.len(), width * height * 3);
    let scale = exposure.exp2();
    let bytes: Vec<u8> = data
        .iter()
        .map(|&v| {
            let v = if v.is_finite() {
                (v * scale).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (srgb_encode(v) * 255.0 + 0.5) as u8
        })
        .collect();
    let file =
        std::fs::File::create(path).map_err(|e| ImageError(format!("{}: {e}", path.display())))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width as u32, height as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc
        .write_header()
        .map_err(|e| ImageError(format!("{}: {e}", path.display())))?;
    w.write_image_data(&bytes)
        .map_err(|e| ImageError(format!("{}: {e}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t01_exr_round_trip_is_lossless() {
        let dir = std::env::temp_dir().join(format!("hairshade-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("a.exr");
        let data: Vec<f32> = (0..5 * 3 * 3).map(|i| i as f32 * 0.37 - 2.0).collect();
        write_exr(&p, 5, 3, &data).unwrap();
        let (w, h, back) = read_exr(&p).unwrap();
        assert_eq!((w, h), (5, 3));
        assert_eq!(back, data);
        std::fs::remove_dir_all(&dir).ok();
    }
}
