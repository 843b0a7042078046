//! Reading images that scenes refer to (environment maps).

use lightlab_core::Rgb;
use std::path::Path;

/// The first RGB(A) layer of an OpenEXR file: width, height and linear texels row by row from the
/// top.
pub(crate) fn read_rgb_exr(path: &Path) -> Result<(usize, usize, Vec<Rgb>), String> {
    use exr::prelude::*;
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("exr") => {}
        _ => {
            return Err(format!(
                "{}: environment maps are read from OpenEXR files (.exr); convert it first",
                path.display()
            ));
        }
    }
    if !path.is_file() {
        return Err(format!("image file {} does not exist", path.display()));
    }
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
