//! Directional albedo ρ(wo) = ∫ f(wo, wi)|cos θi| dωi = E[weight].
//!
//! In importance mode this integrand is f(wi, wo)|cos θi|, the fraction of light arriving from `wo`
//! that is scattered anywhere, so it must be ≤ 1 for every BSDF. In radiance mode the same holds for
//! reflection; refraction is scaled by 1/η′², so the bound is max(1, 1/η′²).
//!
//! Monte Carlo checks use 5σ of the estimate (one-sided false-failure probability ≈ 3·10⁻⁷ per
//! check under the normal approximation; seeds are fixed, so results are deterministic), plus 10⁻⁶
//! for f32 rounding where every sample has the same weight (σ = 0).

use crate::common::*;
use lightlab_core::{Rgb, TransportMode, Vec2, Vec3};
use lightlab_materials::{Bsdf, Distribution, Plastic};
use rand::RngExt;

fn albedo(bsdf: Bsdf, wo: Vec3, mode: TransportMode, n: usize, seed: u64) -> MeanEstimate {
    let mut rng = rng(seed);
    let mut est = MeanEstimate::default();
    for _ in 0..n {
        match bsdf.sample(wo, rng.random(), uniform2(&mut rng), mode) {
            Some(s) => est.add(s.weight),
            None => est.add(Rgb::BLACK),
        }
    }
    est
}

/// Largest albedo allowed in `mode` for `wo` (see module docs).
fn albedo_bound(bsdf: Bsdf, wo: Vec3, mode: TransportMode) -> f64 {
    match (bsdf, mode) {
        (Bsdf::RoughDielectric { eta, .. }, TransportMode::Radiance) => {
            let etap = if wo.z > 0.0 { eta } else { 1.0 / eta };
            (1.0 / (etap * etap)).max(1.0) as f64
        }
        _ => 1.0,
    }
}

#[test]
fn albedo_is_at_most_one() {
    let mut bsdfs = rough_conductors();
    bsdfs.extend(rough_dielectrics());
    bsdfs.extend(phongs());
    bsdfs.extend(plastics());
    bsdfs.extend(rough_plastics());
    // White Phong at the energy-conservation limit kd + ks = 1.
    bsdfs.push(Bsdf::Phong {
        kd: Rgb::splat(0.3),
        ks: Rgb::splat(0.7),
        exponent: 5.0,
    });
    for bsdf in bsdfs {
        for wo in wos_both_sides() {
            for mode in MODES {
                let est = albedo(bsdf, wo, mode, 50_000, 11);
                let bound = albedo_bound(bsdf, wo, mode);
                for c in 0..3 {
                    assert!(
                        est.mean(c) <= bound + 5.0 * est.sigma(c) + 1e-6,
                        "{bsdf:?}, wo {wo}, {mode:?}, channel {c}: albedo {} ± {} > {bound}",
                        est.mean(c),
                        est.sigma(c)
                    );
                }
            }
        }
    }
}

/// ∫ f(wo, wi)|cos θi| dωi over the whole sphere by the midpoint rule on a `n` × 2`n` grid in
/// (θi, φi), dω = sin θ dθ dφ: an answer that does not depend on the BSDF's sampling routine.
fn albedo_quadrature(bsdf: Bsdf, wo: Vec3, mode: TransportMode, n: usize) -> [f64; 3] {
    let (dt, dp) = (
        std::f64::consts::PI / n as f64,
        std::f64::consts::PI / n as f64,
    );
    let mut sum = [0.0f64; 3];
    for i in 0..n {
        let theta = (i as f64 + 0.5) * dt;
        let w = theta.sin() * dt * dp;
        for j in 0..2 * n {
            let wi = dir(theta as f32, ((j as f64 + 0.5) * dp) as f32);
            let f = bsdf.eval(wo, wi, mode).f;
            for c in 0..3 {
                sum[c] += f[c] as f64 * (wi.z.abs() as f64) * w;
            }
        }
    }
    sum
}

