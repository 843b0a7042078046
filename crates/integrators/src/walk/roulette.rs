//! Russian roulette (Arvo & Kirk 1990; pbrt-v4 §14.5.1), applied by the walk's scatter step alone.

use lightlab_core::{Rgb, TransportMode};
use lightlab_materials::BsdfSample;

/// When and how hard a walk plays Russian roulette: the integrators' `russian_roulette` (start)
/// and `roulette_threshold` settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoulettePolicy {
    /// From this many scattering vertices on; `None`: never.
    pub start: Option<u32>,
    /// The relative throughput τ ∈ (0, 1] below which a path is played for (see [`Roulette`]).
    pub threshold: f32,
}

impl RoulettePolicy {
    /// No roulette: walks end only at their depth limit.
    pub const OFF: RoulettePolicy = RoulettePolicy {
        start: None,
        threshold: 1.0,
    };
}

/// A walk's roulette, weight-cutoff style (Arvo & Kirk 1990, §4): from `start` scattering
/// vertices on, a path whose throughput score s is below the threshold τ continues with
/// probability q = s / τ and is divided by q, so it carries on with score τ and the estimate stays
/// unbiased; paths scoring τ or more always continue. τ = 1 is survival in proportion to
/// throughput (pbrt-v4); a smaller τ ends fewer paths and gives the survivors smaller weights.
///
/// Past [`DEEP`] scattering vertices survival is at most [`DEEP_SURVIVAL`] whatever the score (as
/// Mitsuba 3 caps it at every depth), so a walk whose throughput does not fall — light trapped by
/// total internal reflection in a lossless dielectric, a hall of perfect mirrors — still ends
/// (after 20 more vertices on average) and the estimate stays unbiased. Such walks had run for
/// minutes, past any time budget; walks that deep are otherwise so rare that images do not change.
///
/// The score is β relative to the walk's starting throughput — light paths start with the
/// emitted flux, in units of power that scale with the scene, which no absolute threshold can
/// judge — and, for radiance, with the η² of every refraction so far divided out (radiance is
/// scaled by 1/η² on entering a denser medium; pbrt-v4 §13.4.4), so that paths inside glass are
/// not ended for a scale factor they lose again on leaving.
/// Scattering vertices after which survival is capped at [`DEEP_SURVIVAL`].
pub(crate) const DEEP: u32 = 64;
/// The largest survival probability past [`DEEP`] vertices.
const DEEP_SURVIVAL: f32 = 0.95;

#[derive(Clone, Copy, Debug)]
pub(crate) struct Roulette {
    start: Option<u32>,
    /// 1 / (τ · max component of the starting throughput).
    inv_beta_threshold: f32,
    eta_scale: f32,
    radiance: bool,
}

impl Roulette {
    pub fn new(policy: RoulettePolicy, mode: TransportMode, beta_start: Rgb) -> Roulette {
        Roulette {
            start: policy.start,
            inv_beta_threshold: 1.0 / (policy.threshold * beta_start.max_component()),
            eta_scale: 1.0,
            radiance: mode == TransportMode::Radiance,
        }
    }

