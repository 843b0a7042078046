//! From a RON file to a [`Scene`]: parse, resolve material names and mesh files, apply transforms,
//! build the BVH and the lights.
//!
//! Positions are read and transformed in f64, and the whole scene is then moved so that the centre
//! of its bounding box (geometry, camera and lights) is the origin before anything is rounded to
//! the f32 the renderer works in: a scene translated far from the world origin renders like the
//! original, because f32 spacing is set by the coordinates' size after the move — the scene's
//! extent — not by its distance from the world origin (pbrt-v4 renders in camera-relative space for
//! the same reason). `Scene::origin` records where that centre is in the file's coordinates.

use crate::desc::{
    ColourDesc, GeometryDesc, GeometryRaw, LightDesc, LightRaw, MAX_EMITTED, MaterialDesc,
    MaterialRaw, Microfacets, MotionDesc, RotationDesc, Roughness, SceneDesc, TransformDesc,
};
use crate::{Camera, EnvMap, Light, Scene, SceneError};
use glam::{DMat3, DQuat, DVec3, Mat3, Vec2, Vec3};
use lightlab_core::Rgb;
use lightlab_geometry::{
    Accel, Geometry, Motion, MotionKey, NO_LIGHT, Shape, Sphere, TriangleMesh,
};
use lightlab_materials::{Bsdf, Distribution, Material, Plastic, RoughPlastic};
use std::path::Path;

/// Loads and builds the scene in `path`: RON, or a Mitsuba 3 XML file (`.xml`, imported with its
/// defaults; its notes become the scene's warnings). Mesh files are resolved relative to the file.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    if crate::mitsuba::is_mitsuba(path) {
        let imported = crate::mitsuba::import(path, &[])?;
        let mut scene = build_scene(imported.desc, path)?;
        scene.warnings.extend(imported.notes);
        return Ok(scene);
    }
    let text = crate::text::read_text(path).map_err(|e| SceneError::reading(path, e))?;
    parse_scene(&text, path)
}

/// Builds a scene from a description made in code (e.g. by the Mitsuba importer); `path` names it
/// in errors and anchors relative mesh paths.
pub fn build_scene(desc: SceneDesc, path: &Path) -> Result<Scene, SceneError> {
    build(desc, "", path)
}

/// Where the field lies that a camera's validation names ("camera fov must be …"): ron reports
/// such an error at the end of `Camera(...)`, so the field is the last `fov:` between the camera's
/// opening and that position.
fn field_of_camera_error(text: &str, e: &ron::error::SpannedError) -> Option<(usize, usize)> {
    let ron::Error::Message(m) = &e.code else {
        return None;
    };
    let field = m.strip_prefix("camera ")?.split_whitespace().next()?;
    // The byte offset of ron's (1-based, character) line and column.
    let line_start: usize = text
        .split_inclusive('\n')
        .take(e.span.start.line.saturating_sub(1))
        .map(str::len)
        .sum();
    let end = line_start
        + text[line_start..]
            .chars()
            .take(e.span.start.col.saturating_sub(1))
            .map(char::len_utf8)
            .sum::<usize>();
    let camera = text[..end].rfind("Camera(")?;
    let at = camera + text[camera..end].rfind(&format!("{field}:"))?;
    Some(crate::error::line_col(text, at))
}

