//! Mitsuba shape plugins as Lightlab geometry, in world space (the `to_world` transform applied
//! here, in f64): meshes from OBJ and PLY files, `rectangle`, `cube` and `sphere`.
//!
//! Mesh normals follow Mitsuba 3: a file's vertex normals are shading normals unless `face_normals`
//! is set; a mesh file without normals gets angle-weighted vertex normals (Thürmer and Wüthrich
//! 1998; Mitsuba's `recompute_vertex_normals`), so smooth meshes shade smoothly in both renderers.
//! `flip_normals` turns the front side (and so the side one-sided BSDFs and area lights face).
//!
//! Texture coordinates are Mitsuba's (read off Mitsuba 3.9.1): a mesh file's own (OBJ's v flipped
//! unless `flip_tex_coords` is false; PLY's `u`/`v`, `s`/`t` or `texture_u`/`texture_v` as they
//! are), barycentric (b₁, b₂) without them; a rectangle's ((x + 1)/2, (y + 1)/2) in its own frame;
//! Mitsuba's own table for the cube; a disk's (r, φ / 2π); a sphere's (φ / 2π, θ / π) in its own
//! (rotated) frame.

use super::object::Object;
use crate::SceneError;
use crate::desc::{GeometryDesc, GeometryRaw, RotationDesc, TransformDesc};
use crate::load::MeshFile;
use glam::{DMat3, DMat4, DQuat, DVec3, Vec2, Vec3};
use std::path::Path;

