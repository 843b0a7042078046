//! The photon map: photons indexed by a kd-tree (kiddo's immutable tree; Bentley 1975, Jensen 2001
//! ch. 6) and the radiance estimate built from them.
//!
//! Density estimation (Jensen 2001, eq. 7.6, with a kernel as in Silverman 1986):
//!
//!   L(x, ωo) ≈ 1/(π r²) · Σ_p K(d_p² / r²) · f(x, ωo, ωp) · Φ_p · |ωp·n_s| / |ωp·n_g|,
//!
//! where K is normalised so that ∫ K over the unit disk is π, f is evaluated without the cosine
//! (the photon density already is flux per unit area), and the last factor converts flux per
//! geometric area into the shading-normal cosine the BSDF expects (it is 1 without shading
//! normals). Only photons whose surface faces the same way as the gather point's are used
//! (Mitsuba issue #145: photons on the far side of a thin wall), and the BSDF's own side test
//! rejects photons from behind.
//!
//! Bias. With a fixed radius the estimate is unbiased where the photon density is constant over
//! the disk. With the k nearest photons the radius r_k is the k-th photon's distance, and the
//! k − 1 photons inside it are what is summed: given r_k they are uniform in the disk (for a
//! constant density), and (k − 1)/(π r_k²) is the unbiased estimate of the density (Silverman
//! 1986, §5.2; counting the k-th photon too, as Jensen 2001 eq. 7.6 does, overestimates by
//! k/(k − 1): +2 % at k = 50, +11 % at k = 10, however many photons are traced). Elsewhere the
//! density varies over the disk and the estimate is biased toward its average there; that blur is
//! what vanishes only as the radius shrinks — more photons for a fixed k, or progressive radii.
//!
//! Photon groups. A map's photon paths are split into `GROUPS` contiguous ranges of path index;
//! each photon knows its group, so an estimator can also sum each group's share and estimate its
//! own variance from the spread of the independent group estimates.

use super::trace::{Photon, Traced};
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use lightlab_core::{INV_PI, Rgb, TransportMode};
use lightlab_materials::SurfaceBsdf;
use serde::{Deserialize, Serialize};
use std::num::NonZero;

/// Density-estimation kernel, as a function of t = d²/r², normalised to ∫_disk K dA = π r².
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Kernel {
    /// K = 1: every photon in the disk counts equally (Jensen 2001, eq. 7.6).
    #[default]
    Uniform,
    /// K = 3 (1 − d/r): the cone filter (Jensen 2001, §7.2.1, with k = 1).
    Cone,
    /// K = 2 (1 − d²/r²): the Epanechnikov kernel, optimal in the AMISE sense (Silverman 1986, §4.3.1).
    Epanechnikov,
}

impl Kernel {
    /// Weight of a photon at squared distance `t·r²` (0 ≤ t ≤ 1).
    #[inline]
    pub fn weight(self, t: f32) -> f32 {
        match self {
            Kernel::Uniform => 1.0,
            Kernel::Cone => 3.0 * (1.0 - t.sqrt()).max(0.0),
            Kernel::Epanechnikov => 2.0 * (1.0 - t).max(0.0),
        }
    }
}

/// How the photons of one estimate are found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Search {
    /// Every photon within `radius_sq`.
    Radius {
        /// The squared radius (kiddo's distances are squared).
        radius_sq: f32,
    },
    /// The k nearest photons, no farther than `max_radius_sq`; the estimate's radius is the k-th
    /// distance (or the cap when fewer are found).
    Nearest {
        /// Photons found.
        k: usize,
        /// Squared largest search radius.
        max_radius_sq: f32,
    },
}

/// A point where radiance is estimated from photons.
#[derive(Clone, Copy, Debug)]
pub struct GatherPoint {
    /// The surface point.
    pub p: Vec3,
    /// Unit direction toward the camera side of the path.
    pub wo: Vec3,
    /// The surface's BSDF there, which weights each photon.
    pub bsdf: SurfaceBsdf,
}

/// Smallest subtree (in photons) whose two halves the kd-tree build makes on two threads.
const PARALLEL_BUILD: usize = 16_384;

/// Photons indexed by a kd-tree (kiddo) for radius and k-nearest searches (Jensen 2001, ch. 6),
/// with the photon groups that give its own variance.
pub struct PhotonMap {
    photons: Vec<Photon>,
    /// Index of the first photon of each group (photons are in path order, groups are ranges of
    /// paths), `GROUPS` entries.
    group_starts: Vec<u32>,
    /// `None` when there are no photons (kiddo cannot build an empty tree).
    tree: Option<ImmutableKdTree<f32, 3>>,
}

impl PhotonMap {
    /// Bytes the kd-tree holds per photon: a copy of its position and its index (kiddo's stems
    /// add a few per cent).
    const TREE_BYTES: usize = size_of::<[f32; 3]>() + size_of::<u32>();

    /// Bytes of a map that will hold `photons` photons.
    pub fn bytes_for(photons: f64) -> f64 {
        photons * (size_of::<Photon>() + Self::TREE_BYTES) as f64
    }

