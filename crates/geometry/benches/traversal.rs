//! Traversal benchmark (BENCHMARKS.md, "Traversal"): the Cornell box with a 1.05 M-triangle UV
//! sphere; incoherent closest-hit rays, shadow segments and primary camera rays, on rayon pools of
//! 1 and 2 threads, reporting Mrays/s per wall second and per CPU second, plus BVH build time and
//! memory; first, small and mid-sized scenes on both static structures (the 4-wide BVH and the
//! CWBVH), which is what the accelerator's choice by size rests on.
//!
//! Run: `cargo bench -p lightlab-geometry --bench traversal`.

use lightlab_core::{Ray, Vec2, Vec3};
use lightlab_geometry::{Accel, Geometry, Layout, NO_LIGHT, Shape, TriangleMesh};
use lightlab_samplers::warp::square_to_uniform_sphere;
use lightlab_testkit::timing::timed;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use std::f32::consts::PI;

const INCOHERENT: usize = 4 << 20;
const SHADOW: usize = 4 << 20;
const RESOLUTION: usize = 1024;
const WARM_UP: usize = 100_000;

fn mesh(positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Shape {
    Shape {
        geometry: Geometry::Mesh(TriangleMesh::new(positions, None, None, indices).unwrap()),
        material: 0,
        light: NO_LIGHT,
    }
}

/// Appends the quad a, b, c, d (counter-clockwise) as two triangles.
fn quad(p: &mut Vec<Vec3>, i: &mut Vec<[u32; 3]>, q: [Vec3; 4]) {
    let k = p.len() as u32;
    p.extend(q);
    i.extend([[k, k + 1, k + 2], [k, k + 2, k + 3]]);
}

/// Walls of [−1, 1]³ without the front (z = +1), and the two blocks of the classic Cornell box
/// (its coordinates in mm mapped so that the camera at +z looks down −z).
fn cornell_box() -> Vec<Shape> {
    let (mut p, mut i) = (Vec::new(), Vec::new());
    let v = Vec3::new;
    quad(
        &mut p,
        &mut i,
        [
            v(-1., -1., 1.),
            v(1., -1., 1.),
            v(1., -1., -1.),
            v(-1., -1., -1.),
        ],
    );
    quad(
        &mut p,
        &mut i,
        [
            v(-1., 1., -1.),
            v(1., 1., -1.),
            v(1., 1., 1.),
            v(-1., 1., 1.),
        ],
    );
    quad(
        &mut p,
        &mut i,
        [
            v(-1., -1., -1.),
            v(1., -1., -1.),
            v(1., 1., -1.),
            v(-1., 1., -1.),
        ],
    );
    quad(
        &mut p,
        &mut i,
        [
            v(-1., -1., 1.),
            v(-1., -1., -1.),
            v(-1., 1., -1.),
            v(-1., 1., 1.),
        ],
    );
    quad(
        &mut p,
        &mut i,
        [
            v(1., -1., -1.),
            v(1., -1., 1.),
            v(1., 1., 1.),
            v(1., 1., -1.),
        ],
    );
    let walls = mesh(p, i);

    let map = |x: f32, y: f32, z: f32| {
        v(
            1.0 - 2.0 * x / 556.0,
            2.0 * y / 548.8 - 1.0,
            1.0 - 2.0 * z / 559.2,
        )
    };
    let (mut p, mut i) = (Vec::new(), Vec::new());
    let blocks: [([(f32, f32); 4], f32); 2] = [
        ([(130., 65.), (82., 225.), (240., 272.), (290., 114.)], 165.),
        (
            [(423., 247.), (265., 296.), (314., 456.), (472., 406.)],
            330.,
        ),
    ];
    for (corners, height) in blocks {
        let top = corners.map(|(x, z)| map(x, height, z));
        let bottom = corners.map(|(x, z)| map(x, 0.0, z));
        quad(&mut p, &mut i, top);
        quad(&mut p, &mut i, [bottom[3], bottom[2], bottom[1], bottom[0]]);
        for k in 0..4 {
            let l = (k + 1) % 4;
            quad(&mut p, &mut i, [bottom[k], bottom[l], top[l], top[k]]);
        }
    }
    vec![walls, mesh(p, i)]
}

/// UV sphere with `rings` bands of latitude and `segments` of longitude (triangles at the poles).
fn uv_sphere(center: Vec3, radius: f32, rings: u32, segments: u32) -> Shape {
    let mut p = vec![center + radius * Vec3::Z];
    for j in 1..rings {
        let theta = PI * j as f32 / rings as f32;
        for s in 0..segments {
            let phi = 2.0 * PI * s as f32 / segments as f32;
            p.push(
                center
                    + radius
                        * Vec3::new(
                            theta.sin() * phi.cos(),
                            theta.sin() * phi.sin(),
                            theta.cos(),
                        ),
            );
        }
    }
    p.push(center - radius * Vec3::Z);
    let south = p.len() as u32 - 1;
    let ring = |j: u32, s: u32| 1 + (j - 1) * segments + s % segments;
    let mut i = Vec::new();
    for s in 0..segments {
        i.push([0, ring(1, s), ring(1, s + 1)]);
        i.push([south, ring(rings - 1, s + 1), ring(rings - 1, s)]);
    }
    for j in 1..rings - 1 {
        for s in 0..segments {
            i.push([ring(j, s), ring(j + 1, s), ring(j + 1, s + 1)]);
            i.push([ring(j, s), ring(j + 1, s + 1), ring(j, s + 1)]);
        }
    }
    mesh(p, i)
}

fn random_point(rng: &mut Pcg64) -> Vec3 {
    Vec3::new(
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
        rng.random_range(-1.0..1.0),
    )
}

fn incoherent_rays(rng: &mut Pcg64, n: usize) -> Vec<Ray> {
    (0..n)
        .map(|_| {
            let o = random_point(rng);
            Ray::new(
                o,
                square_to_uniform_sphere(Vec2::new(rng.random(), rng.random())),
            )
        })
        .collect()
}

fn shadow_rays(rng: &mut Pcg64, n: usize) -> Vec<Ray> {
    (0..n)
        .map(|_| {
            let (a, b) = (random_point(rng), random_point(rng));
            Ray::segment(a, b - a, 1.0)
        })
        .collect()
}

/// Pinhole at (0, 0, 3.9) looking at the origin, 39.3077° field of view, pixel centres in
/// scanline order.
fn primary_rays(resolution: usize) -> Vec<Ray> {
    let tan_half = (39.3077f32.to_radians() * 0.5).tan();
    let eye = Vec3::new(0.0, 0.0, 3.9);
    (0..resolution * resolution)
        .map(|k| {
            let (x, y) = ((k % resolution) as f32 + 0.5, (k / resolution) as f32 + 0.5);
            let sx = (2.0 * x / resolution as f32 - 1.0) * tan_half;
            let sy = (1.0 - 2.0 * y / resolution as f32) * tan_half;
            Ray::new(eye, Vec3::new(sx, sy, -1.0).normalize())
        })
        .collect()
}

/// Closest hits (`closest`) or occlusion tests over `rays` in chunks of 1024; returns the hits.
fn trace(accel: &Accel, rays: &[Ray], closest: bool) -> usize {
    rays.par_chunks(1024)
        .map(|chunk| {
            chunk
                .iter()
                .filter(|r| {
                    if closest {
                        accel.intersect(r).is_some()
                    } else {
                        accel.occluded(r)
                    }
                })
                .count()
        })
        .sum()
}

/// Small and mid-sized scenes on both static structures, one thread: what `Layout::BySize`'s
/// threshold is chosen by.
fn compare_layouts() {
    const RAYS: usize = 1 << 20;
    let mut rng = Pcg64::seed_from_u64(7);
    let incoherent = incoherent_rays(&mut rng, RAYS);
    let shadow = shadow_rays(&mut rng, RAYS);
    println!("## Structures by scene size (1 thread, {RAYS} rays each)");
    println!(
        "| scene | triangles | structure | nodes | incoherent Mrays/s | shadow Mrays/s | build s |"
    );
    println!("|---|---|---|---|---|---|---|");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let sizes = [
        None,
        Some((8, 16)),
        Some((16, 32)),
        Some((32, 64)),
        Some((64, 128)),
        Some((128, 256)),
    ];
    for size in sizes {
        let mut shapes = cornell_box();
        let name = match size {
            None => "Cornell box".to_string(),
            Some((rings, segments)) => {
                shapes.push(uv_sphere(Vec3::ZERO, 0.35, rings, segments));
                format!("Cornell box + {rings}×{segments} sphere")
            }
        };
        for layout in [Layout::Compressed, Layout::Wide] {
            let input = shapes.clone();
            let (accel, build, _) = timed(|| {
                pool.install(|| Accel::with_layout(input, Vec::new(), (0.0, 0.0), layout))
            });
            let rate = |rays: &[Ray], closest| {
                pool.install(|| trace(&accel, &rays[..WARM_UP], closest));
                let (_, wall, _) = timed(|| pool.install(|| trace(&accel, rays, closest)));
                rays.len() as f64 / wall / 1e6
            };
            let (a, b) = (rate(&incoherent, true), rate(&shadow, false));
            println!(
                "| {name} | {} | {layout:?} | {} | {a:.2} | {b:.2} | {build:.3} |",
                accel.triangle_count(),
                accel.stats().nodes,
            );
        }
    }
    println!();
}

fn main() {
    compare_layouts();
    if std::env::args().any(|a| a == "--layouts-only") {
        return;
    }
    let mut shapes = cornell_box();
    shapes.push(uv_sphere(Vec3::ZERO, 0.35, 512, 1024));

    println!("## Build");
    let mut accel = None;
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let input = shapes.clone();
        let (built, wall, cpu) = timed(|| pool.install(|| Accel::new(input)));
        let stats = built.stats();
        println!(
            "threads {threads}: {} triangles, build {wall:.3} s wall, {cpu:.2} s CPU; {} nodes = {:.1} MB, primitives {:.1} MB",
            built.triangle_count(),
            stats.nodes,
            stats.node_bytes as f64 / 1e6,
            stats.primitive_bytes as f64 / 1e6
        );
        accel = Some(built);
    }
    let accel = accel.unwrap();

    let mut rng = Pcg64::seed_from_u64(2024);
    let workloads = [
        (
            "incoherent closest-hit",
            incoherent_rays(&mut rng, INCOHERENT),
            true,
        ),
        ("shadow (occluded)", shadow_rays(&mut rng, SHADOW), false),
        ("primary closest-hit", primary_rays(RESOLUTION), true),
    ];

    println!("\n## Traversal");
    println!(
        "| rays | threads | count | hit % | Mrays/s wall | Mrays/s per CPU-s | CPU-s / wall-s |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (name, rays, closest) in &workloads {
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| trace(&accel, &rays[..WARM_UP], *closest));
            let (hits, wall, cpu) = timed(|| pool.install(|| trace(&accel, rays, *closest)));
            let n = rays.len() as f64;
            println!(
                "| {name} | {threads} | {} | {:.1} | {:.2} | {:.2} | {:.2} |",
                rays.len(),
                100.0 * hits as f64 / n,
                n / wall / 1e6,
                n / cpu / 1e6,
                cpu / wall
            );
        }
    }
}
