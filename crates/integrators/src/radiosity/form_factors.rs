//! Form factors by ray casting (Malley's method; Cohen & Wallace 1993 §4.9.4, Sillion & Puech
//! 1994 §3.5): from side a of patch i, N rays leave points uniform over the patch in
//! cosine-distributed directions about that side's normal, and F̂_ab = n_ab / N, the fraction
//! landing on unknown b (the side of the patch they hit facing the ray).
//!
//! Estimator. A ray's origin has density 1/A_i and its direction cos θ/π, so the probability that
//! it lands on b is (1/A_i) ∫_{A_i} ∫_{A_b} V cos θ cos θ' / (π r²) dA dA' — exactly the
//! area-averaged form factor F_ab the radiosity equation uses. n_ab is binomial: F̂_ab is unbiased,
//! with variance F_ab (1 − F_ab) / N, and every row sums to at most 1 (to exactly 1 in a closed
//! scene; the rest escapes). Rows are independent of each other, each drawn from its own random
//! stream keyed by (seed, unknown), so the matrix does not depend on the thread count.

use super::patches::Patches;
use lightlab_core::Frame;
use lightlab_geometry::spawn_ray;
use lightlab_samplers::warp::square_to_cosine_hemisphere;
use lightlab_samplers::{Independent, Sampler};
use lightlab_scene::Scene;
use rayon::prelude::*;

/// The estimated form factors F̂ of every unknown, a sparse matrix of hit counts: row a's entries
/// are `(column, count)` pairs, F̂_ab = count / rays.
pub(crate) struct FormFactors {
    /// Row a is `entries[start[a]..start[a + 1]]`.
    start: Vec<usize>,
    entries: Vec<(u32, u32)>,
    /// Rays cast per row.
    pub rays: u32,
    /// Rays cast in all.
    pub rays_cast: u64,
}

/// Seed word of the form-factor streams (camera samples use the same seed under other keys).
const KEY: u64 = 0x666f_726d_5f66_6163;

impl FormFactors {
    /// Estimates the rows of the unknowns `active` marks, `rays` rays each; the other rows are
    /// empty (a side that neither reflects nor emits needs none).
    pub fn estimate(
        scene: &Scene,
        patches: &Patches,
        active: &[bool],
        rays: u32,
        seed: u64,
    ) -> FormFactors {
        let rows: Vec<Vec<(u32, u32)>> = (0..active.len())
            .into_par_iter()
            .map(|a| {
                if !active[a] || !(patches.list[a / 2].area > 0.0) {
                    return Vec::new();
                }
                let patch = &patches.list[a / 2];
                let side = if a % 2 == 0 { 1.0 } else { -1.0 };
                let mut sampler = Independent::keyed(&[seed, KEY, a as u64]);
                let mut hits: Vec<u32> = Vec::with_capacity(rays as usize);
                for _ in 0..rays {
                    let point = patch.sample(sampler.next_2d());
                    let n = side * point.n;
                    let d =
                        Frame::from_z(n).to_world(square_to_cosine_hemisphere(sampler.next_2d()));
                    if let Some(hit) = scene.intersect(&spawn_ray(point.p, point.p_error, n, d)) {
                        let back = d.dot(hit.ng) > 0.0;
                        hits.push(2 * patches.patch_of(&hit, scene) + back as u32);
                    }
                }
                hits.sort_unstable();
                let mut row: Vec<(u32, u32)> = Vec::new();
                for b in hits {
                    match row.last_mut() {
                        Some((c, n)) if *c == b => *n += 1,
                        _ => row.push((b, 1)),
                    }
                }
                row
            })
            .collect();
        let cast = active
            .iter()
            .enumerate()
            .filter(|&(a, &on)| on && patches.list[a / 2].area > 0.0)
            .count() as u64
            * rays as u64;
        let mut start = Vec::with_capacity(rows.len() + 1);
        start.push(0);
        let mut entries = Vec::with_capacity(rows.iter().map(Vec::len).sum());
        for row in rows {
            entries.extend(row);
            start.push(entries.len());
        }
        FormFactors {
            start,
            entries,
            rays,
            rays_cast: cast,
        }
    }

    /// Number of unknowns (rows).
    pub fn len(&self) -> usize {
        self.start.len() - 1
    }

    /// Row a: (b, n_ab) with F̂_ab = n_ab / rays.
    #[inline]
    pub fn row(&self, a: usize) -> &[(u32, u32)] {
        &self.entries[self.start[a]..self.start[a + 1]]
    }

    /// Stored entries (distinct (a, b) pairs a ray joined).
    pub fn entry_count(&self) -> usize {
        self.entries.len()
    }

    /// Σ_b F̂_ab x_b, channel by channel.
    #[inline]
    pub fn gather(&self, a: usize, x: &[[f64; 3]]) -> [f64; 3] {
        let mut s = [0.0; 3];
        for &(b, n) in self.row(a) {
            let xb = &x[b as usize];
            for c in 0..3 {
                s[c] += n as f64 * xb[c];
            }
        }
        let inv = 1.0 / self.rays as f64;
        s.map(|v| v * inv)
    }

    /// The transpose's rows: for each b, the (a, n_ab) of every row that hit it (progressive
    /// shooting spreads b's radiosity along its column).
    pub fn columns(&self) -> FormFactors {
        let n = self.len();
        let mut counts = vec![0usize; n + 1];
        for &(b, _) in &self.entries {
            counts[b as usize + 1] += 1;
        }
        for i in 0..n {
            counts[i + 1] += counts[i];
        }
        let mut fill = counts.clone();
        let mut entries = vec![(0u32, 0u32); self.entries.len()];
        for a in 0..n {
            for &(b, c) in self.row(a) {
                entries[fill[b as usize]] = (a as u32, c);
                fill[b as usize] += 1;
            }
        }
        FormFactors {
            start: counts,
            entries,
            rays: self.rays,
            rays_cast: 0,
        }
    }
}