    /// Indexes the photons of a tracing pass.
    pub fn new(traced: Traced) -> PhotonMap {
        let Traced {
            photons,
            group_starts,
        } = traced;
        let points: Vec<[f32; 3]> = photons.iter().map(|p| p.p.to_array()).collect();
        let tree = if points.is_empty() {
            None
        } else {
            // Built in parallel from this many points down (kiddo's default starts at 262 144,
            // which left a progressive pass's map of ≈ 230 000 photons to one core); the tree is
            // the serial build's, node for node (kiddo tests that), so images do not change.
            ImmutableKdTree::<f32, 3>::builder()
                .with_parallel_construction_threshold(PARALLEL_BUILD)
                .build_from_slice(&points)
                .ok()
        };
        PhotonMap {
            photons,
            group_starts,
            tree,
        }
    }

    /// The group of photon `i`.
    #[inline]
    pub fn group(&self, i: u32) -> usize {
        self.group_starts
            .partition_point(|&start| start <= i)
            .max(1)
            - 1
    }

    /// Its photons, in path order.
    pub fn photons(&self) -> &[Photon] {
        &self.photons
    }

    /// Number of photons.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// Whether it holds no photon.
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// Bytes held: photons plus the tree (its points and item indices).
    pub fn bytes(&self) -> usize {
        self.photons.capacity() * size_of::<Photon>() + self.photons.len() * Self::TREE_BYTES
    }

    /// Calls `visit(photon, index, d²)` for every photon within `radius_sq` of `p` (in no
    /// particular but deterministic order).
    #[inline]
    pub fn within(&self, p: Vec3, radius_sq: f32, mut visit: impl FnMut(&Photon, u32, f32)) {
        let Some(tree) = &self.tree else { return };
        tree.query(&p.to_array())
            .within::<SquaredEuclidean<f32>>(radius_sq)
            .unsorted()
            .visit(|it| visit(&self.photons[it.item as usize], it.item, it.distance));
    }

    /// The k nearest photons within `max_radius_sq`, nearest first, as (index, d²).
    pub fn nearest(&self, p: Vec3, k: usize, max_radius_sq: f32) -> Vec<(u32, f32)> {
        // No query returns more than the map holds: a k beyond it (up to u32::MAX is accepted)
        // would only size kiddo's result buffer, 8 bytes per k.
        let (Some(tree), Some(k)) = (&self.tree, NonZero::new(k.min(self.photons.len()))) else {
            return Vec::new();
        };
        tree.query(&p.to_array())
            .nearest_n::<SquaredEuclidean<f32>>(k)
            .within(max_radius_sq)
            .execute()
            .into_iter()
            .map(|it| (it.item, it.distance))
            .collect()
    }

    /// The density estimate of reflected radiance at `g`, photon by photon: `sink(photon, group,
    /// c)` with c = K(d²/r²) · f · Φ · (shading factor) / (π r²), so that the estimate is the sum of
    /// the c of the photons the caller keeps. Returns r². With `Nearest`, r is the k-th photon's
    /// distance and that photon is not summed (the estimate would be k/(k − 1) too large; see the
    /// module docs), unless fewer than k lie within the cap, which is then a fixed radius. The
    /// radius is set by all photons, kept or not, so the photons kept are a thinning of a disk of
    /// known area.
    pub fn estimate(
        &self,
        g: &GatherPoint,
        search: Search,
        kernel: Kernel,
        mut sink: impl FnMut(&Photon, usize, Rgb),
    ) -> f32 {
        match search {
            Search::Radius { radius_sq } => {
                let norm = INV_PI / radius_sq;
                self.within(g.p, radius_sq, |ph, i, d2| {
                    sink(
                        ph,
                        self.group(i),
                        contribution(g, ph) * (kernel.weight(d2 / radius_sq) * norm),
                    );
                });
                radius_sq
            }
            Search::Nearest { k, max_radius_sq } => {
                let mut found = self.nearest(g.p, k, max_radius_sq);
                let radius_sq = if found.len() == k {
                    found.pop().map_or(max_radius_sq, |(_, d2)| d2)
                } else {
                    max_radius_sq
                };
                if radius_sq > 0.0 {
                    let norm = INV_PI / radius_sq;
                    for &(i, d2) in &found {
                        let ph = &self.photons[i as usize];
                        sink(
                            ph,
                            self.group(i),
                            contribution(g, ph) * (kernel.weight(d2 / radius_sq) * norm),
                        );
                    }
                }
                radius_sq
            }
        }
    }
}

