//! The immutable scene shared by all render threads.

use crate::{Camera, Light};
use glam::Vec3;
use lightlab_core::{Ray, Rgb};
use lightlab_geometry::{Accel, Hit, Shape};
use lightlab_materials::Bsdf;
use lightlab_samplers::Distribution1D;

pub struct Scene {
    pub camera: Camera,
    pub accel: Accel,
    /// BSDF of material id `i` (the `material` of a [`Hit`]).
    pub materials: Vec<Bsdf>,
    pub material_names: Vec<String>,
    pub lights: Vec<Light>,
    /// Power-proportional light selection; `None` when nothing emits.
    light_selection: Option<Distribution1D>,
    /// Indices of the environment lights, looked up when a ray escapes.
    environment: Vec<u32>,
    /// Bounding sphere of the geometry.
    pub center: Vec3,
    pub radius: f32,
}

impl Scene {
    pub(crate) fn new(
        camera: Camera,
        accel: Accel,
        materials: Vec<Bsdf>,
        material_names: Vec<String>,
        lights: Vec<Light>,
    ) -> Scene {
        let (lo, hi) = accel.bounds();
        let (center, radius) = if lo.is_finite() && hi.is_finite() && lo.cmple(hi).all() {
            (
                (lo + hi) * 0.5,
                ((hi - lo) * 0.5).length().max(f32::MIN_POSITIVE),
            )
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
            .enumerate()
            .filter(|(_, l)| matches!(l, Light::Environment { .. }))
            .map(|(i, _)| i as u32)
            .collect();
        Scene {
            camera,
            accel,
            materials,
            material_names,
            lights,
            light_selection,
            environment,
            center,
            radius,
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

    /// Chooses a light with probability proportional to its power: (index, probability).
    #[inline]
    pub fn sample_light(&self, u: f32) -> Option<(u32, f32)> {
        self.light_selection.as_ref().map(|d| {
            let (i, p, _) = d.sample(u);
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

    /// Radiance arriving from infinity along a ray that hits nothing (environments are constant).
    #[inline]
    pub fn environment_le(&self) -> Rgb {
        self.environment
            .iter()
            .fold(Rgb::BLACK, |acc, &i| match self.lights[i as usize] {
                Light::Environment { radiance } => acc + radiance,
                _ => acc,
            })
    }

    /// Environment lights, for MIS weights of escaped rays.
    #[inline]
    pub fn environment_lights(&self) -> &[u32] {
        &self.environment
    }
}