/// The world-space geometry of a `<shape>` and the transform that places it (the identity except
/// for spheres, which keep their rotation for their parameterisation); its nested BSDF and emitter
/// are read by the caller. What a mesh file's loading left out goes to `notes`.
pub(crate) fn geometry(
    o: &Object,
    base: &Path,
    notes: &mut Vec<String>,
) -> Result<(GeometryDesc, TransformDesc), SceneError> {
    let mut transform = TransformDesc::default();
    let to_world = o.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
    let flip = o.boolean("flip_normals", false)?;
    let g = match o.ty {
        "obj" | "ply" => {
            let file = o
                .string("filename")?
                .ok_or_else(|| o.error(format!("{} needs a filename", o.describe())))?;
            let face_normals = o.boolean("face_normals", false)?;
            let flip_v = o.ty == "obj" && o.boolean("flip_tex_coords", true)?;
            let path = base.join(file);
            let m = if o.ty == "obj" {
                crate::load::load_obj(&path, !face_normals, flip_v)
            } else {
                load_ply(&path)
            }
            .map_err(|m| o.error(m))?;
            notes.extend(m.notes.iter().cloned());
            mesh(m, face_normals, to_world, flip)
        }
        "rectangle" => {
            let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
            // The front is the transformed normal (0, 0, 1) (normals transform by the inverse
            // transpose): a mirroring transform reverses the corners' winding.
            let mirror = (to_world.determinant() < 0.0) != flip;
            let tris = [(0, 1, 2), (0, 2, 3)];
            GeometryRaw::Mesh {
                positions: corners
                    .iter()
                    .map(|&(x, y)| to_world.transform_point3(DVec3::new(x, y, 0.0)))
                    .collect(),
                indices: tris
                    .map(|(a, b, c)| if mirror { (a, c, b) } else { (a, b, c) })
                    .to_vec(),
                normals: None,
                uvs: Some(
                    corners
                        .iter()
                        .map(|&(x, y)| Vec2::new(0.5 * (x + 1.0) as f32, 0.5 * (y + 1.0) as f32))
                        .collect(),
                ),
            }
        }
        "disk" => {
            // The unit disk in z = 0 facing +z, as a fan of DISK_SEGMENTS triangles whose rim is
            // pushed out by √(θ / sin θ), θ = 2π/n, so that the area is the disk's exactly; the
            // boundary then stays within 4·10⁻⁶ of the radius (an approximation the import notes).
            let n = DISK_SEGMENTS;
            let theta = std::f64::consts::TAU / n as f64;
            let k = (theta / theta.sin()).sqrt();
            // Vertices: n + 1 on the rim (the first repeated at φ = 2π, where u wraps), then one
            // centre per triangle with the triangle's middle φ, so that (r, φ / 2π) interpolates
            // within 1/(2n) of Mitsuba's.
            let rim = |i: usize| {
                let (s, c) = (i as f64 * theta).sin_cos();
                to_world.transform_point3(DVec3::new(k * c, k * s, 0.0))
            };
            let mut positions: Vec<DVec3> = (0..=n).map(rim).collect();
            let mut uvs: Vec<Vec2> = (0..=n)
                .map(|i| Vec2::new(k as f32, i as f32 / n as f32))
                .collect();
            let centre = to_world.transform_point3(DVec3::ZERO);
            positions.extend(std::iter::repeat_n(centre, n));
            uvs.extend((0..n).map(|i| Vec2::new(0.0, (i as f32 + 0.5) / n as f32)));
            let mirror = (to_world.determinant() < 0.0) != flip;
            let indices = (0..n as u32)
                .map(|i| {
                    let (c, a, b) = (n as u32 + 1 + i, i, i + 1);
                    if mirror { (c, b, a) } else { (c, a, b) }
                })
                .collect();
            GeometryRaw::Mesh {
                positions,
                indices,
                normals: None,
                uvs: Some(uvs),
            }
        }
        "cube" => {
            let mirror = (to_world.determinant() < 0.0) != flip;
            GeometryRaw::Mesh {
                positions: CUBE_POSITIONS
                    .iter()
                    .map(|&p| to_world.transform_point3(DVec3::from_array(p)))
                    .collect(),
                indices: (0..6u32)
                    .flat_map(|f| {
                        let k = 4 * f;
                        [(k, k + 1, k + 2), (k + 3, k, k + 2)]
                    })
                    .map(|(a, b, c)| if mirror { (a, c, b) } else { (a, b, c) })
                    .collect(),
                normals: None,
                uvs: Some((0..6).flat_map(|_| CUBE_FACE_UVS).collect()),
            }
        }
        "sphere" => {
            if flip {
                return Err(
                    o.error("flip_normals on a sphere (an inward-facing sphere) is not imported")
                );
            }
            let center = o.point("center")?.unwrap_or(DVec3::ZERO);
            let radius = o.float_or("radius", 1.0)?;
            if !(radius > 0.0 && radius.is_finite()) {
                return Err(o.error(format!(
                    "a sphere's radius must be > 0 and finite, got {radius}"
                )));
            }
            let m = to_world
                * DMat4::from_translation(center)
                * DMat4::from_scale(DVec3::splat(radius));
            let lin = DMat3::from_mat4(m);
            let lengths = [lin.x_axis, lin.y_axis, lin.z_axis].map(|c| c.length());
            let r = lengths[0];
            let similar = lengths.iter().all(|l| (l - r).abs() <= 1e-6 * r)
                && lin.x_axis.dot(lin.y_axis).abs() <= 1e-6 * r * r
                && lin.y_axis.dot(lin.z_axis).abs() <= 1e-6 * r * r
                && lin.z_axis.dot(lin.x_axis).abs() <= 1e-6 * r * r;
            if !((r as f32) > 0.0 && (r as f32).is_finite()) {
                return Err(o.error(format!(
                    "the sphere's radius in the world, {r:e}, is beyond what 32-bit floats hold"
                )));
            }
            if !similar {
                return Err(o.error(
                    "a sphere's to_world must be a rotation, uniform scale and translation (an \
                     ellipsoid is not a sphere)",
                ));
            }
            if lin.determinant() < 0.0 {
                return Err(o.error(
                    "a mirroring to_world on a sphere is not imported (its parameterisation would \
                     be mirrored; use a rotation)",
                ));
            }
            // The sphere's own frame, for its (u, v): the rotation part, as an axis and angle.
            let (axis, angle) = DQuat::from_mat3(&(lin * (1.0 / r))).to_axis_angle();
            transform = TransformDesc {
                rotate: vec![RotationDesc {
                    axis: axis.as_vec3(),
                    degrees: angle.to_degrees() as f32,
                }],
                translate: m.transform_point3(DVec3::ZERO),
                ..TransformDesc::default()
            };
            GeometryRaw::Sphere {
                center: DVec3::ZERO,
                radius: r as f32,
            }
        }
        other => {
            return Err(o.error(format!(
                "shape type '{other}' is not imported (supported: obj, ply, rectangle, cube, \
                 sphere, disk)"
            )));
        }
    };
    let g = GeometryDesc::try_from(g).map_err(|e| o.error(format!("{}: {e}", o.describe())))?;
    Ok((g, transform))
}

