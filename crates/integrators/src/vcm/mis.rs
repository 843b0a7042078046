//! The MIS weights of VCM's techniques (Georgiev et al. 2012, §4–5; Georgiev 2012, "Implementing
//! vertex connection and merging", the technical report's recursive quantities), computed in O(1)
//! per technique from two numbers each subpath vertex carries, and (for the tests) the weights
//! from their definition.
//!
//! Techniques of a path x₀ (on a light) … x_k (the lens): the connections s = 0 … k of
//! bidirectional path tracing (s light vertices, t = k + 1 − s ≥ 1 camera vertices), density
//! p_s = Π_{j<s} L_j · Π_{j≥s} C_j (L_j, C_j: the area densities with which the light and the
//! camera side generate x_j; C_k = 1), and a merge at every non-delta interior vertex x_j
//! (1 ≤ j ≤ k − 1): the light subpath reaches x_j, the camera subpath lands within r of it, which
//! it does with probability ≈ π r² C_j, so p_M,j = p_{j+1} · π r² C_j = p_j · π r² L_j. Per pass a
//! camera path is connected to one light path and merged with all N of them, so merges enter the
//! heuristic with the sample count N (Georgiev et al. eq. 11): n·p_M,j = η L_j p_j with
//! η = π r² N. The balance heuristic weighs technique τ by n_τ p_τ / Σ n p, the power heuristic by
//! (n_τ p_τ)² / Σ (n p)².
//!
//! Recursion. For a light vertex y_m (m ≥ 0, the subpath's own numbering) write r_j = C_j / L_j.
//! The sum over the techniques that generate more of the path from the camera, relative to the
//! connection ending at y_m, is C_m · Q_m with
//!
//!   Q_m = a_m + η·[merge at y_m] + C_{m−1} · b_m,   a_m = [connection before y_m] / L_m,
//!   b_m = Q_{m−1} / L_m,
//!
//! and the same holds on the camera side with the roles of L and C exchanged. C_m and C_{m−1}
//! depend on the vertex the subpath is joined to; everything else is known once the walk has
//! passed y_m. `d_vcm` = a_m and `d_vc` = b_m are the report's dVCM and dVC written in the area
//! measure (the report divides the densities into solid-angle and geometric parts; here the walk
//! already stores the area densities). The report's third quantity, dVM = dVC / η, serves its
//! merge weights when both techniques are on; below, merges are weighted with the same two
//! numbers, and a variant that leaves a technique out zeroes its terms instead (`Techniques`).
//!
//! Conventions shared with BDPT (`bdpt::mis`): a density of 0 enters as 1, a delta vertex's two
//! densities are written as `walk::vertex::delta_densities` does, no connection or merge happens
//! at a delta vertex, no camera path hits a point or spot light, Russian roulette is not in the
//! densities.

use crate::walk::PathVertex;
use serde::{Deserialize, Serialize};

/// How VCM weights its techniques (Veach 1997, §9.2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Heuristic {
    /// wᵢ = nᵢpᵢ / Σⱼ nⱼpⱼ.
    #[default]
    Balance,
    /// wᵢ = (nᵢpᵢ)² / Σⱼ (nⱼpⱼ)².
    Power,
}

impl Heuristic {
    /// A density (or η) as the heuristic sums it.
    #[inline]
    pub fn of(self, x: f64) -> f64 {
        match self {
            Heuristic::Balance => x,
            Heuristic::Power => x * x,
        }
    }
}

/// Which techniques a variant combines.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Techniques {
    /// Connections with s ≥ 1 (BDPT's strategies besides a camera path hitting a light).
    pub connect: bool,
    /// Merges.
    pub merge: bool,
    pub heuristic: Heuristic,
    /// η = π r² N as the heuristic sums it (0 without merges), N the light paths of a pass.
    pub eta: f64,
    /// ℓ, the light paths per pixel and pass (all splatted through the lens), as the heuristic
    /// sums it: the sample count of the light-tracing strategies (t = 1) against the camera
    /// path's one connection.
    pub light_tracing: f64,
}

