//! Lightlab's geometry: the shapes a scene is made of (triangle meshes and spheres), the ray
//! acceleration structure over all of them ([`Accel`]: a 4-wide BVH for small scenes, a compressed
//! 8-wide BVH from obvhs for large ones), the plain-data [`Hit`] record with a floating-point error
//! bound on the hit point, robust ray spawning from such points (pbrt-v4 §6.8.6), and area /
//! solid-angle sampling of shapes for light sampling.
//!
//! Precision contract (design.md, "Self-intersection"): every hit point carries a conservative
//! absolute error bound `p_error`; rays leave surfaces through [`spawn_ray`] and friends, which offset
//! the origin by that bound and never by a fixed epsilon. Intersection has no epsilon at the near
//! end either, so scenes scaled by 10⁻³ … 10³ or moved far from the origin behave the same.

mod accel;
mod bvh4;
mod hit;
mod mesh;
mod motion;
mod offset;
mod rotation;
mod sampling;
mod shape;
mod sphere;
mod triangle;

pub use accel::{Accel, AccelStats, Layout, WIDE_MAX_PRIMITIVES};
pub use hit::Hit;
pub use mesh::{MeshError, TriangleMesh};
pub use motion::{Motion, MotionKey, RigidTransform};
pub use offset::{offset_ray_origin, spawn_ray, spawn_ray_to, spawn_ray_to_point};
pub use rotation::{rotate, slerp, unrotate};
pub use sampling::SurfaceSample;
pub use shape::{Geometry, NO_LIGHT, Shape};
pub use sphere::Sphere;
pub use triangle::{geometric_normal, point_with_error};
