//! The acceleration structure for small scenes: a 4-wide BVH whose nodes hold their children's
//! boxes as four-lane vectors and whose leaves hold their triangles side by side, tested together
//! by the watertight test (SIMD across triangles, glam's `Vec4`: SSE2 on x86-64).
//!
//! On small scenes it beats the 8-wide compressed BVH, which decodes byte-quantised nodes and tests
//! leaf triangles one at a time (BENCHMARKS.md, "Structures by scene size"): on the Cornell box a
//! ray tests three nodes and 1.1 packets. Large scenes keep the compressed BVH ([`crate::Accel`]
//! chooses by primitive count).
//!
//! Topology: top-down surface-area heuristic (MacDonald & Booth 1990) with a full sweep over the
//! centroids on each axis, leaves of at most two triangles or one sphere; each node takes four
//! children by splitting the largest of its candidate subsets until there are four (the collapse
//! of a binary BVH into a wide one of Dammertz et al. 2008, "Shallow bounding volume hierarchies
//! for fast SIMD ray tracing of incoherent rays", done while building). Boxes are in world space,
//! exact (min/max of the vertices); the slab test scales exit distances by 1 + 2γ₅ to stay
//! conservative (pbrt-v4 §6.8.2). The triangle test gives bit for bit the results of
//! [`triangle::intersect`]: the same operations in the same order, lane by lane.

use crate::sphere::Sphere;
use crate::triangle::{self, WatertightRay};
use glam::{Vec3A, Vec4};
use lightlab_core::{Ray, Vec3, gamma};

/// A child slot: an inner node, a triangle packet, a sphere or nothing.
const LEAF: u32 = 1 << 31;
const SPHERE: u32 = 1 << 30;
const EMPTY: u32 = u32::MAX;

/// Factor on slab exit distances covering the slab test's rounding (as the compressed BVH's).
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(5);

/// Four children's boxes, one lane per child: `bounds[a]` the low and `bounds[3 + a]` the high
/// planes on axis a, so a ray picks its near and far planes by index, without a branch. An empty
/// slot has an inverted box (never hit).
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: [Vec4; 6],
    child: [u32; 4],
}

/// Up to four triangles side by side: `v[vertex][axis]`, one lane per triangle. A packet of fewer
/// than four repeats its last triangle, which changes no closest hit (ties keep the first lane).
#[derive(Clone, Copy, Debug)]
struct Packet {
    v: [[Vec4; 3]; 3],
    /// The primitives' indices in the builder's list, one per lane.
    ids: [u32; 4],
}

impl Packet {
    fn triangle(&self, lane: usize) -> [Vec3; 3] {
        self.v.map(|v| {
            Vec3::new(
                v[0].to_array()[lane],
                v[1].to_array()[lane],
                v[2].to_array()[lane],
            )
        })
    }
}

/// A primitive handed to the builder: a triangle or a sphere with its index in the caller's list.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Primitive {
    Triangle([Vec3; 3]),
    Sphere(Sphere),
}

#[derive(Clone, Copy)]
struct Item {
    lo: Vec3,
    hi: Vec3,
    centroid: Vec3,
    /// Index into the builder's primitives.
    index: u32,
    sphere: bool,
}

/// Deepest tree the traversal stacks hold (three pending children per level).
const MAX_DEPTH: usize = 20;

/// Trees at most this deep (up to 4⁵ leaves, ≈ 2 000 triangles) are traversed with a stack of
/// `3 · SHALLOW + 1` entries instead of `3 · MAX_DEPTH + 1`.
const SHALLOW: usize = 5;

/// The 4-wide BVH. `Sync + Send`.
#[derive(Debug, Default)]
pub(crate) struct Bvh4 {
    nodes: Vec<Node>,
    packets: Vec<Packet>,
    spheres: Vec<(Sphere, u32)>,
    /// What the root is: an inner node, a leaf, or `EMPTY`.
    root: u32,
    /// Inner nodes on the longest path from the root: the traversal stacks hold at most three
    /// pending children per level.
    depth: usize,
}

