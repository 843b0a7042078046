//! Reading images that scenes refer to (environment maps).

use lightlab_core::Rgb;
use std::path::Path;

/// An image as linear RGB: width, height and texels row by row from the top.
pub(crate) type RgbImage = (usize, usize, Vec<Rgb>);

/// Reads an image file as linear RGB (alpha ignored, grey replicated): OpenEXR and Radiance HDR
/// as stored; PNG and JPEG (8 or 16 bits per channel) decoded from sRGB (IEC 61966-2-1) unless
/// `raw`, when their values scaled to [0, 1] are taken as they are. Mitsuba 3 reads bitmaps the
/// same way.
pub(crate) fn read_rgb_image(path: &Path, raw: bool) -> Result<RgbImage, String> {
    if !path.is_file() {
        return Err(format!("image file {} does not exist", path.display()));
    }
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if extension.eq_ignore_ascii_case("exr") {
        return read_rgb_exr(path);
    }
    let image = image::ImageReader::open(path)
        .and_then(|r| r.with_guessed_format())
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?
        .decode()
        .map_err(|e| {
            format!(
                "cannot read {} (PNG, JPEG, OpenEXR and Radiance HDR are supported): {e}",
                path.display()
            )
        })?;
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

/// The sRGB transfer function's inverse (IEC 61966-2-1): an encoded value in [0, 1] to linear.
pub(crate) fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The first RGB(A) layer of an OpenEXR file: width, height and linear texels row by row from the
/// top.
fn read_rgb_exr(path: &Path) -> Result<RgbImage, String> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            let (w, h) = (resolution.width(), resolution.height());
            (w, vec![Rgb::BLACK; w * h])
        },
        |(w, texels): &mut (usize, Vec<Rgb>), pos, (r, g, b, _): (f32, f32, f32, f32)| {
            texels[pos.y() * *w + pos.x()] = Rgb::new(r, g, b);
        },
    )
    .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let size = image.layer_data.size;
    let (_, texels) = image.layer_data.channel_data.pixels;
    Ok((size.width(), size.height(), texels))
}
