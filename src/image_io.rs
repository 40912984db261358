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
fn try_zeroed<T: Clone + Default + Send + Sync>(
    len: usize,
    what: &str,
) -> Result<Vec<T>, ImageError> {
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

/// One layer of an EXR file: the channels that share a name prefix in one
/// part. `name` joins the part's name and the prefix with `.`, or is the
/// prefix alone when it already starts with the part's name (Blender's
/// multilayer `ViewLayer.Combined` holds `ViewLayer.Combined.R`, ...); a
/// plain RGB file has one layer named `""`. `channels` are the names after
/// the prefix, in the file's order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExrLayer {
    pub name: String,
    pub channels: Vec<String>,
    pub width: usize,
    pub height: usize,
}

impl ExrLayer {
    /// `'name' (R, G, B, A; 640x360)`, as errors list a file's layers.
    fn describe(&self) -> String {
        format!(
            "'{}' ({}; {}x{})",
            self.name,
            self.channels.join(", "),
            self.width,
            self.height
        )
    }

    /// How the layer's channels become RGB: the indices of R, G and B, or
    /// one channel three times (a single-channel layer, read as grey).
    fn rgb(&self) -> Option<[usize; 3]> {
        let at = |c: &str| self.channels.iter().position(|n| n == c);
        match (at("R"), at("G"), at("B")) {
            (Some(r), Some(g), Some(b)) => Some([r, g, b]),
            _ if self.channels.len() == 1 => Some([0; 3]),
            _ => None,
        }
    }
}

/// `(layer, channel)` of a channel named `full` in a part named `part`:
/// the prefix before the channel name's last `.`, joined to the part's name.
fn split_channel(part: Option<&str>, full: &str) -> (String, String) {
    let (prefix, short) = match full.rfind('.') {
        Some(i) => (&full[..i], &full[i + 1..]),
        None => ("", full),
    };
    // Blender names a part "ViewLayer.Combined" and its channels
    // "ViewLayer.Combined.R": a prefix that repeats the part's name is not
    // joined to it again.
    let name = match (part.filter(|p| !p.is_empty()), prefix.is_empty()) {
        (Some(p), false) if prefix == p || prefix.starts_with(&format!("{p}.")) => {
            prefix.to_string()
        }
        (Some(p), false) => format!("{p}.{prefix}"),
        (Some(p), true) => p.to_string(),
        (None, _) => prefix.to_string(),
    };
    (name, short.to_string())
}

fn exr_format_error(path: &Path, e: &dyn std::fmt::Display) -> ImageError {
    ImageError(
        format!("{}: cannot read EXR: {e}", path.display()),
        ImageErrorKind::Format,
    )
}

/// The layers of an EXR file's headers, in the file's order, and the
/// header each comes from.
fn layers_of(headers: &[exr::meta::header::Header]) -> Vec<(usize, ExrLayer)> {
    let mut layers: Vec<(usize, ExrLayer)> = Vec::new();
    for (part, header) in headers.iter().enumerate() {
        let part_name = header
            .own_attributes
            .layer_name
            .as_ref()
            .map(|t| t.to_string());
        for c in header.channels.list.iter() {
            let (name, short) = split_channel(part_name.as_deref(), &c.name.to_string());
            match layers
                .iter_mut()
                .find(|(p, l)| *p == part && l.name == name)
            {
                Some((_, l)) => l.channels.push(short),
                None => layers.push((
                    part,
                    ExrLayer {
                        name,
                        channels: vec![short],
                        width: header.layer_size.width(),
                        height: header.layer_size.height(),
                    },
                )),
            }
        }
    }
    layers
}

/// The layers of the EXR file at `path` (its headers only are read).
pub fn exr_layers(path: &Path) -> Result<Vec<ExrLayer>, ImageError> {
    file_len(path, "EXR")?;
    let meta =
        exr::meta::MetaData::read_from_file(path, false).map_err(|e| exr_format_error(path, &e))?;
    Ok(layers_of(&meta.headers)
        .into_iter()
        .map(|(_, l)| l)
        .collect())
}

