//! Integrator settings as RON, shared by `lightlab render --integrator '...'` and experiment files.

use crate::Integrator;
use crate::bdpt::Bdpt;
use crate::light::LightTracer;
use crate::path::PathTracer;
use crate::paths::{Layers, Router};
use crate::photon::config::{PhotonMapConfig, ProgressiveConfig};
use crate::photon::pm::PhotonMapper;
use crate::photon::progressive::{Progressive, Variant};
use lightlab_samplers::SamplerConfig;
use serde::{Deserialize, Serialize};

/// Which integrator to run and with what settings, e.g. `Path(max_bounces: 8, strategy: Mis)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum IntegratorConfig {
    /// Unidirectional path tracing from the camera (Kajiya 1986) with next-event estimation.
    Path(PathConfig),
    /// Light tracing (particle tracing; Arvo & Kirk 1990, Dutré et al. 1993): paths from the lights,
    /// every non-specular vertex connected to the camera.
    Light(LightConfig),
    /// Bidirectional path tracing (Veach & Guibas 1994): every (s, t) connection strategy, combined
    /// by the balance heuristic.
    Bdpt(BdptConfig),
    /// Photon mapping (Jensen 1996): a global and a caustic photon map, direct light by light
    /// sampling, final gather.
    PhotonMap(PhotonMapConfig),
    /// Progressive photon mapping (Hachisuka et al. 2008): fixed visible points, shrinking radius;
    /// samples per pixel count passes.
    Ppm(ProgressiveConfig),
    /// Stochastic progressive photon mapping (Hachisuka & Jensen 2009): new visible points every
    /// pass; samples per pixel count passes.
    Sppm(ProgressiveConfig),
}

/// Settings of bidirectional path tracing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    try_from = "BdptConfigRaw",
    into = "BdptConfigRaw"
)]
pub struct BdptConfig {
    pub max_bounces: Option<u32>,
    pub min_bounces: u32,
    pub russian_roulette: Option<u32>,
    pub sampler: SamplerConfig,
    pub mis: Mis,
    pub strategy_layers: bool,
    pub outliers: Option<f32>,
    pub paths: Option<String>,
    pub layers: Layers,
}

/// How bidirectional path tracing weights its strategies (Veach 1997, ch. 9).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Mis {
    /// wᵢ = pᵢ / Σⱼ pⱼ (Veach's balance heuristic).
    #[default]
    Balance,
    /// wᵢ = pᵢ² / Σⱼ pⱼ² (the power heuristic with β = 2).
    Power,
    /// wᵢ = 1 / (number of strategies that can produce the path): unweighted averaging.
    Uniform,
    /// No MIS: only strategy (s, t), with weight 1 — the paths of s + t − 2 bounces that this one
    /// strategy samples, for looking at one technique alone.
    Only { s: u32, t: u32 },
}

