//! `SurfaceBsdf`: frame conversion, rejection of light leaks through shading normals, and the
//! adjoint shading-normal correction in importance mode. Deterministic.

use crate::common::*;
use lightlab_core::{Frame, TransportMode, Vec2, Vec3};
use lightlab_materials::{Bsdf, Distribution, Material, SurfaceBsdf};
use rand::RngExt;

/// A random unit vector and a random tangent-ish vector.
fn random_frame_inputs(rng: &mut rand_pcg::Pcg32) -> (Vec3, Vec3) {
    (uniform_sphere(rng), uniform_sphere(rng) * 2.0)
}

fn test_bsdfs() -> Vec<Bsdf> {
    vec![
        diffuse(),
        mirror(),
        Bsdf::Conductor {
            eta: GOLD_ETA,
            k: GOLD_K,
        },
        Bsdf::Dielectric { eta: 1.5 },
        rough_conductor(Vec2::new(0.1, 0.6)),
        Bsdf::RoughDielectric {
            alpha: Vec2::new(0.3, 0.1),
            eta: 1.5,
            distribution: Distribution::Ggx,
        },
        Bsdf::RoughConductor {
            alpha: Vec2::new(0.3, 0.1),
            eta: GOLD_ETA,
            k: GOLD_K,
            distribution: Distribution::Beckmann,
        },
        phong(20.0),
        plastics()[0],
        rough_plastics()[1],
    ]
}

/// With ns = ng, world-space results are the local-frame ones, transformed.
#[test]
fn surface_bsdf_matches_local_bsdf_when_normals_agree() {
    let mut rng = rng(51);
    for bsdf in test_bsdfs() {
        for _ in 0..50 {
            let (n, dpdu) = random_frame_inputs(&mut rng);
            let surface = SurfaceBsdf::new(n, dpdu, n, bsdf);
            let frame = Frame::from_normal_tangent(n, dpdu);
            let (wo, wi) = (uniform_sphere(&mut rng), uniform_sphere(&mut rng));
            let (wo_l, wi_l) = (frame.to_local(wo), frame.to_local(wi));
            for mode in MODES {
                let world = surface.eval(wo, wi, mode);
                let local = bsdf.eval(wo_l, wi_l, mode);
                assert_rgb_rel(world.f, local.f, 1e-4, &|| format!("{bsdf:?} f"));
                assert_rel(world.pdf_fwd, local.pdf_fwd, 1e-4, &|| {
                    format!("{bsdf:?} pdf_fwd")
                });
                assert_rel(world.pdf_rev, local.pdf_rev, 1e-4, &|| {
                    format!("{bsdf:?} pdf_rev")
                });
                assert_rel(surface.pdf(wo, wi), local.pdf_fwd, 1e-4, &|| {
                    format!("{bsdf:?} pdf")
                });
                let (u_lobe, u) = (rng.random(), uniform2(&mut rng));
                let s_world = surface.sample(wo, u_lobe, u, mode);
                let s_local = bsdf.sample(wo_l, u_lobe, u, mode);
                match (s_world, s_local) {
                    (Some(a), Some(b)) => {
                        assert!((a.wi - frame.to_world(b.wi)).length() < 1e-5, "{bsdf:?} wi");
                        assert_rgb_rel(a.weight, b.weight, 1e-5, &|| format!("{bsdf:?} weight"));
                        assert_eq!(a.pdf, b.pdf);
                    }
                    (None, None) => {}
                    (a, b) => panic!("{bsdf:?}: world {a:?} vs local {b:?}"),
                }
            }
        }
    }
}

