//! Quick build/trace probe on a synthetic scene (many spheres over a ground grid), no scenes crate.
use antumbra_core::build::{build_binned_sah, BuildSettings};
use antumbra_core::geometry::Ray;
use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::trace::{NoStats, RayQuery, TraversalStats};
use glam::Vec3;
use std::time::Instant;

fn main() {
    let mut tris = Vec::new();
    let (rings, segs) = (24u32, 48u32);
    for k in 0..160u32 {
        let c = Vec3::new(
            unit_float(hash_u32(3 * k)) * 20.0 - 10.0,
            unit_float(hash_u32(3 * k + 1)) * 20.0 - 10.0,
            unit_float(hash_u32(3 * k + 2)) * 3.0,
        );
        let rad = 0.3 + unit_float(hash_u32(k + 999)) * 1.2;
        let p = |r: u32, s: u32| {
            let th = std::f32::consts::PI * r as f32 / rings as f32;
            let ph = 2.0 * std::f32::consts::PI * s as f32 / segs as f32;
            c + Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()) * rad
        };
        for r in 0..rings {
            for s in 0..segs {
                tris.push([p(r, s), p(r + 1, s), p(r + 1, s + 1)]);
                tris.push([p(r, s), p(r + 1, s + 1), p(r, s + 1)]);
            }
        }
    }
    println!("{} triangles", tris.len());
    let mode = std::env::args().nth(1).unwrap_or_default();
    if mode == "build" {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let bvh = pool.install(|| build_binned_sah(&tris, &BuildSettings::default()));
        println!("nodes {}", bvh.nodes.len());
        return;
    }
    let settings = BuildSettings::default();
    for threads in if mode == "trace" { vec![] } else { vec![1, 2] } {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut best = f64::MAX;
            for _ in 0..3 {
                let t = Instant::now();
                std::hint::black_box(build_binned_sah(&tris, &settings));
                best = best.min(t.elapsed().as_secs_f64() * 1e3);
            }
            println!("build {threads} threads: {best:.1} ms");
        });
    }
    let bvh = build_binned_sah(&tris, &settings);
    println!(
        "nodes {} sah {:.2}",
        bvh.nodes.len(),
        bvh.sah_cost(1.0, 1.0)
    );
    let eye = Vec3::new(0.0, -25.0, 12.0);
    let n = 512u32;
    let mut prim = Vec::new();
    for y in 0..n {
        for x in 0..n {
            let d = Vec3::new(
                (x as f32 / n as f32 - 0.5) * 1.0,
                1.0,
                (0.5 - y as f32 / n as f32) * 1.0 - 0.45,
            );
            prim.push(Ray::new(eye, d, 0.0, f32::INFINITY));
        }
    }
    let t = Instant::now();
    let hits: Vec<_> = prim
        .iter()
        .map(|r| bvh.closest_hit(r, &mut NoStats))
        .collect();
    let ms = t.elapsed().as_secs_f64() * 1e3;
    println!(
        "primary 1 thread: {:.2} Mrays/s ({} hits)",
        prim.len() as f64 / ms / 1e3,
        hits.iter().flatten().count()
    );
    let light = Vec3::new(5.0, -3.0, 30.0);
    let shadow: Vec<Ray> = prim
        .iter()
        .zip(&hits)
        .filter_map(|(r, h)| {
            h.map(|h| {
                let p = r.at(h.t);
                let o = p + (light - p).normalize() * 1e-3;
                Ray::new(o, light - o, 0.0, 1.0)
            })
        })
        .collect();
    let mut st = TraversalStats::default();
    let occ = shadow.iter().filter(|r| bvh.occluded(r, &mut st)).count();
    println!(
        "shadow rays {} occluded {:.1}% N_B {:.2} N_L {:.2} N_T {:.2}",
        shadow.len(),
        100.0 * occ as f64 / shadow.len() as f64,
        st.inner as f64 / shadow.len() as f64,
        st.leaves as f64 / shadow.len() as f64,
        st.triangles as f64 / shadow.len() as f64
    );
    if mode == "trace" {
        return;
    }
    let mut best = f64::MAX;
    for _ in 0..3 {
        let t = Instant::now();
        let c = shadow
            .iter()
            .filter(|r| bvh.occluded(r, &mut NoStats))
            .count();
        std::hint::black_box(c);
        best = best.min(t.elapsed().as_secs_f64() * 1e3);
    }
    println!(
        "shadow 1 thread: {:.2} Mrays/s",
        shadow.len() as f64 / best / 1e3
    );
}
