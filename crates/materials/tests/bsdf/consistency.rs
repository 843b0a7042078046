//! sample(), eval() and pdf() describe the same thing: for every sample, f = eval(wo, wi).f,
//! pdf = eval(wo, wi).pdf_fwd = pdf(wo, wi), weight = eval's f·|cos θi| / pdf(wo, wi), and
//! eval(wo, wi).pdf_rev = eval(wi, wo).pdf_fwd; a plastic's delta sample carries the coating's
//! Fresnel reflection ks·F(cos θo), from an independent evaluation of Fresnel's equations.
//! Deterministic (no statistics involved).

use crate::common::*;
use lightlab_core::{Rgb, TransportMode, Vec3};
use lightlab_materials::{Bsdf, BsdfSample, LobeClass};
use rand::RngExt;

const REL: f32 = 1e-3;

fn check_sample_consistency(bsdf: Bsdf, wos: &[Vec3], seed: u64) {
    for &wo in wos {
        for mode in MODES {
            let mut rng = rng(seed);
            let n = 4000;
            let mut found = 0;
            let p_delta = bsdf.delta_probability(wo);
            for _ in 0..n {
                let u_lobe: f32 = rng.random();
                let Some(s) = bsdf.sample(wo, u_lobe, uniform2(&mut rng), mode) else {
                    continue;
                };
                found += 1;
                let ctx = || format!("{bsdf:?}, wo {wo}, {mode:?}, wi {}", s.wi);
                assert!((s.wi.length() - 1.0).abs() < 1e-4, "{}: |wi| != 1", ctx());
                // A delta lobe is taken exactly when u_lobe < delta_probability(wo).
                assert_eq!(s.delta, u_lobe < p_delta, "{}: P = {p_delta}", ctx());
                if s.delta {
                    check_mixed_delta_sample(bsdf, wo, &s, p_delta);
                    continue;
                }
                assert_eq!(s.transmission, s.wi.z * wo.z < 0.0, "{}", ctx());
                let e = bsdf.eval(wo, s.wi, mode);
                let weight = e.f * (s.wi.z.abs() / bsdf.pdf(wo, s.wi));
                assert_rgb_rel(s.weight, weight, REL, &|| format!("{}: weight", ctx()));
                assert_rgb_rel(s.f, e.f, REL, &|| format!("{}: f vs eval", ctx()));
                assert_rel(s.pdf, e.pdf_fwd, REL, &|| format!("{}: pdf vs eval", ctx()));
                assert_rel(e.pdf_fwd, bsdf.pdf(wo, s.wi), REL, &|| {
                    format!("{}: eval pdf vs pdf()", ctx())
                });
                let rev = bsdf.eval(s.wi, wo, mode);
                assert_rel(e.pdf_rev, rev.pdf_fwd, REL, &|| {
                    format!("{}: pdf_rev vs reversed pdf_fwd", ctx())
                });
                assert_rel(rev.pdf_rev, e.pdf_fwd, REL, &|| {
                    format!("{}: reversed pdf_rev vs pdf_fwd", ctx())
                });
                if let (Bsdf::RoughDielectric { eta, .. }, true) = (bsdf, s.transmission) {
                    let etap = if wo.z > 0.0 { eta } else { 1.0 / eta };
                    assert_rel(s.eta, etap, 1e-6, &|| format!("{}: eta", ctx()));
                } else {
                    assert_eq!(s.eta, 1.0, "{}: eta of a reflection", ctx());
                }
            }
            assert!(
                found >= n / 10,
                "{bsdf:?}, wo {wo}, {mode:?}: only {found} of {n} samples succeeded"
            );
        }
    }
}

