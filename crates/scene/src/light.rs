//! Lights and their sampling. Area lights are shapes with emission; point and spot lights are delta
//! positions, the environment is infinite, and a directional light is both: a delta direction at
//! infinity. Light selection is proportional to emitted power (see `Scene`).

use crate::EnvMap;
use glam::{Vec2, Vec3};
use lightlab_core::{Frame, INV_4PI, INV_PI, PI, Rgb};
use std::sync::Arc;

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;
use lightlab_geometry::Shape;
use lightlab_samplers::warp::{
    square_to_concentric_disk, square_to_cosine_hemisphere, square_to_uniform_cone,
    square_to_uniform_cone_pdf, square_to_uniform_sphere, square_to_uniform_sphere_pdf,
};

#[derive(Clone, Debug)]
pub enum Light {
    /// Lambertian emitter on shape `shape` with constant `radiance`.
    Area {
        shape: u32,
        radiance: Rgb,
        two_sided: bool,
    },
    Point {
        position: Vec3,
        intensity: Rgb,
    },
    /// `cos_falloff_start ≥ cos_total`; full intensity inside the falloff start, none outside
    /// the cone, and between them the `profile`'s falloff.
    Spot {
        position: Vec3,
        axis: Vec3,
        intensity: Rgb,
        cos_total: f32,
        cos_falloff_start: f32,
        profile: SpotProfile,
    },
    /// Radiance arriving from infinity: `radiance` from every direction, or, with a `map`, the
    /// map's radiance (which then includes `radiance`), importance-sampled by the map.
    Environment {
        radiance: Rgb,
        map: Option<Arc<EnvMap>>,
    },
    /// Parallel light from infinity travelling along the unit `direction` (the sun, pbrt-v4's
    /// `DistantLight`): `irradiance` E (W·m⁻²) on a surface facing it, E·|cos θ| on others.
    Directional {
        direction: Vec3,
        irradiance: Rgb,
    },
}

/// A ray leaving a light, for light tracing and photon emission (pbrt-v4 §12, `SampleLe`).
#[derive(Clone, Copy, Debug)]
pub struct LightEmission {
    /// Origin on the light, its error bound and the light's normal there (the direction for delta
    /// and infinite lights).
    pub p: Vec3,
    pub p_error: Vec3,
    pub n: Vec3,
    /// Unit direction of emission.
    pub dir: Vec3,
    /// Radiance (area, environment) or intensity (point, spot) along `dir`.
    pub le: Rgb,
    /// Area density of `p` (1 for delta positions), and solid-angle density of `dir`.
    pub pdf_pos: f32,
    pub pdf_dir: f32,
    /// The position is a delta (point and spot lights).
    pub delta_pos: bool,
}

/// A direction toward a light from a reference point, with what arrives along it.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the reference point to the light.
    pub wi: Vec3,
    /// Incident radiance (area, environment) or intensity / d² (delta lights) along `wi`, before
    /// visibility.
    pub li: Rgb,
    /// Solid-angle density of `wi` for this light (not including the light-selection probability);
    /// 1 for delta lights.
    pub pdf_w: f32,
    /// Sampled point on the light (for environment lights, unused) and its error bound and normal.
    pub p: Vec3,
    pub p_error: Vec3,
    pub n: Vec3,
    pub delta: bool,
    pub infinite: bool,
}

