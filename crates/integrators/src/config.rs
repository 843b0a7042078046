//! Integrator settings as RON, shared by `lightlab render --integrator '...'` and experiment
//! files. Each integrator's settings struct lives beside its code (`PathConfig` in `path`,
//! `LightConfig` in `light`, `BdptConfig` in `bdpt`, `PhotonMapConfig` and `ProgressiveConfig` in
//! `photon::config`): every field optional (`#[serde(default)]`, the default on its doc comment),
//! unknown fields errors, checked once by [`Validate`] — by [`IntegratorConfig::from_ron`] and again
//! by [`IntegratorConfig::build`], so no integrator is ever built from settings it cannot run.

use crate::Integrator;
use crate::bdpt::{Bdpt, BdptConfig};
use crate::cone::{Cone, ConeConfig};
use crate::light::{LightConfig, LightTracer};
use crate::path::{PathConfig, PathTracer};
use crate::paths::{Layers, Router};
use crate::photon::config::{PhotonMapConfig, ProgressiveConfig};
use crate::photon::pm::PhotonMapper;
use crate::photon::progressive::{Progressive, Variant};
use crate::radiosity::{Radiosity, RadiosityConfig};
use crate::vcm::{Vcm, VcmConfig};
use crate::walk::RoulettePolicy;
use serde::{Deserialize, Serialize};

