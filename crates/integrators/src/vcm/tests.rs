//! VCM's recursive MIS weights against their definition and against BDPT's, through diffuse,
//! glossy and specular vertices.

use super::merge::merge_weight;
use super::mis::{Heuristic, Quantities, Technique, Techniques, reference_weight};
use super::*;
use crate::bdpt::tests::{
    as_light_origin, bdpt, camera_paths_to_lights, delta_light_scenes, flat_interface,
    production_paths, scene, split, strategies, weight_scenes,
};
use crate::bdpt::{Bdpt, Mis};

/// Every variant and heuristic, with η = π r² N small and large against the paths' densities and
/// one or three light paths per pixel, each with (η, ℓ) themselves (not as the heuristic sums
/// them).
fn all_techniques() -> Vec<(Techniques, (f64, f64))> {
    let mut out = Vec::new();
    for (connect, merge) in [(true, true), (true, false), (false, true)] {
        for heuristic in [Heuristic::Balance, Heuristic::Power] {
            for (eta, light_paths) in [(0.02, 1.0), (2.0, 1.0), (0.5, 3.0)] {
                let eta = if merge { eta } else { 0.0 };
                out.push((
                    Techniques {
                        connect,
                        merge,
                        heuristic,
                        eta: heuristic.of(eta),
                        light_tracing: heuristic.of(light_paths),
                    },
                    (eta, light_paths),
                ));
            }
        }
    }
    out
}

fn quantities(t: &Techniques, path: &[PathVertex], light: bool, scene: &Scene) -> Vec<Quantities> {
    let delta_light = light
        && path
            .first()
            .and_then(|v| v.light())
            .is_some_and(|l| scene.lights[l as usize].is_delta());
    let mut q = Vec::new();
    t.subpath(path, light, delta_light, &mut q);
    q
}

/// The Cornell box with its white walls a rough metal (glossy vertices).
fn glossy_cornell() -> Scene {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.ron"),
    )
    .unwrap()
    .replace(
        "\"white\": Diffuse(albedo: (0.725, 0.71, 0.68))",
        "\"white\": RoughConductor(roughness: Isotropic(0.2), eta: (0.2, 0.9, 1.1), k: (3.9, 2.4, 2.2))",
    );
    lightlab_scene::parse_scene(&text, std::path::Path::new("glossy-cornell.ron")).unwrap()
}

/// The recursive weights (two quantities per vertex, `mis`) equal the weights from their
/// definition (`mis::reference_weight`: every technique's density recomputed from the geometry)
/// for every connection and merge that can make camera paths ending on a light, and sum to one —
/// in the `bdpt::tests::weight_scenes` (diffuse, specular vertices and impossible techniques, an
/// environment) and a glossy Cornell box, for every variant, both heuristics and two merge radii. Tolerance:
/// 1e-3 relative (f32 densities).
#[test]
fn recursive_weights_equal_the_definition() {
    let mut scenes = weight_scenes();
    scenes.push(("glossy cornell box", glossy_cornell()));
    for (name, scene) in scenes {
        let mut merges = 0;
        for z in camera_paths_to_lights(&scene, 11) {
            let n = z.len();
            // The path light first, its emitter as a light vertex.
            let mut x: Vec<PathVertex> = z.iter().rev().copied().collect();
            as_light_origin(&mut x[0]);
            for (t, eta) in all_techniques() {
                let mut sum = 0.0f64;
                for s in 0..n {
                    let (light, camera) = split(&scene, &z, s);
                    let tc = n - s;
                    if s > 0 && (!t.connect || light[s - 1].delta || camera[tc - 1].delta) {
                        continue;
                    }
                    // No connection reaches the lens from a light at infinity.
                    if s > 0 && tc == 1 && light[s - 1].infinite {
                        continue;
                    }
                    let (lq, cq) = (
                        quantities(&t, &light, true, &scene),
                        quantities(&t, &camera, false, &scene),
                    );
                    let sampled = match (s, tc) {
                        (_, 1) => Some(camera[0]),
                        (1, _) => Some(light[0]),
                        _ => None,
                    };
                    let w = Vcm::connection_weight(
                        &scene,
                        &t,
                        (&light, &lq),
                        (&camera, &cq),
                        sampled,
                        s,
                        tc,
                    ) as f64;
                    let reference = reference_weight(&scene, &x, Technique::Connect(s), &t, eta);
                    assert!(
                        (w - reference).abs() <= 1e-3 * reference.max(1e-6),
                        "{name}, {t:?}: connection s = {s} of a path of {n} vertices: \
                         recursive {w}, reference {reference}"
                    );
                    sum += w;
                }
                for j in (1..n - 1).filter(|&j| t.merge && !x[j].delta) {
                    // The light subpath x₀ … x_j, the camera subpath x_k … x_j.
                    let light = split(&scene, &z, j + 1).0;
                    let camera = split(&scene, &z, j).1;
                    let tc = camera.len();
                    let (lq, cq) = (
                        quantities(&t, &light, true, &scene),
                        quantities(&t, &camera, false, &scene),
                    );
                    let light_prev = x[j].pdf(&scene, Some(&x[j + 1]), &x[j - 1]);
                    let camera_prev = x[j].pdf(&scene, Some(&x[j - 1]), &x[j + 1]);
                    let w = t.merge(lq[j], cq[tc - 1], light_prev, camera_prev) as f64;
                    let reference = reference_weight(&scene, &x, Technique::Merge(j), &t, eta);
                    assert!(
                        (w - reference).abs() <= 1e-3 * reference.max(1e-6),
                        "{name}, {t:?}: merge at x{j} of a path of {n} vertices: \
                         recursive {w}, reference {reference}"
                    );
                    sum += w;
                    merges += 1;
                }
                assert!(
                    (sum - 1.0).abs() < 1e-3,
                    "{name}, {t:?}: the weights of a path of {n} vertices sum to {sum}"
                );
            }
        }
        assert!(merges > 100, "{name}: only {merges} merges weighed");
    }
}

