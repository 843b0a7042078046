//! The MIS weights against their definition, through every kind of vertex.

use super::*;
use crate::walk::{Kind, unoccluded};
use glam::Vec2;
use lightlab_core::Rgb;
use lightlab_geometry::NO_LIGHT;

/// The scenes the weights are checked on: the Cornell box (diffuse, an area light), the caustic
/// sphere (specular vertices, impossible strategies) and spheres on a plane under a constant sky
/// (a light at infinity: seen directly, reached after bounces, and emitting light subpaths from a
/// disk).
pub(crate) fn weight_scenes() -> Vec<(&'static str, Scene)> {
    let sky = lightlab_scene::parse_scene(
        r#"Scene(camera: Camera(eye: (0, 1, 4), target: (0, 0.5, 0), fov: 50, resolution: (256, 256)),
            materials: { "white": Diffuse(albedo: (0.7, 0.7, 0.7)), "glass": Dielectric(ior: 1.5) },
            shapes: [
                Shape(geometry: Quad(corner: (-3, 0, -3), edge1: (0, 0, 6), edge2: (6, 0, 0)), material: "white"),
                Shape(geometry: Sphere(center: (-0.6, 0.5, 0), radius: 0.5), material: "white"),
                Shape(geometry: Sphere(center: (0.6, 0.5, 0), radius: 0.5), material: "glass"),
            ],
            lights: [ Environment(radiance: (1, 1, 1)) ])"#,
        std::path::Path::new("sky.ron"),
    )
    .unwrap();
    vec![
        ("cornell-box.ron", scene("cornell-box.ron")),
        ("caustic-sphere.ron", scene("caustic-sphere.ron")),
        ("sky", sky),
    ]
}

pub(crate) fn scene(name: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    lightlab_scene::load_scene(&path).unwrap()
}

/// The emitter a camera path ended on, as a light subpath's origin: an emitting surface becomes a
/// light vertex; an environment reached by escaping already is one.
pub(crate) fn as_light_origin(v: &mut PathVertex) {
    if v.kind == Kind::Surface {
        v.kind = Kind::Light { light: v.emitter };
        v.sb = None;
        v.delta = false;
    }
}

/// The vertices of a full path x₀ (on a light) … x_{n−1} (the camera) split as s light and
/// t = n − s camera vertices, with every density recomputed from the geometry, as both subpath
/// generators would have stored them.
pub(crate) fn split(
    scene: &Scene,
    z: &[PathVertex],
    s: usize,
) -> (Vec<PathVertex>, Vec<PathVertex>) {
    let n = z.len();
    let t = n - s;
    let mut camera: Vec<PathVertex> = z[..t].to_vec();
    let mut light: Vec<PathVertex> = z[t..].iter().rev().copied().collect();
    if let Some(y0) = light.first_mut() {
        as_light_origin(y0);
    }
    for i in 1..camera.len() {
        let prev = if i >= 2 { Some(camera[i - 2]) } else { None };
        camera[i].pdf_fwd = camera[i - 1].pdf(scene, prev.as_ref(), &camera[i]);
    }
    if !light.is_empty() {
        light[0].pdf_fwd = light[0].pdf_light_origin(scene);
    }
    for i in 1..light.len() {
        let prev = if i >= 2 { Some(light[i - 2]) } else { None };
        light[i].pdf_fwd = light[i - 1].pdf(scene, prev.as_ref(), &light[i]);
    }
    // Reverse densities of the interior vertices (the last two of each side are set by
    // `mis_weight` itself).
    for i in 0..camera.len().saturating_sub(2) {
        let next2 = camera[i + 2];
        camera[i].pdf_rev = camera[i + 1].pdf(scene, Some(&next2), &camera[i]);
    }
    for i in 0..light.len().saturating_sub(2) {
        let next2 = light[i + 2];
        light[i].pdf_rev = light[i + 1].pdf(scene, Some(&next2), &light[i]);
    }
    (light, camera)
}