/// The two numbers a subpath vertex carries for the weights (module docs): `d_vcm` = a_m, the
/// connection that ends just before it, and `d_vc` = b_m, everything before that.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Quantities {
    pub d_vcm: f64,
    pub d_vc: f64,
}

/// A density as the weights read it: 0 (undefined) enters as 1, as in BDPT.
#[inline]
fn remap(p: f32) -> f64 {
    if p != 0.0 { p as f64 } else { 1.0 }
}

impl Techniques {
    #[inline]
    fn of(&self, p: f32) -> f64 {
        self.heuristic.of(remap(p))
    }

    #[inline]
    fn inverse(&self, p: f32) -> f64 {
        self.heuristic.of(1.0 / remap(p))
    }

    /// Whether a merge can happen at `v`: a non-delta surface vertex at least one scattering
    /// vertex from its subpath's origin.
    #[inline]
    pub fn merges_at(&self, v: &PathVertex) -> bool {
        self.merge && v.depth >= 1 && v.on_surface() && v.sb.is_some_and(|sb| !sb.bsdf.is_delta())
    }

    /// The quantities of every vertex of a subpath (`light`: a light subpath, whose origin a
    /// camera path can hit unless the light is a delta light, `delta_light`), appended to `out`.
    pub fn subpath(
        &self,
        path: &[PathVertex],
        light: bool,
        delta_light: bool,
        out: &mut Vec<Quantities>,
    ) {
        let base = out.len();
        for (m, v) in path.iter().enumerate() {
            let inv_fwd = self.inverse(v.pdf_fwd);
            let q = if m == 0 {
                // The connection before a light origin is s = 0, a camera path hitting it (always
                // a technique, where possible); there is none before the lens.
                let possible = light && !delta_light;
                Quantities {
                    d_vcm: if possible { inv_fwd } else { 0.0 },
                    d_vc: 0.0,
                }
            } else {
                let prev = &path[m - 1];
                let qp = out[base + m - 1];
                // Q_{m−1}: the connection ending at y_{m−1} needs it non-delta, a merge there is one
                // if it merges; C_{m−2} was stored once the walk scattered at y_{m−1}.
                let before = if m >= 2 {
                    self.of(path[m - 2].pdf_rev) * qp.d_vc
                } else {
                    0.0
                };
                let q_prev = if prev.delta { 0.0 } else { qp.d_vcm }
                    + if !prev.delta && self.merges_at(prev) {
                        self.eta
                    } else {
                        0.0
                    }
                    + before;
                // Connections with s ≥ 1 are the only ones before a camera vertex or a light
                // vertex past the origin; before the first camera vertex it is light tracing's
                // (t = 1), with its sample count ℓ.
                // Light tracing never joins the lens to a light at infinity: a camera ray that
                // escaped at once found the environment by s = 0 alone.
                let possible = self.connect && !prev.delta && (light || m != 1 || !v.infinite);
                let count = if !light && m == 1 {
                    self.light_tracing
                } else {
                    1.0
                };
                Quantities {
                    d_vcm: if possible { count * inv_fwd } else { 0.0 },
                    d_vc: inv_fwd * q_prev,
                }
            };
            out.push(q);
        }
    }

    /// The quantities of a light point sampled for next-event estimation (density `pdf_fwd` as a
    /// light subpath's origin), as [`Techniques::subpath`] gives a light origin.
    pub fn sampled_light(&self, v: &PathVertex, delta_light: bool) -> Quantities {
        Quantities {
            d_vcm: if delta_light {
                0.0
            } else {
                self.inverse(v.pdf_fwd)
            },
            d_vc: 0.0,
        }
    }

