//! From a RON file to a [`Scene`]: parse, resolve material names and mesh files, apply transforms,
//! build the BVH and the lights.

use crate::desc::{
    GeometryDesc, GeometryRaw, LightDesc, LightRaw, MaterialDesc, MaterialRaw, Roughness,
    SceneDesc, TransformDesc,
};
use crate::{Camera, Light, Scene, SceneError};
use glam::{Mat3, Quat, Vec2, Vec3};
use lightlab_geometry::{Accel, Geometry, NO_LIGHT, Shape, Sphere, TriangleMesh};
use lightlab_materials::Bsdf;
use std::path::Path;

/// Loads and builds the scene in `path`. Mesh files are resolved relative to the scene file.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_scene(&text, path)
}

/// Builds a scene from RON `text`; `path` names it in errors and anchors relative mesh paths.
pub fn parse_scene(text: &str, path: &Path) -> Result<Scene, SceneError> {
    let options =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    let desc: SceneDesc = options.from_str(text).map_err(|e| SceneError::Invalid {
        path: path.to_path_buf(),
        line: e.span.start.line,
        col: e.span.start.col,
        message: e.code.to_string(),
    })?;
    build(desc, text, path)
}

fn build(desc: SceneDesc, text: &str, path: &Path) -> Result<Scene, SceneError> {
    if desc.shapes.is_empty() && desc.lights.is_empty() {
        return Err(SceneError::at(
            path,
            text,
            "Scene",
            "the scene is empty: it has no shapes and no lights".into(),
        ));
    }
    let camera = Camera::new(&desc.camera);
    let material_names: Vec<String> = desc.materials.iter().map(|(n, _)| n.clone()).collect();
    let materials: Vec<Bsdf> = desc.materials.iter().map(|(_, m)| bsdf(m)).collect();
    let base = path.parent().unwrap_or(Path::new("."));

    let mut shapes = Vec::with_capacity(desc.shapes.len());
    let mut lights = Vec::new();
    for (i, s) in desc.shapes.iter().enumerate() {
        let material = material_names
            .iter()
            .position(|n| *n == s.material)
            .ok_or_else(|| {
                let known = if material_names.is_empty() {
                    "none are defined".to_string()
                } else {
                    material_names.join(", ")
                };
                SceneError::at(
                    path,
                    text,
                    &format!("\"{}\"", s.material),
                    format!(
                        "shape {i}: unknown material \"{}\" (defined: {known})",
                        s.material
                    ),
                )
            })? as u32;
        let geometry = geometry(&s.geometry, &s.transform, base).map_err(|(needle, msg)| {
            SceneError::at(path, text, &needle, format!("shape {i}: {msg}"))
        })?;
        let light = match s.emission {
            Some(e) => {
                lights.push(Light::Area {
                    shape: i as u32,
                    radiance: e.radiance,
                    two_sided: e.two_sided,
                });
                (lights.len() - 1) as u32
            }
            None => NO_LIGHT,
        };
        let shape = Shape {
            geometry,
            material,
            light,
        };
        if light != NO_LIGHT && !(shape.area() > 0.0) {
            let needle = match &s.geometry.0 {
                GeometryRaw::Obj { file, .. } => format!("\"{file}\""),
                _ => "emission".into(),
            };
            return Err(SceneError::at(
                path,
                text,
                &needle,
                format!("shape {i}: emissive shape has zero area"),
            ));
        }
        shapes.push(shape);
    }
    lights.extend(desc.lights.iter().map(light));
    Ok(Scene::new(
        camera,
        Accel::new(shapes),
        materials,
        material_names,
        lights,
    ))
}