/// Up to 300 camera paths, traced with `seed`, that end on an emitter they receive light from
/// (at least 50 of them): a camera vertex, 0–7 scattering vertices and the emitter (a surface, or
/// the environment a ray escaped to).
pub(crate) fn camera_paths_to_lights(scene: &Scene, seed: u64) -> Vec<Vec<PathVertex>> {
    let bdpt = bdpt(6);
    let mut counters = Counters::default();
    let mut out = Vec::new();
    let mut direct = 0;
    for pixel in 0..200_000u64 {
        let mut sampler = Independent::new();
        sampler.start_pixel_sample(seed, pixel, 0);
        let film = Vec2::new(
            (pixel % 256) as f32 + 0.5,
            ((pixel / 256) % 256) as f32 + 0.5,
        );
        let mut z = Vec::new();
        bdpt.camera_subpath(scene, film, 0.0, &mut sampler, 8, &mut z, &mut counters);
        let Some(last) = z.last() else { continue };
        // Emitters seen directly (a camera vertex and the emitter) at most 30 times, so longer
        // paths fill the rest.
        if z.len() == 2 {
            if direct == 30 {
                continue;
            }
            direct += 1;
        }
        if last.light().is_some() && !last.le(scene, &z[z.len() - 2]).is_black() {
            out.push(z);
            if out.len() == 300 {
                break;
            }
        }
    }
    assert!(
        out.len() >= 50,
        "only {} paths reached the light",
        out.len()
    );
    out
}

/// The strategies (s, t) that can make camera path `z` (camera first, ending on a light), each
/// with its fast MIS weight from the subpaths `split` builds for it.
fn fast_weights(scene: &Scene, z: &[PathVertex], heuristic: Mis) -> Vec<(usize, usize, f32)> {
    let n = z.len();
    (0..n)
        .filter_map(|s| {
            let t = n - s;
            let (light, camera) = split(scene, z, s);
            if s > 0 && (light[s - 1].delta || camera[t - 1].delta) {
                return None;
            }
            // No connection reaches the lens from a light at infinity (`connection`).
            if s > 0 && t == 1 && light[s - 1].infinite {
                return None;
            }
            let sampled = match (s, t) {
                (_, 1) => Some(camera[0]),
                (1, _) => Some(light[0]),
                _ => None,
            };
            let w = Bdpt::mis_weight(scene, &light, &camera, sampled, s, t, heuristic);
            Some((s, t, w))
        })
        .collect()
}

/// Veach's condition for unbiased MIS: the weights of all strategies that can produce a path sum
/// to one, for the balance and power heuristics and uniform weights. Checked on camera paths that
/// end on a light, in the [`weight_scenes`].
#[test]
fn weights_of_all_strategies_sum_to_one() {
    for (name, scene) in weight_scenes() {
        for z in camera_paths_to_lights(&scene, 7) {
            for heuristic in [Mis::Balance, Mis::Power, Mis::Uniform] {
                let sum: f64 = fast_weights(&scene, &z, heuristic)
                    .iter()
                    .map(|&(_, _, w)| w as f64)
                    .sum();
                assert!(
                    (sum - 1.0).abs() < 1e-3,
                    "{name}, {heuristic:?}: a path of {} vertices has weights summing to {sum}",
                    z.len()
                );
            }
        }
    }
}

/// The fast weights (Veach's walk over density ratios) equal the weights from their definition
/// (`mis::reference_weight`: every strategy's path density recomputed from the geometry), for
/// every strategy of camera paths that end on a light, in the [`weight_scenes`], for the
/// balance and power heuristics and uniform weights. Tolerance: 1e-3 relative (f32 densities).
#[test]
fn fast_weights_equal_the_reference_definition() {
    for (name, scene) in weight_scenes() {
        let mut with_delta = 0;
        let mut escaped = 0;
        for z in camera_paths_to_lights(&scene, 11) {
            // The path light first, its emitter as a light vertex.
            let mut x: Vec<PathVertex> = z.iter().rev().copied().collect();
            as_light_origin(&mut x[0]);
            escaped += x[0].infinite as u32;
            with_delta += x.iter().any(|v| v.delta) as u32;
            for heuristic in [Mis::Balance, Mis::Power, Mis::Uniform] {
                for (s, t, fast) in fast_weights(&scene, &z, heuristic) {
                    let reference = mis::reference_weight(&scene, &x, s, heuristic);
                    assert!(
                        (fast as f64 - reference).abs() <= 1e-3 * reference.max(1e-6),
                        "{name}, {heuristic:?}, (s, t) = ({s}, {t}) of a path of {} vertices: \
                         fast {fast}, reference {reference}",
                        z.len()
                    );
                }
            }
        }
        if name != "cornell-box.ron" {
            assert!(
                with_delta >= 10,
                "{name}: only {with_delta} paths through the glass"
            );
        }
        if name == "sky" {
            assert!(
                escaped >= 250,
                "{name}: only {escaped} paths reached the sky"
            );
        }
    }
}

