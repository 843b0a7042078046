//! Chi-square goodness-of-fit tests that `Bsdf::sample` draws directions with density `Bsdf::pdf`,
//! with the testkit harness (Mitsuba 3's `chi2.py` procedure: 10⁶ draws, expected counts from the
//! pdf integrated over each cell, cells expected below 5 pooled, immediate failure for a sample
//! where the pdf integrates to zero). A draw that `sample` rejects (a reflection below the
//! horizon, a refraction under total internal reflection) is lost mass: the expected counts come
//! from ∫ pdf times the number of draws, so these tests check the pdf's normalisation as well as
//! its shape.
//!
//! Two charts:
//!
//! - **Sphere** ([`Domain::Sphere`], 41 × 80 equal-area cells over all directions) for lobes wider
//!   than a cell: Diffuse, Plastic (its base), RoughPlastic, Phong with exponents 0, 1 and 20, GGX with α from 0.05 to 1 and anisotropic
//!   α = (0.1, 0.6), Beckmann with α = 0.3 and (0.1, 0.6). The horizon lies in the middle of a row, on an edge of the integration
//!   sub-grid, so the jump from reflection to transmission is integrated exactly.
//! - **Window** ([`DirectionWindow`] on [`Domain::Square`]) for near-specular lobes (GGX with
//!   α = 10⁻³, the `ALPHA_MIN` clamp and anisotropic (10⁻³, 2·10⁻²), Phong with exponent 1000):
//!   the gnomonic chart around the lobe's centre, aligned with the principal axes of the lobe and
//!   four GGX widths (or cosⁿ widths) across, so the lobe fills the 41 × 40 cells even at
//!   grazing incidence, where it is 1000 times narrower across the plane of incidence than
//!   along it. Draws outside the window count as rejected. At grazing incidence these tests put
//!   `wo` in the xz-plane: the lobe is then 2·10⁻⁶ rad wide across the plane, and only there are
//!   the sampled directions' small components computed without cancellation in f32 (at a generic
//!   azimuth their rounding, ~6·10⁻⁸, is 3 % of the lobe's width).
//!
//! Incident directions: normal, 45° and grazing (10⁻³ rad above the horizon), on both sides of the
//! surface for the two-sided models and for glass (seen from inside at 30° instead of 45° for the
//! near-specular transmission lobe: 45° is beyond the critical angle).
//!
//! False failures: every chi-square run uses the default α = sidak(0.01, 300) = 3.35 × 10⁻⁵.
//! This file makes 181 runs (counted per test function below), so a correct implementation fails
//! some run with probability 1 − (1 − α)¹⁸¹ ≈ 0.60 % over the choice of seeds; the seeds are fixed,
//! so a passing suite keeps passing until the sampling code changes.

use crate::common::*;
use glam::{DVec2, DVec3};
use lightlab_core::{TransportMode, Vec2, Vec3};
use lightlab_materials::{ALPHA_MIN, Bsdf, Distribution};
use lightlab_testkit::{Chi2Test, DirectionWindow, Domain};

/// Windows span this many lobe widths on each side of the centre.
const WINDOW_WIDTHS: f64 = 4.0;

/// The sampled direction; a delta lobe's (plastic's coating) counts as a rejected draw, the mass
/// `pdf` does not describe.
fn sample_wi(bsdf: Bsdf, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
    bsdf.sample(wo, u_lobe, u, TransportMode::Radiance)
        .filter(|s| !s.delta)
        .map(|s| s.wi)
}

/// The sphere histogram's frame: a cyclic permutation of the axes, (x, y, z) ↦ (y, z, x), exact
/// in floating point. Its poles are the horizon directions ±x, where no tested lobe peaks; in the
/// harness's own frame the lobes of normal incidence would sit on the poles, whose wedge-shaped
/// cells resolve a lobe narrower than a row (≈ 0.2 rad) too poorly to integrate. The horizon is
/// the histogram's φ = 0 and φ = π meridians, cell edges, so the jump there (reflection to
/// transmission, or to zero) is integrated exactly.
fn to_histogram(w: Vec3) -> Vec3 {
    Vec3::new(w.y, w.z, w.x)
}

