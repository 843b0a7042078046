//! Images as researchers use them: linear float OpenEXR with named layers (one EXR part per layer,
//! channels R, G, B), and a tone-mapped sRGB PNG preview.

use crate::atomic::write_atomic_with;
use lightlab_integrators::{Film, RenderOutput};
use std::path::Path;

/// A named RGB image, row-major.
#[derive(Clone, Debug)]
pub struct RgbLayer {
    pub name: String,
    pub pixels: Vec<[f32; 3]>,
}

#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{path}: {message}")]
    Exr { path: String, message: String },
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
}

/// The layers every render writes: `radiance` (pixel means) and `variance` (estimated variance of each
/// pixel mean, s²/n, per channel).
pub fn film_layers(film: &Film) -> Vec<RgbLayer> {
    let f = |v: [f64; 3]| v.map(|x| x as f32);
    vec![
        RgbLayer {
            name: "radiance".into(),
            pixels: film.pixels.iter().map(|p| f(p.mean())).collect(),
        },
        RgbLayer {
            name: "variance".into(),
            pixels: film
                .pixels
                .iter()
                .map(|p| f(p.variance_of_mean()))
                .collect(),
        },
    ]
}

/// The layers of a render: the full image's `radiance` and `variance`, then each path-class or
/// bounce layer the integrator wrote as `<name>` and `<name>.variance`.
pub fn output_layers(out: &RenderOutput) -> Vec<RgbLayer> {
    let mut layers = film_layers(&out.film);
    for (name, film) in &out.layers {
        let [mean, variance] = <[RgbLayer; 2]>::try_from(film_layers(film)).expect("two layers");
        layers.push(RgbLayer {
            name: name.clone(),
            pixels: mean.pixels,
        });
        layers.push(RgbLayer {
            name: format!("{name}.variance"),
            pixels: variance.pixels,
        });
    }
    layers
}

/// Per layer, the values the 32-bit float file cannot hold: the film keeps f64, and a finite
/// value beyond f32's range (3.4·10³⁸) — a variance, the square of a radiance above 1.8·10¹⁹, as a
/// point light 10⁻⁵ from a surface gives — is written as an infinity. Layers without any are left
/// out.
pub fn f32_overflows(layers: &[RgbLayer]) -> Vec<(String, usize)> {
    layers
        .iter()
        .map(|l| {
            let n = l.pixels.iter().flatten().filter(|v| !v.is_finite()).count();
            (l.name.clone(), n)
        })
        .filter(|&(_, n)| n > 0)
        .collect()
}

/// Writes the layers as a multi-part OpenEXR file, atomically, ZIP-compressed 32-bit float.
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    layers: &[RgbLayer],
) -> Result<(), ImageError> {
    use exr::prelude::*;
    let size = Vec2(width as usize, height as usize);
    let parts: Vec<Layer<AnyChannels<FlatSamples>>> = layers
        .iter()
        .map(|l| {
            let channel = |name: &str, c: usize| {
                AnyChannel::new(
                    name,
                    FlatSamples::F32(l.pixels.iter().map(|p| p[c]).collect()),
                )
            };
            Layer::new(
                size,
                LayerAttributes::named(l.name.as_str()),
                Encoding::SMALL_LOSSLESS,
                AnyChannels::sort(smallvec::smallvec![
                    channel("R", 0),
                    channel("G", 1),
                    channel("B", 2)
                ]),
            )
        })
        .collect();
    let image = Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions(size)),
        parts,
    );
    write_atomic_with(path, |tmp| {
        image.write().to_file(tmp).map_err(std::io::Error::other)
    })
    .map_err(|e| ImageError::Exr {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}

/// Reads every RGB layer of an OpenEXR file: (width, height, layers). A layer is a set of channels
/// `R`, `G`, `B` with a common prefix (`radiance.R`, or no prefix) in one part; its name is the
/// part's name and the prefix joined by a dot, either alone when the other is empty — so
/// Lightlab's multi-part files, single-part files with plain `R, G, B` (Mitsuba 3, pbrt-v4; the
/// unnamed layer `""`) and single-part multi-layer files all read. Other channels (`A`, depth) are
/// ignored.
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<RgbLayer>), ImageError> {
    use exr::prelude::*;
    let err = |message: String| ImageError::Exr {
        path: path.display().to_string(),
        message,
    };
    lightlab_scene::check_exr_size(path).map_err(err)?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(|e| {
            // The exr crate's own message for a file of another kind ("reference to missing
            // bytes") does not say so: OpenEXR files begin with the magic number 76 2f 31 01.
            let mut magic = [0u8; 4];
            let other_kind = std::fs::File::open(path).is_ok_and(|mut f| {
                std::io::Read::read_exact(&mut f, &mut magic).is_err()
                    || magic != [0x76, 0x2f, 0x31, 0x01]
            });
            err(if !other_kind {
                e.to_string()
            } else {
                format!("not an OpenEXR file (it does not begin with OpenEXR's magic number; {e})")
            })
        })?;
    let mut size = None;
    let mut out = Vec::new();
    for layer in &image.layer_data {
        let part = layer
            .attributes
            .layer_name
            .as_ref()
            .map_or_else(String::new, |n| n.to_string());
        let channels = &layer.channel_data.list;
        let split = |name: &str| match name.rfind('.') {
            Some(i) => (name[..i].to_string(), name[i + 1..].to_string()),
            None => (String::new(), name.to_string()),
        };
        let mut prefixes: Vec<String> = channels
            .iter()
            .map(|c| split(&c.name.to_string()).0)
            .collect();
        prefixes.sort();
        prefixes.dedup();
        for prefix in prefixes {
            let find = |n: &str| {
                channels.iter().find(|c| {
                    let (p, base) = split(&c.name.to_string());
                    p == prefix && base.eq_ignore_ascii_case(n)
                })
            };
            let (Some(r), Some(g), Some(b)) = (find("R"), find("G"), find("B")) else {
                continue;
            };
            let (r, g, b) = (
                r.sample_data.values_as_f32().collect::<Vec<_>>(),
                g.sample_data.values_as_f32().collect::<Vec<_>>(),
                b.sample_data.values_as_f32().collect::<Vec<_>>(),
            );
            let name = match (part.is_empty(), prefix.is_empty()) {
                (_, true) => part.clone(),
                (true, false) => prefix.clone(),
                (false, false) => format!("{part}.{prefix}"),
            };
            size = Some((layer.size.0 as u32, layer.size.1 as u32));
            out.push(RgbLayer {
                name,
                pixels: (0..r.len()).map(|i| [r[i], g[i], b[i]]).collect(),
            });
        }
    }
    let (w, h) = size.ok_or_else(|| err("no layer with R, G and B channels".into()))?;
    Ok((w, h, out))
}

