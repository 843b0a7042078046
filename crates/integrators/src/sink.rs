//! Where an estimator puts what one sample finds: [`Sink`] collects the sample's contributions to
//! its own pixel (by path class, through the integrator's [`Router`]), its splats into other
//! pixels (light-traced connections to the camera), and the part of each contribution that comes
//! from a photon group, so that the pass driver (`passes`) can turn them into pixel statistics.

use crate::paths::{PathClass, Router};
use crate::render::{Counters, Technique};
use glam::Vec2;
use lightlab_core::Rgb;

/// One splat: `value` added to slot `slot` of pixel `pixel` (row-major index).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Splat {
    pub pixel: u32,
    pub slot: u32,
    pub value: Rgb,
}

/// The contributions of one sample. Slot 0 is the full image, slot 1 + l layer l of the router,
/// and any further slots are the integrator's own (BDPT's strategy layers).
pub struct Sink<'r> {
    router: &'r Router,
    width: u32,
    height: u32,
    /// This sample's contributions to its own pixel, per slot.
    pub(crate) values: Vec<Rgb>,
    /// Splats of the work item so far (every sample of it).
    pub(crate) splats: Vec<Splat>,
    /// Photon groups (0: the estimator uses no photon map).
    groups: usize,
    /// This sample's photon contributions per slot and group, slot-major.
    pub(crate) group_values: Vec<Rgb>,
    /// Full-image statistics of this pixel before the current pass (for outlier tests).
    pub(crate) running: crate::PixelSums,
}

impl<'r> Sink<'r> {
    pub(crate) fn new(
        router: &'r Router,
        (width, height): (u32, u32),
        slots: usize,
        groups: usize,
    ) -> Sink<'r> {
        Sink {
            router,
            width,
            height,
            values: vec![Rgb::BLACK; slots],
            splats: Vec::new(),
            groups,
            group_values: vec![Rgb::BLACK; slots * groups],
            running: Default::default(),
        }
    }

    /// Forgets the current sample's own contributions (not the splats).
    pub(crate) fn clear(&mut self) {
        self.values.fill(Rgb::BLACK);
        self.group_values.fill(Rgb::BLACK);
    }

    /// The router that sends contributions to layers by path class.
    pub fn router(&self) -> &'r Router {
        self.router
    }

    /// The full image's running mean of this pixel before the current pass, and its sample count.
    pub fn running_mean(&self) -> ([f64; 3], u64) {
        (self.running.mean, self.running.count)
    }

    /// Adds `c`, made by a camera path whose scattering vertices are `eye` (camera first), where
    /// the router sends it; the class is only turned light first when the router needs it.
    #[inline]
    pub fn add_eye(&mut self, eye: &PathClass, c: Rgb) {
        if self.router.is_trivial() {
            self.values[0] += c;
        } else {
            self.add(&eye.reversed(), c);
        }
    }

    /// [`Sink::add_eye`] unless `c` is NaN or infinite, which is counted against `technique`
    /// instead (design.md).
    #[inline]
    pub(crate) fn add_eye_or_count(
        &mut self,
        eye: &PathClass,
        c: Rgb,
        technique: Technique,
        counters: &mut Counters,
    ) {
        if c.is_finite() {
            self.add_eye(eye, c);
        } else {
            counters.count_non_finite(technique);
        }
    }

    /// Adds `c`, made by a path of class `class` (light first), where the router sends it.
    #[inline]
    pub fn add(&mut self, class: &PathClass, c: Rgb) {
        if let Some(layer) = self.router.route(class) {
            self.add_routed(layer, c);
        }
    }

    /// Adds `c` to the full image and to layer `layer` (as [`Router::route`] returned it).
    #[inline]
    pub fn add_routed(&mut self, layer: usize, c: Rgb) {
        self.values[0] += c;
        if self.router.layer_count() > 0 {
            self.values[1 + layer] += c;
        }
    }

    /// Adds `c` to slot `slot` alone.
    #[inline]
    pub fn add_slot(&mut self, slot: usize, c: Rgb) {
        self.values[slot] += c;
    }

    /// Adds `c`, the contribution of a photon of group `group` to a path of class `class`: to the
    /// pixel, and to that group's share of it (when the render keeps groups).
    #[inline]
    pub fn add_photon(&mut self, group: usize, class: &PathClass, c: Rgb) {
        let Some(layer) = self.router.route(class) else {
            return;
        };
        self.add_routed(layer, c);
        let g = self.groups;
        if g == 0 {
            return;
        }
        self.group_values[group] += c;
        if self.router.layer_count() > 0 {
            self.group_values[(1 + layer) * g + group] += c;
        }
    }

    /// The pixel that raster position `raster` falls in (positions on the far edges are clamped).
    #[inline]
    pub fn pixel_at(&self, raster: Vec2) -> u32 {
        let (x, y) = (raster.x as u32, raster.y as u32);
        y.min(self.height - 1) * self.width + x.min(self.width - 1)
    }

    /// Adds `c` to slot `slot` of pixel `pixel` (a splat: another pixel than the sample's).
    #[inline]
    pub fn splat_slot(&mut self, pixel: u32, slot: usize, c: Rgb) {
        self.splats.push(Splat {
            pixel,
            slot: slot as u32,
            value: c,
        });
    }

    /// Splats `c` into the full image and layer `layer` of pixel `pixel`.
    #[inline]
    pub fn splat_routed(&mut self, pixel: u32, layer: usize, c: Rgb) {
        self.splat_slot(pixel, 0, c);
        if self.router.layer_count() > 0 {
            self.splat_slot(pixel, 1 + layer, c);
        }
    }
}
