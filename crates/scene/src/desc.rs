//! The RON scene format: serde types that map one-to-one onto the file, each field documented with its
//! meaning and default. Values are checked as they are read (`try_from`), so a bad value is reported by
//! the RON parser with the file's line and column; references between parts (material names, mesh
//! files) are checked when the scene is built (see `load.rs`).
//!
//! Units: lengths in scene units, angles in degrees, radiance in W·sr⁻¹·m⁻² and intensity in W·sr⁻¹
//! per RGB channel. Positions are read in f64 (the loader moves the scene to its own centre before
//! anything is rounded to f32), directions and sizes in f32.

use glam::{DVec3, Vec3};
use lightlab_core::Rgb;
use serde::{Deserialize, Deserializer, de};

/// A whole scene file: `Scene(camera: ..., materials: {...}, shapes: [...], lights: [...])`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Scene")]
pub struct SceneDesc {
    /// The camera. Required.
    pub camera: CameraDesc,
    /// Named materials, `{"white": Diffuse(albedo: (0.7, 0.7, 0.7)), ...}`. Names must be unique.
    /// Default: none.
    #[serde(default, deserialize_with = "unique_map")]
    pub materials: Vec<(String, MaterialDesc)>,
    /// Named textures that materials' colours can name instead of a constant,
    /// `{"tiles": Checkerboard(color0: (0.1, 0.1, 0.1), color1: (0.8, 0.8, 0.8), scale: (8, 8))}`.
    /// Default: none.
    #[serde(default, deserialize_with = "unique_map")]
    pub textures: Vec<(String, TextureDesc)>,
    /// Surfaces. Default: none.
    #[serde(default)]
    pub shapes: Vec<ShapeDesc>,
    /// Lights that are not surfaces (point, spot, environment). Area lights are shapes with an
    /// `emission`. Default: none.
    #[serde(default)]
    pub lights: Vec<LightDesc>,
}

impl SceneDesc {
    /// The files the scene reads besides itself, as written (relative to the scene file): meshes,
    /// texture images and the environment map — what a cache of its renders must hash too.
    pub fn input_files(&self) -> Vec<&str> {
        let meshes = self.shapes.iter().filter_map(|s| match &s.geometry.0 {
            GeometryRaw::Obj { file, .. } => Some(file.as_str()),
            _ => None,
        });
        let textures = self.textures.iter().filter_map(|(_, t)| match t {
            TextureDesc::Bitmap { file, .. } => Some(file.as_str()),
            _ => None,
        });
        let maps = self.lights.iter().filter_map(|l| match &l.0 {
            LightRaw::EnvironmentMap { file, .. } => Some(file.as_str()),
            _ => None,
        });
        meshes.chain(textures).chain(maps).collect()
    }
}

/// `Camera(eye: (0, 0, 3.9), target: (0, 0, 0), fov: 39.3, resolution: (256, 256))`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Camera", try_from = "CameraRaw")]
pub struct CameraDesc {
    pub eye: DVec3,
    pub target: DVec3,
    pub up: Vec3,
    pub fov: f32,
    pub resolution: (u32, u32),
    pub lens: Lens,
    /// The image mirrored left to right (a sensor transform with negative determinant; set by the
    /// Mitsuba importer). RON cameras are never mirrored.
    pub mirrored: bool,
    /// Shutter open and close times.
    pub shutter: (f32, f32),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Camera")]
pub(crate) struct CameraRaw {
    /// Position of the pinhole (or the lens centre). Required.
    pub eye: DVec3,
    /// A point the camera looks at. Required.
    pub target: DVec3,
    /// Up direction; need not be perpendicular to the view direction. Default (0, 1, 0).
    #[serde(default = "default_up")]
    pub up: Vec3,
    /// Full field of view in degrees along the smaller image axis, in (0, 180). Required.
    pub fov: f32,
    /// Image width and height in pixels, each ≥ 1. Required.
    pub resolution: (u32, u32),
    /// `Pinhole` or `ThinLens(aperture_radius: r, focus_distance: d)`. Default `Pinhole`.
    #[serde(default)]
    pub lens: Lens,
    /// `(open, close)`: every camera sample (and light path) gets a time uniform in the interval,
    /// where shapes with a `motion` are then. Equal times (the default `(0, 0)`) take an instant:
    /// no motion blur, and no sample dimension is spent on time.
    #[serde(default)]
    pub shutter: (f32, f32),
}

fn default_up() -> Vec3 {
    Vec3::Y
}

/// The camera's lens model. Pixels use a box filter: a sample counts only in its own pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Lens {
    /// An ideal pinhole: everything in focus.
    #[default]
    Pinhole,
    /// A thin lens (Kolb et al. 1995; pbrt-v4 §5.2.3): rays leave a disk of `aperture_radius`
    /// (≥ 10⁻¹⁵) and meet on the plane at `focus_distance` (in (0, 10²⁰]) along the view direction.
    ThinLens {
        aperture_radius: f32,
        focus_distance: f32,
    },
}