/// Builds a scene from RON `text`; `path` names it in errors and anchors relative mesh paths.
pub fn parse_scene(text: &str, path: &Path) -> Result<Scene, SceneError> {
    // A byte-order mark (some editors write one) is not part of the RON.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let options =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    let desc: SceneDesc = options.from_str(text).map_err(|e| {
        // An error at the very end of the text means the file stops inside a value.
        let body = text.trim_end();
        let end_line = body.matches('\n').count() + 1;
        let end_col = body.len() - body.rfind('\n').map_or(0, |i| i + 1) + 1;
        let at_end = (e.span.start.line, e.span.start.col) >= (end_line, end_col);
        let (line, col) =
            field_of_camera_error(text, &e).unwrap_or((e.span.start.line, e.span.start.col));
        SceneError::Invalid {
            path: path.to_path_buf(),
            line,
            col,
            message: if matches!(e.code, ron::Error::Eof) || at_end {
                format!(
                    "unexpected end of file: the file stops inside a value (is it truncated, or \
                     a bracket left open?) [{}]",
                    e.code
                )
            } else {
                crate::ron_message(&e.code)
            },
        }
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
    let base = path.parent().unwrap_or(Path::new("."));
    let inputs: Vec<std::path::PathBuf> = desc.input_files().iter().map(|f| base.join(f)).collect();
    let texture_names: Vec<&str> = desc.textures.iter().map(|(n, _)| n.as_str()).collect();
    let textures = desc
        .textures
        .iter()
        .map(|(name, t)| {
            crate::textures::texture(t, base).map_err(|(needle, m)| {
                // A settings error is located at the texture's entry, `"name":`.
                let needle = if needle.is_empty() {
                    [format!("\"{name}\":"), format!("\"{name}\"")]
                        .into_iter()
                        .find(|n| text.contains(n.as_str()))
                        .unwrap_or_default()
                } else {
                    needle
                };
                SceneError::at(path, text, &needle, format!("texture \"{name}\": {m}"))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let material_names: Vec<String> = desc.materials.iter().map(|(n, _)| n.clone()).collect();
    let materials = desc
        .materials
        .iter()
        .map(|(name, m)| {
            crate::textures::material(m, &texture_names, &textures).map_err(|(needle, msg)| {
                SceneError::at(path, text, &needle, format!("material \"{name}\": {msg}"))
            })
        })
        .collect::<Result<Vec<Material>, _>>()?;

    // World-space geometry in f64, then the scene's centre.
    let mut world = Vec::with_capacity(desc.shapes.len());
    let mut bounds = Bounds::default();
    let mut mesh_notes = Vec::new();
    bounds.add(desc.camera.eye);
    for l in &desc.lights {
        match l.0 {
            LightRaw::Point { position, .. } | LightRaw::Spot { position, .. } => {
                bounds.add(position)
            }
            LightRaw::Environment { .. }
            | LightRaw::EnvironmentMap { .. }
            | LightRaw::Directional { .. } => {}
        }
    }
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
        let g = geometry(&s.geometry, &s.transform, base, &mut mesh_notes).map_err(
            |(needle, msg)| SceneError::at(path, text, &needle, format!("shape {i}: {msg}")),
        )?;
        g.extend(&mut bounds);
        world.push((material, g));
    }
    let origin = bounds.centre();

    let camera = Camera::new(&desc.camera, origin);
    let mut shapes = Vec::with_capacity(desc.shapes.len());
    let mut lights = Vec::new();
    // The camera and the point and spot lights: how near they are to a surface is a feature too.
    let mut features = Features {
        points: std::iter::once(desc.camera.eye)
            .chain(desc.lights.iter().filter_map(|l| match l.0 {
                LightRaw::Point { position, .. } | LightRaw::Spot { position, .. } => {
                    Some(position)
                }
                _ => None,
            }))
            .collect(),
        ..Features::default()
    };
    let mut motions = Vec::with_capacity(desc.shapes.len());
    let mut degenerate = Vec::new();
    let mut degenerate_triangles = Vec::new();
    for (i, ((material, g), s)) in world.into_iter().zip(&desc.shapes).enumerate() {
        let needle = match &s.geometry.0 {
            GeometryRaw::Obj { file, .. } => format!("\"{file}\""),
            GeometryRaw::Mesh { .. } => "Mesh".into(),
            _ => "geometry".into(),
        };
        features.add(&g, origin);
        // Checked shape by shape, before anything (an emitter's area) overflows.
        if features.largest > MAX_EXTENT {
            return Err(SceneError::at(
                path,
                text,
                &needle,
                format!(
                    "shape {i} reaches {:.3e} from the scene's centre; render space is f32, \
                     whose triangle areas and squared distances overflow beyond about \
                     {MAX_EXTENT:e} (areas came out infinite or NaN): scale the scene down",
                    features.largest
                ),
            ));
        }
        let geometry = g
            .into_render_space(origin)
            .map_err(|msg| SceneError::at(path, text, &needle, format!("shape {i}: {msg}")))?;
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
        if !(shape.area() > 0.0) {
            // Allowed (it changes nothing), but most likely a typo: parallel quad edges, a mesh
            // of collapsed triangles.
            degenerate.push(i);
        } else if let Geometry::Mesh(m) = &shape.geometry {
            // Collapsed triangles in a mesh that has area: as harmless, and as likely a slip.
            let collapsed = (0..m.len())
                .filter(|&t| !(m.triangle_area(t) > 0.0))
                .count();
            if collapsed > 0 {
                degenerate_triangles.push((i, collapsed));
            }
        }
        shapes.push(shape);
        motions.push(s.motion.as_ref().map(|m| motion(m, origin)));
    }
    let env = environment_map(&desc.lights, base)
        .map_err(|(needle, msg)| SceneError::at(path, text, &needle, msg))?;
    for l in &desc.lights {
        match l.0 {
            // Folded into the map.
            LightRaw::EnvironmentMap { .. } => {}
            LightRaw::Environment { .. } if env.is_some() => {}
            _ => lights.push(light(l, origin)),
        }
    }
    if let Some((map, constant)) = env {
        lights.push(Light::Environment {
            radiance: constant,
            map: Some(std::sync::Arc::new(map)),
        });
    }
    let shutter = camera.shutter;
    let accel = Accel::with_motion(shapes, motions, shutter);
    // Moving shapes reach where their motion takes them while the shutter is open.
    let (lo, hi) = accel.bounds();
    let reach = lo.abs().max(hi.abs()).max_element() as f64;
    if !(reach <= MAX_EXTENT) {
        return Err(SceneError::at(
            path,
            text,
            "motion:",
            format!(
                "while the shutter is open, moving shapes reach {reach:.3e} from the scene's \
                 centre; render space is f32, whose triangle areas and squared distances \
                 overflow beyond about {MAX_EXTENT:e}: keep the motion's translations within it"
            ),
        ));
    }
    let mut scene = Scene::new(camera, accel, materials, material_names, textures, lights);
    scene.origin = origin;
    scene.inputs = inputs;
    scene.warnings.extend(features.warning(path));
    if !degenerate.is_empty() {
        scene.warnings.push(format!(
            "{}: shapes {degenerate:?} have zero area: no ray can hit them",
            path.display()
        ));
    }
    for (i, n) in degenerate_triangles {
        scene.warnings.push(format!(
            "{}: shape {i} has {n} zero-area triangles (repeated or collinear vertices): no ray \
             can hit them",
            path.display()
        ));
    }
    scene.warnings.extend(mesh_notes);
    Ok(scene)
}

/// The bounding box of everything placed in the scene, in f64.
#[derive(Default)]
struct Bounds(Option<(DVec3, DVec3)>);

impl Bounds {
    fn add(&mut self, p: DVec3) {
        self.0 = Some(match self.0 {
            None => (p, p),
            Some((lo, hi)) => (lo.min(p), hi.max(p)),
        });
    }

    /// The centre of the box (the origin of render space).
    fn centre(&self) -> DVec3 {
        self.0.map_or(DVec3::ZERO, |(lo, hi)| (lo + hi) * 0.5)
    }
}

/// What f32 render space must resolve: the largest coordinate and the smallest feature (triangle
/// edge, sphere radius, or the distance from the camera or a point or spot light to the nearest
/// surface: a light one unit above a plane a million wide is lit from positions that carry errors
/// of the plane's float steps).
#[derive(Default)]
struct Features {
    largest: f64,
    smallest: f64,
    /// The camera's and the positional lights' positions (world space).
    points: Vec<DVec3>,
}

/// The farthest a shape may reach from the scene's centre (render space): a triangle twice as wide
/// has a cross product whose squared length overflows f32.
const MAX_EXTENT: f64 = 1e9;

/// A feature spanning fewer float steps of the largest coordinate than this is reported.
const MIN_STEPS: f64 = 1024.0;

impl Features {
    fn add(&mut self, g: &WorldGeometry, origin: DVec3) {
        if self.smallest == 0.0 {
            self.smallest = f64::INFINITY;
        }
        match g {
            WorldGeometry::Mesh {
                positions, indices, ..
            } => {
                for p in positions {
                    self.largest = self.largest.max((*p - origin).abs().max_element());
                }
                for t in indices {
                    let v = t.map(|i| positions[i as usize]);
                    for k in 0..3 {
                        let e = v[k].distance(v[(k + 1) % 3]);
                        if e > 0.0 {
                            self.smallest = self.smallest.min(e);
                        }
                    }
                    for &p in &self.points {
                        let d = p.distance(closest_on_triangle(p, v));
                        if d > 0.0 {
                            self.smallest = self.smallest.min(d);
                        }
                    }
                }
            }
            WorldGeometry::Sphere { center, radius, .. } => {
                let r = *radius as f64;
                self.largest = self.largest.max((*center - origin).abs().max_element() + r);
                self.smallest = self.smallest.min(r);
                for &p in &self.points {
                    let d = (p.distance(*center) - r).abs();
                    if d > 0.0 {
                        self.smallest = self.smallest.min(d);
                    }
                }
            }
        }
    }

    /// A warning when the smallest feature spans fewer than `MIN_STEPS` f32 steps at the largest
    /// coordinate of render space (a tiny object in a huge scene): f32 positions then quantise it.
    fn warning(&self, path: &Path) -> Option<String> {
        let step = self.largest * f32::EPSILON as f64;
        (self.smallest.is_finite() && step > 0.0 && self.smallest < MIN_STEPS * step).then(|| {
            format!(
                "{}: the smallest feature ({:.3e}: a shape's size, or the distance from the camera \
                 or a point or spot light to a surface) is only {:.0} float steps of the scene's \
                 extent ({:.3e} from its centre): f32 positions will quantise it visibly; scale or \
                 split the scene so that its parts are within about 10⁴ of each other in size",
                path.display(),
                self.smallest,
                self.smallest / step,
                self.largest
            )
        })
    }
}

/// The point of triangle `v` nearest to `p` (Ericson 2005, "Real-Time Collision Detection",
/// §5.1.5: the Voronoi region of `p` among the vertices, edges and face).
fn closest_on_triangle(p: DVec3, [a, b, c]: [DVec3; 3]) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// The BSDF of `m` with its constant colours; a textured colour is black here (the texture
/// replaces it at every hit: [`Material::bsdf_at`]).
pub(crate) fn bsdf(m: &MaterialDesc) -> Bsdf {
    let c = |c: &ColourDesc| c.constant().unwrap_or(Rgb::BLACK);
    let alpha = |r: Roughness| match r {
        Roughness::Isotropic(a) => Vec2::splat(a),
        Roughness::Anisotropic(ax, ay) => Vec2::new(ax, ay),
    };
    match m.raw {
        MaterialRaw::Diffuse { ref albedo } => Bsdf::Diffuse { albedo: c(albedo) },
        MaterialRaw::Mirror { ref reflectance } => Bsdf::Mirror {
            reflectance: c(reflectance),
        },
        MaterialRaw::Conductor { eta, k } => Bsdf::Conductor { eta, k },
        MaterialRaw::Dielectric { ior } => Bsdf::Dielectric { eta: ior },
        MaterialRaw::ThinDielectric { ior } => Bsdf::ThinDielectric { eta: ior },
        MaterialRaw::RoughConductor {
            roughness,
            eta,
            k,
            distribution,
        } => Bsdf::RoughConductor {
            alpha: alpha(roughness),
            eta,
            k,
            distribution: microfacets(distribution),
        },
        MaterialRaw::RoughDielectric {
            roughness,
            ior,
            distribution,
        } => Bsdf::RoughDielectric {
            alpha: alpha(roughness),
            eta: ior,
            distribution: microfacets(distribution),
        },
        MaterialRaw::Phong {
            ref kd,
            ref ks,
            exponent,
        } => Bsdf::Phong {
            kd: c(kd),
            ks: c(ks),
            exponent,
        },
        MaterialRaw::Plastic {
            ref kd,
            ref ks,
            ior,
            nonlinear,
        } => Bsdf::Plastic(Plastic::new(c(kd), c(ks), ior, nonlinear)),
        MaterialRaw::RoughPlastic {
            ref kd,
            ref ks,
            roughness,
            ior,
            distribution,
            nonlinear,
        } => Bsdf::RoughPlastic(RoughPlastic::new(
            c(kd),
            c(ks),
            microfacets(distribution),
            alpha(roughness).x,
            ior,
            nonlinear,
        )),
    }
}

fn microfacets(d: Microfacets) -> Distribution {
    match d {
        Microfacets::Ggx => Distribution::Ggx,
        Microfacets::Beckmann => Distribution::Beckmann,
    }
}

fn light(l: &LightDesc, origin: DVec3) -> Light {
    match l.0 {
        LightRaw::Point {
            position,
            intensity,
        } => Light::Point {
            position: (position - origin).as_vec3(),
            intensity,
        },
        LightRaw::Spot {
            position,
            target,
            intensity,
            cone_angle,
            falloff_start,
            profile,
        } => Light::Spot {
            position: (position - origin).as_vec3(),
            axis: crate::desc::unit(target - position).as_vec3(),
            intensity,
            cos_total: cone_angle.to_radians().cos(),
            cos_falloff_start: falloff_start.unwrap_or(cone_angle).to_radians().cos(),
            profile,
        },
        LightRaw::Environment { radiance } => Light::Environment {
            radiance,
            map: None,
        },
        LightRaw::Directional {
            direction,
            irradiance,
        } => Light::Directional {
            direction: crate::desc::unit(direction).as_vec3(),
            irradiance,
        },
        LightRaw::EnvironmentMap { .. } => unreachable!("environment maps are built by the loader"),
    }
}

/// The scene's environment map, if it has one, with the constant environments folded in (their
/// sum is returned too); on error (text to locate, message).
fn environment_map(
    lights: &[LightDesc],
    base: &Path,
) -> Result<Option<(EnvMap, Rgb)>, (String, String)> {
    let maps: Vec<(&String, f32, &Vec<RotationDesc>)> = lights
        .iter()
        .filter_map(|l| match &l.0 {
            LightRaw::EnvironmentMap {
                file,
                scale,
                rotate,
            } => Some((file, *scale, rotate)),
            _ => None,
        })
        .collect();
    let (file, scale, rotate) = match maps[..] {
        [] => return Ok(None),
        [m] => m,
        _ => {
            return Err((
                "EnvironmentMap".into(),
                "a scene has at most one EnvironmentMap (add constant Environments to it instead)"
                    .into(),
            ));
        }
    };
    let needle = format!("\"{file}\"");
    let (w, h, texels) =
        crate::image::read_rgb_image(&base.join(file), false).map_err(|m| (needle.clone(), m))?;
    let rotation = RotationDesc::compose(rotate);
    let to_world = DMat3::from_quat(rotation).as_mat3();
    let constant = lights.iter().fold(Rgb::BLACK, |acc, l| match l.0 {
        LightRaw::Environment { radiance } => acc + radiance,
        _ => acc,
    });
    // The scale alone is checked with the description; the brightest texel (an HDR sun) too,
    // once the map has refused negative and non-finite texels.
    let brightest = texels
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.max_component().total_cmp(&b.1.max_component()))
        .map(|(i, t)| (i, t.max_component()));
    let map = EnvMap::new(w, h, texels, scale, constant, to_world)
        .map_err(|m| (needle.clone(), format!("{file}: {m}")))?;
    if let Some((i, t)) = brightest
        && t as f64 * scale as f64 + constant.max_component() as f64 > MAX_EMITTED as f64
    {
        return Err((
            needle,
            format!(
                "{file}: texel ({}, {}) of {t} times scale {scale} (plus any constant \
                 Environment) emits more than {MAX_EMITTED:e} per channel: pixel values are \
                 squared for their variance in 32-bit floats, which overflow beyond that; lower \
                 the scale or express the scene in larger units of power",
                i % w,
                i / w
            ),
        ));
    }
    Ok(Some((map, constant)))
}

/// A shape's keyframed motion in render space (the pivot moved by −`origin`).
fn motion(m: &MotionDesc, origin: DVec3) -> Motion {
    let keys = m
        .keys
        .iter()
        .map(|k| MotionKey {
            time: k.time,
            translate: k.translate.as_vec3(),
            rotate: RotationDesc::compose(&k.rotate).as_quat(),
        })
        .collect();
    Motion::new((m.pivot - origin).as_vec3(), keys)
        .expect("MotionDesc checked its keys when it was parsed")
}

/// An affine transform: p ↦ linear·p + translate (in f64), normals by the inverse transpose.
struct Affine {
    linear: DMat3,
    normal: Mat3,
    translate: DVec3,
    rotation: DQuat,
}

impl Affine {
    fn new(t: &TransformDesc) -> Affine {
        let rotation = RotationDesc::compose(&t.rotate);
        let linear = DMat3::from_quat(rotation) * DMat3::from_diagonal(t.scale.as_dvec3());
        Affine {
            linear,
            normal: linear.inverse().transpose().as_mat3(),
            translate: t.translate,
            rotation,
        }
    }
    fn point(&self, p: DVec3) -> DVec3 {
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

/// A shape's geometry in world space, positions in f64.
enum WorldGeometry {
    Mesh {
        positions: Vec<DVec3>,
        normals: Option<Vec<Vec3>>,
        uvs: Option<Vec<Vec2>>,
        indices: Vec<[u32; 3]>,
    },
    Sphere {
        center: DVec3,
        radius: f32,
        orientation: DQuat,
    },
}

impl WorldGeometry {
    fn extend(&self, bounds: &mut Bounds) {
        match self {
            WorldGeometry::Mesh { positions, .. } => positions.iter().for_each(|&p| bounds.add(p)),
            WorldGeometry::Sphere { center, radius, .. } => {
                bounds.add(*center - *radius as f64);
                bounds.add(*center + *radius as f64);
            }
        }
    }

    /// The geometry in render space: moved by −`origin`, then rounded to f32.
    fn into_render_space(self, origin: DVec3) -> Result<Geometry, String> {
        match self {
            WorldGeometry::Mesh {
                positions,
                normals,
                uvs,
                indices,
            } => TriangleMesh::new(
                positions
                    .into_iter()
                    .map(|p| (p - origin).as_vec3())
                    .collect(),
                normals,
                uvs,
                indices,
            )
            .map(Geometry::Mesh)
            .map_err(|e| e.to_string()),
            WorldGeometry::Sphere {
                center,
                radius,
                orientation,
            } => Ok(Geometry::Sphere(Sphere {
                center: (center - origin).as_vec3(),
                radius,
                orientation: orientation.as_quat(),
            })),
        }
    }
}

/// Builds the geometry in world space, adding what a mesh file's loading left out to `notes`; on
/// error returns (text to locate, message).
fn geometry(
    g: &GeometryDesc,
    t: &TransformDesc,
    base: &Path,
    notes: &mut Vec<String>,
) -> Result<WorldGeometry, (String, String)> {
    let xf = Affine::new(t);
    let mesh = |positions: Vec<DVec3>,
                indices: Vec<[u32; 3]>,
                normals: Option<Vec<Vec3>>,
                uvs: Option<Vec<Vec2>>| {
        let flip = xf.flips();
        WorldGeometry::Mesh {
            positions: positions.into_iter().map(|p| xf.point(p)).collect(),
            normals: normals.map(|ns| ns.into_iter().map(|n| xf.normal(n)).collect()),
            uvs,
            indices: indices
                .into_iter()
                .map(|[a, b, c]| if flip { [a, c, b] } else { [a, b, c] })
                .collect(),
        }
    };
    Ok(match &g.0 {
        GeometryRaw::Mesh {
            positions,
            indices,
            normals,
            uvs,
        } => mesh(
            positions.clone(),
            indices.iter().map(|&(a, b, c)| [a, b, c]).collect(),
            normals.clone(),
            uvs.clone(),
        ),
        GeometryRaw::Obj { file, normals } => {
            let m = load_obj(&base.join(file), *normals, true)
                .map_err(|m| (format!("\"{file}\""), m))?;
            notes.extend(m.notes);
            mesh(m.positions, m.indices, m.normals, m.uvs)
        }
        GeometryRaw::Quad {
            corner,
            edge1,
            edge2,
        } => quad_mesh(*corner, edge1.as_dvec3(), edge2.as_dvec3(), &mesh),
        GeometryRaw::QuadCorners {
            corners: (p0, p1, _, p3),
        } => quad_mesh(*p0, *p1 - *p0, *p3 - *p0, &mesh),
        GeometryRaw::Cuboid { half_extents: h } => {
            let h = h.as_dvec3();
            let mut positions = Vec::with_capacity(24);
            let mut indices = Vec::with_capacity(12);
            let mut uvs = Vec::with_capacity(24);
            for a in 0..3 {
                let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                let axis = |i: usize| DVec3::AXES[i] * h[i];
                for s in [1.0f64, -1.0] {
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
                    uvs.extend(QUAD_UVS);
                }
            }
            mesh(positions, indices, None, Some(uvs))
        }
        GeometryRaw::Sphere { center, radius } => WorldGeometry::Sphere {
            center: xf.point(*center),
            radius: radius * t.scale.x.abs(),
            orientation: xf.rotation,
        },
    })
}

type MeshBuilder<'a> =
    &'a dyn Fn(Vec<DVec3>, Vec<[u32; 3]>, Option<Vec<Vec3>>, Option<Vec<Vec2>>) -> WorldGeometry;

/// (u, v) of a parallelogram's corners in boundary order from `corner`: u along the first edge.
const QUAD_UVS: [Vec2; 4] = [
    Vec2::new(0.0, 0.0),
    Vec2::new(1.0, 0.0),
    Vec2::new(1.0, 1.0),
    Vec2::new(0.0, 1.0),
];

fn quad_mesh(corner: DVec3, e1: DVec3, e2: DVec3, mesh: MeshBuilder) -> WorldGeometry {
    mesh(
        vec![corner, corner + e1, corner + e1 + e2, corner + e2],
        vec![[0, 1, 2], [0, 2, 3]],
        None,
        Some(QUAD_UVS.to_vec()),
    )
}

/// A mesh file's triangles, with the file's vertex normals and texture coordinates when every
/// vertex has them.
pub(crate) struct MeshFile {
    pub positions: Vec<DVec3>,
    pub indices: Vec<[u32; 3]>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    /// What was left out of the file, for the scene's warnings.
    pub notes: Vec<String>,
}

/// Reads every object of an OBJ file into one triangle mesh; `flip_v` turns the file's texture
/// coordinates (v up the image) into (u, 1 − v) (v down the image, Lightlab's and Mitsuba's).
pub(crate) fn load_obj(file: &Path, use_normals: bool, flip_v: bool) -> Result<MeshFile, String> {
    if file.is_dir() {
        return Err(format!(
            "{} is a directory, not a mesh file (name an .obj file in it)",
            file.display()
        ));
    }
    if !file.is_file() {
        return Err(format!("mesh file {} does not exist", file.display()));
    }
    check_obj_syntax(file)?;
    let (models, _materials) = tobj::load_obj(file, &tobj::GPU_LOAD_OPTIONS)
        .map_err(|e| format!("cannot read mesh file {}: {e}", file.display()))?;
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut all_have_normals = use_normals;
    let mut all_have_uvs = true;
    for m in &models {
        let base = positions.len() as u32;
        let mesh = &m.mesh;
        positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0], p[1], p[2])),
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
                    .map(|n| Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32)),
            );
        } else {
            all_have_normals = false;
        }
        if mesh.texcoords.len() / 2 == mesh.positions.len() / 3 {
            uvs.extend(mesh.texcoords.chunks_exact(2).map(|t| {
                let v = if flip_v { 1.0 - t[1] } else { t[1] };
                Vec2::new(t[0] as f32, v as f32)
            }));
        } else {
            all_have_uvs = false;
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
    let (normals, uvs, notes) = usable_attributes(
        file,
        all_have_normals.then_some(normals),
        all_have_uvs.then_some(uvs),
    );
    Ok(MeshFile {
        positions,
        indices,
        normals,
        uvs,
        notes,
    })
}

