//! Images in and out: OpenEXR (linear float RGB, lossless) and PNG
//! previews (tone-mapped by exposure and clamped, sRGB-encoded).

use std::path::Path;

/// What went wrong in an image read or write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageErrorKind {
    /// The file could not be opened, read or written.
    Io,
    /// The file is not a valid image, or declares more than it holds.
    Format,
    /// The declared size exceeds the caller's pixel limit.
    TooLarge,
    /// The pixel buffer could not be allocated.
    Memory,
}

/// An I/O or format error, with the path.
#[derive(Debug)]
pub struct ImageError(pub String, pub ImageErrorKind);

impl std::fmt::Display for ImageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ImageError {}

/// The largest image the readers accept unless told otherwise: 2^28
/// pixels (16384 × 16384; 4 GiB as RGBA float32).
pub const DEFAULT_MAX_PIXELS: usize = 1 << 28;

/// Largest ratio of decoded to stored bytes any supported compression
/// reaches: deflate's (PNG, EXR ZIP/ZIPS/PXR24) is 1032:1 (a 258-byte
/// match in under 2 bits); EXR RLE stops at 64:1 and PIZ's Huffman runs
/// (a code of at least 9 bits for up to 255 16-bit zeros) under 500:1.
/// A file that declares more decoded bytes than this ratio allows is
/// truncated or forged, and is refused before anything is allocated.
pub const MAX_COMPRESSION_RATIO: u64 = 1032;

/// Refuses a declared `width × height` image (`decoded` bytes of pixel
/// data) of a `file_len`-byte file: above `max_pixels`, or more than the
/// file can hold at [`MAX_COMPRESSION_RATIO`].
fn check_declared(
    path: &Path,
    format: &str,
    (width, height): (usize, usize),
    decoded: u64,
    file_len: u64,
    max_pixels: usize,
) -> Result<(), ImageError> {
    let pixels = width as u128 * height as u128;
    if pixels > max_pixels as u128 {
        return Err(ImageError(
            format!(
                "{}: {format} declares {width}x{height} pixels, more than the limit of {max_pixels} \
                 (pass a larger max_pixels to read it)",
                path.display()
            ),
            ImageErrorKind::TooLarge,
        ));
    }
    if decoded > file_len.saturating_mul(MAX_COMPRESSION_RATIO) {
        return Err(ImageError(
            format!(
                "{}: {format} declares {width}x{height} pixels ({decoded} bytes of pixel data), \
                 more than its {file_len} bytes can hold: the file is truncated or corrupt",
                path.display()
            ),
            ImageErrorKind::Format,
        ));
    }
    Ok(())
}

/// A zeroed buffer of `len` values, or an error naming `what` when the
/// memory cannot be had (instead of aborting the process).
fn try_zeroed<T: Clone + Default>(len: usize, what: &str) -> Result<Vec<T>, ImageError> {
    crate::alloc::try_zeroed(len, what)
        .map_err(|e| ImageError(e.to_string(), ImageErrorKind::Memory))
}

fn file_len(path: &Path, format: &str) -> Result<u64, ImageError> {
    let io = |e: std::io::Error| {
        ImageError(
            format!("{}: cannot read {format}: {e}", path.display()),
            ImageErrorKind::Io,
        )
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(ImageError(
            format!(
                "{}: cannot read {format}: not a regular file",
                path.display()
            ),
            ImageErrorKind::Io,
        ));
    }
    Ok(meta.len())
}

/// Writes `data` (row-major RGB f32, `width × height`) as a float EXR.
pub fn write_exr(path: &Path, width: usize, height: usize, data: &[f32]) -> Result<(), ImageError> {
    assert_eq!(data.len(), width * height * 3);
    exr::prelude::write_rgb_file(path, width, height, |x, y| {
        let i = (y * width + x) * 3;
        (data[i], data[i + 1], data[i + 2])
    })
    .map_err(|e| {
        ImageError(
            format!("{}: cannot write EXR: {e}", path.display()),
            ImageErrorKind::Io,
        )
    })
}

/// Reads the RGB channels of an EXR (A ignored) as row-major f32. The
/// header is read first: an image over `max_pixels`, or declaring more
/// than the file can hold, is refused before its pixels are allocated.
pub fn read_exr(path: &Path, max_pixels: usize) -> Result<(usize, usize, Vec<f32>), ImageError> {
    use exr::prelude::*;
    let err = |e: &dyn std::fmt::Display| {
        ImageError(
            format!("{}: cannot read EXR: {e}", path.display()),
            ImageErrorKind::Format,
        )
    };
    let len = file_len(path, "EXR")?;
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| err(&e))?;
    for header in meta.headers.iter() {
        let size = header.layer_size;
        let bytes_per_pixel: u64 = header
            .channels
            .list
            .iter()
            .map(|c| c.sample_type.bytes_per_sample() as u64)
            .sum();
        let decoded = (size.width() as u64)
            .saturating_mul(size.height() as u64)
            .saturating_mul(bytes_per_pixel.max(1));
        check_declared(
            path,
            "EXR",
            (size.width(), size.height()),
            decoded,
            len,
            max_pixels,
        )?;
    }
    // The reader allocates the pixels in a callback that cannot fail: ask
    // for the largest layer's buffer first, so a failure is an error here.
    let largest = meta
        .headers
        .iter()
        .map(|h| h.layer_size.width() * h.layer_size.height() * 3)
        .max()
        .unwrap_or(0);
    Vec::<f32>::new().try_reserve_exact(largest).map_err(|_| {
        ImageError(
            format!(
                "{}: cannot allocate {} bytes for its pixels",
                path.display(),
                4 * largest
            ),
            ImageErrorKind::Memory,
        )
    })?;
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
    .map_err(|e| err(&e))?;
    let size = image.layer_data.size;
    let (_, px) = image.layer_data.channel_data.pixels;
    Ok((size.width(), size.height(), px))
}

