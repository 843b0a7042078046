//! The ray acceleration structure over every triangle and sphere of the scene: for small scenes
//! (up to [`WIDE_MAX_PRIMITIVES`]) the 4-wide BVH of [`crate::bvh4`], otherwise one obvhs CWBVH
//! (Ylitie et al. 2017, 8-wide compressed nodes) with our own node test and primitive tests. Both
//! use the same watertight triangle test and give the same hits.
//!
//! Two deliberate departures of the CWBVH path from obvhs's own traversal (crates.md §2 lists its pitfalls):
//! - **Canonical space.** The BVH is built over the primitives' boxes mapped by `(x − c)·s` into
//!   roughly [−1, 1]³, with `s` a power of two and `c` on a power-of-two grid, so a ray maps into it
//!   exactly (in the usual cases) and t is unchanged. A scene scaled by 10⁻³ or 10³ or moved to
//!   (10⁴, 10⁴, 10⁴) therefore gets the same tree and the same numerics in the node test.
//! - **Node test.** obvhs's `CwBvhNode::intersect_ray` clamps the entry distance to an absolute
//!   1e-4 (and clamps 1/d), which culls hits at small t in small scenes. [`intersect_node`] is the
//!   same quantised slab test with t ≥ 0, a finite 1/d, and conservative rounding (boxes padded by
//!   [`BOX_PAD`], exit distances scaled by 1 + 2γ₅ as in pbrt-v4 §6.8.2), driven by obvhs's
//!   `traverse!` macro.
//!
//! Primitives are stored once more in leaf order (`bvh.primitive_indices` applied), so a leaf's
//! triangles are contiguous in memory and the traversal needs no indirection; their shape and
//! triangle ids live in a separate, colder array that is read only for the final hit.

use crate::bvh4::{Bvh4, Primitive};
use crate::hit::Hit;
use crate::motion::Motion;
use crate::shape::{Geometry, Shape};
use crate::triangle::{self, WatertightRay};
use glam::{UVec2, Vec3A, Vec4};
use lightlab_core::{Ray, Vec3, gamma};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::node::{CwBvhNode, extract_byte64};
use obvhs::{BvhBuildParams, traverse};
use rayon::prelude::*;
use std::time::Duration;

/// Padding of every primitive box in canonical units (the scene spans about [−1, 1]³). It absorbs
/// the rounding of the box mapping, of obvhs's quantisation and the absolute part of the slab
/// test's error (≈ 3ε·node extent), so a box never loses a point of its primitive.
const BOX_PAD: f32 = 1.0 / (1 << 19) as f32;

/// Factor on slab exit distances covering the relative rounding error of the slab test.
const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(5);

/// Scenes with at most this many static primitives get the 4-wide BVH ([`Bvh4`]), larger ones the
/// CWBVH. Measured (BENCHMARKS.md, "Structures by scene size", one thread): from 34 to 65 058
/// triangles the 4-wide BVH traces 0.95–1.1× the CWBVH's closest-hit rays and 1.3–1.4× its shadow
/// rays; its build is serial and 3× slower (0.15 s at 65 k), and larger scenes were not measured.
pub const WIDE_MAX_PRIMITIVES: usize = 1 << 16;

/// The structure over the static primitives.
enum Structure {
    /// obvhs's CWBVH with the primitives copied into its leaf order.
    Compressed { bvh: CwBvh, prims: Vec<Primitive> },
    /// The 4-wide BVH of small scenes; primitive ids index `refs` in build order.
    Wide(Bvh4),
}

/// Which structure holds the static primitives. Both give the same hits (the same primitive
/// tests, conservative box tests); they differ in speed, which is why the choice is by size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// The 4-wide BVH up to [`WIDE_MAX_PRIMITIVES`] primitives, the CWBVH above.
    BySize,
    /// obvhs's 8-wide compressed BVH (Ylitie et al. 2017).
    Compressed,
    /// The 4-wide BVH with four-triangle leaves ([`crate::bvh4`]).
    Wide,
}

/// Which shape and which triangle of it a leaf-order primitive is.
#[derive(Clone, Copy, Debug)]
struct PrimRef {
    shape: u32,
    index: u32,
}

/// The map from world space to the BVH's canonical space: `(x − center)·scale`.
#[derive(Clone, Copy, Debug)]
struct Canonical {
    center: Vec3A,
    scale: f32,
}

impl Canonical {
    /// `scale` is a power of two with the scene's half-extent mapped to at most 1; `center` is the
    /// scene's centre rounded to a grid of 1/16 of that power of two. Both choices make
    /// `(x − center)·scale` exact for most points near the scene.
    fn new(lo: Vec3A, hi: Vec3A) -> Canonical {
        let half = ((hi - lo) * 0.5).max_element();
        let scale = if half > 0.0 && half.is_finite() {
            (-half.log2().ceil()).exp2()
        } else {
            1.0
        };
        let grid = 1.0 / (16.0 * scale);
        let center = ((lo + hi) * 0.5 / grid).round() * grid;
        Canonical { center, scale }
    }

    #[inline(always)]
    fn point(&self, p: Vec3A) -> Vec3A {
        (p - self.center) * self.scale
    }
}

/// A ray in canonical space with what the node test needs.
struct TraversalRay {
    o: Vec3A,
    inv_d: Vec3A,
    /// Direction used for the octant (child order) and the near/far plane choice; zero or tiny
    /// components are replaced by a small positive value so 1/d stays finite.
    d: Vec3A,
}