impl TryFrom<CameraRaw> for CameraDesc {
    type Error = String;
    fn try_from(c: CameraRaw) -> Result<Self, String> {
        // The eye is a position the renderer holds in f32 (the target only fixes a direction).
        single_precision_dvec("camera eye", c.eye)?;
        finite_dvec("camera target", c.target)?;
        finite_vec("camera up", c.up)?;
        let view = c.target - c.eye;
        if view == DVec3::ZERO || !view.is_finite() {
            return Err("camera eye and target coincide: the view direction is undefined".into());
        }
        // In f64 and scaled (`unit`): an up vector of (0, 1e-30, 0) or (0, 3e38, 3e38) under- or
        // overflows f32's squared length and was called zero or parallel.
        let up = if c.up == glam::Vec3::ZERO {
            DVec3::ZERO
        } else {
            unit(c.up.as_dvec3())
        };
        if unit(view).cross(up).length() < 1e-6 {
            return Err("camera up is zero or parallel to the view direction".into());
        }
        if !(c.fov >= MIN_FOV && c.fov < 180.0) {
            return Err(format!(
                "camera fov must be in [{MIN_FOV:e}, 180) degrees (narrower, the image plane's \
                 area 4·tan²(fov/2) that light tracing's importance divides by is not a normal \
                 f32), got {}",
                c.fov
            ));
        }
        let side = 1..=crate::MAX_RESOLUTION;
        if !side.contains(&c.resolution.0) || !side.contains(&c.resolution.1) {
            return Err(format!(
                "camera resolution must be 1…{} pixels in each axis, got {}×{}",
                crate::MAX_RESOLUTION,
                c.resolution.0,
                c.resolution.1
            ));
        }
        if let Lens::ThinLens {
            aperture_radius,
            focus_distance,
        } = c.lens
        {
            if !(aperture_radius >= MIN_APERTURE && aperture_radius.is_finite()) {
                return Err(format!(
                    "ThinLens aperture_radius must be ≥ {MIN_APERTURE:e} (smaller, the lens area \
                     underflows f32 and light tracing's connections to the lens are lost), got \
                     {aperture_radius}: use Pinhole for a pinhole"
                ));
            }
            if aperture_radius > MAX_APERTURE {
                return Err(format!(
                    "ThinLens aperture_radius must be at most {MAX_APERTURE:e} (shapes reach at \
                     most 1e9 from the scene's centre; at 1e20 the lens area overflows f32 and \
                     every camera ray is lost), got {aperture_radius}"
                ));
            }
            if !(focus_distance > 0.0 && focus_distance <= MAX_FOCUS) {
                return Err(format!(
                    "ThinLens focus_distance must be in (0, {MAX_FOCUS:e}] (shapes reach at most \
                     1e9 from the scene's centre, so a plane of focus farther than that is focus \
                     at infinity already), got {focus_distance}"
                ));
            }
            if aperture_radius / focus_distance > MAX_LENS_SLOPE {
                return Err(format!(
                    "ThinLens aperture_radius / focus_distance must be at most {MAX_LENS_SLOPE:e} \
                     (beyond, a lens ray's direction overflows f32 and every camera ray is lost), \
                     got {aperture_radius} / {focus_distance}"
                ));
            }
        }
        let (open, close) = c.shutter;
        if !(open.is_finite() && close.is_finite() && open <= close) {
            return Err(format!(
                "camera shutter must be (open, close) with finite open ≤ close, got ({open}, {close})"
            ));
        }
        if !(close - open).is_finite() {
            return Err(format!(
                "camera shutter ({open}, {close}) is longer than f32 holds (close − open \
                 overflows, and sample times would all fall at one end): shorten it"
            ));
        }
        Ok(CameraDesc {
            eye: c.eye,
            target: c.target,
            up: c.up,
            fov: c.fov,
            resolution: c.resolution,
            lens: c.lens,
            mirrored: false,
            shutter: c.shutter,
        })
    }
}

/// A surface material. Colours marked [`ColourDesc`] can vary over the surface with a texture; all
/// other parameters are constant.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, try_from = "MaterialRaw")]
pub struct MaterialDesc {
    pub raw: MaterialRaw,
    /// Black from behind (Mitsuba's convention for reflecting BSDFs; set by the Mitsuba importer).
    /// Every RON material scatters on both sides.
    pub one_sided: bool,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename = "Material")]
pub enum MaterialRaw {
    /// Lambertian reflection, `albedo` per channel in [0, 1]. Two-sided.
    Diffuse { albedo: ColourDesc },
    /// Perfect specular reflection scaled by `reflectance` in [0, 1]. Default reflectance (1, 1, 1).
    Mirror {
        #[serde(default = "white")]
        reflectance: ColourDesc,
    },
    /// Smooth metal: specular reflection weighted by the conductor Fresnel reflectance for the
    /// complex index of refraction `eta` + i·`k` per channel (eta ≥ 0, k ≥ 0, not both 0).
    Conductor { eta: Rgb, k: Rgb },
    /// A thin sheet of glass (a window pane): both faces' reflections summed, 2R/(1 + R), the rest
    /// transmitted without bending. `ior` of the sheet relative to its surroundings, > 0; default 1.5.
    ThinDielectric {
        #[serde(default = "glass_ior")]
        ior: f32,
    },
    /// Smooth dielectric interface (glass): Fresnel-weighted reflection and refraction. `ior` is the
    /// index of refraction inside relative to outside (the side the geometric normal points to), > 0.
    /// Default 1.5.
    Dielectric {
        #[serde(default = "glass_ior")]
        ior: f32,
    },
    /// Rough metal: microfacets (Walter et al. 2007) with complex index of refraction `eta` + i·`k`
    /// per channel (eta ≥ 0, k ≥ 0, not both 0). `distribution` `Ggx` (default; sampled by visible
    /// normals, Heitz 2018) or `Beckmann`.
    RoughConductor {
        roughness: Roughness,
        eta: Rgb,
        k: Rgb,
        #[serde(default)]
        distribution: Microfacets,
    },
    /// Rough glass: microfacet reflection and transmission (Walter et al. 2007). `ior` as for
    /// `Dielectric`, > 0 and at least 10⁻⁴ from 1; default 1.5. `distribution` as for
    /// `RoughConductor`.
    RoughDielectric {
        roughness: Roughness,
        #[serde(default = "glass_ior")]
        ior: f32,
        #[serde(default)]
        distribution: Microfacets,
    },
    /// Modified Phong (Lafortune and Willems 1994): diffuse `kd` plus a normalised cosⁿ lobe `ks` around
    /// the mirror direction, `exponent` n in [0, 10⁷]. Energy conservation requires kd + ks ≤ 1 per
    /// channel.
    Phong {
        kd: ColourDesc,
        ks: ColourDesc,
        exponent: f32,
    },
    /// Smooth plastic (Mitsuba 3's `plastic`): a Lambertian base of albedo `kd` in [0, 1] under a
    /// smooth dielectric coating of index `ior` relative to the outside (> 0; default 1.5), whose
    /// delta reflection is scaled by `ks` in [0, 1] (default (1, 1, 1), the physical coating).
    /// `nonlinear: true` lets the base's albedo enter every internal reflection, darkening and
    /// saturating colours; the default keeps kd's hue. Two-sided.
    Plastic {
        kd: ColourDesc,
        #[serde(default = "white")]
        ks: ColourDesc,
        #[serde(default = "glass_ior")]
        ior: f32,
        #[serde(default)]
        nonlinear: bool,
    },
    /// Rough plastic (Mitsuba 3's `roughplastic`): `Plastic` with a rough coating, whose
    /// microfacets have `roughness` `Isotropic(α)` (the coating's transmittance is tabulated over
    /// the polar angle alone, so anisotropic roughness is refused) and `distribution` as for
    /// `RoughConductor`. `ior` ≥ 10⁻¹⁸ and at least 10⁻⁴ from 1, default 1.5; `kd`, `ks`,
    /// `nonlinear` as for `Plastic`.
    /// Two-sided.
    RoughPlastic {
        kd: ColourDesc,
        #[serde(default = "white")]
        ks: ColourDesc,
        roughness: Roughness,
        #[serde(default = "glass_ior")]
        ior: f32,
        #[serde(default)]
        distribution: Microfacets,
        #[serde(default)]
        nonlinear: bool,
    },
}

