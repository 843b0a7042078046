//! From texture and material descriptions to the renderer's [`Texture`]s and [`Material`]s:
//! images read and decoded, texture names resolved to the slots they fill, and textured
//! reflectances checked against energy conservation over every value the texture can take.

use crate::desc::{ColourDesc, FilterDesc, MaterialDesc, MaterialRaw, TextureDesc, WrapDesc};
use glam::{Affine2, Vec2};
use lightlab_materials::{Bitmap, Filter, Material, Pattern, Texture, TextureSlots, Wrap};
use std::path::Path;

/// The texture `t` describes, its image read relative to `base`; on error (text to locate,
/// message).
pub(crate) fn texture(t: &TextureDesc, base: &Path) -> Result<Texture, (String, String)> {
    t.check().map_err(|m| (String::new(), m))?;
    let to_uv = match t.placement() {
        (_, _, Some([[a, b, c], [d, e, f]])) => Affine2::from_cols_array(&[a, d, b, e, c, f]),
        (scale, offset, None) => Affine2::from_scale_angle_translation(
            Vec2::new(scale.0, scale.1),
            0.0,
            Vec2::new(offset.0, offset.1),
        ),
    };
    Ok(match t {
        TextureDesc::Bitmap {
            file,
            filter,
            wrap,
            raw,
            ..
        } => {
            let needle = format!("\"{file}\"");
            let (w, h, texels) = crate::image::read_rgb_image(&base.join(file), *raw)
                .map_err(|m| (needle.clone(), m))?;
            if let Some(i) = texels.iter().position(|t| !t.is_finite()) {
                return Err((
                    needle,
                    format!("{file}: texel ({}, {}) is not finite", i % w, i / w),
                ));
            }
            let filter = match filter {
                FilterDesc::Nearest => Filter::Nearest,
                FilterDesc::Bilinear => Filter::Bilinear,
            };
            let wrap = match wrap {
                WrapDesc::Repeat => Wrap::Repeat,
                WrapDesc::Mirror => Wrap::Mirror,
                WrapDesc::Clamp => Wrap::Clamp,
            };
            let bitmap = Bitmap::new(w, h, texels, filter, wrap).map_err(|m| (needle, m))?;
            Texture {
                pattern: Pattern::Bitmap(bitmap),
                to_uv,
            }
        }
        TextureDesc::Checkerboard { color0, color1, .. } => Texture {
            pattern: Pattern::Checkerboard {
                color0: *color0,
                color1: *color1,
            },
            to_uv,
        },
    })
}

/// The material `m` describes, its texture names resolved in `names` (parallel to `textures`);
/// on error (text to locate, message).
pub(crate) fn material(
    m: &MaterialDesc,
    names: &[&str],
    textures: &[Texture],
) -> Result<Material, (String, String)> {
    // A texture colour's id, with its largest and smallest values.
    let slot = |what: &str, c: &ColourDesc| -> Result<Option<(u32, f32)>, (String, String)> {
        let ColourDesc::Texture(name) = c else {
            return Ok(None);
        };
        let needle = format!("\"{name}\"");
        let i = names.iter().position(|n| n == name).ok_or_else(|| {
            let known = if names.is_empty() {
                "none are defined".to_string()
            } else {
                names.join(", ")
            };
            (
                needle.clone(),
                format!("{what} names texture \"{name}\", which is not in `textures` ({known})"),
            )
        })?;
        let t = &textures[i];
        let (lo, hi) = (t.min_value(), t.max_value());
        if !(lo >= 0.0 && hi <= 1.0) {
            return Err((
                needle,
                format!(
                    "{what} is a reflectance, so its texture's values must lie in [0, 1]; \
                     \"{name}\" ranges over [{lo}, {hi}]"
                ),
            ));
        }
        Ok(Some((i as u32, hi)))
    };
    let id = |s: Option<(u32, f32)>| s.map(|(i, _)| i);
    let textures = match &m.raw {
        MaterialRaw::Diffuse { albedo: c } => TextureSlots {
            reflectance: id(slot("Diffuse albedo", c)?),
            specular: None,
        },
        MaterialRaw::Mirror { reflectance: c } => TextureSlots {
            reflectance: id(slot("Mirror reflectance", c)?),
            specular: None,
        },
        MaterialRaw::Plastic { kd, ks, .. } => TextureSlots {
            reflectance: id(slot("Plastic kd", kd)?),
            specular: id(slot("Plastic ks", ks)?),
        },
        MaterialRaw::RoughPlastic { kd, ks, .. } => TextureSlots {
            reflectance: id(slot("RoughPlastic kd", kd)?),
            specular: id(slot("RoughPlastic ks", ks)?),
        },
        MaterialRaw::Phong { kd, ks, .. } => {
            let (d, s) = (slot("Phong kd", kd)?, slot("Phong ks", ks)?);
            let largest = |c: &ColourDesc, s: Option<(u32, f32)>| {
                s.map_or_else(|| c.constant().map_or(0.0, |c| c.max_component()), |s| s.1)
            };
            if (d.is_some() || s.is_some()) && largest(kd, d) + largest(ks, s) > 1.0 {
                let needle = match (kd, ks) {
                    (ColourDesc::Texture(n), _) | (_, ColourDesc::Texture(n)) => format!("\"{n}\""),
                    _ => "Phong".into(),
                };
                return Err((
                    needle,
                    "Phong kd + ks must be ≤ 1 for energy conservation, and the largest values \
                     of its textured kd and ks can sum to more"
                        .into(),
                ));
            }
            TextureSlots {
                reflectance: id(d),
                specular: id(s),
            }
        }
        _ => TextureSlots::NONE,
    };
    Ok(Material {
        bsdf: crate::load::bsdf(m),
        one_sided: m.one_sided,
        textures,
    })
}
