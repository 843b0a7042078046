//! Vertex merging (Georgiev et al. 2012, §4.2; Hachisuka et al. 2012): a camera vertex z takes
//! every light vertex y of the pass within the radius r as the end of a light subpath that
//! reached z, the density estimate of photon mapping (Jensen 2001, eq. 7.6, uniform kernel):
//!
//!   β_z · f(z, ω_z, ω_y) · β_y · |ω_y·n_s| / |ω_y·n_g| / (π r² N),
//!
//! N the light paths of the pass and β_y the flux a light path brings to y. The uniform kernel
//! is the one the merge's acceptance probability π r² C_z in the MIS weights assumes. Light
//! vertices on a surface facing the other way (the far side of a thin wall) are not merged with,
//! as in the photon mappers.

use super::mis::{Quantities, Techniques};
use super::pass::LightPass;
use crate::walk::PathVertex;
use lightlab_core::{Rgb, TransportMode};

/// One merge at a camera vertex.
pub(super) struct Merged<'a> {
    /// The light vertex.
    pub light: &'a PathVertex,
    /// Its light subpath up to and including it.
    pub light_path: &'a [PathVertex],
    /// The merge's estimate before its MIS weight.
    pub unweighted: Rgb,
    pub weight: f32,
}

/// Merges camera vertex z = `camera[t − 1]` (quantities `z_q`) with the light vertices of `pass`
/// within its radius that complete a path of `bounces` scattering vertices, calling `visit` for
/// each that carries light; `scale` is 1 / (π r² N).
#[allow(clippy::too_many_arguments)]
pub(super) fn merge(
    pass: &LightPass,
    techniques: &Techniques,
    camera: &[PathVertex],
    t: usize,
    z_q: Quantities,
    scale: f32,
    bounces: (u32, u32),
    mut visit: impl FnMut(&Merged),
) {
    let z = &camera[t - 1];
    let (Some(grid), Some(sb)) = (&pass.grid, &z.sb) else {
        return;
    };
    grid.within(z.p, |m, _| {
        let (i, chunk) = (m.index as usize, &pass.chunks[m.chunk as usize]);
        let y = &chunk.vertices[i];
        let n = y.depth + z.depth - 1;
        if n < bounces.0 || n > bounces.1 || y.ng.dot(z.ng) <= 0.0 {
            return;
        }
        let wi = y.wo;
        let f = sb.eval(z.wo, wi, TransportMode::Radiance).f;
        if f.is_black() {
            return;
        }
        let (cos_s, cos_g) = (wi.dot(z.ns).abs(), wi.dot(z.ng).abs());
        let shading = if cos_s == cos_g { 1.0 } else { cos_s / cos_g };
        visit(&Merged {
            light: y,
            // A light subpath's vertices are numbered from 0 at its origin.
            light_path: &chunk.vertices[i - y.depth as usize..=i],
            unweighted: z.beta * f * y.beta * (shading * scale),
            // The light vertex has depth ≥ 1, so its predecessor is the vertex before it.
            weight: merge_weight(
                techniques,
                (y, chunk.quantities[i], &chunk.vertices[i - 1]),
                (z, z_q, &camera[t - 2]),
            ),
        });
    });
}

/// The MIS weight of merging camera vertex z with light vertex y, each given with its
/// quantities and predecessor: the predecessors' densities are those of z's BSDF sampling
/// toward y's predecessor (for light arriving from z's) and toward z's predecessor (for light
/// arriving from y's), the merged vertex standing for both.
pub(super) fn merge_weight(
    techniques: &Techniques,
    (y, y_q, y_prev): (&PathVertex, Quantities, &PathVertex),
    (z, z_q, z_prev): (&PathVertex, Quantities, &PathVertex),
) -> f32 {
    let Some(sb) = &z.sb else { return 0.0 };
    let light_prev = y.convert_density(sb.pdf(z.wo, y.wo), y_prev);
    let camera_prev = z.convert_density(sb.pdf(y.wo, z.wo), z_prev);
    techniques.merge(y_q, z_q, light_prev, camera_prev)
}
