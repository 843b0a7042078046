//! Pinhole and thin-lens cameras (pbrt-v4 §5.2). Raster coordinates: x right, y down, pixel (i, j)
//! covers [i, i+1) × [j, j+1). `fov` is the full angle along the smaller image axis.

use crate::desc::{CameraDesc, Lens};
use glam::{Vec2, Vec3};
use lightlab_core::Ray;
use lightlab_samplers::Sampler;
use lightlab_samplers::warp::square_to_concentric_disk;

/// A connection from a scene point to the camera (see [`Camera::sample_wi`]).
#[derive(Clone, Copy, Debug)]
pub struct CameraSample {
    /// Point on the lens (the eye for a pinhole).
    pub p_lens: Vec3,
    /// Unit direction from the scene point toward `p_lens`.
    pub wi: Vec3,
    /// Importance of the ray from `p_lens` toward the scene point.
    pub we: f32,
    /// Density of `wi` in solid angle at the scene point.
    pub pdf_w: f32,
    /// Raster position (pixels) the connection contributes to.
    pub raster: Vec2,
}

#[derive(Clone, Debug)]
pub struct Camera {
    pub eye: Vec3,
    /// Unit view direction, and the right and up axes of the image plane (orthonormal).
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub width: u32,
    pub height: u32,
    /// Half-extent of the image plane at distance 1 along x and y.
    pub half_size: Vec2,
    pub lens: Lens,
    /// Shutter open and close times (equal: an instant).
    pub shutter: (f32, f32),
}

impl Camera {
    /// The camera of `d` in render space: positions moved by −`origin` (see `load`).
    pub fn new(d: &CameraDesc, origin: glam::DVec3) -> Camera {
        let forward = crate::desc::unit(d.target - d.eye).as_vec3();
        // `up` normalised in f64 first: its f32 squared length may under- or overflow.
        let right = forward
            .cross(d.up.as_dvec3().normalize().as_vec3())
            .normalize();
        let up = right.cross(forward);
        // A mirrored image: pixels to the right look to the left.
        let right = if d.mirrored { -right } else { right };
        let (w, h) = d.resolution;
        let t = (d.fov.to_radians() * 0.5).tan();
        let half_size = if w >= h {
            Vec2::new(t * w as f32 / h as f32, t)
        } else {
            Vec2::new(t, t * h as f32 / w as f32)
        };
        Camera {
            eye: (d.eye - origin).as_vec3(),
            forward,
            right,
            up,
            width: w,
            height: h,
            half_size,
            lens: d.lens,
            shutter: d.shutter,
        }
    }

    /// The same camera with another image size; the field of view along the smaller axis is kept.
    pub fn with_resolution(&self, width: u32, height: u32) -> Camera {
        let t = self.half_size.min_element();
        let half_size = if width >= height {
            Vec2::new(t * width as f32 / height as f32, t)
        } else {
            Vec2::new(t, t * height as f32 / width as f32)
        };
        Camera {
            width,
            height,
            half_size,
            ..self.clone()
        }
    }

    /// Whether the shutter stays open over an interval (motion blur), not an instant.
    #[inline]
    pub fn shutter_open(&self) -> bool {
        self.shutter.1 > self.shutter.0
    }