/// The ray as the node and packet tests use it: origin, inverse direction with zero components
/// replaced by tiny ones (finite slab distances), and, per axis, the index of the near and the far
/// plane in [`Node::bounds`].
struct Traversal {
    o: [Vec4; 3],
    inv_d: [Vec4; 3],
    near: [usize; 3],
    far: [usize; 3],
}

impl Traversal {
    #[inline(always)]
    fn new(ray: &Ray) -> Traversal {
        let d = Vec3A::from(ray.d);
        // As the compressed BVH's canonical ray: a tilt below 10⁻¹⁸ relative, finite 1/d.
        let tiny = Vec3A::splat(d.abs().max_element() * (1.0 / (1u64 << 60) as f32));
        let d = Vec3A::select(d.abs().cmplt(tiny), tiny, d);
        let inv = d.recip();
        let negative = [d.x < 0.0, d.y < 0.0, d.z < 0.0];
        Traversal {
            o: [
                Vec4::splat(ray.o.x),
                Vec4::splat(ray.o.y),
                Vec4::splat(ray.o.z),
            ],
            inv_d: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            near: std::array::from_fn(|a| a + 3 * negative[a] as usize),
            far: std::array::from_fn(|a| a + 3 * !negative[a] as usize),
        }
    }

    /// Entry distances of the four children and the mask of those entered with t ≤ t_max.
    #[inline(always)]
    fn node(&self, node: &Node, t_max: f32) -> (Vec4, u32) {
        let mut near = Vec4::ZERO;
        let mut far = Vec4::splat(f32::INFINITY);
        for a in 0..3 {
            near = near.max((node.bounds[self.near[a]] - self.o[a]) * self.inv_d[a]);
            far = far.min((node.bounds[self.far[a]] - self.o[a]) * self.inv_d[a]);
        }
        let far = (far * FAR_SCALE).min(Vec4::splat(t_max));
        (near, near.cmple(far).bitmask())
    }
}

/// The watertight test's per-ray constants as lanes: origin and shear in the permuted axes.
struct PacketRay {
    k: [usize; 3],
    o: [Vec4; 3],
    s: [Vec4; 3],
}

impl PacketRay {
    #[inline(always)]
    fn new(w: &WatertightRay) -> PacketRay {
        let (k, o, s) = w.parts();
        PacketRay {
            k,
            o: [
                Vec4::splat(o[k[0]]),
                Vec4::splat(o[k[1]]),
                Vec4::splat(o[k[2]]),
            ],
            s: s.map(Vec4::splat),
        }
    }

    /// Vertices (one per lane) translated to the origin, permuted (z the dominant axis) and
    /// sheared.
    #[inline(always)]
    fn transform(&self, v: &[Vec4; 3]) -> [Vec4; 3] {
        let x = v[self.k[0]] - self.o[0];
        let y = v[self.k[1]] - self.o[1];
        let z = v[self.k[2]] - self.o[2];
        [x + self.s[0] * z, y + self.s[1] * z, z]
    }
}

/// Lanes of a packet's watertight test (Woop et al. 2013 as in [`triangle::intersect`]): which
/// triangles are hit with 0 < t ≤ t_max, their t and their unnormalised barycentrics.
struct PacketHits {
    mask: u32,
    t: Vec4,
    b: [Vec4; 3],
}

