//! Shapes of a scene: a geometry plus the material and light ids the renderer needs at a hit, and
//! the sampling interface lights use (area and solid-angle densities).

use crate::mesh::TriangleMesh;
use crate::motion::RigidTransform;
use crate::sampling::{SurfaceSample, area_sample_to_solid_angle, pdf_area_to_solid_angle};
use crate::sphere::Sphere;
use lightlab_core::{Vec2, Vec3};

/// `Shape::light` of a shape that does not emit.
pub const NO_LIGHT: u32 = u32::MAX;

/// The geometry of one shape.
// A mesh carries more than a sphere (its cached sampling data); scenes hold few shapes, and
// boxing it would add a pointer chase to every hit and light sample.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum Geometry {
    Mesh(TriangleMesh),
    Sphere(Sphere),
}

/// One shape of the scene with the ids the renderer needs at a hit.
#[derive(Clone, Debug)]
pub struct Shape {
    pub geometry: Geometry,
    pub material: u32,
    /// Light id if the shape is emissive, [`NO_LIGHT`] otherwise.
    pub light: u32,
}

impl Shape {
    /// The shape's rest geometry moved by `m`: where a moving shape is at one instant.
    pub fn moved(&self, m: &RigidTransform) -> Shape {
        let geometry = match &self.geometry {
            Geometry::Mesh(mesh) => Geometry::Mesh(
                TriangleMesh::new(
                    mesh.positions.iter().map(|&p| m.point(p)).collect(),
                    mesh.normals
                        .as_ref()
                        .map(|n| n.iter().map(|&n| m.vector(n)).collect()),
                    mesh.uvs.clone(),
                    mesh.indices.clone(),
                )
                .expect("a rigid motion keeps a valid mesh valid"),
            ),
            Geometry::Sphere(s) => Geometry::Sphere(Sphere {
                center: m.point(s.center),
                radius: s.radius,
                orientation: (m.rotation() * s.orientation).normalize(),
            }),
        };
        Shape {
            geometry,
            ..self.clone()
        }
    }

    pub fn area(&self) -> f32 {
        match &self.geometry {
            Geometry::Mesh(m) => m.area(),
            Geometry::Sphere(s) => s.area(),
        }
    }

    /// A point uniform over the whole shape, pdf = 1 / area (0 for a shape without area).
    pub fn sample_area(&self, u: Vec2) -> SurfaceSample {
        match &self.geometry {
            Geometry::Mesh(m) => m.sample_area(u),
            Geometry::Sphere(s) => s.sample_area(u),
        }
    }

    pub fn pdf_area(&self) -> f32 {
        match &self.geometry {
            Geometry::Mesh(m) => m.pdf_area(),
            Geometry::Sphere(s) => s.pdf_area(),
        }
    }

    /// A point on the shape with its density in solid angle at `ref_p`. Spheres sample the cone of
    /// visible directions when `ref_p` is outside; meshes (and spheres around `ref_p`) convert area
    /// sampling, pdf_w = pdf_a·d²/|cos θ_light|. `None` when that density is degenerate (point seen
    /// edge-on or at `ref_p`, or a shape without area).
    pub fn sample_solid_angle(&self, ref_p: Vec3, u: Vec2) -> Option<SurfaceSample> {
        match &self.geometry {
            Geometry::Mesh(m) => area_sample_to_solid_angle(m.sample_area(u), ref_p),
            Geometry::Sphere(s) => s.sample_solid_angle(ref_p, u),
        }
    }

    /// Density [`Shape::sample_solid_angle`] has for the point `p` with geometric normal `n` on the
    /// shape, seen from `ref_p` (infinite when seen exactly edge-on).
    pub fn pdf_solid_angle(&self, ref_p: Vec3, p: Vec3, n: Vec3) -> f32 {
        match &self.geometry {
            Geometry::Mesh(m) => pdf_area_to_solid_angle(m.pdf_area(), ref_p, p, n),
            Geometry::Sphere(s) => s.pdf_solid_angle(ref_p, p, n),
        }
    }
}