/// A shading normal tilted 30° from ng. `wi` above the shading plane but below the geometric one
/// (and the reverse) would leak light; both directions must be rejected.
#[test]
fn surface_bsdf_rejects_directions_where_shading_and_geometric_normals_disagree() {
    let ng = Vec3::Z;
    let ns = dir(30f32.to_radians(), 0.0);
    let good = dir(20f32.to_radians(), 1.0);
    // Below the geometric plane, above the shading plane (ns leans toward +x).
    let leak_below = Vec3::new(0.99, 0.0, -0.1).normalize();
    // Above the geometric plane, below the shading plane.
    let leak_above = Vec3::new(-0.99, 0.0, 0.1).normalize();
    assert!(leak_below.dot(ns) > 0.0 && leak_below.dot(ng) < 0.0);
    assert!(leak_above.dot(ns) < 0.0 && leak_above.dot(ng) > 0.0);
    let mut rng = rng(52);
    for bsdf in test_bsdfs() {
        let surface = SurfaceBsdf::new(ns, Vec3::Y, ng, bsdf);
        for mode in MODES {
            for leak in [leak_below, leak_above] {
                for (wo, wi) in [(good, leak), (leak, good)] {
                    let e = surface.eval(wo, wi, mode);
                    assert!(
                        e.f.is_black() && e.pdf_fwd == 0.0 && e.pdf_rev == 0.0,
                        "{bsdf:?}"
                    );
                    assert_eq!(surface.pdf(wo, wi), 0.0, "{bsdf:?}");
                }
                assert!(surface.sample(leak, 0.5, Vec2::splat(0.5), mode).is_none());
            }
            // wo in the shading tangent plane.
            let in_plane = ns.cross(Vec3::Y).normalize();
            assert!(
                surface
                    .sample(in_plane, 0.5, Vec2::splat(0.5), mode)
                    .is_none()
            );
            // Nothing sampled from a good wo may leak.
            for _ in 0..2000 {
                let wo = if rng.random::<bool>() { good } else { -good };
                if let Some(s) = surface.sample(wo, rng.random(), uniform2(&mut rng), mode) {
                    assert!(
                        s.wi.dot(ng) * s.wi.dot(ns) > 0.0,
                        "{bsdf:?}: sampled leaking wi {}",
                        s.wi
                    );
                }
            }
        }
    }
}

/// Importance mode multiplies f and weight by |wo·ns||wi·ng| / (|wo·ng||wi·ns|); radiance mode
/// does not (Veach 1997, eq. 5.19).
#[test]
fn surface_bsdf_applies_adjoint_shading_normal_correction_in_importance_mode() {
    let ng = Vec3::Z;
    let ns = dir(25f32.to_radians(), 0.3);
    let mut rng = rng(53);
    for bsdf in test_bsdfs() {
        let surface = SurfaceBsdf::new(ns, Vec3::X, ng, bsdf);
        let frame = surface.frame;
        let mut checked = 0;
        for _ in 0..3000 {
            let (wo, wi) = (uniform_sphere(&mut rng), uniform_sphere(&mut rng));
            if wo.dot(ng) * wo.dot(ns) <= 0.0 || wi.dot(ng) * wi.dot(ns) <= 0.0 {
                continue;
            }
            let correction =
                wo.dot(ns).abs() * wi.dot(ng).abs() / (wo.dot(ng).abs() * wi.dot(ns).abs());
            let (wo_l, wi_l) = (frame.to_local(wo), frame.to_local(wi));
            let imp = surface.eval(wo, wi, TransportMode::Importance);
            let local_imp = bsdf.eval(wo_l, wi_l, TransportMode::Importance);
            assert_rgb_rel(imp.f, local_imp.f * correction, 1e-4, &|| {
                format!("{bsdf:?} importance f")
            });
            assert_rel(imp.pdf_fwd, local_imp.pdf_fwd, 1e-4, &|| {
                format!("{bsdf:?} pdf untouched")
            });
            let rad = surface.eval(wo, wi, TransportMode::Radiance);
            let local_rad = bsdf.eval(wo_l, wi_l, TransportMode::Radiance);
            assert_rgb_rel(rad.f, local_rad.f, 1e-4, &|| format!("{bsdf:?} radiance f"));
            checked += !imp.f.is_black() as usize;

            let (u_lobe, u) = (rng.random(), uniform2(&mut rng));
            let (Some(s), Some(l)) = (
                surface.sample(wo, u_lobe, u, TransportMode::Importance),
                bsdf.sample(wo_l, u_lobe, u, TransportMode::Importance),
            ) else {
                continue;
            };
            let c = wo.dot(ns).abs() * s.wi.dot(ng).abs() / (wo.dot(ng).abs() * s.wi.dot(ns).abs());
            assert_rgb_rel(s.weight, l.weight * c, 1e-4, &|| {
                format!("{bsdf:?} importance weight")
            });
            assert_rgb_rel(s.f, l.f * c, 1e-4, &|| {
                format!("{bsdf:?} importance sample f")
            });
        }
        if !bsdf.is_delta() {
            assert!(checked > 100, "{bsdf:?}: only {checked} non-zero pairs");
        }
    }
}