impl Mis {
    /// Whether strategy (s, t) is left out entirely.
    pub fn excludes(&self, s: usize, t: usize) -> bool {
        matches!(*self, Mis::Only { s: os, t: ot } if (os as usize, ot as usize) != (s, t))
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Bdpt")]
pub struct BdptConfigRaw {
    /// Largest number of scattering vertices of a full path; `None` for no limit. Default `None`.
    #[serde(default)]
    pub max_bounces: Option<u32>,
    /// Smallest number of scattering vertices a contribution must have. Default 0.
    #[serde(default)]
    pub min_bounces: u32,
    /// Russian roulette on both subpaths from this many vertices on; `None` turns it off.
    /// Default `Some(3)`.
    #[serde(default = "default_rr")]
    pub russian_roulette: Option<u32>,
    /// Sampler of the camera subpaths (the light subpaths use independent samples). Default
    /// `Independent`.
    #[serde(default)]
    pub sampler: SamplerConfig,
    /// Strategy weights: `Balance`, `Power`, `Uniform` or `Only(s: S, t: T)`. Default `Balance`.
    #[serde(default)]
    pub mis: Mis,
    /// Also write every strategy (s, t) as layers `s{s}t{t}` (MIS-weighted; they sum to the image)
    /// and `s{s}t{t}.unweighted` (the strategy's own estimate of its paths). Needs `max_bounces`.
    /// Default false.
    #[serde(default)]
    pub strategy_layers: bool,
    /// Log every contribution larger (in its largest channel) than this multiple of its pixel's
    /// running mean, with its provenance (pixel, sample index, strategy, path class, densities,
    /// MIS weight), for replay with `lightlab replay`. Non-finite contributions are always logged.
    /// Default `None` (only non-finite ones).
    #[serde(default)]
    pub outliers: Option<f32>,
    /// Render only the contributions of paths this expression matches (e.g. `"LS+DE"`; see the
    /// README's "Path classes"); `None` renders every path. Default `None`.
    #[serde(default)]
    pub paths: Option<String>,
    /// Image layers written besides the full image: `Off`, `Bounces` or
    /// `Classes(["LS+DE", ...])` (plus a `rest` layer). Default `Off`.
    #[serde(default)]
    pub layers: Layers,
}

impl TryFrom<BdptConfigRaw> for BdptConfig {
    type Error = String;
    fn try_from(r: BdptConfigRaw) -> Result<Self, String> {
        check_bounces(r.max_bounces, r.min_bounces, r.russian_roulette)?;
        if let Mis::Only { s, t } = r.mis
            && t == 0
        {
            return Err(format!(
                "Only(s: {s}, t: 0) is not a strategy: paths must reach the camera, so t ≥ 1"
            ));
        }
        Router::check(r.paths.as_deref(), &r.layers)?;
        if let Some(f) = r.outliers
            && !(f > 1.0 && f.is_finite())
        {
            return Err(format!(
                "outliers is a multiple of the pixel's running mean and must be finite and > 1, got {f}"
            ));
        }
        if r.strategy_layers && r.max_bounces.is_none() {
            return Err(
                "strategy_layers needs max_bounces (it bounds the number of strategies)".into(),
            );
        }
        Ok(BdptConfig {
            max_bounces: r.max_bounces,
            min_bounces: r.min_bounces,
            russian_roulette: r.russian_roulette,
            sampler: r.sampler,
            mis: r.mis,
            strategy_layers: r.strategy_layers,
            outliers: r.outliers,
            paths: r.paths,
            layers: r.layers,
        })
    }
}

impl From<BdptConfig> for BdptConfigRaw {
    fn from(c: BdptConfig) -> Self {
        BdptConfigRaw {
            max_bounces: c.max_bounces,
            min_bounces: c.min_bounces,
            russian_roulette: c.russian_roulette,
            sampler: c.sampler,
            mis: c.mis,
            strategy_layers: c.strategy_layers,
            outliers: c.outliers,
            paths: c.paths,
            layers: c.layers,
        }
    }
}

/// Settings of the light tracer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    try_from = "LightConfigRaw",
    into = "LightConfigRaw"
)]
pub struct LightConfig {
    pub max_bounces: Option<u32>,
    pub min_bounces: u32,
    pub russian_roulette: Option<u32>,
    pub paths: Option<String>,
    pub layers: Layers,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Light")]
pub struct LightConfigRaw {
    /// Largest number of scattering vertices (the vertex connected to the camera included); `None`
    /// for no limit. Default `None`.
    #[serde(default)]
    pub max_bounces: Option<u32>,
    /// Smallest number of scattering vertices a contribution must have. Default 0.
    #[serde(default)]
    pub min_bounces: u32,
    /// Russian roulette from this many scattering vertices on; `None` turns it off. Default `Some(3)`.
    #[serde(default = "default_rr")]
    pub russian_roulette: Option<u32>,
    /// Render only the contributions of paths this expression matches (e.g. `"LS+DE"`; see the
    /// README's "Path classes"); `None` renders every path. Default `None`.
    #[serde(default)]
    pub paths: Option<String>,
    /// Image layers written besides the full image: `Off`, `Bounces` or
    /// `Classes(["LS+DE", ...])` (plus a `rest` layer). Default `Off`.
    #[serde(default)]
    pub layers: Layers,
}

impl TryFrom<LightConfigRaw> for LightConfig {
    type Error = String;
    fn try_from(r: LightConfigRaw) -> Result<Self, String> {
        check_bounces(r.max_bounces, r.min_bounces, r.russian_roulette)?;
        Router::check(r.paths.as_deref(), &r.layers)?;
        Ok(LightConfig {
            max_bounces: r.max_bounces,
            min_bounces: r.min_bounces,
            russian_roulette: r.russian_roulette,
            paths: r.paths,
            layers: r.layers,
        })
    }
}

impl From<LightConfig> for LightConfigRaw {
    fn from(c: LightConfig) -> Self {
        LightConfigRaw {
            max_bounces: c.max_bounces,
            min_bounces: c.min_bounces,
            russian_roulette: c.russian_roulette,
            paths: c.paths,
            layers: c.layers,
        }
    }
}

/// The bounce settings every integrator shares: unbounded paths need Russian roulette, and
/// `min_bounces ≤ max_bounces`.
pub(crate) fn check_bounces(
    max_bounces: Option<u32>,
    min_bounces: u32,
    russian_roulette: Option<u32>,
) -> Result<(), String> {
    if max_bounces.is_none() && russian_roulette.is_none() {
        return Err("unbounded paths (max_bounces: None) need Russian roulette: set max_bounces or russian_roulette".into());
    }
    if let Some(max) = max_bounces
        && min_bounces > max
    {
        return Err(format!(
            "min_bounces ({min_bounces}) exceeds max_bounces ({max})"
        ));
    }
    Ok(())
}

/// Settings of the path tracer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    deny_unknown_fields,
    try_from = "PathConfigRaw",
    into = "PathConfigRaw"
)]
pub struct PathConfig {
    pub max_bounces: Option<u32>,
    pub min_bounces: u32,
    pub russian_roulette: Option<u32>,
    pub strategy: Strategy,
    pub shadows: bool,
    pub sampler: SamplerConfig,
    pub paths: Option<String>,
    pub layers: Layers,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Path")]
pub struct PathConfigRaw {
    /// Largest number of scattering vertices on a path; `None` for no limit (Russian roulette ends
    /// paths). Default `None`.
    #[serde(default)]
    pub max_bounces: Option<u32>,
    /// Smallest number of scattering vertices a contribution must have: `min_bounces: k,
    /// max_bounces: k` isolates the k-th term of the Neumann series. Default 0.
    #[serde(default)]
    pub min_bounces: u32,
    /// Russian roulette from this many scattering vertices on (survival probability
    /// min(1, max channel of the throughput)); `None` turns it off. Default `Some(3)`.
    #[serde(default = "default_rr")]
    pub russian_roulette: Option<u32>,
    /// How directions are chosen at each vertex. Default `Mis`.
    #[serde(default)]
    pub strategy: Strategy,
    /// Test visibility for next-event estimation. `false` computes direct illumination without
    /// shadows (and then counts emitters only through light sampling; see `Strategy`). Default true.
    #[serde(default = "yes")]
    pub shadows: bool,
    /// Where the sample values come from: `Independent`, `Stratified`, `LatinHypercube`, `Halton`
    /// or `Sobol` (see `lightlab_samplers::SamplerConfig`). Default `Independent`.
    #[serde(default)]
    pub sampler: SamplerConfig,
    /// Render only the contributions of paths this expression matches (e.g. `"LS+DE"`; see the
    /// README's "Path classes"); `None` renders every path. Default `None`.
    #[serde(default)]
    pub paths: Option<String>,
    /// Image layers written besides the full image: `Off`, `Bounces` or
    /// `Classes(["LS+DE", ...])` (plus a `rest` layer). Default `Off`.
    #[serde(default)]
    pub layers: Layers,
}

fn default_rr() -> Option<u32> {
    Some(3)
}
fn yes() -> bool {
    true
}

/// Sampling strategy of the path tracer, for comparing blind and informed Monte Carlo.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Strategy {
    /// Light sampling and BSDF sampling combined by the power heuristic (Veach 1997, §9.2).
    #[default]
    Mis,
    /// BSDF sampling only: emitters count when a sampled ray hits them.
    BsdfOnly,
    /// Light sampling only: emitters hit by BSDF-sampled rays count only after the camera or a
    /// specular vertex, where light sampling is impossible.
    LightOnly,
    /// Blind Monte Carlo: uniform directions on the hemisphere of the outgoing direction (the whole
    /// sphere for transmissive rough surfaces), no light sampling; specular vertices are sampled
    /// by their BSDF.
    Uniform,
}