/// The albedo estimated by sampling, E[f·|cos θi|/p], equals the albedo integrated from `eval`
/// over the whole sphere: the sampling routine reaches every direction where f > 0, so no energy
/// is lost or gained between them (the bound above is one-sided, and the chi-square tests only
/// compare samples with `pdf`, not with f). Every non-delta model at roughness where a 512 × 1024
/// grid resolves the lobe (α ≥ 0.1, Phong exponents ≤ 20), at normal and 45° incidence on both
/// sides, in both modes. Tolerance: 5σ of the 50 000-sample estimate (two-sided false failures
/// ≈ 6·10⁻⁷ per check) plus 2·10⁻³ for the quadrature's error (at most 4.3·10⁻⁴ against a 2048 ×
/// 4096 grid, for anisotropic rough glass at normal incidence).
#[test]
fn sampled_albedo_equals_the_integral_of_eval() {
    let resolved = |bsdf: &Bsdf| match *bsdf {
        Bsdf::RoughConductor { alpha, .. } | Bsdf::RoughDielectric { alpha, .. } => {
            alpha.min_element() >= 0.1
        }
        Bsdf::Phong { exponent, .. } => exponent <= 20.0,
        Bsdf::RoughPlastic(p) => p.coating.alpha >= 0.1,
        _ => true,
    };
    let mut bsdfs = vec![diffuse()];
    bsdfs.extend(rough_conductors());
    bsdfs.extend(rough_dielectrics());
    bsdfs.extend(phongs());
    bsdfs.extend(rough_plastics());
    bsdfs.retain(resolved);
    assert!(bsdfs.len() >= 20, "{} models", bsdfs.len());
    let wos = [
        Vec3::Z,
        dir(std::f32::consts::FRAC_PI_4, 0.7),
        -Vec3::Z,
        -dir(std::f32::consts::FRAC_PI_4, 0.7),
    ];
    let mut seed = 100;
    for bsdf in bsdfs {
        for wo in wos {
            for mode in MODES {
                seed += 1;
                let est = albedo(bsdf, wo, mode, 50_000, seed);
                let want = albedo_quadrature(bsdf, wo, mode, 512);
                for c in 0..3 {
                    assert!(
                        (est.mean(c) - want[c]).abs() <= 5.0 * est.sigma(c) + 2e-3,
                        "{bsdf:?}, wo {wo}, {mode:?}, channel {c}: sampled {} ± {} vs integrated {}",
                        est.mean(c),
                        est.sigma(c),
                        want[c]
                    );
                }
            }
        }
    }
}

#[test]
fn diffuse_albedo_equals_albedo() {
    let Bsdf::Diffuse { albedo: rho } = diffuse() else {
        unreachable!()
    };
    for wo in wos_both_sides() {
        for mode in MODES {
            let est = albedo(diffuse(), wo, mode, 10_000, 12);
            for c in 0..3 {
                assert!(
                    (est.mean(c) - rho[c] as f64).abs() < 1e-5,
                    "wo {wo}, channel {c}: {} vs {}",
                    est.mean(c),
                    rho[c]
                );
            }
        }
    }
}

#[test]
fn mirror_albedo_equals_reflectance() {
    let Bsdf::Mirror { reflectance } = mirror() else {
        unreachable!()
    };
    for wo in wos_both_sides() {
        for mode in MODES {
            let est = albedo(mirror(), wo, mode, 100, 13);
            for c in 0..3 {
                assert!((est.mean(c) - reflectance[c] as f64).abs() < 1e-5);
            }
        }
    }
}

