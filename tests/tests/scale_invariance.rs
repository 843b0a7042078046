//! Robustness of ray spawning (design.md: error-bounded offsets, no fixed epsilon): the Cornell box
//! moved to (10⁴, 10⁴, 10⁴), or scaled by 10⁻³ or 10³ about the origin (radiance unchanged), renders
//! the same image; so does the 10⁻³ box moved ~10³ of its sizes off the origin (f32 positions there
//! still resolve it by ~10⁴ ulps). Compared by a two-sample z-test of the means of 4×4 image
//! regions, against the box at its original place and scale.
//!
//! False-failure rate ≤ 1e-3 for the file (Šidák over every comparison), fixed seeds.

use lightlab_testkit::stats::{sidak, z_critical};
use lightlab_tests::{cornell, regions, render, scene};

#[test]
fn cornell_box_far_away_tiny_and_huge_renders_the_same() {
    let res = (48, 48);
    let config = "Path(max_bounces: 4)";
    let spp = 48;
    let base = regions(
        &render(&scene(&cornell(1.0, [0.0; 3], res)), config, spp, 11),
        4,
    );
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
        for (k, (a, b)) in base.iter().zip(regions(&out, 4)).enumerate() {
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