/// A sampler that replays `values` in order (then ½): drives a production walk along a path
/// chosen in advance.
struct Script {
    values: Vec<f32>,
    next: usize,
}

impl Sampler for Script {
    fn start_pixel_sample(&mut self, _: u64, _: u64, _: u64) {}
    fn next_1d(&mut self) -> f32 {
        self.next += 1;
        self.values.get(self.next - 1).copied().unwrap_or(0.5)
    }
    fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_1d(), self.next_1d())
    }
}

pub(crate) fn bdpt(max_bounces: u32) -> Bdpt {
    Bdpt::new(BdptConfig {
        max_bounces: Some(max_bounces),
        russian_roulette: None,
        ..BdptConfig::default()
    })
    .unwrap()
}

/// The camera subpath that `camera_subpath` traces back through the vertices of the light
/// subpath `light` (x₀ on the light … x_{n−1}) when its samples are chosen to: the camera ray
/// through x_{n−1}'s raster position, at every diffuse vertex the inverse of the cosine warp
/// toward the next vertex, at every delta vertex the lobe the light path took. `None` unless
/// the walk retraces every vertex — but x₀ on a light no ray can hit (point, spot,
/// directional), where the camera subpath stops at x₁ (n vertices, no s = 0 strategy).
pub(crate) fn camera_through(
    bdpt: &Bdpt,
    scene: &Scene,
    light: &[PathVertex],
) -> Option<Vec<PathVertex>> {
    use lightlab_samplers::warp::cosine_hemisphere_to_square;
    let n = light.len();
    let raster = scene
        .camera
        .sample_wi(light[n - 1].p, Vec2::splat(0.5))?
        .raster;
    let mut values = vec![0.5, 0.5];
    for j in (1..n).rev() {
        let (here, next) = (&light[j], &light[j - 1]);
        let sb = here.sb?;
        let wi = (next.p - here.p).normalize();
        let (u_lobe, u_dir) = if here.delta {
            let prev = if j + 1 < n {
                light[j + 1].p
            } else {
                scene.camera.eye
            };
            let through = (prev - here.p).dot(here.ng) * (next.p - here.p).dot(here.ng) < 0.0;
            (if through { 1.0 - 1e-6 } else { 0.0 }, Vec2::splat(0.5))
        } else {
            let mut local = sb.frame.to_local(wi);
            local.z = local.z.abs();
            (0.5, cosine_hemisphere_to_square(local))
        };
        values.extend([u_lobe, u_dir.x, u_dir.y, 0.5]);
    }
    let mut sampler = Script { values, next: 0 };
    let mut camera = Vec::new();
    let film = raster;
    bdpt.camera_subpath(
        scene,
        film,
        0.0,
        &mut sampler,
        n as u32 + 1,
        &mut camera,
        &mut Counters::default(),
    );
    let hittable = light[0]
        .light()
        .is_some_and(|l| !scene.lights[l as usize].is_delta());
    let retraced = if hittable {
        camera.len() == n + 1
            && (1..=n).all(|j| camera[j].p.distance(light[n - j].p) < 1e-3)
            && camera[n].emitter != NO_LIGHT
    } else {
        camera.len() >= n && (1..n).all(|j| camera[j].p.distance(light[n - j].p) < 1e-3)
    };
    camera.truncate(if hittable { n + 1 } else { n });
    retraced.then_some(camera)
}

/// The strategies (s, t = m + 1 − s) that can make the path of the `m` light vertices and the
/// camera subpath retracing them (`camera_through`): s = 0 where the camera subpath reaches
/// the light, every connection that joins two non-delta vertices.
pub(crate) fn strategies(light: &[PathVertex], camera: &[PathVertex]) -> Vec<usize> {
    let m = light.len();
    (0..=m)
        .filter(|&s| {
            if s == 0 {
                camera.len() == m + 1
            } else {
                !(light[s - 1].delta || camera[m - s].delta)
            }
        })
        .collect()
}

/// Σ over the strategies that can make the path `light` + camera of their MIS weights, from
/// the densities the two production walks stored.
fn weight_sum(scene: &Scene, light: &[PathVertex], camera: &[PathVertex], heuristic: Mis) -> f64 {
    let m = light.len();
    strategies(light, camera)
        .into_iter()
        .map(|s| {
            let t = m + 1 - s;
            let sampled = match (s, t) {
                (_, 1) => Some(camera[0]),
                (1, _) => Some(light[0]),
                _ => None,
            };
            Bdpt::mis_weight(scene, light, camera, sampled, s, t, heuristic) as f64
        })
        .sum()
}

