//! Helmholtz reciprocity f(wo, wi) = f(wi, wo) for reflection, the generalised reciprocity
//! f(wo, wi)/η_o² = f(wi, wo)/η_i² for refraction in radiance mode (Veach 1997, eq. 5.14; η_o, η_i
//! the indices on the sides of wo and wi), and importance mode being the adjoint
//! f*(wo, wi) = f(wi, wo). Deterministic.
//!
//! Direction pairs: `wi` drawn from sample(wo) (inside the lobe, where f is large) and uniformly on
//! the sphere (everywhere else), for the usual three incidences on both sides plus random `wo`.

use crate::common::*;
use lightlab_core::{TransportMode, Vec3};
use lightlab_materials::Bsdf;
use rand::RngExt;

const REL: f32 = 1e-4;

/// Pairs (wo, wi) to test, half sampled from the BSDF and half uniform.
fn pairs(bsdf: Bsdf, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = rng(seed);
    let mut wos = wos_both_sides();
    wos.extend((0..10).map(|_| uniform_sphere(&mut rng)));
    let mut out = Vec::new();
    for wo in wos {
        for _ in 0..300 {
            let u_lobe = rng.random();
            let u = uniform2(&mut rng);
            if let Some(s) = bsdf.sample(wo, u_lobe, u, TransportMode::Radiance) {
                out.push((wo, s.wi));
            }
            out.push((wo, uniform_sphere(&mut rng)));
        }
    }
    out
}

/// Index of refraction on the side of `w` (outside = 1, inside = `eta`).
fn side_eta(bsdf: Bsdf, w: Vec3) -> f32 {
    match bsdf {
        Bsdf::RoughDielectric { eta, .. } if w.z < 0.0 => eta,
        _ => 1.0,
    }
}

fn check_reciprocity(bsdf: Bsdf, seed: u64, transmission: bool) {
    let mut checked = 0;
    for (wo, wi) in pairs(bsdf, seed) {
        if (wo.z * wi.z < 0.0) != transmission {
            continue;
        }
        let f = bsdf.eval(wo, wi, TransportMode::Radiance).f;
        let g = bsdf.eval(wi, wo, TransportMode::Radiance).f;
        let (eo, ei) = (side_eta(bsdf, wo), side_eta(bsdf, wi));
        assert_rgb_rel(f / (eo * eo), g / (ei * ei), REL, &|| {
            format!("{bsdf:?}: f({wo}, {wi}) vs f({wi}, {wo})")
        });
        checked += !f.is_black() as usize;
    }
    assert!(checked > 100, "{bsdf:?}: only {checked} non-zero pairs");
}

#[test]
fn diffuse_is_reciprocal() {
    check_reciprocity(diffuse(), 31, false);
}

#[test]
fn rough_conductor_is_reciprocal() {
    for bsdf in rough_conductors() {
        check_reciprocity(bsdf, 32, false);
    }
}

#[test]
fn phong_is_reciprocal() {
    for bsdf in phongs() {
        check_reciprocity(bsdf, 33, false);
    }
}

#[test]
fn plastic_is_reciprocal() {
    for bsdf in plastics() {
        check_reciprocity(bsdf, 34, false);
    }
}

#[test]
fn rough_plastic_is_reciprocal() {
    for bsdf in rough_plastics() {
        check_reciprocity(bsdf, 37, false);
    }
}

#[test]
fn rough_dielectric_reflection_is_reciprocal() {
    for bsdf in rough_dielectrics() {
        check_reciprocity(bsdf, 34, false);
    }
}

#[test]
fn rough_dielectric_transmission_obeys_generalised_reciprocity() {
    for bsdf in rough_dielectrics() {
        check_reciprocity(bsdf, 35, true);
    }
}

/// eval(wo, wi, Importance) = eval(wi, wo, Radiance) for every non-delta variant and direction
/// pair; for refraction this is what makes light tracing and path tracing agree.
#[test]
fn importance_mode_is_the_adjoint_of_radiance_mode() {
    let mut bsdfs = vec![diffuse()];
    bsdfs.extend(rough_conductors());
    bsdfs.extend(rough_dielectrics());
    bsdfs.extend(phongs());
    bsdfs.extend(plastics());
    bsdfs.extend(rough_plastics());
    for bsdf in bsdfs {
        for (wo, wi) in pairs(bsdf, 36) {
            let adjoint = bsdf.eval(wo, wi, TransportMode::Importance).f;
            let reversed = bsdf.eval(wi, wo, TransportMode::Radiance).f;
            assert_rgb_rel(adjoint, reversed, REL, &|| {
                format!("{bsdf:?}: f*({wo}, {wi}) vs f({wi}, {wo})")
            });
        }
    }
}