    /// The time of one sample: uniform over the shutter from one dimension of `sampler`, drawn
    /// only when the shutter is open (an instant costs no dimension, so images of scenes without
    /// motion blur keep their bits).
    #[inline]
    pub fn sample_time<S: Sampler>(&self, sampler: &mut S) -> f32 {
        let (open, close) = self.shutter;
        if close > open {
            open + (close - open) * sampler.next_1d()
        } else {
            open
        }
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The ray through raster position `film` (in pixels), using `u_lens` on the lens for a thin lens.
    /// The direction is unit length.
    #[inline]
    pub fn generate_ray(&self, film: Vec2, u_lens: Vec2) -> Ray {
        let ndc = Vec2::new(
            2.0 * film.x / self.width as f32 - 1.0,
            1.0 - 2.0 * film.y / self.height as f32,
        );
        let c = ndc * self.half_size;
        let dir = self.right * c.x + self.up * c.y + self.forward;
        match self.lens {
            Lens::Pinhole => Ray::new(self.eye, dir.normalize()),
            Lens::ThinLens {
                aperture_radius,
                focus_distance,
            } => {
                // All lens rays meet where the pinhole ray reaches the plane of focus, at
                // eye + F·dir: from the lens point eye + l that is F·(dir − l/F), normalised
                // without forming F·dir, whose square overflowed f32 beyond F ≈ 10¹⁹ (the ray
                // came out zero and hit nothing).
                let l = aperture_radius * square_to_concentric_disk(u_lens);
                let offset = self.right * l.x + self.up * l.y;
                Ray::new(
                    self.eye + offset,
                    (dir - offset / focus_distance).normalize(),
                )
            }
        }
    }

    /// Connects the scene point `p` to the camera for light tracing (pbrt-v4 §16.1.1, `SampleWi`):
    /// a point on the lens (the eye for a pinhole; `u_lens` on the aperture disk for a thin lens),
    /// the raster position the connection lands on, the importance `We` of that ray and the density
    /// `pdf_w` of the direction from `p` (lens area measure converted to solid angle at `p`).
    /// `We / pdf_w · |cos at p|` times what leaves `p` toward the lens is the contribution to the
    /// pixel estimate summed over the whole film; `None` outside the image or behind the camera.
    ///
    /// We(ω) = 1 / (A · A_lens · cos⁴ θ) with A the image-plane area at distance 1 and A_lens the
    /// aperture area (1 for a pinhole), so that ∫ We cos θ dω over the film is 1 / A_lens.
    pub fn sample_wi(&self, p: Vec3, u_lens: Vec2) -> Option<CameraSample> {
        let film_area = 4.0 * self.half_size.x * self.half_size.y;
        let (p_lens, lens_area, focus) = match self.lens {
            Lens::Pinhole => (self.eye, 1.0, None),
            Lens::ThinLens {
                aperture_radius,
                focus_distance,
            } => {
                let l = aperture_radius * square_to_concentric_disk(u_lens);
                let area = std::f32::consts::PI * aperture_radius * aperture_radius;
                (
                    self.eye + self.right * l.x + self.up * l.y,
                    area,
                    Some(focus_distance),
                )
            }
        };
        let d = p - p_lens;
        let dist_sq = d.length_squared();
        if !(dist_sq > 0.0) || !dist_sq.is_finite() {
            return None;
        }
        let w = d / dist_sq.sqrt();
        let cos = w.dot(self.forward);
        if !(cos > 0.0) {
            return None;
        }
        // A thin lens images the plane of focus: the raster position is that of the point where the
        // connection crosses it, seen through the lens centre.
        let toward = match focus {
            None => d,
            Some(f) => p_lens + w * (f / cos) - self.eye,
        };
        let raster = self.raster_of_direction(toward)?;
        let we = 1.0 / (film_area * lens_area * cos * cos * cos * cos);
        Some(CameraSample {
            p_lens,
            wi: -w,
            we,
            pdf_w: dist_sq / (cos * lens_area),
            raster,
        })
    }

    /// Solid-angle density with which camera rays from the lens point `p_lens`, over uniformly
    /// distributed raster positions of the whole film, have direction `w` (unit): 1 / (A · cos³ θ)
    /// inside the image, 0 outside (pbrt-v4 §5.2, `PdfWe`; A as in [`Camera::sample_wi`]).
    pub fn pdf_we_dir(&self, p_lens: Vec3, w: Vec3) -> f32 {
        let cos = w.dot(self.forward);
        if !(cos > 0.0) {
            return 0.0;
        }
        let toward = match self.lens {
            Lens::Pinhole => w,
            Lens::ThinLens { focus_distance, .. } => p_lens + w * (focus_distance / cos) - self.eye,
        };
        if self.raster_of_direction(toward).is_none() {
            return 0.0;
        }
        1.0 / (4.0 * self.half_size.x * self.half_size.y * cos * cos * cos)
    }

    /// The raster position at which a pinhole ray with direction `d` leaves the eye, if inside the image.
    pub fn raster_of_direction(&self, d: Vec3) -> Option<Vec2> {
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let c = Vec2::new(d.dot(self.right), d.dot(self.up)) / z / self.half_size;
        let film = Vec2::new(
            (c.x + 1.0) * 0.5 * self.width as f32,
            (1.0 - c.y) * 0.5 * self.height as f32,
        );
        (film.x >= 0.0
            && film.y >= 0.0
            && film.x < self.width as f32
            && film.y < self.height as f32)
            .then_some(film)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn desc(res: (u32, u32)) -> CameraDesc {
        CameraDesc {
            eye: glam::DVec3::new(0.0, 0.0, 3.9),
            target: glam::DVec3::ZERO,
            up: Vec3::Y,
            fov: 90.0,
            resolution: res,
            lens: Lens::Pinhole,
            mirrored: false,
            shutter: (0.0, 0.0),
        }
    }

    /// A mirrored camera (a Mitsuba sensor with a reflecting transform) sees the image flipped
    /// left to right, and light tracing's connection lands on the same flipped pixel.
    #[test]
    fn a_mirrored_camera_flips_the_image_left_to_right() {
        let plain = Camera::new(&desc((64, 48)), glam::DVec3::ZERO);
        let mirrored = Camera::new(
            &CameraDesc {
                mirrored: true,
                ..desc((64, 48))
            },
            glam::DVec3::ZERO,
        );
        for (x, y) in [(3.5f32, 10.25f32), (40.0, 47.0), (63.9, 0.1)] {
            let a = plain.generate_ray(Vec2::new(x, y), Vec2::ZERO);
            let b = mirrored.generate_ray(Vec2::new(64.0 - x, y), Vec2::ZERO);
            assert!(
                (a.d - b.d).length() < 1e-6,
                "({x}, {y}): {} vs {}",
                a.d,
                b.d
            );
            let p = a.o + a.d * 2.0;
            let s = mirrored.sample_wi(p, Vec2::ZERO).unwrap();
            assert!(
                (s.raster - Vec2::new(64.0 - x, y)).length() < 1e-3,
                "{:?}",
                s.raster
            );
        }
        assert_eq!(plain.up, mirrored.up);
    }

    #[test]
    fn fov_spans_the_smaller_axis() {
        for res in [(200, 100), (100, 200), (64, 64)] {
            let cam = Camera::new(&desc(res), glam::DVec3::ZERO);
            let (w, h) = (res.0 as f32, res.1 as f32);
            // Edge of the smaller axis is 45° off axis for a 90° fov.
            let d = if w >= h {
                cam.generate_ray(Vec2::new(w * 0.5, 0.0), Vec2::ZERO).d
            } else {
                cam.generate_ray(Vec2::new(0.0, h * 0.5), Vec2::ZERO).d
            };
            assert!(
                (d.dot(cam.forward) - (0.5f32).sqrt()).abs() < 1e-5,
                "{res:?}"
            );
            // Image centre looks at the target; +x raster is +right, +y raster is down.
            let c = cam.generate_ray(Vec2::new(w * 0.5, h * 0.5), Vec2::ZERO).d;
            assert!((c - Vec3::NEG_Z).length() < 1e-6);
            assert!(cam.generate_ray(Vec2::new(w, h * 0.5), Vec2::ZERO).d.x > 0.0);
            assert!(cam.generate_ray(Vec2::new(w * 0.5, h), Vec2::ZERO).d.y < 0.0);
            // Raster position round-trips.
            let film = Vec2::new(0.3 * w, 0.8 * h);
            let back = cam
                .raster_of_direction(cam.generate_ray(film, Vec2::ZERO).d)
                .unwrap();
            assert!((back - film).length() < 1e-3);
        }
    }

    #[test]
    fn thin_lens_rays_meet_on_the_focal_plane() {
        let mut d = desc((64, 32));
        d.lens = Lens::ThinLens {
            aperture_radius: 0.2,
            focus_distance: 2.0,
        };
        let cam = Camera::new(&d, glam::DVec3::ZERO);
        let film = Vec2::new(10.5, 20.25);
        let hit = |u: Vec2| {
            let r = cam.generate_ray(film, u);
            let t = (2.0 - (r.o - cam.eye).dot(cam.forward)) / r.d.dot(cam.forward);
            r.at(t)
        };
        let a = hit(Vec2::new(0.1, 0.2));
        let b = hit(Vec2::new(0.9, 0.7));
        assert!((a - b).length() < 1e-5);
        assert!((cam.generate_ray(film, Vec2::new(0.9, 0.7)).o - cam.eye).length() > 0.01);
    }
}
