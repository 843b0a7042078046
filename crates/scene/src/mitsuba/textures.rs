//! Mitsuba texture plugins (`bitmap`, `checkerboard`) as Lightlab textures, each element imported
//! once however often it is referenced. Their lookups follow Mitsuba's (see
//! `lightlab_materials::Texture`); `to_uv` keeps its full 2D affine part (Mitsuba applies the
//! 4 × 4 matrix's x and y rows to (u, v, ·, 1)).

use super::object::Object;
use super::xml::Element;
use super::{Once, Refs};
use crate::SceneError;
use crate::desc::{ColourDesc, FilterDesc, TextureDesc, WrapDesc};

/// The scene's textures. Bitmap file names stay relative to the scene file (in directory `base`),
/// as the loader reads them.
pub(crate) struct Textures {
    pub once: Once<TextureDesc>,
    pub base: std::path::PathBuf,
}

impl Textures {
    /// The name of the texture element `el` (imported on first use).
    pub fn add(&mut self, el: &Element) -> Result<String, SceneError> {
        let base = &self.base;
        self.once.add(el, "texture", || texture(el, base))
    }
}

/// Colour parameter `name` of `o`: a constant, or a nested `<texture name>` or `<ref name id>`
/// naming one.
pub(crate) fn colour(
    o: &Object,
    name: &str,
    refs: &Refs,
    textures: &mut Textures,
) -> Result<Option<ColourDesc>, SceneError> {
    match o.nested_named(name, &["texture", "ref"]) {
        Some(el) => {
            let el = refs.resolve(el, "texture")?;
            Ok(Some(ColourDesc::Texture(textures.add(el)?)))
        }
        None => Ok(o.color(name)?.map(ColourDesc::Constant)),
    }
}

fn texture(el: &Element, base: &std::path::Path) -> Result<TextureDesc, SceneError> {
    let o = Object::new(el)?;
    let to_uv = match o.transform("to_uv")? {
        Some(m) => {
            let m = m.to_cols_array_2d();
            // m[column][row]: u′ = m00·u + m01·v + m03, v′ = m10·u + m11·v + m13.
            let row = |r: usize| [m[0][r] as f32, m[1][r] as f32, m[3][r] as f32];
            Some([row(0), row(1)])
        }
        None => None,
    };
    let t = match o.ty {
        "bitmap" => {
            let file = o
                .string("filename")?
                .ok_or_else(|| o.error(format!("{} needs a filename", o.describe())))?;
            super::existing(&o, base, file)?;
            let filter = match o.string("filter_type")?.unwrap_or("bilinear") {
                "bilinear" => FilterDesc::Bilinear,
                "nearest" => FilterDesc::Nearest,
                other => {
                    return Err(o.error(format!(
                        "filter_type \"{other}\" is not Mitsuba's (bilinear, nearest)"
                    )));
                }
            };
            let wrap = match o.string("wrap_mode")?.unwrap_or("repeat") {
                "repeat" => WrapDesc::Repeat,
                "mirror" => WrapDesc::Mirror,
                "clamp" => WrapDesc::Clamp,
                other => {
                    return Err(o.error(format!(
                        "wrap_mode \"{other}\" is not Mitsuba's (repeat, mirror, clamp)"
                    )));
                }
            };
            let raw = o.boolean("raw", false)?;
            // Storage precision and a lookup acceleration structure: neither changes a value
            // beyond rounding.
            o.string("format")?;
            o.boolean("accel", true)?;
            TextureDesc::Bitmap {
                file: file.to_string(),
                filter,
                wrap,
                raw,
                scale: (1.0, 1.0),
                offset: (0.0, 0.0),
                to_uv,
            }
        }
        "checkerboard" => TextureDesc::Checkerboard {
            color0: o.color("color0")?.unwrap_or(lightlab_core::Rgb::splat(0.4)),
            color1: o.color("color1")?.unwrap_or(lightlab_core::Rgb::splat(0.2)),
            scale: (1.0, 1.0),
            offset: (0.0, 0.0),
            to_uv,
        },
        other => {
            return Err(o.error(format!(
                "texture type '{other}' is not imported (supported: bitmap, checkerboard)"
            )));
        }
    };
    o.finish()?;
    t.check()
        .map_err(|m| o.error(format!("{}: {m}", o.describe())))?;
    Ok(t)
}