/// Reflected plus refracted f·|cos θi|, summed over the two discrete lobes exactly: R + T = 1 in
/// importance mode, R + T/η′² in radiance mode. At normal incidence R = ((η − 1)/(η + 1))².
#[test]
fn dielectric_energy_sums_to_one() {
    for bsdf in dielectrics() {
        let Bsdf::Dielectric { eta } = bsdf else {
            unreachable!()
        };
        for wo in wos_both_sides() {
            let etap = if wo.z > 0.0 { eta } else { 1.0 / eta };
            for mode in MODES {
                let u = Vec2::splat(0.5);
                let r = bsdf.sample(wo, 0.0, u, mode).unwrap();
                let t = bsdf.sample(wo, 1.0 - f32::EPSILON, u, mode).unwrap();
                assert!(!r.transmission);
                let reflected = r.f.r * r.wi.z.abs();
                let refracted = if t.transmission {
                    t.f.r * t.wi.z.abs()
                } else {
                    // Total internal reflection: both u_lobe values chose the reflection.
                    assert!(
                        (reflected - 1.0).abs() < 1e-6,
                        "{bsdf:?} wo {wo}: TIR but R != 1"
                    );
                    0.0
                };
                let total = match mode {
                    TransportMode::Importance => reflected + refracted,
                    TransportMode::Radiance => reflected + refracted * etap * etap,
                };
                assert!(
                    (total - 1.0).abs() < 1e-5,
                    "{bsdf:?}, wo {wo}, {mode:?}: R {reflected} + T {refracted} -> {total}"
                );
                if wo.z.abs() == 1.0 {
                    let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
                    assert!(
                        (reflected - f0).abs() < 1e-6,
                        "{bsdf:?}: R {reflected} vs {f0}"
                    );
                }
            }
        }
    }
}

/// The specular lobe's (n+2)/(2π) normalisation makes its albedo exactly ks at normal incidence
/// (Lafortune & Willems 1994), so the total is kd + ks there.
#[test]
fn phong_albedo_at_normal_incidence_is_kd_plus_ks() {
    for bsdf in phongs() {
        let Bsdf::Phong { kd, ks, .. } = bsdf else {
            unreachable!()
        };
        for mode in MODES {
            let est = albedo(bsdf, Vec3::Z, mode, 200_000, 14);
            for c in 0..3 {
                let expect = (kd[c] + ks[c]) as f64;
                assert!(
                    (est.mean(c) - expect).abs() <= 5.0 * est.sigma(c) + 1e-6,
                    "{bsdf:?}, channel {c}: {} ± {} vs {expect}",
                    est.mean(c),
                    est.sigma(c)
                );
            }
        }
    }
}

/// At α = 10⁻³ and normal incidence G2/G1 ≈ 1 and every microfacet normal is within ~0.1° of +z,
/// so the albedo is the conductor Fresnel reflectance ((n−1)² + k²)/((n+1)² + k²) to ~10⁻⁵.
#[test]
fn rough_conductor_with_small_alpha_reflects_the_fresnel_reflectance() {
    let bsdf = rough_conductor(Vec2::splat(1e-3));
    for wo in [Vec3::Z, -Vec3::Z] {
        for mode in MODES {
            let est = albedo(bsdf, wo, mode, 10_000, 15);
            for c in 0..3 {
                let (n, k) = (GOLD_ETA[c], GOLD_K[c]);
                let f0 = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
                assert!(
                    (est.mean(c) - f0 as f64).abs() < 1e-3,
                    "channel {c}: {} vs {f0}",
                    est.mean(c)
                );
            }
        }
    }
}

/// At α = 10⁻³ the rough dielectric approaches the smooth one: the probability of reflection is
/// the smooth Fresnel reflectance (binomial, 5σ plus 2·10⁻³ for the remaining roughness) and the
/// importance-mode albedo is G2/G1 ≈ 1.
#[test]
fn rough_dielectric_with_small_alpha_matches_smooth_dielectric() {
    for eta in ETAS {
        let rough = Bsdf::RoughDielectric {
            alpha: Vec2::splat(1e-3),
            eta,
            distribution: Distribution::Ggx,
        };
        let smooth = Bsdf::Dielectric { eta };
        for wo in [dir(0.6, 0.2), dir(0.3, 4.0), -dir(0.6, 0.2), -dir(0.3, 4.0)] {
            let mode = TransportMode::Importance;
            let r_smooth = smooth.sample(wo, 0.0, Vec2::ZERO, mode).unwrap().pdf as f64;
            let mut rng = rng(16);
            let n = 100_000;
            let (mut reflected, mut est) = (0usize, MeanEstimate::default());
            for _ in 0..n {
                let s = rough.sample(wo, rng.random(), uniform2(&mut rng), mode);
                reflected += s.is_some_and(|s| !s.transmission) as usize;
                est.add_scalar(s.map_or(0.0, |s| s.weight.r));
            }
            let p = reflected as f64 / n as f64;
            let sigma = (r_smooth * (1.0 - r_smooth) / n as f64).sqrt();
            assert!(
                (p - r_smooth).abs() <= 5.0 * sigma + 2e-3,
                "eta {eta}, wo {wo}: reflected {p} vs Fresnel {r_smooth}"
            );
            assert!(
                (est.mean(0) - 1.0).abs() < 2e-3,
                "eta {eta}, wo {wo}: albedo {}",
                est.mean(0)
            );
        }
    }
}

