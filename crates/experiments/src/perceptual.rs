//! Perceptual error: ꟻLIP (Andersson et al. 2020, "ꟻLIP: A Difference Evaluator for Alternating
//! Images", HPG), computed by NVIDIA's reference implementation (the `nv-flip` bindings) on the
//! 8-bit sRGB previews of the two images (exposure 0, clipped to [0, 1]: the LDR form of the
//! metric, for images as a viewer sees them), at 67 pixels per degree (a 0.7 m wide 4K monitor
//! seen from 0.7 m, the paper's default). The per-pixel error is in [0, 1]; its mean over the
//! image is the single number the authors recommend.

/// ꟻLIP of an image against a reference.
pub struct Flip {
    /// Mean of the error map.
    pub mean: f64,
    /// The error map, row by row from the top, in [0, 1].
    pub map: Vec<f32>,
}

/// ꟻLIP of `test` against `reference`, both `width` × `height` linear RGB; `None` when the sizes
/// differ.
pub fn flip(reference: &[[f32; 3]], test: &[[f32; 3]], width: u32, height: u32) -> Option<Flip> {
    let n = width as usize * height as usize;
    if reference.len() != n || test.len() != n || n == 0 {
        return None;
    }
    let image = |p: &[[f32; 3]]| {
        nv_flip::FlipImageRgb8::with_data(width, height, &crate::image_io::to_srgb8(p, 0.0))
    };
    let map = nv_flip::flip(
        image(reference),
        image(test),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let map = map.to_vec();
    let mean = map.iter().map(|&e| e as f64).sum::<f64>() / n as f64;
    Some(Flip { mean, map })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth test image and a copy with noise of amplitude `a` (fixed pseudo-random pattern).
    fn images(a: f32) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
        let (w, h) = (64, 48);
        let clean: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32 / w as f32, (i / w) as f32 / h as f32);
                [0.2 + 0.6 * x, 0.3 + 0.4 * y, 0.5]
            })
            .collect();
        let noisy = clean
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let u = ((i as u32).wrapping_mul(2_654_435_761) >> 8) as f32 / (1 << 24) as f32;
                p.map(|c| (c + a * (u - 0.5)).max(0.0))
            })
            .collect();
        (clean, noisy)
    }

    #[test]
    fn flip_is_zero_for_equal_images_and_grows_with_the_noise() {
        let (clean, _) = images(0.0);
        let same = flip(&clean, &clean, 64, 48).unwrap();
        assert_eq!(same.mean, 0.0);
        assert_eq!(same.map.len(), 64 * 48);
        let means: Vec<f64> = [0.05, 0.2, 0.6]
            .iter()
            .map(|&a| {
                let (clean, noisy) = images(a);
                flip(&clean, &noisy, 64, 48).unwrap().mean
            })
            .collect();
        assert!(
            means[0] > 0.0 && means[0] < means[1] && means[1] < means[2] && means[2] <= 1.0,
            "{means:?}"
        );
        assert!(flip(&clean, &clean[1..], 64, 48).is_none());
    }
}
