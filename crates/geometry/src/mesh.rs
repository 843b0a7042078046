//! Indexed triangle meshes with optional per-vertex shading normals and texture coordinates, and
//! uniform area sampling over a whole mesh (triangle chosen ∝ area, then a uniform point in it).

use crate::sampling::SurfaceSample;
use crate::triangle::{self, DEFAULT_UV};
use lightlab_core::{Vec2, Vec3, gamma};
use lightlab_samplers::{Distribution1D, warp};
use std::fmt;

/// An indexed triangle mesh. Build it with [`TriangleMesh::new`], which checks the data and caches
/// the area distribution used by [`TriangleMesh::sample_area`]; the fields stay public for reading
/// and must not be changed afterwards (the cache would go stale).
#[derive(Clone, Debug)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    /// Optional per-vertex shading normals (need not be unit length).
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    /// Counter-clockwise triangles (seen from the front, where the geometric normal points).
    pub indices: Vec<[u32; 3]>,
    /// Triangle choice ∝ area; `None` when the mesh has zero area.
    area_distribution: Option<Distribution1D>,
    area: f32,
    /// Per triangle, what every hit and light sample on it needs and no ray changes, computed
    /// once here (24 bytes a triangle; recomputing them per hit cost more time than their load,
    /// even on the 1.05 M-triangle benchmark mesh: BENCHMARKS.md, "Speed work (issue 15): traversal,
    /// hit records, light sampling").
    frames: Vec<TriangleFrame>,
    /// A mesh of two triangles that make a parallelogram (a `Quad`, a rectangular area light) is
    /// sampled as one, without choosing a triangle.
    parallelogram: Option<Parallelogram>,
}

/// The parallelogram `origin + s·e1 + t·e2`, (s, t) ∈ [0, 1)², of a two-triangle mesh, with how
/// far (per axis) its fourth corner lies from the mesh's shared vertex: the corners are rounded to f32, so the two triangles may close the
/// parallelogram only to a few ulps, which the sampled points' error bound absorbs.
#[derive(Clone, Copy, Debug)]
struct Parallelogram {
    origin: Vec3,
    e1: Vec3,
    e2: Vec3,
    gap: Vec3,
}

/// A triangle's unit geometric normal ([`triangle::geometric_normal`]; zero for a degenerate
/// triangle) and ∂p/∂u ([`triangle::dpdu`] under the mesh's (u, v)).
#[derive(Clone, Copy, Debug)]
struct TriangleFrame {
    ng: Vec3,
    dpdu: Vec3,
}

/// What is wrong with mesh data given to [`TriangleMesh::new`].
#[derive(Clone, Debug, PartialEq)]
pub enum MeshError {
    /// Triangle `triangle` refers to vertex `index`, but there are only `vertices`.
    IndexOutOfRange {
        triangle: usize,
        index: u32,
        vertices: usize,
    },
    /// `normals` or `uvs` (named by `what`) has `len` entries instead of one per position.
    AttributeLength {
        what: &'static str,
        len: usize,
        vertices: usize,
    },
    /// Position `vertex` has a NaN or infinite coordinate.
    NonFinitePosition { vertex: usize },
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshError::IndexOutOfRange {
                triangle,
                index,
                vertices,
            } => write!(
                f,
                "triangle {triangle} uses vertex {index}, but the mesh has {vertices} vertices"
            ),
            MeshError::AttributeLength {
                what,
                len,
                vertices,
            } => write!(
                f,
                "the mesh has {len} {what} for {vertices} vertices (need one per vertex)"
            ),
            MeshError::NonFinitePosition { vertex } => {
                write!(f, "vertex {vertex} has a NaN or infinite coordinate")
            }
        }
    }
}

impl std::error::Error for MeshError {}

