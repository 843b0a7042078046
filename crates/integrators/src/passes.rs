//! The render driver: the image is rendered in *passes* over the sample index — pass after pass,
//! every pixel's samples i₀ … i₁ − 1 — until the budget is spent, a number of samples or a time.
//!
//! Why passes. (1) A time budget is then the same estimator as a sample budget: a render stopped
//! by the clock after N samples per pixel is bit for bit the render of N samples (every pixel adds
//! its samples in index order, and splats of sample index i are summed in a fixed order), so
//! progressive samplers (Sobol', Halton) keep their stratification and an equal-time comparison
//! compares the estimators themselves. (2) Honest variances: for light tracing and BDPT a light
//! path splats into any pixel, so one path's contributions to a pixel are correlated; the driver
//! makes the whole of sample index i — every path traced for it, splats included — one sample of
//! each pixel, and sample indices are independent and identically distributed, so s²/n over them
//! is the variance of the pixel mean (and the spread of per-index image averages the standard
//! error of the image average, however correlated pixels are).
//!
//! Work items are 16 × 16 tiles (of one sample index when the integrator splats); their results
//! are merged in tile order, so the image is bit-identical on any number of threads.

use crate::Integrator;
use crate::film::{Film, PixelSums};
use crate::paths::Router;
use crate::render::{Counters, PixelVariance, RenderOutput};
use crate::sink::Sink;
use lightlab_core::Progress;
use lightlab_samplers::{Sampler, SamplerConfig, SamplerVisitor};
use lightlab_scene::Scene;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// What `Integrator::render_passes` hands on to a render loop generic over its sampler.
pub(crate) struct RenderArgs<'a, 'b> {
    pub scene: &'a Scene,
    pub budget: &'a Budget,
    pub seed: u64,
    pub progress: &'a dyn Progress,
    pub on_pass: &'b mut dyn FnMut(u32, &Film) -> bool,
}

/// An integrator whose render loop is monomorphised per sampler type (the one `Integrator::sampler`
/// names).
pub(crate) trait SampledRender: Integrator {
    /// The render loop, with a freshly constructed sampler to clone per pixel sample.
    fn render_with<S: Sampler + Clone + Send + Sync + 'static>(
        &self,
        prototype: S,
        args: RenderArgs,
    ) -> RenderOutput;
}

/// Runs `integrator`'s render loop for the sampler type its settings name (constructed for the
/// budget's sample count, per replicate; a time budget's sequence starts as one sample would).
pub(crate) fn render_sampled<I: SampledRender>(
    integrator: &I,
    scene: &Scene,
    budget: &Budget,
    seed: u64,
    progress: &dyn Progress,
    on_pass: &mut dyn FnMut(u32, &Film) -> bool,
) -> RenderOutput {
    struct With<'i, 'a, 'b, I> {
        integrator: &'i I,
        args: RenderArgs<'a, 'b>,
    }
    impl<I: SampledRender> SamplerVisitor for With<'_, '_, '_, I> {
        type Output = RenderOutput;
        fn visit<S: Sampler + Clone + Send + Sync + 'static>(self, prototype: S) -> RenderOutput {
            self.integrator.render_with(prototype, self.args)
        }
    }
    let args = RenderArgs {
        scene,
        budget,
        seed,
        progress,
        on_pass,
    };
    // The sampler the settings name (`Integrator::sampler`; none: independent samples).
    let sampler = integrator.sampler().copied().unwrap_or_default();
    sampler.dispatch(
        budget.samples_or(1) / integrator.replicates().max(1),
        With { integrator, args },
    )
}

/// How much work a render may do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// Samples per pixel (camera paths per pixel; light paths per pixel for light tracing; passes
    /// for progressive photon mapping), ≥ 1.
    Samples(u32),
    /// Wall-clock seconds: samples (or passes) continue until the time is spent, the render
    /// stopping at the pass boundary nearest the budget (at least one sample).
    Seconds(f64),
}

impl Budget {
    /// The samples per pixel of a sample budget; `otherwise` for a time budget.
    pub fn samples_or(&self, otherwise: u32) -> u32 {
        match *self {
            Budget::Samples(n) => n,
            Budget::Seconds(_) => otherwise,
        }
    }

    /// Checks the budget: at least one sample, or a positive finite time.
    pub fn check(&self) -> Result<(), String> {
        match *self {
            Budget::Samples(0) => Err("a sample budget must be ≥ 1 sample per pixel".into()),
            Budget::Seconds(s) if !(s > 0.0 && s.is_finite()) => Err(format!(
                "a time budget must be a finite number of seconds > 0, got {s}"
            )),
            _ => Ok(()),
        }
    }
}

/// Decides how many samples each pass renders, keeps the progress bar, and says when to stop.
pub(crate) struct Schedule<'a> {
    budget: Budget,
    start: Instant,
    /// When the first pass started (setup such as photon tracing comes before it).
    first_pass: Option<Instant>,
    progress: &'a dyn Progress,
    /// Permille of a time budget reported so far.
    reported: AtomicU64,
    /// Every pass renders a multiple of this many samples (the sampler's replicates).
    step: u32,
}

