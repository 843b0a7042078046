//! Path classes and the image layers they select: every contribution an integrator makes carries
//! its Heckbert path string (`class`); a regular expression over those strings (`regex`) filters
//! what an integrator renders (`paths: "LS+DE"`), and a [`Layers`] request splits the image into
//! layers — by expression (the first that matches, plus a remainder) or by bounce count (the terms
//! of the Neumann series) — that always sum to the full image.

pub mod class;
pub mod regex;

pub use class::PathClass;
pub use regex::{PathRegex, PathRegexError};

use class::MAX_RECORDED;
use serde::{Deserialize, Serialize};

/// Which layers an integrator writes besides the full image.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Layers {
    /// The full image only.
    #[default]
    Off,
    /// One layer per number of scattering vertices k = 0, 1, …: the terms gε, gMε, gMgMε, … of
    /// the Neumann series. Up to `max_bounces` when it is set, otherwise 0…9 and a last layer for
    /// 10 or more.
    Bounces,
    /// One layer per expression, holding the contributions whose path the expression matches
    /// first, and a last layer, `rest`, for the contributions none matches.
    Classes(Vec<String>),
}

/// Bounce layers of an unbounded integrator: 0 … UNBOUNDED_BOUNCE_LAYERS − 2, then the rest.
const UNBOUNDED_BOUNCE_LAYERS: u32 = 11;

/// Decides, per contribution, whether it is rendered and into which layer.
#[derive(Clone, Debug)]
pub struct Router {
    filter: Option<PathRegex>,
    split: Split,
}

#[derive(Clone, Debug)]
enum Split {
    None,
    /// This many layers, one per bounce count; with `catch_all` the last holds every count from
    /// its own on (unbounded walks, or more bounces than there are layers).
    Bounces {
        layers: u32,
        catch_all: bool,
    },
    Classes(Vec<PathRegex>),
}

impl Router {
    /// The router of an integrator with `paths` (an expression, or `None` for all paths),
    /// `layers` and `max_bounces`. Errors name the bad expression and the column of the fault.
    pub fn new(
        paths: Option<&str>,
        layers: &Layers,
        max_bounces: Option<u32>,
    ) -> Result<Router, String> {
        let filter = paths
            .map(PathRegex::new)
            .transpose()
            .map_err(|e| format!("paths: {e}"))?;
        let split = match layers {
            Layers::Off => Split::None,
            Layers::Bounces => {
                let layers =
                    max_bounces.map_or(UNBOUNDED_BOUNCE_LAYERS, |m| m.saturating_add(1).min(64));
                Split::Bounces {
                    layers,
                    catch_all: max_bounces.is_none_or(|m| m >= layers),
                }
            }
            Layers::Classes(exprs) => {
                if exprs.is_empty() {
                    return Err("layers: Classes needs at least one expression".into());
                }
                let regexes: Vec<PathRegex> = exprs
                    .iter()
                    .map(|e| PathRegex::new(e))
                    .collect::<Result<_, _>>()
                    .map_err(|e| format!("layers: {e}"))?;
                // Each layer is named by its expression; a repeated one would name two layers alike
                // (which no EXR holds) and leave the second always empty, as the first match wins.
                for (i, r) in regexes.iter().enumerate() {
                    if regexes[..i].iter().any(|q| q.as_str() == r.as_str()) {
                        return Err(format!(
                            "layers: {} is given twice; each expression names one layer, so list it once",
                            r.as_str()
                        ));
                    }
                }
                Split::Classes(regexes)
            }
        };
        Ok(Router { filter, split })
    }

    /// Checks settings without keeping the router (for configuration parsing), and that `paths`
    /// matches some path of `min_bounces` to `max_bounces` scattering vertices (else every path
    /// would be filtered out, and the image black without a word).
    pub fn check(
        paths: Option<&str>,
        layers: &Layers,
        min_bounces: u32,
        max_bounces: Option<u32>,
    ) -> Result<(), String> {
        let router = Router::new(paths, layers, None)?;
        if let Some(filter) = &router.filter
            && filter
                .lengths(min_bounces, max_bounces.unwrap_or(u32::MAX))
                .is_empty()
        {
            let all = filter.lengths(0, u32::MAX);
            return Err(format!(
                "paths: \"{}\" matches no path of {} scattering vertices (bounces), so every path \
                 would be filtered out and the image black; it matches {}",
                filter.as_str(),
                match max_bounces {
                    Some(max) if max == min_bounces => format!("{max}"),
                    Some(max) => format!("{min_bounces} to {max}"),
                    None => format!("{min_bounces} or more"),
                },
                describe_lengths(&all)
            ));
        }
        Ok(())
    }

    /// Number of layers besides the full image.
    pub fn layer_count(&self) -> usize {
        match &self.split {
            Split::None => 0,
            Split::Bounces { layers, .. } => *layers as usize,
            Split::Classes(r) => r.len() + 1,
        }
    }