/// A mesh file's per-vertex normals and texture coordinates where every one is usable (normals
/// finite and non-zero, texture coordinates finite), with a note for each set left out, so that
/// the file's own shading is not dropped silently.
pub(crate) fn usable_attributes(
    file: &Path,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
) -> (Option<Vec<Vec3>>, Option<Vec<Vec2>>, Vec<String>) {
    let mut notes = Vec::new();
    let normals = normals.filter(|ns| {
        let bad = ns
            .iter()
            .filter(|n| !(n.is_finite() && n.length_squared() > 0.0))
            .count();
        if bad > 0 {
            notes.push(format!(
                "mesh file {}: {bad} vertex normals are zero or not finite, so the file's normals \
                 are not used (the triangles' own normals shade it)",
                file.display()
            ));
        }
        bad == 0
    });
    let uvs = uvs.filter(|uvs| {
        let bad = uvs.iter().filter(|uv| !uv.is_finite()).count();
        if bad > 0 {
            notes.push(format!(
                "mesh file {}: {bad} texture coordinates are not finite, so the file's texture \
                 coordinates are not used (textures see each triangle's barycentric coordinates)",
                file.display()
            ));
        }
        bad == 0
    });
    (normals, uvs, notes)
}

/// Reads an OBJ file's vertex and face lines the way the loader will, so that a malformed line is
/// reported with its line number (the OBJ loader's own errors have none).
fn check_obj_syntax(file: &Path) -> Result<(), String> {
    let text =
        crate::text::read_text(file).map_err(|e| format!("mesh file {}", e.located(file)))?;
    // What a face corner `v/vt/vn` refers to: vertices, texture coordinates, normals.
    const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let mut counts = [0usize; 3];
    // Per kind, the face line with the largest (positive) index, checked once the file is read
    // (OBJ allows faces before the data they refer to).
    let mut largest: [Option<(usize, usize, String)>; 3] = [None, None, None];
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let bad = |what: &str| {
            Err(format!(
                "mesh file {}:{}: {what}: {}",
                file.display(),
                n + 1,
                line.trim()
            ))
        };
        match words.next() {
            Some("v") => {
                let coords: Vec<&str> = words.collect();
                if coords.len() < 3 || coords.iter().take(3).any(|w| w.parse::<f64>().is_err()) {
                    return bad("a vertex needs three numbers");
                }
                if coords
                    .iter()
                    .take(3)
                    .any(|w| w.parse::<f64>().is_ok_and(|x| !x.is_finite()))
                {
                    return bad("a vertex must be finite");
                }
                counts[0] += 1;
            }
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            Some("f") => {
                let corners: Vec<&str> = words.collect();
                if corners.len() < 3 {
                    return bad("a face needs at least three vertices");
                }
                for c in corners {
                    for (kind, index) in c.split('/').take(3).enumerate() {
                        if kind > 0 && index.is_empty() {
                            continue;
                        }
                        match index.parse::<i64>() {
                            // Negative indices count back from the items read so far.
                            Ok(i) if i < 0 && (i.unsigned_abs() as usize) <= counts[kind] => {}
                            Ok(i) if i > 0 => {
                                if largest[kind].as_ref().is_none_or(|l| i as usize > l.0) {
                                    largest[kind] =
                                        Some((i as usize, n + 1, line.trim().to_string()));
                                }
                            }
                            Ok(_) => {
                                return bad(&format!(
                                    "a face refers to a {} that does not exist",
                                    KINDS[kind]
                                ));
                            }
                            // Digits beyond i64 name no item of any file.
                            Err(_)
                                if index
                                    .trim_start_matches('-')
                                    .bytes()
                                    .all(|b| b.is_ascii_digit()) =>
                            {
                                return bad(&format!(
                                    "a face refers to a {} that does not exist",
                                    KINDS[kind]
                                ));
                            }
                            Err(_) => {
                                return bad(&format!(
                                    "a face's {} index is not an integer",
                                    KINDS[kind]
                                ));
                            }
                        }
                    }
                }
            }
            _ => {}
        }
    }
    for (kind, largest) in largest.into_iter().enumerate() {
        if let Some((i, n, line)) = largest.filter(|l| l.0 > counts[kind]) {
            return Err(format!(
                "mesh file {}:{n}: a face refers to {} {i}, but the file has {}: {line}",
                file.display(),
                KINDS[kind],
                counts[kind]
            ));
        }
    }
    Ok(())
}