/// f(ωo, ωp) · Φ_p · |ωp·n_s| / |ωp·n_g| for one photon, or zero when its surface faces away.
#[inline]
pub fn contribution(g: &GatherPoint, ph: &Photon) -> Rgb {
    if ph.ng().dot(g.bsdf.ng) <= 0.0 {
        return Rgb::BLACK;
    }
    let wi = ph.wi();
    let f = g.bsdf.eval(g.wo, wi, TransportMode::Radiance).f;
    if f.is_black() {
        return Rgb::BLACK;
    }
    let (cos_s, cos_g) = (wi.dot(g.bsdf.frame.n).abs(), wi.dot(g.bsdf.ng).abs());
    let shading = if cos_s == cos_g { 1.0 } else { cos_s / cos_g };
    f * ph.power * shading
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightlab_samplers::{Independent, Sampler};

    fn photon_at(p: Vec3) -> Photon {
        photon(p, Vec3::Z, Vec3::Z)
    }

    fn photon(p: Vec3, wi: Vec3, ng: Vec3) -> Photon {
        Photon::new(
            p,
            wi,
            ng,
            Rgb::WHITE,
            crate::paths::PathClass::EMPTY.push(lightlab_materials::LobeClass::Diffuse),
        )
    }

    /// kd-tree gathers equal a linear scan on random queries, for radius and kNN searches
    /// (radius² passed to kiddo, not r).
    #[test]
    fn gathers_match_a_linear_scan() {
        let mut s = Independent::new();
        s.start_pixel_sample(7, 0, 0);
        let photons: Vec<Photon> = (0..5000)
            .map(|_| photon_at(Vec3::new(s.next_1d(), s.next_1d(), s.next_1d() * 0.1)))
            .collect();
        let map = PhotonMap::new(Traced::ungrouped(photons.clone()));
        for q in 0..200 {
            let p = Vec3::new(s.next_1d(), s.next_1d(), 0.05);
            let r = 0.01 + 0.1 * (q as f32 / 200.0);
            let mut from_tree: Vec<usize> = Vec::new();
            map.within(p, r * r, |ph, _, d2| {
                assert!((d2 - ph.p.distance_squared(p)).abs() < 1e-6);
                from_tree.push(photons.iter().position(|x| x.p == ph.p).unwrap());
            });
            from_tree.sort();
            let scan: Vec<usize> = (0..photons.len())
                .filter(|&i| photons[i].p.distance_squared(p) <= r * r)
                .collect();
            assert_eq!(from_tree, scan, "query {q} at {p} r {r}");

            let k = 1 + q % 60;
            let mut by_distance: Vec<(f32, usize)> = (0..photons.len())
                .map(|i| (photons[i].p.distance_squared(p), i))
                .filter(|&(d2, _)| d2 <= r * r)
                .collect();
            by_distance.sort_by(|a, b| a.0.total_cmp(&b.0));
            by_distance.truncate(k);
            let knn = map.nearest(p, k, r * r);
            assert_eq!(knn.len(), by_distance.len(), "query {q}");
            for (a, b) in knn.iter().zip(&by_distance) {
                assert!((a.1 - b.0).abs() < 1e-7, "query {q}: {a:?} vs {b:?}");
            }
        }
        // A k beyond the photons held (any u32 is accepted) finds them all, allocating no more.
        let all = map.nearest(Vec3::splat(0.5), u32::MAX as usize, f32::INFINITY);
        assert_eq!(all.len(), photons.len());
    }

    /// Photons on the far side of a thin wall (opposite normal) or arriving from behind the
    /// surface do not light the gather point (Mitsuba issue #145); one from the front does, with
    /// f·Φ = Φ/π for a white Lambertian.
    #[test]
    fn photons_from_behind_are_rejected() {
        let g = GatherPoint {
            p: Vec3::ZERO,
            wo: Vec3::new(0.0, 0.6, 0.8),
            bsdf: SurfaceBsdf::new(
                Vec3::Z,
                Vec3::X,
                Vec3::Z,
                lightlab_materials::Bsdf::Diffuse { albedo: Rgb::WHITE },
            ),
        };
        let front = photon(Vec3::ZERO, Vec3::new(0.0, -0.6, 0.8), Vec3::Z);
        let c = contribution(&g, &front);
        assert!((c.g - 1.0 / std::f32::consts::PI).abs() < 1e-5, "{c:?}");
        let far_side = photon(Vec3::ZERO, Vec3::new(0.0, 0.6, -0.8), -Vec3::Z);
        assert!(contribution(&g, &far_side).is_black());
        let from_behind = photon(Vec3::ZERO, Vec3::new(0.0, 0.6, -0.8), Vec3::Z);
        assert!(contribution(&g, &from_behind).is_black());
    }

    /// Each kernel integrates to π over the unit disk (midpoint rule in t = d²/r², for which the
    /// disk's area element is π dt).
    #[test]
    fn kernels_are_normalised() {
        for kernel in [Kernel::Uniform, Kernel::Cone, Kernel::Epanechnikov] {
            let n = 100_000;
            let integral: f64 = (0..n)
                .map(|i| kernel.weight((i as f32 + 0.5) / n as f32) as f64)
                .sum::<f64>()
                * std::f64::consts::PI
                / n as f64;
            assert!(
                (integral - std::f64::consts::PI).abs() < 1e-4,
                "{kernel:?}: {integral}"
            );
        }
    }
}