/// Light subpaths of `scene` traced by production code (seeds 0, 1, …) whose last vertex the
/// camera sees and which `keep` accepts, each with the camera subpath retracing it.
pub(crate) fn production_paths(
    scene: &Scene,
    bdpt: &Bdpt,
    vertices: u32,
    keep: impl Fn(&[PathVertex]) -> bool,
    want: usize,
) -> Vec<(Vec<PathVertex>, Vec<PathVertex>)> {
    let mut out = Vec::new();
    for seed in 0..400_000u64 {
        let mut sampler = Independent::new();
        sampler.start_pixel_sample(seed, 0, 0);
        let mut light = Vec::new();
        bdpt.light_subpath(
            scene,
            0.0,
            &mut sampler,
            vertices,
            &mut light,
            &mut Counters::default(),
        );
        let Some(last) = light.last() else { continue };
        if last.delta || !keep(&light) {
            continue;
        }
        let visible = scene
            .camera
            .sample_wi(last.p, Vec2::splat(0.5))
            .is_some_and(|cs| {
                unoccluded(
                    scene,
                    last,
                    &PathVertex::new(Kind::Camera, cs.p_lens, 0.0, Rgb::WHITE),
                )
            });
        if !visible {
            continue;
        }
        if let Some(camera) = camera_through(bdpt, scene, &light) {
            out.push((light, camera));
            if out.len() == want {
                break;
            }
        }
    }
    out
}

/// Spheres on a plane (one diffuse, one glass) in front of a diffuse wall, lit by a light no
/// ray can hit: a point light, a spot light with a soft edge, or a directional light.
pub(crate) fn delta_light_scenes() -> Vec<(&'static str, Scene)> {
    [
        ("point light", "Point(position: (0.5, 2.5, 1.5), intensity: (10, 10, 10))"),
        (
            "spot light",
            "Spot(position: (1, 3, 1.5), target: (0, 0.3, 0), intensity: (20, 20, 20), \
             cone_angle: 40, falloff_start: 25)",
        ),
        (
            "directional light",
            "Directional(direction: (-0.3, -1, -0.4), irradiance: (3, 3, 3))",
        ),
    ]
    .into_iter()
    .map(|(name, light)| {
        let text = format!(
            r#"Scene(camera: Camera(eye: (0, 1, 4), target: (0, 0.5, 0), fov: 50, resolution: (256, 256)),
                materials: {{ "white": Diffuse(albedo: (0.7, 0.7, 0.7)), "glass": Dielectric(ior: 1.5) }},
                shapes: [
                    Shape(geometry: Quad(corner: (-3, 0, -3), edge1: (0, 0, 6), edge2: (6, 0, 0)), material: "white"),
                    Shape(geometry: Quad(corner: (-3, 0, -1.5), edge1: (6, 0, 0), edge2: (0, 3, 0)), material: "white"),
                    Shape(geometry: Sphere(center: (-0.6, 0.5, 0), radius: 0.5), material: "white"),
                    Shape(geometry: Sphere(center: (0.6, 0.5, 0), radius: 0.5), material: "glass"),
                ],
                lights: [ {light} ])"#
        );
        let scene = lightlab_scene::parse_scene(&text, std::path::Path::new(name)).unwrap();
        (name, scene)
    })
    .collect()
}

