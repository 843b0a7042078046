//! The MIS weight of a strategy (Veach 1997 §10.2, §9.2): the fast form the renderer uses, a walk
//! over ratios of neighbouring strategies' densities from what the subpaths stored, and (for the
//! tests) the weight from its definition, every strategy's density recomputed from the path's
//! geometry. The two are tested against each other (`tests.rs`).

use super::{Bdpt, Mis};
use crate::walk::PathVertex;
use lightlab_scene::Scene;

impl Bdpt {
    /// The MIS weight of strategy (s, t) (pbrt-v4 `MISWeight`, balance heuristic). `sampled` replaces
    /// the endpoint that strategy sampled anew (the light point for s = 1, the lens point for t = 1).
    pub(crate) fn mis_weight(
        scene: &Scene,
        light: &[PathVertex],
        camera: &[PathVertex],
        sampled: Option<PathVertex>,
        s: usize,
        t: usize,
        heuristic: Mis,
    ) -> f32 {
        if matches!(heuristic, Mis::Only { .. }) {
            return 1.0;
        }
        let (lv, cv) = used_vertices(light, camera, &sampled, s, t);
        let rev = reverse_densities(scene, lv, cv, s, t);
        // The connection changes its end vertices and their predecessors: the ends are never delta
        // for the connection itself, and all four take the reverse densities it implies.
        let camera_rev = |i: usize| match t - i {
            1 => rev.camera,
            2 => rev.camera_prev,
            _ => cv[i].pdf_rev,
        };
        let light_rev = |i: usize| match s - i {
            1 => rev.light,
            2 => rev.light_prev,
            _ => lv[i].pdf_rev,
        };
        let camera_delta = |i: usize| i + 1 != t && cv[i].delta;
        // Strategy (s + t − 1, 1) joins the lens to cv[1]: impossible when that is the environment
        // a camera ray escaped to (s = 0, t = 2), as no connection reaches a light at infinity.
        let lens_reaches = |i: usize| i != 1 || !cv[1].infinite;
        let light_delta = |i: usize| i + 1 != s && lv[i].delta;
        let remap = |p: f32| if p != 0.0 { p } else { 1.0 };
        // Each other strategy i enters with rᵢ = pᵢ / p_s: the balance heuristic sums rᵢ, the power
        // heuristic (β = 2) rᵢ², uniform weights count the strategies (Veach 1997, §9.2).
        let term = |r: f32| match heuristic {
            Mis::Balance => r,
            Mis::Power => r * r,
            Mis::Uniform => 1.0,
            Mis::Only { .. } => 0.0,
        };
        let mut sum = 0.0f32;
        let mut ri = 1.0f32;
        for i in (1..t).rev() {
            ri *= remap(camera_rev(i)) / remap(cv[i].pdf_fwd);
            if !camera_delta(i) && !camera_delta(i - 1) && lens_reaches(i) {
                sum += term(ri);
            }
        }
        ri = 1.0;
        for i in (0..s).rev() {
            ri *= remap(light_rev(i)) / remap(lv[i].pdf_fwd);
            let delta_before = if i > 0 {
                light_delta(i - 1)
            } else {
                lv[0]
                    .light()
                    .is_some_and(|l| scene.lights[l as usize].is_delta())
            };
            if !light_delta(i) && !delta_before {
                sum += term(ri);
            }
        }
        1.0 / (1.0 + sum)
    }
}

/// The light and camera vertices strategy (s, t) used, without copying the subpaths: t = 1
/// samples the lens point (for s = t = 1 too, whose light vertex is the subpath's origin), which
/// is then the only camera vertex; s = 1 with t ≥ 2 samples a point on a light, the only light
/// vertex. `sampled` is that endpoint.
pub(crate) fn used_vertices<'a>(
    light: &'a [PathVertex],
    camera: &'a [PathVertex],
    sampled: &'a Option<PathVertex>,
    s: usize,
    t: usize,
) -> (&'a [PathVertex], &'a [PathVertex]) {
    let endpoint =
        || std::slice::from_ref(sampled.as_ref().expect("the strategy sampled an endpoint"));
    let camera = if t == 1 { endpoint() } else { &camera[..t] };
    let light = if s == 1 && t > 1 {
        endpoint()
    } else {
        &light[..s]
    };
    (light, camera)
}

/// The densities with which the other side of connection (s, t) generates its end vertices and
/// their predecessors (area measure; zero where there is no such vertex).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Reverse {
    /// y_{s−1} from z_{t−1} (arrived from z_{t−2}).
    pub light: f32,
    /// y_{s−2} from y_{s−1} (arrived from z_{t−1}).
    pub light_prev: f32,
    /// z_{t−1} from y_{s−1} (arrived from y_{s−2}); for s = 0 as a light subpath's origin.
    pub camera: f32,
    /// z_{t−2} from z_{t−1} (arrived from y_{s−1}); for s = 0 as emitted by z_{t−1}.
    pub camera_prev: f32,
}