/// Unpolarised Fresnel reflectance in f64 for incidence cosine `c` (> 0) and relative index `eta`.
fn fresnel(c: f64, eta: f64) -> f64 {
    let s2 = (1.0 - c * c) / (eta * eta);
    if s2 >= 1.0 {
        return 1.0;
    }
    let t = (1.0 - s2).sqrt();
    let (rs, rp) = ((c - eta * t) / (c + eta * t), (eta * c - t) / (eta * c + t));
    0.5 * (rs * rs + rp * rp)
}

/// The albedo of the layered plastic in closed form: ks·F(θo) from the coating plus
/// (1 − F(θo))·kd(1 − F_dr,int)/(1 − kd·F_dr,int) from the base for the nonlinear form, which is
/// (1 − F(θo))·kd for the linear one (its ρ sums the series with kd once), F_dr,int integrated here
/// independently (midpoint rule, 10⁵ points). Exactly 1 for white linear plastic: the white
/// furnace. Monte Carlo at 5σ.
#[test]
fn plastic_albedo_is_the_layered_closed_form() {
    let mut bsdfs = plastics();
    bsdfs.push(Bsdf::Plastic(Plastic::new(
        Rgb::WHITE,
        Rgb::WHITE,
        1.5,
        false,
    )));
    for bsdf in bsdfs {
        let Bsdf::Plastic(p) = bsdf else {
            unreachable!()
        };
        let eta = p.eta as f64;
        let n = 100_000;
        let fdr_int = (0..n)
            .map(|i| {
                let mu = (i as f64 + 0.5) / n as f64;
                2.0 * fresnel(mu, 1.0 / eta) * mu / n as f64
            })
            .sum::<f64>();
        for wo in wos_both_sides() {
            let f_o = fresnel(wo.z.abs() as f64, eta);
            for mode in MODES {
                let est = albedo(bsdf, wo, mode, 100_000, 17);
                for c in 0..3 {
                    let kd = p.kd[c] as f64;
                    let base = if p.nonlinear {
                        kd * (1.0 - fdr_int) / (1.0 - kd * fdr_int)
                    } else {
                        kd
                    };
                    let expect = p.ks[c] as f64 * f_o + (1.0 - f_o) * base;
                    assert!(
                        (est.mean(c) - expect).abs() <= 5.0 * est.sigma(c) + 1e-5,
                        "{bsdf:?}, wo {wo}, channel {c}: {} ± {} vs {expect}",
                        est.mean(c),
                        est.sigma(c)
                    );
                }
            }
        }
    }
}