/// A colour parameter: a constant `(r, g, b)`, or the name of a texture in the scene's `textures`
/// (`"tiles"`) whose value at each surface point replaces it.
#[derive(Clone, Debug, PartialEq)]
pub enum ColourDesc {
    Constant(Rgb),
    Texture(String),
}

impl ColourDesc {
    /// The constant, or `None` for a texture.
    pub fn constant(&self) -> Option<Rgb> {
        match self {
            ColourDesc::Constant(c) => Some(*c),
            ColourDesc::Texture(_) => None,
        }
    }
}

impl From<Rgb> for ColourDesc {
    fn from(c: Rgb) -> Self {
        ColourDesc::Constant(c)
    }
}

impl<'de> Deserialize<'de> for ColourDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> de::Visitor<'de> for V {
            type Value = ColourDesc;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a colour (r, g, b) or the name of a texture (\"name\")")
            }
            fn visit_str<E: de::Error>(self, name: &str) -> Result<ColourDesc, E> {
                Ok(ColourDesc::Texture(name.to_string()))
            }
            fn visit_seq<A: de::SeqAccess<'de>>(self, seq: A) -> Result<ColourDesc, A::Error> {
                Rgb::deserialize(de::value::SeqAccessDeserializer::new(seq))
                    .map(ColourDesc::Constant)
            }
        }
        d.deserialize_any(V)
    }
}

/// A texture: a bitmap image or a checkerboard, placed on a surface's (u, v) by
/// (u′, v′) = (u·scale.0 + offset.0, v·scale.1 + offset.1), or by a general affine map given as
/// `to_uv: ((a, b, c), (d, e, f))`, u′ = a·u + b·v + c, v′ = d·u + e·v + f (instead of scale and
/// offset; Mitsuba's `to_uv`). Image row 0 (the top) lies at v′ = 0
/// and the image covers [0, 1)² (Mitsuba 3's conventions). Surfaces' (u, v): meshes' own texture
/// coordinates (OBJ files' v flipped, as Mitsuba does), quads (0, 0) at `corner` to (1, 1) at the
/// opposite corner with u along `edge1`, each cuboid face likewise, spheres
/// (φ / 2π, θ / π) about their own z axis (θ = 0 at +z).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename = "Texture")]
pub enum TextureDesc {
    /// An image file, path relative to the scene file: PNG or JPEG (8 or 16 bits, sRGB-encoded
    /// unless `raw`), OpenEXR or Radiance HDR (linear). `filter` `Bilinear` (default) or
    /// `Nearest`; `wrap` `Repeat` (default), `Mirror` or `Clamp`; `raw: true` reads PNG/JPEG values
    /// as linear (for data such as roughness maps). The alpha channel is ignored.
    Bitmap {
        file: String,
        #[serde(default)]
        filter: FilterDesc,
        #[serde(default)]
        wrap: WrapDesc,
        #[serde(default)]
        raw: bool,
        #[serde(default = "unit_uv")]
        scale: (f32, f32),
        #[serde(default)]
        offset: (f32, f32),
        #[serde(default)]
        to_uv: Option<[[f32; 3]; 2]>,
    },
    /// `color0` and `color1` (each channel ≥ 0) in a 2 × 2 board per unit square of (u′, v′):
    /// `color0` where ⌊2u′⌋ + ⌊2v′⌋ is even. Defaults 0.4 and 0.2 grey (Mitsuba's).
    Checkerboard {
        #[serde(default = "grey40")]
        color0: Rgb,
        #[serde(default = "grey20")]
        color1: Rgb,
        #[serde(default = "unit_uv")]
        scale: (f32, f32),
        #[serde(default)]
        offset: (f32, f32),
        #[serde(default)]
        to_uv: Option<[[f32; 3]; 2]>,
    },
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename = "Filter")]
pub enum FilterDesc {
    Nearest,
    #[default]
    Bilinear,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename = "Wrap")]
pub enum WrapDesc {
    #[default]
    Repeat,
    Mirror,
    Clamp,
}

fn unit_uv() -> (f32, f32) {
    (1.0, 1.0)
}
fn grey40() -> Rgb {
    Rgb::splat(0.4)
}
fn grey20() -> Rgb {
    Rgb::splat(0.2)
}

/// A texture's scale, offset and optional `to_uv` matrix rows.
pub type Placement = ((f32, f32), (f32, f32), Option<[[f32; 3]; 2]>);

impl TextureDesc {
    /// Checks the values that need no file: finite placement, non-negative checker colours.
    pub fn check(&self) -> Result<(), String> {
        match self {
            TextureDesc::Bitmap { file, .. } if file.is_empty() => {
                return Err("Bitmap file name is empty".into());
            }
            TextureDesc::Checkerboard { color0, color1, .. } => {
                non_negative_rgb("Checkerboard color0", *color0)?;
                non_negative_rgb("Checkerboard color1", *color1)?;
            }
            _ => {}
        }
        let (scale, offset, to_uv) = self.placement();
        if to_uv.is_some() && (scale != (1.0, 1.0) || offset != (0.0, 0.0)) {
            return Err("give a texture either scale/offset or to_uv, not both".into());
        }
        let numbers = [scale.0, scale.1, offset.0, offset.1]
            .into_iter()
            .chain(to_uv.into_iter().flatten().flatten());
        if !numbers.into_iter().all(f32::is_finite) {
            return Err("texture scale, offset and to_uv must be finite".into());
        }
        Ok(())
    }

    /// The texture's (scale, offset, to_uv).
    pub fn placement(&self) -> Placement {
        match self {
            TextureDesc::Bitmap {
                scale,
                offset,
                to_uv,
                ..
            }
            | TextureDesc::Checkerboard {
                scale,
                offset,
                to_uv,
                ..
            } => (*scale, *offset, *to_uv),
        }
    }
}

