//! ∫ pdf(wo, ω) dω over the sphere is ≤ 1, and equals the probability that `sample(wo)` returns a
//! direction (Diffuse: exactly 1), because pdf() is the density of what sample() returns and the
//! rest of the probability is lost samples.
//!
//! The integral is estimated by importance sampling from a fixed defensive mixture that knows
//! nothing about the BSDF's own sampling: uniform directions on the sphere plus uniform cones of
//! half-angle 0.002 … 1 rad around the lobe centres (mirror direction, and the refracted direction for
//! rough glass). So peaked lobes (α = 10⁻³, exponent 1000) are hit often enough for the estimate
//! and its standard error to mean something.
//!
//! Tolerance: 5 standard errors of the difference (two-sided false-failure probability ≈ 6·10⁻⁷
//! per check under the normal approximation; fixed seeds).

use crate::common::*;
use glam::DVec3;
use lightlab_core::{TransportMode, Vec3};
use lightlab_materials::Bsdf;
use rand::RngExt;
use rand_pcg::Pcg32;
use std::f64::consts::PI;

const N: usize = 200_000;
const CONE_ANGLES: [f64; 5] = [0.002, 0.01, 0.05, 0.2, 1.0];

/// Directions where the lobes of `bsdf` peak for `wo`.
fn lobe_centres(bsdf: Bsdf, wo: Vec3) -> Vec<DVec3> {
    let wo = wo.as_dvec3();
    let mut centres = vec![DVec3::new(-wo.x, -wo.y, wo.z)];
    if let Bsdf::RoughDielectric { eta, .. } = bsdf {
        let etap = if wo.z > 0.0 {
            eta as f64
        } else {
            1.0 / eta as f64
        };
        let sin2_t = (1.0 - wo.z * wo.z) / (etap * etap);
        if sin2_t < 1.0 {
            let cos_t = (1.0 - sin2_t).sqrt();
            centres.push(DVec3::new(
                -wo.x / etap,
                -wo.y / etap,
                -cos_t.copysign(wo.z),
            ));
        }
    }
    centres
}

/// The mixture: component 0 is the uniform sphere, then one cone per (centre, angle). Computed in
/// f64, with cone membership decided by chord length, so that tiny cones are sampled and tested
/// consistently.
struct Proposal {
    centres: Vec<DVec3>,
}

impl Proposal {
    fn components(&self) -> usize {
        1 + self.centres.len() * CONE_ANGLES.len()
    }

    fn sample(&self, rng: &mut Pcg32) -> Vec3 {
        let k = rng.random_range(0..self.components());
        if k == 0 {
            return uniform_sphere(rng);
        }
        let centre = self.centres[(k - 1) / CONE_ANGLES.len()];
        let angle = CONE_ANGLES[(k - 1) % CONE_ANGLES.len()];
        let (u, v): (f64, f64) = (rng.random(), rng.random());
        // Uniform in the cap: 1 − cos θ uniform in [0, 1 − cos θmax] = [0, 2 sin²(θmax/2)].
        let one_minus_cos = u * 2.0 * (0.5 * angle).sin().powi(2);
        let cos = 1.0 - one_minus_cos;
        let sin = (one_minus_cos * (2.0 - one_minus_cos)).sqrt();
        let (s, t) = centre.any_orthonormal_pair();
        let phi = 2.0 * PI * v;
        (s * (sin * phi.cos()) + t * (sin * phi.sin()) + centre * cos)
            .normalize()
            .as_vec3()
    }

    fn density(&self, w: Vec3) -> f64 {
        let w = w.as_dvec3().normalize();
        let mut sum = 1.0 / (4.0 * PI);
        for &c in &self.centres {
            let chord = (w - c).length();
            for angle in CONE_ANGLES {
                if chord <= 2.0 * (0.5 * angle).sin() {
                    sum += 1.0 / (2.0 * PI * 2.0 * (0.5 * angle).sin().powi(2));
                }
            }
        }
        sum / self.components() as f64
    }
}

fn pdf_integral(bsdf: Bsdf, wo: Vec3, seed: u64) -> MeanEstimate {
    let proposal = Proposal {
        centres: lobe_centres(bsdf, wo),
    };
    let mut rng = rng(seed);
    let mut est = MeanEstimate::default();
    for _ in 0..N {
        let w = proposal.sample(&mut rng);
        est.add_scalar((bsdf.pdf(wo, w) as f64 / proposal.density(w)) as f32);
    }
    est
}

fn success_probability(bsdf: Bsdf, wo: Vec3, seed: u64) -> f64 {
    let mut rng = rng(seed);
    let hits = (0..N)
        .filter(|_| {
            bsdf.sample(
                wo,
                rng.random(),
                uniform2(&mut rng),
                TransportMode::Radiance,
            )
            .is_some_and(|s| !s.delta)
        })
        .count();
    hits as f64 / N as f64
}

#[test]
fn diffuse_pdf_integrates_to_one() {
    for wo in wos_both_sides() {
        let est = pdf_integral(diffuse(), wo, 21);
        assert!(
            (est.mean(0) - 1.0).abs() <= 5.0 * est.sigma(0),
            "wo {wo}: {} ± {}",
            est.mean(0),
            est.sigma(0)
        );
    }
}

#[test]
fn pdf_integrates_to_the_probability_that_sampling_succeeds() {
    let mut bsdfs = rough_conductors();
    bsdfs.extend(rough_dielectrics());
    bsdfs.extend(phongs());
    bsdfs.extend(plastics());
    bsdfs.extend(rough_plastics());
    for bsdf in bsdfs {
        for wo in wos_both_sides() {
            let est = pdf_integral(bsdf, wo, 22);
            let p = success_probability(bsdf, wo, 23);
            let (integral, sigma) = (est.mean(0), est.sigma(0));
            let sigma_p = (p * (1.0 - p) / N as f64).sqrt();
            let tol = 5.0 * (sigma * sigma + sigma_p * sigma_p).sqrt();
            assert!(
                integral <= 1.0 + 5.0 * sigma,
                "{bsdf:?}, wo {wo}: ∫pdf = {integral} ± {sigma} > 1"
            );
            assert!(
                (integral - p).abs() <= tol,
                "{bsdf:?}, wo {wo}: ∫pdf = {integral} ± {sigma}, P(sample) = {p} ± {sigma_p}"
            );
        }
    }
}