/// One refractive interface: a light under a diffuse ceiling above a flat glass surface
/// (η = 1.5 below it), a diffuse floor in the glass and the camera in the glass too — the
/// path `L D S D E` crosses the interface once.
pub(crate) fn flat_interface(material: &str) -> Scene {
    let text = format!(
        "Scene(camera: Camera(eye: (0, -0.4, 1.6), target: (0, -1, 0), fov: 50, resolution: (32, 32)),
           materials: {{ \"white\": Diffuse(albedo: (0.8, 0.8, 0.8)), \"black\": Diffuse(albedo: (0, 0, 0)),
                         \"interface\": {material} }},
           shapes: [
             Shape(geometry: Quad(corner: (-10, 0, -10), edge1: (0, 0, 20), edge2: (20, 0, 0)), material: \"interface\"),
             Shape(geometry: Quad(corner: (-3, -1, -3), edge1: (0, 0, 6), edge2: (6, 0, 0)), material: \"white\"),
             Shape(geometry: Quad(corner: (-3, 1, -3), edge1: (6, 0, 0), edge2: (0, 0, 6)), material: \"white\"),
             Shape(geometry: Quad(corner: (-0.3, 0.5, -0.3), edge1: (0, 0, 0.6), edge2: (0.6, 0, 0)), material: \"black\",
                   emission: (radiance: (5, 5, 5))),
           ])"
    );
    lightlab_scene::parse_scene(&text, std::path::Path::new("flat-interface.ron")).unwrap()
}

/// The weights of all strategies sum to one with the densities the walks themselves store —
/// through a mirror, one flat refractive interface, the glass sphere (two interfaces), for
/// an emitter seen directly, and from point, spot and directional lights —
/// for the balance and power heuristics and uniform weights. (It fails when the two walks
/// disagree on a delta vertex's ratio of densities.) On paths without specular vertices each
/// weight is also its definition (`mis::reference_weight`), which covers the delta lights'
/// own densities (their origins and first segments).
#[test]
fn production_weights_sum_to_one_through_specular_vertices() {
    let with_delta = |p: &[PathVertex]| p.iter().any(|v| v.delta);
    let mirror_floor = {
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../scenes/caustic-sphere.ron"),
        )
        .unwrap()
        .replace(
            "\"glass\": Dielectric(ior: 1.5)",
            "\"glass\": Mirror(reflectance: (0.9, 0.9, 0.9))",
        );
        lightlab_scene::parse_scene(&text, std::path::Path::new("mirror-sphere.ron")).unwrap()
    };
    let directly = |p: &[PathVertex]| p.len() == 1;
    let longer = |p: &[PathVertex]| p.len() >= 3;
    for (name, scene, keep, vertices) in
        [
            (
                "mirror sphere",
                mirror_floor,
                &with_delta as &dyn Fn(&[PathVertex]) -> bool,
                6,
            ),
            (
                "flat interface",
                flat_interface("Dielectric(ior: 1.5)"),
                &with_delta,
                6,
            ),
            (
                "glass sphere",
                super::tests::scene("caustic-sphere.ron"),
                &with_delta,
                6,
            ),
            // An emitter seen directly: s = 0 (the camera ray hits it) and s = t = 1.
            (
                "emitter seen directly",
                super::tests::scene("cornell-box.ron"),
                &directly,
                1,
            ),
        ]
        .into_iter()
        .chain(
            // Lights no ray can hit (no s = 0): paths through the glass, and paths of two or more
            // scattering vertices.
            delta_light_scenes()
                .into_iter()
                .map(|(name, scene)| {
                    (
                        name,
                        scene,
                        &with_delta as &dyn Fn(&[PathVertex]) -> bool,
                        5,
                    )
                })
                .chain(delta_light_scenes().into_iter().map(|(name, scene)| {
                    (name, scene, &longer as &dyn Fn(&[PathVertex]) -> bool, 5)
                })),
        )
    {
        let bdpt = bdpt(6);
        let paths = production_paths(&scene, &bdpt, vertices, keep, 40);
        assert!(paths.len() >= 20, "{name}: only {} paths", paths.len());
        for (light, camera) in &paths {
            // The path light first: the light subpath and the lens. Its weights by definition
            // where no vertex is specular (`reference_weight` takes a density through a delta
            // vertex as 1; the walks store the true ones, see the finite-difference test below).
            let x: Vec<PathVertex> = light.iter().chain(&camera[..1]).copied().collect();
            let diffuse = !x.iter().any(|v| v.delta);
            for heuristic in [Mis::Balance, Mis::Power, Mis::Uniform] {
                let sum = weight_sum(&scene, light, camera, heuristic);
                assert!(
                    (sum - 1.0).abs() < 2e-3,
                    "{name}, {heuristic:?}: a path of {} light vertices has weights summing to {sum}",
                    light.len()
                );
                for s in strategies(light, camera).into_iter().filter(|_| diffuse) {
                    let (t, m) = (light.len() + 1 - s, light.len());
                    let sampled = match (s, t) {
                        (_, 1) => Some(camera[0]),
                        (1, _) => Some(light[0]),
                        _ => None,
                    };
                    let fast = Bdpt::mis_weight(&scene, light, camera, sampled, s, t, heuristic);
                    let reference = mis::reference_weight(&scene, &x, s, heuristic);
                    assert!(
                        (fast as f64 - reference).abs() <= 2e-3 * reference.max(1e-6),
                        "{name}, {heuristic:?}, (s, t) = ({s}, {t}) of {m} light vertices: \
                         production {fast}, definition {reference}"
                    );
                }
            }
        }
    }
}

/// On `L D S D E` through one flat interface the balance weights are the true ones: the ratio
/// of the light-tracing strategy (s = 4) to next-event estimation (s = 1) equals the ratio of
/// their path densities computed independently, with the solid-angle Jacobians through the
/// refraction taken by finite differences in f64 (Snell's law, the landing point's area per
/// steradian). Keeping the lobe probability alone at the delta vertex was off by the
/// compression (η_i/η_t)² cos θ_i / cos θ_t — a factor 0.3–0.5 here.
#[test]
fn weights_through_one_refraction_match_finite_difference_densities() {
    use glam::DVec3;
    let scene = flat_interface("Dielectric(ior: 1.5)");
    let eta = 1.5f64;
    let bdpt = bdpt(3);
    let shape = |p: &[PathVertex]| {
        p.len() == 4 && !p[1].delta && p[2].delta && p[1].p.y > 0.9 && p[3].p.y < -0.9
    };
    let paths = production_paths(&scene, &bdpt, 4, shape, 10);
    assert!(paths.len() >= 5, "only {} L D S D paths", paths.len());
    // Refracts d at the plane y = 0 and returns where it lands on the plane y = `to`.
    let land = |origin: DVec3, d: DVec3, to: f64| -> DVec3 {
        let at = origin + d * (-origin.y / d.y);
        let (eta_i, eta_t) = if d.y < 0.0 { (1.0, eta) } else { (eta, 1.0) };
        let n = DVec3::new(0.0, -d.y.signum(), 0.0);
        let cos_i = -d.dot(n);
        let r = eta_i / eta_t;
        let t = d * r + n * (r * cos_i - (1.0 - r * r * (1.0 - cos_i * cos_i)).sqrt());
        at + t * ((to - at.y) / t.y)
    };
    // Steradians per unit area of the landing point on the plane y = `to`, for directions
    // around d from `origin`.
    let jacobian = |origin: DVec3, d: DVec3, to: f64| -> f64 {
        let (t1, t2) = {
            let a = if d.x.abs() < 0.9 { DVec3::X } else { DVec3::Z };
            let t1 = d.cross(a).normalize();
            (t1, d.cross(t1))
        };
        let h = 1e-6;
        let at = |a: f64, b: f64| land(origin, (d + t1 * a + t2 * b).normalize(), to);
        let da = (at(h, 0.0) - at(-h, 0.0)) / (2.0 * h);
        let db = (at(0.0, h) - at(0.0, -h)) / (2.0 * h);
        1.0 / da.cross(db).length()
    };
    for (light, camera) in &paths {
        let x: Vec<DVec3> = light.iter().map(|v| v.p.as_dvec3()).collect();
        let eye = scene.camera.eye.as_dvec3();
        let cos_up = |a: DVec3, b: DVec3| (b - a).normalize().y.abs();
        // s = 4: the light emits x₀ → x₁ (cosine), x₁ scatters toward x₂ (cosine), which
        // refracts to x₃; the camera vertex is the pinhole for every strategy.
        let d01 = x[1] - x[0];
        let p_41 = cos_up(x[0], x[1]) / std::f64::consts::PI * cos_up(x[0], x[1])
            / d01.length_squared()
            * cos_up(x[1], x[2])
            / std::f64::consts::PI
            * jacobian(x[1], (x[2] - x[1]).normalize(), -1.0);
        // s = 1: the camera samples x₃ (its directional density times cos/d²), x₃ scatters
        // toward x₂ (cosine), which refracts to x₁; the light point x₀ is sampled alike.
        let d3 = x[3] - eye;
        let p_cam = scene
            .camera
            .pdf_we_dir(scene.camera.eye, d3.normalize().as_vec3()) as f64
            * cos_up(eye, x[3])
            / d3.length_squared();
        let p_14 = p_cam * cos_up(x[3], x[2]) / std::f64::consts::PI
            * jacobian(x[3], (x[2] - x[3]).normalize(), 1.0);
        let w = |s: usize| {
            let t = 5 - s;
            let sampled = match (s, t) {
                (_, 1) => Some(camera[0]),
                (1, _) => Some(light[0]),
                _ => None,
            };
            Bdpt::mis_weight(&scene, light, camera, sampled, s, t, Mis::Balance) as f64
        };
        let (production, exact) = (w(4) / w(1), p_41 / p_14);
        assert!(
            (production / exact - 1.0).abs() < 2e-3,
            "w(4,1)/w(1,4) = {production:.5}, the densities' ratio {exact:.5}"
        );
    }
}