impl TraversalRay {
    #[inline(always)]
    fn new(canonical: &Canonical, ray: &Ray) -> TraversalRay {
        let d = Vec3A::from(ray.d) * canonical.scale;
        // Replacing components below 2⁻⁶⁰·|d|∞ tilts the ray by less than 10⁻¹⁸ relative, far below
        // BOX_PAD, and keeps every slab distance finite (no 0·∞).
        let tiny = Vec3A::splat(d.abs().max_element() * (1.0 / (1u64 << 60) as f32));
        let d = Vec3A::select(d.abs().cmplt(tiny), tiny, d);
        TraversalRay {
            o: canonical.point(ray.o.into()),
            inv_d: d.recip(),
            d,
        }
    }
}

/// Statistics of a built [`Accel`].
#[derive(Clone, Copy, Debug)]
pub struct AccelStats {
    pub nodes: usize,
    /// Bytes of BVH nodes.
    pub node_bytes: usize,
    /// Primitives in the BVH (degenerate triangles are left out).
    pub primitives: usize,
    /// Bytes of the leaf-order primitive data and their ids.
    pub primitive_bytes: usize,
}

/// Closest-hit and any-hit queries over a set of shapes. `Sync + Send`; build once, query from
/// many threads.
pub struct Accel {
    shapes: Vec<Shape>,
    structure: Structure,
    /// Each static primitive's shape and index in it (degenerate triangles left out), in the
    /// structure's primitive order.
    refs: Vec<PrimRef>,
    canonical: Canonical,
    bounds: (Vec3, Vec3),
    triangle_count: usize,
    /// Shapes that move over the shutter, outside the BVH (a two-level structure with a flat top
    /// level: a static scene pays nothing for them).
    moving: Vec<Moving>,
}

/// A moving shape: its own BVH over its rest geometry, queried with rays moved into the rest
/// frame at their time, behind a box that bounds it over all times.
struct Moving {
    shape: u32,
    motion: Motion,
    accel: Accel,
    swept: (Vec3, Vec3),
}

impl Accel {
    /// Builds one CWBVH over all triangles and spheres (obvhs PLOC + reinsertion + CWBVH
    /// conversion, `medium_build`), in parallel on the current rayon pool. Degenerate triangles
    /// and spheres of non-positive radius are left out: they can never be hit.
    pub fn new(shapes: Vec<Shape>) -> Accel {
        Accel::with_motion(shapes, Vec::new(), (0.0, 0.0))
    }

    /// As [`Accel::new`], with `motion[i]` (where given and `Some`) moving shape `i` rigidly over
    /// time: shape `i` is then its rest geometry, [`Ray::time`] says where it is. Rays' times lie
    /// in `shutter` (open, close): the bounds of moving shapes cover those times only.
    pub fn with_motion(
        shapes: Vec<Shape>,
        motion: Vec<Option<Motion>>,
        shutter: (f32, f32),
    ) -> Accel {
        Accel::with_layout(shapes, motion, shutter, Layout::BySize)
    }