    /// Whether the path, after scattering into `s` at its `depth`-th vertex with throughput
    /// `beta` now, continues; `u` is the roulette's uniform sample.
    #[inline]
    pub fn survives(&mut self, depth: u32, s: &BsdfSample, u: f32, beta: &mut Rgb) -> bool {
        if s.transmission && self.radiance {
            self.eta_scale *= s.eta * s.eta;
        }
        match self.start {
            Some(start) if depth >= start => {
                let cap = if depth >= DEEP { DEEP_SURVIVAL } else { 1.0 };
                let q = (beta.max_component() * self.inv_beta_threshold * self.eta_scale).min(cap);
                if !(u < q) {
                    return false;
                }
                *beta /= q;
                true
            }
            _ => true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use lightlab_materials::LobeClass;

    /// Survival in proportion to throughput (τ = 1) from depth `start`.
    fn from(start: u32) -> RoulettePolicy {
        RoulettePolicy {
            start: Some(start),
            threshold: 1.0,
        }
    }

    /// A refraction into glass of η = 1.5: radiance is scaled by 1/η² (weight 1/2.25), importance
    /// is not.
    fn into_glass(mode: TransportMode) -> BsdfSample {
        let w = if mode == TransportMode::Radiance {
            1.0 / 2.25
        } else {
            1.0
        };
        BsdfSample {
            wi: -Vec3::Z,
            f: Rgb::splat(w),
            pdf: 1.0,
            weight: Rgb::splat(w),
            lobe: LobeClass::Specular,
            transmission: true,
            eta: 1.5,
            delta: true,
        }
    }

    /// A reflection of weight 1 (no η² to divide out).
    fn reflection() -> BsdfSample {
        BsdfSample {
            transmission: false,
            eta: 1.0,
            ..into_glass(TransportMode::Importance)
        }
    }

    /// Inside glass a radiance path keeps its full chance of survival: the η² it lost on entering
    /// is not held against it (pbrt-v4 §13.4.4). A light path (importance) is not rescaled.
    #[test]
    fn radiance_roulette_divides_out_the_refraction_scale() {
        let s = into_glass(TransportMode::Radiance);
        let mut beta = s.weight;
        let mut r = Roulette::new(from(0), TransportMode::Radiance, Rgb::WHITE);
        assert!(r.survives(1, &s, 0.999, &mut beta));
        assert_eq!(beta, s.weight, "q = 1 leaves β alone");

        // The same throughput on a light path is a real loss of flux: q = 1/2.25.
        let mut beta = s.weight;
        let mut r = Roulette::new(from(0), TransportMode::Importance, Rgb::WHITE);
        assert!(!r.survives(1, &s, 0.5, &mut beta));
        let mut beta = s.weight;
        let mut r = Roulette::new(from(0), TransportMode::Importance, Rgb::WHITE);
        assert!(r.survives(1, &s, 0.3, &mut beta));
        assert!((beta.r - 1.0).abs() < 1e-6, "β/q = 1, got {beta:?}");
    }

    /// Roulette starts at its depth and scores β relative to the walk's start.
    #[test]
    fn roulette_starts_at_its_depth_relative_to_the_start() {
        let s = reflection();
        let mut r = Roulette::new(from(3), TransportMode::Importance, Rgb::splat(100.0));
        let mut beta = Rgb::splat(50.0);
        assert!(r.survives(2, &s, 0.99, &mut beta), "before the start depth");
        assert_eq!(beta, Rgb::splat(50.0));
        assert!(!r.survives(3, &s, 0.6, &mut beta), "q = 50/100");
        let mut beta = Rgb::splat(50.0);
        assert!(r.survives(3, &s, 0.4, &mut beta));
        assert_eq!(beta, Rgb::splat(100.0));
    }

    /// Below the threshold τ a path survives with probability score/τ and carries on with score
    /// τ; at or above it the path always continues, unchanged. The survivors' mean weight keeps
    /// the estimate unbiased: E[β′] = q · β/q = β.
    #[test]
    fn a_threshold_plays_only_for_paths_below_it() {
        let s = reflection();
        let policy = RoulettePolicy {
            start: Some(1),
            threshold: 0.5,
        };
        let mut r = Roulette::new(policy, TransportMode::Importance, Rgb::splat(2.0));
        let mut beta = Rgb::splat(1.0);
        assert!(
            r.survives(1, &s, 0.999, &mut beta),
            "score 1/2 = τ: no roulette"
        );
        assert_eq!(beta, Rgb::splat(1.0));
        let mut beta = Rgb::new(0.1, 0.4, 0.2);
        assert!(
            !r.survives(1, &s, 0.81, &mut beta),
            "q = 0.4/2 / 0.5 = 0.4 < 0.81"
        );
        let mut beta = Rgb::new(0.1, 0.4, 0.2);
        assert!(r.survives(1, &s, 0.39, &mut beta));
        assert!(
            (beta.g - 1.0).abs() < 1e-6 && (beta.r - 0.25).abs() < 1e-6,
            "score τ: β/q = β/0.4, got {beta:?}"
        );
    }

    /// A lossless walk (score never below τ) survives every vertex before `DEEP`, and from there
    /// on with probability 0.95, its weight divided by it: it ends, and stays unbiased.
    #[test]
    fn deep_walks_end_even_when_lossless() {
        let s = reflection();
        let mut r = Roulette::new(from(1), TransportMode::Importance, Rgb::WHITE);
        let mut beta = Rgb::WHITE;
        assert!(r.survives(DEEP - 1, &s, 0.999, &mut beta));
        assert_eq!(beta, Rgb::WHITE);
        assert!(!r.survives(DEEP, &s, 0.96, &mut beta));
        let mut beta = Rgb::WHITE;
        assert!(r.survives(DEEP, &s, 0.94, &mut beta));
        assert!((beta.r - 1.0 / 0.95).abs() < 1e-6, "β/0.95, got {beta:?}");
    }
}
