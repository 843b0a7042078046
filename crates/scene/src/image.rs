//! Reading images that scenes refer to (environment maps and textures).

use lightlab_core::Rgb;
use std::path::Path;

/// The most memory an image may take decoded (the `image` crate's default, 512 MiB, refused
/// 16384 × 8192 environment maps, 1.5 GiB): above it a corrupt header's dimensions would exhaust
/// memory (the texels are copied twice more on their way to the scene).
const MAX_DECODED_BYTES: u64 = 4 << 30;

/// An image as linear RGB: width, height and texels row by row from the top.
pub(crate) type RgbImage = (usize, usize, Vec<Rgb>);

/// Reads an image file as linear RGB (alpha ignored): OpenEXR (R, G and B channels, or Y as grey) and Radiance
/// HDR as stored; PNG and JPEG (8 or 16 bits per channel, grey replicated) decoded from sRGB
/// (IEC 61966-2-1) unless `raw`, when their values scaled to [0, 1] are taken as they are.
/// Mitsuba 3 reads bitmaps the same way. An image without texels is refused.
pub(crate) fn read_rgb_image(path: &Path, raw: bool) -> Result<RgbImage, String> {
    let (w, h, texels) = read_any(path, raw)?;
    if w == 0 || h == 0 {
        return Err(format!("{} is empty ({w} × {h} texels)", path.display()));
    }
    Ok((w, h, texels))
}

fn read_any(path: &Path, raw: bool) -> Result<RgbImage, String> {
    if path.is_dir() {
        return Err(format!(
            "image file {} is a directory, not an image",
            path.display()
        ));
    }
    if !path.is_file() {
        return Err(format!("image file {} does not exist", path.display()));
    }
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if extension.eq_ignore_ascii_case("exr") {
        return read_rgb_exr(path);
    }
    let unreadable = |e: image::ImageError| {
        let why = match e {
            image::ImageError::Limits(_) => format!(
                "decoding it takes more than {} GiB of memory",
                MAX_DECODED_BYTES >> 30
            ),
            e => e.to_string(),
        };
        format!(
            "cannot read {} (PNG, JPEG, OpenEXR and Radiance HDR are supported): {why}",
            path.display()
        )
    };
    let mut limits = image::Limits::no_limits();
    limits.max_alloc = Some(MAX_DECODED_BYTES);
    let mut file = std::io::BufReader::new(
        std::fs::File::open(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?,
    );
    let image = if std::io::BufRead::fill_buf(&mut file).is_ok_and(|b| b.starts_with(b"#?")) {
        // Radiance HDR. Its first line names the program that wrote it: `#?RADIANCE`, or
        // `#?RGBE` from Mitsuba 3 and Walter's rgbe.c; the strict decoder takes only the former.
        use image::ImageDecoder;
        let file = lf_header(file).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let mut decoder =
            image::codecs::hdr::HdrDecoder::new_nonstrict(file).map_err(unreadable)?;
        limits.reserve(decoder.total_bytes()).map_err(unreadable)?;
        decoder.set_limits(limits).map_err(unreadable)?;
        image::DynamicImage::from_decoder(decoder).map_err(unreadable)?
    } else {
        let mut reader = image::ImageReader::new(file)
            .with_guessed_format()
            .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        reader.limits(limits);
        reader.decode().map_err(unreadable)?
    };
    let linear = matches!(
        image,
        image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_)
    ) || raw;
    let (w, h) = (image.width() as usize, image.height() as usize);
    let decode = |c: f32| if linear { c } else { srgb_to_linear(c) };
    let texels = image
        .to_rgb32f()
        .pixels()
        .map(|p| Rgb::new(decode(p[0]), decode(p[1]), decode(p[2])))
        .collect();
    Ok((w, h, texels))
}

