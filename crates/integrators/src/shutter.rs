//! Time for estimators that share one instant among many paths.
//!
//! Path tracing, light tracing and BDPT draw each sample's time from their samplers
//! (`Camera::sample_time`, one dimension right after the pixel position). Methods whose paths
//! meet other paths of the same pass — photon mapping's visible points and photons, VCM's merges
//! and connections — need those paths to see one scene, so a pass takes one instant for all of
//! them (pbrt-v4's SPPM had to learn this: photons and visible points of different times mix two
//! scenes). The passes' instants are an Owen-scrambled van der Corput sequence over the pass index
//! (Owen 1995): each one uniform over the shutter, so every pass is an unbiased sample of the
//! time integral, and the first 2ᵏ passes stratified into 2ᵏ equal intervals.

use lightlab_samplers::lowdiscrepancy::owen_scrambled_radical_inverse;
use lightlab_scene::Camera;

/// Seed word of the passes' instants.
const TIME_STREAM: u64 = 0x7e3a_9c1d_52b8_04f6;

/// What the variance layer of a render whose passes take these instants is: the spread over the
/// passes, which the instants' stratification makes an upper bound on the variance of the mean
/// rather than an estimate of it (so experiments do not subtract it from a reference's error).
pub(crate) fn instants_variance() -> crate::render::PixelVariance {
    crate::render::PixelVariance::NotAnEstimate(
        "an upper bound: the passes take stratified shutter instants (Owen-scrambled van der \
         Corput), so their spread overestimates the variance of the mean"
            .into(),
    )
}

/// The instant of pass `pass` of a render with `seed`.
pub(crate) fn pass_time(camera: &Camera, seed: u64, pass: u64) -> f32 {
    let (open, close) = camera.shutter;
    if close > open {
        let u = owen_scrambled_radical_inverse(pass, 2, seed ^ TIME_STREAM);
        open + (close - open) * u
    } else {
        open
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_cover_the_shutter_in_strata() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.ron");
        let mut camera = lightlab_scene::load_scene(&path).unwrap().camera;
        assert_eq!(pass_time(&camera, 1, 5), 0.0);
        camera.shutter = (2.0, 4.0);
        for seed in [1, 2] {
            let mut strata = [0; 16];
            for pass in 0..16 {
                let t = pass_time(&camera, seed, pass);
                assert!((2.0..4.0).contains(&t));
                strata[((t - 2.0) * 8.0) as usize] += 1;
            }
            assert_eq!(strata, [1; 16], "seed {seed}");
        }
        assert_ne!(pass_time(&camera, 1, 3), pass_time(&camera, 2, 3));
    }
}
