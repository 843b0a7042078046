//! The patches of a radiosity solution: every triangle of the scene's meshes cut into m² equal
//! triangles (m chosen per triangle so that patches are about the target area), every sphere into
//! equal-area cells between parallels equally spaced in z (Archimedes: a zone's area is 2πr·Δz)
//! and meridians. A patch has two sides, front (the side its geometric normal points to) and
//! back, each an unknown of the solution: unknown `2 i + side` of patch i.

use glam::Quat;
use lightlab_core::{PI, Vec2, Vec3};
use lightlab_geometry::{
    Geometry, Hit, Sphere, TriangleMesh, geometric_normal, point_with_error, rotate, unrotate,
};
use lightlab_samplers::warp::square_to_uniform_triangle;
use lightlab_scene::Scene;

/// Where a patch lies on its shape.
#[derive(Clone, Copy, Debug)]
enum Piece {
    /// Sub-triangle of a mesh triangle with these corners in the triangle's barycentric (b₁, b₂).
    Triangle {
        triangle: [Vec3; 3],
        corners: [Vec2; 3],
    },
    /// Sphere cell z₀ ≤ z ≤ z₁, φ₀ ≤ φ ≤ φ₁ in the sphere's own frame.
    SphereCell {
        sphere: Sphere,
        z: [f32; 2],
        phi: [f32; 2],
    },
}

/// One patch: a piece of one shape.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Patch {
    pub shape: u32,
    pub area: f64,
    piece: Piece,
}

/// A point sampled on a patch.
pub(crate) struct PatchPoint {
    pub p: Vec3,
    pub p_error: Vec3,
    /// Unit geometric normal (the front side's).
    pub n: Vec3,
}

impl Patch {
    /// A point uniform over the patch's area.
    pub fn sample(&self, u: Vec2) -> PatchPoint {
        match self.piece {
            Piece::Triangle { triangle, corners } => {
                let s = square_to_uniform_triangle(u);
                let b =
                    corners[0] + s.x * (corners[1] - corners[0]) + s.y * (corners[2] - corners[0]);
                let (p, p_error) = point_with_error(&triangle, [1.0 - b.x - b.y, b.x, b.y], 6);
                PatchPoint {
                    p,
                    p_error,
                    n: geometric_normal(&triangle).unwrap_or(Vec3::Z),
                }
            }
            Piece::SphereCell { sphere, z, phi } => {
                let cz = z[0] + u.x * (z[1] - z[0]);
                let f = phi[0] + u.y * (phi[1] - phi[0]);
                let sz = (1.0 - cz * cz).max(0.0).sqrt();
                let n = rotate(
                    sphere.orientation,
                    Vec3::new(sz * f.cos(), sz * f.sin(), cz),
                )
                .normalize();
                let (p, p_error) = sphere.world_point(sphere.radius * n);
                PatchPoint { p, p_error, n }
            }
        }
    }
}

/// How one shape's patches are numbered.
#[derive(Clone, Debug)]
enum Layout {
    /// Triangle k's patches start at `first[k]`; it is cut `cuts[k]` times along each edge.
    Mesh { first: Vec<u32>, cuts: Vec<u32> },
    /// Cells start at `first`: `bands` zones in z, `sectors` in φ, band-major.
    Sphere {
        first: u32,
        bands: u32,
        sectors: u32,
        orientation: Quat,
        center: Vec3,
    },
}

/// Every patch of a scene and the map from a ray hit to its patch.
pub(crate) struct Patches {
    pub list: Vec<Patch>,
    layouts: Vec<Layout>,
}

impl Patches {
    /// Cuts `scene`'s shapes into about `target` patches of equal area.
    pub fn new(scene: &Scene, target: u32) -> Patches {
        let total: f64 = scene.shapes().iter().map(|s| s.area() as f64).sum();
        let patch_area = total / target.max(1) as f64;
        let mut list = Vec::new();
        let mut layouts = Vec::new();
        for (si, shape) in scene.shapes().iter().enumerate() {
            let si = si as u32;
            layouts.push(match &shape.geometry {
                Geometry::Mesh(mesh) => mesh_patches(mesh, si, patch_area, &mut list),
                Geometry::Sphere(sphere) => sphere_patches(sphere, si, patch_area, &mut list),
            });
        }
        Patches { list, layouts }
    }

    /// The patch a ray hit.
    pub fn patch_of(&self, hit: &Hit, scene: &Scene) -> u32 {
        match &self.layouts[hit.shape as usize] {
            Layout::Mesh { first, cuts } => {
                let k = hit.primitive as usize;
                let Geometry::Mesh(mesh) = &scene.shapes()[hit.shape as usize].geometry else {
                    unreachable!("a mesh layout belongs to a mesh")
                };
                first[k] + sub_triangle(barycentric(&mesh.vertices(k), hit.p), cuts[k])
            }
            &Layout::Sphere {
                first,
                bands,
                sectors,
                orientation,
                center,
            } => {
                let d = unrotate(orientation, hit.p - center).normalize_or(Vec3::Z);
                let band = (((d.z + 1.0) * 0.5 * bands as f32) as u32).min(bands - 1);
                let phi = d.y.atan2(d.x).rem_euclid(2.0 * PI);
                let sector = ((phi / (2.0 * PI) * sectors as f32) as u32).min(sectors - 1);
                first + band * sectors + sector
            }
        }
    }
}