/// The distribution of microfacet normals: `Ggx` (Trowbridge–Reitz, long tails) or `Beckmann`
/// (Gaussian slopes). Default `Ggx`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
pub enum Microfacets {
    #[default]
    Ggx,
    Beckmann,
}

/// GGX roughness α (the slope-space standard deviation scale; α = 0 is clamped to the smallest value
/// the BSDF supports). `Isotropic(α)` or `Anisotropic(αx, αy)` with αx along the surface's u tangent.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub enum Roughness {
    Isotropic(f32),
    Anisotropic(f32, f32),
}

fn white() -> ColourDesc {
    ColourDesc::Constant(Rgb::WHITE)
}
fn glass_ior() -> f32 {
    1.5
}

impl TryFrom<MaterialRaw> for MaterialDesc {
    type Error = String;
    fn try_from(m: MaterialRaw) -> Result<Self, String> {
        match &m {
            MaterialRaw::Diffuse { albedo } => unit_colour("Diffuse albedo", albedo)?,
            MaterialRaw::Mirror { reflectance } => unit_colour("Mirror reflectance", reflectance)?,
            MaterialRaw::Dielectric { ior } => positive("Dielectric ior", *ior)?,
            MaterialRaw::ThinDielectric { ior } => positive("ThinDielectric ior", *ior)?,
            MaterialRaw::Conductor { eta, k } => check_complex_ior("Conductor", *eta, *k)?,
            MaterialRaw::RoughConductor {
                roughness, eta, k, ..
            } => {
                check_roughness(*roughness)?;
                check_complex_ior("RoughConductor", *eta, *k)?;
            }
            MaterialRaw::RoughDielectric { roughness, ior, .. } => {
                check_roughness(*roughness)?;
                positive("RoughDielectric ior", *ior)?;
                near_one_ior("RoughDielectric", *ior)?;
            }
            MaterialRaw::Plastic { kd, ks, ior, .. } => {
                unit_colour("Plastic kd", kd)?;
                unit_colour("Plastic ks", ks)?;
                positive("Plastic ior", *ior)?;
            }
            MaterialRaw::RoughPlastic {
                kd,
                ks,
                roughness,
                ior,
                ..
            } => {
                unit_colour("RoughPlastic kd", kd)?;
                unit_colour("RoughPlastic ks", ks)?;
                check_roughness(*roughness)?;
                if let Roughness::Anisotropic(ax, ay) = roughness {
                    return Err(format!(
                        "RoughPlastic roughness must be Isotropic(α): its coating's transmittance \
                         depends on the polar angle alone; got Anisotropic({ax}, {ay})"
                    ));
                }
                positive("RoughPlastic ior", *ior)?;
                near_one_ior("RoughPlastic", *ior)?;
                if *ior < 1e-18 {
                    return Err(format!(
                        "RoughPlastic ior must be ≥ 1e-18: below, the coating's 1/η² overflows \
                         f32 and the base would render black; got {ior}"
                    ));
                }
            }
            MaterialRaw::Phong { kd, ks, exponent } => {
                unit_colour("Phong kd", kd)?;
                unit_colour("Phong ks", ks)?;
                // With textures, the loader checks the sum against their largest values.
                if let (Some(kd), Some(ks)) = (kd.constant(), ks.constant())
                    && (kd + ks).max_component() > 1.0
                {
                    return Err(format!(
                        "Phong kd + ks must be ≤ 1 per channel for energy conservation, got kd {} + ks {}",
                        fmt_rgb(kd),
                        fmt_rgb(ks)
                    ));
                }
                if !(*exponent >= 0.0 && *exponent <= MAX_PHONG_EXPONENT) {
                    return Err(format!(
                        "Phong exponent must be in [0, {MAX_PHONG_EXPONENT:e}] (beyond, the lobe \
                         is narrower than f32 directions resolve and its light is lost: use Mirror \
                         or Conductor for a mirror), got {exponent}"
                    ));
                }
            }
        }
        Ok(MaterialDesc {
            raw: m,
            one_sided: false,
        })
    }
}

/// The narrowest field of view, in degrees: 4·tan²(fov/2) = 7.6·10⁻¹⁷, a normal f32 (at 10⁻⁴⁴°
/// tan(fov/2) was 0 and BDPT's camera densities divided by it, −5.6 % without a warning).
const MIN_FOV: f32 = 1e-6;

/// The smallest thin-lens aperture radius: π r² stays far from f32's underflow (at 10⁻¹⁹ light
/// tracing lost 98 % of its connections to the lens, silently).
const MIN_APERTURE: f32 = 1e-15;

/// The farthest plane of focus.
const MAX_FOCUS: f32 = 1e20;

/// The widest thin-lens aperture radius: the scene's extent (π r² overflowed f32 at 10²⁰).
const MAX_APERTURE: f32 = 1e9;

/// The largest aperture_radius / focus_distance: a lens ray's direction dir − l/F (camera space)
/// and its squared length stay far inside f32 (at 10²⁰ every camera ray was non-finite).
const MAX_LENS_SLOPE: f32 = 1e12;

/// The largest Phong exponent: at 10⁷ a sphere's albedo is still the converged one; from about
/// 10⁹ on, a sampled direction's round trip through the shading frame moves cos α by 10⁻⁷ and
/// cosⁿα underflows, so the specular lobe is silently lost.
const MAX_PHONG_EXPONENT: f32 = 1e7;

/// A rough interface's index must differ from 1 by at least 10⁻⁴: nearer, the half vector
/// wo·ηo + wi·ηi cancels in f32 and refracted light is lost (−14 % of a sphere's albedo at
/// 1.0000001 and α = 1; correct at 1.0001). An index-matched interface has no microfacet
/// refraction at all.
fn near_one_ior(what: &str, ior: f32) -> Result<(), String> {
    if (ior - 1.0).abs() < 1e-4 {
        return Err(format!(
            "{what} ior must differ from 1 by at least 1e-4 (an index-matched rough interface \
             does not refract, and nearer to 1 f32 cannot resolve its half vectors), got {ior}"
        ));
    }
    Ok(())
}