impl TriangleMesh {
    /// Checks the mesh (indices in range, one normal / uv per vertex, finite positions) and caches
    /// its area distribution. Degenerate triangles are allowed: they are never hit or sampled.
    pub fn new(
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        uvs: Option<Vec<Vec2>>,
        indices: Vec<[u32; 3]>,
    ) -> Result<TriangleMesh, MeshError> {
        let vertices = positions.len();
        if let Some(vertex) = positions.iter().position(|p| !p.is_finite()) {
            return Err(MeshError::NonFinitePosition { vertex });
        }
        for (what, len) in [
            ("normals", normals.as_ref().map(Vec::len)),
            ("uvs", uvs.as_ref().map(Vec::len)),
        ] {
            if let Some(len) = len.filter(|&len| len != vertices) {
                return Err(MeshError::AttributeLength {
                    what,
                    len,
                    vertices,
                });
            }
        }
        for (triangle, tri) in indices.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertices) {
                return Err(MeshError::IndexOutOfRange {
                    triangle,
                    index,
                    vertices,
                });
            }
        }
        let mut mesh = TriangleMesh {
            positions,
            normals,
            uvs,
            indices,
            area_distribution: None,
            area: 0.0,
            frames: Vec::new(),
            parallelogram: None,
        };
        mesh.frames = (0..mesh.indices.len())
            .map(|i| {
                let v = mesh.vertices(i);
                match triangle::geometric_normal(&v) {
                    Some(ng) => TriangleFrame {
                        ng,
                        dpdu: triangle::dpdu(&v, &mesh.vertex_uvs(i), ng),
                    },
                    None => TriangleFrame {
                        ng: Vec3::ZERO,
                        dpdu: Vec3::ZERO,
                    },
                }
            })
            .collect();
        let areas: Vec<f32> = (0..mesh.indices.len())
            .map(|i| mesh.triangle_area(i))
            .collect();
        mesh.area_distribution = Distribution1D::new(&areas);
        mesh.area = mesh
            .area_distribution
            .as_ref()
            .map_or(0.0, |d| d.total() as f32);
        mesh.parallelogram = mesh.as_parallelogram();
        Ok(mesh)
    }

    /// The parallelogram two triangles (a, b, c) and (a, c, d) sharing the diagonal a–c make, when
    /// they do: coplanar, with the same orientation, and d − a + b − a = c − a to 16 ulps of the
    /// largest coordinate (what rounding the corners of an exact parallelogram leaves).
    fn as_parallelogram(&self) -> Option<Parallelogram> {
        let [t0, t1] = self.indices[..] else {
            return None;
        };
        let (n0, n1) = (self.geometric_normal(0)?, self.geometric_normal(1)?);
        // The diagonal: the two vertices the triangles share, taken in t0's order (a before c).
        let shared: Vec<usize> = (0..3).filter(|&k| t1.contains(&t0[k])).collect();
        let [i, j] = shared[..] else {
            return None;
        };
        let (a, b, c) = match (i, j) {
            (0, 2) => (t0[0], t0[1], t0[2]),
            (0, 1) => (t0[1], t0[2], t0[0]),
            _ => (t0[2], t0[0], t0[1]),
        };
        let d = *t1.iter().find(|&&k| k != a && k != c)?;
        let [a, b, c, d] = [a, b, c, d].map(|k| self.positions[k as usize]);
        let gap = (c.as_dvec3() - (b.as_dvec3() + d.as_dvec3() - a.as_dvec3())).abs();
        let scale = [a, b, c, d]
            .iter()
            .map(|p| p.abs().max_element())
            .fold(0.0, f32::max);
        let closes = gap.max_element() <= 16.0 * f64::from(f32::EPSILON) * f64::from(scale);
        (n0.dot(n1) > 1.0 - 1e-6 && closes).then(|| Parallelogram {
            origin: a,
            e1: b - a,
            e2: d - a,
            gap: gap.as_vec3(),
        })
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.indices.len()
    }

    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// The three vertex positions of triangle `i`.
    #[inline]
    pub fn vertices(&self, i: usize) -> [Vec3; 3] {
        self.indices[i].map(|k| self.positions[k as usize])
    }

    /// Unit geometric normal of triangle `i` ([`triangle::geometric_normal`]); `None` when it is
    /// degenerate.
    #[inline]
    pub fn geometric_normal(&self, i: usize) -> Option<Vec3> {
        let ng = self.frames[i].ng;
        (ng != Vec3::ZERO).then_some(ng)
    }

    /// ∂p/∂u of the non-degenerate triangle `i` under the mesh's (u, v) ([`triangle::dpdu`]).
    #[inline]
    pub(crate) fn dpdu(&self, i: usize) -> Vec3 {
        self.frames[i].dpdu
    }

    /// The (u, v) of triangle `i`'s vertices ((0, 0), (1, 0), (0, 1) without uvs: barycentric).
    #[inline]
    pub fn vertex_uvs(&self, i: usize) -> [Vec2; 3] {
        match &self.uvs {
            Some(uvs) => self.indices[i].map(|k| uvs[k as usize]),
            None => DEFAULT_UV,
        }
    }

    pub fn triangle_area(&self, i: usize) -> f32 {
        let [p0, p1, p2] = self.vertices(i);
        0.5 * (p1 - p0).cross(p2 - p0).length()
    }

    /// Total surface area.
    pub fn area(&self) -> f32 {
        self.area
    }

    /// Unit shading normal at barycentrics `b` of triangle `i`: interpolated vertex normals, or
    /// `ng` when the mesh has none or they cancel.
    #[inline]
    pub(crate) fn shading_normal(&self, i: usize, b: [f32; 3], ng: Vec3) -> Vec3 {
        match &self.normals {
            Some(normals) => {
                let [n0, n1, n2] = self.indices[i].map(|k| normals[k as usize]);
                (b[0] * n0 + b[1] * n1 + b[2] * n2)
                    .try_normalize()
                    .unwrap_or(ng)
            }
            None => ng,
        }
    }

    /// A point uniform over the whole mesh (pdf 1 / area): `u.x` picks the triangle ∝ area and is
    /// then reused, remapped, for the point inside it (pbrt-v4 §A.4.2 and §6.5.4); a parallelogram
    /// is sampled as one, `origin + u.x·e1 + u.y·e2`. A mesh of zero area returns pdf 0.
    pub fn sample_area(&self, u: Vec2) -> SurfaceSample {
        if let Some(q) = &self.parallelogram {
            let (along1, along2) = (u.x * q.e1, u.y * q.e2);
            // The rounding of e1, e2, the products and the sums (γ₆, as pbrt-v4 bounds a sampled
            // triangle point), and how far the rounded corners leave the exact parallelogram.
            let p_error = gamma(6) * (q.origin.abs() + along1.abs() + along2.abs()) + q.gap;
            return SurfaceSample {
                p: q.origin + along1 + along2,
                p_error,
                n: self.frames[0].ng,
                pdf: 1.0 / self.area,
            };
        }
        let Some(distribution) = &self.area_distribution else {
            return SurfaceSample {
                p: self.positions.first().copied().unwrap_or(Vec3::ZERO),
                p_error: Vec3::ZERO,
                n: Vec3::Z,
                pdf: 0.0,
            };
        };
        let (i, _, ux) = distribution.sample(u.x);
        let v = self.vertices(i);
        let b12 = warp::square_to_uniform_triangle(Vec2::new(ux, u.y));
        let b = [1.0 - b12.x - b12.y, b12.x, b12.y];
        let (p, p_error) = triangle::point_with_error(&v, b, 6);
        SurfaceSample {
            p,
            p_error,
            // Sampled triangles have positive area, so the normal exists.
            n: self.geometric_normal(i).unwrap_or(Vec3::Z),
            pdf: 1.0 / self.area,
        }
    }

    /// Density of [`TriangleMesh::sample_area`] per unit area.
    pub fn pdf_area(&self) -> f32 {
        if self.area > 0.0 {
            1.0 / self.area
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_rejects_bad_data() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!(matches!(
            TriangleMesh::new(p.clone(), None, None, vec![[0, 1, 3]]),
            Err(MeshError::IndexOutOfRange { index: 3, .. })
        ));
        assert!(matches!(
            TriangleMesh::new(p.clone(), Some(vec![Vec3::Z]), None, vec![[0, 1, 2]]),
            Err(MeshError::AttributeLength {
                what: "normals",
                ..
            })
        ));
        assert!(matches!(
            TriangleMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::NAN], None, None, vec![]),
            Err(MeshError::NonFinitePosition { vertex: 2 })
        ));
        let m = TriangleMesh::new(p, None, None, vec![[0, 1, 2]]).unwrap();
        assert_eq!(m.area(), 0.5);
    }

    #[test]
    fn zero_area_mesh_has_zero_pdf() {
        let m = TriangleMesh::new(vec![Vec3::ZERO, Vec3::X], None, None, vec![[0, 1, 1]]).unwrap();
        assert_eq!(m.area(), 0.0);
        assert_eq!(m.pdf_area(), 0.0);
        let s = m.sample_area(Vec2::splat(0.5));
        assert_eq!(s.pdf, 0.0);
        assert!(s.p.is_finite());
    }

    fn quad(corners: [Vec3; 4], flipped: bool) -> TriangleMesh {
        let indices = if flipped {
            vec![[0, 2, 1], [0, 3, 2]]
        } else {
            vec![[0, 1, 2], [0, 2, 3]]
        };
        TriangleMesh::new(corners.to_vec(), None, None, indices).unwrap()
    }

    /// Rectangles in either vertex order, near and far from the origin, are sampled as
    /// parallelograms; kites, bent quads and other meshes are not.
    #[test]
    fn parallelograms_are_recognised() {
        let (u, v) = (Vec3::new(0.8, 0.6, 0.0), Vec3::new(-0.18, 0.24, 0.4));
        for c in [Vec3::ZERO, Vec3::new(1e4, -3e3, 7e3)] {
            for flipped in [false, true] {
                let m = quad([c - u - v, c + u - v, c + u + v, c - u + v], flipped);
                let q = m.parallelogram.expect("a rectangle");
                assert!((q.e1.cross(q.e2).length() - m.area()).abs() < 1e-5 * m.area());
            }
        }
        let kite = [
            Vec3::ZERO,
            Vec3::new(1.0, -0.3, 0.0),
            Vec3::new(2.5, 0.0, 0.0),
            Vec3::Y,
        ];
        let bent = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.01), Vec3::Y];
        for corners in [kite, bent] {
            assert!(quad(corners, false).parallelogram.is_none());
        }
        let one = TriangleMesh::new(kite.to_vec(), None, None, vec![[0, 1, 2]]).unwrap();
        assert!(one.parallelogram.is_none());
    }
}