/// Anisotropic roughness follows dpdu: (αx, αy) along dpdu = x equals (αy, αx) along dpdu = y.
#[test]
fn surface_bsdf_anisotropy_follows_dpdu() {
    let (a, b) = (0.1, 0.6);
    let along_x = SurfaceBsdf::new(Vec3::Z, Vec3::X, Vec3::Z, rough_conductor(Vec2::new(a, b)));
    let along_y = SurfaceBsdf::new(Vec3::Z, Vec3::Y, Vec3::Z, rough_conductor(Vec2::new(b, a)));
    let mut rng = rng(54);
    let mut differs = 0;
    for _ in 0..500 {
        let (wo, wi) = (uniform_sphere(&mut rng), uniform_sphere(&mut rng));
        let (fx, fy) = (
            along_x.eval(wo, wi, TransportMode::Radiance).f,
            along_y.eval(wo, wi, TransportMode::Radiance).f,
        );
        assert_rgb_rel(fx, fy, 1e-4, &|| format!("wo {wo}, wi {wi}"));
        let iso = SurfaceBsdf::new(Vec3::Z, Vec3::Y, Vec3::Z, rough_conductor(Vec2::new(a, b)));
        let f_swapped = iso.eval(wo, wi, TransportMode::Radiance).f;
        differs += ((f_swapped.r - fx.r).abs() > 1e-3 * fx.r) as usize;
    }
    // Guard against the frame being ignored: rotating the tangent must change something.
    assert!(
        differs > 50,
        "rotating dpdu changed only {differs} of 500 values"
    );
}

/// A one-sided surface (Mitsuba's reflecting BSDFs) is black from behind — eval, pdf and sample —
/// and identical to the two-sided one in front.
#[test]
fn one_sided_surfaces_are_black_from_behind_and_unchanged_in_front() {
    let mut rng = rng(52);
    for bsdf in [
        diffuse(),
        mirror(),
        rough_conductor(Vec2::splat(0.3)),
        phong(20.0),
        plastics()[0],
        rough_plastics()[1],
    ] {
        let material = Material {
            one_sided: true,
            ..Material::two_sided(bsdf)
        };
        let one = SurfaceBsdf::of(Vec3::Z, Vec3::X, Vec3::Z, &material, bsdf);
        let two = SurfaceBsdf::of(Vec3::Z, Vec3::X, Vec3::Z, &Material::two_sided(bsdf), bsdf);
        let (mut front_samples, mut back_two_sided) = (0, 0);
        for _ in 0..200 {
            let (wo, wi) = (uniform_sphere(&mut rng), uniform_sphere(&mut rng));
            let (u_lobe, u) = (rng.random::<f32>(), uniform2(&mut rng));
            for mode in MODES {
                let (e1, e2) = (one.eval(wo, wi, mode), two.eval(wo, wi, mode));
                let s1 = one.sample(wo, u_lobe, u, mode);
                let s2 = two.sample(wo, u_lobe, u, mode);
                if wo.z < 0.0 || wi.z < 0.0 {
                    assert!(e1.f.is_black() && e1.pdf_fwd == 0.0, "{bsdf:?} {wo} {wi}");
                    assert_eq!(one.pdf(wo, wi), 0.0);
                } else {
                    assert_eq!(e1.f, e2.f);
                    assert_eq!(one.pdf(wo, wi), two.pdf(wo, wi));
                }
                if wo.z < 0.0 {
                    assert!(s1.is_none(), "{bsdf:?}: sampled from behind at {wo}");
                    back_two_sided += s2.is_some() as usize;
                } else if let (Some(a), Some(b)) = (s1, s2) {
                    assert_eq!(a.wi, b.wi);
                    assert_eq!(a.weight, b.weight);
                    front_samples += 1;
                }
            }
        }
        assert!(
            front_samples > 100,
            "{bsdf:?}: {front_samples} front samples"
        );
        // The two-sided surface does scatter from behind, so the test sees the difference.
        assert!(
            back_two_sided > 50,
            "{bsdf:?}: {back_two_sided} back samples"
        );
    }
}