/// Reads a PNG as row-major RGBA f32 in [0, 1] (8- or 16-bit, any color
/// type; gray and RGB get alpha 1). Like [`read_exr`], the declared size
/// is checked against `max_pixels` and the file's length first.
pub fn read_png(path: &Path, max_pixels: usize) -> Result<(usize, usize, Vec<f32>), ImageError> {
    let err = |e: &dyn std::fmt::Display| {
        ImageError(
            format!("{}: cannot read PNG: {e}", path.display()),
            ImageErrorKind::Format,
        )
    };
    let len = file_len(path, "PNG")?;
    let file = std::fs::File::open(path).map_err(|e| {
        ImageError(
            format!("{}: cannot read PNG: {e}", path.display()),
            ImageErrorKind::Io,
        )
    })?;
    let mut dec = png::Decoder::new(std::io::BufReader::new(file));
    dec.set_transformations(png::Transformations::EXPAND);
    // The decoder's own buffers (text chunks, ICC profiles) stay small.
    dec.set_limits(png::Limits { bytes: 64 << 20 });
    let mut reader = dec.read_info().map_err(|e| err(&e))?;
    let (w, h) = {
        let info = reader.info();
        (info.width as usize, info.height as usize)
    };
    let out_len = reader
        .output_buffer_size()
        .ok_or_else(|| err(&"image too large"))?;
    // Stored rows: a filter byte each, then the samples before expansion.
    let row = {
        let info = reader.info();
        let bits = info.bits_per_pixel() as u64;
        1 + (w as u64 * bits).div_ceil(8)
    };
    check_declared(
        path,
        "PNG",
        (w, h),
        row.saturating_mul(h as u64),
        len,
        max_pixels,
    )?;
    let what = path.display().to_string();
    let mut buf = try_zeroed::<u8>(out_len, &what)?;
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
    let mut out = try_zeroed::<f32>(w * h * 4, &what)?;
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

/// 8-bit sRGB values of `data × 2^exposure`, clamped to [0, 1]; a
/// non-finite value becomes 0 (black).
pub fn srgb8(data: &[f32], exposure: f32) -> Vec<u8> {
    let scale = exposure.exp2();
    data.iter()
        .map(|&v| {
            let v = if v.is_finite() {
                (v * scale).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (srgb_encode(v) * 255.0 + 0.5) as u8
        })
        .collect()
}

/// An 8-bit sRGB PNG of `data × 2^exposure` (as [`srgb8`]) into `out`.
fn encode_png_to<W: std::io::Write>(
    out: W,
    width: usize,
    height: usize,
    data: &[f32],
    exposure: f32,
) -> Result<(), png::EncodingError> {
    assert_eq!(data.len(), width * height * 3);
    let mut enc = png::Encoder::new(out, width as u32, height as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header()?;
    w.write_image_data(&srgb8(data, exposure))
}

/// The bytes of an 8-bit sRGB PNG of `data × 2^exposure`, clamped to [0, 1].
pub fn encode_png(
    width: usize,
    height: usize,
    data: &[f32],
    exposure: f32,
) -> Result<Vec<u8>, ImageError> {
    let mut bytes = Vec::new();
    encode_png_to(&mut bytes, width, height, data, exposure)
        .map_err(|e| ImageError(format!("PNG: {e}"), ImageErrorKind::Io))?;
    Ok(bytes)
}

/// Writes an 8-bit sRGB PNG of `data × 2^exposure`, clamped to [0, 1].
pub fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    data: &[f32],
    exposure: f32,
) -> Result<(), ImageError> {
    let io = |e: &dyn std::fmt::Display| {
        ImageError(format!("{}: {e}", path.display()), ImageErrorKind::Io)
    };
    let file = std::fs::File::create(path).map_err(|e| io(&e))?;
    let mut out = std::io::BufWriter::new(file);
    encode_png_to(&mut out, width, height, data, exposure).map_err(|e| io(&e))?;
    std::io::Write::flush(&mut out).map_err(|e| io(&e))
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
        let (w, h, back) = read_exr(&p, DEFAULT_MAX_PIXELS).unwrap();
        assert_eq!((w, h), (5, 3));
        assert_eq!(back, data);
        std::fs::remove_dir_all(&dir).ok();
    }
}