fn from_histogram(v: Vec3) -> Vec3 {
    Vec3::new(v.z, v.x, v.y)
}

/// Chi-square test over the whole sphere of directions (12 × 12 integration points per cell:
/// the glossy lobes span a few cells).
fn chi2_sphere(name: &str, bsdf: Bsdf, wo: Vec3, seed: u64) {
    Chi2Test::new(Domain::Sphere)
        .seed(seed)
        .integration(12)
        .run_lobe(
            name,
            |u_lobe, u| sample_wi(bsdf, wo, u_lobe, u).map(to_histogram),
            |v: Vec3| bsdf.pdf(wo, from_histogram(v)),
        )
        .assert_ok();
}

/// Chi-square test on a window of directions; samples outside it are rejected draws.
fn chi2_window(name: &str, bsdf: Bsdf, wo: Vec3, window: &DirectionWindow, seed: u64) {
    Chi2Test::new(Domain::Square)
        .seed(seed)
        .run_lobe(
            name,
            |u_lobe, u| sample_wi(bsdf, wo, u_lobe, u).and_then(|wi| window.to_square(wi)),
            |p: Vec2| window.density(p, |wi| bsdf.pdf(wo, wi)),
        )
        .assert_ok();
}

/// Runs `chi2_sphere` for each incident direction; returns the number of runs.
fn sphere_cases(label: &str, bsdf: Bsdf, wos: &[Vec3], seed: u64) -> usize {
    for (k, &wo) in wos.iter().enumerate() {
        chi2_sphere(&format!("{label}_wo{k}"), bsdf, wo, seed + k as u64);
    }
    wos.len()
}

// ---- Lobe windows --------------------------------------------------------------------------

/// The microfacet normal with slopes δ (Walter et al. 2007: m ∝ (−δx, −δy, 1)).
fn slope_normal(d: DVec2) -> DVec3 {
    DVec3::new(-d.x, -d.y, 1.0).normalize()
}

fn reflect(wo: DVec3, m: DVec3) -> DVec3 {
    2.0 * wo.dot(m) * m - wo
}

/// Snell refraction of `wo` through the interface with normal `m` and relative index
/// η = η_inside / η_outside (outside where `m` points), in f64; `None` under total internal
/// reflection.
fn refract(wo: DVec3, m: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = m.dot(wo);
    let (m, eta, cos_i) = if cos_i < 0.0 {
        (-m, 1.0 / eta, -cos_i)
    } else {
        (m, eta, cos_i)
    };
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    (sin2_t < 1.0).then(|| -wo / eta + (cos_i / eta - (1.0 - sin2_t).sqrt()) * m)
}

/// The window around the reflection lobe of slopes with scale `alpha`.
fn reflection_window(wo: Vec3, alpha: Vec2) -> DirectionWindow {
    let wo = wo.as_dvec3();
    DirectionWindow::around_lobe(
        |d| Some(reflect(wo, slope_normal(d))),
        (alpha.x as f64, alpha.y as f64),
        WINDOW_WIDTHS,
    )
    .expect("a reflection lobe")
}

/// The window around the transmission lobe, `None` under total internal reflection.
fn transmission_window(wo: Vec3, alpha: Vec2, eta: f32) -> Option<DirectionWindow> {
    let wo = wo.as_dvec3();
    DirectionWindow::around_lobe(
        |d| refract(wo, slope_normal(d), eta as f64),
        (alpha.x as f64, alpha.y as f64),
        WINDOW_WIDTHS,
    )
}

/// A direction in the xz-plane (1 ± 0.03)·10⁻³ rad above the horizon whose f32 components have
/// x² + z² = 1 to 10⁻¹²: x = sin θ rounded, then z = √(1 − x²) rounded, which z's fine spacing
/// near 10⁻³ allows (an f32 direction there is typically 3·10⁻⁸ off unit length). The samplers
/// reflect `wo` as given, so a longer `wo` tilts the half vector of (wo, unit wi) by (|wo| − 1) /
/// (2 cos θo) ≈ 1.5·10⁻⁵ — 15 % of α at `ALPHA_MIN`, which a window test sees as a shifted lobe.
fn grazing_unit_xz() -> Vec3 {
    let x = GRAZING.sin();
    let z = (1.0 - (x as f64).powi(2)).sqrt() as f32;
    let error = ((x as f64).powi(2) + (z as f64).powi(2) - 1.0).abs();
    assert!(
        error < 1e-12 && (z / 1e-3 - 1.0).abs() < 0.03,
        "z {z}, error {error}"
    );
    Vec3::new(x, 0.0, z)
}