impl Light {
    /// What kind of light this is, for messages ("an area light", "a point light", …).
    pub fn kind(&self) -> &'static str {
        match self {
            Light::Area { .. } => "an area light",
            Light::Point { .. } => "a point light",
            Light::Spot { .. } => "a spot light",
            Light::Environment { .. } => "an environment light",
            Light::Directional { .. } => "a directional light",
        }
    }

    /// A ray leaving the light: position ∝ area (uniform on the disk of radius `scene_radius`
    /// facing the direction for the environment), direction cosine-weighted on the emitting side(s)
    /// of area lights, uniform for point lights, uniform in the cone for spot lights and uniform on
    /// the sphere for the environment; the directional light's rays start on the same disk and all
    /// travel along its direction (`pdf_dir` = 1, a discrete probability). The throughput of the ray is
    /// `le · |cos(n, dir)| / (pdf_pos · pdf_dir)` (cos = 1 for delta and infinite lights).
    pub fn sample_le(
        &self,
        shapes: &[Shape],
        scene_center: Vec3,
        scene_radius: f32,
        u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<LightEmission> {
        match *self {
            Light::Area {
                shape,
                radiance,
                two_sided,
            } => {
                let s = shapes[shape as usize].sample_area(u_pos);
                if !(s.pdf > 0.0) {
                    return None;
                }
                // Two-sided: the back side with probability ½, reusing u_dir.x.
                let (u, side, side_pdf) = if two_sided {
                    if u_dir.x < 0.5 {
                        (Vec2::new(u_dir.x * 2.0, u_dir.y), 1.0, 0.5)
                    } else {
                        (Vec2::new((u_dir.x - 0.5) * 2.0, u_dir.y), -1.0, 0.5)
                    }
                } else {
                    (u_dir, 1.0, 1.0)
                };
                let local = square_to_cosine_hemisphere(Vec2::new(u.x.min(ONE_MINUS_EPSILON), u.y));
                let dir = Frame::from_z(s.n * side).to_world(local);
                let pdf_dir = local.z * INV_PI * side_pdf;
                (pdf_dir > 0.0).then_some(LightEmission {
                    p: s.p,
                    p_error: s.p_error,
                    n: s.n,
                    dir,
                    le: radiance,
                    pdf_pos: s.pdf,
                    pdf_dir,
                    delta_pos: false,
                })
            }
            Light::Point {
                position,
                intensity,
            } => {
                let dir = square_to_uniform_sphere(u_dir);
                Some(LightEmission {
                    p: position,
                    p_error: Vec3::ZERO,
                    n: dir,
                    dir,
                    le: intensity,
                    pdf_pos: 1.0,
                    pdf_dir: INV_4PI,
                    delta_pos: true,
                })
            }
            Light::Spot {
                position,
                axis,
                intensity,
                cos_total,
                cos_falloff_start,
                profile,
            } => {
                let local = square_to_uniform_cone(u_dir, cos_total);
                let dir = Frame::from_z(axis).to_world(local);
                let falloff = profile.falloff(local.z, cos_total, cos_falloff_start);
                let pdf_dir = square_to_uniform_cone_pdf(local, cos_total);
                Some(LightEmission {
                    p: position,
                    p_error: Vec3::ZERO,
                    n: dir,
                    dir,
                    le: intensity * falloff,
                    pdf_pos: 1.0,
                    pdf_dir,
                    delta_pos: true,
                })
            }
            Light::Environment { radiance, ref map } => {
                // Light arrives from −dir: start on a disk of the scene's bounding sphere's radius,
                // outside it, perpendicular to dir.
                let (dir, le, pdf_dir) = match map {
                    Some(m) => {
                        let (d, le, pdf) = m.sample(u_dir)?;
                        (-d, le, pdf)
                    }
                    None => (-square_to_uniform_sphere(u_dir), radiance, INV_4PI),
                };
                let d = square_to_concentric_disk(u_pos) * scene_radius;
                let frame = Frame::from_z(dir);
                let p =
                    scene_center + frame.to_world(Vec3::new(d.x, d.y, 0.0)) - dir * scene_radius;
                Some(LightEmission {
                    p,
                    p_error: Vec3::ZERO,
                    n: dir,
                    dir,
                    le,
                    pdf_pos: 1.0 / (PI * scene_radius * scene_radius),
                    pdf_dir,
                    delta_pos: false,
                })
            }
            Light::Directional {
                direction,
                irradiance,
            } => {
                let d = square_to_concentric_disk(u_pos) * scene_radius;
                let frame = Frame::from_z(direction);
                let p = scene_center + frame.to_world(Vec3::new(d.x, d.y, 0.0))
                    - direction * scene_radius;
                Some(LightEmission {
                    p,
                    p_error: Vec3::ZERO,
                    n: direction,
                    dir: direction,
                    le: irradiance,
                    pdf_pos: 1.0 / (PI * scene_radius * scene_radius),
                    pdf_dir: 1.0,
                    delta_pos: false,
                })
            }
        }
    }

    /// Densities with which [`Light::sample_le`] produces a ray leaving the light at a point with
    /// normal `n` in unit direction `w`: (area density of the position, solid-angle density of the
    /// direction).
    pub fn pdf_le(&self, shapes: &[Shape], scene_radius: f32, n: Vec3, w: Vec3) -> (f32, f32) {
        match *self {
            Light::Area {
                shape, two_sided, ..
            } => {
                let cos = n.dot(w);
                let pdf_dir = if two_sided {
                    cos.abs() * 0.5 * INV_PI
                } else {
                    cos.max(0.0) * INV_PI
                };
                (shapes[shape as usize].pdf_area(), pdf_dir)
            }
            Light::Point { .. } => (1.0, INV_4PI),
            Light::Spot {
                axis, cos_total, ..
            } => (
                1.0,
                square_to_uniform_cone_pdf(Frame::from_z(axis).to_local(w), cos_total),
            ),
            Light::Environment { ref map, .. } => (
                1.0 / (PI * scene_radius * scene_radius),
                map.as_ref().map_or(INV_4PI, |m| m.pdf(-w)),
            ),
            Light::Directional { .. } => (1.0 / (PI * scene_radius * scene_radius), 1.0),
        }
    }

    /// Whether the light is a Dirac delta in position (point, spot) or direction (directional),
    /// so that no path can hit it: only a connection (next-event estimation) reaches it.
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. }
        )
    }

    /// Whether the light sits at infinity (environment, directional): its rays come from a disk
    /// bounding the scene, and its origin is a direction.
    pub fn is_infinite(&self) -> bool {
        matches!(self, Light::Environment { .. } | Light::Directional { .. })
    }

    /// Radiance leaving an area light's surface point with geometric normal `n` in direction `w`.
    #[inline]
    pub fn area_le(radiance: Rgb, two_sided: bool, n: Vec3, w: Vec3) -> Rgb {
        if two_sided || n.dot(w) > 0.0 {
            radiance
        } else {
            Rgb::BLACK
        }
    }

    /// Total emitted power Φ, used for power-proportional light selection. `scene_radius` bounds the
    /// scene for infinite lights (pbrt-v4 §12.5.1: Φ = π r² · 4π L for a constant environment).
    pub fn power(&self, shapes: &[Shape], scene_radius: f32) -> Rgb {
        match *self {
            Light::Area {
                shape,
                radiance,
                two_sided,
            } => {
                radiance * (PI * shapes[shape as usize].area() * if two_sided { 2.0 } else { 1.0 })
            }
            Light::Point { intensity, .. } => intensity * (4.0 * PI),
            Light::Spot {
                intensity,
                cos_total,
                cos_falloff_start,
                profile,
                ..
            } => intensity * profile.solid_angle(cos_total, cos_falloff_start),
            Light::Environment { radiance, ref map } => {
                let integral = map.as_ref().map_or(radiance * (4.0 * PI), |m| m.integral());
                integral * (PI * scene_radius * scene_radius)
            }
            // pbrt-v4 §12.4: the irradiance over the disk the scene presents to the light.
            Light::Directional { irradiance, .. } => {
                irradiance * (PI * scene_radius * scene_radius)
            }
        }
    }

    /// Samples incident illumination at `p` (pbrt-v4's `SampleLi`).
    pub fn sample_li(&self, shapes: &[Shape], p: Vec3, u: Vec2) -> Option<LightSample> {
        match *self {
            Light::Area {
                shape,
                radiance,
                two_sided,
            } => {
                let s = shapes[shape as usize].sample_solid_angle(p, u)?;
                let d = s.p - p;
                let dist2 = d.length_squared();
                if !(dist2 > 0.0) || !(s.pdf > 0.0) || !s.pdf.is_finite() {
                    return None;
                }
                let wi = d / dist2.sqrt();
                let li = Light::area_le(radiance, two_sided, s.n, -wi);
                Some(LightSample {
                    wi,
                    li,
                    pdf_w: s.pdf,
                    p: s.p,
                    p_error: s.p_error,
                    n: s.n,
                    delta: false,
                    infinite: false,
                })
            }
            Light::Point {
                position,
                intensity,
            } => {
                let d = position - p;
                let dist2 = d.length_squared();
                if !(dist2 > 0.0) {
                    return None;
                }
                let wi = d / dist2.sqrt();
                Some(LightSample {
                    wi,
                    li: intensity / dist2,
                    pdf_w: 1.0,
                    p: position,
                    p_error: Vec3::ZERO,
                    n: -wi,
                    delta: true,
                    infinite: false,
                })
            }
            Light::Spot {
                position,
                axis,
                intensity,
                cos_total,
                cos_falloff_start,
                profile,
            } => {
                let d = position - p;
                let dist2 = d.length_squared();
                if !(dist2 > 0.0) {
                    return None;
                }
                let wi = d / dist2.sqrt();
                let falloff = profile.falloff(axis.dot(-wi), cos_total, cos_falloff_start);
                Some(LightSample {
                    wi,
                    li: intensity * (falloff / dist2),
                    pdf_w: 1.0,
                    p: position,
                    p_error: Vec3::ZERO,
                    n: -wi,
                    delta: true,
                    infinite: false,
                })
            }
            Light::Environment { radiance, ref map } => {
                let (wi, li, pdf_w) = match map {
                    Some(m) => m.sample(u)?,
                    None => {
                        let wi = square_to_uniform_sphere(u);
                        (wi, radiance, square_to_uniform_sphere_pdf(wi))
                    }
                };
                Some(LightSample {
                    wi,
                    li,
                    pdf_w,
                    p: p + wi,
                    p_error: Vec3::ZERO,
                    n: -wi,
                    delta: false,
                    infinite: true,
                })
            }
            Light::Directional {
                direction,
                irradiance,
            } => Some(LightSample {
                wi: -direction,
                li: irradiance,
                pdf_w: 1.0,
                p: p - direction,
                p_error: Vec3::ZERO,
                n: direction,
                delta: true,
                infinite: true,
            }),
        }
    }

    /// Solid-angle density with which `sample_li` from `p` would produce the point `lp` (normal `ln`)
    /// on this light (for the environment: any direction). Zero for delta lights.
    pub fn pdf_li(&self, shapes: &[Shape], p: Vec3, lp: Vec3, ln: Vec3) -> f32 {
        match *self {
            Light::Area { shape, .. } => shapes[shape as usize].pdf_solid_angle(p, lp, ln),
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. } => 0.0,
            Light::Environment { .. } => self.environment_pdf(-ln),
        }
    }

    /// Solid-angle density with which an environment light's `sample_li` returns the unit
    /// direction `d` (toward the environment); zero for other lights.
    #[inline]
    pub fn environment_pdf(&self, d: Vec3) -> f32 {
        match self {
            Light::Environment { map: Some(m), .. } => m.pdf(d),
            Light::Environment { .. } => INV_4PI,
            _ => 0.0,
        }
    }

    /// Radiance an environment light sends from the unit direction `d` (pointing toward the
    /// environment, e.g. an escaped ray's); black for other lights.
    #[inline]
    pub fn environment_le(&self, d: Vec3) -> Rgb {
        match self {
            Light::Environment { map: Some(m), .. } => m.le(d),
            Light::Environment { radiance, .. } => *radiance,
            _ => Rgb::BLACK,
        }
    }
}