/// Declares [`IntegratorConfig`], one variant per integrator with its settings and how it is
/// built, and everything that goes through all variants: registering an integrator is its line
/// here.
macro_rules! integrators {
    ($( $(#[$doc:meta])* $variant:ident($config:ty) => $build:expr, )*) => {
        /// Which integrator to run and with what settings, e.g. `Path(max_bounces: 8, strategy:
        /// Mis)`.
        #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub enum IntegratorConfig {
            $( $(#[$doc])* $variant($config), )*
        }

        impl IntegratorConfig {
            fn settings(&self) -> &dyn Settings {
                match self {
                    $( IntegratorConfig::$variant(c) => c, )*
                }
            }

            fn settings_mut(&mut self) -> &mut dyn Settings {
                match self {
                    $( IntegratorConfig::$variant(c) => c, )*
                }
            }

            /// The integrator these settings describe, after checking them (each integrator's
            /// constructor validates its settings).
            pub fn build(&self) -> Result<Box<dyn Integrator>, ConfigError> {
                Ok(match self {
                    $( IntegratorConfig::$variant(c) => {
                        Box::new(($build)(c.clone())?) as Box<dyn Integrator>
                    } )*
                })
            }
        }
    };
}

integrators! {
    /// Unidirectional path tracing from the camera (Kajiya 1986) with next-event estimation.
    Path(PathConfig) => PathTracer::new,
    /// Light tracing (particle tracing; Arvo & Kirk 1990, Dutré et al. 1993): paths from the
    /// lights, every non-specular vertex connected to the camera.
    Light(LightConfig) => LightTracer::new,
    /// Bidirectional path tracing (Veach & Guibas 1994): every (s, t) connection strategy,
    /// combined by the balance heuristic.
    Bdpt(BdptConfig) => Bdpt::new,
    /// Photon mapping (Jensen 1996): a global and a caustic photon map, direct light by light
    /// sampling, final gather.
    PhotonMap(PhotonMapConfig) => PhotonMapper::new,
    /// Progressive photon mapping (Hachisuka et al. 2008): fixed visible points, shrinking
    /// radius; samples per pixel count passes.
    Ppm(ProgressiveConfig) => |c| Progressive::new(c, Variant::Ppm),
    /// Stochastic progressive photon mapping (Hachisuka & Jensen 2009): new visible points every
    /// pass; samples per pixel count passes.
    Sppm(ProgressiveConfig) => |c| Progressive::new(c, Variant::Sppm),
    /// Vertex connection and merging (Georgiev et al. 2012): BDPT's connections and photon
    /// mapping's merges under one MIS, a shrinking merge radius; samples per pixel count passes.
    Vcm(VcmConfig) => Vcm::new,
    /// Radiosity (Goral et al. 1984): Lambertian patches, ray-cast form factors, a Jacobi,
    /// Gauss–Seidel or progressive-shooting solve, shown through the camera.
    Radiosity(RadiosityConfig) => Radiosity::new,
    /// Cone tracing (Amanatides 1984): one cone per pixel, analytic coverage of spheres and
    /// polygons composited front to back, direct light with shadow cones.
    Cone(ConeConfig) => Cone::new,
}

/// What every settings struct offers the variant-independent code ([`settings!`] implements it).
pub(crate) trait Settings: Validate {
    /// The `paths` and `layers` settings.
    fn paths_and_layers(&mut self) -> (&mut Option<String>, &mut Layers);
}

/// Settings that cannot be used, and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ConfigError {
    /// The text is not RON for these settings (an unknown field or variant, a wrong type): where.
    #[error("{line}:{col}: {message}")]
    Syntax {
        /// Line of the fault, from 1.
        line: usize,
        /// Column of the fault, from 1.
        col: usize,
        /// What is wrong there.
        message: String,
    },
    /// A value, or a combination of values, outside what the integrator can do.
    #[error("{0}")]
    Invalid(String),
}

impl From<ConfigError> for String {
    fn from(e: ConfigError) -> String {
        e.to_string()
    }
}

/// The check every settings struct passes before an integrator is built from it.
pub trait Validate {
    /// `Ok` if an integrator can run with these settings; otherwise what is wrong and what is
    /// allowed.
    fn validate(&self) -> Result<(), ConfigError>;
}

/// The most bounces a path may take without Russian roulette ([`check_common`]).
pub(crate) const MAX_BOUNCES_WITHOUT_ROULETTE: u32 = 1 << 16;

/// The bounce settings every integrator shares: unbounded paths need Russian roulette, and
/// without it at most [`MAX_BOUNCES_WITHOUT_ROULETTE`] bounces; `min_bounces ≤ max_bounces` and a
/// roulette threshold in (0, 1]; and the path-class settings (`paths`, `layers`), which must parse.
pub(crate) fn check_common(
    max_bounces: Option<u32>,
    min_bounces: u32,
    roulette: RoulettePolicy,
    paths: Option<&str>,
    layers: &Layers,
) -> Result<(), ConfigError> {
    if max_bounces.is_none() && roulette.start.is_none() {
        return invalid(
            "unbounded paths (max_bounces: None) need Russian roulette: set max_bounces or \
             russian_roulette",
        );
    }
    if let Some(max) = max_bounces
        && roulette.start.is_none()
        && max > MAX_BOUNCES_WITHOUT_ROULETTE
    {
        return invalid(format!(
            "max_bounces {max} without Russian roulette: at most {MAX_BOUNCES_WITHOUT_ROULETTE} \
             (where nothing absorbs, as in a white furnace, every path is traced to that depth, \
             and bidirectional methods store every vertex); set russian_roulette for longer paths"
        ));
    }
    if !(roulette.threshold > 0.0 && roulette.threshold <= 1.0) {
        return invalid(format!(
            "roulette_threshold must be in (0, 1] (the relative throughput below which Russian \
             roulette plays; 1 plays on every path), got {}",
            roulette.threshold
        ));
    }
    if let Some(max) = max_bounces
        && min_bounces > max
    {
        return invalid(format!(
            "min_bounces ({min_bounces}) exceeds max_bounces ({max})"
        ));
    }
    Router::check(paths, layers, min_bounces, max_bounces).map_err(ConfigError::Invalid)
}

/// Most replicates a sampler's samples may be split into (each holds 24 bytes per pixel and layer).
pub(crate) const MAX_REPLICATES: u32 = 4096;

/// Whether a setting is 1: `replicates` is not written then (`IntegratorConfig::to_ron`).
pub(crate) fn is_one(n: &u32) -> bool {
    *n == 1
}

/// Checks a `replicates` setting: 1 (none) to [`MAX_REPLICATES`].
pub(crate) fn check_replicates(replicates: u32) -> Result<(), ConfigError> {
    if !(1..=MAX_REPLICATES).contains(&replicates) {
        return invalid(format!(
            "replicates must be 1 (none) to {MAX_REPLICATES}: the independent replicates each \
             pixel's samples are split into for a variance estimate, at least 2 for one (16 is \
             usual); got {replicates}"
        ));
    }
    Ok(())
}

/// Defines an integrator's settings struct `$name` (RON name `$ron`): the fields every integrator
/// shares — `max_bounces`, `min_bounces`, `russian_roulette` first, `paths` and `layers` last,
/// documented once here — around its own, each given with its default; serde defaults and
/// `deny_unknown_fields` (a typo is an error), a `Default` of those defaults, and
/// `check_common` for its `Validate`.
macro_rules! settings {
    (
        $(#[$meta:meta])*
        $name:ident as $ron:literal {
            $( $(#[$field_meta:meta])* $field:ident: $ty:ty = $default:expr, )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
        #[serde(default, deny_unknown_fields, rename = $ron)]
        pub struct $name {
            /// Largest number of scattering vertices of a full path (k of Heckbert's
            /// `L X₁…X_k E`; the vertex connected to the camera included); `None` for no limit,
            /// Russian roulette then ends paths. Default `None`.
            pub max_bounces: Option<u32>,
            /// Smallest number of scattering vertices a contribution must have: `min_bounces: k,
            /// max_bounces: k` isolates the k-th term of the Neumann series. Default 0.
            pub min_bounces: u32,
            /// Russian roulette from this many scattering vertices on, on every walk the
            /// integrator makes (camera, light, photon paths); `None` turns it off. Default
            /// `Some(1)`.
            pub russian_roulette: Option<u32>,
            /// The throughput, relative to the walk's start, below which Russian roulette plays:
            /// a path below τ continues with probability throughput/τ and then with throughput τ;
            /// others always continue (weight-cutoff roulette, Arvo & Kirk 1990; see
            /// `walk::roulette`). 1 is survival in proportion to throughput (pbrt-v4, Mitsuba);
            /// smaller values end fewer paths and give survivors smaller weights. In (0, 1].
            /// Default 0.5, with `russian_roulette: 1` the most efficient measured
            /// (BENCHMARKS.md, "Russian roulette: start and threshold").
            pub roulette_threshold: f32,
            $( $(#[$field_meta])* pub $field: $ty, )*
            /// Render only the contributions of paths this expression matches (e.g. `"LS+DE"`;
            /// see the README's "Path classes"); `None` renders every path. Default `None`.
            pub paths: Option<String>,
            /// Image layers written besides the full image: `Off`, `Bounces` or
            /// `Classes(["LS+DE", ...])` (plus a `rest` layer). Default `Off`.
            pub layers: $crate::paths::Layers,
        }

        impl Default for $name {
            fn default() -> Self {
                $name {
                    max_bounces: None,
                    min_bounces: 0,
                    russian_roulette: Some(1),
                    roulette_threshold: 0.5,
                    $( $field: $default, )*
                    paths: None,
                    layers: $crate::paths::Layers::Off,
                }
            }
        }

        impl $crate::config::Settings for $name {
            fn paths_and_layers(&mut self) -> (&mut Option<String>, &mut $crate::paths::Layers) {
                (&mut self.paths, &mut self.layers)
            }
        }

        impl $name {
            /// Validates the settings and builds the router of their `paths` and `layers`: what
            /// every integrator's constructor starts with.
            pub(crate) fn checked_router(
                &self,
            ) -> Result<$crate::paths::Router, $crate::config::ConfigError> {
                $crate::config::Validate::validate(self)?;
                $crate::paths::Router::new(self.paths.as_deref(), &self.layers, self.max_bounces)
                    .map_err($crate::config::ConfigError::Invalid)
            }

            /// The walks' Russian roulette: `russian_roulette` and `roulette_threshold`.
            pub fn roulette(&self) -> $crate::walk::RoulettePolicy {
                $crate::walk::RoulettePolicy {
                    start: self.russian_roulette,
                    threshold: self.roulette_threshold,
                }
            }

            /// The checks of the shared fields (`config::check_common`).
            fn check_common(&self) -> Result<(), $crate::config::ConfigError> {
                $crate::config::check_common(
                    self.max_bounces,
                    self.min_bounces,
                    self.roulette(),
                    self.paths.as_deref(),
                    &self.layers,
                )
            }
        }
    };
}
pub(crate) use settings;

/// An `Invalid` error.
pub(crate) fn invalid<T>(message: impl Into<String>) -> Result<T, ConfigError> {
    Err(ConfigError::Invalid(message.into()))
}

impl Validate for IntegratorConfig {
    fn validate(&self) -> Result<(), ConfigError> {
        self.settings().validate()
    }
}

impl IntegratorConfig {
    /// Parses and checks RON such as `Path(max_bounces: 8)`. Syntax errors carry line:column.
    pub fn from_ron(text: &str) -> Result<IntegratorConfig, ConfigError> {
        let config: IntegratorConfig =
            ron_options()
                .from_str(text)
                .map_err(|e| ConfigError::Syntax {
                    line: e.span.start.line,
                    col: e.span.start.col,
                    message: lightlab_scene::ron_message(&e.code),
                })?;
        config.validate()?;
        Ok(config)
    }

    /// The settings written back as RON, every field explicit but those added after experiments
    /// had recorded runs (`replicates`), which are written only when not at their default: the
    /// text names a run (its id, its seed, its reference's cache key), so that settings from
    /// before keep their names.
    pub fn to_ron(&self) -> String {
        ron_options()
            .to_string_pretty(
                self,
                ron::ser::PrettyConfig::new()
                    .struct_names(true)
                    .compact_structs(true),
            )
            .expect("integrator settings always serialise")
    }

    /// These settings with `paths` and/or `layers` replaced (checked as when parsed).
    pub fn with_paths_and_layers(
        mut self,
        paths: Option<String>,
        layers: Option<Layers>,
    ) -> Result<IntegratorConfig, ConfigError> {
        let (p, l) = self.settings_mut().paths_and_layers();
        if let Some(paths) = paths {
            *p = Some(paths);
        }
        if let Some(layers) = layers {
            *l = layers;
        }
        self.validate()?;
        Ok(self)
    }
}

/// RON options used for every Lightlab document: `Some(..)` may be omitted, and a variant holding a
/// settings struct is written `Path(max_bounces: 8)` rather than `Path((max_bounces: 8))`.
pub fn ron_options() -> ron::Options {
    use ron::extensions::Extensions;
    ron::Options::default()
        .with_default_extension(Extensions::IMPLICIT_SOME | Extensions::UNWRAP_VARIANT_NEWTYPES)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::Strategy;

    #[test]
    fn parses_defaults_and_round_trips() {
        let c = IntegratorConfig::from_ron("Path(max_bounces: 8)").unwrap();
        let IntegratorConfig::Path(p) = &c else {
            panic!("{c:?}")
        };
        assert_eq!(p.max_bounces, Some(8));
        assert_eq!(p.russian_roulette, Some(1));
        assert_eq!(p.roulette_threshold, 0.5);
        assert_eq!(p.strategy, Strategy::Mis);
        assert!(p.shadows);
        assert_eq!(IntegratorConfig::from_ron(&c.to_ron()).unwrap(), c);
        let d = IntegratorConfig::from_ron("Path()").unwrap();
        let IntegratorConfig::Path(d) = d else {
            panic!("{d:?}")
        };
        assert_eq!(d.max_bounces, None);
        assert_eq!(d.sampler, lightlab_samplers::SamplerConfig::Independent);
        let l = IntegratorConfig::from_ron("Light(max_bounces: 2)").unwrap();
        assert_eq!(
            l.to_ron(),
            "Light(max_bounces: 2, min_bounces: 0, russian_roulette: 1, roulette_threshold: 0.5, paths: None, layers: Off)"
        );
        assert_eq!(IntegratorConfig::from_ron(&l.to_ron()).unwrap(), l);
        for text in [
            "PhotonMap(photons: 1000, gather: Radius(Absolute(0.1)), indirect: Direct)",
            "Sppm(alpha: 0.5, update: Global, kernel: Cone)",
            "Ppm(radius: Absolute(0.01))",
            "Radiosity(patches: 64, solver: Shooting, ambient: true, iterations: 3)",
        ] {
            let c = IntegratorConfig::from_ron(text).unwrap();
            assert_eq!(
                IntegratorConfig::from_ron(&c.to_ron()).unwrap(),
                c,
                "{}",
                c.to_ron()
            );
        }
        let s = IntegratorConfig::from_ron("Path(sampler: Sobol)").unwrap();
        assert_eq!(IntegratorConfig::from_ron(&s.to_ron()).unwrap(), s);
        // The text of default settings names every committed run (id, seed, reference cache key):
        // a field added since must not change it.
        assert_eq!(
            IntegratorConfig::from_ron("Path()").unwrap().to_ron(),
            "Path(max_bounces: None, min_bounces: 0, russian_roulette: 1, roulette_threshold: 0.5, strategy: Mis, shadows: true, sampler: Independent, paths: None, layers: Off)"
        );
        assert_eq!(
            IntegratorConfig::from_ron("Bdpt()").unwrap().to_ron(),
            "Bdpt(max_bounces: None, min_bounces: 0, russian_roulette: 1, roulette_threshold: 0.5, sampler: Independent, mis: Balance, strategy_layers: false, outliers: None, paths: None, layers: Off)"
        );
        let vcm = IntegratorConfig::from_ron("Vcm()").unwrap().to_ron();
        assert!(!vcm.contains("replicates"), "{vcm}");
        for text in [
            "Path(sampler: Sobol, replicates: 8)",
            "Bdpt(replicates: 2)",
            "Vcm(variant: Vc, replicates: 2)",
        ] {
            let c = IntegratorConfig::from_ron(text).unwrap();
            assert!(c.to_ron().contains("replicates: "), "{}", c.to_ron());
            assert_eq!(IntegratorConfig::from_ron(&c.to_ron()).unwrap(), c);
        }
    }

    #[test]
    fn rejects_bad_settings_with_position() {
        let e = IntegratorConfig::from_ron("Path(max_bounce: 8)")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("1:") && e.contains("max_bounce"), "{e}");
        let e = IntegratorConfig::from_ron("Path(max_bounces: None, russian_roulette: None)")
            .unwrap_err()
            .to_string();
        assert!(e.contains("Russian roulette"), "{e}");
        // Four billion bounces without roulette: a white furnace traced every path that deep,
        // and BDPT stored every vertex (gigabytes, growing). 65 536 is accepted, with roulette any.
        for integrator in ["Path", "Bdpt", "Vcm", "Light", "Sppm", "PhotonMap"] {
            let e = IntegratorConfig::from_ron(&format!(
                "{integrator}(max_bounces: 4294967295, russian_roulette: None)"
            ))
            .unwrap_err()
            .to_string();
            assert!(e.contains("at most 65536"), "{integrator}: {e}");
            for ok in [
                "max_bounces: 65536, russian_roulette: None",
                "max_bounces: 4294967295",
            ] {
                IntegratorConfig::from_ron(&format!("{integrator}({ok})")).unwrap();
            }
        }
        for tau in ["0", "-0.5", "1.5", "inf", "NaN"] {
            let e = IntegratorConfig::from_ron(&format!("Path(roulette_threshold: {tau})"))
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("roulette_threshold must be in (0, 1]"),
                "{tau}: {e}"
            );
        }
        let e = IntegratorConfig::from_ron("Path(max_bounces: 2, min_bounces: 3)")
            .unwrap_err()
            .to_string();
        assert!(e.contains("min_bounces"), "{e}");
        let e = IntegratorConfig::from_ron("Path(max_bounces: -1)")
            .unwrap_err()
            .to_string();
        assert!(e.contains("1:"), "{e}");
        assert!(
            IntegratorConfig::from_ron("Pth()")
                .unwrap_err()
                .to_string()
                .contains("Path")
        );
        assert!(
            IntegratorConfig::from_ron("Light(strategy: Mis)")
                .unwrap_err()
                .to_string()
                .contains("strategy")
        );
        assert!(
            IntegratorConfig::from_ron("Light(min_bounces: 3, max_bounces: 1)")
                .unwrap_err()
                .to_string()
                .contains("min_bounces")
        );
        for (bad, words) in [
            ("Sppm(alpha: 1.5)", "alpha"),
            ("Sppm(alpha: 0)", "alpha"),
            (
                "Sppm(alpha: 0.01)",
                "update: Local, alpha must be at least 0.1",
            ),
            ("Ppm(alpha: 1e-6, update: Local)", "seldom reach"),
            (
                "PhotonMap(indirect: FinalGather(rays: 4294967295))",
                "FinalGather rays must be between 1 and 16384",
            ),
            ("Sppm(radius: Absolute(0))", "radius"),
            ("Sppm(radius: Relative(-1))", "radius"),
            ("Ppm(photons_per_pass: 0)", "photons_per_pass"),
            ("PhotonMap(photons: 0)", "photons"),
            (
                "PhotonMap(gather: Nearest(k: 0, max_radius: Relative(0.1)))",
                "k must be at least 3, got 0",
            ),
            (
                "PhotonMap(gather: Nearest(k: 1, max_radius: Relative(0.1)))",
                "none for k = 1",
            ),
            (
                "PhotonMap(caustic_gather: Nearest(k: 2, max_radius: Relative(0.1)))",
                "unbounded for k = 2",
            ),
            (
                "PhotonMap(caustic_gather: Radius(Absolute(inf)))",
                "caustic_gather radius",
            ),
            ("PhotonMap(indirect: FinalGather(rays: 0))", "FinalGather"),
            ("PhotonMap(kernel: Gaussian)", "Epanechnikov"),
            ("Vcm(alpha: 0)", "alpha must lie in (0, 1]"),
            ("Vcm(alpha: 1.5)", "alpha"),
            ("Vcm(radius: Absolute(0))", "radius"),
            ("Vcm(outliers: Some(0.5))", "outliers"),
            ("Vcm(strategy_layers: true)", "needs max_bounces"),
            ("Vcm(mis: Uniform)", "Power"),
            ("Vcm(variant: Pm)", "Bpm"),
            ("Radiosity(patches: 0)", "patches must lie in 1"),
            ("Radiosity(rays: 0)", "rays must lie in 1"),
            ("Radiosity(tolerance: 0)", "tolerance must lie in (0, 1)"),
            ("Radiosity(tolerance: 1)", "tolerance"),
            ("Radiosity(max_bounces: 1, min_bounces: 2)", "min_bounces"),
            (
                "Radiosity(solver: GaussSeidel, max_bounces: 3)",
                "only the Jacobi solver",
            ),
            (
                "Radiosity(solver: Shooting, layers: Bounces)",
                "only the Jacobi solver",
            ),
            ("Radiosity(ambient: true)", "solver: Shooting"),
            ("Radiosity(paths: \"LD(\")", "paths"),
        ] {
            let e = IntegratorConfig::from_ron(bad).unwrap_err().to_string();
            assert!(e.contains(words), "{bad}: {e}");
        }
        assert!(
            IntegratorConfig::from_ron("Path(sampler: Sobl)")
                .unwrap_err()
                .to_string()
                .contains("Sobol")
        );
    }
}