impl<'a> Schedule<'a> {
    /// A schedule whose clock starts now; `work_per_sample` is what one sample index of every
    /// pixel advances the progress bar by (pixels, or 1 for a pass-counting integrator).
    pub fn new(budget: Budget, progress: &'a dyn Progress, work_per_sample: u64) -> Schedule<'a> {
        match budget {
            Budget::Samples(n) => progress.start(n as u64 * work_per_sample),
            Budget::Seconds(_) => progress.start(1000),
        }
        Schedule {
            budget,
            start: Instant::now(),
            first_pass: None,
            progress,
            reported: AtomicU64::new(0),
            step: 1,
        }
    }

    /// Seconds since the schedule started.
    pub fn elapsed(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// The number of samples of the next pass, `done` samples having been rendered, at most
    /// `preferred`; `None` when the budget is spent. Under a time budget the passes halve the
    /// remaining time, at the rate measured so far, and the render stops when the remaining time
    /// is less than half a one-step pass, so that it ends within half a step (a sample, or one per
    /// replicate) of the budget. Renders end on a multiple of the step (a sample budget is one
    /// already: `Integrator::check_budget`): passes are multiples of it, or, where the estimator
    /// renders one sample index per pass (`preferred` below the step: progressive photon
    /// mapping, VCM), a time budget continues to the next multiple before it stops.
    pub fn next_pass(&mut self, done: u32, preferred: u32) -> Option<u32> {
        let step = self.step;
        let preferred = if preferred >= step {
            preferred / step * step
        } else {
            preferred.max(1)
        };
        let n = match self.budget {
            Budget::Samples(n) => (done < n).then(|| preferred.min(n - done))?,
            Budget::Seconds(_) if !done.is_multiple_of(step) => preferred.min(step - done % step),
            Budget::Seconds(seconds) => {
                let since_first = self.first_pass.map(|f| f.elapsed().as_secs_f64());
                let steps = timed_pass(seconds, self.elapsed(), since_first, done / step)?;
                let room = (u32::MAX - done) / step;
                (room > 0)
                    .then(|| steps.clamp(1, room) * step)?
                    .min(preferred)
            }
        };
        self.first_pass.get_or_insert_with(Instant::now);
        Some(n)
    }

    /// Reports `work` units done (pixel samples, or passes; as `work_per_sample` counts them).
    pub fn advance(&self, work: u64) {
        match self.budget {
            Budget::Samples(_) => self.progress.advance(work),
            Budget::Seconds(seconds) => {
                let permille = ((self.elapsed() / seconds).min(1.0) * 1000.0) as u64;
                let before = self.reported.fetch_max(permille, Ordering::Relaxed);
                if permille > before {
                    self.progress.advance(permille - before);
                }
            }
        }
    }
}

/// The samples of the next pass under a time budget of `seconds`, `elapsed` seconds having passed
/// since the schedule started and `since_first_pass` since the first pass did (`None` before it),
/// with `done` samples rendered; `None` when the budget is spent. The first pass renders one sample;
/// later ones half the remaining time at the rate measured so far (at most doubling the count), and
/// the render stops when less than half a sample's time remains.
///
/// The count N reached is a stopping time: it depends on the clock, so on how long the samples
/// took, and so, weakly, on their values. The image is the render of N samples, but N is not
/// independent of it. Renewal theory gives the bias of a mean over N samples whose cost c
/// correlates with their value X: Cov(X, c) / (E[c] · E[N]) to first order (c is the whole sample
/// index's cost, summed over the image, so a pixel's share of the covariance is 1/pixels of a lone
/// pixel's). Relative to the standard error that is ρ(X, c) · CV(c) / √N, or ρ · CV(c_p) / (P · √N)
/// for a pixel among P of similar cost c_p, on average over budgets (when the cost of a sample
/// index hardly varies, N is nearly fixed and particular budgets give up to about
/// ρ / (√(2πP) · N)): second order in the MSE. `stopping_time_bias` checks the formula in the worst case, one pixel whose cost is its value.
fn timed_pass(seconds: f64, elapsed: f64, since_first_pass: Option<f64>, done: u32) -> Option<u32> {
    let Some(since_first) = since_first_pass else {
        return Some(1);
    };
    let per_sample = since_first / done.max(1) as f64;
    let remaining = seconds - elapsed;
    if done == u32::MAX || remaining < 0.5 * per_sample {
        return None;
    }
    let fit = (0.5 * remaining / per_sample.max(1e-12)).floor();
    Some((fit.min(done as f64).max(1.0) as u32).min(u32::MAX - done))
}

/// What the driver needs to know about an estimator.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PassSpec {
    pub width: u32,
    pub height: u32,
    /// Slots per pixel: the full image, the router's layers, any of the integrator's own.
    pub slots: usize,
    /// Whether samples splat into other pixels; each work item is then one sample index.
    pub splats: bool,
    /// Independent photon groups whose spread is each pixel's shared variance (0: none).
    pub groups: usize,
    /// Whether sample indices are independent and identically distributed (an independent
    /// sampler), so that the film's s²/n and the image's standard error are estimates.
    pub independent: bool,
    /// Independent replicates of the sampler (`lightlab_samplers::replicate_sample`; 1: none):
    /// sample index i belongs to replicate i mod R, passes are multiples of R, and each pixel's
    /// variance is the spread of its R replicate means, an estimate whatever the sampler.
    pub replicates: u32,
}

impl PassSpec {
    /// The full image and `router`'s layers over `scene`'s camera: no splats, no photon groups,
    /// independent sample indices. Estimators change what differs with `..`.
    pub fn layers(scene: &Scene, router: &Router) -> PassSpec {
        PassSpec {
            width: scene.camera.width,
            height: scene.camera.height,
            slots: 1 + router.layer_count(),
            splats: false,
            groups: 0,
            independent: true,
            replicates: 1,
        }
    }