#[inline(always)]
fn packet_hits(p: &Packet, r: &PacketRay, w: &WatertightRay, t_max: f32) -> PacketHits {
    let [p0, p1, p2] = [
        r.transform(&p.v[0]),
        r.transform(&p.v[1]),
        r.transform(&p.v[2]),
    ];
    let e0 = p1[0] * p2[1] - p1[1] * p2[0];
    let e1 = p2[0] * p0[1] - p2[1] * p0[0];
    let e2 = p0[0] * p1[1] - p0[1] * p1[0];
    let zero = Vec4::ZERO;
    if (e0.cmpeq(zero) | e1.cmpeq(zero) | e2.cmpeq(zero)).any() {
        // An edge through the ray: the scalar test re-evaluates it in double precision.
        return scalar_hits(p, w, t_max);
    }
    let negative = e0.cmplt(zero) | e1.cmplt(zero) | e2.cmplt(zero);
    let positive = e0.cmpgt(zero) | e1.cmpgt(zero) | e2.cmpgt(zero);
    let outside = negative & positive;
    if outside.all() {
        // The ray passes outside every triangle of the packet (most of a shadow ray's packets):
        // no distances, no error bounds.
        return PacketHits {
            mask: 0,
            t: zero,
            b: [zero; 3],
        };
    }
    let det = e0 + e1 + e2;
    let sz = r.s[2];
    // Depths in length units for the x and y error bounds, as in the scalar test.
    let max_zl = p0[2].abs().max(p1[2].abs()).max(p2[2].abs());
    let (z0, z1, z2) = (p0[2] * sz, p1[2] * sz, p2[2] * sz);
    let t_scaled = e0 * z0 + e1 * z1 + e2 * z2;
    let limit = Vec4::splat(t_max) * det;
    let behind_or_beyond_neg = det.cmplt(zero) & (t_scaled.cmpge(zero) | t_scaled.cmplt(limit));
    let behind_or_beyond_pos = det.cmpgt(zero) & (t_scaled.cmple(zero) | t_scaled.cmpgt(limit));
    let inv_det = Vec4::ONE / det;
    let t = t_scaled * inv_det;
    // Conservative t > 0 (pbrt-v4 §6.8.7), as in the scalar test.
    let max_zt = z0.abs().max(z1.abs()).max(z2.abs());
    let delta_z = Vec4::splat(gamma(3)) * max_zt;
    let max_xt = p0[0].abs().max(p1[0].abs()).max(p2[0].abs());
    let max_yt = p0[1].abs().max(p1[1].abs()).max(p2[1].abs());
    let delta_x = Vec4::splat(gamma(5)) * (max_xt + max_zl);
    let delta_y = Vec4::splat(gamma(5)) * (max_yt + max_zl);
    let delta_e = Vec4::splat(2.0)
        * (Vec4::splat(gamma(2)) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t = Vec4::splat(3.0)
        * (Vec4::splat(gamma(3)) * max_e * max_zt + delta_e * max_zt + delta_z * max_e)
        * inv_det.abs();
    let rejected =
        outside | det.cmpeq(zero) | behind_or_beyond_neg | behind_or_beyond_pos | t.cmple(delta_t);
    PacketHits {
        mask: !rejected.bitmask() & 0xf,
        t,
        b: [e0 * inv_det, e1 * inv_det, e2 * inv_det],
    }
}

/// The packet tested one triangle at a time (the rare case of an exactly zero edge function).
#[cold]
fn scalar_hits(p: &Packet, w: &WatertightRay, t_max: f32) -> PacketHits {
    let (mut mask, mut t, mut b) = (0, [0.0; 4], [[0.0; 4]; 3]);
    for lane in 0..4 {
        if let Some(h) = triangle::intersect(w, &p.triangle(lane), t_max) {
            mask |= 1 << lane;
            t[lane] = h.t;
            for i in 0..3 {
                b[i][lane] = h.b[i];
            }
        }
    }
    PacketHits {
        mask,
        t: Vec4::from_array(t),
        b: b.map(Vec4::from_array),
    }
}

impl Bvh4 {
    /// Builds over `prims`, primitive `i` reported as id `i`; `None` when the tree would be deeper
    /// than the traversal's stack allows (then the caller uses another structure).
    pub(crate) fn build(prims: &[Primitive]) -> Option<Bvh4> {
        let mut items: Vec<Item> = prims
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let (lo, hi) = match p {
                    Primitive::Triangle(v) => (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2])),
                    Primitive::Sphere(s) => {
                        // center ± r rounds; widen by a bound on that rounding.
                        let r = Vec3::splat(s.radius);
                        let pad = (s.center.abs() + r) * f32::EPSILON;
                        (s.center - r - pad, s.center + r + pad)
                    }
                };
                Item {
                    lo,
                    hi,
                    centroid: (lo + hi) * 0.5,
                    index: i as u32,
                    sphere: matches!(p, Primitive::Sphere(_)),
                }
            })
            .collect();
        let mut bvh = Bvh4 {
            root: EMPTY,
            ..Bvh4::default()
        };
        if items.is_empty() {
            return Some(bvh);
        }
        bvh.root = Builder {
            bvh: &mut bvh,
            prims,
        }
        .subtree(&mut items, 0)?;
        Some(bvh)
    }

    pub(crate) fn node_count(&self) -> usize {
        self.nodes.len()
    }

    pub(crate) fn bytes(&self) -> (usize, usize) {
        (
            self.nodes.len() * size_of::<Node>(),
            self.packets.len() * size_of::<Packet>()
                + self.spheres.len() * size_of::<(Sphere, u32)>(),
        )
    }

    /// Closest hit with 0 < t < t_max: (id, t, barycentrics; zeros for a sphere).
    #[inline]
    pub(crate) fn intersect(
        &self,
        ray: &Ray,
        w: &WatertightRay,
        t_max: f32,
    ) -> Option<(u32, f32, [f32; 3])> {
        // A stack no deeper than the tree needs: zeroing 64 entries per ray cost more than
        // a small scene's node tests.
        if self.depth <= SHALLOW {
            self.closest::<{ 3 * SHALLOW + 1 }>(ray, w, t_max)
        } else {
            self.closest::<{ 3 * MAX_DEPTH + 1 }>(ray, w, t_max)
        }
    }

    /// [`Bvh4::intersect`] with a stack of `N` pending children.
    #[inline(always)]
    fn closest<const N: usize>(
        &self,
        ray: &Ray,
        w: &WatertightRay,
        t_max: f32,
    ) -> Option<(u32, f32, [f32; 3])> {
        if self.root == EMPTY {
            return None;
        }
        let tr = Traversal::new(ray);
        let pr = PacketRay::new(w);
        let mut t_max = t_max;
        let mut closest = None;
        let mut stack = [(0u32, 0.0f32); N];
        let mut top = 0;
        let mut slot = self.root;
        loop {
            if slot & LEAF == 0 {
                let node = &self.nodes[slot as usize];
                let (near, mut mask) = tr.node(node, t_max);
                if mask != 0 {
                    let near = near.to_array();
                    // Visit the nearest child next, push the others farthest first (children at
                    // equal distances: the later lane first). One or two children, the usual
                    // cases, skip the sorting loop and its branches.
                    let first = mask.trailing_zeros() as usize;
                    let rest = mask & (mask - 1);
                    if rest == 0 {
                        slot = node.child[first];
                        continue;
                    }
                    if rest & (rest - 1) == 0 {
                        let second = rest.trailing_zeros() as usize;
                        let (nearer, farther) = if near[first] < near[second] {
                            (first, second)
                        } else {
                            (second, first)
                        };
                        stack[top] = (node.child[farther], near[farther]);
                        top += 1;
                        slot = node.child[nearer];
                        continue;
                    }
                    let base = top;
                    while mask != 0 {
                        let lane = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let mut j = top;
                        while j > base && stack[j - 1].1 < near[lane] {
                            stack[j] = stack[j - 1];
                            j -= 1;
                        }
                        stack[j] = (node.child[lane], near[lane]);
                        top += 1;
                    }
                    top -= 1;
                    slot = stack[top].0;
                    continue;
                }
            } else if slot & SPHERE != 0 {
                let (s, id) = &self.spheres[(slot & !(LEAF | SPHERE)) as usize];
                if let Some(t) = s.intersect(ray.o, ray.d, t_max) {
                    t_max = t;
                    closest = Some((*id, t, [0.0; 3]));
                }
            } else {
                let p = &self.packets[(slot & !LEAF) as usize];
                let h = packet_hits(p, &pr, w, t_max);
                let (t, b) = (h.t.to_array(), h.b.map(|v| v.to_array()));
                let mut mask = h.mask;
                while mask != 0 {
                    let lane = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if t[lane] < t_max {
                        t_max = t[lane];
                        closest =
                            Some((p.ids[lane], t[lane], [b[0][lane], b[1][lane], b[2][lane]]));
                    }
                }
            }
            // Next: the nearest pending child still in front of the closest hit.
            loop {
                if top == 0 {
                    return closest;
                }
                top -= 1;
                if stack[top].1 <= t_max {
                    break;
                }
            }
            slot = stack[top].0;
        }
    }

    /// Whether anything is hit with 0 < t < t_max.
    #[inline]
    pub(crate) fn occluded(&self, ray: &Ray, w: &WatertightRay, t_max: f32) -> bool {
        if self.depth <= SHALLOW {
            self.any_hit::<{ 3 * SHALLOW + 1 }>(ray, w, t_max)
        } else {
            self.any_hit::<{ 3 * MAX_DEPTH + 1 }>(ray, w, t_max)
        }
    }

    /// [`Bvh4::occluded`] with a stack of `N` pending children.
    #[inline(always)]
    fn any_hit<const N: usize>(&self, ray: &Ray, w: &WatertightRay, t_max: f32) -> bool {
        if self.root == EMPTY {
            return false;
        }
        let tr = Traversal::new(ray);
        let pr = PacketRay::new(w);
        let mut stack = [0u32; N];
        let mut top = 0;
        let mut slot = self.root;
        loop {
            if slot & LEAF == 0 {
                let node = &self.nodes[slot as usize];
                let (_, mut mask) = tr.node(node, t_max);
                while mask != 0 {
                    let lane = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    stack[top] = node.child[lane];
                    top += 1;
                }
            } else if slot & SPHERE != 0 {
                let (s, _) = &self.spheres[(slot & !(LEAF | SPHERE)) as usize];
                if s.intersect(ray.o, ray.d, t_max).is_some() {
                    return true;
                }
            } else {
                let p = &self.packets[(slot & !LEAF) as usize];
                let h = packet_hits(p, &pr, w, t_max);
                let t = h.t.to_array();
                if (0..4).any(|lane| h.mask & (1 << lane) != 0 && t[lane] < t_max) {
                    return true;
                }
            }
            if top == 0 {
                return false;
            }
            top -= 1;
            slot = stack[top];
        }
    }
}

