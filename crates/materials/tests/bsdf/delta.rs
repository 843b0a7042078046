//! Delta BSDFs (Mirror, smooth Conductor, smooth Dielectric) have no density to chi-square test; their samples are
//! checked exactly instead, against an independent f64 implementation of the mirror direction,
//! Snell's law and the unpolarised Fresnel reflectance (Born & Wolf; pbrt-v4 §9.3): the sampled
//! direction, the lobe chosen for each `u_lobe` (reflection iff u_lobe < R), the selection
//! probability reported as `pdf`, the weight f·|cos θi|/pdf (reflectance for the mirror; 1 for
//! reflection and 1/η′² in radiance mode, 1 in importance mode, for refraction) and η′.
//! Deterministic: no statistics involved.

use crate::common::*;
use glam::DVec3;
use lightlab_core::{Rgb, TransportMode, Vec2, Vec3};
use lightlab_materials::{Bsdf, LobeClass};
use rand::RngExt;

/// The three awkward incidences on both sides, 200 random directions (both hemispheres), and
/// directions within 10⁻⁶ … 10⁻³ rad of the horizon and of the critical angle of glass seen from
/// inside (41.81°).
fn incident_directions() -> Vec<Vec3> {
    let mut wos = wos_both_sides();
    let mut rng = rng(7100);
    wos.extend(
        (0..200)
            .map(|_| uniform_sphere(&mut rng))
            .filter(|w| w.z != 0.0),
    );
    let critical = (1.0f64 / 1.5).asin();
    for eps in [1e-6f64, 1e-4, 1e-3] {
        let phi = rng.random::<f32>() * std::f32::consts::TAU;
        for theta in [
            std::f64::consts::FRAC_PI_2 - eps,
            critical - eps,
            critical + eps,
        ] {
            let w = dir(theta as f32, phi);
            wos.extend([w, Vec3::new(w.x, w.y, -w.z)]);
        }
    }
    wos
}