/// The delta sample of a BSDF that mixes delta and non-delta lobes (smooth plastic): the mirror
/// direction, invisible to eval and pdf, with the selection probability as its pdf and
/// weight · pdf = ks·F(cos θo), the coating's reflection.
fn check_mixed_delta_sample(bsdf: Bsdf, wo: Vec3, s: &BsdfSample, p_delta: f32) {
    let ctx = || format!("{bsdf:?}, wo {wo}, delta wi {}", s.wi);
    assert!(
        bsdf.mixes_delta() && s.lobe == LobeClass::Specular,
        "{}",
        ctx()
    );
    assert!(
        (s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6,
        "{}",
        ctx()
    );
    assert_eq!(s.pdf, p_delta, "{}", ctx());
    assert_eq!(bsdf.pdf(wo, s.wi), bsdf.eval(wo, s.wi, MODES[0]).pdf_fwd);
    let Bsdf::Plastic(plastic) = bsdf else {
        panic!("{}: only plastic mixes a delta lobe in", ctx());
    };
    let reflected = plastic.ks * fresnel_dielectric(wo.z.abs(), plastic.eta);
    assert_rgb_rel(s.weight * s.pdf, reflected, REL, &|| {
        format!("{}: weight · pdf against ks·F", ctx())
    });
}

/// What a delta BSDF's reflected and transmitted lobes carry, f·|cos θi| (= weight · pdf), from
/// Fresnel's equations evaluated here: a mirror its reflectance; a conductor the complex-index
/// reflectance; a dielectric R and T = 1 − R, T over η′² in radiance mode (pbrt-v4 §9.5.2); a thin
/// sheet R′ = 2R/(1 + R) and 1 − R′ (the slab's inter-reflections summed).
fn delta_lobes(bsdf: Bsdf, wo: Vec3, mode: TransportMode) -> (Rgb, Rgb) {
    let cos = wo.z.abs();
    match bsdf {
        Bsdf::Mirror { reflectance } => (reflectance, Rgb::BLACK),
        Bsdf::Conductor { eta, k } => (
            Rgb::new(
                fresnel_conductor(cos, eta.r, k.r),
                fresnel_conductor(cos, eta.g, k.g),
                fresnel_conductor(cos, eta.b, k.b),
            ),
            Rgb::BLACK,
        ),
        Bsdf::Dielectric { eta } => {
            let etap = if wo.z > 0.0 { eta } else { 1.0 / eta };
            let r = fresnel_dielectric(cos, etap);
            let t = match mode {
                TransportMode::Radiance => (1.0 - r) / (etap * etap),
                TransportMode::Importance => 1.0 - r,
            };
            (Rgb::splat(r), Rgb::splat(t))
        }
        Bsdf::ThinDielectric { eta } => {
            let r = fresnel_dielectric(cos, eta);
            let r = 2.0 * r / (1.0 + r);
            (Rgb::splat(r), Rgb::splat(1.0 - r))
        }
        _ => panic!("{bsdf:?} is not a delta BSDF"),
    }
}

/// Unpolarised reflectance of a conductor of complex index η + ik at cos θ = `cos_i`, in the
/// real-arithmetic form of Born & Wolf §14.4 (a² + b², a; the s and p reflectances averaged).
fn fresnel_conductor(cos_i: f32, eta: f32, k: f32) -> f32 {
    let (c, eta, k) = (cos_i as f64, eta as f64, k as f64);
    let (c2, s2) = (c * c, 1.0 - c * c);
    let t = eta * eta - k * k - s2;
    let a2b2 = (t * t + 4.0 * eta * eta * k * k).sqrt();
    let a = (0.5 * (a2b2 + t)).max(0.0).sqrt();
    let rs = (a2b2 - 2.0 * a * c + c2) / (a2b2 + 2.0 * a * c + c2);
    let rp =
        rs * (c2 * a2b2 - 2.0 * a * c * s2 + s2 * s2) / (c2 * a2b2 + 2.0 * a * c * s2 + s2 * s2);
    (0.5 * (rs + rp)) as f32
}

/// Unpolarised Fresnel reflectance of a smooth dielectric interface of relative index `eta`, lit
/// from outside at cos θ = `cos_i` (Born & Wolf §1.5; the average of the s and p reflectances).
fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let (cos_i, eta) = (cos_i as f64, eta as f64);
    let sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t2).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (0.5 * (rs * rs + rp * rp)) as f32
}

#[test]
fn diffuse_samples_agree_with_eval_and_pdf() {
    check_sample_consistency(diffuse(), &wos_both_sides(), 1);
}

#[test]
fn rough_conductor_samples_agree_with_eval_and_pdf() {
    for bsdf in rough_conductors() {
        check_sample_consistency(bsdf, &wos_both_sides(), 2);
    }
}

#[test]
fn rough_dielectric_samples_agree_with_eval_and_pdf() {
    for bsdf in rough_dielectrics() {
        check_sample_consistency(bsdf, &wos_both_sides(), 3);
    }
}