/// Normal incidence, 45° and grazing in the xz-plane (see the module docs), upper side.
fn wos_near_specular() -> Vec<Vec3> {
    vec![
        Vec3::Z,
        dir(std::f32::consts::FRAC_PI_4, 0.7),
        grazing_unit_xz(),
    ]
}

fn flip(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

// ---- Diffuse ------------------------------------------------------------------------------

/// 6 runs.
#[test]
fn chi2_diffuse() {
    sphere_cases("diffuse", diffuse(), &wos_both_sides(), 4100);
}

// ---- RoughConductor -----------------------------------------------------------------------

/// 6 runs: α = 10⁻³ on both sides.
#[test]
fn chi2_rough_conductor_alpha_1e_3() {
    let alpha = Vec2::splat(1e-3);
    let wos: Vec<Vec3> = wos_near_specular()
        .into_iter()
        .flat_map(|w| [w, flip(w)])
        .collect();
    for (k, &wo) in wos.iter().enumerate() {
        let window = reflection_window(wo, alpha);
        chi2_window(
            &format!("rough_conductor_a1e-3_wo{k}"),
            rough_conductor(alpha),
            wo,
            &window,
            4200 + k as u64,
        );
    }
}

/// GGX density of visible-normal reflection, G1(wo) D(h) / (4 |cos θo|) (Heitz 2018, eq. 17;
/// Walter et al. 2007, eq. 14), written independently of the crate and evaluated in f64 for the
/// f64 directions of a window.
fn ggx_reflection_pdf_f64(wo: DVec3, wi: DVec3, alpha: DVec2) -> f64 {
    if wo.z * wi.z <= 0.0 {
        return 0.0;
    }
    let up = DVec3::new(1.0, 1.0, wo.z.signum());
    let (wo, wi) = (wo * up, wi * up);
    let h = (wo + wi).normalize();
    let e = (h.x / alpha.x).powi(2) + (h.y / alpha.y).powi(2) + h.z * h.z;
    let d = 1.0 / (std::f64::consts::PI * alpha.x * alpha.y * e * e);
    let tan2 = ((alpha.x * wo.x).powi(2) + (alpha.y * wo.y).powi(2)) / (wo.z * wo.z);
    let lambda = 0.5 * ((1.0 + tan2).sqrt() - 1.0);
    d / (1.0 + lambda) / (4.0 * wo.z)
}

/// 6 runs: α = 0 given, raised to `ALPHA_MIN` (3 incidences), and anisotropic (10⁻³, 2·10⁻²)
/// (3 incidences, 45° at an azimuth where the lobe's axes are oblique to the plane of incidence).
///
/// At `ALPHA_MIN` and grazing incidence the lobe is 2·10⁻⁴ rad long in the plane of incidence,
/// where a direction near (−1, 0, 10⁻³) changes its x component by only 2·10⁻⁷ across the lobe:
/// three f32 ulps. An f32 direction cannot resolve that lobe (rounding x moves the half vector
/// it implies by ~30 % of α), so `Bsdf::pdf` at the harness's f32 test points is noise at the cell
/// scale even though it is exact for its input. That case tests the sampler against the
/// independent f64 density above at the window's f64 directions, and checks separately that
/// `Bsdf::pdf` equals that density at the sampled f32 directions (to 10⁻⁵).
#[test]
fn chi2_rough_conductor_alpha_min_and_anisotropic_near_specular() {
    let bsdf = rough_conductor(Vec2::ZERO);
    let alpha = Vec2::splat(ALPHA_MIN);
    for (k, wo) in wos_near_specular().into_iter().enumerate() {
        let name = format!("rough_conductor_alpha_min_wo{k}");
        let window = reflection_window(wo, alpha);
        if wo.z > 1e-2 {
            chi2_window(&name, bsdf, wo, &window, 4250 + k as u64);
            continue;
        }
        let (wo64, alpha64) = (wo.as_dvec3(), alpha.as_dvec2());
        let mut rng = rng(4259);
        for _ in 0..10_000 {
            let Some(s) = bsdf.sample(wo, 0.5, uniform2(&mut rng), TransportMode::Radiance) else {
                continue;
            };
            let reference = ggx_reflection_pdf_f64(wo64, s.wi.as_dvec3(), alpha64) as f32;
            assert_rel(s.pdf, reference, 1e-5, &|| {
                format!("{name}: pdf at {}", s.wi)
            });
            assert_rel(bsdf.pdf(wo, s.wi), reference, 1e-5, &|| {
                format!("{name}: pdf()")
            });
        }
        Chi2Test::new(Domain::Square)
            .seed(4250 + k as u64)
            .run_lobe(
                &name,
                |u_lobe, u| sample_wi(bsdf, wo, u_lobe, u).and_then(|wi| window.to_square(wi)),
                |p: Vec2| window.density_f64(p, |wi| ggx_reflection_pdf_f64(wo64, wi, alpha64)),
            )
            .assert_ok();
    }
    let alpha = Vec2::new(1e-3, 2e-2);
    for (k, wo) in wos_near_specular().into_iter().enumerate() {
        let window = reflection_window(wo, alpha);
        chi2_window(
            &format!("rough_conductor_a1e-3x2e-2_wo{k}"),
            rough_conductor(alpha),
            wo,
            &window,
            4260 + k as u64,
        );
    }
}

/// 12 runs: α = 0.05 on windows (the lobe spans two sphere cells) and α = 0.3 on the sphere,
/// both sides.
#[test]
fn chi2_rough_conductor_glossy() {
    let alpha = Vec2::splat(0.05);
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        let window = reflection_window(wo, alpha);
        chi2_window(
            &format!("rough_conductor_a0.05_wo{k}"),
            rough_conductor(alpha),
            wo,
            &window,
            4300 + k as u64,
        );
    }
    sphere_cases(
        "rough_conductor_a0.3",
        rough_conductor(Vec2::splat(0.3)),
        &wos_both_sides(),
        4310,
    );
}

