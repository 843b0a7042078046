//! Robustness of ray spawning (design.md: error-bounded offsets, no fixed epsilon): the Cornell box
//! moved to (10⁴, 10⁴, 10⁴), or scaled by 10⁻³ or 10³ about the origin (radiance unchanged), renders
//! the same image; so does the 10⁻³ box moved ~10³ of its sizes off the origin (f32 positions there
//! still resolve it by ~10⁴ ulps). Compared by a two-sample z-test of the means of 4×4 image
//! regions, against the box at its original place and scale.
//!
//! False-failure rate ≤ 1e-3 for the file (Šidák over every comparison), fixed seeds.

use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{cornell, render, scene};

/// Image means of a 4×4 grid of regions (and their standard errors), so that a leak in one corner
/// cannot hide in the average.
fn region_means(out: &lightlab_integrators::RenderOutput) -> Vec<([f64; 3], [f64; 3])> {
    let f = &out.film;
    let (w, h) = (f.width as usize, f.height as usize);
    let mut regions = vec![([0.0; 3], [0.0; 3]); 16];
    let per = (w / 4 * (h / 4)) as f64;
    for y in 0..h {
        for x in 0..w {
            let r = &mut regions[(y * 4 / h) * 4 + x * 4 / w];
            let (m, v) = (f.mean(y * w + x), f.variance_of_mean(y * w + x));
            for c in 0..3 {
                r.0[c] += m[c] / per;
                r.1[c] += v[c] / (per * per);
            }
        }
    }
    regions
        .into_iter()
        .map(|(m, v)| (m, v.map(f64::sqrt)))
        .collect()
}

#[test]
fn cornell_box_far_away_tiny_and_huge_renders_the_same() {
    let res = (48, 48);
    let config = "Path(max_bounces: 4)";
    let spp = 48;
    let base = region_means(&render(
        &scene(&cornell(1.0, [0.0; 3], res)),
        config,
        spp,
        11,
    ));
    let variants = [
        ("moved to 1e4", 1.0, [1e4, 1e4, 1e4]),
        ("scaled 1e-3", 1e-3, [0.0; 3]),
        ("scaled 1e3", 1e3, [0.0; 3]),
        ("scaled 1e-3 and moved", 1e-3, [1.0, -2.0, 0.5]),
    ];
    let crit = z_critical(sidak(1e-3, (variants.len() * 16 * 3) as u64));
    for (what, s, t) in variants {
        let out = render(&scene(&cornell(s, t, res)), config, spp, 12);
        assert_eq!(
            out.stats.non_finite_total(),
            0,
            "{what}: non-finite samples"
        );
        for (k, (a, b)) in base.iter().zip(region_means(&out)).enumerate() {
            for c in 0..3 {
                let se = (a.1[c] * a.1[c] + b.1[c] * b.1[c]).sqrt();
                let z = (b.0[c] - a.0[c]) / se.max(1e-12);
                assert!(
                    z.abs() < crit,
                    "{what}: region {k} channel {c}: {} vs {} at scale 1, z = {z:.2} (critical {crit:.2})",
                    b.0[c],
                    a.0[c]
                );
            }
        }
    }
}