fn mesh_patches(mesh: &TriangleMesh, shape: u32, patch_area: f64, list: &mut Vec<Patch>) -> Layout {
    let mut first = Vec::with_capacity(mesh.len());
    let mut cuts = Vec::with_capacity(mesh.len());
    for k in 0..mesh.len() {
        let area = mesh.triangle_area(k) as f64;
        let m = ((area / patch_area).sqrt().round() as u32).clamp(1, MAX_CUTS);
        first.push(list.len() as u32);
        cuts.push(m);
        let triangle = mesh.vertices(k);
        let sub = area / (m * m) as f64;
        let c = |i: u32, j: u32| Vec2::new(i as f32, j as f32) / m as f32;
        // Upright triangles (i, j), (i+1, j), (i, j+1) with i + j ≤ m − 1, row by row, then the
        // inverted ones (i+1, j), (i+1, j+1), (i, j+1) with i + j ≤ m − 2 (see `sub_triangle`).
        for i in 0..m {
            for j in 0..m - i {
                list.push(Patch {
                    shape,
                    area: sub,
                    piece: Piece::Triangle {
                        triangle,
                        corners: [c(i, j), c(i + 1, j), c(i, j + 1)],
                    },
                });
            }
        }
        for i in 0..m.saturating_sub(1) {
            for j in 0..m - 1 - i {
                list.push(Patch {
                    shape,
                    area: sub,
                    piece: Piece::Triangle {
                        triangle,
                        corners: [c(i + 1, j), c(i + 1, j + 1), c(i, j + 1)],
                    },
                });
            }
        }
    }
    Layout::Mesh { first, cuts }
}

/// Cuts per triangle edge at most (m² patches).
const MAX_CUTS: u32 = 4096;

fn sphere_patches(sphere: &Sphere, shape: u32, patch_area: f64, list: &mut Vec<Patch>) -> Layout {
    let area = sphere.area() as f64;
    let cells = (area / patch_area).round().max(2.0);
    let bands = ((cells / 2.0).sqrt().round() as u32).clamp(1, MAX_CUTS);
    let sectors = 2 * bands;
    let first = list.len() as u32;
    let cell_area = area / (bands * sectors) as f64;
    for b in 0..bands {
        for s in 0..sectors {
            let z = |b: u32| -1.0 + 2.0 * b as f32 / bands as f32;
            let phi = |s: u32| 2.0 * PI * s as f32 / sectors as f32;
            list.push(Patch {
                shape,
                area: cell_area,
                piece: Piece::SphereCell {
                    sphere: *sphere,
                    z: [z(b), z(b + 1)],
                    phi: [phi(s), phi(s + 1)],
                },
            });
        }
    }
    Layout::Sphere {
        first,
        bands,
        sectors,
        orientation: sphere.orientation,
        center: sphere.center,
    }
}

/// Barycentrics (b₁, b₂) of the point `p` on (or, from rounding, beside) triangle `v`.
fn barycentric(v: &[Vec3; 3], p: Vec3) -> Vec2 {
    let (e1, e2, d) = (v[1] - v[0], v[2] - v[0], p - v[0]);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if !(det > 0.0) {
        return Vec2::ZERO;
    }
    Vec2::new((d22 * d1 - d12 * d2) / det, (d11 * d2 - d12 * d1) / det)
}

/// Index, in `mesh_patches`' order, of the sub-triangle holding barycentrics `b` when the triangle
/// is cut `m` times along each edge.
fn sub_triangle(b: Vec2, m: u32) -> u32 {
    let mf = m as f32;
    let (x, y) = ((b.x.clamp(0.0, 1.0) * mf), (b.y.clamp(0.0, 1.0) * mf));
    let i = (x as u32).min(m - 1);
    let j = (y as u32).min(m - 1 - i);
    let inverted = i + j < m - 1 && (x - i as f32) + (y - j as f32) > 1.0;
    if inverted {
        // After all m(m+1)/2 upright ones; inverted row i has m − 1 − i entries.
        m * (m + 1) / 2 + i * (m - 1) - i * i.saturating_sub(1) / 2 + j
    } else {
        // Upright row i has m − i entries.
        i * m - i * i.saturating_sub(1) / 2 + j
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every sub-triangle's centroid maps back to that sub-triangle.
    #[test]
    fn sub_triangle_indices_are_the_construction_order() {
        for m in [1, 2, 3, 7] {
            let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
            let mut list = Vec::new();
            let mesh = TriangleMesh::new(v.to_vec(), None, None, vec![[0, 1, 2]]).unwrap();
            mesh_patches(&mesh, 0, 0.5 / (m * m) as f64, &mut list);
            assert_eq!(list.len(), (m * m) as usize);
            for (k, patch) in list.iter().enumerate() {
                let Piece::Triangle { corners, .. } = patch.piece else {
                    panic!()
                };
                let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
                assert_eq!(sub_triangle(centroid, m), k as u32, "m {m}");
            }
        }
    }
}