/// 12 runs: α = 1 and anisotropic (0.1, 0.6), both sides.
#[test]
fn chi2_rough_conductor_rough_and_anisotropic() {
    sphere_cases(
        "rough_conductor_a1",
        rough_conductor(Vec2::splat(1.0)),
        &wos_both_sides(),
        4400,
    );
    sphere_cases(
        "rough_conductor_a0.1x0.6",
        rough_conductor(Vec2::new(0.1, 0.6)),
        &wos_both_sides(),
        4410,
    );
}

// ---- Beckmann ------------------------------------------------------------------------------

/// 30 runs: Beckmann normals (visible normals, Heitz & d'Eon 2014) on gold at α = 0.05 (reflection window),
/// 0.3 and (0.1, 0.6), and on glass at 0.3 and (0.1, 0.6), both sides.
#[test]
fn chi2_beckmann() {
    let gold = |alpha| Bsdf::RoughConductor {
        alpha,
        eta: GOLD_ETA,
        k: GOLD_K,
        distribution: Distribution::Beckmann,
    };
    let glass = |alpha| Bsdf::RoughDielectric {
        alpha,
        eta: 1.5,
        distribution: Distribution::Beckmann,
    };
    let alpha = Vec2::splat(0.05);
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        let window = reflection_window(wo, alpha);
        chi2_window(
            &format!("beckmann_conductor_a0.05_wo{k}"),
            gold(alpha),
            wo,
            &window,
            4800 + k as u64,
        );
    }
    let mut runs = 0;
    for (i, alpha) in [Vec2::splat(0.3), Vec2::new(0.1, 0.6)]
        .into_iter()
        .enumerate()
    {
        let seed = 4810 + 20 * i as u64;
        runs += sphere_cases(
            &format!("beckmann_conductor_a{alpha}"),
            gold(alpha),
            &wos_both_sides(),
            seed,
        );
        runs += sphere_cases(
            &format!("beckmann_dielectric_a{alpha}"),
            glass(alpha),
            &wos_both_sides(),
            seed + 10,
        );
    }
    assert_eq!(runs, 24);
}