impl TryFrom<PathConfigRaw> for PathConfig {
    type Error = String;
    fn try_from(r: PathConfigRaw) -> Result<Self, String> {
        check_bounces(r.max_bounces, r.min_bounces, r.russian_roulette)?;
        Router::check(r.paths.as_deref(), &r.layers)?;
        if !r.shadows && matches!(r.strategy, Strategy::BsdfOnly | Strategy::Uniform) {
            return Err(format!(
                "shadows: false switches off the visibility test of next-event estimation, which \
                 strategy {:?} does not do (no light sampling); use it with Mis or LightOnly",
                r.strategy
            ));
        }
        Ok(PathConfig {
            max_bounces: r.max_bounces,
            min_bounces: r.min_bounces,
            russian_roulette: r.russian_roulette,
            strategy: r.strategy,
            shadows: r.shadows,
            sampler: r.sampler,
            paths: r.paths,
            layers: r.layers,
        })
    }
}

impl From<PathConfig> for PathConfigRaw {
    fn from(c: PathConfig) -> Self {
        PathConfigRaw {
            max_bounces: c.max_bounces,
            min_bounces: c.min_bounces,
            russian_roulette: c.russian_roulette,
            strategy: c.strategy,
            shadows: c.shadows,
            sampler: c.sampler,
            paths: c.paths,
            layers: c.layers,
        }
    }
}

