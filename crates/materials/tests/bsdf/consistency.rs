//! sample(), eval() and pdf() describe the same thing: for every sample,
//! weight = f·|cos θi|/pdf, f = eval(wo, wi).f, pdf = eval(wo, wi).pdf_fwd = pdf(wo, wi), and
//! eval(wo, wi).pdf_rev = eval(wi, wo).pdf_fwd. Deterministic (no statistics involved).

use crate::common::*;
use lightlab_core::{TransportMode, Vec3};
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
                let weight = s.f * (s.wi.z.abs() / s.pdf);
                assert_rgb_rel(s.weight, weight, REL, &|| format!("{}: weight", ctx()));
                let e = bsdf.eval(wo, s.wi, mode);
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

/// The delta sample of a BSDF that mixes delta and non-delta lobes: the mirror direction,
/// invisible to eval and pdf, with the selection probability as its pdf and
/// weight = f·|cos θi| / pdf.
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
    let weight = s.f * (s.wi.z.abs() / s.pdf);
    assert_rgb_rel(s.weight, weight, REL, &|| format!("{}: weight", ctx()));
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
    let mut bsdfs = vec![mirror()];
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
                    let weight = s.f * (s.wi.z.abs() / s.pdf);
                    assert_rgb_rel(s.weight, weight, 1e-5, &|| format!("{}: weight", ctx()));
                    let mirrored = Vec3::new(-wo.x, -wo.y, wo.z);
                    if s.transmission {
                        let Bsdf::Dielectric { eta } = bsdf else {
                            panic!("{}: transmission from a mirror", ctx())
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
                        if let Bsdf::Mirror { reflectance } = bsdf {
                            assert_rgb_rel(s.weight, reflectance, 1e-5, &|| ctx());
                        }
                    }
                }
            }
        }
    }
}