/// η ≥ 0 and k ≥ 0 per channel, not both zero (η = 0 with k > 0 is a lossless reflector, R = 1).
fn check_complex_ior(what: &str, eta: Rgb, k: Rgb) -> Result<(), String> {
    for (e, k_c) in eta.to_array().into_iter().zip(k.to_array()) {
        if !(e >= 0.0 && e.is_finite() && k_c >= 0.0 && k_c.is_finite() && e + k_c > 0.0) {
            return Err(format!(
                "{what} eta and k must be ≥ 0 and finite per channel and not both 0, got eta {}, k {}",
                fmt_rgb(eta),
                fmt_rgb(k)
            ));
        }
    }
    Ok(())
}

fn check_roughness(r: Roughness) -> Result<(), String> {
    let (ax, ay) = match r {
        Roughness::Isotropic(a) => (a, a),
        Roughness::Anisotropic(ax, ay) => (ax, ay),
    };
    for a in [ax, ay] {
        if !(a >= 0.0 && a.is_finite()) {
            return Err(format!("roughness α must be ≥ 0 and finite, got {a}"));
        }
    }
    Ok(())
}

/// `Shape(geometry: Quad(...), material: "white")`, optionally emissive and transformed.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Shape", try_from = "ShapeRaw")]
pub struct ShapeDesc {
    pub geometry: GeometryDesc,
    pub material: String,
    pub emission: Option<EmissionDesc>,
    pub transform: TransformDesc,
    pub motion: Option<MotionDesc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Shape")]
struct ShapeRaw {
    /// The surface. Required.
    geometry: GeometryDesc,
    /// Name of an entry in `materials`. Required.
    material: String,
    /// Makes the shape an area light. Default: not emissive.
    #[serde(default)]
    emission: Option<EmissionDesc>,
    /// Applied to the geometry: scale, then rotations in order, then translation. Default: identity.
    #[serde(default)]
    transform: TransformDesc,
    /// Rigid motion over the camera's shutter, applied after `transform`. Default: at rest.
    #[serde(default)]
    motion: Option<MotionDesc>,
}

impl TryFrom<ShapeRaw> for ShapeDesc {
    type Error = String;
    fn try_from(s: ShapeRaw) -> Result<Self, String> {
        if s.emission.is_some() && s.geometry.local_area() == Some(0.0) {
            return Err("emissive shape has zero area: an area light needs a surface".into());
        }
        if s.emission.is_some() && s.motion.is_some() {
            return Err(
                "an emissive shape cannot move: light sampling and emission use emitters at rest"
                    .into(),
            );
        }
        if matches!(s.geometry.0, GeometryRaw::Sphere { .. }) {
            let v = s.transform.scale;
            if v.x != v.y || v.y != v.z {
                return Err(format!(
                    "a Sphere accepts only a uniform scale, got {}",
                    fmt3(v.as_dvec3())
                ));
            }
        }
        Ok(ShapeDesc {
            geometry: s.geometry,
            material: s.material,
            emission: s.emission,
            transform: s.transform,
            motion: s.motion,
        })
    }
}

/// `Motion(pivot: (0, 0.3, 0), keys: [Key(time: 0, translate: (-0.2, 0, 0)), Key(time: 1,
/// translate: (0.2, 0, 0), rotate: [(axis: (0, 0, 1), degrees: -60)])])`: keyframed rigid motion.
/// At time t a point x of the (transformed) shape is at R(t)·(x − pivot) + pivot + T(t), T
/// interpolated linearly and R by slerp (the shorter arc: split turns of 180° or more into more
/// keys) between the keys around t; before the first key and after the last the shape stays there.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Motion", try_from = "MotionRaw")]
pub struct MotionDesc {
    pub pivot: DVec3,
    pub keys: Vec<KeyDesc>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Motion")]
struct MotionRaw {
    /// The point rotations turn about. Default (0, 0, 0).
    #[serde(default)]
    pivot: DVec3,
    /// At least two keys, in strictly increasing time. Required.
    keys: Vec<KeyDesc>,
}

/// One keyframe of a [`MotionDesc`].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Key")]
pub struct KeyDesc {
    /// Required.
    pub time: f32,
    /// Default (0, 0, 0).
    #[serde(default)]
    pub translate: DVec3,
    /// Right-handed rotations about the pivot, applied in order. Default none.
    #[serde(default)]
    pub rotate: Vec<RotationDesc>,
}

impl TryFrom<MotionRaw> for MotionDesc {
    type Error = String;
    fn try_from(m: MotionRaw) -> Result<Self, String> {
        single_precision_dvec("motion pivot", m.pivot)?;
        if m.keys.len() < 2 {
            return Err(format!(
                "a Motion needs at least two keys, got {}",
                m.keys.len()
            ));
        }
        for k in &m.keys {
            if !k.time.is_finite() {
                return Err(format!("motion key time must be finite, got {}", k.time));
            }
            single_precision_dvec("motion key translate", k.translate)?;
            for r in &k.rotate {
                finite_vec("rotation axis", r.axis)?;
                if r.axis.length_squared() == 0.0 || !r.degrees.is_finite() {
                    return Err("rotation needs a non-zero axis and finite degrees".into());
                }
            }
        }
        if let Some(w) = m.keys.windows(2).find(|w| !(w[0].time < w[1].time)) {
            return Err(format!(
                "motion key times must increase strictly (as 32-bit floats), got {} then {}",
                w[0].time, w[1].time
            ));
        }
        if let Some(w) = m
            .keys
            .windows(2)
            .find(|w| !(w[1].time - w[0].time).is_finite())
        {
            return Err(format!(
                "motion keys at times {} and {} are farther apart than f32 holds (their \
                 difference overflows, and the motion between them could not be interpolated)",
                w[0].time, w[1].time
            ));
        }
        Ok(MotionDesc {
            pivot: m.pivot,
            keys: m.keys,
        })
    }
}

/// Surface geometry, in the shape's local coordinates (before `transform`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, try_from = "GeometryRaw")]
pub struct GeometryDesc(pub GeometryRaw);

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Geometry")]
pub enum GeometryRaw {
    /// Inline triangle mesh: `positions`, `indices` as triples (counter-clockwise = front, the side the
    /// normal cross(p1 − p0, p2 − p0) points to), optional per-vertex shading `normals` and texture
    /// coordinates `uvs` (without them each triangle's are (0, 0), (1, 0), (0, 1): barycentric, as in
    /// Mitsuba).
    Mesh {
        positions: Vec<DVec3>,
        indices: Vec<(u32, u32, u32)>,
        #[serde(default)]
        normals: Option<Vec<Vec3>>,
        #[serde(default)]
        uvs: Option<Vec<glam::Vec2>>,
    },
    /// Wavefront OBJ file, path relative to the scene file; triangulated on load. `normals`: use the
    /// file's vertex normals as shading normals if it has them. Default true. The file's texture
    /// coordinates, if every vertex has one, are the mesh's (u, v) with v flipped (OBJ's v points
    /// up the image, Lightlab's down, as in Mitsuba).
    Obj {
        file: String,
        #[serde(default = "yes")]
        normals: bool,
    },
    /// Parallelogram `corner + a·edge1 + b·edge2`, a, b ∈ [0, 1]; front side along edge1 × edge2.
    Quad {
        corner: DVec3,
        edge1: Vec3,
        edge2: Vec3,
    },
    /// Parallelogram by its four corners in order around the boundary; front side along
    /// (p1 − p0) × (p3 − p0). The corners must form a parallelogram.
    QuadCorners {
        corners: (DVec3, DVec3, DVec3, DVec3),
    },
    /// Analytic sphere; the normal points outward.
    Sphere { center: DVec3, radius: f32 },
    /// Axis-aligned box centred at the origin with the given half-extents (> 0), outward normals;
    /// place it with `transform`.
    Cuboid { half_extents: Vec3 },
}

fn yes() -> bool {
    true
}

impl GeometryDesc {
    /// Area before the transform, if known without reading files.
    pub fn local_area(&self) -> Option<f32> {
        match &self.0 {
            GeometryRaw::Mesh {
                positions, indices, ..
            } => Some(
                indices
                    .iter()
                    .map(|&(a, b, c)| {
                        let (a, b, c) = (
                            positions[a as usize],
                            positions[b as usize],
                            positions[c as usize],
                        );
                        0.5 * (b - a).cross(c - a).length() as f32
                    })
                    .sum(),
            ),
            GeometryRaw::Obj { .. } => None,
            GeometryRaw::Quad { edge1, edge2, .. } => Some(edge1.cross(*edge2).length()),
            GeometryRaw::QuadCorners {
                corners: (p0, p1, _, p3),
            } => Some((*p1 - *p0).cross(*p3 - *p0).length() as f32),
            GeometryRaw::Sphere { radius, .. } => {
                Some(4.0 * std::f32::consts::PI * radius * radius)
            }
            GeometryRaw::Cuboid { half_extents: h } => {
                Some(8.0 * (h.x * h.y + h.y * h.z + h.z * h.x))
            }
        }
    }
}

impl TryFrom<GeometryRaw> for GeometryDesc {
    type Error = String;
    fn try_from(g: GeometryRaw) -> Result<Self, String> {
        match &g {
            GeometryRaw::Mesh {
                positions,
                indices,
                normals,
                uvs,
            } => {
                if let Some(uvs) = uvs {
                    if uvs.len() != positions.len() {
                        return Err(format!(
                            "Mesh has {} uvs for {} positions",
                            uvs.len(),
                            positions.len()
                        ));
                    }
                    if let Some(i) = uvs.iter().position(|uv| !uv.is_finite()) {
                        return Err(format!("Mesh uv {i} is not finite"));
                    }
                }
                for (i, p) in positions.iter().enumerate() {
                    finite_dvec(&format!("Mesh position {i}"), *p)?;
                }
                if indices.is_empty() {
                    return Err("Mesh has no triangles".into());
                }
                for (t, &(a, b, c)) in indices.iter().enumerate() {
                    for v in [a, b, c] {
                        if v as usize >= positions.len() {
                            return Err(format!(
                                "Mesh triangle {t} uses vertex {v}, but there are only {} positions",
                                positions.len()
                            ));
                        }
                    }
                }
                if let Some(ns) = normals {
                    if ns.len() != positions.len() {
                        return Err(format!(
                            "Mesh has {} normals for {} positions",
                            ns.len(),
                            positions.len()
                        ));
                    }
                    for (i, n) in ns.iter().enumerate() {
                        finite_vec(&format!("Mesh normal {i}"), *n)?;
                        if n.length_squared() == 0.0 {
                            return Err(format!("Mesh normal {i} is zero"));
                        }
                    }
                }
            }
            GeometryRaw::Obj { file, .. } => {
                if file.is_empty() {
                    return Err("Obj file name is empty".into());
                }
            }
            GeometryRaw::Quad {
                corner,
                edge1,
                edge2,
            } => {
                finite_dvec("Quad corner", *corner)?;
                finite_vec("Quad edge1", *edge1)?;
                finite_vec("Quad edge2", *edge2)?;
            }
            GeometryRaw::QuadCorners {
                corners: (p0, p1, p2, p3),
            } => {
                for (i, p) in [p0, p1, p2, p3].into_iter().enumerate() {
                    finite_dvec(&format!("QuadCorners corner {i}"), *p)?;
                }
                let scale = (*p1 - *p0).length().max((*p3 - *p0).length());
                if (*p1 + *p3 - *p0 - *p2).length() > 1e-4 * scale {
                    return Err(
                        "QuadCorners do not form a parallelogram (p0 + p2 must equal p1 + p3)"
                            .into(),
                    );
                }
            }
            GeometryRaw::Sphere { center, radius } => {
                finite_dvec("Sphere center", *center)?;
                if !(*radius > 0.0 && radius.is_finite()) {
                    return Err(format!(
                        "Sphere radius must be finite and > 0, got {radius}{}",
                        if radius.is_infinite() {
                            " (a number beyond 3.4e38 reads as infinity; shapes may reach at \
                             most 1e9 from the scene's centre)"
                        } else {
                            ""
                        }
                    ));
                }
            }
            GeometryRaw::Cuboid { half_extents } => {
                finite_vec("Cuboid half_extents", *half_extents)?;
                if half_extents.min_element() <= 0.0 {
                    return Err(format!(
                        "Cuboid half_extents must all be > 0, got {}",
                        fmt3(half_extents.as_dvec3())
                    ));
                }
            }
        }
        Ok(GeometryDesc(g))
    }
}

/// Area emission: `(radiance: (17, 12, 4))`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Emission", try_from = "EmissionRaw")]
pub struct EmissionDesc {
    pub radiance: Rgb,
    pub two_sided: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Emission")]
struct EmissionRaw {
    /// Emitted radiance per channel, ≥ 0, the same in every direction (Lambertian emitter). Required.
    radiance: Rgb,
    /// Emit from both sides. Default false: only the front side (the geometric normal's side).
    #[serde(default)]
    two_sided: bool,
}

impl EmissionDesc {
    /// Checked emission: radiance ≥ 0, finite and at most [`MAX_EMITTED`] per channel.
    pub fn new(radiance: Rgb, two_sided: bool) -> Result<Self, String> {
        emitted_rgb("emission radiance", radiance)?;
        Ok(EmissionDesc {
            radiance,
            two_sided,
        })
    }
}

impl TryFrom<EmissionRaw> for EmissionDesc {
    type Error = String;
    fn try_from(e: EmissionRaw) -> Result<Self, String> {
        EmissionDesc::new(e.radiance, e.two_sided)
    }
}

/// `(scale: (1, 2, 1), rotate: [(axis: (0, 1, 0), degrees: 18.25)], translate: (0, -0.4, 0))`.
/// Applied as scale, then each rotation in order, then translation.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Transform", try_from = "TransformRaw")]
pub struct TransformDesc {
    pub scale: Vec3,
    pub rotate: Vec<RotationDesc>,
    pub translate: DVec3,
}

impl Default for TransformDesc {
    fn default() -> Self {
        TransformDesc {
            scale: Vec3::ONE,
            rotate: Vec::new(),
            translate: DVec3::ZERO,
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "Transform")]
struct TransformRaw {
    /// Per-axis scale factors, non-zero. Default (1, 1, 1).
    #[serde(default = "one")]
    scale: Vec3,
    /// Right-handed rotations about `axis` by `degrees`, applied in order. Default none.
    #[serde(default)]
    rotate: Vec<RotationDesc>,
    /// Translation. Default (0, 0, 0).
    #[serde(default)]
    translate: DVec3,
}

fn one() -> Vec3 {
    Vec3::ONE
}

/// A right-handed rotation: +90° about +y takes +x to −z.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Rotation")]
pub struct RotationDesc {
    pub axis: Vec3,
    pub degrees: f32,
}

impl RotationDesc {
    /// The rotations applied in order, as one quaternion (in f64).
    pub fn compose(rotations: &[RotationDesc]) -> glam::DQuat {
        rotations.iter().fold(glam::DQuat::IDENTITY, |q, r| {
            glam::DQuat::from_axis_angle(
                r.axis.as_dvec3().normalize(),
                (r.degrees as f64).to_radians(),
            ) * q
        })
    }
}

impl TryFrom<TransformRaw> for TransformDesc {
    type Error = String;
    fn try_from(t: TransformRaw) -> Result<Self, String> {
        finite_vec("transform scale", t.scale)?;
        finite_dvec("transform translate", t.translate)?;
        if t.scale.x == 0.0 || t.scale.y == 0.0 || t.scale.z == 0.0 {
            return Err(format!(
                "transform scale must be non-zero on every axis, got {}",
                fmt3(t.scale.as_dvec3())
            ));
        }
        for r in &t.rotate {
            finite_vec("rotation axis", r.axis)?;
            if r.axis.length_squared() == 0.0 || !r.degrees.is_finite() {
                return Err("rotation needs a non-zero axis and finite degrees".into());
            }
        }
        Ok(TransformDesc {
            scale: t.scale,
            rotate: t.rotate,
            translate: t.translate,
        })
    }
}

/// Lights that are not surfaces.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, try_from = "LightRaw")]
pub struct LightDesc(pub LightRaw);

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields, rename = "Light")]
pub enum LightRaw {
    /// Isotropic point light with radiant `intensity` (W·sr⁻¹, ≥ 0).
    Point { position: DVec3, intensity: Rgb },
    /// Spot light at `position` aimed at `target`: full `intensity` inside `falloff_start` degrees of
    /// the axis, falling off to zero at `cone_angle` degrees: `profile` `Smoothstep` in cos θ
    /// (default; pbrt-v4 §12.2.1) or `Angular`, linear in the angle (Mitsuba 3's spot).
    /// 0 < falloff_start ≤ cone_angle ≤ 180; default falloff_start = cone_angle (a hard edge).
    Spot {
        position: DVec3,
        target: DVec3,
        intensity: Rgb,
        cone_angle: f32,
        #[serde(default)]
        falloff_start: Option<f32>,
        #[serde(default)]
        profile: crate::SpotProfile,
    },
    /// Constant radiance arriving from every direction at infinity (≥ 0).
    Environment { radiance: Rgb },
    /// Radiance from infinity read from a latitude–longitude image `file` (relative to the scene
    /// file; OpenEXR or Radiance HDR, or PNG/JPEG decoded from sRGB), Mitsuba 3's `envmap` parameterisation (+y is the top row; see
    /// scenes/README.md), times `scale` (≥ 0, default 1), turned by `rotate` (as in `Transform`).
    /// Importance-sampled by its brightness. At most one per scene; constant `Environment`s add
    /// to it.
    EnvironmentMap {
        file: String,
        #[serde(default = "unit_scale")]
        scale: f32,
        #[serde(default)]
        rotate: Vec<RotationDesc>,
    },
    /// Parallel light from infinity travelling along `direction` (any non-zero length; the sun):
    /// `irradiance` (W·m⁻², ≥ 0) on a surface facing it. A delta direction: only next-event
    /// estimation and light paths reach it (path tracing with `strategy: BsdfOnly` cannot).
    Directional { direction: DVec3, irradiance: Rgb },
}

fn unit_scale() -> f32 {
    1.0
}

impl TryFrom<LightRaw> for LightDesc {
    type Error = String;
    fn try_from(l: LightRaw) -> Result<Self, String> {
        match l {
            LightRaw::Point {
                position,
                intensity,
            } => {
                finite_dvec("Point position", position)?;
                emitted_rgb("Point intensity", intensity)?;
            }
            LightRaw::Spot {
                position,
                target,
                intensity,
                cone_angle,
                falloff_start,
                ..
            } => {
                finite_dvec("Spot position", position)?;
                finite_dvec("Spot target", target)?;
                if target == position {
                    return Err("Spot target equals its position: the axis is undefined".into());
                }
                emitted_rgb("Spot intensity", intensity)?;
                if !(cone_angle > 0.0 && cone_angle <= 180.0) {
                    return Err(format!(
                        "Spot cone_angle must be in (0, 180] degrees, got {cone_angle}"
                    ));
                }
                let start = falloff_start.unwrap_or(cone_angle);
                if !(start > 0.0 && start <= cone_angle) {
                    return Err(format!(
                        "Spot falloff_start must be in (0, cone_angle = {cone_angle}], got {start}"
                    ));
                }
            }
            LightRaw::Environment { radiance } => emitted_rgb("Environment radiance", radiance)?,
            LightRaw::Directional {
                direction,
                irradiance,
            } => {
                finite_dvec("Directional direction", direction)?;
                if direction == DVec3::ZERO {
                    return Err("Directional direction must be non-zero".into());
                }
                emitted_rgb("Directional irradiance", irradiance)?;
            }
            LightRaw::EnvironmentMap {
                ref file,
                scale,
                ref rotate,
            } => {
                if file.is_empty() {
                    return Err("EnvironmentMap file name is empty".into());
                }
                if !(0.0..=MAX_EMITTED).contains(&scale) {
                    return Err(format!(
                        "EnvironmentMap scale must be in [0, {MAX_EMITTED:e}], got {scale}"
                    ));
                }
                for r in rotate {
                    finite_vec("rotation axis", r.axis)?;
                    if r.axis.length_squared() == 0.0 || !r.degrees.is_finite() {
                        return Err("rotation needs a non-zero axis and finite degrees".into());
                    }
                }
            }
        }
        Ok(LightDesc(l))
    }
}

fn finite_vec(what: &str, v: Vec3) -> Result<(), String> {
    finite_dvec(what, v.as_dvec3())
}

fn finite_dvec(what: &str, v: DVec3) -> Result<(), String> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(format!("{what} must be finite, got {}", fmt3(v)))
    }
}

