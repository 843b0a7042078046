//! Chi-square goodness-of-fit tests of the scene's sampling routines with the testkit harness:
//! lights (`Light::sample_li` against `Light::pdf_li`, `Light::sample_le` against
//! `Light::pdf_le`) and the camera (`Camera::generate_ray` over uniform film positions against the
//! known direction density 1/(A cos³θ) and `Camera::pdf_we_dir`, thin-lens points uniform on the
//! aperture, and `Camera::sample_wi`'s connection directions against the lens area converted to
//! solid angle).
//!
//! Densities a test expects come from the public `pdf_*` functions where the crate has one, and
//! from independent formulas otherwise (stated at each test); where both exist, a deterministic
//! check that they agree sits beside the chi-square test.
//!
//! False failures: 14 chi-square tests at the default α = sidak(0.01, 300) = 3.35 × 10⁻⁵ each
//! (counted per test function below), together 1 − (1 − α)¹⁴ ≈ 0.047 % over the choice of seed;
//! the seeds are fixed. The deterministic checks cannot fail by chance.

use glam::{DVec3, Vec2, Vec3};
use lightlab_core::{Frame, Rgb};
use lightlab_geometry::{Geometry, Shape, Sphere, TriangleMesh};
use lightlab_samplers::warp::square_to_uniform_sphere;
use lightlab_scene::desc::{CameraDesc, Lens};
use lightlab_scene::{Camera, Light};
use lightlab_testkit::{Chi2Test, DirectionWindow, Domain};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg32;

const SCENE_CENTER: Vec3 = Vec3::new(0.5, -1.0, 2.0);
const SCENE_RADIUS: f32 = 3.0;

// ---- Lights ---------------------------------------------------------------------------------

/// 3 tests: the environment's `sample_li` directions against `pdf_li` (uniform, 1/4π), its
/// `sample_le` directions against `pdf_le` and its `sample_le` origins, uniform on the disk of the
/// scene's radius perpendicular to the direction, against `pdf_le`'s area density.
#[test]
fn chi2_environment_light() {
    let light = Light::Environment {
        radiance: Rgb::new(0.3, 0.5, 1.0),
        map: None,
    };
    let p = Vec3::new(0.2, 0.7, -1.5);
    Chi2Test::new(Domain::Sphere)
        .seed(6100)
        .run(
            "environment_sample_li",
            |u| {
                let s = light.sample_li(&[], p, u)?;
                assert!(s.infinite && !s.delta && s.pdf_w == light.pdf_li(&[], p, s.p, s.n));
                Some(s.wi)
            },
            |w: Vec3| light.pdf_li(&[], p, p + w, -w),
        )
        .assert_ok();
    let mut rng = Pcg32::seed_from_u64(6101);
    Chi2Test::new(Domain::Sphere)
        .seed(6102)
        .run(
            "environment_sample_le_direction",
            |u_dir| {
                let u_pos = Vec2::new(rng.random(), rng.random());
                let e = light.sample_le(&[], SCENE_CENTER, SCENE_RADIUS, u_pos, u_dir)?;
                Some(e.dir)
            },
            |w: Vec3| light.pdf_le(&[], SCENE_RADIUS, w, w).1,
        )
        .assert_ok();
    // Origins in the frame of their direction, scaled to the unit disk (density per unit area of
    // the unit disk = pdf_pos · R²). They must also start outside the scene's bounding sphere.
    let mut rng = Pcg32::seed_from_u64(6103);
    Chi2Test::new(Domain::Disk)
        .seed(6104)
        .run(
            "environment_sample_le_origin",
            |u_pos| {
                let u_dir = Vec2::new(rng.random(), rng.random());
                let e = light.sample_le(&[], SCENE_CENTER, SCENE_RADIUS, u_pos, u_dir)?;
                let offset = e.p - SCENE_CENTER + e.dir * SCENE_RADIUS;
                assert!(offset.dot(e.dir).abs() < 1e-4 * SCENE_RADIUS, "{e:?}");
                assert!(
                    (e.p - SCENE_CENTER).dot(e.dir) < -0.999 * SCENE_RADIUS,
                    "{e:?}"
                );
                let local = Frame::from_z(e.dir).to_local(offset) / SCENE_RADIUS;
                Some(local.truncate())
            },
            |_: Vec2| light.pdf_le(&[], SCENE_RADIUS, Vec3::Z, Vec3::Z).0 * SCENE_RADIUS.powi(2),
        )
        .assert_ok();
}