    /// The sum over one side's techniques relative to a connection ending at its vertex with
    /// quantities `q`: C_m · (a_m + η·[merge] + C_{m−1} · b_m), `rev` and `rev_prev` the other
    /// side's densities of the vertex and its predecessor.
    #[inline]
    fn side(&self, q: Quantities, rev: f32, rev_prev: f32, merge: bool) -> f64 {
        self.of(rev) * (q.d_vcm + if merge { self.eta } else { 0.0 } + self.of(rev_prev) * q.d_vc)
    }

    /// The weight of a connection whose light end has quantities `light` (`None` for s = 0) and
    /// may merge, whose camera end has `camera` and may merge (`None` for t = 1, the lens point
    /// sampled by light tracing, whose sample count ℓ divides the others'), given the
    /// connection's reverse densities (`bdpt::mis::Reverse`).
    pub fn connection(
        &self,
        light: Option<(Quantities, bool)>,
        camera: Option<(Quantities, bool)>,
        rev: &crate::bdpt::Reverse,
    ) -> f32 {
        let w_light = light.map_or(0.0, |(q, merge)| {
            self.side(q, rev.light, rev.light_prev, merge)
        });
        let weight = match camera {
            Some((q, merge)) => {
                1.0 / (w_light + 1.0 + self.side(q, rev.camera, rev.camera_prev, merge))
            }
            None => 1.0 / (w_light / self.light_tracing + 1.0),
        };
        weight as f32
    }

    /// The weight of merging camera vertex z (quantities `camera`) with light vertex y
    /// (`light`), `light_prev` the density of y's predecessor sampled from z's BSDF toward it,
    /// `camera_prev` that of z's predecessor sampled from z's BSDF for light arriving from y.
    pub fn merge(
        &self,
        light: Quantities,
        camera: Quantities,
        light_prev: f32,
        camera_prev: f32,
    ) -> f32 {
        let others = light.d_vcm
            + self.of(light_prev) * light.d_vc
            + camera.d_vcm
            + self.of(camera_prev) * camera.d_vc;
        (self.eta / (others + self.eta)) as f32
    }
}

/// One technique of a full path.
#[cfg(test)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Technique {
    /// Connection with s light vertices.
    Connect(usize),
    /// Merge at x_j.
    Merge(usize),
}

/// The weight of technique `tech` for the full path `x`, light first (x₀ on a light, x_k the
/// camera), from its definition (module docs; `bdpt::mis::reference_weight` for the
/// connections): every density recomputed from the geometry, n·p of each technique summed over
/// those the variant has that can make the path. `eta` is η = π r² N itself and `light_paths`
/// ℓ (not as the heuristic sums them): n is ℓ for light tracing (s = k, t = 1), 1 for the other
/// connections; a merge's n·p is η·L_j·p_j.
#[cfg(test)]
pub(super) fn reference_weight(
    scene: &lightlab_scene::Scene,
    x: &[PathVertex],
    tech: Technique,
    techniques: &Techniques,
    (eta, light_paths): (f64, f64),
) -> f64 {
    let k = x.len() - 1;
    let densities = crate::bdpt::PathDensities::new(scene, x);
    let possible = |t: Technique| match t {
        Technique::Connect(0) => !densities.delta_light && !x[0].delta,
        Technique::Connect(i) => {
            techniques.connect && !(x[i - 1].delta || x[i].delta || (i == k && x[i - 1].infinite))
        }
        Technique::Merge(j) => techniques.merge && !x[j].delta,
    };
    let density = |t: Technique| match t {
        Technique::Connect(i) if i == k => light_paths * densities.strategy(i),
        Technique::Connect(i) => densities.strategy(i),
        Technique::Merge(j) => eta * densities.light[j] * densities.strategy(j),
    };
    let term = |t: Technique| techniques.heuristic.of(density(t));
    let all = (0..=k)
        .map(Technique::Connect)
        .chain((1..k).map(Technique::Merge));
    let total: f64 = all.filter(|&t| possible(t)).map(term).sum();
    term(tech) / total
}
