//! The world-space face of a BSDF at a surface point (pbrt-v4's `BSDF` class, §9.1.5): converts
//! directions to and from the shading frame and rejects bad configurations once, so no `Bsdf`
//! variant repeats it.

use crate::{Bsdf, BsdfEval, BsdfSample, Plastic, RoughPlastic, Texture, TextureSlots};
use lightlab_core::{Frame, TransportMode, Vec2, Vec3};

/// A [`Bsdf`] placed at a surface point with shading frame `frame` (`frame.n` = shading normal ns)
/// and geometric normal `ng` (unit).
///
/// Directions are in world space, unit length and point away from the surface.
///
/// **Light leaks.** With shading normals, a direction can be above the shading tangent plane and
/// below the geometric one (or vice versa). Every `wo` and `wi` for which
/// sign(w·ng) ≠ sign(w·ns) — or either dot product is zero — is rejected: `eval` and `pdf` return
/// zero, `sample` returns `None`. This also rejects `wo·ns == 0`.
///
/// **Adjoint shading-normal correction.** Shading normals make the BSDF non-symmetric (Veach 1997,
/// §5.3). In [`TransportMode::Importance`] the value `f` (and so `weight`) is multiplied by
///
///   |wo·ns| · |wi·ng| / (|wo·ng| · |wi·ns|)
///
/// (Veach 1997, eq. 5.19; pbrt-v3 `CorrectShadingNormal`), which is 0 when the denominator is 0 or
/// the ratio overflows. Radiance mode needs no correction. Pdfs are never corrected: they describe
/// the sampling, which is unchanged.
///
/// `sample` also rejects samples whose value is zero.
///
/// **One-sided surfaces.** With `one_sided`, only the front (the side `ns` and `ng` point to)
/// scatters: every direction below it is rejected as above, so the back is black — Mitsuba's
/// convention for reflecting BSDFs not wrapped in `twosided` (Mitsuba 3 docs, "BSDFs").
#[derive(Clone, Copy, Debug)]
pub struct SurfaceBsdf {
    pub frame: Frame,
    pub ng: Vec3,
    pub bsdf: Bsdf,
    pub one_sided: bool,
}

/// A scene material: its BSDF, whether its back side is black (see [`SurfaceBsdf`]), and which of
/// the BSDF's colours textures replace.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    pub bsdf: Bsdf,
    pub one_sided: bool,
    pub textures: TextureSlots,
}

impl Material {
    /// A material that scatters on both sides, without textures.
    pub fn two_sided(bsdf: Bsdf) -> Material {
        Material {
            bsdf,
            one_sided: false,
            textures: TextureSlots::NONE,
        }
    }

    /// The BSDF at a surface point with parameters `uv`: the material's, with each textured colour
    /// looked up in `textures` (the scene's list the slots index).
    #[inline]
    pub fn bsdf_at(&self, uv: Vec2, textures: &[Texture]) -> Bsdf {
        if self.textures.is_empty() {
            return self.bsdf;
        }
        let lookup = |slot: Option<u32>| slot.map(|i| textures[i as usize].eval(uv));
        let (reflectance, specular) = (
            lookup(self.textures.reflectance),
            lookup(self.textures.specular),
        );
        let mut bsdf = self.bsdf;
        match &mut bsdf {
            Bsdf::Diffuse { albedo: c } | Bsdf::Mirror { reflectance: c } => {
                *c = reflectance.unwrap_or(*c);
            }
            Bsdf::Phong { kd, ks, .. }
            | Bsdf::Plastic(Plastic { kd, ks, .. })
            | Bsdf::RoughPlastic(RoughPlastic { kd, ks, .. }) => {
                *kd = reflectance.unwrap_or(*kd);
                *ks = specular.unwrap_or(*ks);
            }
            _ => {}
        }
        bsdf
    }
}

impl SurfaceBsdf {
    /// Shading frame from the unit shading normal `ns` and the tangent `dpdu` (which orients
    /// anisotropic roughness; see [`Frame::from_normal_tangent`]); `ng` is the unit geometric normal.
    #[inline]
    pub fn new(ns: Vec3, dpdu: Vec3, ng: Vec3, bsdf: Bsdf) -> Self {
        SurfaceBsdf {
            frame: Frame::from_normal_tangent(ns, dpdu),
            ng,
            bsdf,
            one_sided: false,
        }
    }

    /// The surface of `material`, whose BSDF at this point is `bsdf` (see [`Material::bsdf_at`]):
    /// [`SurfaceBsdf::new`] with the material's sidedness.
    #[inline]
    pub fn of(ns: Vec3, dpdu: Vec3, ng: Vec3, material: &Material, bsdf: Bsdf) -> Self {
        SurfaceBsdf {
            one_sided: material.one_sided,
            ..SurfaceBsdf::new(ns, dpdu, ng, bsdf)
        }
    }

    /// `w` in the shading frame, or `None` when its side of the shading and geometric tangent
    /// planes disagree (or it lies in either plane), or it is below a one-sided surface.
    #[inline]
    fn local_if_consistent(&self, w: Vec3) -> Option<Vec3> {
        let local = self.frame.to_local(w);
        (w.dot(self.ng) * local.z > 0.0 && !(self.one_sided && local.z < 0.0)).then_some(local)
    }

    /// Veach 1997, eq. 5.19: the factor that turns the radiance-mode BSDF with shading normals into
    /// its adjoint for importance transport.
    #[inline]
    fn importance_correction(&self, wo: Vec3, wi: Vec3) -> f32 {
        let num = wo.dot(self.frame.n).abs() * wi.dot(self.ng).abs();
        let den = wo.dot(self.ng).abs() * wi.dot(self.frame.n).abs();
        if den == 0.0 {
            return 0.0;
        }
        let c = num / den;
        if c.is_finite() { c } else { 0.0 }
    }

    /// f(wo, wi) and both pdfs for world-space directions.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> BsdfEval {
        let (Some(wo_local), Some(wi_local)) =
            (self.local_if_consistent(wo), self.local_if_consistent(wi))
        else {
            return BsdfEval::ZERO;
        };
        let mut e = self.bsdf.eval(wo_local, wi_local, mode);
        if mode == TransportMode::Importance {
            e.f *= self.importance_correction(wo, wi);
        }
        e
    }

    /// Samples a world-space `wi`; see [`Bsdf::sample`].
    #[inline]
    pub fn sample(
        &self,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        let wo_local = self.local_if_consistent(wo)?;
        let mut s = self.bsdf.sample(wo_local, u_lobe, u, mode)?;
        let wi = self.frame.to_world(s.wi);
        if wi.dot(self.ng) * s.wi.z <= 0.0 {
            return None;
        }
        if mode == TransportMode::Importance {
            let c = self.importance_correction(wo, wi);
            s.f *= c;
            s.weight *= c;
        }
        if s.f.is_black() {
            return None;
        }
        s.wi = wi;
        Some(s)
    }

    /// Probability that `sample(wo)` takes a Dirac-delta lobe (see [`Bsdf::delta_probability`]);
    /// 0 where `wo` is rejected.
    #[inline]
    pub fn delta_probability(&self, wo: Vec3) -> f32 {
        self.local_if_consistent(wo)
            .map_or(0.0, |w| self.bsdf.delta_probability(w))
    }

    /// Solid-angle pdf with which `sample(wo)` yields `wi`, world space.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match (self.local_if_consistent(wo), self.local_if_consistent(wi)) {
            (Some(wo_local), Some(wi_local)) => self.bsdf.pdf(wo_local, wi_local),
            _ => 0.0,
        }
    }
}
