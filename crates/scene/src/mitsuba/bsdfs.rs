//! Mitsuba BSDF plugins as Lightlab materials, with Mitsuba's defaults and its sidedness: reflecting
//! BSDFs are one-sided (black from behind) unless wrapped in `twosided`; dielectrics are two-sided.

use super::Refs;
use super::object::Object;
use super::presets::{CONDUCTORS, DIELECTRICS};
use super::textures::{Textures, colour};
use super::xml::Element;
use crate::SceneError;
use crate::desc::{ColourDesc, MaterialDesc, MaterialRaw, Microfacets, Roughness};
use lightlab_core::Rgb;

/// The material of a `<bsdf>` element (resolving a nested `twosided`).
pub(crate) fn material(
    el: &Element,
    refs: &Refs,
    textures: &mut Textures,
) -> Result<MaterialDesc, SceneError> {
    let o = Object::new(el)?;
    let (raw, one_sided) = match o.ty {
        "twosided" => {
            let inner = o.nested(&["bsdf", "ref"]);
            let [inner] = inner[..] else {
                return Err(o.error(format!(
                    "{} with {} nested BSDFs: Lightlab imports twosided with one BSDF (the same \
                     on both sides)",
                    o.describe(),
                    inner.len()
                )));
            };
            let inner = refs.resolve(inner, "bsdf")?;
            o.finish()?;
            let m = material(inner, refs, textures)?;
            return Ok(MaterialDesc {
                one_sided: false,
                ..m
            });
        }
        "diffuse" => (
            MaterialRaw::Diffuse {
                albedo: colour(&o, "reflectance", refs, textures)?
                    .unwrap_or(ColourDesc::Constant(Rgb::splat(0.5))),
            },
            true,
        ),
        "conductor" => {
            let (eta, k) = complex_ior(&o)?;
            let raw = match (eta, k) {
                // Mitsuba's material "none": a perfect mirror scaled by specular_reflectance.
                (None, _) => MaterialRaw::Mirror {
                    reflectance: colour(&o, "specular_reflectance", refs, textures)?
                        .unwrap_or(ColourDesc::Constant(Rgb::WHITE)),
                },
                (Some(eta), k) => {
                    unit_scale(&o)?;
                    MaterialRaw::Conductor { eta, k }
                }
            };
            (raw, true)
        }
        "roughconductor" => {
            let (roughness, distribution) = roughness(&o)?;
            let (eta, k) = complex_ior(&o)?;
            unit_scale(&o)?;
            (
                MaterialRaw::RoughConductor {
                    roughness,
                    eta: eta.unwrap_or(Rgb::BLACK),
                    k,
                    distribution,
                },
                true,
            )
        }
        "dielectric" => {
            let ior = relative_ior(&o, "bk7")?;
            unit_scales(&o)?;
            (MaterialRaw::Dielectric { ior }, false)
        }
        "thindielectric" => {
            let ior = relative_ior(&o, "bk7")?;
            unit_scales(&o)?;
            (MaterialRaw::ThinDielectric { ior }, false)
        }
        "roughdielectric" => {
            let (roughness, distribution) = roughness(&o)?;
            let ior = relative_ior(&o, "bk7")?;
            unit_scales(&o)?;
            (
                MaterialRaw::RoughDielectric {
                    roughness,
                    ior,
                    distribution,
                },
                false,
            )
        }
        "plastic" => {
            let ior = relative_ior(&o, "polypropylene")?;
            (
                MaterialRaw::Plastic {
                    kd: colour(&o, "diffuse_reflectance", refs, textures)?
                        .unwrap_or(ColourDesc::Constant(Rgb::splat(0.5))),
                    ks: colour(&o, "specular_reflectance", refs, textures)?
                        .unwrap_or(ColourDesc::Constant(Rgb::WHITE)),
                    ior,
                    nonlinear: o.boolean("nonlinear", false)?,
                },
                true,
            )
        }
        "roughplastic" => {
            let (roughness, distribution) = roughness(&o)?;
            let ior = relative_ior(&o, "polypropylene")?;
            (
                MaterialRaw::RoughPlastic {
                    kd: colour(&o, "diffuse_reflectance", refs, textures)?
                        .unwrap_or(ColourDesc::Constant(Rgb::splat(0.5))),
                    ks: colour(&o, "specular_reflectance", refs, textures)?
                        .unwrap_or(ColourDesc::Constant(Rgb::WHITE)),
                    roughness,
                    ior,
                    distribution,
                    nonlinear: o.boolean("nonlinear", false)?,
                },
                true,
            )
        }
        other => {
            return Err(o.error(format!(
                "BSDF type '{other}' is not imported (supported: diffuse, conductor, \
                 roughconductor, dielectric, thindielectric, roughdielectric, plastic, \
                 roughplastic, twosided)"
            )));
        }
    };
    o.finish()?;
    let mut m =
        MaterialDesc::try_from(raw).map_err(|e| o.error(format!("{}: {e}", o.describe())))?;
    m.one_sided = one_sided;
    Ok(m)
}