/// 2 tests: an environment map's `sample_li` directions against `pdf_li` and its `sample_le`
/// directions against `pdf_le`. The map (48 × 24, turned about an oblique axis) has a sun 20 times
/// brighter than its sky over a few texels, a black band (zero density), a gradient and a constant
/// added, so the densities span four orders of magnitude.
#[test]
fn chi2_environment_map() {
    let (w, h) = (48usize, 24usize);
    let texels = (0..h)
        .flat_map(|j| {
            (0..w).map(move |i| {
                let (x, y) = (i as f32 / w as f32, j as f32 / h as f32);
                if (10..13).contains(&j) {
                    Rgb::BLACK
                } else if (30..33).contains(&i) && (4..6).contains(&j) {
                    Rgb::splat(20.0)
                } else {
                    Rgb::new(0.2 + x, 0.5 * y, 0.1)
                }
            })
        })
        .collect();
    let rotation = glam::Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.7);
    let map = lightlab_scene::EnvMap::new(w, h, texels, 1.5, Rgb::splat(0.01), rotation).unwrap();
    let light = Light::Environment {
        radiance: Rgb::splat(0.01),
        map: Some(std::sync::Arc::new(map)),
    };
    let p = Vec3::new(0.2, 0.7, -1.5);
    Chi2Test::new(Domain::Sphere)
        .seed(6110)
        .run(
            "envmap_sample_li",
            |u| {
                let s = light.sample_li(&[], p, u)?;
                assert!(s.infinite && !s.delta);
                assert_eq!(s.pdf_w, light.pdf_li(&[], p, s.p, s.n));
                assert_eq!(s.li, light.environment_le(s.wi));
                Some(s.wi)
            },
            |w: Vec3| light.pdf_li(&[], p, p + w, -w),
        )
        .assert_ok();
    let mut rng = Pcg32::seed_from_u64(6111);
    Chi2Test::new(Domain::Sphere)
        .seed(6112)
        .run(
            "envmap_sample_le_direction",
            |u_dir| {
                let u_pos = Vec2::new(rng.random(), rng.random());
                let e = light.sample_le(&[], SCENE_CENTER, SCENE_RADIUS, u_pos, u_dir)?;
                assert_eq!(e.le, light.environment_le(-e.dir));
                Some(e.dir)
            },
            |w: Vec3| light.pdf_le(&[], SCENE_RADIUS, w, w).1,
        )
        .assert_ok();
}

