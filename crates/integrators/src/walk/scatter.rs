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