/// η and k of a conductor: `material` (a preset name, default "none") or `eta` and `k` colours.
/// `None` for η means Mitsuba's "none" (η = 0, k = 1: every channel reflects fully).
fn complex_ior(o: &Object) -> Result<(Option<Rgb>, Rgb), SceneError> {
    let (eta, k) = (o.color("eta")?, o.color("k")?);
    match o.string("material")? {
        Some(name) if eta.is_some() || k.is_some() => Err(o.error(format!(
            "{} gives both material=\"{name}\" and eta/k: give one",
            o.describe()
        ))),
        Some("none") => Ok((None, Rgb::WHITE)),
        Some(name) => CONDUCTORS
            .iter()
            .find(|(n, ..)| *n == name)
            .map(|&(_, eta, k)| (Some(eta), k))
            .ok_or_else(|| {
                o.error(format!(
                    "unknown conductor material \"{name}\" (Mitsuba's presets: none, {})",
                    CONDUCTORS
                        .iter()
                        .map(|(n, ..)| *n)
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            }),
        None => match (eta, k) {
            (None, None) => Ok((None, Rgb::WHITE)),
            (eta, k) => Ok((Some(eta.unwrap_or(Rgb::BLACK)), k.unwrap_or(Rgb::WHITE))),
        },
    }
}

/// The microfacet distribution (`beckmann`, Mitsuba's default, or `ggx`) and its roughness from
/// `alpha` or `alpha_u`/`alpha_v` (default 0.1, Mitsuba's).
fn roughness(o: &Object) -> Result<(Roughness, Microfacets), SceneError> {
    let distribution = match o.string("distribution")?.unwrap_or("beckmann") {
        "ggx" => Microfacets::Ggx,
        "beckmann" => Microfacets::Beckmann,
        d => {
            return Err(o.error(format!(
                "unknown microfacet distribution '{d}' (beckmann or ggx)"
            )));
        }
    };
    // The flag changes only how Mitsuba samples normals, not the BSDF.
    o.boolean("sample_visible", true)?;
    let alpha = o.float("alpha")?;
    let (u, v) = (o.float("alpha_u")?, o.float("alpha_v")?);
    let r = match (alpha, u, v) {
        (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
            return Err(o.error("give either alpha or alpha_u and alpha_v, not both"));
        }
        (Some(a), None, None) => Roughness::Isotropic(a as f32),
        (None, None, None) => Roughness::Isotropic(0.1),
        (None, Some(u), Some(v)) if u == v => Roughness::Isotropic(u as f32),
        // α_u along ∂p/∂u, which every imported shape takes from Mitsuba's own parameterisation.
        (None, Some(u), Some(v)) => Roughness::Anisotropic(u as f32, v as f32),
        (None, _, _) => return Err(o.error("alpha_u and alpha_v must be given together")),
    };
    Ok((r, distribution))
}

/// `int_ior / ext_ior`, each a number or one of Mitsuba's named media (defaults `int_default` and
/// air).
fn relative_ior(o: &Object, int_default: &str) -> Result<f32, SceneError> {
    let ior = |name: &str, default: &str| -> Result<f64, SceneError> {
        if matches!(o.tag_of(name), Some("float" | "integer"))
            && let Some(x) = o.float(name)?
        {
            return Ok(x);
        }
        let preset = o.string(name)?.unwrap_or(default);
        DIELECTRICS
            .iter()
            .find(|(n, _)| *n == preset)
            .map(|&(_, v)| v as f64)
            .ok_or_else(|| {
                o.error(format!(
                    "{name}: unknown medium \"{preset}\" (give a number or one of: {})",
                    DIELECTRICS
                        .iter()
                        .map(|(n, _)| *n)
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })
    };
    let (int, ext) = (ior("int_ior", int_default)?, ior("ext_ior", "air")?);
    if !(int > 0.0 && ext > 0.0) {
        return Err(o.error(format!(
            "int_ior and ext_ior must be > 0, got {int} and {ext}"
        )));
    }
    Ok((int / ext) as f32)
}

/// Lightlab's Fresnel conductors have no extra scale factor: `specular_reflectance` must be 1.
fn unit_scale(o: &Object) -> Result<(), SceneError> {
    match o.color("specular_reflectance")? {
        Some(c) if c != Rgb::WHITE => Err(o.error(format!(
            "{}: specular_reflectance ≠ 1 with a Fresnel conductor is not imported",
            o.describe()
        ))),
        _ => Ok(()),
    }
}

/// Dielectrics: `specular_reflectance` and `specular_transmittance` (non-physical scales) must be 1.
fn unit_scales(o: &Object) -> Result<(), SceneError> {
    for name in ["specular_reflectance", "specular_transmittance"] {
        if let Some(c) = o.color(name)?
            && c != Rgb::WHITE
        {
            return Err(o.error(format!(
                "{}: {name} ≠ 1 (a non-physical scale) is not imported",
                o.describe()
            )));
        }
    }
    Ok(())
}
