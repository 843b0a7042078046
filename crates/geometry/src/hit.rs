//! The record of a closest hit: plain data, everything the renderer needs at a surface point.

use lightlab_core::{Vec2, Vec3};

/// Plain data at a closest hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Ray parameter of the hit, in units of the ray direction's length.
    pub t: f32,
    /// The hit point, reconstructed on the surface (barycentric interpolation for triangles,
    /// reprojection for spheres), not `o + t·d`.
    pub p: Vec3,
    /// Conservative absolute error bound of `p` per axis (pbrt-v4 §6.8); feed it to
    /// [`spawn_ray`](crate::spawn_ray) and friends.
    pub p_error: Vec3,
    /// Unit geometric normal: `normalize(cross(p1 − p0, p2 − p0))` for triangles (counter-clockwise
    /// is the front), outward for spheres. Not flipped towards the ray.
    pub ng: Vec3,
    /// Unit shading normal: interpolated vertex normals when the mesh has them, else `ng`.
    /// Not flipped to `ng`'s side.
    pub ns: Vec3,
    /// Surface tangent ∂p/∂u, for anisotropic frames (not normalised; may be zero at a sphere's pole).
    pub dpdu: Vec3,
    pub uv: Vec2,
    /// Index of the shape in [`Accel::shapes`](crate::Accel::shapes).
    pub shape: u32,
    /// Triangle index within its mesh; 0 for spheres.
    pub primitive: u32,
    pub material: u32,
    /// Light id of an emissive shape, [`NO_LIGHT`](crate::NO_LIGHT) otherwise.
    pub light: u32,
}