struct Builder<'a> {
    bvh: &'a mut Bvh4,
    prims: &'a [Primitive],
}

impl Builder<'_> {
    /// Builds the subtree over `items` at `depth` and returns its child slot.
    fn subtree(&mut self, items: &mut [Item], depth: usize) -> Option<u32> {
        if is_leaf(items) {
            return Some(self.leaf(items));
        }
        if depth == MAX_DEPTH {
            return None;
        }
        self.bvh.depth = self.bvh.depth.max(depth + 1);
        // Four children: split the candidate with the largest box until there are four or none
        // can be split.
        let mut parts: Vec<&mut [Item]> = vec![items];
        while parts.len() < 4 {
            let Some(k) = (0..parts.len())
                .filter(|&k| !is_leaf(parts[k]))
                .max_by(|&a, &b| area(bounds(parts[a])).total_cmp(&area(bounds(parts[b]))))
            else {
                break;
            };
            let part = parts.swap_remove(k);
            let at = sah_split(part);
            let (left, right) = part.split_at_mut(at);
            parts.push(left);
            parts.push(right);
        }
        let index = self.bvh.nodes.len();
        // Empty slots keep an inverted box: low planes at +∞, high planes at −∞.
        let mut bounds4: [[f32; 4]; 6] = std::array::from_fn(|k| {
            [if k < 3 {
                f32::INFINITY
            } else {
                f32::NEG_INFINITY
            }; 4]
        });
        self.bvh.nodes.push(Node {
            bounds: bounds4.map(Vec4::from_array),
            child: [EMPTY; 4],
        });
        let mut child = [EMPTY; 4];
        for (lane, part) in parts.into_iter().enumerate() {
            let (lo, hi) = bounds(part);
            for a in 0..3 {
                bounds4[a][lane] = lo[a];
                bounds4[3 + a][lane] = hi[a];
            }
            child[lane] = self.subtree(part, depth + 1)?;
        }
        self.bvh.nodes[index] = Node {
            bounds: bounds4.map(Vec4::from_array),
            child,
        };
        Some(index as u32)
    }

    /// The leaf slot of `items`: up to two triangles (lanes repeated), or one sphere.
    fn leaf(&mut self, items: &[Item]) -> u32 {
        let bvh = &mut *self.bvh;
        let first = items[0].index as usize;
        if let Primitive::Sphere(s) = self.prims[first] {
            bvh.spheres.push((s, first as u32));
            return LEAF | SPHERE | (bvh.spheres.len() - 1) as u32;
        }
        let mut v = [[[0.0f32; 4]; 3]; 3];
        let mut ids = [0; 4];
        for lane in 0..4 {
            let i = items[lane.min(items.len() - 1)].index as usize;
            let Primitive::Triangle(t) = self.prims[i] else {
                unreachable!("a leaf holds triangles or one sphere");
            };
            for (k, vertex) in t.iter().enumerate() {
                for a in 0..3 {
                    v[k][a][lane] = vertex[a];
                }
            }
            ids[lane] = i as u32;
        }
        bvh.packets.push(Packet {
            v: v.map(|v| v.map(Vec4::from_array)),
            ids,
        });
        LEAF | (bvh.packets.len() - 1) as u32
    }
}