    /// As [`Accel::with_motion`] with the structure chosen by `layout` (benchmarks and tests
    /// compare them; a wide BVH deeper than its traversal stack falls back to the CWBVH).
    pub fn with_layout(
        shapes: Vec<Shape>,
        motion: Vec<Option<Motion>>,
        shutter: (f32, f32),
        layout: Layout,
    ) -> Accel {
        let mut refs = Vec::new();
        let mut boxes: Vec<(Vec3, Vec3)> = Vec::new();
        let mut moving = Vec::new();
        for (s, shape) in shapes.iter().enumerate() {
            let shape_id = s as u32;
            if let Some(Some(m)) = motion.get(s) {
                let accel = Accel::with_layout(vec![shape.clone()], Vec::new(), shutter, layout);
                let (lo, hi) = accel.bounds();
                let swept = m.swept_bounds((lo + hi) * 0.5, (hi - lo).length() * 0.5, shutter);
                moving.push(Moving {
                    shape: shape_id,
                    motion: m.clone(),
                    accel,
                    swept,
                });
                continue;
            }
            match &shape.geometry {
                Geometry::Mesh(mesh) => {
                    let tris: Vec<(PrimRef, (Vec3, Vec3))> = (0..mesh.len())
                        .into_par_iter()
                        .filter_map(|i| {
                            let v = mesh.vertices(i);
                            mesh.geometric_normal(i)?;
                            let lo = v[0].min(v[1]).min(v[2]);
                            let hi = v[0].max(v[1]).max(v[2]);
                            let r = PrimRef {
                                shape: shape_id,
                                index: i as u32,
                            };
                            Some((r, (lo, hi)))
                        })
                        .collect();
                    let (r, b): (Vec<_>, Vec<_>) = tris.into_iter().unzip();
                    refs.extend(r);
                    boxes.extend(b);
                }
                Geometry::Sphere(sphere) => {
                    if sphere.radius > 0.0 && sphere.center.is_finite() && sphere.radius.is_finite()
                    {
                        refs.push(PrimRef {
                            shape: shape_id,
                            index: 0,
                        });
                        // center ± r rounds; widen by a bound on that rounding.
                        let r = Vec3::splat(sphere.radius);
                        let pad = (sphere.center.abs() + r) * f32::EPSILON;
                        boxes.push((sphere.center - r - pad, sphere.center + r + pad));
                    }
                }
            }
        }

        let union = |boxes: &mut dyn Iterator<Item = (Vec3, Vec3)>| {
            boxes.fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), b| (lo.min(b.0), hi.max(b.1)),
            )
        };
        let (lo, hi) = union(&mut boxes.iter().copied());
        let canonical = Canonical::new(lo.into(), hi.into());
        let (lo, hi) = union(&mut boxes.iter().copied().chain(moving.iter().map(|m| m.swept)));
        let bounds = if boxes.is_empty() && moving.is_empty() {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        };

        let primitive = |r: &PrimRef| match &shapes[r.shape as usize].geometry {
            Geometry::Mesh(mesh) => Primitive::Triangle(mesh.vertices(r.index as usize)),
            Geometry::Sphere(sphere) => Primitive::Sphere(*sphere),
        };
        let static_triangles = refs
            .iter()
            .filter(|r| matches!(shapes[r.shape as usize].geometry, Geometry::Mesh(_)))
            .count();
        let wide = match layout {
            Layout::BySize if refs.len() > WIDE_MAX_PRIMITIVES => None,
            Layout::Compressed => None,
            _ => {
                let prims: Vec<Primitive> = refs.iter().map(primitive).collect();
                Bvh4::build(&prims)
            }
        };
        let (structure, refs) = if let Some(bvh4) = wide {
            (Structure::Wide(bvh4), refs)
        } else if refs.is_empty() {
            let empty = Structure::Compressed {
                bvh: CwBvh::default(),
                prims: Vec::new(),
            };
            (empty, Vec::new())
        } else {
            let aabbs: Vec<Aabb> = boxes
                .par_iter()
                .map(|&(lo, hi)| {
                    Aabb::new(
                        canonical.point(lo.into()) - BOX_PAD,
                        canonical.point(hi.into()) + BOX_PAD,
                    )
                })
                .collect();
            let mut bvh = build_cwbvh(
                &aabbs,
                BvhBuildParams::medium_build(),
                &mut Duration::default(),
            );
            let leaf_refs: Vec<PrimRef> = bvh
                .primitive_indices
                .par_iter()
                .map(|&i| refs[i as usize])
                .collect();
            // The traversal indexes leaf order directly; the indirection is no longer needed.
            bvh.primitive_indices = Vec::new();
            let prims = leaf_refs.par_iter().map(primitive).collect();
            (Structure::Compressed { bvh, prims }, leaf_refs)
        };

        let triangle_count =
            static_triangles + moving.iter().map(|m| m.accel.triangle_count).sum::<usize>();
        Accel {
            shapes,
            structure,
            refs,
            canonical,
            bounds,
            triangle_count,
            moving,
        }
    }

    /// Whether any shape moves.
    pub fn has_motion(&self) -> bool {
        !self.moving.is_empty()
    }

    /// The motion of shape `i`, if it moves.
    pub fn motion(&self, i: u32) -> Option<&Motion> {
        self.moving.iter().find(|m| m.shape == i).map(|m| &m.motion)
    }

    pub fn shapes(&self) -> &[Shape] {
        &self.shapes
    }

    /// World-space bounding box (min, max) of everything in the BVH (spheres' boxes widened by
    /// their rounding error) and of moving shapes over all times; (0, 0) when empty.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Number of (non-degenerate) triangles in the BVH.
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    pub fn stats(&self) -> AccelStats {
        let ref_bytes = self.refs.len() * size_of::<PrimRef>();
        match &self.structure {
            Structure::Compressed { bvh, prims } => AccelStats {
                nodes: bvh.nodes.len(),
                node_bytes: bvh.nodes.len() * size_of::<CwBvhNode>(),
                primitives: prims.len(),
                primitive_bytes: prims.len() * size_of::<Primitive>() + ref_bytes,
            },
            Structure::Wide(bvh) => {
                let (node_bytes, primitive_bytes) = bvh.bytes();
                AccelStats {
                    nodes: bvh.node_count(),
                    node_bytes,
                    primitives: self.refs.len(),
                    primitive_bytes: primitive_bytes + ref_bytes,
                }
            }
        }
    }

    /// Closest hit with t in (0, ray.t_max), moving shapes where they are at `ray.time`.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut closest = self.intersect_static(ray);
        for m in &self.moving {
            let t_max = closest.map_or(ray.t_max, |h| h.t);
            if !slab(m.swept, ray, t_max) {
                continue;
            }
            let tr = m.motion.at(ray.time);
            let rest = Ray {
                t_max,
                ..tr.ray_to_rest(ray)
            };
            if let Some(h) = m.accel.intersect(&rest)
                && h.t < t_max
            {
                closest = Some(Hit {
                    shape: m.shape,
                    ..tr.hit_to_world(h)
                });
            }
        }
        closest
    }

    /// Whether anything is hit with t in (0, ray.t_max), moving shapes at `ray.time`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_static(ray)
            || self.moving.iter().any(|m| {
                slab(m.swept, ray, ray.t_max)
                    && m.accel.occluded(&m.motion.at(ray.time).ray_to_rest(ray))
            })
    }

    fn intersect_static(&self, ray: &Ray) -> Option<Hit> {
        if self.refs.is_empty() || ray.t_max.is_nan() || ray.t_max <= 0.0 {
            return None;
        }
        let wray = WatertightRay::new(ray.o, ray.d)?;
        let (id, t, b) = match &self.structure {
            Structure::Wide(bvh) => bvh.intersect(ray, &wray, ray.t_max)?,
            Structure::Compressed { bvh, prims } => {
                compressed_intersect(bvh, prims, &self.canonical, ray, &wray)?
            }
        };
        self.hit(ray, id, t, b)
    }

    fn occluded_static(&self, ray: &Ray) -> bool {
        if self.refs.is_empty() || ray.t_max.is_nan() || ray.t_max <= 0.0 {
            return false;
        }
        let Some(wray) = WatertightRay::new(ray.o, ray.d) else {
            return false;
        };
        match &self.structure {
            Structure::Wide(bvh) => bvh.occluded(ray, &wray, ray.t_max),
            Structure::Compressed { bvh, prims } => {
                compressed_occluded(bvh, prims, &self.canonical, ray, &wray)
            }
        }
    }

    /// The [`Hit`] for primitive `id` (an index into `refs`) hit at `t` with barycentrics `b`.
    fn hit(&self, ray: &Ray, id: u32, t: f32, b: [f32; 3]) -> Option<Hit> {
        let r = self.refs[id as usize];
        let shape = &self.shapes[r.shape as usize];
        let (t, p, p_error, ng, ns, dpdu, uv) = match &shape.geometry {
            Geometry::Mesh(mesh) => {
                let i = r.index as usize;
                let v = mesh.vertices(i);
                // Degenerate triangles are not in the BVH, so the normal exists.
                let ng = mesh.geometric_normal(i)?;
                let (p, p_error) = triangle::point_with_error(&v, b, 7);
                let uvs = mesh.vertex_uvs(i);
                let uv = b[0] * uvs[0] + b[1] * uvs[1] + b[2] * uvs[2];
                let ns = mesh.shading_normal(i, b, ng);
                (t, p, p_error, ng, ns, mesh.dpdu(i), uv)
            }
            Geometry::Sphere(sphere) => {
                let (t, s) = sphere.hit_surface(ray.o, ray.d, ray.t_max)?;
                (t, s.p, s.p_error, s.n, s.n, s.dpdu, s.uv)
            }
        };
        Some(Hit {
            t,
            p,
            p_error,
            ng,
            ns,
            dpdu,
            uv,
            shape: r.shape,
            primitive: r.index,
            material: shape.material,
            light: shape.light,
        })
    }
}

