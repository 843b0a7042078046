//! A uniform hash grid over photons for fixed-radius gathering (Teschner et al. 2003's spatial
//! hash; the structure SmallVCM and pbrt-v4's SPPM use): cells of edge 2r, so the photons within r
//! of a point lie in the 2 × 2 × 2 cells nearest it. Faster to build and query than the kd-tree
//! when one radius serves every query (BENCHMARKS.md, "Photon maps"); SPPM uses it with the
//! `Global` radius schedule, VCM with the light vertices it merges with.

use super::trace::Photon;
use glam::{IVec3, Vec3};
use rayon::prelude::*;

/// Something with a place in space, to be found by a grid.
pub trait Located: Copy + Send + Sync {
    /// Where it is.
    fn position(&self) -> Vec3;
}

impl Located for Photon {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// Items (photons by default) bucketed by a spatial hash of cells of edge 2r, for gathers of
/// radius r.
pub struct HashGrid<T: Located = Photon> {
    /// Items sorted by cell hash.
    photons: Vec<T>,
    /// `cell_ends[h]`: one past the last photon of hash bucket h (prefix sums of the counts).
    cell_ends: Vec<u32>,
    origin: Vec3,
    inv_cell: f32,
    radius_sq: f32,
}

impl<T: Located> HashGrid<T> {
    /// Builds a grid of `photons` for gathering within `radius` (> 0) of query points: a counting
    /// sort by bucket, stable (a bucket keeps the input order), whose per-item steps (the bounds,
    /// the buckets, the final copy) run in parallel and whose serial steps touch only indices.
    pub fn new(photons: &[T], radius: f32) -> HashGrid<T> {
        // The minimum is exact and `f32::min` passes over NaN (glam's `Vec3::min` would not), so
        // any grouping of the reduction, whatever the thread count, gives the same origin.
        let min = |a: Vec3, b: Vec3| Vec3::new(a.x.min(b.x), a.y.min(b.y), a.z.min(b.z));
        let origin = photons
            .par_iter()
            .map(|p| p.position())
            .reduce(|| Vec3::splat(f32::INFINITY), min);
        let mut grid = HashGrid {
            photons: Vec::new(),
            cell_ends: vec![0; photons.len().max(1)],
            origin,
            inv_cell: 1.0 / (2.0 * radius),
            radius_sq: radius * radius,
        };
        let keys: Vec<u32> = photons
            .par_iter()
            .map(|p| grid.bucket(grid.cell_of(p.position())) as u32)
            .collect();
        for &k in &keys {
            grid.cell_ends[k as usize] += 1;
        }
        let mut sum = 0;
        for e in grid.cell_ends.iter_mut() {
            sum += *e;
            *e = sum;
        }
        let mut next = grid.cell_ends.clone();
        let mut order = vec![0u32; photons.len()];
        for (i, &k) in keys.iter().enumerate().rev() {
            next[k as usize] -= 1;
            order[next[k as usize] as usize] = i as u32;
        }
        grid.photons = order.par_iter().map(|&i| photons[i as usize]).collect();
        grid
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    /// Whether it holds no item.
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    #[inline]
    fn cell_of(&self, p: Vec3) -> Vec3 {
        (p - self.origin) * self.inv_cell
    }

    #[inline]
    fn bucket(&self, c: Vec3) -> usize {
        self.bucket_of(c.floor().as_ivec3())
    }

    #[inline]
    fn bucket_of(&self, c: IVec3) -> usize {
        let (x, y, z) = (c.x as u32, c.y as u32, c.z as u32);
        (x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663) ^ z.wrapping_mul(83_492_791))
            as usize
            % self.cell_ends.len()
    }

    /// Calls `visit(item, d²)` for every item within the grid's radius of `p`.
    #[inline]
    pub fn within(&self, p: Vec3, mut visit: impl FnMut(&T, f32)) {
        if self.photons.is_empty() {
            return;
        }
        let c = self.cell_of(p);
        let f = c.floor();
        // The 2 × 2 × 2 block of cells whose union covers the ball of radius r = half a cell.
        let lo = f.as_ivec3() - IVec3::from((c - f).cmplt(Vec3::splat(0.5)));
        let mut seen = [usize::MAX; 8];
        for (n, d) in (0..8)
            .map(|i| IVec3::new(i & 1, (i >> 1) & 1, i >> 2))
            .enumerate()
        {
            let b = self.bucket_of(lo + d);
            // Two cells can share a bucket: scan each bucket once.
            if seen[..n].contains(&b) {
                continue;
            }
            seen[n] = b;
            let start = if b == 0 { 0 } else { self.cell_ends[b - 1] };
            for ph in &self.photons[start as usize..self.cell_ends[b] as usize] {
                let d2 = ph.position().distance_squared(p);
                if d2 <= self.radius_sq {
                    visit(ph, d2);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lightlab_core::Rgb;
    use lightlab_samplers::{Independent, Sampler};

    /// Grid gathers equal a linear scan on random queries, also far outside the photons' box.
    #[test]
    fn gathers_match_a_linear_scan() {
        let mut s = Independent::new();
        s.start_pixel_sample(3, 0, 0);
        let photons: Vec<Photon> = (0..4000)
            .map(|i| {
                Photon::new(
                    Vec3::new(s.next_1d(), s.next_1d(), s.next_1d() * 0.2),
                    Vec3::Z,
                    Vec3::Z,
                    Rgb::splat(i as f32),
                    crate::paths::PathClass::EMPTY.push(lightlab_materials::LobeClass::Diffuse),
                )
            })
            .collect();
        for r in [0.01f32, 0.05, 0.3] {
            let grid = HashGrid::new(&photons, r);
            for q in 0..300 {
                let p = Vec3::new(s.next_1d() * 1.4 - 0.2, s.next_1d() * 1.4 - 0.2, 0.1);
                let mut got: Vec<u32> = Vec::new();
                grid.within(p, |ph, _| got.push(ph.power.r as u32));
                got.sort();
                let want: Vec<u32> = (0..photons.len() as u32)
                    .filter(|&i| photons[i as usize].p.distance_squared(p) <= r * r)
                    .collect();
                assert_eq!(got, want, "r {r}, query {q} at {p}");
            }
        }
    }
}
