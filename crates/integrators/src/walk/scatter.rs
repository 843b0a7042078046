//! How the walk chooses a direction at a vertex: by the BSDF (importance sampling), or blindly.

use glam::{Vec2, Vec3};
use lightlab_core::{INV_2PI, INV_4PI, TransportMode};
use lightlab_materials::{Bsdf, BsdfSample, SurfaceBsdf};
use lightlab_samplers::warp::{square_to_uniform_hemisphere, square_to_uniform_sphere};

/// Where directions come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Directions {
    /// The BSDF's own sampling routine.
    Bsdf,
    /// Blind Monte Carlo at non-delta vertices: uniform on the hemisphere of ωo (the whole sphere
    /// for a transmissive rough surface); delta vertices are still sampled by their BSDF.
    Uniform,
}

/// A direction at the surface `sb` for arrival from `wo`, with f·|cos|/p.
#[inline]
pub(crate) fn sample(
    sb: &SurfaceBsdf,
    wo: Vec3,
    u_lobe: f32,
    u_dir: Vec2,
    mode: TransportMode,
    directions: Directions,
) -> Option<BsdfSample> {
    match directions {
        Directions::Uniform if !sb.bsdf.is_delta() => {
            // A BSDF mixing in a delta lobe keeps it, chosen as the BSDF chooses it.
            let p_delta = sb.delta_probability(wo);
            if u_lobe < p_delta {
                sb.sample(wo, u_lobe, u_dir, mode)
            } else {
                Some(uniform(sb, wo, u_dir, mode, 1.0 - p_delta))
            }
        }
        _ => sb.sample(wo, u_lobe, u_dir, mode),
    }
}

/// A uniform direction, taken with probability `p_choice`.
fn uniform(sb: &SurfaceBsdf, wo: Vec3, u: Vec2, mode: TransportMode, p_choice: f32) -> BsdfSample {
    let (local, pdf) = if matches!(sb.bsdf, Bsdf::RoughDielectric { .. }) {
        (square_to_uniform_sphere(u), INV_4PI)
    } else {
        let mut d = square_to_uniform_hemisphere(u);
        if sb.frame.n.dot(wo) < 0.0 {
            d.z = -d.z;
        }
        (d, INV_2PI)
    };
    let pdf = pdf * p_choice;
    let wi = sb.frame.to_world(local);
    let f = sb.eval(wo, wi, mode).f;
    let transmission = wi.dot(sb.ng) * wo.dot(sb.ng) < 0.0;
    // pbrt-v4's etap: the relative index of wi's side over wo's.
    let eta = match sb.bsdf {
        Bsdf::RoughDielectric { eta, .. } if transmission => {
            if wo.dot(sb.ng) > 0.0 {
                eta
            } else {
                1.0 / eta
            }
        }
        _ => 1.0,
    };
    BsdfSample {
        wi,
        f,
        pdf,
        weight: f * (local.z.abs() / pdf),
        lobe: sb.bsdf.lobe_class(),
        transmission,
        eta,
        delta: false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightlab_core::Rgb;
    use lightlab_materials::{Distribution, Plastic};
    use lightlab_testkit::{Chi2Test, Domain};

    /// The density of a blind non-delta direction `wi` at `sb` for arrival from `wo`: uniform on
    /// the sphere for rough glass, on ωo's side of the shading normal otherwise, times the
    /// probability of not taking a delta lobe.
    fn uniform_pdf(sb: &SurfaceBsdf, wo: Vec3, wi: Vec3) -> f32 {
        let p_choice = 1.0 - sb.delta_probability(wo);
        if matches!(sb.bsdf, Bsdf::RoughDielectric { .. }) {
            INV_4PI * p_choice
        } else if sb.frame.n.dot(wi) * sb.frame.n.dot(wo) > 0.0 {
            INV_2PI * p_choice
        } else {
            0.0
        }
    }

    /// `Strategy::Uniform`'s directions follow the density they report, chi-square tested over
    /// the sphere (the default significance, `Chi2Test`'s suite budget) on a surface whose shading
    /// normal is tilted from its geometric one, from both sides, in both transport modes: a
    /// diffuse surface, rough glass (the whole sphere, both microfacet distributions) and plastic,
    /// whose delta lobe is kept and taken as the BSDF takes it (delta samples are the test's
    /// rejected mass: the density integrates to 1 − P(delta)). Each accepted sample must report
    /// that density and the weight f·|cos θ|/p.
    #[test]
    fn uniform_directions_follow_their_pdf() {
        let bsdfs = [
            Bsdf::Diffuse {
                albedo: Rgb::new(0.8, 0.5, 0.2),
            },
            Bsdf::RoughDielectric {
                alpha: Vec2::splat(0.3),
                eta: 1.5,
                distribution: Distribution::Ggx,
            },
            Bsdf::RoughDielectric {
                alpha: Vec2::new(0.1, 0.4),
                eta: 1.0 / 1.33,
                distribution: Distribution::Beckmann,
            },
            Bsdf::Plastic(Plastic::new(
                Rgb::new(0.7, 0.4, 0.2),
                Rgb::splat(1.0),
                1.5,
                false,
            )),
        ];
        let ng = Vec3::new(0.0, 0.0, 1.0);
        let ns = Vec3::new(0.3, -0.2, 1.0).normalize();
        let dpdu = Vec3::X;
        let mut seed = 0;
        for bsdf in bsdfs {
            let sb = SurfaceBsdf::new(ns, dpdu, ng, bsdf);
            for wo in [
                Vec3::new(0.4, 0.3, 0.866).normalize(),
                Vec3::new(-0.5, 0.2, -0.6).normalize(),
            ] {
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    seed += 1;
                    let name = format!("uniform {bsdf:?}, wo {wo}, {mode:?}");
                    Chi2Test::new(Domain::Sphere)
                        .seed(seed)
                        .run_lobe(
                            &name,
                            |u_lobe, u| {
                                let s = sample(&sb, wo, u_lobe, u, mode, Directions::Uniform)?;
                                if s.delta {
                                    return None;
                                }
                                let pdf = uniform_pdf(&sb, wo, s.wi);
                                assert_eq!(s.pdf, pdf, "{name}: reported pdf at {}", s.wi);
                                // Near the shading horizon f32 rounding of cos θ (and of the
                                // adjoint correction's ratio of cosines) dominates.
                                let cos = sb.frame.n.dot(s.wi).abs();
                                let want = sb.eval(wo, s.wi, mode).f * (cos / pdf);
                                let pairs = [(s.weight.r, want.r), (s.weight.b, want.b)];
                                for (got, want) in pairs.into_iter().filter(|_| cos > 0.01) {
                                    assert!(
                                        (got - want).abs() <= 1e-3 * want.abs().max(1e-3),
                                        "{name}: weight {got} against {want} at {}",
                                        s.wi
                                    );
                                }
                                Some(s.wi)
                            },
                            |wi| uniform_pdf(&sb, wo, wi),
                        )
                        .assert_ok();
                }
            }
        }
    }
}
