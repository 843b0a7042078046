//! Sampler benchmark (BENCHMARKS.md, "Samplers' cost"): nanoseconds per path sample and per value of
//! each sampler on its own, one thread, for the path tracer's dimension layout of a three-bounce
//! path (pixel 2D, lens 2D, then per bounce 1D light choice, 2D light point, 1D BSDF lobe, 2D BSDF
//! direction, 1D roulette: 25 values), 64 samples per pixel. What a sampler adds to a render is
//! measured in `lightlab bench`; this isolates the sampler.
//!
//! Run: `cargo bench -p lightlab-samplers --bench samplers`.

use lightlab_samplers::{Sampler, SamplerConfig, SamplerVisitor};
use lightlab_testkit::timing::{build_simd, cpu_model};
use std::hint::black_box;
use std::time::Instant;

const SPP: u32 = 64;
const PIXELS: u64 = 64 * 64;
const BOUNCES: usize = 3;
const VALUES_PER_SAMPLE: usize = 4 + 7 * BOUNCES;
const REPETITIONS: usize = 5;

/// The fastest of [`REPETITIONS`] passes over every pixel's samples: seconds per path sample.
struct Time;

impl SamplerVisitor for Time {
    type Output = f64;

    fn visit<S: Sampler + Clone + Send + Sync + 'static>(self, sampler: S) -> f64 {
        let mut best = f64::INFINITY;
        for repetition in 0..REPETITIONS {
            let mut sampler = sampler.clone();
            let start = Instant::now();
            let mut sum = 0.0f32;
            for pixel in 0..PIXELS {
                for index in 0..SPP as u64 {
                    sum += path_sample(&mut sampler, repetition as u64, pixel, index);
                }
            }
            black_box(sum);
            best = best.min(start.elapsed().as_secs_f64());
        }
        best / (PIXELS * SPP as u64) as f64
    }
}

/// One path sample's values, summed. Not inlined, so that every sampler's calls are inlined into a
/// function of the same shape, as into the path tracer's loop (left to the compiler, it inlined some
/// samplers into the benchmark loop and called others, which moved their figures by 1.3–2×).
#[inline(never)]
fn path_sample<S: Sampler>(sampler: &mut S, seed: u64, pixel: u64, index: u64) -> f32 {
    sampler.start_pixel_sample(seed, pixel, index);
    let (film, lens) = (sampler.next_2d(), sampler.next_2d());
    let mut sum = film.x + film.y + lens.x + lens.y;
    for _ in 0..BOUNCES {
        let (choice, light) = (sampler.next_1d(), sampler.next_2d());
        let (lobe, direction) = (sampler.next_1d(), sampler.next_2d());
        let roulette = sampler.next_1d();
        sum += choice + light.x + light.y + lobe + direction.x + direction.y + roulette;
    }
    sum
}

fn main() {
    println!(
        "{} × {SPP} path samples of {VALUES_PER_SAMPLE} values, one thread, the fastest of \
         {REPETITIONS} passes; {} ({} build)\n",
        PIXELS,
        cpu_model().unwrap_or_else(|| "unknown CPU".into()),
        build_simd()
    );
    println!("| sampler | ns per path sample | ns per value | ÷ Independent |");
    println!("|---|---|---|---|");
    let independent = SamplerConfig::Independent.dispatch(SPP, Time);
    for config in SamplerConfig::ALL {
        let seconds = if config == SamplerConfig::Independent {
            independent
        } else {
            config.dispatch(SPP, Time)
        };
        println!(
            "| {} | {:.1} | {:.2} | {:.2} |",
            config.name(),
            seconds * 1e9,
            seconds * 1e9 / VALUES_PER_SAMPLE as f64,
            seconds / independent
        );
    }
}