/// The layer `layer` names, or without a name the file's only layer, its
/// unnamed RGB layer, its only RGB layer, or its only RGB layer named
/// `Combined` (Blender's beauty pass); otherwise an error listing what the
/// file has.
fn choose_layer(
    path: &Path,
    layers: &[(usize, ExrLayer)],
    layer: Option<&str>,
) -> Result<usize, ImageError> {
    let listing = || {
        let all: Vec<String> = layers.iter().map(|(_, l)| l.describe()).collect();
        all.join(", ")
    };
    let fail = |msg: String| {
        Err(ImageError(
            format!("{}: {msg}", path.display()),
            ImageErrorKind::Format,
        ))
    };
    let chosen = match layer {
        Some(name) => match layers.iter().position(|(_, l)| l.name == name) {
            Some(i) => i,
            None => return fail(format!("has no layer '{name}'; its layers: {}", listing())),
        },
        None => {
            let rgb: Vec<usize> = (0..layers.len())
                .filter(|&i| {
                    let c = &layers[i].1.channels;
                    ["R", "G", "B"].iter().all(|n| c.iter().any(|x| x == n))
                })
                .collect();
            if layers.len() == 1 {
                0
            } else if let Some(&i) = rgb.iter().find(|&&i| layers[i].1.name.is_empty()) {
                i
            } else if rgb.len() == 1 {
                rgb[0]
            } else if let [i] = rgb
                .iter()
                .copied()
                .filter(|&i| {
                    let n = &layers[i].1.name;
                    n == "Combined" || n.ends_with(".Combined")
                })
                .collect::<Vec<_>>()[..]
            {
                i // Blender's beauty pass among its other RGB passes
            } else if layers.is_empty() {
                return fail("has no channels".to_string());
            } else {
                return fail(format!(
                    "has {} layers, choose one with layer=: {}",
                    layers.len(),
                    listing()
                ));
            }
        }
    };
    if layers[chosen].1.rgb().is_none() {
        return fail(format!(
            "layer {} has no R, G and B channels and is not a single channel: choose another \
             with layer=: {}",
            layers[chosen].1.describe(),
            listing()
        ));
    }
    Ok(chosen)
}

/// Reads an EXR as row-major RGB f32 (A ignored): the RGB layer of a plain
/// file, or the layer `layer` names (see [`ExrLayer`]); a single-channel
/// layer is read as grey (its value in R, G and B). The headers are read
/// first: an image over `max_pixels`, or declaring more than the file can
/// hold, is refused before its pixels are allocated, and a file whose
/// layer is missing or ambiguous gets an error listing its layers.
pub fn read_exr_layer(
    path: &Path,
    max_pixels: usize,
    layer: Option<&str>,
) -> Result<(usize, usize, Vec<f32>), ImageError> {
    use exr::prelude::*;
    let err = |e: &dyn std::fmt::Display| exr_format_error(path, e);
    let len = file_len(path, "EXR")?;
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| err(&e))?;
    let mut total: u64 = 0;
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
        total = total.saturating_add(
            (size.width() as u64 * size.height() as u64)
                .saturating_mul(4 * header.channels.list.len() as u64),
        );
        if header.deep {
            return Err(err(&"deep data is not supported"));
        }
        if let Some(c) = header
            .channels
            .list
            .iter()
            .find(|c| c.sampling != Vec2(1, 1))
        {
            return Err(err(&format_args!(
                "channel '{}' is subsampled, which is not supported",
                c.name
            )));
        }
    }
    let layers = layers_of(&meta.headers);
    let chosen = choose_layer(path, &layers, layer)?;
    // The reader allocates the channels in callbacks that cannot fail: ask
    // for all of them, and the result, first, so a failure is an error here.
    let (w, h) = (layers[chosen].1.width, layers[chosen].1.height);
    let need = usize::try_from(total).unwrap_or(usize::MAX) / 4 + w * h * 3;
    Vec::<f32>::new().try_reserve_exact(need).map_err(|_| {
        ImageError(
            format!(
                "{}: cannot allocate {} bytes for its pixels",
                path.display(),
                4 * need as u128
            ),
            ImageErrorKind::Memory,
        )
    })?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(|e| err(&e))?;
    let (part, ref want) = layers[chosen];
    let data = &image.layer_data[part];
    let part_name = data.attributes.layer_name.as_ref().map(|t| t.to_string());
    let channel = |short: &str| {
        data.channel_data.list.iter().find(|c| {
            split_channel(part_name.as_deref(), &c.name.to_string())
                == (want.name.clone(), short.to_string())
        })
    };
    let idx = want.rgb().expect("checked by choose_layer");
    let mut px = try_zeroed::<f32>(w * h * 3, "the EXR's pixels")?;
    for (k, &i) in idx.iter().enumerate() {
        let c = channel(&want.channels[i]).ok_or_else(|| err(&"a channel vanished"))?;
        if c.sample_data.len() != w * h {
            return Err(err(&"a channel's sample count disagrees with its size"));
        }
        for (p, v) in c.sample_data.values_as_f32().enumerate() {
            px[p * 3 + k] = v;
        }
    }
    Ok((w, h, px))
}