/// A Radiance HDR file with its header's CRLF line ends (a file that passed through Windows
/// tools) made LF: the header is the lines up to the first empty one and the resolution line after
/// it, and the `image` crate's decoder ends it only at an empty line, so `\r` lines ran it into
/// the pixels ("EOF in header"). The pixels are passed on untouched. At most 64 KiB of header.
fn lf_header<R: std::io::BufRead>(mut file: R) -> std::io::Result<impl std::io::BufRead> {
    let mut header = Vec::new();
    let mut blank_seen = false;
    loop {
        let mut line = Vec::new();
        if file.read_until(b'\n', &mut line)? == 0 || header.len() > 1 << 16 {
            break;
        }
        if line.ends_with(b"\r\n") {
            line.truncate(line.len() - 2);
            line.push(b'\n');
        }
        let blank = line == b"\n";
        header.extend_from_slice(&line);
        if blank_seen {
            break;
        }
        blank_seen = blank;
    }
    Ok(std::io::Read::chain(std::io::Cursor::new(header), file))
}

/// The sRGB transfer function's inverse (IEC 61966-2-1): an encoded value in [0, 1] to linear.
pub(crate) fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// `Err` when the OpenEXR file at `path` would take more than [`MAX_DECODED_BYTES`] decoded, as its
/// header declares (each part's largest level, every channel as f32): a corrupt or hostile header
/// of a few hundred bytes can claim 100 000² pixels, and the exr crate allocates them before it
/// reads a texel. The error says why, without the path. An unreadable header is left to the reader,
/// whose message is more specific.
pub fn check_exr_size(path: &Path) -> Result<(), String> {
    let Ok(meta) = exr::meta::MetaData::read_from_file(path, false) else {
        return Ok(());
    };
    let bytes: f64 = meta
        .headers
        .iter()
        .map(|h| h.layer_size.area() as f64 * h.channels.list.len() as f64 * 4.0)
        .sum();
    if bytes > MAX_DECODED_BYTES as f64 {
        let h = &meta.headers[0];
        return Err(format!(
            "cannot read {}: its header declares {} × {} pixels{} in {} channel(s), which take              {:.0} GiB decoded, more than the {} GiB allowed (is the file corrupt?)",
            path.display(),
            h.layer_size.width(),
            h.layer_size.height(),
            if meta.headers.len() > 1 {
                format!(" (and {} more parts)", meta.headers.len() - 1)
            } else {
                String::new()
            },
            h.channels.list.len(),
            bytes / (1u64 << 30) as f64,
            MAX_DECODED_BYTES >> 30
        ));
    }
    Ok(())
}

