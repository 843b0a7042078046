//! Choice of sampler in settings files (RON: `sampler: Sobol`) and its dispatch to a concrete,
//! monomorphised [`Sampler`] type.

use crate::{Halton, Independent, LatinHypercube, Sampler, Sobol, Stratified};
use serde::{Deserialize, Serialize};

/// Which [`Sampler`] generates a pixel's sample values. Default: `Independent`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SamplerConfig {
    /// Independent uniform values from a PCG32 stream per (seed, pixel, sample) (O'Neill 2014):
    /// plain Monte Carlo, MSE ∝ N⁻¹; the baseline. [`Independent`].
    #[default]
    Independent,
    /// Jittered sampling: `spp` strata per 1D dimension, a most-square nx × ny grid per 2D pair
    /// (N-rooks when spp is prime or the grid would be elongated), strata permuted per dimension
    /// and pixel by hashing (Cook 1986; pbrt-v4 §8.5). [`Stratified`].
    Stratified,
    /// Latin hypercube sampling: `spp` strata in every dimension, an independent hashed
    /// permutation per (seed, pixel, dimension), jittered within the stratum (McKay, Beckman and
    /// Conover 1979; Shirley 1991 "N-rooks"). [`LatinHypercube`].
    LatinHypercube,
    /// Halton sequence in the first 1024 prime bases, Owen-scrambled per pixel (Halton 1964;
    /// Owen 1995; pbrt-v4 §8.6), independent values beyond dimension 1024. [`Halton`].
    Halton,
    /// Owen-scrambled Sobol' (0, 2)-sequence pairs, shuffled per pixel and dimension pair
    /// ("padding"; Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4)); best with spp
    /// a power of two. [`Sobol`].
    Sobol,
}

/// Code that is generic over the sampler type, run by [`SamplerConfig::dispatch`] with the concrete
/// sampler a configuration names (Rust has no generic closures, hence a trait).
pub trait SamplerVisitor {
    type Output;
    /// Called with a freshly constructed sampler; clone it per pixel loop or thread.
    fn visit<S: Sampler + Clone + Send + Sync + 'static>(self, sampler: S) -> Self::Output;
}

impl SamplerConfig {
    /// Every sampler, in declaration order.
    pub const ALL: [SamplerConfig; 5] = [
        SamplerConfig::Independent,
        SamplerConfig::Stratified,
        SamplerConfig::LatinHypercube,
        SamplerConfig::Halton,
        SamplerConfig::Sobol,
    ];

    /// The variant's name as written in RON (`"LatinHypercube"`), for tables and file names.
    pub fn name(&self) -> &'static str {
        match self {
            SamplerConfig::Independent => "Independent",
            SamplerConfig::Stratified => "Stratified",
            SamplerConfig::LatinHypercube => "LatinHypercube",
            SamplerConfig::Halton => "Halton",
            SamplerConfig::Sobol => "Sobol",
        }
    }

    /// Whether the sampler must know the number of samples per pixel before the first one: its
    /// strata are laid out for exactly that many (`Stratified`, `LatinHypercube`). The others are
    /// sequences whose every prefix is as good as a fresh set.
    pub fn needs_sample_count(&self) -> bool {
        matches!(
            self,
            SamplerConfig::Stratified | SamplerConfig::LatinHypercube
        )
    }

    /// The most samples per pixel the sampler takes: `Stratified` and `LatinHypercube` put sample i
    /// of n in the i-th of n strata of [0, 1) as an f32, which separates at most 2²⁴ of them (more,
    /// and strata overlap and the top one reaches 1.0); the others have no limit.
    pub fn max_samples(&self) -> u32 {
        if self.needs_sample_count() {
            1 << 24
        } else {
            u32::MAX
        }
    }

    /// The sample count at most `n` (and at least 1) this sampler stratifies best: for
    /// `Stratified`, the largest whose 2D pairs get a proper nx × ny grid rather than the N-rooks
    /// fallback (a prime or elongated count); `n` itself for the others.
    pub fn best_count_up_to(&self, n: u32) -> u32 {
        let n = n.min(self.max_samples());
        match self {
            SamplerConfig::Stratified => (1..=n.max(1))
                .rev()
                .find(|&m| !crate::Stratified::new(m).is_n_rooks())
                .unwrap_or(1),
            _ => n.max(1),
        }
    }

    /// Whether the samples of a pixel are independent (only `Independent`): then s²/n over them
    /// estimates the variance of the pixel mean. For the others see [`Self::correlation_note`].
    pub fn independent(&self) -> bool {
        matches!(self, SamplerConfig::Independent)
    }

    /// Why s²/n over a pixel's `samples` (what the integrator draws with this sampler) is no
    /// estimate of the variance V of their mean when the sampler is not independent. With n samples
    /// of variance σ² each, E[s²] = (σ² − V)·n/(n − 1), so E[s²/n] ≥ V exactly when V ≤ σ²/n: s²/n
    /// overestimates V on average where the sampler does better than independent sampling, as
    /// stratified and scrambled low-discrepancy samples do on smooth and piecewise-smooth
    /// integrands, but no sampler here guarantees that for every integrand (a scrambled
    /// (0, m, 2)-net may have up to twice independent sampling's variance: Owen 1997, "Monte Carlo
    /// variance of scrambled net quadrature", SIAM J. Numer. Anal. 34(5)).
    pub fn correlation_note(&self, samples: &str) -> String {
        format!(
            "the {} sampler's {samples} are correlated: s²/n is no estimate of the variance of the \
             mean (above it on average only where the sampler beats independent samples, as \
             stratification does on smooth integrands)",
            self.name()
        )
    }

    /// Constructs the configured sampler for `spp` samples per pixel and hands it to `visitor`,
    /// so the visitor's code is monomorphised for each sampler type.
    pub fn dispatch<V: SamplerVisitor>(self, spp: u32, visitor: V) -> V::Output {
        match self {
            SamplerConfig::Independent => visitor.visit(Independent::new()),
            SamplerConfig::Stratified => visitor.visit(Stratified::new(spp)),
            SamplerConfig::LatinHypercube => visitor.visit(LatinHypercube::new(spp)),
            SamplerConfig::Halton => visitor.visit(Halton::new(spp)),
            SamplerConfig::Sobol => visitor.visit(Sobol::new(spp)),
        }
    }
}