impl IntegratorConfig {
    /// Parses RON such as `Path(max_bounces: 8)`. Errors carry line:column.
    pub fn from_ron(text: &str) -> Result<IntegratorConfig, String> {
        ron_options()
            .from_str(text)
            .map_err(|e| format!("{}:{}: {}", e.span.start.line, e.span.start.col, e.code))
    }

    /// The settings written back as RON, every field explicit.
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

    /// The `paths` and `layers` settings, whatever the integrator.
    fn paths_and_layers(&mut self) -> (&mut Option<String>, &mut Layers) {
        match self {
            IntegratorConfig::Path(c) => (&mut c.paths, &mut c.layers),
            IntegratorConfig::Light(c) => (&mut c.paths, &mut c.layers),
            IntegratorConfig::Bdpt(c) => (&mut c.paths, &mut c.layers),
            IntegratorConfig::PhotonMap(c) => (&mut c.paths, &mut c.layers),
            IntegratorConfig::Ppm(c) | IntegratorConfig::Sppm(c) => (&mut c.paths, &mut c.layers),
        }
    }

    /// These settings with `paths` and/or `layers` replaced (checked as when parsed).
    pub fn with_paths_and_layers(
        mut self,
        paths: Option<String>,
        layers: Option<Layers>,
    ) -> Result<IntegratorConfig, String> {
        let (p, l) = self.paths_and_layers();
        if let Some(paths) = paths {
            *p = Some(paths);
        }
        if let Some(layers) = layers {
            *l = layers;
        }
        Router::check(p.as_deref(), l)?;
        Ok(self)
    }