/// Mitsuba 3.9.1's `cube`: four corners per face (faces −y, +y, +x, +z, −x, −z), triangles
/// (0, 1, 2) and (3, 0, 2) of each, and the same (u, v) on every face.
const CUBE_POSITIONS: [[f64; 3]; 24] = [
    [1.0, -1.0, -1.0],
    [1.0, -1.0, 1.0],
    [-1.0, -1.0, 1.0],
    [-1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, 1.0, 1.0],
    [1.0, 1.0, 1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [1.0, 1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
    [-1.0, -1.0, 1.0],
    [-1.0, -1.0, 1.0],
    [-1.0, 1.0, 1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [1.0, -1.0, -1.0],
    [-1.0, -1.0, -1.0],
    [-1.0, 1.0, -1.0],
];
const CUBE_FACE_UVS: [Vec2; 4] = [
    Vec2::new(0.0, 1.0),
    Vec2::new(1.0, 1.0),
    Vec2::new(1.0, 0.0),
    Vec2::new(0.0, 0.0),
];

/// Triangles of a tessellated `disk`.
pub(crate) const DISK_SEGMENTS: usize = 1024;

/// A mesh file's triangles in world space, with Mitsuba's normals (see the module docs).
fn mesh(m: MeshFile, face_normals: bool, to_world: DMat4, flip: bool) -> GeometryRaw {
    let MeshFile {
        positions,
        indices,
        normals,
        uvs,
        ..
    } = m;
    let positions: Vec<DVec3> = positions
        .into_iter()
        .map(|p| to_world.transform_point3(p))
        .collect();
    let normal_matrix = DMat3::from_mat4(to_world).inverse().transpose();
    let normals = if face_normals {
        None
    } else {
        Some(match normals {
            Some(ns) => ns
                .into_iter()
                .map(|n| (normal_matrix * n.as_dvec3()).normalize().as_vec3())
                .collect(),
            None => angle_weighted_normals(&positions, &indices),
        })
    };
    let sign = if flip { -1.0 } else { 1.0 };
    GeometryRaw::Mesh {
        positions,
        indices: indices
            .into_iter()
            .map(|[a, b, c]| if flip { (a, c, b) } else { (a, b, c) })
            .collect(),
        normals: normals.map(|ns| ns.into_iter().map(|n| n * sign).collect()),
        uvs,
    }
}

/// Vertex normals as the sum of the adjacent faces' normals weighted by the face's angle at the
/// vertex (Thürmer and Wüthrich 1998). A vertex no face gives a direction gets +z (it shades
/// nothing: no triangle uses it).
fn angle_weighted_normals(positions: &[DVec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut sum = vec![DVec3::ZERO; positions.len()];
    for t in indices {
        let p = t.map(|i| positions[i as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        for k in 0..3 {
            let d0 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
            let d1 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
            let angle = d0.dot(d1).clamp(-1.0, 1.0).acos();
            sum[t[k] as usize] += n * angle;
        }
    }
    sum.into_iter()
        .map(|n| n.try_normalize().unwrap_or(DVec3::Z).as_vec3())
        .collect()
}

/// Reads the vertices (x, y, z and optional nx, ny, nz) and faces (polygons, fan-triangulated) of
/// a PLY file, ASCII or binary.
fn load_ply(path: &Path) -> Result<MeshFile, String> {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::{DefaultElement, Property};
    let file = std::fs::File::open(path)
        .map_err(|e| format!("cannot open mesh file {}: {e}", path.display()))?;
    let mut reader = std::io::BufReader::new(file);
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut reader)
        .map_err(|e| format!("cannot read PLY file {}: {e}", path.display()))?;
    let scalar = |e: &DefaultElement, key: &str| -> Option<f64> {
        Some(match e.get(key)? {
            Property::Float(x) => *x as f64,
            Property::Double(x) => *x,
            _ => return None,
        })
    };
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| format!("PLY file {} has no vertex element", path.display()))?;
    let mut positions = Vec::with_capacity(vertices.len());
    let mut normals = Vec::with_capacity(vertices.len());
    let mut uvs = Vec::with_capacity(vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        let p = match (scalar(v, "x"), scalar(v, "y"), scalar(v, "z")) {
            (Some(x), Some(y), Some(z)) => DVec3::new(x, y, z),
            _ => {
                return Err(format!(
                    "PLY file {}: vertex {i} has no float x, y, z",
                    path.display()
                ));
            }
        };
        if !p.is_finite() {
            return Err(format!(
                "PLY file {}: vertex {i} is not finite",
                path.display()
            ));
        }
        positions.push(p);
        if let (Some(x), Some(y), Some(z)) = (scalar(v, "nx"), scalar(v, "ny"), scalar(v, "nz")) {
            normals.push(Vec3::new(x as f32, y as f32, z as f32));
        }
        let uv = [
            ("u", "v"),
            ("s", "t"),
            ("texture_u", "texture_v"),
            ("texture_s", "texture_t"),
        ]
        .iter()
        .find_map(|&(a, b)| Some(Vec2::new(scalar(v, a)? as f32, scalar(v, b)? as f32)));
        if let Some(uv) = uv {
            uvs.push(uv);
        }
    }
    let faces = ply
        .payload
        .get("face")
        .ok_or_else(|| format!("PLY file {} has no face element", path.display()))?;
    let mut indices = Vec::with_capacity(faces.len());
    for (f, face) in faces.iter().enumerate() {
        let list: Vec<i64> = match face
            .get("vertex_indices")
            .or_else(|| face.get("vertex_index"))
        {
            Some(Property::ListInt(l)) => l.iter().map(|&i| i as i64).collect(),
            Some(Property::ListUInt(l)) => l.iter().map(|&i| i as i64).collect(),
            Some(Property::ListShort(l)) => l.iter().map(|&i| i as i64).collect(),
            Some(Property::ListUShort(l)) => l.iter().map(|&i| i as i64).collect(),
            Some(Property::ListChar(l)) => l.iter().map(|&i| i as i64).collect(),
            Some(Property::ListUChar(l)) => l.iter().map(|&i| i as i64).collect(),
            _ => {
                return Err(format!(
                    "PLY file {}: face {f} has no integer vertex_indices list",
                    path.display()
                ));
            }
        };
        if list.len() < 3 || list.iter().any(|&i| i < 0 || i as usize >= positions.len()) {
            return Err(format!(
                "PLY file {}: face {f} needs ≥ 3 indices of existing vertices, got {list:?}",
                path.display()
            ));
        }
        for k in 1..list.len() - 1 {
            indices.push([list[0] as u32, list[k] as u32, list[k + 1] as u32]);
        }
    }
    if indices.is_empty() {
        return Err(format!("PLY file {} has no faces", path.display()));
    }
    let n = positions.len();
    let (normals, uvs, notes) = crate::load::usable_attributes(
        path,
        (normals.len() == n).then_some(normals),
        (uvs.len() == n).then_some(uvs),
    );
    Ok(MeshFile {
        positions,
        indices,
        normals,
        uvs,
        notes,
    })
}