/// `v` (finite, non-zero) at unit length, whatever its magnitude: scaled by its largest
/// component first, so that the squared length neither overflows (a direction of (1e200, −1e200,
/// 0) had normalised to zero: a black image) nor underflows.
pub(crate) fn unit(v: DVec3) -> DVec3 {
    (v / v.abs().max_element()).normalize()
}

/// Finite and within f32's range: a motion's pivot and translations are kept in f32.
fn single_precision_dvec(what: &str, v: DVec3) -> Result<(), String> {
    if v.is_finite() && v.abs().max_element() <= f32::MAX as f64 {
        Ok(())
    } else {
        Err(format!(
            "{what} must be finite and within ±{:e}, got {}",
            f32::MAX,
            fmt3(v)
        ))
    }
}

/// A triple as the file writes it: `(1, NaN, 0.5)`.
pub(crate) fn fmt3(v: DVec3) -> String {
    let f = |x: f64| {
        if x.is_nan() {
            "NaN".to_string()
        } else {
            format!("{x}")
        }
    };
    format!("({}, {}, {})", f(v.x), f(v.y), f(v.z))
}

fn fmt_rgb(c: Rgb) -> String {
    let f = |x: f32| {
        if x.is_nan() {
            "NaN".to_string()
        } else {
            format!("{x}")
        }
    };
    format!("({}, {}, {})", f(c.r), f(c.g), f(c.b))
}