    /// What the films' variance is for an estimator whose samples (`samples`, as the message names
    /// them) come from `sampler`: the replicates' spread, s²/n over independent samples, or no
    /// estimate.
    pub fn pixel_variance(&self, sampler: &SamplerConfig, samples: &str) -> PixelVariance {
        if self.replicates > 1 {
            PixelVariance::Replicates {
                replicates: self.replicates,
            }
        } else if self.independent {
            PixelVariance::Independent
        } else {
            PixelVariance::NotAnEstimate(sampler.correlation_note(samples))
        }
    }

    /// Bytes the driver holds at once for these images: a film per slot (each pixel's
    /// statistics, with its photon-group or replicate sums), and either the tiles' copies of them
    /// being merged back (`pixel_pass`) or the pass's pixel buffer and one sample index's values
    /// (`splat_pass`).
    pub fn bytes(&self) -> u64 {
        let cells = self.width as u64 * self.height as u64 * self.slots as u64;
        let per_cell = (size_of::<PixelSums>()
            + size_of::<[f64; 3]>()
                * (group_stride(self.groups) + replicate_stride(self.replicates)))
            as u64;
        let passing = if self.splats {
            (size_of::<[f64; 3]>() + size_of::<[f32; 3]>()) as u64
        } else {
            per_cell
        };
        cells.saturating_mul(per_cell + passing)
    }
}

/// What a render produced: one film per slot, the counters summed over work items, the samples
/// per pixel done, and each work item's own results in a fixed order.
pub(crate) struct PassOutput<E> {
    pub films: Vec<Film>,
    pub counters: Counters,
    pub spp: u32,
    pub extras: Vec<E>,
}

/// Tile edge in pixels: small enough to balance two cores on small images, large enough to amortise
/// scheduling.
const TILE: u32 = 16;
/// With splats, sample indices rendered concurrently are raised until there are this many work
/// items per pass (small images)…
const MIN_ITEMS: usize = 64;
/// …as long as their per-pixel buffers hold at most this many pixel slots; without splats, a
/// pass buffers at most this many per-sample tile sums.
const MAX_BUFFERED: usize = 1 << 22;

/// Renders pass after pass as `schedule` decides, calling `sample(x, y, index, sink, counters,
/// extra)` for every pixel sample, and `on_pass(samples done, full-image film)` after every pass
/// (false stops the render).
pub(crate) fn run_passes<E, F>(
    spec: &PassSpec,
    router: &Router,
    schedule: &mut Schedule,
    on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    sample: F,
) -> PassOutput<E>
where
    E: Default + Send,
    F: Fn(u32, u32, u64, &mut Sink, &mut Counters, &mut E) + Sync,
{
    drive(spec, router, schedule, on_pass, None, sample)
}

/// [`run_passes`] for estimators whose passes each start with work every pixel shares (the
/// photons of progressive photon mapping): `begin(pass, counters)` runs before pass `pass`
/// (0-based), and every pass renders one sample index, `index = pass`.
pub(crate) fn run_progressive_passes<E, F>(
    spec: &PassSpec,
    router: &Router,
    schedule: &mut Schedule,
    on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    begin: &mut dyn FnMut(u32, &mut Counters),
    sample: F,
) -> PassOutput<E>
where
    E: Default + Send,
    F: Fn(u32, u32, u64, &mut Sink, &mut Counters, &mut E) + Sync,
{
    drive(spec, router, schedule, on_pass, Some(begin), sample)
}

/// Samples per pass without splats. Each tile keeps its per-sample image sums (per slot and
/// photon group) until the pass ends, so a pass holds at most [`MAX_BUFFERED`] of them: one pass of
/// all 2³² − 1 samples asked for 10¹¹ bytes and aborted, and a million samples of a 256² image for
/// 6 GB. Splitting passes changes no result (a pixel's samples add up in index order either way).
fn pixel_pass_samples(tiles: usize, slots: usize, groups: usize) -> u32 {
    let per_sample = tiles * slots * (1 + groups);
    (MAX_BUFFERED / per_sample.max(1)).clamp(1, u32::MAX as usize) as u32
}

/// Work run before a pass, with its 0-based number.
type PassStart<'a> = &'a mut dyn FnMut(u32, &mut Counters);

/// The driver behind both.
fn drive<E, F>(
    spec: &PassSpec,
    router: &Router,
    schedule: &mut Schedule,
    on_pass: &mut dyn FnMut(u32, &Film) -> bool,
    mut begin: Option<PassStart>,
    sample: F,
) -> PassOutput<E>
where
    E: Default + Send,
    F: Fn(u32, u32, u64, &mut Sink, &mut Counters, &mut E) + Sync,
{
    let (width, height) = (spec.width, spec.height);
    let pixels = width as usize * height as usize;
    let tiles: Vec<(u32, u32)> = (0..height.div_ceil(TILE))
        .flat_map(|ty| (0..width.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    schedule.step = spec.replicates.max(1);
    let mut state = State {
        films: (0..spec.slots).map(|_| Film::new(width, height)).collect(),
        groups: vec![[0.0; 3]; pixels * spec.slots * group_stride(spec.groups)],
        image_groups: vec![[0.0; 3]; spec.slots * group_stride(spec.groups)],
        replicas: vec![[0.0; 3]; pixels * spec.slots * replicate_stride(spec.replicates)],
        image_replicas: vec![[0.0; 3]; spec.slots * replicate_stride(spec.replicates)],
        passes: vec![PixelSums::default(); spec.slots],
        counters: Counters::default(),
        extras: Vec::new(),
    };
    let preferred = if begin.is_some() {
        1
    } else if spec.splats {
        let by_items = MIN_ITEMS.div_ceil(tiles.len());
        let by_memory = (MAX_BUFFERED / (pixels * spec.slots).max(1)).max(1);
        by_items.min(by_memory) as u32
    } else {
        pixel_pass_samples(tiles.len(), spec.slots, spec.groups)
    };
    let mut done = 0u32;
    while let Some(n) = schedule.next_pass(done, preferred) {
        let indices = done as u64..done as u64 + n as u64;
        if let Some(begin) = begin.as_mut() {
            begin(done, &mut state.counters);
        }
        if spec.splats {
            splat_pass(spec, router, schedule, &tiles, indices, &mut state, &sample);
        } else {
            pixel_pass(spec, router, schedule, &tiles, indices, &mut state, &sample);
        }
        done += n;
        state.finish(spec);
        if !on_pass(done, &state.films[0]) {
            break;
        }
    }
    PassOutput {
        films: state.films,
        counters: state.counters,
        spp: done,
        extras: state.extras,
    }
}

/// The statistics accumulated so far.
struct State<E> {
    films: Vec<Film>,
    /// Per pixel and slot, the photon-group statistics (`accumulate_groups`) of its samples.
    groups: Vec<[f64; 3]>,
    /// Per slot, the photon-group statistics of the image average of each sample index.
    image_groups: Vec<[f64; 3]>,
    /// Per pixel, slot and replicate (`PassSpec::replicates` > 1), the sum of its samples.
    replicas: Vec<[f64; 3]>,
    /// Per slot and replicate, the sum of its sample indices' image averages.
    image_replicas: Vec<[f64; 3]>,
    /// Per slot: statistics of the image-wide average of each sample index.
    passes: Vec<PixelSums>,
    counters: Counters,
    extras: Vec<E>,
}

impl<E> State<E> {
    /// Sets each film's shared variance and image standard error from what has been summed.
    fn finish(&mut self, spec: &PassSpec) {
        if spec.replicates > 1 {
            self.finish_replicates(spec.replicates as usize);
            return;
        }
        let (g, stride) = (spec.groups, group_stride(spec.groups));
        if g > 1 {
            for (slot, film) in self.films.iter_mut().enumerate() {
                for (i, p) in film.pixels.iter_mut().enumerate() {
                    let acc = &self.groups[(i * spec.slots + slot) * stride..][..stride];
                    let camera = PixelSums {
                        shared_var: [0.0; 3],
                        ..*p
                    }
                    .variance_of_mean();
                    p.shared_var = shared_variance(acc, p.count, camera);
                }
            }
        }
        for (slot, film) in self.films.iter_mut().enumerate() {
            let passes = &self.passes[slot];
            film.image_se = (spec.independent && passes.count >= 2).then(|| {
                let mut var = passes.variance_of_mean();
                if g > 1 {
                    let acc = &self.image_groups[slot * stride..][..stride];
                    let shared = shared_variance(acc, passes.count, var);
                    for c in 0..3 {
                        var[c] += shared[c];
                    }
                }
                var.map(f64::sqrt)
            });
        }
    }

    /// With R replicates, each pixel's variance of the mean is the spread of its R replicate means:
    /// s²/R over them, R − 1 degrees of freedom (the randomised quasi-Monte Carlo estimate;
    /// L'Ecuyer & Lemieux 2002, eq. 2). It replaces s²/n over the samples (`m2` is kept 0, the
    /// estimate is `shared_var`); the image's standard error comes from the replicates' image
    /// averages the same way. Sample index i is replicate i mod R's, so after n samples replicate k
    /// holds ⌊n/R⌋ of them, one more if k < n mod R (renders end with equal replicates; passes in
    /// between need not).
    fn finish_replicates(&mut self, r: usize) {
        let n = self.films[0].pixels[0].count as usize;
        if n < r {
            // An empty replicate (only where `Integrator::check_budget` was bypassed): no estimate.
            for film in &mut self.films {
                film.pixels.iter_mut().for_each(|p| p.m2 = [0.0; 3]);
                film.image_se = None;
            }
            return;
        }
        let counts: Vec<f64> = (0..r)
            .map(|k| (n / r + (k < n % r) as usize) as f64)
            .collect();
        let spread = |sums: &[[f64; 3]]| -> [f64; 3] {
            std::array::from_fn(|c| {
                let means = sums.iter().zip(&counts).map(|(s, n)| s[c] / n);
                let mean = means.clone().sum::<f64>() / r as f64;
                let ss = means.map(|m| (m - mean).powi(2)).sum::<f64>();
                ss / (r * (r - 1)) as f64
            })
        };
        let slots = self.films.len();
        for (slot, film) in self.films.iter_mut().enumerate() {
            for (i, p) in film.pixels.iter_mut().enumerate() {
                p.m2 = [0.0; 3];
                p.shared_var = spread(&self.replicas[(i * slots + slot) * r..][..r]);
            }
            film.image_se = Some(spread(&self.image_replicas[slot * r..][..r]).map(f64::sqrt));
        }
    }
}

/// Entries per pixel and slot of replicate sums: R, or none without replicates.
fn replicate_stride(replicates: u32) -> usize {
    if replicates > 1 {
        replicates as usize
    } else {
        0
    }
}

/// Entries per slot of photon-group statistics: the G group sums and W.
fn group_stride(groups: usize) -> usize {
    if groups > 0 { groups + 1 } else { 0 }
}

/// Adds one sample's photon-group shares `shares` (G of them) to `acc`: Σ share_g per group, and
/// W += Σ_g (q_g − q̄)² with q_g = G·share_g, the sample's own estimate from group g alone.
fn accumulate_groups(acc: &mut [[f64; 3]], shares: impl Iterator<Item = [f64; 3]> + Clone) {
    let g = (acc.len() - 1) as f64;
    let (mut sum, mut sum_sq) = ([0.0f64; 3], [0.0f64; 3]);
    for (a, v) in acc.iter_mut().zip(shares) {
        for c in 0..3 {
            a[c] += v[c];
            sum[c] += v[c];
            sum_sq[c] += v[c] * v[c];
        }
    }
    let w = acc.last_mut().expect("W entry");
    for c in 0..3 {
        w[c] += g * g * sum_sq[c] - g * sum[c] * sum[c];
    }
}

/// The photon maps' share of the variance of a pixel mean over `n` camera samples, from its group
/// statistics `acc` (see `accumulate_groups`) — a two-way crossed random-effects design: sample k
/// with group g estimates Y_kg = A_k + q_kg, and the pixel mean is the mean of all Y_kg, whose
/// variance is σ²_camera/n + σ²_group/G + σ²_interaction/(nG). The camera samples' s²/n (already in
/// the film, `camera`) estimates σ²_camera/n + σ²_interaction/(nG); the spread of the group
/// estimates Q_g = G·Σ_k share_kg / n estimates σ²_group + σ²_interaction/n; the interaction's mean
/// square is (W − n(G − 1)s²(Q)) / ((n − 1)(G − 1)) (Searle, Casella & McCulloch 1992, §4.3), counted
/// once. The result is kept ≥ −`camera`, so the total variance is never negative.
fn shared_variance(acc: &[[f64; 3]], count: u64, camera: [f64; 3]) -> [f64; 3] {
    let g = acc.len() - 1;
    let (gf, n) = (g as f64, count as f64);
    if g < 2 || count < 2 {
        return [0.0; 3];
    }
    let mut out = [0.0; 3];
    for c in 0..3 {
        let q = |s: &[f64; 3]| gf * s[c] / n;
        let mean = acc[..g].iter().map(q).sum::<f64>() / gf;
        let s2 = acc[..g].iter().map(|s| (q(s) - mean).powi(2)).sum::<f64>() / (gf - 1.0);
        let interaction = (acc[g][c] - n * (gf - 1.0) * s2) / ((n - 1.0) * (gf - 1.0));
        out[c] = (s2 / gf - interaction / (n * gf)).max(-camera[c]);
    }
    out
}

fn to_f64(c: lightlab_core::Rgb) -> [f64; 3] {
    [c.r as f64, c.g as f64, c.b as f64]
}

fn tile_size(spec: &PassSpec, (x0, y0): (u32, u32)) -> (u32, u32) {
    (TILE.min(spec.width - x0), TILE.min(spec.height - y0))
}

/// A pass of an estimator that does not splat: each tile renders all the pass's samples of its
/// pixels and adds each to the pixel's statistics.
fn pixel_pass<E, F>(
    spec: &PassSpec,
    router: &Router,
    schedule: &Schedule,
    tiles: &[(u32, u32)],
    indices: std::ops::Range<u64>,
    state: &mut State<E>,
    sample: &F,
) where
    E: Default + Send,
    F: Fn(u32, u32, u64, &mut Sink, &mut Counters, &mut E) + Sync,
{
    struct TileOut<E> {
        sums: Vec<PixelSums>,
        groups: Vec<[f64; 3]>,
        replicas: Vec<[f64; 3]>,
        /// Per sample index and slot: Σ over the tile's pixels.
        image: Vec<[f64; 3]>,
        /// Per sample index, slot and photon group: Σ over the tile's pixels of the group's share.
        image_groups: Vec<[f64; 3]>,
        counters: Counters,
        extra: E,
    }
    let (slots, g) = (spec.slots, spec.groups);
    let stride = slots * group_stride(g);
    let r = replicate_stride(spec.replicates);
    let n = (indices.end - indices.start) as usize;
    let width = spec.width;
    let films = &state.films;
    let groups = &state.groups;
    let replicas = &state.replicas;
    let out: Vec<TileOut<E>> = tiles
        .par_iter()
        .map(|&(x0, y0)| {
            let (w, h) = tile_size(spec, (x0, y0));
            let mut t = TileOut {
                sums: Vec::with_capacity((w * h) as usize * slots),
                groups: Vec::with_capacity((w * h) as usize * stride),
                replicas: Vec::with_capacity((w * h) as usize * slots * r),
                image: vec![[0.0; 3]; n * slots],
                image_groups: vec![[0.0; 3]; n * slots * g],
                counters: Counters::default(),
                extra: E::default(),
            };
            let mut sink = Sink::new(router, (spec.width, spec.height), slots, g);
            for y in y0..y0 + h {
                for x in x0..x0 + w {
                    let i = (y * width + x) as usize;
                    let base = t.sums.len();
                    t.sums.extend(films.iter().map(|f| f.pixels[i]));
                    let gbase = t.groups.len();
                    t.groups
                        .extend_from_slice(&groups[i * stride..(i + 1) * stride]);
                    let rbase = t.replicas.len();
                    t.replicas
                        .extend_from_slice(&replicas[i * slots * r..(i + 1) * slots * r]);
                    sink.running = t.sums[base];
                    for (k, index) in indices.clone().enumerate() {
                        sink.clear();
                        sample(x, y, index, &mut sink, &mut t.counters, &mut t.extra);
                        for s in 0..slots {
                            let v = to_f64(sink.values[s]);
                            t.sums[base + s].add(v);
                            if r > 0 {
                                add_to(&mut t.replicas[rbase + s * r + index as usize % r], v);
                            }
                            let acc = &mut t.image[k * slots + s];
                            for c in 0..3 {
                                acc[c] += v[c];
                            }
                        }
                        for s in 0..slots * (g > 0) as usize {
                            let shares = &sink.group_values[s * g..(s + 1) * g];
                            let acc = &mut t.groups[gbase + s * (g + 1)..][..g + 1];
                            accumulate_groups(acc, shares.iter().map(|v| to_f64(*v)));
                            let image = &mut t.image_groups[(k * slots + s) * g..][..g];
                            for (acc, v) in image.iter_mut().zip(shares) {
                                let v = to_f64(*v);
                                for c in 0..3 {
                                    acc[c] += v[c];
                                }
                            }
                        }
                    }
                }
            }
            schedule.advance((w * h) as u64 * n as u64);
            t
        })
        .collect();
    let mut image = vec![[0.0f64; 3]; n * slots];
    let mut image_groups = vec![[0.0f64; 3]; n * slots * g];
    for (&(x0, y0), t) in tiles.iter().zip(out) {
        let (w, h) = tile_size(spec, (x0, y0));
        for k in 0..(w * h) as usize {
            let i = ((y0 + k as u32 / w) * width + x0 + k as u32 % w) as usize;
            for (s, film) in state.films.iter_mut().enumerate() {
                film.pixels[i] = t.sums[k * slots + s];
            }
            state.groups[i * stride..(i + 1) * stride]
                .copy_from_slice(&t.groups[k * stride..(k + 1) * stride]);
            state.replicas[i * slots * r..(i + 1) * slots * r]
                .copy_from_slice(&t.replicas[k * slots * r..(k + 1) * slots * r]);
        }
        for (acc, v) in image
            .iter_mut()
            .zip(&t.image)
            .chain(image_groups.iter_mut().zip(&t.image_groups))
        {
            for c in 0..3 {
                acc[c] += v[c];
            }
        }
        state.counters.merge(&t.counters);
        state.extras.push(t.extra);
    }
    add_image_averages(state, &image, slots, indices.start, r);
    if g > 0 {
        let pixels = state.films[0].pixels.len() as f64;
        for per_index in image_groups.chunks(slots * g) {
            for (s, shares) in per_index.chunks(g).enumerate() {
                let acc = &mut state.image_groups[s * (g + 1)..][..g + 1];
                accumulate_groups(acc, shares.iter().map(|v| v.map(|x| x / pixels)));
            }
        }
    }
}

/// Adds the image-wide average of each sample index (`image`: per index from `first` on and per
/// slot, Σ over pixels) to the per-slot statistics, and to its replicate's sum (`r` replicates,
/// 0 for none).
fn add_image_averages<E>(
    state: &mut State<E>,
    image: &[[f64; 3]],
    slots: usize,
    first: u64,
    r: usize,
) {
    let pixels = state.films[0].pixels.len() as f64;
    for (index, per_index) in (first..).zip(image.chunks(slots)) {
        for (s, (stats, sum)) in state.passes.iter_mut().zip(per_index).enumerate() {
            let average = sum.map(|x| x / pixels);
            stats.add(average);
            if r > 0 {
                add_to(
                    &mut state.image_replicas[s * r + index as usize % r],
                    average,
                );
            }
        }
    }
}

/// `acc += v`, per channel.
#[inline]
fn add_to(acc: &mut [f64; 3], v: [f64; 3]) {
    for c in 0..3 {
        acc[c] += v[c];
    }
}

/// A pass of an estimator that splats: every (sample index, tile) is a work item; each sample
/// index's contributions — to the samples' own pixels and splatted — are summed into one buffer
/// in tile order, and each pixel adds its buffer value as one sample.
fn splat_pass<E, F>(
    spec: &PassSpec,
    router: &Router,
    schedule: &Schedule,
    tiles: &[(u32, u32)],
    indices: std::ops::Range<u64>,
    state: &mut State<E>,
    sample: &F,
) where
    E: Default + Send,
    F: Fn(u32, u32, u64, &mut Sink, &mut Counters, &mut E) + Sync,
{
    struct ItemOut<E> {
        own: Vec<lightlab_core::Rgb>,
        splats: Vec<crate::sink::Splat>,
        counters: Counters,
        extra: E,
    }
    let slots = spec.slots;
    let width = spec.width;
    let films = &state.films;
    let items: Vec<(u64, (u32, u32))> = indices
        .clone()
        .flat_map(|index| tiles.iter().map(move |&t| (index, t)))
        .collect();
    let out: Vec<ItemOut<E>> = items
        .par_iter()
        .map(|&(index, (x0, y0))| {
            let (w, h) = tile_size(spec, (x0, y0));
            let mut sink = Sink::new(router, (spec.width, spec.height), slots, 0);
            let mut item = ItemOut {
                own: Vec::with_capacity((w * h) as usize * slots),
                splats: Vec::new(),
                counters: Counters::default(),
                extra: E::default(),
            };
            for y in y0..y0 + h {
                for x in x0..x0 + w {
                    sink.clear();
                    sink.running = films[0].pixels[(y * width + x) as usize];
                    sample(x, y, index, &mut sink, &mut item.counters, &mut item.extra);
                    item.own.extend_from_slice(&sink.values);
                }
            }
            item.splats = std::mem::take(&mut sink.splats);
            schedule.advance((w * h) as u64);
            item
        })
        .collect();
    let pixels = films[0].pixels.len();
    let r = replicate_stride(spec.replicates);
    let mut buffer = vec![[0.0f64; 3]; pixels * slots];
    let mut image = vec![[0.0f64; 3]; slots];
    let mut out = out.into_iter();
    for index in indices {
        buffer.fill([0.0; 3]);
        for &(x0, y0) in tiles {
            let item = out.next().expect("one result per work item");
            let (w, _) = tile_size(spec, (x0, y0));
            for (k, own) in item.own.chunks(slots).enumerate() {
                let i = ((y0 + k as u32 / w) * width + x0 + k as u32 % w) as usize;
                for (acc, v) in buffer[i * slots..(i + 1) * slots].iter_mut().zip(own) {
                    let v = to_f64(*v);
                    for c in 0..3 {
                        acc[c] += v[c];
                    }
                }
            }
            for s in &item.splats {
                let acc = &mut buffer[s.pixel as usize * slots + s.slot as usize];
                let v = to_f64(s.value);
                for c in 0..3 {
                    acc[c] += v[c];
                }
            }
            state.counters.merge(&item.counters);
            state.extras.push(item.extra);
        }
        image.fill([0.0; 3]);
        for (i, values) in buffer.chunks(slots).enumerate() {
            for (s, v) in values.iter().enumerate() {
                state.films[s].pixels[i].add(*v);
                add_to(&mut image[s], *v);
                if r > 0 {
                    add_to(
                        &mut state.replicas[(i * slots + s) * r + index as usize % r],
                        *v,
                    );
                }
            }
        }
        add_image_averages(state, &image, slots, index, r);
    }
}

#[cfg(test)]
mod tests {
    use super::{
        Budget, MAX_BUFFERED, PassSpec, Schedule, pixel_pass_samples, run_passes, timed_pass,
    };
    use crate::paths::{Layers, Router};
    use lightlab_core::{NoProgress, Rgb};

    /// With replicates, a time budget ends on a multiple of them: one pass of R samples, or, for an
    /// estimator that renders one sample index per pass (VCM), R passes of one, though the clock ran
    /// out after the first (a budget of a nanosecond); a sample budget's passes stay within it.
    #[test]
    fn renders_end_on_a_multiple_of_the_replicates() {
        let passes = |budget: Budget, preferred: u32| {
            let mut schedule = Schedule::new(budget, &NoProgress, 1);
            schedule.step = 4;
            let (mut done, mut sizes) = (0, Vec::new());
            while let Some(n) = schedule.next_pass(done, preferred) {
                sizes.push(n);
                done += n;
            }
            sizes
        };
        assert_eq!(passes(Budget::Seconds(1e-9), 64), [4]);
        assert_eq!(passes(Budget::Seconds(1e-9), 1), [1, 1, 1, 1]);
        assert_eq!(passes(Budget::Samples(12), 1), [1; 12]);
        assert_eq!(passes(Budget::Samples(12), 6), [4, 4, 4]);
        assert_eq!(passes(Budget::Samples(12), 64), [12]);
    }

    /// The replicates' variance, exactly: a one-pixel estimator whose sample i is the value i, in
    /// R = 4 replicates (sample i is replicate i mod 4's). After 8 samples the replicate means are
    /// 2, 3, 4, 5 (variance of their mean 5/12) and the image's standard error is √(5/12); after 6
    /// the replicates hold 2, 2, 1, 1 samples, with means 2, 3, 2, 3 (1/12: a render ends with equal
    /// replicates, passes in between need not). With and without splatting (the two pass kinds).
    #[test]
    fn replicate_variance_is_the_spread_of_the_replicate_means() {
        let router = Router::new(None, &Layers::Off, None).unwrap();
        for splats in [false, true] {
            for (n, want) in [(8u32, 5.0 / 12.0), (6, 1.0 / 12.0)] {
                let spec = PassSpec {
                    width: 1,
                    height: 1,
                    slots: 1,
                    splats,
                    groups: 0,
                    independent: false,
                    replicates: 4,
                };
                let mut schedule = Schedule::new(Budget::Samples(n), &NoProgress, 1);
                let out = run_passes(
                    &spec,
                    &router,
                    &mut schedule,
                    &mut |_, _| true,
                    |_, _, index, sink, _, _: &mut ()| sink.add_slot(0, Rgb::splat(index as f32)),
                );
                let film = &out.films[0];
                let what = format!("splats {splats}, {n} samples");
                assert_eq!(film.mean(0)[0], (n - 1) as f64 / 2.0, "{what}");
                assert!((film.variance_of_mean(0)[0] - want).abs() < 1e-12, "{what}");
                let se = film.image_se.expect("replicates give a standard error")[0];
                assert!((se * se - want).abs() < 1e-12, "{what}");
            }
        }
    }

    /// A pass's per-sample buffers stay within MAX_BUFFERED entries (about 100 MB) for any image,
    /// while one-tile images still render many samples per pass; never zero samples.
    #[test]
    fn pixel_passes_buffer_a_bounded_number_of_samples() {
        for (tiles, slots, groups) in [(1, 1, 0), (256, 1, 0), (65536, 4, 3), (1 << 24, 8, 0)] {
            let n = pixel_pass_samples(tiles, slots, groups) as usize;
            assert!(n >= 1);
            assert!(
                n == 1 || n * tiles * slots * (1 + groups) <= MAX_BUFFERED,
                "{tiles} tiles: {n} samples per pass"
            );
        }
        assert_eq!(pixel_pass_samples(1, 1, 0), 1 << 22);
    }
    use lightlab_samplers::{Independent, Sampler};

    /// A render on a simulated clock under a time budget of `seconds`: every sample index gives
    /// each of `pixels` pixels an exponential value X of mean and variance 1 and costs
    /// Σ (c₀ + c₁·X) over them. Returns the pixels' estimates and the samples reached.
    fn timed_render(
        seconds: f64,
        pixels: usize,
        (c0, c1): (f64, f64),
        rng: &mut Independent,
    ) -> (Vec<f64>, u32) {
        let mut sums = vec![0.0; pixels];
        let (mut clock, mut first_pass, mut done) = (0.0, None, 0u32);
        while let Some(n) = timed_pass(seconds, clock, first_pass.map(|f| clock - f), done) {
            first_pass.get_or_insert(clock);
            for _ in 0..n {
                for sum in &mut sums {
                    let x = -(1.0 - rng.next_1d() as f64).ln();
                    *sum += x;
                    clock += c0 + c1 * x;
                }
            }
            done += n;
        }
        (sums.iter().map(|s| s / done as f64).collect(), done)
    }

    /// The bias of a time-budgeted render's mean is the renewal-theory value Cov(X, c) / (E[c]·E[N])
    /// of `timed_pass`'s docs: about 1/N of the mean for a lone pixel whose cost is its value (the
    /// worst case), 1/pixels of that in an image, and nothing when the cost does not depend on the
    /// value. 20,000 simulated renders per case, fixed seeds; each check allows 4 standard errors
    /// of the simulated bias (false-failure rate 6·10⁻⁵) plus 10 % of the first-order formula.
    #[test]
    fn stopping_time_bias() {
        let renders = 20_000;
        for (case, (seconds, pixels, cost)) in [
            (64.0, 1, (0.0, 1.0)),
            (64.0, 1, (1.0, 1.0)),
            (16.0 * 64.0, 16, (0.0, 1.0)),
            (64.0, 1, (1.0, 0.0)),
        ]
        .into_iter()
        .enumerate()
        {
            let mut rng = Independent::new();
            rng.start_pixel_sample(11, case as u64, 0);
            let (mut bias, mut bias2, mut samples) = (0.0, 0.0, 0.0);
            for _ in 0..renders {
                let (means, n) = timed_render(seconds, pixels, cost, &mut rng);
                let b = means.iter().map(|m| m - 1.0).sum::<f64>() / pixels as f64;
                (bias, bias2, samples) = (bias + b, bias2 + b * b, samples + n as f64);
            }
            let r = renders as f64;
            let (bias, samples) = (bias / r, samples / r);
            let se = ((bias2 / r - bias * bias) / (r - 1.0)).sqrt();
            // Cov(X, c) = c₁·Var X = c₁; E[c] = pixels · (c₀ + c₁).
            let (c0, c1) = cost;
            let expected = c1 / (pixels as f64 * (c0 + c1) * samples);
            assert!(
                (bias - expected).abs() < 4.0 * se + 0.1 * expected,
                "case {case}: bias {bias:.5} ± {se:.5} over E[N] = {samples:.1} samples, \
                 renewal theory {expected:.5}"
            );
        }
    }
}