/// The [`Reverse`] densities of connection (s, t) of `light` and `camera`, whose end vertices are
/// the ones the strategy used (the sampled endpoint already in place).
pub(crate) fn reverse_densities(
    scene: &Scene,
    light: &[PathVertex],
    camera: &[PathVertex],
    s: usize,
    t: usize,
) -> Reverse {
    let pt = &camera[t - 1];
    let pt_minus = t.checked_sub(2).map(|i| &camera[i]);
    let Some(qs) = s.checked_sub(1).map(|i| &light[i]) else {
        return Reverse {
            camera: pt.pdf_light_origin(scene),
            camera_prev: pt_minus.map_or(0.0, |p| pt.pdf_light(scene, p)),
            ..Reverse::default()
        };
    };
    let qs_minus = s.checked_sub(2).map(|i| &light[i]);
    Reverse {
        light: pt.pdf(scene, pt_minus, qs),
        light_prev: qs_minus.map_or(0.0, |q| qs.pdf(scene, Some(pt), q)),
        camera: qs.pdf(scene, qs_minus, pt),
        camera_prev: pt_minus.map_or(0.0, |p| pt.pdf(scene, Some(qs), p)),
    }
}

/// The weight of strategy `s` (s light vertices) for the full path `x`, light first (x₀ on a
/// light, x_k the camera), from its definition (Veach 1997 eq. 9.13 and §10.2): strategy i
/// samples the path with density pᵢ = Π_{j<i} L_j · Π_{j≥i} C_j, where L_j is the area density
/// with which the light side generates x_j and C_j the camera side's (C_k = 1: the lens point is
/// never weighed), each recomputed from the geometry; wₛ = pₛ^β / Σᵢ pᵢ^β over the strategies
/// that can make the path — none connects at a Dirac-delta surface, no camera path hits a
/// point light (i = 0), and the lens is never joined to a light at infinity (i = k = 1). A density generated through a delta vertex, which `PathVertex::pdf`
/// cannot evaluate (0), enters as 1, as the fast form reads it: every possible strategy holds
/// exactly one of the two a delta vertex has (the light side's if it connects after it, the
/// camera side's if before), so this is the convention of their ratio being 1.
#[cfg(test)]
pub(super) fn reference_weight(scene: &Scene, x: &[PathVertex], s: usize, heuristic: Mis) -> f64 {
    let k = x.len() - 1;
    let densities = PathDensities::new(scene, x);
    // x₀ (the light) and x_k (the lens) are never delta surfaces.
    let possible = |i: usize| match i {
        0 => !densities.delta_light && !x[0].delta,
        _ => !(x[i - 1].delta || x[i].delta || (i == k && x[i - 1].infinite)),
    };
    let density = |i: usize| densities.strategy(i);
    let term = |i: usize| match heuristic {
        Mis::Balance => density(i),
        Mis::Power => density(i).powi(2),
        Mis::Uniform => 1.0,
        Mis::Only { .. } => (i == s) as u8 as f64,
    };
    let total: f64 = (0..=k).filter(|&i| possible(i)).map(term).sum();
    term(s) / total
}

/// The area densities with which the light side (L_j) and the camera side (C_j) generate each
/// vertex x_j of a full path, light first, recomputed from the geometry; a density through a
/// delta vertex enters as 1 (see `reference_weight`), and C_k = 1 (the lens point).
#[cfg(test)]
pub(crate) struct PathDensities {
    /// L_j.
    pub light: Vec<f64>,
    /// C_j.
    camera: Vec<f64>,
    /// Whether x₀ is on a light no ray can hit (point, spot, directional).
    pub delta_light: bool,
}

#[cfg(test)]
impl PathDensities {
    pub fn new(scene: &Scene, x: &[PathVertex]) -> PathDensities {
        let k = x.len() - 1;
        let remap = |p: f32| if p != 0.0 { p as f64 } else { 1.0 };
        let light = (0..=k)
            .map(|j| match j {
                0 => remap(x[0].pdf_light_origin(scene)),
                _ => remap(x[j - 1].pdf(scene, j.checked_sub(2).map(|i| &x[i]), &x[j])),
            })
            .collect();
        let camera = (0..=k)
            .map(|j| match j {
                _ if j == k => 1.0,
                _ => remap(x[j + 1].pdf(scene, x.get(j + 2), &x[j])),
            })
            .collect();
        let delta_light = x[0]
            .light()
            .is_some_and(|l| scene.lights[l as usize].is_delta());
        PathDensities {
            light,
            camera,
            delta_light,
        }
    }

    /// The density of the path sampled with i light vertices: Π_{j<i} L_j · Π_{j≥i} C_j.
    pub fn strategy(&self, i: usize) -> f64 {
        self.light[..i].iter().product::<f64>() * self.camera[i..].iter().product::<f64>()
    }
}