/// The first RGB(A) layer of an OpenEXR file, or else its first luminance (`Y`) layer as grey:
/// width, height and linear texels row by row from the top.
fn read_rgb_exr(path: &Path) -> Result<RgbImage, String> {
    use exr::prelude::*;
    check_exr_size(path).map_err(|why| format!("cannot read {}: {why}", path.display()))?;
    fn texels(resolution: Vec2<usize>) -> (usize, Vec<Rgb>) {
        let (w, h) = (resolution.width(), resolution.height());
        (w, vec![Rgb::BLACK; w * h])
    }
    let rgb = read_first_rgba_layer_from_file(
        path,
        |resolution, _| texels(resolution),
        |(w, texels): &mut (usize, Vec<Rgb>), pos, (r, g, b, _): (f32, f32, f32, f32)| {
            texels[pos.y() * *w + pos.x()] = Rgb::new(r, g, b);
        },
    );
    let (size, (_, texels)) = match rgb {
        Ok(image) => (image.layer_data.size, image.layer_data.channel_data.pixels),
        // A grey image (Mitsuba's `mono` variants write one) replicates Y, as Mitsuba reads it.
        Err(rgb_error) => read()
            .no_deep_data()
            .largest_resolution_level()
            .specific_channels()
            .required("Y")
            .collect_pixels(
                |resolution, _| texels(resolution),
                |(w, texels): &mut (usize, Vec<Rgb>), pos, (y,): (f32,)| {
                    texels[pos.y() * *w + pos.x()] = Rgb::new(y, y, y);
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_file(path)
            .map(|image| (image.layer_data.size, image.layer_data.channel_data.pixels))
            .map_err(|_| {
                format!(
                    "cannot read {} (an OpenEXR image needs R, G and B channels, or Y): \
                     {rgb_error}",
                    path.display()
                )
            })?,
    };
    Ok((size.width(), size.height(), texels))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir() -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("lightlab-image-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// 8-bit 128 and 64 decode to Mitsuba 3.9.1's 0.21586 and 0.0512694 (its `bitmap` on the same
    /// PNG), 255 to 1; `raw` keeps 128/255.
    #[test]
    fn png_is_decoded_from_srgb_unless_raw() {
        let path = dir().join("s.png");
        image::RgbImage::from_pixel(1, 1, image::Rgb([128, 64, 255]))
            .save(&path)
            .unwrap();
        let (w, h, t) = read_rgb_image(&path, false).unwrap();
        assert_eq!((w, h), (1, 1));
        assert!(
            (t[0] - Rgb::new(0.21586, 0.0512694, 1.0))
                .map(f32::abs)
                .max_component()
                < 2e-5
        );
        let (_, _, t) = read_rgb_image(&path, true).unwrap();
        assert!((t[0].r - 128.0 / 255.0).abs() < 1e-6);
    }

    /// 16-bit and grey PNGs decode too (grey to three equal channels), rows from the top.
    #[test]
    fn sixteen_bit_and_grey_images() {
        let path = dir().join("grey16.png");
        image::ImageBuffer::<image::Luma<u16>, _>::from_fn(1, 2, |_, y| {
            image::Luma([65535 * y as u16])
        })
        .save(&path)
        .unwrap();
        let (w, h, t) = read_rgb_image(&path, false).unwrap();
        assert_eq!((w, h), (1, 2));
        assert_eq!(t[0], Rgb::BLACK);
        assert!((t[1] - Rgb::WHITE).map(f32::abs).max_component() < 1e-6);
    }

    /// Radiance HDR is linear: values above 1 survive (to its 8-bit shared-exponent precision).
    #[test]
    fn hdr_is_linear() {
        let path = dir().join("sky.hdr");
        image::Rgb32FImage::from_pixel(2, 1, image::Rgb([4.0, 0.5, 0.25]))
            .save(&path)
            .unwrap();
        let (_, _, t) = read_rgb_image(&path, false).unwrap();
        assert!(
            (t[1] - Rgb::new(4.0, 0.5, 0.25))
                .map(f32::abs)
                .max_component()
                < 0.02
        );
    }

    /// Radiance HDR files whose first line is `#?RGBE` (Mitsuba 3's and Walter's rgbe.c writers)
    /// read like `#?RADIANCE` ones: RGBE (128, 64, 32, 129) is (1, 0.5, 0.25), without Ward's
    /// +0.5 (as Mitsuba 3 and stb_image decode it). A 16384 × 8192 map (1.5 GiB decoded) is not
    /// refused by the `image` crate's default 512 MiB limit: its header alone, without pixels,
    /// fails for want of data, not of memory.
    #[test]
    fn hdr_headers_of_other_writers_and_large_maps_read() {
        let path = dir().join("rgbe.hdr");
        let mut bytes = b"#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n".to_vec();
        bytes.extend([128, 64, 32, 129, 128, 64, 32, 129]);
        std::fs::write(&path, &bytes).unwrap();
        let (w, h, t) = read_rgb_image(&path, false).unwrap();
        assert_eq!((w, h), (2, 1));
        assert_eq!(t[1], Rgb::new(1.0, 0.5, 0.25));
        let large = dir().join("large.hdr");
        std::fs::write(
            &large,
            b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8192 +X 16384\n",
        )
        .unwrap();
        let err = read_rgb_image(&large, false).unwrap_err();
        assert!(!err.contains("emory"), "{err}");
        let huge = dir().join("huge.hdr");
        std::fs::write(
            &huge,
            b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 200000 +X 200000\n",
        )
        .unwrap();
        let err = read_rgb_image(&huge, false).unwrap_err();
        assert!(err.contains("more than 4 GiB"), "{err}");
        let err = read_rgb_image(&dir(), false).unwrap_err();
        assert!(err.contains("is a directory"), "{err}");
        let empty = dir().join("empty.hdr");
        std::fs::write(&empty, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 0 +X 0\n").unwrap();
        let err = read_rgb_image(&empty, false).unwrap_err();
        assert!(err.contains("empty.hdr"), "{err}");
    }

    /// An OpenEXR header of a few hundred bytes claiming 100 000² pixels is refused before the
    /// exr crate allocates them (it aborted the process, out of memory); one claiming 64² pixels
    /// that are not there fails for want of data, not of memory.
    #[test]
    fn exr_headers_claiming_huge_images_are_refused() {
        let huge = dir().join("huge.exr");
        std::fs::write(
            &huge,
            lightlab_testkit::files::exr_header_only(100_000, 100_000),
        )
        .unwrap();
        let err = read_rgb_image(&huge, false).unwrap_err();
        assert!(
            err.contains("huge.exr") && err.contains("100000 × 100000") && err.contains("37 GiB"),
            "{err}"
        );
        let small = dir().join("small-header.exr");
        std::fs::write(&small, lightlab_testkit::files::exr_header_only(64, 64)).unwrap();
        assert!(check_exr_size(&small).is_ok());
        let err = read_rgb_image(&small, false).unwrap_err();
        assert!(!err.contains("GiB"), "{err}");
    }

    /// An OpenEXR file with one luminance channel `Y` (Mitsuba's `mono` output) reads as grey;
    /// it was refused for want of R, G and B. A file with neither is still refused, saying what
    /// it needs.
    #[test]
    fn grey_exr_reads_as_grey() {
        use exr::prelude::*;
        let path = dir().join("grey.exr");
        let pixels = SpecificChannels::build()
            .with_channel("Y")
            .with_pixel_fn(|p: Vec2<usize>| (0.25f32 + p.x() as f32,));
        Image::from_channels((2, 1), pixels)
            .write()
            .to_file(&path)
            .unwrap();
        let (w, h, t) = read_rgb_image(&path, false).unwrap();
        assert_eq!((w, h), (2, 1));
        assert_eq!(
            t,
            vec![Rgb::new(0.25, 0.25, 0.25), Rgb::new(1.25, 1.25, 1.25)]
        );
        let depth = dir().join("depth.exr");
        let pixels = SpecificChannels::build()
            .with_channel("Z")
            .with_pixel_fn(|_| (1.0f32,));
        Image::from_channels((2, 1), pixels)
            .write()
            .to_file(&depth)
            .unwrap();
        let err = read_rgb_image(&depth, false).unwrap_err();
        assert!(err.contains("depth.exr") && err.contains("or Y"), "{err}");
    }

    /// A header with CRLF line ends (and a blank line `\r\n`) reads as the LF one does; it failed
    /// with "EOF in header".
    #[test]
    fn hdr_header_with_crlf_line_ends_reads() {
        let path = dir().join("crlf.hdr");
        let mut bytes = b"#?RADIANCE\r\nFORMAT=32-bit_rle_rgbe\r\n\r\n-Y 1 +X 2\r\n".to_vec();
        // A pixel whose bytes hold \r and \n stays as it is.
        bytes.extend([13, 10, 13, 129, 128, 64, 32, 129]);
        std::fs::write(&path, &bytes).unwrap();
        let (w, h, t) = read_rgb_image(&path, false).unwrap();
        assert_eq!((w, h), (2, 1));
        assert_eq!(t[0], Rgb::new(13.0 / 128.0, 10.0 / 128.0, 13.0 / 128.0));
        assert_eq!(t[1], Rgb::new(1.0, 0.5, 0.25));
    }

    #[test]
    fn unreadable_images_are_errors() {
        let path = dir().join("not-an-image.png");
        std::fs::write(&path, "text").unwrap();
        assert!(
            read_rgb_image(&path, false)
                .unwrap_err()
                .contains("cannot read")
        );
        assert!(
            read_rgb_image(&dir().join("missing.png"), false)
                .unwrap_err()
                .contains("does not exist")
        );
    }
}
