//! No NaN or infinity anywhere: a grid of extreme inputs (directions on and within 10⁻²⁰ of the
//! horizon, α from 10⁻⁴ (and 0) to 1, nearly index-matched and very dense dielectrics, extreme Phong
//! exponents and all-black materials). Deterministic.

use crate::common::*;
use lightlab_core::{Rgb, Vec2, Vec3};
use lightlab_materials::{Bsdf, Distribution, Plastic, RoughPlastic};

fn extreme_bsdfs() -> Vec<Bsdf> {
    let alphas = [
        Vec2::ZERO,
        Vec2::splat(1e-4),
        Vec2::splat(1e-3),
        Vec2::splat(0.05),
        Vec2::splat(1.0),
        Vec2::new(1e-4, 1.0),
        Vec2::new(1.0, 1e-4),
    ];
    let etas = [1.0001f32, 4.0, 1.0 / 1.0001, 0.25];
    let mut v = vec![
        Bsdf::Diffuse { albedo: Rgb::WHITE },
        Bsdf::Diffuse { albedo: Rgb::BLACK },
        Bsdf::Mirror {
            reflectance: Rgb::WHITE,
        },
    ];
    v.extend(etas.iter().map(|&eta| Bsdf::Dielectric { eta }));
    v.extend(etas.iter().map(|&eta| Bsdf::ThinDielectric { eta }));
    v.push(Bsdf::Conductor {
        eta: Rgb::new(0.01, 1.0, 20.0),
        k: Rgb::new(20.0, 0.0, 0.01),
    });
    for alpha in alphas {
        v.push(rough_conductor(alpha));
        for distribution in DISTRIBUTIONS {
            v.push(Bsdf::RoughConductor {
                alpha,
                eta: Rgb::new(0.01, 1.0, 20.0),
                k: Rgb::new(20.0, 0.0, 0.01),
                distribution,
            });
            v.extend(etas.iter().map(|&eta| Bsdf::RoughDielectric {
                alpha,
                eta,
                distribution,
            }));
        }
    }
    for exponent in [0.0, 1.0, 1e4] {
        v.push(phong(exponent));
        v.push(Bsdf::Phong {
            kd: Rgb::BLACK,
            ks: Rgb::WHITE,
            exponent,
        });
        v.push(Bsdf::Phong {
            kd: Rgb::BLACK,
            ks: Rgb::BLACK,
            exponent,
        });
    }
    for eta in etas {
        for (kd, ks) in [
            (Rgb::WHITE, Rgb::WHITE),
            (Rgb::BLACK, Rgb::WHITE),
            (Rgb::BLACK, Rgb::BLACK),
        ] {
            v.extend(
                [false, true].map(|nonlinear| Bsdf::Plastic(Plastic::new(kd, ks, eta, nonlinear))),
            );
            for (distribution, alpha) in [
                (Distribution::Ggx, 0.0),
                (Distribution::Ggx, 1e-4),
                (Distribution::Beckmann, 1e-4),
                (Distribution::Ggx, 10.0),
            ] {
                v.extend([false, true].map(|nonlinear| {
                    Bsdf::RoughPlastic(RoughPlastic::new(
                        kd,
                        ks,
                        distribution,
                        alpha,
                        eta,
                        nonlinear,
                    ))
                }));
            }
        }
    }
    v
}

fn extreme_directions() -> Vec<Vec3> {
    let mut v = Vec::new();
    for z in [1.0f32, 0.7, 1e-3, 1e-6, 1e-7, 1e-20, 0.0] {
        for phi in [0.0f32, 0.4, std::f32::consts::FRAC_PI_2, 2.5] {
            let r = (1.0 - z * z).sqrt();
            let w = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            v.push(w);
            v.push(Vec3::new(w.x, w.y, -z));
            v.push(Vec3::new(-w.x, -w.y, z));
        }
    }
    v
}

#[test]
fn no_nan_or_inf_at_extreme_inputs() {
    let dirs = extreme_directions();
    let us = [0.0f32, 1e-7, 0.3, 0.5, 0.9, 1.0 - f32::EPSILON];
    for bsdf in extreme_bsdfs() {
        for &wo in &dirs {
            for &wi in &dirs {
                for mode in MODES {
                    let e = bsdf.eval(wo, wi, mode);
                    assert!(
                        e.f.is_finite() && e.f.min_component() >= 0.0,
                        "{bsdf:?} eval({wo}, {wi}, {mode:?}).f = {:?}",
                        e.f
                    );
                    assert!(
                        e.pdf_fwd.is_finite() && e.pdf_fwd >= 0.0,
                        "{bsdf:?} eval({wo}, {wi}).pdf_fwd = {}",
                        e.pdf_fwd
                    );
                    assert!(e.pdf_rev.is_finite() && e.pdf_rev >= 0.0);
                }
                let p = bsdf.pdf(wo, wi);
                assert!(p.is_finite() && p >= 0.0, "{bsdf:?} pdf({wo}, {wi}) = {p}");
            }
            for mode in MODES {
                for &u_lobe in &us {
                    for &u0 in &us {
                        for &u1 in &us {
                            let Some(s) = bsdf.sample(wo, u_lobe, Vec2::new(u0, u1), mode) else {
                                continue;
                            };
                            let ctx =
                                format!("{bsdf:?} sample({wo}, {u_lobe}, ({u0}, {u1})): {s:?}");
                            assert!(
                                s.wi.is_finite() && (s.wi.length() - 1.0).abs() < 1e-3,
                                "{ctx}"
                            );
                            assert!(s.pdf.is_finite() && s.pdf > 0.0, "{ctx}");
                            assert!(s.f.is_finite() && s.f.min_component() >= 0.0, "{ctx}");
                            assert!(
                                s.weight.is_finite() && s.weight.min_component() >= 0.0,
                                "{ctx}"
                            );
                            assert!(s.eta.is_finite() && s.eta > 0.0, "{ctx}");
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn sample_rejects_wo_on_the_horizon() {
    for bsdf in extreme_bsdfs() {
        for mode in MODES {
            for wo in [
                Vec3::X,
                Vec3::new(0.6, -0.8, 0.0),
                Vec3::new(0.6, 0.8, -0.0),
            ] {
                assert!(
                    bsdf.sample(wo, 0.5, Vec2::splat(0.5), mode).is_none(),
                    "{bsdf:?}, wo {wo}"
                );
            }
        }
    }
}