/// Both intersections (t > 0) of a ray with a sphere in f64, nearest first.
fn hit_sphere(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Vec<f64> {
    let oc = o - c;
    let b = oc.dot(d);
    let disc = r * r - (oc - b * d).length_squared();
    if disc < 0.0 {
        return Vec::new();
    }
    let root = disc.sqrt();
    [-b - root, -b + root]
        .into_iter()
        .filter(|&t| t > 0.0)
        .collect()
}

/// 1 test: a spherical area light seen from 1.5 radii, `sample_li` directions against `pdf_li` at
/// the first point along each direction (f64 ray casting), on the sphere of directions; every
/// sample's pdf is `pdf_li` at its point and its radiance is the light's on the side it faces.
#[test]
fn chi2_sphere_area_light_sample_li() {
    let (center, radius) = (Vec3::new(-0.3, 0.4, 1.0), 0.8);
    let shapes = [Shape {
        geometry: Geometry::Sphere(Sphere::new(center, radius)),
        material: 0,
        light: 0,
    }];
    let radiance = Rgb::new(2.0, 1.0, 0.5);
    let light = Light::Area {
        shape: 0,
        radiance,
        two_sided: false,
    };
    let p = center + Vec3::new(0.6, -0.9, 0.6).normalize() * (1.5 * radius);
    Chi2Test::new(Domain::Sphere)
        .seed(6110)
        .run(
            "sphere_area_light_sample_li",
            |u| {
                let s = light.sample_li(&shapes, p, u)?;
                assert_eq!(s.pdf_w, light.pdf_li(&shapes, p, s.p, s.n));
                assert_eq!(s.li, radiance, "{s:?}");
                Some(s.wi)
            },
            |w: Vec3| {
                let (o, d) = (p.as_dvec3(), w.as_dvec3().normalize());
                let c = center.as_dvec3();
                match hit_sphere(o, d, c, radius as f64).first() {
                    Some(&t) => {
                        let q = o + t * d;
                        light.pdf_li(&shapes, p, q.as_vec3(), ((q - c) / radius as f64).as_vec3())
                    }
                    None => 0.0,
                }
            },
        )
        .assert_ok();
}

/// A unit-square emitter in a tilted plane.
fn quad_shapes() -> (Vec<Shape>, Vec3) {
    let (u, v) = (Vec3::new(0.6, 0.8, 0.0), Vec3::new(-0.48, 0.36, 0.8));
    let c = Vec3::new(0.1, 0.2, 0.3);
    let h = 0.5;
    let positions = vec![
        c - h * u - h * v,
        c + h * u - h * v,
        c + h * u + h * v,
        c - h * u + h * v,
    ];
    let mesh = TriangleMesh::new(positions, None, None, vec![[0, 1, 2], [0, 2, 3]]).unwrap();
    let shapes = vec![Shape {
        geometry: Geometry::Mesh(mesh),
        material: 0,
        light: 0,
    }];
    (shapes, u.cross(v).normalize())
}

/// 2 tests: the emission directions of a one-sided and a two-sided quad area light
/// (cosine-weighted on the emitting side(s)) against `pdf_le`'s direction density, on the sphere;
/// the origins lie on the quad with `pdf_le`'s area density.
#[test]
fn chi2_area_light_sample_le() {
    let (shapes, n) = quad_shapes();
    for (k, two_sided) in [false, true].into_iter().enumerate() {
        let light = Light::Area {
            shape: 0,
            radiance: Rgb::WHITE,
            two_sided,
        };
        let mut rng = Pcg32::seed_from_u64(6120 + k as u64);
        Chi2Test::new(Domain::Sphere)
            .seed(6122 + k as u64)
            .run(
                &format!("area_light_sample_le_two_sided_{two_sided}"),
                |u_dir| {
                    let u_pos = Vec2::new(rng.random(), rng.random());
                    let e = light.sample_le(&shapes, SCENE_CENTER, SCENE_RADIUS, u_pos, u_dir)?;
                    let (pdf_pos, pdf_dir) = light.pdf_le(&shapes, SCENE_RADIUS, e.n, e.dir);
                    assert!((e.n - n).length() < 1e-5 || (e.n + n).length() < 1e-5);
                    assert_eq!(e.pdf_pos, pdf_pos, "{e:?}");
                    // cos θ/π from the local frame vs from n·dir: f32 rounding, ~10⁻⁸ absolute.
                    let tol = 1e-5 * pdf_dir + 1e-7;
                    assert!((e.pdf_dir - pdf_dir).abs() <= tol, "{e:?}: {pdf_dir}");
                    assert!(!e.delta_pos);
                    Some(e.dir)
                },
                |w: Vec3| light.pdf_le(&shapes, SCENE_RADIUS, n, w).1,
            )
            .assert_ok();
    }
}

/// 2 tests: point-light emission (uniform) and spot-light emission (uniform in the cone of
/// half-angle 35° around a tilted axis) against `pdf_le`, on the sphere of directions.
#[test]
fn chi2_point_and_spot_light_sample_le() {
    let position = Vec3::new(1.0, 2.0, -0.5);
    let point = Light::Point {
        position,
        intensity: Rgb::WHITE,
    };
    let axis = Vec3::new(0.3, -0.5, -0.8).normalize();
    let spot = Light::Spot {
        position,
        axis,
        intensity: Rgb::WHITE,
        cos_total: 35f32.to_radians().cos(),
        cos_falloff_start: 25f32.to_radians().cos(),
        profile: lightlab_scene::SpotProfile::Smoothstep,
    };
    for (k, (name, light)) in [("point", point), ("spot", spot)].into_iter().enumerate() {
        Chi2Test::new(Domain::Sphere)
            .seed(6130 + k as u64)
            .run(
                &format!("{name}_light_sample_le"),
                |u_dir| {
                    let e = light.sample_le(&[], SCENE_CENTER, SCENE_RADIUS, Vec2::ZERO, u_dir)?;
                    assert!(e.delta_pos && e.p == position && e.pdf_pos == 1.0);
                    Some(e.dir)
                },
                |w: Vec3| light.pdf_le(&[], SCENE_RADIUS, w, w).1,
            )
            .assert_ok();
    }
}

// ---- Camera ---------------------------------------------------------------------------------

/// A 16:9 camera with a 50° vertical field of view, looking along a direction off every axis.
fn camera(lens: Lens) -> Camera {
    Camera::new(
        &CameraDesc {
            eye: glam::DVec3::new(1.0, 2.0, 3.0),
            target: glam::DVec3::new(-0.5, 0.2, 0.4),
            up: Vec3::Y,
            fov: 50.0,
            resolution: (32, 18),
            lens,
            mirrored: false,
            shutter: (0.0, 0.0),
        },
        glam::DVec3::ZERO,
    )
}

/// Direction in the camera frame (right, up, forward), where the cap around +z is the view cone.
fn to_camera(cam: &Camera, w: Vec3) -> Vec3 {
    Vec3::new(w.dot(cam.right), w.dot(cam.up), w.dot(cam.forward))
}

fn from_camera(cam: &Camera, v: Vec3) -> Vec3 {
    cam.right * v.x + cam.up * v.y + cam.forward * v.z
}

/// The pinhole direction density of uniform film positions, from the geometry of the image plane
/// at distance 1 (area A = 4·hx·hy): 1/(A cos³θ) inside the frustum, 0 outside. `offset` is the
/// lens point's offset in the lens plane over the focus distance (zero for a pinhole): from a lens
/// point, the frustum is the one through the image rectangle on the plane of focus.
fn frustum_pdf(cam: &Camera, v: Vec3, offset: Vec2) -> f32 {
    let (h, z) = (cam.half_size, v.z);
    if !(z > 0.0) {
        return 0.0;
    }
    let c = offset + v.truncate() / z;
    if c.x.abs() > h.x || c.y.abs() > h.y {
        return 0.0;
    }
    1.0 / (4.0 * h.x * h.y * z * z * z)
}

/// A cap around the view direction that contains the frustum (from any lens point within
/// `tilt` rad of the axis) with a margin.
fn view_cap(cam: &Camera, tilt: f32) -> Domain {
    let h = cam.half_size;
    let corner = (h.x * h.x + h.y * h.y).sqrt().atan();
    Domain::Cap {
        cos_theta_max: (corner + tilt + 0.03).cos(),
    }
}

/// 1 test and a deterministic check: pinhole rays through uniform film positions have direction
/// density 1/(A cos³θ) inside the frustum (A from `half_size`), on a cap around the view
/// direction; `pdf_we_dir` is that density (to 10⁻⁵ away from the frustum's edges).
#[test]
fn chi2_pinhole_camera_rays() {
    let cam = camera(Lens::Pinhole);
    let film = |u: Vec2| u * Vec2::new(cam.width as f32, cam.height as f32);
    Chi2Test::new(view_cap(&cam, 0.0))
        .seed(6140)
        .run(
            "pinhole_camera_rays",
            |u| {
                let ray = cam.generate_ray(film(u), Vec2::splat(0.5));
                assert_eq!(ray.o, cam.eye);
                Some(to_camera(&cam, ray.d))
            },
            |v: Vec3| frustum_pdf(&cam, v, Vec2::ZERO),
        )
        .assert_ok();
    let mut rng = Pcg32::seed_from_u64(6141);
    for _ in 0..100_000 {
        let v = square_to_uniform_sphere(Vec2::new(rng.random(), rng.random()));
        let c = v.truncate() / v.z;
        let edge = (c.abs() - cam.half_size).abs().min_element();
        if v.z > 0.0 && edge < 1e-4 {
            continue;
        }
        let want = frustum_pdf(&cam, v, Vec2::ZERO);
        let got = cam.pdf_we_dir(cam.eye, from_camera(&cam, v));
        assert!(
            (got - want).abs() <= 1e-5 * want,
            "direction {v} (camera frame): pdf_we_dir {got}, want {want}"
        );
    }
}

/// 2 tests: thin-lens ray origins are uniform on the aperture disk (lens plane coordinates over
/// the aperture radius, on the unit disk), and for a fixed lens point the directions of rays
/// through uniform film positions have density `pdf_we_dir(p_lens, ·)`, which is checked against
/// the same independent frustum density seen from the lens point.
#[test]
fn chi2_thin_lens_camera_rays() {
    let (aperture_radius, focus_distance) = (0.15, 2.5);
    let cam = camera(Lens::ThinLens {
        aperture_radius,
        focus_distance,
    });
    let film = |u: Vec2| u * Vec2::new(cam.width as f32, cam.height as f32);
    let mut rng = Pcg32::seed_from_u64(6150);
    Chi2Test::new(Domain::Disk)
        .seed(6151)
        .run(
            "thin_lens_points",
            |u_lens| {
                let ray = cam.generate_ray(film(Vec2::new(rng.random(), rng.random())), u_lens);
                let l = ray.o - cam.eye;
                assert!(
                    l.dot(cam.forward).abs() < 1e-5,
                    "origin off the lens plane: {l}"
                );
                Some(Vec2::new(l.dot(cam.right), l.dot(cam.up)) / aperture_radius)
            },
            |p: Vec2| {
                if p.length_squared() <= 1.0 {
                    std::f32::consts::FRAC_1_PI
                } else {
                    0.0
                }
            },
        )
        .assert_ok();

    let u_lens = Vec2::new(0.85, 0.3);
    let p_lens = cam.generate_ray(film(Vec2::splat(0.5)), u_lens).o;
    let l = p_lens - cam.eye;
    let offset = Vec2::new(l.dot(cam.right), l.dot(cam.up)) / focus_distance;
    let tilt = (l.length() / focus_distance).atan();
    Chi2Test::new(view_cap(&cam, tilt))
        .seed(6152)
        .run(
            "thin_lens_directions",
            |u| {
                let ray = cam.generate_ray(film(u), u_lens);
                assert!((ray.o - p_lens).length() < 1e-6);
                Some(to_camera(&cam, ray.d))
            },
            |v: Vec3| {
                let got = cam.pdf_we_dir(p_lens, from_camera(&cam, v));
                let want = frustum_pdf(&cam, v, offset);
                let c = offset + v.truncate() / v.z;
                let edge = (c.abs() - cam.half_size).abs().min_element();
                assert!(
                    edge < 1e-4 || (got - want).abs() <= 1e-5 * want,
                    "direction {v} (camera frame): pdf_we_dir {got}, want {want}"
                );
                got
            },
        )
        .assert_ok();
}

/// 1 test: `Camera::sample_wi` from a point near the centre of the plane of focus (so that every
/// lens point images it inside the film) draws lens points uniformly on the aperture: its
/// directions toward the lens have density |l − p|² / (|cos θ_lens| · π R²), found by
/// intersecting each direction with the lens plane (f64), on a window around the lens. Each
/// sample's `pdf_w` is that density, and no sample is rejected.
#[test]
fn chi2_camera_sample_wi() {
    let (aperture_radius, focus_distance) = (0.15f32, 2.5f32);
    let cam = camera(Lens::ThinLens {
        aperture_radius,
        focus_distance,
    });
    let p = cam.eye + cam.forward * focus_distance + cam.right * 0.1 + cam.up * 0.05;
    let (eye, forward, o) = (cam.eye.as_dvec3(), cam.forward.as_dvec3(), p.as_dvec3());
    // `rim` > 1 widens the aperture for checking samples, which can lie on its rim.
    let lens_pdf = |w: DVec3, rim: f64| -> f64 {
        let t = (eye - o).dot(forward) / w.dot(forward);
        let l = o + t * w;
        if !(t > 0.0) || (l - eye).length() > rim * aperture_radius as f64 {
            return 0.0;
        }
        let area = std::f64::consts::PI * (aperture_radius as f64).powi(2);
        t * t / (w.dot(forward).abs() * area)
    };
    let to_eye = eye - o;
    let tan = 1.1 * aperture_radius as f64 / to_eye.length();
    let window = DirectionWindow::new(to_eye, cam.right.as_dvec3(), (tan, tan));
    let result = Chi2Test::new(Domain::Square).seed(6160).run(
        "camera_sample_wi",
        |u_lens| {
            let s = cam
                .sample_wi(p, u_lens)
                .expect("the point is imaged from every lens point");
            let want = lens_pdf(s.wi.as_dvec3().normalize(), 1.0 + 1e-5);
            assert!(
                (s.pdf_w as f64 / want - 1.0).abs() < 1e-4,
                "{s:?}: want pdf {want}"
            );
            window.to_square(s.wi)
        },
        |q: Vec2| {
            let (w, jacobian) = window.direction_f64(q);
            (lens_pdf(w, 1.0) * jacobian) as f32
        },
    );
    result.assert_ok();
    assert_eq!(result.accepted, result.samples);
}

/// The camera's frame is orthonormal and `half_size` follows the fov along the smaller axis, as
/// the densities above assume.
#[test]
fn camera_frame_and_image_plane() {
    let cam = camera(Lens::Pinhole);
    for (a, b) in [
        (cam.right, cam.up),
        (cam.up, cam.forward),
        (cam.forward, cam.right),
    ] {
        assert!(a.dot(b).abs() < 1e-6 && (a.length() - 1.0).abs() < 1e-6);
    }
    assert!((cam.half_size.y - 25f32.to_radians().tan()).abs() < 1e-6);
    assert!((cam.half_size.x / cam.half_size.y - 32.0 / 18.0).abs() < 1e-5);
}