#[test]
fn phong_samples_agree_with_eval_and_pdf() {
    for bsdf in phongs() {
        check_sample_consistency(bsdf, &wos_both_sides(), 4);
    }
}

#[test]
fn plastic_samples_agree_with_eval_and_pdf() {
    for bsdf in plastics() {
        assert!(bsdf.mixes_delta() && !bsdf.is_delta());
        check_sample_consistency(bsdf, &wos_both_sides(), 7);
    }
}

#[test]
fn rough_plastic_samples_agree_with_eval_and_pdf() {
    for bsdf in rough_plastics() {
        assert!(!bsdf.mixes_delta() && !bsdf.is_delta());
        check_sample_consistency(bsdf, &wos_both_sides(), 8);
    }
}

#[test]
fn phong_reports_the_lobe_it_sampled() {
    let bsdf = phong(20.0);
    // p_diffuse = avg(kd) / (avg(kd) + avg(ks)) = (1/3) / (1/3 + 0.4) ≈ 0.4545.
    let wo = dir(0.5, 1.0);
    let mut rng = rng(5);
    for (u_lobe, lobe) in [(0.2, LobeClass::Diffuse), (0.8, LobeClass::Glossy)] {
        for _ in 0..100 {
            if let Some(s) = bsdf.sample(wo, u_lobe, uniform2(&mut rng), TransportMode::Radiance) {
                assert_eq!(s.lobe, lobe, "u_lobe {u_lobe}");
            }
        }
    }
}

#[test]
fn delta_bsdfs_have_no_density_and_follow_the_delta_convention() {
    let mut bsdfs = vec![
        mirror(),
        Bsdf::Conductor {
            eta: GOLD_ETA,
            k: GOLD_K,
        },
        Bsdf::ThinDielectric { eta: 1.5 },
    ];
    bsdfs.extend(dielectrics());
    let mut rng = rng(6);
    for bsdf in bsdfs {
        for wo in wos_both_sides() {
            for mode in MODES {
                for i in 0..64 {
                    let u_lobe = (i as f32 + 0.5) / 64.0;
                    let s = bsdf
                        .sample(wo, u_lobe, uniform2(&mut rng), mode)
                        .unwrap_or_else(|| panic!("{bsdf:?} wo {wo}: no sample"));
                    let ctx = || format!("{bsdf:?}, wo {wo}, {mode:?}, u_lobe {u_lobe}");
                    assert!(s.delta && s.lobe == LobeClass::Specular, "{}", ctx());
                    let e = bsdf.eval(wo, s.wi, mode);
                    assert!(e.f.is_black() && e.pdf_fwd == 0.0 && e.pdf_rev == 0.0);
                    assert_eq!(bsdf.pdf(wo, s.wi), 0.0);
                    assert!(s.pdf > 0.0 && s.pdf <= 1.0, "{}: pdf {}", ctx(), s.pdf);
                    let (reflected, transmitted) = delta_lobes(bsdf, wo, mode);
                    let want = if s.transmission {
                        transmitted
                    } else {
                        reflected
                    };
                    assert_rgb_rel(s.weight * s.pdf, want, 1e-4, &|| {
                        format!("{}: weight · pdf against the lobe's Fresnel factor", ctx())
                    });
                    let mirrored = Vec3::new(-wo.x, -wo.y, wo.z);
                    if let (true, Bsdf::ThinDielectric { .. }) = (s.transmission, bsdf) {
                        assert_eq!(s.wi, -wo, "{}: a thin sheet passes light straight", ctx());
                        assert_eq!(s.eta, 1.0, "{}", ctx());
                    } else if s.transmission {
                        let Bsdf::Dielectric { eta } = bsdf else {
                            panic!("{}: transmission from a reflector", ctx())
                        };
                        let etap = if wo.z > 0.0 { eta } else { 1.0 / eta };
                        assert_eq!(s.eta, etap);
                        // Snell: sin θo = η′ sin θi, in the plane of incidence on the far side.
                        let sin_o = wo.truncate().length();
                        let sin_i = s.wi.truncate().length();
                        assert!((sin_o - etap * sin_i).abs() < 1e-5, "{}: Snell", ctx());
                        assert!(s.wi.truncate().dot(wo.truncate()) <= 0.0);
                    } else {
                        assert!((s.wi - mirrored).length() < 1e-6, "{}: not mirrored", ctx());
                    }
                }
            }
        }
    }
}
