//! Russian roulette (Arvo & Kirk 1990; pbrt-v4 §14.5.1), shared by every path-building loop.

use lightlab_core::Rgb;

/// From `start` scattering vertices on (`None`: never), continues a path of `depth` vertices with
/// probability q = min(1, `score`) and divides its throughput by q, so the estimate stays unbiased;
/// `false` means the path ends here. `u` is the roulette's uniform sample.
#[inline]
pub(crate) fn survives(start: Option<u32>, depth: u32, score: f32, u: f32, beta: &mut Rgb) -> bool {
    match start {
        Some(start) if depth >= start => {
            let q = score.min(1.0);
            if !(u < q) {
                return false;
            }
            *beta /= q;
            true
        }
        _ => true,
    }
}