/// Closest hit in the CWBVH: (leaf-order id, t, barycentrics; zeros for a sphere).
fn compressed_intersect(
    bvh: &CwBvh,
    prims: &[Primitive],
    canonical: &Canonical,
    ray: &Ray,
    wray: &WatertightRay,
) -> Option<(u32, f32, [f32; 3])> {
    let tray = TraversalRay::new(canonical, ray);
    let mut t_max = ray.t_max;
    let mut closest: Option<(u32, [f32; 3])> = None;
    let mut state = bvh.new_traversal(tray.d);
    let mut node;
    traverse!(
        bvh,
        node,
        state,
        intersect_node(node, &tray, t_max, state.oct_inv4),
        {
            let id = state.primitive_id;
            match &prims[id as usize] {
                Primitive::Triangle(v) => {
                    if let Some(h) = triangle::intersect(wray, v, t_max)
                        && h.t < t_max
                    {
                        t_max = h.t;
                        closest = Some((id, h.b));
                    }
                }
                Primitive::Sphere(s) => {
                    if let Some(t) = s.intersect(ray.o, ray.d, t_max) {
                        t_max = t;
                        closest = Some((id, [0.0; 3]));
                    }
                }
            }
        }
    );
    closest.map(|(id, b)| (id, t_max, b))
}

/// Whether anything in the CWBVH is hit with t in (0, ray.t_max).
fn compressed_occluded(
    bvh: &CwBvh,
    prims: &[Primitive],
    canonical: &Canonical,
    ray: &Ray,
    wray: &WatertightRay,
) -> bool {
    let tray = TraversalRay::new(canonical, ray);
    let t_max = ray.t_max;
    let mut state = bvh.new_traversal(tray.d);
    let mut node;
    let mut occluded = false;
    'search: {
        traverse!(
            bvh,
            node,
            state,
            intersect_node(node, &tray, t_max, state.oct_inv4),
            {
                let hit = match &prims[state.primitive_id as usize] {
                    Primitive::Triangle(v) => {
                        triangle::intersect(wray, v, t_max).is_some_and(|h| h.t < t_max)
                    }
                    Primitive::Sphere(s) => s.intersect(ray.o, ray.d, t_max).is_some(),
                };
                if hit {
                    occluded = true;
                    break 'search;
                }
            }
        );
    }
    occluded
}

/// Whether `ray` may meet the box `b` with t in [0, t_max] (slab test, exit distances widened by
/// the test's rounding; a NaN from a zero direction component on a slab's plane keeps the box).
#[inline]
fn slab(b: (Vec3, Vec3), ray: &Ray, t_max: f32) -> bool {
    let inv = ray.d.recip();
    let (t0, t1) = ((b.0 - ray.o) * inv, (b.1 - ray.o) * inv);
    if t0.is_nan() || t1.is_nan() {
        return true;
    }
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element().min(t_max) * FAR_SCALE;
    near <= far
}

