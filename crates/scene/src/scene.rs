//! The immutable scene shared by all render threads.

use crate::{Camera, Light};
use glam::Vec3;
use lightlab_core::{Ray, Rgb};
use lightlab_geometry::{Accel, Hit, Shape};
use lightlab_materials::{Material, Texture};
use lightlab_samplers::Distribution1D;

pub struct Scene {
    pub camera: Camera,
    pub accel: Accel,
    /// Material id `i` (the `material` of a [`Hit`]): its BSDF and sidedness.
    pub materials: Vec<Material>,
    pub material_names: Vec<String>,
    /// The textures materials' [`TextureSlots`](lightlab_materials::TextureSlots) index.
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    /// Power-proportional light selection; `None` when nothing emits.
    light_selection: Option<Distribution1D>,
    /// Index of the environment light, looked up when a ray escapes (the scene's environment
    /// lights merged into one).
    environment: Option<u32>,
    /// Bounding sphere of the geometry.
    pub center: Vec3,
    pub radius: f32,
    /// Where render space's origin lies in the scene file's coordinates: every position the
    /// renderer sees is the file's minus this (computed in f64 when loading).
    pub origin: glam::DVec3,
    /// What loading noticed and the user should know (e.g. features too small for f32 to
    /// resolve); printed by the command line.
    pub warnings: Vec<String>,
    /// The files the scene was built from besides its own (meshes, texture images, environment
    /// map), for caches keyed by what produced a render.
    pub inputs: Vec<std::path::PathBuf>,
}

impl Scene {
    pub(crate) fn new(
        camera: Camera,
        accel: Accel,
        materials: Vec<Material>,
        material_names: Vec<String>,
        textures: Vec<Texture>,
        lights: Vec<Light>,
    ) -> Scene {
        let lights = merge_environments(lights);
        let (lo, hi) = accel.bounds();
        // Lights at infinity emit from a disk of this radius (area density 1/(πR²), kept a normal
        // float by the floor). With no geometry, or all of it at one point, there is nothing to
        // bound: a unit sphere about the eye keeps those densities and the lights' power finite (a
        // radius of 0 made them infinite and zero, and the photon methods' images NaN).
        let half = ((hi - lo) * 0.5).length();
        let (center, radius) =
            if lo.is_finite() && hi.is_finite() && lo.cmple(hi).all() && half > 0.0 {
                ((lo + hi) * 0.5, half.max(1e-18))
            } else {
                (camera.eye, 1.0)
            };
        let powers: Vec<f32> = lights
            .iter()
            .map(|l| l.power(accel.shapes(), radius).average())
            .collect();
        let light_selection = Distribution1D::new(&powers);
        let environment = lights
            .iter()
            .position(|l| matches!(l, Light::Environment { .. }))
            .map(|i| i as u32);
        Scene {
            camera,
            accel,
            materials,
            material_names,
            textures,
            lights,
            light_selection,
            environment,
            center,
            radius,
            origin: glam::DVec3::ZERO,
            warnings: Vec::new(),
            inputs: Vec::new(),
        }
    }

    #[inline]
    pub fn shapes(&self) -> &[Shape] {
        self.accel.shapes()
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.accel.intersect(ray)
    }

    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.accel.occluded(ray)
    }

    /// Whether any shape moves (`motion` in the scene file).
    #[inline]
    pub fn has_motion(&self) -> bool {
        self.accel.has_motion()
    }

    /// Whether the image integrates over time: shapes move and the shutter is open.
    #[inline]
    pub fn motion_blur(&self) -> bool {
        self.has_motion() && self.camera.shutter_open()
    }

    /// The scene frozen at instant `t`: every moving shape where it is then, nothing moving, the
    /// shutter closed at `t`. Methods that solve for a scene at rest (radiosity, cone tracing)
    /// integrate over the shutter by averaging such instants — the accumulation buffer (Haeberli
    /// & Akeley 1990).
    pub fn at_instant(&self, t: f32) -> Scene {
        let shapes = (0..self.shapes().len())
            .map(|i| {
                let s = &self.shapes()[i];
                match self.accel.motion(i as u32) {
                    Some(m) => s.moved(&m.at(t)),
                    None => s.clone(),
                }
            })
            .collect();
        let mut camera = self.camera.clone();
        camera.shutter = (t, t);
        let mut scene = Scene::new(
            camera,
            Accel::new(shapes),
            self.materials.clone(),
            self.material_names.clone(),
            self.textures.clone(),
            self.lights.clone(),
        );
        scene.origin = self.origin;
        scene.inputs = self.inputs.clone();
        scene
    }

    /// Chooses a light with probability proportional to its power: (index, probability).
    #[inline]
    pub fn sample_light(&self, u: f32) -> Option<(u32, f32)> {
        self.light_selection.as_ref().map(|d| {
            let (i, p) = d.sample_index(u);
            (i as u32, p)
        })
    }

    /// Probability that [`Scene::sample_light`] picks light `i`.
    #[inline]
    pub fn light_pmf(&self, i: u32) -> f32 {
        self.light_selection
            .as_ref()
            .map_or(0.0, |d| d.pmf(i as usize))
    }

    /// Radiance arriving from infinity along a ray of direction `d` (unit) that hits nothing.
    #[inline]
    pub fn environment_le(&self, d: Vec3) -> Rgb {
        match self.environment {
            Some(i) => self.lights[i as usize].environment_le(d),
            None => Rgb::BLACK,
        }
    }

    /// The environment light, if any, for MIS weights of escaped rays.
    #[inline]
    pub fn environment_light(&self) -> Option<u32> {
        self.environment
    }
}

/// Several environment lights are one: a ray that escapes sees their summed radiance, and a light
/// sample or photon from "the environment" must be drawn from that sum, so they are merged into a
/// single light (at the first one's place) whose radiance is the sum. With one light per escaped
/// direction, every estimator's MIS weights and emission densities stay those of a single emitter.
/// The loader has already folded constant environments into an environment map, if there is one
/// (there is at most one).
fn merge_environments(lights: Vec<Light>) -> Vec<Light> {
    let total = lights.iter().fold(None, |acc: Option<Rgb>, l| match l {
        Light::Environment { radiance, .. } => Some(acc.unwrap_or(Rgb::BLACK) + *radiance),
        _ => acc,
    });
    let mut merged = false;
    lights
        .into_iter()
        .filter_map(|l| match l {
            Light::Environment { .. } if merged => None,
            Light::Environment { map: Some(m), .. } => {
                merged = true;
                Some(Light::Environment {
                    radiance: total.unwrap_or(Rgb::BLACK),
                    map: Some(m),
                })
            }
            Light::Environment { map: None, .. } => {
                merged = true;
                total.map(|radiance| Light::Environment {
                    radiance,
                    map: None,
                })
            }
            other => Some(other),
        })
        .collect()
}