/// Σ over the techniques `t` has that can make the path `light` + `camera` (production subpaths
/// retracing one path) of their weights, from what the two walks stored: connections as the
/// renderer weights them, merges at every interior vertex with the camera vertex's BSDF.
fn production_sum(
    scene: &Scene,
    t: &Techniques,
    light: &[PathVertex],
    camera: &[PathVertex],
) -> f64 {
    let m = light.len();
    let (lq, cq) = (
        quantities(t, light, true, scene),
        quantities(t, camera, false, scene),
    );
    let connections: f64 = strategies(light, camera)
        .into_iter()
        .filter(|&s| s == 0 || t.connect)
        .map(|s| {
            let tc = m + 1 - s;
            let sampled = match (s, tc) {
                (_, 1) => Some(camera[0]),
                (1, _) => Some(light[0]),
                _ => None,
            };
            Vcm::connection_weight(scene, t, (light, &lq), (camera, &cq), sampled, s, tc) as f64
        })
        .sum();
    let merges: f64 = (1..m)
        .filter(|&j| t.merges_at(&light[j]))
        .map(|j| {
            let tc = m - j + 1;
            merge_weight(
                t,
                (&light[j], lq[j], &light[j - 1]),
                (&camera[tc - 1], cq[tc - 1], &camera[tc - 2]),
            ) as f64
        })
        .sum();
    connections + merges
}

/// With the densities the walks themselves store (delta vertices as `delta_densities` writes
/// them) the weights of all connections and merges sum to one — through a mirror, one flat
/// refractive interface, the glass sphere, glossy walls, for an emitter seen directly, and from
/// point, spot and directional lights — for
/// every variant, both heuristics and two radii; and without merges (`Vc`) every connection's
/// weight is BDPT's.
#[test]
fn production_weights_sum_to_one_and_vc_is_bdpt() {
    let with_delta = |p: &[PathVertex]| p.iter().any(|v| v.delta);
    let any = |p: &[PathVertex]| p.len() >= 2;
    let directly = |p: &[PathVertex]| p.len() == 1;
    let longer = |p: &[PathVertex]| p.len() >= 3;
    let mirror_sphere = {
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
    type Keep<'a> = &'a dyn Fn(&[PathVertex]) -> bool;
    let cases = [
        ("mirror sphere", mirror_sphere, &with_delta as Keep, 6u32),
        (
            "flat interface",
            flat_interface("Dielectric(ior: 1.5)"),
            &with_delta,
            6,
        ),
        ("glass sphere", scene("caustic-sphere.ron"), &with_delta, 6),
        ("glossy cornell box", glossy_cornell(), &any, 5),
        (
            "emitter seen directly",
            scene("cornell-box.ron"),
            &directly,
            1,
        ),
    ]
    .into_iter()
    .chain(
        // Lights no ray can hit: no s = 0, and a delta light's vertex weighs as `delta_light` says.
        delta_light_scenes()
            .into_iter()
            .map(|(name, scene)| (name, scene, &with_delta as Keep, 5))
            .chain(
                delta_light_scenes()
                    .into_iter()
                    .map(|(name, scene)| (name, scene, &longer as Keep, 5)),
            ),
    );
    for (name, scene, keep, vertices) in cases {
        let bdpt = bdpt(6);
        let paths = production_paths(&scene, &bdpt, vertices, keep, 40);
        assert!(paths.len() >= 20, "{name}: only {} paths", paths.len());
        for (light, camera) in &paths {
            for (t, _) in all_techniques() {
                let sum = production_sum(&scene, &t, light, camera);
                assert!(
                    (sum - 1.0).abs() < 2e-3,
                    "{name}, {t:?}: a path of {} light vertices has weights summing to {sum}",
                    light.len()
                );
                if t.merge || t.light_tracing != 1.0 {
                    continue;
                }
                let (lq, cq) = (
                    quantities(&t, light, true, &scene),
                    quantities(&t, camera, false, &scene),
                );
                let m = light.len();
                for s in strategies(light, camera) {
                    let tc = m + 1 - s;
                    let sampled = match (s, tc) {
                        (_, 1) => Some(camera[0]),
                        (1, _) => Some(light[0]),
                        _ => None,
                    };
                    let mis = match t.heuristic {
                        Heuristic::Balance => Mis::Balance,
                        Heuristic::Power => Mis::Power,
                    };
                    let vcm = Vcm::connection_weight(
                        &scene,
                        &t,
                        (light, &lq),
                        (camera, &cq),
                        sampled,
                        s,
                        tc,
                    );
                    let bdpt = Bdpt::mis_weight(&scene, light, camera, sampled, s, tc, mis);
                    assert!(
                        (vcm - bdpt).abs() <= 1e-4 * bdpt.max(1e-6),
                        "{name}, {mis:?}, (s, t) = ({s}, {tc}): VC {vcm}, BDPT {bdpt}"
                    );
                }
            }
        }
    }
}