/// Unpolarised Fresnel reflectance of a dielectric interface with relative index `eta`
/// (inside / outside, outside on +z) for light arriving along `wo`, in f64; 1 under total
/// internal reflection.
fn fresnel_f64(wo: DVec3, eta: f64) -> f64 {
    let (cos_i, eta) = if wo.z >= 0.0 {
        (wo.z, eta)
    } else {
        (-wo.z, 1.0 / eta)
    };
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Snell's law in vector form: the refracted direction and η′ (the index of the far side over
/// that of `wo`'s side), or `None` under total internal reflection.
fn refract_f64(wo: DVec3, eta: f64) -> Option<(DVec3, f64)> {
    let (n, etap, cos_i) = if wo.z >= 0.0 {
        (DVec3::Z, eta, wo.z)
    } else {
        (-DVec3::Z, 1.0 / eta, -wo.z)
    };
    let sin2_t = (1.0 - cos_i * cos_i) / (etap * etap);
    (sin2_t < 1.0).then(|| {
        let cos_t = (1.0 - sin2_t).sqrt();
        (-wo / etap + (cos_i / etap - cos_t) * n, etap)
    })
}

fn mirror_direction(wo: Vec3) -> Vec3 {
    Vec3::new(-wo.x, -wo.y, wo.z)
}

#[test]
fn mirror_reflects_exactly_with_weight_equal_to_reflectance() {
    let reflectance = Rgb::new(0.9, 0.6, 0.3);
    let bsdf = Bsdf::Mirror { reflectance };
    let mut rng = rng(7101);
    for wo in incident_directions() {
        for mode in MODES {
            let s = bsdf
                .sample(wo, rng.random(), uniform2(&mut rng), mode)
                .unwrap_or_else(|| panic!("mirror, wo {wo}: no sample"));
            let ctx = || format!("mirror, wo {wo}, {mode:?}: {s:?}");
            assert_eq!(s.wi, mirror_direction(wo), "{}", ctx());
            assert_eq!(s.pdf, 1.0, "{}", ctx());
            assert!(s.delta && !s.transmission && s.lobe == LobeClass::Specular);
            assert_eq!(s.eta, 1.0);
            assert_rgb_rel(s.weight, reflectance, 1e-6, &|| {
                format!("{}: weight", ctx())
            });
            assert_rgb_rel(s.f * wo.z.abs(), reflectance, 1e-6, &|| {
                format!("{}: f", ctx())
            });
        }
    }
}

#[test]
fn dielectric_chooses_lobes_by_fresnel_with_exact_directions_and_weights() {
    for eta in [1.5f32, 1.0 / 1.5, 1.0001, 4.0] {
        let bsdf = Bsdf::Dielectric { eta };
        for wo in incident_directions() {
            let wo64 = wo.as_dvec3();
            let r = fresnel_f64(wo64, eta as f64);
            let refracted = refract_f64(wo64, eta as f64);
            assert_eq!(refracted.is_none(), r == 1.0, "eta {eta}, wo {wo}");
            // R is ill-conditioned near the critical angle (dR/dθ is infinite there) and, for η
            // near 1, in η (R depends on η − 1): an f32 evaluation can only be right to R's
            // variation over a few ulps of cos θ and η. Bracket it by perturbing both.
            let perturbed = |k_cos: f64, k_eta: f64| {
                let w = DVec3::new(wo64.x, wo64.y, wo64.z * k_cos);
                (
                    fresnel_f64(w, eta as f64 * k_eta),
                    refract_f64(w, eta as f64 * k_eta),
                )
            };
            let ks = [1.0 - 4e-7, 1.0, 1.0 + 4e-7];
            let mut r_lo = r;
            let mut r_hi = r;
            let mut spread = 0.0f64;
            for k_cos in ks {
                for k_eta in ks {
                    let (rk, tk) = perturbed(k_cos, k_eta);
                    (r_lo, r_hi) = (r_lo.min(rk), r_hi.max(rk));
                    if let (Some((wk, _)), Some((wi, _))) = (tk, refracted) {
                        spread = spread.max((wk - wi).length());
                    }
                }
            }
            let slack = |x: f64| 1e-5 * x + 2e-7;
            // u_lobe in the middle of each lobe's share of [0, 1), at its ends, and just beyond
            // the bracket on both sides of the threshold.
            let mut u_lobes = vec![0.0, (0.5 * r) as f32, (r_lo - 2.0 * slack(r_lo)) as f32];
            if r_hi < 1.0 {
                u_lobes.extend([
                    (r_hi + 2.0 * slack(r_hi)) as f32,
                    (r + 0.5 * (1.0 - r)) as f32,
                    1.0 - f32::EPSILON / 2.0,
                ]);
            }
            for u_lobe in u_lobes {
                for mode in MODES {
                    let s = bsdf
                        .sample(wo, u_lobe, Vec2::new(0.3, 0.7), mode)
                        .unwrap_or_else(|| panic!("eta {eta}, wo {wo}, u_lobe {u_lobe}: none"));
                    let ctx = || format!("eta {eta}, wo {wo}, u_lobe {u_lobe}, {mode:?}: {s:?}");
                    assert!(s.delta && s.lobe == LobeClass::Specular, "{}", ctx());
                    // Reflection iff u_lobe < R: certain outside the bracket of R.
                    let u = u_lobe as f64;
                    if u < r_lo - slack(r_lo) {
                        assert!(!s.transmission, "{}: should reflect", ctx());
                    } else if u > r_hi + slack(r_hi) {
                        assert!(s.transmission, "{}: should refract", ctx());
                    }
                    let reflect = !s.transmission;
                    if reflect {
                        assert_eq!(s.wi, mirror_direction(wo), "{}", ctx());
                        let pdf = s.pdf as f64;
                        assert!(
                            pdf >= r_lo - slack(r_lo) && pdf <= r_hi + slack(r_hi),
                            "{}: pdf = R ∈ [{r_lo}, {r_hi}]",
                            ctx()
                        );
                        assert_eq!(s.eta, 1.0, "{}", ctx());
                        assert_rgb_rel(s.weight, Rgb::WHITE, 1e-5, &|| {
                            format!("{}: weight", ctx())
                        });
                    } else {
                        let (wi, etap) = refracted.unwrap();
                        // Refraction to near the horizon amplifies input rounding (dθt/dθi =
                        // cos θi / (η′ cos θt)): allow the reference's spread over the bracket.
                        assert!(
                            (s.wi.as_dvec3() - wi).length() <= spread + 2e-6,
                            "{}: Snell gives {wi} (± {spread})",
                            ctx()
                        );
                        let (t_lo, t_hi) = (1.0 - r_hi, 1.0 - r_lo);
                        let pdf = s.pdf as f64;
                        assert!(
                            pdf >= t_lo - slack(t_lo) && pdf <= t_hi + slack(t_hi),
                            "{}: pdf = 1 − R ∈ [{t_lo}, {t_hi}]",
                            ctx()
                        );
                        assert_rel(s.eta, etap as f32, 1e-6, &|| format!("{}: eta", ctx()));
                        let weight = match mode {
                            TransportMode::Radiance => 1.0 / (etap * etap),
                            TransportMode::Importance => 1.0,
                        };
                        assert_rgb_rel(s.weight, Rgb::splat(weight as f32), 1e-5, &|| {
                            format!("{}: weight", ctx())
                        });
                    }
                }
            }
        }
    }
}

/// The Fresnel reference itself: R = ((η − 1)/(η + 1))² at normal incidence, 1 beyond the
/// critical angle, 1 at the horizon, and the same from both sides at corresponding angles
/// (Stokes relations: R(θ outside) = R(θt inside)).
#[test]
fn fresnel_reference_is_right() {
    let eta = 1.5;
    assert!((fresnel_f64(DVec3::Z, eta) - 0.04).abs() < 1e-15);
    assert!((fresnel_f64(-DVec3::Z, eta) - 0.04).abs() < 1e-15);
    assert_eq!(
        fresnel_f64(dir(0.8, 0.0).as_dvec3() * DVec3::new(1.0, 1.0, -1.0), eta),
        1.0
    );
    assert!((fresnel_f64(DVec3::new(1.0, 0.0, 1e-12), eta) - 1.0).abs() < 1e-10);
    for theta in [0.2f64, 0.7, 1.2, 1.5] {
        let wo = DVec3::new(theta.sin(), 0.0, theta.cos());
        let (wt, _) = refract_f64(wo, eta).unwrap();
        let from_inside = fresnel_f64(wt, eta);
        assert!(
            (fresnel_f64(wo, eta) - from_inside).abs() < 1e-12,
            "theta {theta}"
        );
        // Snell: sin θo = η sin θt.
        assert!((theta.sin() - eta * wt.truncate().length()).abs() < 1e-12);
    }
}

/// Unpolarised reflectance of a conductor with complex relative index η + ik (Born & Wolf §14.4),
/// in f64 complex arithmetic written out by hand: rs = (cos θ − n cos θt)/(cos θ + n cos θt),
/// rp = (n cos θ − cos θt)/(n cos θ + cos θt), n cos θt = √(n² − sin² θ).
fn conductor_fresnel_f64(cos: f64, eta: f64, k: f64) -> f64 {
    let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let norm2 = |a: (f64, f64)| a.0 * a.0 + a.1 * a.1;
    let sqrt = |a: (f64, f64)| {
        let r = norm2(a).sqrt();
        let re = ((r + a.0) / 2.0).sqrt();
        let im = ((r - a.0) / 2.0).sqrt().copysign(a.1);
        (re, im)
    };
    let n = (eta, k);
    let n2 = mul(n, n);
    let sin2 = 1.0 - cos * cos;
    let n_cos_t = sqrt((n2.0 - sin2, n2.1));
    let rs = norm2((cos - n_cos_t.0, -n_cos_t.1)) / norm2((cos + n_cos_t.0, n_cos_t.1));
    // rp = (n² cos θ − n cos θt)/(n² cos θ + n cos θt) (multiplying num and den by n).
    let n2c = (n2.0 * cos, n2.1 * cos);
    let rp = norm2((n2c.0 - n_cos_t.0, n2c.1 - n_cos_t.1))
        / norm2((n2c.0 + n_cos_t.0, n2c.1 + n_cos_t.1));
    0.5 * (rs + rp)
}

#[test]
fn conductor_reflects_exactly_with_weight_equal_to_its_fresnel_reflectance() {
    let (eta, k) = (GOLD_ETA, GOLD_K);
    let bsdf = Bsdf::Conductor { eta, k };
    let mut rng = rng(7102);
    for wo in incident_directions() {
        let cos = (wo.z as f64).abs();
        let expected = Rgb::new(
            conductor_fresnel_f64(cos, eta.r as f64, k.r as f64) as f32,
            conductor_fresnel_f64(cos, eta.g as f64, k.g as f64) as f32,
            conductor_fresnel_f64(cos, eta.b as f64, k.b as f64) as f32,
        );
        for mode in MODES {
            let s = bsdf
                .sample(wo, rng.random(), uniform2(&mut rng), mode)
                .unwrap_or_else(|| panic!("conductor, wo {wo}: no sample"));
            let ctx = || format!("conductor, wo {wo}, {mode:?}: {s:?}");
            assert_eq!(s.wi, mirror_direction(wo), "{}", ctx());
            assert_eq!(s.pdf, 1.0, "{}", ctx());
            assert!(s.delta && !s.transmission && s.lobe == LobeClass::Specular);
            assert_rgb_rel(s.weight, expected, 1e-4, &|| format!("{}: weight", ctx()));
        }
    }
    // k = 0 is a dielectric seen from outside: the same reflectance as the smooth interface.
    for cos in [1.0f64, 0.7, 0.2, 1e-3] {
        let r = conductor_fresnel_f64(cos, 1.5, 0.0);
        let wo = Vec3::new((1.0 - cos * cos).sqrt() as f32, 0.0, cos as f32);
        let d = Bsdf::Dielectric { eta: 1.5 };
        let s = d
            .sample(wo, 0.0, Vec2::ZERO, TransportMode::Radiance)
            .unwrap();
        assert!(
            (s.pdf as f64 - r).abs() < 1e-5,
            "cos {cos}: {} vs {r}",
            s.pdf
        );
    }
}

/// A thin sheet reflects R′ = 2R/(1 + R) with R the f64 Fresnel reflectance (the sum R + T²R +
/// T²R³ + … of the slab's inter-reflections) and transmits the rest along −wo, with weight 1 for
/// both lobes in both modes and no change of medium.
#[test]
fn thin_dielectric_sums_its_inter_reflections_and_transmits_straight_through() {
    for eta in [1.5f32, 1.0 / 1.5, 1.33] {
        let bsdf = Bsdf::ThinDielectric { eta };
        for wo in incident_directions() {
            let up = DVec3::new(wo.x as f64, wo.y as f64, wo.z.abs() as f64);
            let r = fresnel_f64(up, eta as f64);
            // Near the critical angle R changes faster than f32 resolves cos θ: skip those.
            let nudged = fresnel_f64(DVec3::new(up.x, up.y, up.z * (1.0 + 1e-5)), eta as f64);
            if (r - nudged).abs() > 1e-5 {
                continue;
            }
            let r_slab = 2.0 * r / (1.0 + r);
            for mode in MODES {
                for (u_lobe, reflect) in [(r_slab * 0.999, true), (r_slab * 1.001 + 1e-6, false)] {
                    if u_lobe >= 1.0 {
                        continue;
                    }
                    let s = bsdf
                        .sample(wo, u_lobe as f32, Vec2::new(0.3, 0.7), mode)
                        .unwrap_or_else(|| panic!("eta {eta}, wo {wo}: no sample"));
                    let ctx = || format!("thin eta {eta}, wo {wo}, {mode:?}, u {u_lobe}: {s:?}");
                    assert_eq!(s.transmission, !reflect, "{}", ctx());
                    let want_wi = if reflect { mirror_direction(wo) } else { -wo };
                    assert_eq!(s.wi, want_wi, "{}", ctx());
                    let p = if reflect { r_slab } else { 1.0 - r_slab };
                    assert!((s.pdf as f64 - p).abs() < 2e-6, "{}: pdf vs {p}", ctx());
                    assert_rgb_rel(s.weight, Rgb::WHITE, 1e-5, &|| ctx());
                    assert!(s.delta && s.eta == 1.0 && s.lobe == LobeClass::Specular);
                }
            }
        }
    }
}