fn bsdf(m: &MaterialDesc) -> Bsdf {
    let alpha = |r: Roughness| match r {
        Roughness::Isotropic(a) => Vec2::splat(a),
        Roughness::Anisotropic(ax, ay) => Vec2::new(ax, ay),
    };
    match m.0 {
        MaterialRaw::Diffuse { albedo } => Bsdf::Diffuse { albedo },
        MaterialRaw::Mirror { reflectance } => Bsdf::Mirror { reflectance },
        MaterialRaw::Dielectric { ior } => Bsdf::Dielectric { eta: ior },
        MaterialRaw::RoughConductor { roughness, eta, k } => Bsdf::RoughConductor {
            alpha: alpha(roughness),
            eta,
            k,
        },
        MaterialRaw::RoughDielectric { roughness, ior } => Bsdf::RoughDielectric {
            alpha: alpha(roughness),
            eta: ior,
        },
        MaterialRaw::Phong { kd, ks, exponent } => Bsdf::Phong { kd, ks, exponent },
    }
}

fn light(l: &LightDesc) -> Light {
    match l.0 {
        LightRaw::Point {
            position,
            intensity,
        } => Light::Point {
            position,
            intensity,
        },
        LightRaw::Spot {
            position,
            target,
            intensity,
            cone_angle,
            falloff_start,
        } => Light::Spot {
            position,
            axis: (target - position).normalize(),
            intensity,
            cos_total: cone_angle.to_radians().cos(),
            cos_falloff_start: falloff_start.unwrap_or(cone_angle).to_radians().cos(),
        },
        LightRaw::Environment { radiance } => Light::Environment { radiance },
    }
}

/// An affine transform: p ↦ linear·p + translate, normals by the inverse transpose.
struct Affine {
    linear: Mat3,
    normal: Mat3,
    translate: Vec3,
}

impl Affine {
    fn new(t: &TransformDesc) -> Affine {
        let rotation = t.rotate.iter().fold(Quat::IDENTITY, |q, r| {
            Quat::from_axis_angle(r.axis.normalize(), r.degrees.to_radians()) * q
        });
        let linear = Mat3::from_quat(rotation) * Mat3::from_diagonal(t.scale);
        Affine {
            linear,
            normal: linear.inverse().transpose(),
            translate: t.translate,
        }
    }
    fn point(&self, p: Vec3) -> Vec3 {
        self.linear * p + self.translate
    }
    fn normal(&self, n: Vec3) -> Vec3 {
        (self.normal * n).normalize()
    }
    /// A transform with negative determinant flips the winding, and so the front side; we keep the
    /// front side where the transformed normal points by swapping two indices.
    fn flips(&self) -> bool {
        self.linear.determinant() < 0.0
    }
}