/// Quantised slab test of the 8 children of `node` (Ylitie et al. 2017, §3.1: the ray is moved into
/// the node's 8-bit grid instead of decompressing the boxes), 4 children at a time. Same output as
/// obvhs's `CwBvhNode::intersect_ray` (a hit mask of child nodes and leaf primitives in traversal
/// order), but with entry distances clamped at 0 instead of 1e-4 and conservative exit distances.
#[inline(always)]
fn intersect_node(node: &CwBvhNode, ray: &TraversalRay, t_max: f32, oct_inv4: u32) -> u32 {
    let adj_inv = node.compute_extent() * ray.inv_d;
    let adj_o = (Vec3A::from(node.p) - ray.o) * ray.inv_d;
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let (near_x, far_x) = if ray.d.x < 0.0 {
        (&node.child_max_x, &node.child_min_x)
    } else {
        (&node.child_min_x, &node.child_max_x)
    };
    let (near_y, far_y) = if ray.d.y < 0.0 {
        (&node.child_max_y, &node.child_min_y)
    } else {
        (&node.child_min_y, &node.child_max_y)
    };
    let (near_z, far_z) = if ray.d.z < 0.0 {
        (&node.child_max_z, &node.child_min_z)
    } else {
        (&node.child_min_z, &node.child_max_z)
    };
    let (sx, sy, sz) = (
        Vec4::splat(adj_inv.x),
        Vec4::splat(adj_inv.y),
        Vec4::splat(adj_inv.z),
    );
    let (ox, oy, oz) = (
        Vec4::splat(adj_o.x),
        Vec4::splat(adj_o.y),
        Vec4::splat(adj_o.z),
    );
    let limit = Vec4::splat(t_max);
    let mut hit_mask = 0;
    for half in 0..2 {
        let quad = |q: &[u8; 8]| {
            let i = 4 * half;
            Vec4::new(
                q[i] as f32,
                q[i + 1] as f32,
                q[i + 2] as f32,
                q[i + 3] as f32,
            )
        };
        let t_near = (quad(near_x) * sx + ox)
            .max(quad(near_y) * sy + oy)
            .max((quad(near_z) * sz + oz).max(Vec4::ZERO));
        let t_far = ((quad(far_x) * sx + ox)
            .min(quad(far_y) * sy + oy)
            .min(quad(far_z) * sz + oz)
            * FAR_SCALE)
            .min(limit);
        let mask = t_near.cmple(t_far).bitmask();
        for j in 0..4 {
            if mask & (1 << j) != 0 {
                let child = 4 * half + j;
                hit_mask |= extract_byte64(child_bits8, child) << extract_byte64(bit_index8, child);
            }
        }
    }
    hit_mask
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{NO_LIGHT, Sphere, TriangleMesh};
    use lightlab_core::Vec2;
    use lightlab_samplers::warp::square_to_uniform_sphere;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    fn vec(rng: &mut Pcg64, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(
            rng.random_range(lo..hi),
            rng.random_range(lo..hi),
            rng.random_range(lo..hi),
        )
    }

    fn dir(rng: &mut Pcg64) -> Vec3 {
        square_to_uniform_sphere(Vec2::new(rng.random::<f32>(), rng.random::<f32>()))
    }

    /// Snaps to multiples of 2⁻⁶, exactly representable after adding 10⁴.
    fn snap(v: Vec3) -> Vec3 {
        (v * 64.0).round() / 64.0
    }

    fn shape(geometry: Geometry, material: u32) -> Shape {
        Shape {
            geometry,
            material,
            light: NO_LIGHT,
        }
    }

    /// A soup of triangles of widely varying size (plus some degenerate ones), a closed grid mesh
    /// with shared vertices, and spheres; all coordinates on the 2⁻⁶ grid, then `· scale + offset`.
    fn scene(seed: u64, scale: f32, offset: Vec3) -> Vec<Shape> {
        let mut rng = Pcg64::seed_from_u64(seed);
        let tf = |p: Vec3| p * scale + offset;
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        for i in 0..3000u32 {
            let c = vec(&mut rng, -1.0, 1.0);
            let size = 0.02 * 15f32.powf(rng.random::<f32>());
            let mut v = [0; 3].map(|_| snap(c + size * vec(&mut rng, -1.0, 1.0)));
            match i % 100 {
                0 => v[2] = v[1],              // two equal vertices
                1 => v[2] = 2.0 * v[1] - v[0], // collinear
                2 => v = [v[0]; 3],            // a point
                _ => {}
            }
            positions.extend(v.map(tf));
            indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let soup = TriangleMesh::new(positions, None, None, indices).unwrap();

        // A 16×16 heightfield: neighbouring triangles share edges exactly.
        let n = 16u32;
        let grid_p: Vec<Vec3> = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| (i, j)))
            .map(|(i, j)| {
                let h = ((i * 7 + j * 3) % 5) as f32 / 64.0;
                tf(Vec3::new(
                    i as f32 / 8.0 - 1.0,
                    h - 0.875,
                    j as f32 / 8.0 - 1.0,
                ))
            })
            .collect();
        let grid_i: Vec<[u32; 3]> = (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .flat_map(|(i, j)| {
                let k = j * (n + 1) + i;
                [[k, k + n + 1, k + 1], [k + 1, k + n + 1, k + n + 2]]
            })
            .collect();
        let grid = TriangleMesh::new(grid_p, None, None, grid_i).unwrap();

        let mut shapes = vec![
            shape(Geometry::Mesh(soup), 0),
            shape(Geometry::Mesh(grid), 1),
        ];
        for _ in 0..40 {
            let center = tf(snap(vec(&mut rng, -1.0, 1.0)));
            let radius = scale * (rng.random_range(1..16) as f32 / 64.0);
            shapes.push(shape(Geometry::Sphere(Sphere::new(center, radius)), 2));
        }
        shapes
    }

    /// Both static structures, whatever the scene's size.
    const LAYOUTS: [Layout; 2] = [Layout::Compressed, Layout::Wide];

    fn build(layout: Layout, shapes: Vec<Shape>) -> Accel {
        Accel::with_layout(shapes, Vec::new(), (0.0, 0.0), layout)
    }

    /// Closest hit over every primitive of every shape, with the same primitive tests.
    fn brute_force(shapes: &[Shape], ray: &Ray) -> Option<(u32, u32, f32)> {
        let wray = WatertightRay::new(ray.o, ray.d)?;
        let mut best: Option<(u32, u32, f32)> = None;
        let mut t_max = ray.t_max;
        for (s, shape) in shapes.iter().enumerate() {
            match &shape.geometry {
                Geometry::Mesh(m) => {
                    for i in 0..m.len() {
                        if let Some(h) = triangle::intersect(&wray, &m.vertices(i), t_max)
                            && h.t < t_max
                        {
                            t_max = h.t;
                            best = Some((s as u32, i as u32, h.t));
                        }
                    }
                }
                Geometry::Sphere(sp) => {
                    if let Some(t) = sp.intersect(ray.o, ray.d, t_max) {
                        t_max = t;
                        best = Some((s as u32, 0, t));
                    }
                }
            }
        }
        best
    }

    fn check_hit_is_finite(h: &Hit) {
        for v in [h.p, h.p_error, h.ng, h.ns, h.dpdu] {
            assert!(v.is_finite(), "non-finite hit {h:?}");
        }
        assert!(h.uv.is_finite() && h.t.is_finite() && h.t > 0.0);
        assert!((h.ng.length() - 1.0).abs() < 1e-5 && (h.ns.length() - 1.0).abs() < 1e-5);
    }

    #[test]
    fn closest_hit_and_occlusion_match_brute_force() {
        for layout in LAYOUTS {
            closest_hit_and_occlusion_match_brute_force_in(layout);
        }
    }

    fn closest_hit_and_occlusion_match_brute_force_in(layout: Layout) {
        let variants = [
            (1.0, Vec3::ZERO),
            (1e-3, Vec3::ZERO),
            (1e3, Vec3::ZERO),
            (1.0, Vec3::splat(1e4)),
        ];
        for (v, &(scale, offset)) in variants.iter().enumerate() {
            let shapes = scene(7, scale, offset);
            let accel = build(layout, shapes.clone());
            let mut rng = Pcg64::seed_from_u64(100 + v as u64);
            let (mut hits, n) = (0, 10_000);
            for k in 0..n {
                let o = vec(&mut rng, -1.5, 1.5) * scale + offset;
                let d = dir(&mut rng) * if k % 3 == 0 { 0.37 } else { 1.0 };
                let t_max = if k % 4 == 0 {
                    rng.random_range(0.0..2.0) * scale
                } else {
                    f32::INFINITY
                };
                let ray = Ray::segment(o, d, t_max);
                let expected = brute_force(&shapes, &ray);
                let got = accel.intersect(&ray);
                assert_eq!(accel.occluded(&ray), expected.is_some(), "ray {k} {ray:?}");
                match (expected, got) {
                    (None, None) => {}
                    (Some((s, p, t)), Some(h)) => {
                        hits += 1;
                        check_hit_is_finite(&h);
                        let same = (h.shape, h.primitive) == (s, p);
                        assert!(
                            (h.t - t).abs() <= 1e-5 * t && (same || h.t == t),
                            "variant {v} ray {k}: brute force ({s}, {p}, {t}), bvh {h:?}"
                        );
                        assert_eq!(h.material, shapes[h.shape as usize].material);
                    }
                    (e, g) => panic!("variant {v} ray {k}: brute force {e:?}, bvh {g:?}"),
                }
            }
            assert!(hits > n / 4, "variant {v}: only {hits} hits");
        }
    }

    #[test]
    fn far_translated_scene_gives_identical_hits() {
        for layout in LAYOUTS {
            far_translated_scene_gives_identical_hits_in(layout);
        }
    }

    fn far_translated_scene_gives_identical_hits_in(layout: Layout) {
        // Every coordinate is on a grid that stays exact at 10⁴, so the two scenes must agree bit
        // for bit in t, shape and primitive.
        let near = build(layout, scene(11, 1.0, Vec3::ZERO));
        let offset = Vec3::splat(1e4);
        let far = build(layout, scene(11, 1.0, offset));
        let mut rng = Pcg64::seed_from_u64(12);
        for _ in 0..20_000 {
            let o = snap(vec(&mut rng, -1.5, 1.5));
            let d = dir(&mut rng);
            let a = near.intersect(&Ray::new(o, d));
            let b = far.intersect(&Ray::new(o + offset, d));
            let key = |h: Option<Hit>| h.map(|h| (h.shape, h.primitive, h.t));
            assert_eq!(key(a), key(b));
        }
    }

    #[test]
    fn tiny_and_huge_distances_are_hit() {
        for layout in LAYOUTS {
            tiny_and_huge_distances_are_hit_in(layout);
        }
    }

    fn tiny_and_huge_distances_are_hit_in(layout: Layout) {
        // A 10⁻⁶-sized triangle 10⁻⁶ in front of the origin, inside a scene of size 10⁻³.
        let tri = |c: Vec3, s: f32| {
            let p = vec![
                c + Vec3::new(-s, -s, 0.0),
                c + Vec3::new(s, -s, 0.0),
                c + Vec3::new(0.0, s, 0.0),
            ];
            shape(
                Geometry::Mesh(TriangleMesh::new(p, None, None, vec![[0, 1, 2]]).unwrap()),
                0,
            )
        };
        let small = build(
            layout,
            vec![
                tri(Vec3::new(0.0, 0.0, 1e-6), 1e-6),
                tri(Vec3::new(0.0, 0.0, 1e-3), 1e-3),
                tri(Vec3::new(5e-4, 0.0, -1e-3), 1e-3),
            ],
        );
        let h = small.intersect(&Ray::new(Vec3::ZERO, Vec3::Z)).unwrap();
        assert_eq!(h.shape, 0);
        assert!((h.t - 1e-6).abs() < 1e-12);
        assert!(small.occluded(&Ray::segment(Vec3::ZERO, Vec3::Z, 2e-6)));
        assert!(!small.occluded(&Ray::segment(Vec3::ZERO, Vec3::Z, 0.5e-6)));

        // Hits at t ≈ 10⁶ and from 10⁶ away.
        let big = build(
            layout,
            vec![
                tri(Vec3::new(0.0, 0.0, 1e6), 1e3),
                tri(Vec3::new(0.0, 0.0, 0.0), 1.0),
                shape(
                    Geometry::Sphere(Sphere::new(Vec3::new(0.0, 5.0, 0.0), 1.0)),
                    0,
                ),
            ],
        );
        let h = big
            .intersect(&Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::Z))
            .unwrap();
        assert_eq!(h.shape, 0);
        assert!((h.t - (1e6 - 1.0)).abs() < 1.0);
        let h = big
            .intersect(&Ray::new(Vec3::new(0.0, 5.0, -1e6), Vec3::Z))
            .unwrap();
        assert_eq!(h.shape, 2);
        assert!((h.t - (1e6 - 1.0)).abs() < 0.2);
        assert!((h.p - Vec3::new(0.0, 5.0, -1.0)).length() < 1e-5);
    }

    #[test]
    fn accel_is_send_and_sync() {
        fn check<T: Send + Sync>() {}
        check::<Accel>();
    }

    #[test]
    fn empty_and_single_primitive_scenes() {
        for layout in LAYOUTS {
            empty_and_single_primitive_scenes_in(layout);
        }
    }

    fn empty_and_single_primitive_scenes_in(layout: Layout) {
        let empty = build(layout, Vec::new());
        let ray = Ray::new(Vec3::ZERO, Vec3::Z);
        assert!(empty.intersect(&ray).is_none() && !empty.occluded(&ray));
        assert_eq!(empty.triangle_count(), 0);

        let one = build(
            layout,
            vec![shape(
                Geometry::Sphere(Sphere::new(Vec3::new(0.0, 0.0, 3.0), 1.0)),
                4,
            )],
        );
        let h = one.intersect(&ray).unwrap();
        assert_eq!(
            (h.shape, h.primitive, h.material, h.light),
            (0, 0, 4, NO_LIGHT)
        );
        assert!((h.t - 2.0).abs() < 1e-6);
        let (lo, hi) = one.bounds();
        assert!((lo - Vec3::new(-1.0, -1.0, 2.0)).abs().max_element() < 1e-5);
        assert!((hi - Vec3::new(1.0, 1.0, 4.0)).abs().max_element() < 1e-5);
        // From inside, the far side.
        let h = one
            .intersect(&Ray::new(Vec3::new(0.0, 0.0, 3.0), Vec3::X))
            .unwrap();
        assert!((h.t - 1.0).abs() < 1e-6 && (h.ng - Vec3::X).length() < 1e-6);
        // Zero direction or t_max: nothing.
        assert!(one.intersect(&Ray::new(Vec3::ZERO, Vec3::ZERO)).is_none());
        assert!(!one.occluded(&Ray::segment(Vec3::ZERO, Vec3::Z, 0.0)));
    }

    #[test]
    fn triangle_hit_attributes() {
        for layout in LAYOUTS {
            triangle_hit_attributes_in(layout);
        }
    }

    fn triangle_hit_attributes_in(layout: Layout) {
        let mesh = TriangleMesh::new(
            vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            Some(vec![Vec3::Z, Vec3::Z, Vec3::new(0.0, 1.0, 1.0)]),
            Some(vec![Vec2::ZERO, Vec2::new(2.0, 0.0), Vec2::new(0.0, 4.0)]),
            vec![[0, 1, 2]],
        )
        .unwrap();
        let accel = build(layout, vec![shape(Geometry::Mesh(mesh), 0)]);
        assert_eq!(accel.triangle_count(), 1);
        // From below: ng is not flipped towards the ray.
        let h = accel
            .intersect(&Ray::new(Vec3::new(0.25, 0.5, -1.0), Vec3::Z))
            .unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!((h.p - Vec3::new(0.25, 0.5, 0.0)).length() < 1e-6);
        assert_eq!(h.ng, Vec3::Z);
        assert!((h.ns - Vec3::new(0.0, 0.5, 1.0).normalize()).length() < 1e-6);
        assert!((h.uv - Vec2::new(0.5, 2.0)).length() < 1e-6);
        assert!((h.dpdu - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-6);
        assert!(h.p_error.max_element() > 0.0 && h.p_error.max_element() < 1e-6);
    }

    /// Every fourth shape of [`scene`] moves: a translation of the scene's size and a turn of up
    /// to 120° about a pivot inside the scene, over t in [0, 1].
    fn motions(shapes: &[Shape], seed: u64, scale: f32, offset: Vec3) -> Vec<Option<Motion>> {
        use crate::MotionKey;
        use glam::Quat;
        let mut rng = Pcg64::seed_from_u64(seed);
        (0..shapes.len())
            .map(|i| {
                let pivot = vec(&mut rng, -1.0, 1.0) * scale + offset;
                let axis = dir(&mut rng);
                let key = |time: f32, rng: &mut Pcg64| MotionKey {
                    time,
                    translate: vec(rng, -0.5, 0.5) * scale,
                    rotate: Quat::from_axis_angle(axis, rng.random_range(-1.0..1.0)),
                };
                let keys = vec![key(0.0, &mut rng), key(1.0, &mut rng)];
                (i % 4 == 1).then(|| Motion::new(pivot, keys).unwrap())
            })
            .collect()
    }

    #[test]
    fn moving_shapes_are_hit_where_they_are_at_the_rays_time() {
        for layout in LAYOUTS {
            moving_shapes_are_hit_where_they_are_at_the_rays_time_in(layout);
        }
    }

    fn moving_shapes_are_hit_where_they_are_at_the_rays_time_in(layout: Layout) {
        // Against a static BVH over the shapes moved to that instant (their geometry transformed,
        // not the ray): same shape, same t up to rounding, at every scale.
        for (v, &(scale, offset)) in [
            (1.0, Vec3::ZERO),
            (1e-3, Vec3::ZERO),
            (1e3, Vec3::splat(1e4)),
        ]
        .iter()
        .enumerate()
        {
            let shapes = scene(21, scale, offset);
            let motion = motions(&shapes, 22, scale, offset);
            let accel = Accel::with_layout(shapes.clone(), motion.clone(), (0.0, 1.0), layout);
            assert!(accel.has_motion() && accel.motion(1).is_some() && accel.motion(0).is_none());
            let mut rng = Pcg64::seed_from_u64(23);
            let mut moving_hits = 0;
            for k in 0..40 {
                let time = k as f32 / 39.0;
                let snapshot: Vec<Shape> = shapes
                    .iter()
                    .zip(&motion)
                    .map(|(s, m)| m.as_ref().map_or(s.clone(), |m| s.moved(&m.at(time))))
                    .collect();
                let still = build(layout, snapshot);
                let (lo, hi) = accel.bounds();
                let (slo, shi) = still.bounds();
                assert!(
                    lo.cmple(slo).all() && hi.cmpge(shi).all(),
                    "swept bounds too small"
                );
                for _ in 0..500 {
                    let o = vec(&mut rng, -1.5, 1.5) * scale + offset;
                    let ray = Ray::new(o, dir(&mut rng)).at_time(time);
                    let (a, b) = (accel.intersect(&ray), still.intersect(&ray));
                    assert_eq!(accel.occluded(&ray), b.is_some(), "variant {v} {ray:?}");
                    match (a, b) {
                        (None, None) => {}
                        (Some(a), Some(b)) => {
                            check_hit_is_finite(&a);
                            // Both sides round positions of magnitude |o|: t agrees to that.
                            let tol = 1e-5 * (o.abs().max_element() + scale);
                            assert!(
                                (a.t - b.t).abs() <= 1e-4 * b.t + tol
                                    && (a.shape == b.shape || (a.t - b.t).abs() <= tol),
                                "variant {v} at {time}: moving {a:?}, snapshot {b:?}"
                            );
                            if a.shape == b.shape {
                                assert!((a.p - b.p).length() <= tol);
                                assert!((a.ng - b.ng).length() <= 1e-3);
                            }
                            moving_hits += usize::from(motion[a.shape as usize].is_some());
                        }
                        (a, b) => panic!("variant {v} at {time}: moving {a:?}, snapshot {b:?}"),
                    }
                }
            }
            assert!(
                moving_hits > 500,
                "variant {v}: {moving_hits} hits on moving shapes"
            );
        }
    }

    /// A closed axis-aligned cube mesh, faces counter-clockwise from outside.
    fn cube(center: Vec3, half: f32) -> TriangleMesh {
        let corners: Vec<Vec3> = (0..8)
            .map(|i| {
                let s = |b: u32| if i >> b & 1 == 1 { 1.0 } else { -1.0 };
                center + half * Vec3::new(s(0), s(1), s(2))
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let indices = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect();
        TriangleMesh::new(corners, None, None, indices).unwrap()
    }

    #[test]
    fn rays_leaving_a_moving_shape_do_not_hit_it_again() {
        for layout in LAYOUTS {
            rays_leaving_a_moving_shape_do_not_hit_it_again_in(layout);
        }
    }

    fn rays_leaving_a_moving_shape_do_not_hit_it_again_in(layout: Layout) {
        use crate::spawn_ray;
        for &(scale, offset) in &[
            (1.0, Vec3::ZERO),
            (1e-3, Vec3::ZERO),
            (1e3, Vec3::splat(1e4)),
        ] {
            let center = Vec3::new(0.1, 0.2, 0.3) * scale + offset;
            for geometry in [
                Geometry::Sphere(Sphere::new(center, 0.5 * scale)),
                Geometry::Mesh(cube(center, 0.4 * scale)),
            ] {
                let shapes = vec![shape(geometry, 0)];
                let motion = motions(&[shapes[0].clone(), shapes[0].clone()], 5, scale, offset);
                let m = motion[1].clone().unwrap();
                let accel = Accel::with_layout(shapes, vec![Some(m.clone())], (0.0, 1.0), layout);
                let mut rng = Pcg64::seed_from_u64(6);
                let mut tested = 0;
                for k in 0..20_000 {
                    // Aimed at the shape where it is at that time.
                    let time = rng.random::<f32>();
                    let o = vec(&mut rng, -2.0, 2.0) * scale + offset;
                    let target = m.at(time).point(center) + vec(&mut rng, -0.3, 0.3) * scale;
                    let ray = Ray::new(o, target - o).at_time(time);
                    let Some(h) = accel.intersect(&ray) else {
                        continue;
                    };
                    tested += 1;
                    // Outward: nothing else to hit. Inward: another face, or the sphere's far
                    // side a chord away.
                    let out = if k % 2 == 0 { h.ng } else { -h.ng };
                    let d = (out + 0.999 * dir(&mut rng)).normalize_or(out);
                    let next = spawn_ray(h.p, h.p_error, h.ng, d).at_time(time);
                    match accel.intersect(&next) {
                        None => assert!(d.dot(h.ng) >= 0.0, "{next:?} missed the inside"),
                        Some(g) => assert!(
                            d.dot(h.ng) < 0.0 && g.t > 1e-3 * scale || g.ng.dot(h.ng) < 1.0 - 1e-3,
                            "self-hit at t = {} leaving {h:?}",
                            g.t
                        ),
                    }
                }
                assert!(tested > 15_000, "{tested} hits");
            }
        }
    }
}
