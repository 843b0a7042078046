//! Statistical test support for Lightlab (a dev-dependency only): a chi-square goodness-of-fit
//! harness for sampling routines ([`chi2`]) with gnomonic windows for narrow sets of directions
//! ([`window`]), z-tests for Monte Carlo estimates and whole images, approximate-equality asserts
//! and a least-squares line fit for convergence rates ([`stats`]), wall/CPU timing for the
//! benchmarks ([`timing`]), and crafted input files for bad-input tests ([`files`]).
//!
//! A new sampling routine's test is a few lines:
//!
//! ```
//! use lightlab_samplers::warp::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
//! use lightlab_testkit::{Chi2Test, Domain};
//!
//! Chi2Test::new(Domain::Hemisphere)
//!     .samples(200_000)
//!     .seed(1)
//!     .run(
//!         "cosine_hemisphere_doc",
//!         |u| Some(square_to_cosine_hemisphere(u)),
//!         square_to_cosine_hemisphere_pdf,
//!     )
//!     .assert_ok();
//! ```
//!
//! Every statistical test fails by chance with its significance level α. The defaults split a
//! suite-wide false-failure rate of 1 % over 300 tests with Šidák's correction (see [`chi2`] and
//! [`sidak`]), so a suite of at most 300 such tests fails spuriously at most once in a hundred
//! runs; the fixed seeds make any given run reproducible.

pub mod chi2;
pub mod files;
pub mod stats;
pub mod timing;
pub mod window;

pub use chi2::{Chi2Result, Chi2Test, Domain, DomainPoint, chi2_discrete};
pub use stats::{
    Approx, Fit, ImageEstimate, ImageZTest, PixelZ, Reference, SUITE_ALPHA, SUITE_TESTS, ZTest,
    approx_eq, default_alpha, fit_line, image_z_test, mean_and_std_error, sidak, z_critical,
    z_test_mean,
};
pub use window::DirectionWindow;