/// How a spot light fades between the start of its falloff and the edge of its cone.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
pub enum SpotProfile {
    /// Smoothstep in cos θ (pbrt-v4 §12.2.1).
    #[default]
    Smoothstep,
    /// Linear in the angle θ (Mitsuba 3's `spot`, its `beam_width` to `cutoff_angle`).
    Angular,
}

impl SpotProfile {
    /// The falloff at cos θ from the axis.
    #[inline]
    pub fn falloff(self, cos_theta: f32, cos_total: f32, cos_falloff_start: f32) -> f32 {
        match self {
            SpotProfile::Smoothstep => spot_falloff(cos_theta, cos_total, cos_falloff_start),
            SpotProfile::Angular => {
                if cos_theta >= cos_falloff_start {
                    return 1.0;
                }
                if cos_theta <= cos_total {
                    return 0.0;
                }
                let (total, start) = (cos_total.acos(), cos_falloff_start.acos());
                ((total - cos_theta.acos()) / (total - start)).clamp(0.0, 1.0)
            }
        }
    }

    /// ∫ falloff dω over the sphere.
    fn solid_angle(self, cos_total: f32, cos_falloff_start: f32) -> f32 {
        let inner = 1.0 - cos_falloff_start;
        match self {
            // ∫ smoothstep dω = 2π [(1 − cos_start) + (cos_start − cos_total)/2].
            SpotProfile::Smoothstep => 2.0 * PI * (inner + (cos_falloff_start - cos_total) / 2.0),
            // With b, c the start and edge angles, ∫_b^c (c − θ)/(c − b) sin θ dθ =
            // cos b + (sin b − sin c)/(c − b).
            SpotProfile::Angular => {
                let (c, b) = (cos_total.acos(), cos_falloff_start.acos());
                if c - b <= 1e-6 {
                    return 2.0 * PI * (1.0 - cos_total);
                }
                2.0 * PI * (inner + cos_falloff_start + (b.sin() - c.sin()) / (c - b))
            }
        }
    }
}