fn positive(what: &str, x: f32) -> Result<(), String> {
    if x > 0.0 && x.is_finite() {
        Ok(())
    } else {
        Err(format!("{what} must be > 0 and finite, got {x}"))
    }
}

/// A constant colour in [0, 1]; a texture's values are checked when the scene is built.
fn unit_colour(what: &str, c: &ColourDesc) -> Result<(), String> {
    match c {
        ColourDesc::Constant(c) => unit_rgb(what, *c),
        ColourDesc::Texture(name) if name.is_empty() => Err(format!("{what}: empty texture name")),
        ColourDesc::Texture(_) => Ok(()),
    }
}

fn unit_rgb(what: &str, c: Rgb) -> Result<(), String> {
    if c.to_array().iter().all(|x| (0.0..=1.0).contains(x)) {
        Ok(())
    } else {
        Err(format!(
            "{what} must be in [0, 1] per channel (a surface cannot reflect more than it receives), got {}",
            fmt_rgb(c)
        ))
    }
}

/// The largest emitted value per channel (radiance, intensity or irradiance, in the scene's
/// units): pixel values are squared into the variance layer, and light powers summed for light
/// selection, in 32-bit floats (largest 3.4e38), which brighter lights overflowed — to an infinite
/// variance or, through the light-selection sum, to a black image.
pub const MAX_EMITTED: f32 = 1e15;