/// sRGB opto-electronic transfer function (IEC 61966-2-1).
fn srgb_encode(x: f32) -> f32 {
    if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// 8-bit sRGB of linear values scaled by 2^`exposure` and clipped to [0, 1] (RGB, tightly packed);
/// non-finite pixels are magenta.
pub fn to_srgb8(pixels: &[[f32; 3]], exposure: f32) -> Vec<u8> {
    let scale = exposure.exp2();
    let mut data = Vec::with_capacity(pixels.len() * 3);
    for p in pixels {
        if p.iter().all(|x| x.is_finite()) {
            data.extend(p.map(|x| (srgb_encode((x * scale).clamp(0.0, 1.0)) * 255.0 + 0.5) as u8));
        } else {
            data.extend([255, 0, 255]);
        }
    }
    data
}

/// Writes an 8-bit sRGB preview: linear values scaled by 2^`exposure`, clipped to [0, 1], encoded
/// with the sRGB curve. Non-finite values show as magenta so they cannot hide.
pub fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[[f32; 3]],
    exposure: f32,
) -> Result<(), ImageError> {
    let data = to_srgb8(pixels, exposure);
    let io = |source: std::io::Error| ImageError::Io {
        path: path.display().to_string(),
        source,
    };
    write_atomic_with(path, |tmp| {
        let file = std::io::BufWriter::new(std::fs::File::create(tmp)?);
        let mut enc = png::Encoder::new(file, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut w = enc.write_header().map_err(std::io::Error::other)?;
        w.write_image_data(&data).map_err(std::io::Error::other)?;
        w.finish().map_err(std::io::Error::other)
    })
    .map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_layers_round_trip_bit_exact() {
        let dir = std::env::temp_dir().join(format!("lightlab-exr-{}", std::process::id()));
        let path = dir.join("t.exr");
        let (w, h) = (5u32, 3u32);
        let a: Vec<[f32; 3]> = (0..15)
            .map(|i| [i as f32 * 0.1, 1e-20 * i as f32, 3e4 + i as f32])
            .collect();
        let b: Vec<[f32; 3]> = (0..15).map(|i| [0.5, i as f32, -1.0]).collect();
        write_exr(
            &path,
            w,
            h,
            &[
                RgbLayer {
                    name: "radiance".into(),
                    pixels: a.clone(),
                },
                RgbLayer {
                    name: "variance".into(),
                    pixels: b.clone(),
                },
            ],
        )
        .unwrap();
        let (rw, rh, layers) = read_exr(&path).unwrap();
        assert_eq!((rw, rh), (w, h));
        assert_eq!(layers.len(), 2);
        assert_eq!(layers[0].name, "radiance");
        assert_eq!(layers[0].pixels, a);
        assert_eq!(layers[1].name, "variance");
        assert_eq!(layers[1].pixels, b);
        write_png(&dir.join("t.png"), w, h, &a, 0.0).unwrap();
        assert!(dir.join("t.png").metadata().unwrap().len() > 0);
        std::fs::remove_dir_all(dir).unwrap();
    }
}