/// Reads the RGB channels of a plain RGB(A) EXR: [`read_exr_layer`]
/// without a layer name.
pub fn read_exr(path: &Path, max_pixels: usize) -> Result<(usize, usize, Vec<f32>), ImageError> {
    read_exr_layer(path, max_pixels, None)
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

    /// A file of two parts: "beauty" with Blender-style prefixed channels
    /// (`ViewLayer.Combined.R/G/B/A`, `ViewLayer.Depth.Z`) and "mask", a
    /// single unprefixed `Y`.
    fn write_layered(p: &Path) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        use exr::prelude::*;
        let (w, h) = (4usize, 3usize);
        let val =
            |k: usize| -> Vec<f32> { (0..w * h).map(|i| (i * 7 + k) as f32 * 0.25).collect() };
        let ch = |name: &str, k: usize| AnyChannel::new(name, FlatSamples::F32(val(k)));
        let beauty = Layer::new(
            Vec2(w, h),
            LayerAttributes::named("beauty"),
            Encoding::FAST_LOSSLESS,
            AnyChannels::sort(SmallVec::from_vec(vec![
                ch("ViewLayer.Combined.R", 1),
                ch("ViewLayer.Combined.G", 2),
                ch("ViewLayer.Combined.B", 3),
                ch("ViewLayer.Combined.A", 4),
                ch("ViewLayer.Depth.Z", 5),
            ])),
        );
        let mask = Layer::new(
            Vec2(w, h),
            LayerAttributes::named("mask"),
            Encoding::FAST_LOSSLESS,
            AnyChannels::sort(SmallVec::from_vec(vec![ch("Y", 6)])),
        );
        Image::empty(ImageAttributes::new(IntegerBounds::from_dimensions(Vec2(
            w, h,
        ))))
        .with_layer(beauty)
        .with_layer(mask)
        .write()
        .to_file(p)
        .unwrap();
        let rgb = (0..w * h)
            .flat_map(|i| [val(1)[i], val(2)[i], val(3)[i]])
            .collect();
        let grey = |k| (0..w * h).flat_map(|i| [val(k)[i]; 3]).collect();
        (rgb, grey(5), grey(6))
    }

    #[test]
    fn t02_multilayer_exr_layers_are_chosen_by_name() {
        let dir = std::env::temp_dir().join(format!("hairshade-exr2-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("layers.exr");
        let (rgb, depth, mask) = write_layered(&p);
        let names: Vec<(String, Vec<String>)> = exr_layers(&p)
            .unwrap()
            .into_iter()
            .map(|l| (l.name, l.channels))
            .collect();
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        assert_eq!(
            names,
            vec![
                ("beauty.ViewLayer.Combined".into(), s(&["A", "B", "G", "R"])),
                ("beauty.ViewLayer.Depth".into(), s(&["Z"])),
                ("mask".into(), s(&["Y"])),
            ]
        );
        let read = |l| read_exr_layer(&p, DEFAULT_MAX_PIXELS, l).map(|(_, _, d)| d);
        assert_eq!(read(Some("beauty.ViewLayer.Combined")).unwrap(), rgb);
        assert_eq!(read(Some("beauty.ViewLayer.Depth")).unwrap(), depth);
        assert_eq!(read(Some("mask")).unwrap(), mask);
        // One RGB layer among others: the default.
        assert_eq!(read(None).unwrap(), rgb);
        let e = read(Some("Combined")).unwrap_err();
        assert_eq!(e.1, ImageErrorKind::Format);
        assert!(e.0.contains("has no layer 'Combined'"), "{}", e.0);
        assert!(
            e.0.contains("'beauty.ViewLayer.Combined' (A, B, G, R; 4x3)"),
            "{}",
            e.0
        );
        assert!(e.0.contains("'mask' (Y; 4x3)"), "{}", e.0);
        std::fs::remove_dir_all(&dir).ok();
    }
}