    pub fn build(&self) -> Box<dyn Integrator> {
        match self {
            IntegratorConfig::Path(c) => Box::new(PathTracer::new(c.clone())),
            IntegratorConfig::Light(c) => Box::new(LightTracer::new(c.clone())),
            IntegratorConfig::Bdpt(c) => Box::new(Bdpt::new(c.clone())),
            IntegratorConfig::PhotonMap(c) => Box::new(PhotonMapper::new(c.clone())),
            IntegratorConfig::Ppm(c) => Box::new(Progressive::new(c.clone(), Variant::Ppm)),
            IntegratorConfig::Sppm(c) => Box::new(Progressive::new(c.clone(), Variant::Sppm)),
        }
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

    #[test]
    fn parses_defaults_and_round_trips() {
        let c = IntegratorConfig::from_ron("Path(max_bounces: 8)").unwrap();
        let IntegratorConfig::Path(p) = &c else {
            panic!("{c:?}")
        };
        assert_eq!(p.max_bounces, Some(8));
        assert_eq!(p.russian_roulette, Some(3));
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
            "Light(max_bounces: 2, min_bounces: 0, russian_roulette: 3, paths: None, layers: Off)"
        );
        assert_eq!(IntegratorConfig::from_ron(&l.to_ron()).unwrap(), l);
        for text in [
            "PhotonMap(photons: 1000, gather: Radius(Absolute(0.1)), indirect: Direct)",
            "Sppm(alpha: 0.5, update: Global, kernel: Cone)",
            "Ppm(radius: Absolute(0.01))",
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
    }

    #[test]
    fn rejects_bad_settings_with_position() {
        let e = IntegratorConfig::from_ron("Path(max_bounce: 8)").unwrap_err();
        assert!(e.starts_with("1:") && e.contains("max_bounce"), "{e}");
        let e = IntegratorConfig::from_ron("Path(max_bounces: None, russian_roulette: None)")
            .unwrap_err();
        assert!(e.contains("Russian roulette"), "{e}");
        let e = IntegratorConfig::from_ron("Path(max_bounces: 2, min_bounces: 3)").unwrap_err();
        assert!(e.contains("min_bounces"), "{e}");
        let e = IntegratorConfig::from_ron("Path(max_bounces: -1)").unwrap_err();
        assert!(e.contains("1:"), "{e}");
        assert!(
            IntegratorConfig::from_ron("Pth()")
                .unwrap_err()
                .contains("Path")
        );
        assert!(
            IntegratorConfig::from_ron("Light(strategy: Mis)")
                .unwrap_err()
                .contains("strategy")
        );
        assert!(
            IntegratorConfig::from_ron("Light(min_bounces: 3, max_bounces: 1)")
                .unwrap_err()
                .contains("min_bounces")
        );
        for (bad, words) in [
            ("Sppm(alpha: 1.5)", "alpha"),
            ("Sppm(alpha: 0)", "alpha"),
            ("Sppm(radius: Absolute(0))", "radius"),
            ("Sppm(radius: Relative(-1))", "radius"),
            ("Ppm(photons_per_pass: 0)", "photons_per_pass"),
            ("PhotonMap(photons: 0)", "photons"),
            (
                "PhotonMap(gather: Nearest(k: 0, max_radius: Relative(0.1)))",
                "k must",
            ),
            (
                "PhotonMap(caustic_gather: Radius(Absolute(inf)))",
                "caustic_gather radius",
            ),
            ("PhotonMap(indirect: FinalGather(rays: 0))", "FinalGather"),
            ("PhotonMap(kernel: Gaussian)", "Epanechnikov"),
        ] {
            let e = IntegratorConfig::from_ron(bad).unwrap_err();
            assert!(e.contains(words) && e.contains(':'), "{bad}: {e}");
        }
        assert!(
            IntegratorConfig::from_ron("Path(sampler: Sobl)")
                .unwrap_err()
                .contains("Sobol")
        );
    }
}