/// Whether `items` make one leaf: up to two triangles, or one sphere. Two, not four: a packet
/// costs the same for one to four triangles, but leaves of four on the Cornell box bound two walls
/// each (boxes every interior ray enters); the traversal benchmark measured 9 % (closest hit) and
/// 40 % (shadow rays) more rays per second with two, and three between the two.
fn is_leaf(items: &[Item]) -> bool {
    items.len() == 1 || (items.len() <= 2 && !items.iter().any(|i| i.sphere))
}

/// Sorts `items` along the axis of the cheapest surface-area-heuristic split and returns where
/// it falls (in 1..len): cost = area(left)·|left| + area(right)·|right| over every split of the
/// centroids sorted on each axis (ties broken by index, so the tree is deterministic).
fn sah_split(items: &mut [Item]) -> usize {
    let n = items.len();
    let sort = |items: &mut [Item], a: usize| {
        items.sort_by(|x, y| {
            x.centroid[a]
                .total_cmp(&y.centroid[a])
                .then(x.index.cmp(&y.index))
        })
    };
    let mut best = (f32::INFINITY, 0, n / 2);
    let mut right = vec![0.0f32; n];
    for a in 0..3 {
        sort(items, a);
        let mut b = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for i in (1..n).rev() {
            b = (b.0.min(items[i].lo), b.1.max(items[i].hi));
            right[i] = area(b) * (n - i) as f32;
        }
        let mut b = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for i in 1..n {
            b = (b.0.min(items[i - 1].lo), b.1.max(items[i - 1].hi));
            let cost = area(b) * i as f32 + right[i];
            if cost < best.0 {
                best = (cost, a, i);
            }
        }
    }
    sort(items, best.1);
    best.2
}