/// Builds the geometry in world space; on error returns (text to locate, message).
fn geometry(
    g: &GeometryDesc,
    t: &TransformDesc,
    base: &Path,
) -> Result<Geometry, (String, String)> {
    let xf = Affine::new(t);
    let mesh = |positions: Vec<Vec3>, indices: Vec<[u32; 3]>, normals: Option<Vec<Vec3>>| {
        let flip = xf.flips();
        TriangleMesh::new(
            positions.into_iter().map(|p| xf.point(p)).collect(),
            normals.map(|ns| ns.into_iter().map(|n| xf.normal(n)).collect()),
            None,
            indices
                .into_iter()
                .map(|[a, b, c]| if flip { [a, c, b] } else { [a, b, c] })
                .collect(),
        )
        .map(Geometry::Mesh)
        .map_err(|e| e.to_string())
    };
    let needle = match &g.0 {
        GeometryRaw::Obj { file, .. } => format!("\"{file}\""),
        GeometryRaw::Mesh { .. } => "Mesh".into(),
        _ => "geometry".into(),
    };
    Ok(match &g.0 {
        GeometryRaw::Mesh {
            positions,
            indices,
            normals,
        } => mesh(
            positions.clone(),
            indices.iter().map(|&(a, b, c)| [a, b, c]).collect(),
            normals.clone(),
        )
        .map_err(|m| (needle, m))?,
        GeometryRaw::Obj { file, normals } => {
            let (positions, indices, ns) =
                load_obj(&base.join(file), *normals).map_err(|m| (format!("\"{file}\""), m))?;
            mesh(positions, indices, ns).map_err(|m| (needle, m))?
        }
        GeometryRaw::Quad {
            corner,
            edge1,
            edge2,
        } => quad_mesh(*corner, *edge1, *edge2, &mesh).map_err(|m| (needle, m))?,
        GeometryRaw::QuadCorners {
            corners: (p0, p1, _, p3),
        } => quad_mesh(*p0, *p1 - *p0, *p3 - *p0, &mesh).map_err(|m| (needle, m))?,
        GeometryRaw::Cuboid { half_extents: h } => {
            let mut positions = Vec::with_capacity(24);
            let mut indices = Vec::with_capacity(12);
            for a in 0..3 {
                let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                let axis = |i: usize| Vec3::AXES[i] * h[i];
                for s in [1.0f32, -1.0] {
                    // e_b × e_c = e_a, so (edge1, edge2) = (b, c) faces +a; swap them for the −a face.
                    let (e1, e2) = if s > 0.0 {
                        (axis(b) * 2.0, axis(c) * 2.0)
                    } else {
                        (axis(c) * 2.0, axis(b) * 2.0)
                    };
                    let corner = axis(a) * s - axis(b) - axis(c);
                    let k = positions.len() as u32;
                    positions.extend([corner, corner + e1, corner + e1 + e2, corner + e2]);
                    indices.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]]);
                }
            }
            mesh(positions, indices, None).map_err(|m| (needle, m))?
        }
        GeometryRaw::Sphere { center, radius } => Geometry::Sphere(Sphere {
            center: xf.point(*center),
            radius: radius * t.scale.x.abs(),
        }),
    })
}

type MeshBuilder<'a> =
    &'a dyn Fn(Vec<Vec3>, Vec<[u32; 3]>, Option<Vec<Vec3>>) -> Result<Geometry, String>;

fn quad_mesh(corner: Vec3, e1: Vec3, e2: Vec3, mesh: MeshBuilder) -> Result<Geometry, String> {
    mesh(
        vec![corner, corner + e1, corner + e1 + e2, corner + e2],
        vec![[0, 1, 2], [0, 2, 3]],
        None,
    )
}

type ObjMesh = (Vec<Vec3>, Vec<[u32; 3]>, Option<Vec<Vec3>>);

/// Reads every object of an OBJ file into one triangle mesh.
fn load_obj(file: &Path, use_normals: bool) -> Result<ObjMesh, String> {
    if !file.is_file() {
        return Err(format!("mesh file {} does not exist", file.display()));
    }
    let (models, _materials) = tobj::load_obj(file, &tobj::GPU_LOAD_OPTIONS)
        .map_err(|e| format!("cannot read mesh file {}: {e}", file.display()))?;
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    let mut normals = Vec::new();
    let mut all_have_normals = use_normals;
    for m in &models {
        let base = positions.len() as u32;
        let mesh = &m.mesh;
        positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        indices.extend(
            mesh.indices
                .chunks_exact(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
        if mesh.normals.len() == mesh.positions.len() {
            normals.extend(
                mesh.normals
                    .chunks_exact(3)
                    .map(|n| Vec3::new(n[0], n[1], n[2])),
            );
        } else {
            all_have_normals = false;
        }
    }
    if indices.is_empty() {
        return Err(format!(
            "mesh file {} contains no triangles",
            file.display()
        ));
    }
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!(
            "mesh file {}: vertex {i} is not finite",
            file.display()
        ));
    }
    if indices
        .iter()
        .flatten()
        .any(|&v| v as usize >= positions.len())
    {
        return Err(format!(
            "mesh file {}: a face refers to a missing vertex",
            file.display()
        ));
    }
    let normals = all_have_normals
        .then_some(normals)
        .filter(|ns| ns.iter().all(|n| n.is_finite() && n.length_squared() > 0.0));
    Ok((positions, indices, normals))
}