/// A light's emitted colour: ≥ 0, finite and at most [`MAX_EMITTED`] per channel.
fn emitted_rgb(what: &str, c: Rgb) -> Result<(), String> {
    non_negative_rgb(what, c)?;
    if c.max_component() > MAX_EMITTED {
        return Err(format!(
            "{what} must be at most {MAX_EMITTED:e} per channel, got {}: pixel values are squared \
             for their variance in 32-bit floats, which overflow beyond that; express the scene in \
             larger units of power",
            fmt_rgb(c)
        ));
    }
    Ok(())
}

fn non_negative_rgb(what: &str, c: Rgb) -> Result<(), String> {
    if c.to_array().iter().all(|x| *x >= 0.0 && x.is_finite()) {
        Ok(())
    } else {
        Err(format!(
            "{what} must be ≥ 0 and finite per channel, got {}",
            fmt_rgb(c)
        ))
    }
}

/// Reads a RON map into an ordered list, rejecting duplicate keys (a map would silently keep the last).
fn unique_map<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Vec<(String, T)>, D::Error> {
    struct V<T>(std::marker::PhantomData<T>);
    impl<'de, T: Deserialize<'de>> de::Visitor<'de> for V<T> {
        type Value = Vec<(String, T)>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a map from names to definitions")
        }
        fn visit_map<A: de::MapAccess<'de>>(self, mut m: A) -> Result<Self::Value, A::Error> {
            let mut out: Vec<(String, T)> = Vec::new();
            while let Some((k, v)) = m.next_entry::<String, T>()? {
                if out.iter().any(|(n, _)| *n == k) {
                    return Err(de::Error::custom(format!("\"{k}\" is defined twice")));
                }
                out.push((k, v));
            }
            Ok(out)
        }
    }
    d.deserialize_map(V(std::marker::PhantomData))
}