/// Smoothstep falloff of a spot light between the cone edge and the start of the falloff
/// (pbrt-v4 eq. 12.2 with the smoothstep of §B.2.3).
#[inline]
pub fn spot_falloff(cos_theta: f32, cos_total: f32, cos_falloff_start: f32) -> f32 {
    if cos_theta >= cos_falloff_start {
        return 1.0;
    }
    if cos_theta <= cos_total {
        return 0.0;
    }
    let t = (cos_theta - cos_total) / (cos_falloff_start - cos_total);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_power_matches_integrated_falloff() {
        let (ct, cs) = (30f32.to_radians().cos(), 20f32.to_radians().cos());
        for profile in [SpotProfile::Smoothstep, SpotProfile::Angular] {
            let l = Light::Spot {
                position: Vec3::ZERO,
                axis: Vec3::Z,
                intensity: Rgb::WHITE,
                cos_total: ct,
                cos_falloff_start: cs,
                profile,
            };
            // Midpoint rule over cos θ: ∫ falloff dω = 2π ∫ falloff(cos θ) d cos θ.
            let n = 200_000;
            let integral: f64 = (0..n)
                .map(|i| {
                    let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                    profile.falloff(c as f32, ct, cs) as f64 * 2.0 / n as f64
                })
                .sum::<f64>()
                * 2.0
                * std::f64::consts::PI;
            let p = l.power(&[], 1.0).r as f64;
            assert!(
                (p - integral).abs() < 1e-4 * p,
                "{profile:?}: power {p} vs integral {integral}"
            );
        }
        // Mitsuba's profile is linear in the angle: half way (25°) between 20° and 30°, 1/2.
        let half = SpotProfile::Angular.falloff(25f32.to_radians().cos(), ct, cs);
        assert!((half - 0.5).abs() < 1e-5, "{half}");
    }
}