// ---- RoughDielectric ----------------------------------------------------------------------

/// Near-specular glass: a window on the reflection lobe and, unless totally internally
/// reflected, one on the transmission lobe. Returns the number of runs.
fn rough_dielectric_windows(label: &str, alpha: Vec2, eta: f32, wos: &[Vec3], seed: u64) -> usize {
    let bsdf = Bsdf::RoughDielectric {
        alpha,
        eta,
        distribution: Distribution::Ggx,
    };
    let clamped = alpha.max(Vec2::splat(ALPHA_MIN));
    let mut runs = 0;
    for (k, &wo) in wos.iter().enumerate() {
        let seed = seed + 2 * k as u64;
        let window = reflection_window(wo, clamped);
        chi2_window(&format!("{label}_r_wo{k}"), bsdf, wo, &window, seed);
        runs += 1;
        if let Some(window) = transmission_window(wo, clamped, eta) {
            chi2_window(&format!("{label}_t_wo{k}"), bsdf, wo, &window, seed + 1);
            runs += 1;
        }
    }
    runs
}

/// 13 runs: α = 10⁻³, η = 1.5, from outside (normal, 45°, grazing: reflection and transmission)
/// and from inside (normal and 30°: both lobes; grazing: reflection only, beyond the critical
/// angle), and α = 0 raised to `ALPHA_MIN` at 45° from outside (both lobes).
#[test]
fn chi2_rough_dielectric_near_specular() {
    let outside = wos_near_specular();
    let inside = vec![
        -Vec3::Z,
        flip(dir(std::f32::consts::FRAC_PI_6, 0.7)),
        flip(grazing_unit_xz()),
    ];
    let mut runs = rough_dielectric_windows(
        "rough_dielectric_a1e-3_out",
        Vec2::splat(1e-3),
        1.5,
        &outside,
        4500,
    );
    runs += rough_dielectric_windows(
        "rough_dielectric_a1e-3_in",
        Vec2::splat(1e-3),
        1.5,
        &inside,
        4520,
    );
    runs += rough_dielectric_windows(
        "rough_dielectric_alpha_min",
        Vec2::ZERO,
        1.5,
        &[dir(std::f32::consts::FRAC_PI_4, 0.7)],
        4540,
    );
    assert_eq!(runs, 13);
}

/// 16 runs: α = 0.05 with η = 1.5 on windows, both sides (10: from inside at 45° and grazing,
/// beyond the critical angle, there is no transmission window), and α = 0.3 with η = 1/1.5 (the
/// same interface with its sides swapped) on the sphere, both sides.
#[test]
fn chi2_rough_dielectric_glossy() {
    let runs = rough_dielectric_windows(
        "rough_dielectric_a0.05",
        Vec2::splat(0.05),
        1.5,
        &wos_both_sides(),
        4600,
    );
    assert_eq!(runs, 10);
    sphere_cases(
        "rough_dielectric_a0.3_eta1/1.5",
        Bsdf::RoughDielectric {
            alpha: Vec2::splat(0.3),
            eta: 1.0 / 1.5,
            distribution: Distribution::Ggx,
        },
        &wos_both_sides(),
        4620,
    );
}

/// 6 runs: α = 0.3, η = 1.5, both sides.
#[test]
fn chi2_rough_dielectric_alpha_0_3() {
    sphere_cases(
        "rough_dielectric_a0.3",
        Bsdf::RoughDielectric {
            alpha: Vec2::splat(0.3),
            eta: 1.5,
            distribution: Distribution::Ggx,
        },
        &wos_both_sides(),
        4700,
    );
}