/// The rough plastic's albedo from its parts, each estimated independently here by sampling
/// `RoughDielectric` with the coating's interface (importance mode: weights are energy fractions):
/// ks·R(θo) from the coating plus T(θo)·ρ·T̄/η² from the base, with R and T the interface's
/// reflection and transmission albedos, T̄ = 2∫T(μ)μ dμ its cosine-weighted transmission from
/// outside, F_dr,int = 2∫R_int(μ)μ dμ its reflection from inside, and ρ = kd/(1 − F_dr,int)
/// (nonlinear: kd/(1 − kd·F_dr,int)). This checks the tabulated T, its interpolation, F_dr,int,
/// the 1/(πη²) normalisation and the lobe weights. Tolerance: 5σ of both estimates combined (the
/// parts' σ propagated to first order) plus 2·10⁻³ for the table (64 nodes, linear
/// interpolation) and the 128² quadrature behind it.
#[test]
fn rough_plastic_albedo_is_the_layered_model_of_its_interface() {
    const N: usize = 200_000;
    let mode = TransportMode::Importance;
    let mut rng = rng(18);
    // Reflected and transmitted energy of `interface` from `wo`, or from cosine-distributed
    // directions on `wo`'s side when `cosine`.
    let mut parts = |interface: Bsdf, wo: Vec3, cosine: bool| {
        let (mut r, mut t) = (MeanEstimate::default(), MeanEstimate::default());
        for _ in 0..N {
            let wo = if cosine {
                let u = uniform2(&mut rng);
                let (s, z) = (u.x.sqrt(), (1.0 - u.x).sqrt());
                let phi = std::f32::consts::TAU * u.y;
                Vec3::new(s * phi.cos(), s * phi.sin(), z.copysign(wo.z))
            } else {
                wo
            };
            let s = interface.sample(wo, rng.random(), uniform2(&mut rng), mode);
            let w = s.map_or(0.0, |s| s.weight.r);
            let transmitted = s.is_some_and(|s| s.transmission);
            r.add_scalar(if transmitted { 0.0 } else { w });
            t.add_scalar(if transmitted { w } else { 0.0 });
        }
        ((r.mean(0), r.sigma(0)), (t.mean(0), t.sigma(0)))
    };
    for bsdf in rough_plastics() {
        let Bsdf::RoughPlastic(p) = bsdf else {
            unreachable!()
        };
        let c = p.coating;
        let interface = Bsdf::RoughDielectric {
            alpha: Vec2::splat(c.alpha),
            eta: c.eta,
            distribution: c.distribution,
        };
        let eta2 = (c.eta as f64).powi(2);
        let (_, (t_bar, s_t_bar)) = parts(interface, Vec3::Z, true);
        let ((f_int, s_f_int), _) = parts(interface, -Vec3::Z, true);
        for wo in wos_both_sides() {
            let ((r, s_r), (t, s_t)) = parts(interface, Vec3::new(wo.x, wo.y, wo.z.abs()), false);
            let est = albedo(bsdf, wo, mode, N, 19);
            for ch in 0..3 {
                let (kd, ks) = (p.kd[ch] as f64, p.ks[ch] as f64);
                let denominator = 1.0 - if p.nonlinear { kd * f_int } else { f_int };
                let base = kd * t_bar / (denominator * eta2);
                let expect = ks * r + t * base;
                // First-order propagation of the parts' standard errors.
                let d_f = t * kd * t_bar / (denominator * denominator * eta2)
                    * if p.nonlinear { kd } else { 1.0 };
                let sigma2 = (ks * s_r).powi(2)
                    + (base * s_t).powi(2)
                    + (t * kd / (denominator * eta2) * s_t_bar).powi(2)
                    + (d_f * s_f_int).powi(2)
                    + est.sigma(ch).powi(2);
                assert!(
                    (est.mean(ch) - expect).abs() <= 5.0 * sigma2.sqrt() + 2e-3,
                    "{c:?}, wo {wo}, channel {ch}: {} ± {} vs {expect}",
                    est.mean(ch),
                    est.sigma(ch)
                );
            }
        }
    }
}

/// Sampling visible normals bounds a rough conductor's sample weight, F·G2/G1(wo) ≤ F ≤ 1, for
/// both distributions and at grazing incidence (Heitz 2018 §1; Heitz & d'Eon 2014 §5) — sampling
/// D(m) cos θm instead gives weights up to |wo·m| / (cos θo cos θm), unbounded as θo → 90°.
#[test]
fn rough_conductor_sample_weights_are_at_most_one() {
    let mut rng = rng(20);
    for bsdf in rough_conductors() {
        for wo in wos_both_sides() {
            for _ in 0..20_000 {
                let u = uniform2(&mut rng);
                if let Some(s) = bsdf.sample(wo, 0.5, u, TransportMode::Radiance) {
                    assert!(
                        s.weight.max_component() <= 1.0 + 1e-4,
                        "{bsdf:?}, wo {wo}, u {u}: weight {:?}",
                        s.weight
                    );
                }
            }
        }
    }
}