fn bounds(items: &[Item]) -> (Vec3, Vec3) {
    items.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), i| (lo.min(i.lo), hi.max(i.hi)),
    )
}

fn area((lo, hi): (Vec3, Vec3)) -> f32 {
    let e = (hi - lo).max(Vec3::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    /// A vertex on a coarse grid half the time (axis-aligned edges and exact zeros of the edge
    /// functions, the scalar fallback), anywhere in [−1, 1]³ otherwise.
    fn vertex(rng: &mut Pcg64) -> Vec3 {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if rng.random::<bool>() {
            (v * 4.0).round() / 4.0
        } else {
            v
        }
    }

    /// Closest hit over `tris` one triangle at a time: (index, t).
    fn brute_force(tris: &[[Vec3; 3]], w: &WatertightRay, t_max: f32) -> Option<(u32, f32)> {
        let mut best = None;
        let mut t_max = t_max;
        for (i, t) in tris.iter().enumerate() {
            if let Some(h) = triangle::intersect(w, t, t_max)
                && h.t < t_max
            {
                t_max = h.t;
                best = Some((i as u32, h.t));
            }
        }
        best
    }

    /// Shallow trees take the small stack and deep ones the large; both find the brute-force
    /// closest hit and occlusion, and on a shallow tree the large stack changes nothing.
    #[test]
    fn both_stack_sizes_find_the_closest_hit() {
        let mut rng = Pcg64::seed_from_u64(11);
        for (count, size, deep) in [(40, 0.6, false), (6000, 0.1, true)] {
            let tris: Vec<[Vec3; 3]> = (0..count)
                .map(|_| {
                    let c = vertex(&mut rng);
                    std::array::from_fn(|_| c + size * vertex(&mut rng))
                })
                .collect();
            let prims: Vec<Primitive> = tris.iter().map(|&t| Primitive::Triangle(t)).collect();
            let bvh = Bvh4::build(&prims).unwrap();
            assert_eq!(
                bvh.depth > SHALLOW,
                deep,
                "{count} triangles, depth {}",
                bvh.depth
            );
            let mut hits = 0;
            for _ in 0..5_000 {
                let o = vertex(&mut rng) * 1.5;
                let ray = Ray::new(o, vertex(&mut rng));
                let Some(w) = WatertightRay::new(ray.o, ray.d) else {
                    continue;
                };
                let expected = brute_force(&tris, &w, f32::INFINITY);
                let got = bvh.intersect(&ray, &w, f32::INFINITY);
                assert_eq!(got.map(|(id, t, _)| (id, t)), expected);
                assert_eq!(bvh.occluded(&ray, &w, f32::INFINITY), expected.is_some());
                if !deep {
                    let large = bvh.closest::<{ 3 * MAX_DEPTH + 1 }>(&ray, &w, f32::INFINITY);
                    assert_eq!(large.map(|(id, t, _)| (id, t)), expected);
                    assert_eq!(
                        bvh.any_hit::<{ 3 * MAX_DEPTH + 1 }>(&ray, &w, f32::INFINITY),
                        expected.is_some()
                    );
                }
                hits += usize::from(expected.is_some());
            }
            assert!(hits > 1_000, "{count} triangles: {hits} hits");
        }
    }

    #[test]
    fn packet_test_equals_the_scalar_test_bit_for_bit() {
        let mut rng = Pcg64::seed_from_u64(4);
        let (mut hits, mut at_vertices) = (0, 0);
        for _ in 0..50_000 {
            let tris: [[Vec3; 3]; 4] =
                std::array::from_fn(|_| std::array::from_fn(|_| vertex(&mut rng)));
            let mut v = [[[0.0f32; 4]; 3]; 3];
            for (lane, t) in tris.iter().enumerate() {
                for k in 0..3 {
                    for a in 0..3 {
                        v[k][a][lane] = t[k][a];
                    }
                }
            }
            let packet = Packet {
                v: v.map(|v| v.map(Vec4::from_array)),
                ids: [0, 1, 2, 3],
            };
            let o = vertex(&mut rng) * 2.0;
            let target = tris[rng.random_range(0..4)][rng.random_range(0..3)];
            let d = if rng.random::<bool>() {
                target - o
            } else {
                vertex(&mut rng)
            };
            let Some(w) = WatertightRay::new(o, d) else {
                continue;
            };
            let t_max = if rng.random::<bool>() {
                f32::INFINITY
            } else {
                rng.random_range(0.0..2.0)
            };
            let got = packet_hits(&packet, &PacketRay::new(&w), &w, t_max);
            let (t, b) = (got.t.to_array(), got.b.map(|b| b.to_array()));
            at_vertices += usize::from(t_max.is_infinite() && d == target - o);
            for lane in 0..4 {
                let expected = triangle::intersect(&w, &tris[lane], t_max);
                assert_eq!(
                    got.mask & (1 << lane) != 0,
                    expected.is_some(),
                    "lane {lane}"
                );
                if let Some(h) = expected {
                    hits += 1;
                    assert_eq!(t[lane].to_bits(), h.t.to_bits());
                    for i in 0..3 {
                        assert_eq!(b[i][lane].to_bits(), h.b[i].to_bits());
                    }
                }
            }
        }
        assert!(
            hits > 10_000 && at_vertices > 1000,
            "{hits} hits, {at_vertices} rays at vertices"
        );
    }
}