/// 6 runs: α = 1, η = 1.5, both sides.
#[test]
fn chi2_rough_dielectric_alpha_1() {
    sphere_cases(
        "rough_dielectric_a1",
        Bsdf::RoughDielectric {
            alpha: Vec2::splat(1.0),
            eta: 1.5,
            distribution: Distribution::Ggx,
        },
        &wos_both_sides(),
        4710,
    );
}

/// 6 runs: α = (0.1, 0.6), η = 1.5, both sides.
#[test]
fn chi2_rough_dielectric_anisotropic() {
    sphere_cases(
        "rough_dielectric_a0.1x0.6",
        Bsdf::RoughDielectric {
            alpha: Vec2::new(0.1, 0.6),
            eta: 1.5,
            distribution: Distribution::Ggx,
        },
        &wos_both_sides(),
        4720,
    );
}

// ---- Plastic -------------------------------------------------------------------------------

/// 16 runs: linear and nonlinear, η = 1.5 and 1/1.5, normal and 30° incidence on both sides
/// (45° is beyond the critical angle of η = 1/1.5, where every draw is the coating's). The
/// coating's delta reflections are rejected draws, so the counts also test the selection
/// probability. At grazing incidence the coating reflects all but 0.3 % of the draws, too few
/// for the chart (the normalisation test covers it).
#[test]
fn chi2_plastic() {
    let oblique = dir(std::f32::consts::FRAC_PI_6, 0.7);
    let wos = [Vec3::Z, -Vec3::Z, oblique, flip(oblique)];
    for (k, bsdf) in plastics().into_iter().enumerate() {
        sphere_cases(&format!("plastic{k}"), bsdf, &wos, 5000 + 10 * k as u64);
    }
}

/// 28 runs: the four rough plastics on the sphere, normal, 45° and grazing incidence on both
/// sides — except α = 0.05 at grazing incidence, whose coating lobe is narrower than a sphere cell
/// there — and α = 0.05 on reflection windows around its lobe, all six incidences (the base inside
/// the window is tested with it). The pdf sums both lobes with their selection probabilities, so
/// the counts test the tabulated transmittance that sets them as well as each lobe's shape.
#[test]
fn chi2_rough_plastic() {
    let plastics = rough_plastics();
    let mut runs = 0;
    for (k, &bsdf) in plastics.iter().enumerate() {
        let wos = wos_both_sides();
        let wos = if k == 0 { &wos[..4] } else { &wos[..] };
        runs += sphere_cases(
            &format!("rough_plastic{k}"),
            bsdf,
            wos,
            5100 + 10 * k as u64,
        );
    }
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        let window = reflection_window(wo, Vec2::splat(0.05));
        let name = format!("rough_plastic0_window_wo{k}");
        chi2_window(&name, plastics[0], wo, &window, 5150 + k as u64);
        runs += 1;
    }
    assert_eq!(runs, 28);
}

// ---- Phong --------------------------------------------------------------------------------

/// 18 runs: exponents 0 (the cos⁰ lobe is a cosine-weighted hemisphere about the mirror direction,
/// which `eval` once spread over the whole hemisphere of `wo`: 0⁰ = 1), 1 and 20, both sides.
#[test]
fn chi2_phong_low_exponents() {
    sphere_cases("phong_n0", phong(0.0), &wos_both_sides(), 4790);
    sphere_cases("phong_n1", phong(1.0), &wos_both_sides(), 4800);
    sphere_cases("phong_n20", phong(20.0), &wos_both_sides(), 4810);
}

/// 6 runs: exponent 1000, both sides, on a window around the mirror direction (the cosⁿ lobe has
/// width ~1/√n ≈ 0.03 rad); the diffuse part inside the window is tested with it.
#[test]
fn chi2_phong_high_exponent() {
    let n = 1000.0;
    for (k, wo) in wos_both_sides().into_iter().enumerate() {
        let mirror = DVec3::new(-wo.x as f64, -wo.y as f64, wo.z as f64);
        let half = WINDOW_WIDTHS / (n as f64 + 1.0).sqrt();
        let window = DirectionWindow::new(mirror, DVec3::Z, (half, half));
        chi2_window(
            &format!("phong_n1000_wo{k}"),
            phong(n),
            wo,
            &window,
            4900 + k as u64,
        );
    }
}