    /// Names of the layers, in order.
    pub fn layer_names(&self) -> Vec<String> {
        match &self.split {
            Split::None => Vec::new(),
            &Split::Bounces { layers, catch_all } => (0..layers)
                .map(|k| {
                    if catch_all && k == layers - 1 {
                        format!("bounces {k}+")
                    } else {
                        format!("bounces {k}")
                    }
                })
                .collect(),
            Split::Classes(r) => r
                .iter()
                .map(|e| e.as_str().to_string())
                .chain(["rest".to_string()])
                .collect(),
        }
    }

    /// `None` when the contribution of a path of class `class` is filtered out; otherwise its
    /// layer (0 when there are no layers).
    #[inline]
    pub fn route(&self, class: &PathClass) -> Option<usize> {
        if let Some(f) = &self.filter
            && !f.matches(class)
        {
            return None;
        }
        Some(match &self.split {
            Split::None => 0,
            Split::Bounces { layers, .. } => (class.len() as usize).min(*layers as usize - 1),
            Split::Classes(r) => r.iter().position(|e| e.matches(class)).unwrap_or(r.len()),
        })
    }

    /// Whether every contribution goes to the full image alone, so that hot loops can skip
    /// building path classes.
    #[inline]
    pub fn is_trivial(&self) -> bool {
        self.filter.is_none() && matches!(self.split, Split::None)
    }
}

/// Numbers of scattering vertices as a phrase: "paths of 2", "paths of 1, 3 or 5", "paths of 2
/// or more" (a run up to [`MAX_RECORDED`], past which no path matches).
fn describe_lengths(lengths: &[u32]) -> String {
    match lengths {
        [] => format!("no path of up to {MAX_RECORDED} scattering vertices"),
        [1] => "paths of 1 scattering vertex".into(),
        [k] => format!("paths of {k} scattering vertices"),
        [first, .., last] if *last == MAX_RECORDED && lengths.len() as u32 == last - first + 1 => {
            format!("paths of {first} or more scattering vertices")
        }
        [rest @ .., last] => {
            let rest: Vec<String> = rest.iter().map(u32::to_string).collect();
            format!("paths of {} or {last} scattering vertices", rest.join(", "))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An expression that matches no path within the bounce limits is refused, saying which
    /// lengths it matches: `--paths LDDE` with `max_bounces: 1` rendered black without a word.
    #[test]
    fn paths_outside_the_bounce_limits_are_refused() {
        let check = |paths: &str, min: u32, max: Option<u32>| {
            Router::check(Some(paths), &Layers::Off, min, max)
        };
        let e = check("LDDE", 0, Some(1)).unwrap_err();
        assert!(
            e.contains("\"LDDE\" matches no path of 0 to 1 scattering vertices")
                && e.contains("it matches paths of 2 scattering vertices"),
            "{e}"
        );
        let e = check("LDE|LDDDE", 2, Some(2)).unwrap_err();
        assert!(
            e.contains("of 2 scattering") && e.contains("paths of 1 or 3"),
            "{e}"
        );
        let e = check("LD+E", 0, Some(0)).unwrap_err();
        assert!(e.contains("paths of 1 or more"), "{e}");
        let e = check("LE", 1, None).unwrap_err();
        assert!(
            e.contains("1 or more scattering") && e.contains("paths of 0 scattering"),
            "{e}"
        );
        for (paths, min, max) in [
            ("LDDE", 0, Some(2)),
            ("LD+E", 5, None),
            ("LS*DE", 3, Some(3)),
            ("LE", 0, Some(0)),
        ] {
            check(paths, min, max).unwrap();
        }
        // Layers may be empty at a bounce limit (an experiment's classes under a max_bounces sweep).
        Router::check(None, &Layers::Classes(vec!["LDDE".into()]), 0, Some(1)).unwrap();
        // Past the recorded 32 vertices no path matches.
        let long = format!("L{}E", "D".repeat(33));
        let e = check(&long, 0, None).unwrap_err();
        assert!(e.contains("no path of up to 32"), "{e}");
    }

    /// A bounce layer that holds every count from its own on says so with `+`: the last layer of
    /// an unbounded walk, and of a walk with more bounces than the 64 layers; never a layer of
    /// exactly one count.
    #[test]
    fn bounce_layer_names_mark_the_catch_all() {
        let last = |max: Option<u32>| {
            let names = Router::new(None, &Layers::Bounces, max)
                .unwrap()
                .layer_names();
            (names.len(), names.last().unwrap().clone())
        };
        assert_eq!(last(None), (11, "bounces 10+".into()));
        assert_eq!(last(Some(100)), (64, "bounces 63+".into()));
        assert_eq!(last(Some(63)), (64, "bounces 63".into()));
        assert_eq!(last(Some(10)), (11, "bounces 10".into()));
        assert_eq!(last(Some(0)), (1, "bounces 0".into()));
    }
}
