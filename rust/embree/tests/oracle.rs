//! Embree against a brute-force f64 Möller–Trumbore loop over all triangles.
//!
//! Rays whose outcome depends on rounding are skipped deliberately and counted: a candidate hit
//! within `EDGE_EPS` (distance in the triangle's plane) of a triangle edge, or with t within
//! `T_EPS` of t_min (e.g. rays starting on the surface) or of t_max.

use antumbra_core::geometry::Ray;
use antumbra_embree::{embree_accepts, EmbreeQuality, EmbreeScene};
use glam::{DVec3, Vec3};

const EDGE_EPS: f64 = 1e-5;
const T_EPS: f64 = 1e-5;

/// SplitMix64: deterministic, no dependencies.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// Icosphere-like closed mesh: an octahedron subdivided `level` times, projected on a sphere.
fn sphere(center: Vec3, radius: f32, level: u32) -> Vec<[Vec3; 3]> {
    let (px, nx, py, ny, pz, nz) = (Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z);
    let mut tris = vec![
        [px, py, pz],
        [py, nx, pz],
        [nx, ny, pz],
        [ny, px, pz],
        [py, px, nz],
        [nx, py, nz],
        [ny, nx, nz],
        [px, ny, nz],
    ];
    for _ in 0..level {
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let (ab, bc, ca) = (
                (a + b).normalize(),
                (b + c).normalize(),
                (c + a).normalize(),
            );
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        tris = next;
    }
    tris.iter()
        .map(|t| t.map(|v| center + v * radius))
        .collect()
}

/// Axis-aligned cube as 12 triangles.
fn cube(min: Vec3, max: Vec3) -> Vec<[Vec3; 3]> {
    let p = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    quads
        .iter()
        .flat_map(|q| [[p(q[0]), p(q[1]), p(q[2])], [p(q[0]), p(q[2]), p(q[3])]])
        .collect()
}

/// Random, mutually intersecting triangles in [-1, 1]^3.
fn soup(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            [(); 3].map(|_| c + 0.3 * rng.unit())
        })
        .collect()
}

/// A line/triangle crossing in f64: t along the ray and the signed distance (in the plane) from
/// the crossing point to the nearest edge line, positive inside.
fn crossing(o: DVec3, d: DVec3, tri: &[Vec3; 3]) -> Option<(f64, f64)> {
    let [v0, v1, v2] = tri.map(|v| v.as_dvec3());
    let (e1, e2) = (v1 - v0, v2 - v0);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() <= 1e-12 * e1.length() * e2.length() * d.length() {
        return None; // parallel (random rays are never in-plane)
    }
    let s = o - v0;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    let w = 1.0 - u - v;
    // Barycentric coordinate of vertex i times the altitude from i = distance to the edge
    // opposite i; the altitude is 2 * area / |opposite edge|.
    let area2 = e1.cross(e2).length();
    let dist = [
        w * area2 / (v2 - v1).length(),
        u * area2 / (v2 - v0).length(),
        v * area2 / (v1 - v0).length(),
    ];
    Some((t, dist[0].min(dist[1]).min(dist[2])))
}

#[derive(Debug, PartialEq)]
enum Expect {
    Miss,
    Hit {
        t: f64,
        id: u32,
    },
    /// Some candidate is near an edge, or near t_min / t_max.
    Ambiguous(Why),
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Why {
    Edge,
    TMin,
    TMax,
}

/// What the brute force says about the closest hit in (t_min, t_max], and whether it is
/// decidable without rounding questions.
fn brute(ray: &Ray, tris: &[[Vec3; 3]]) -> (Expect, bool) {
    let (o, d) = (ray.origin.as_dvec3(), ray.direction.as_dvec3());
    let (t_min, t_max) = (ray.t_min as f64, ray.t_max as f64);
    // Candidates not clearly excluded, with their ambiguity.
    let mut cands: Vec<(f64, u32, Option<Why>)> = Vec::new();
    for (i, tri) in tris.iter().enumerate() {
        let Some((t, dist)) = crossing(o, d, tri) else {
            continue;
        };
        if dist < -EDGE_EPS || t < t_min - T_EPS || t > t_max + T_EPS {
            continue;
        }
        let why = if dist <= EDGE_EPS {
            Some(Why::Edge)
        } else if t <= t_min + T_EPS {
            Some(Why::TMin)
        } else if t >= t_max - T_EPS {
            Some(Why::TMax)
        } else {
            None
        };
        cands.push((t, i as u32, why));
    }
    cands.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Occlusion is certain as soon as one candidate is clear.
    let occluded_certain = cands.iter().any(|c| c.2.is_none());
    let closest = match cands.first() {
        None => Expect::Miss,
        Some(&(_, _, Some(why))) => Expect::Ambiguous(why),
        Some(&(t, id, None)) => match cands.get(1) {
            // Two distinct triangles at nearly the same t (not at a shared edge): skip.
            Some(&(t2, _, _)) if t2 - t <= T_EPS => Expect::Ambiguous(Why::Edge),
            _ => Expect::Hit { t, id },
        },
    };
    (closest, occluded_certain)
}

#[derive(Default, Debug)]
struct Tally {
    rays: usize,
    hits: usize,
    misses: usize,
    skipped_edge: usize,
    skipped_tmin: usize,
    skipped_tmax: usize,
    /// Among rays skipped for a hit at ~t_min: how often Embree reported one there.
    embree_hit_at_tmin: usize,
    /// The others, checked against the brute force on the rest of the segment.
    checked_after_tmin: usize,
}

/// Rays of several kinds: from anywhere in a box, from near the surface (1e-4 off, both
/// sides), from exactly on the surface (f32 point on a triangle), and shadow-style segments
/// (t_max = 1 towards a point).
fn rays(rng: &mut Rng, tris: &[[Vec3; 3]], n: usize) -> Vec<Ray> {
    let on_surface = |rng: &mut Rng| {
        let tri = &tris[rng.below(tris.len())];
        let (mut a, mut b) = (rng.f32(), rng.f32());
        if a + b > 1.0 {
            (a, b) = (1.0 - a, 1.0 - b);
        }
        let p = tri[0] + a * (tri[1] - tri[0]) + b * (tri[2] - tri[0]);
        let nrm = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        (p, nrm)
    };
    (0..n)
        .map(|i| {
            let t_max = match rng.below(3) {
                0 => f32::INFINITY,
                1 => rng.range(0.05, 1.0),
                _ => rng.range(1.0, 6.0),
            };
            match i % 4 {
                0 => {
                    let o = Vec3::new(
                        rng.range(-2.5, 2.5),
                        rng.range(-2.5, 2.5),
                        rng.range(-2.5, 2.5),
                    );
                    Ray::new(o, rng.unit() * rng.range(0.3, 2.0), 0.0, t_max)
                }
                1 => {
                    let (p, nrm) = on_surface(rng);
                    let side = if rng.below(2) == 0 { 1e-4 } else { -1e-4 };
                    Ray::new(p + side * nrm, rng.unit(), 0.0, t_max)
                }
                2 => {
                    let (p, _) = on_surface(rng);
                    Ray::new(p, rng.unit(), 0.0, t_max)
                }
                _ => {
                    let (p, nrm) = on_surface(rng);
                    let target = Vec3::new(
                        rng.range(-3.0, 3.0),
                        rng.range(-3.0, 3.0),
                        rng.range(-3.0, 3.0),
                    );
                    let o = p + 1e-4 * nrm;
                    Ray::new(o, target - o, rng.range(0.0, 1e-3), 1.0)
                }
            }
        })
        .collect()
}

fn check_scene(name: &str, tris: &[[Vec3; 3]], n_rays: usize, seed: u64) -> Tally {
    check_scene_with(name, tris, n_rays, seed, true)
}

fn check_scene_with(
    name: &str,
    tris: &[[Vec3; 3]],
    n_rays: usize,
    seed: u64,
    robust: bool,
) -> Tally {
    let scene = EmbreeScene::with_options(tris, EmbreeQuality::High, None, robust).unwrap();
    let mut rng = Rng(seed);
    let rays = rays(&mut rng, tris, n_rays);
    let mut tally = Tally::default();
    let mut many = vec![false; rays.len()];
    scene.occluded_many(&rays, &mut many);
    for (ray, &occ_many) in rays.iter().zip(&many) {
        assert!(embree_accepts(ray));
        tally.rays += 1;
        let occ = scene.occluded(ray);
        assert_eq!(occ, occ_many, "{name}: occluded_many differs on {ray:?}");
        let hit = scene.intersect(ray);
        assert_eq!(
            occ,
            hit.is_some(),
            "{name}: occluded and intersect disagree on {ray:?}"
        );
        let (expect, occ_certain) = brute(ray, tris);
        if occ_certain {
            assert!(occ, "{name}: Embree misses a clear hit: {ray:?} {expect:?}");
        }
        match expect {
            Expect::Miss => {
                tally.misses += 1;
                assert!(!occ, "{name}: Embree occluded, brute force misses: {ray:?}");
                assert_eq!(hit, None, "{name}: {ray:?}");
            }
            Expect::Hit { t, id } => {
                tally.hits += 1;
                let (et, eid) = hit.unwrap_or_else(|| panic!("{name}: no hit {ray:?}"));
                assert_eq!(
                    eid, id,
                    "{name}: primID, brute t {t}, Embree t {et}: {ray:?}"
                );
                assert!(
                    (et as f64 - t).abs() <= 1e-5 * (1.0 + t.abs()),
                    "{name}: t {et} vs {t}: {ray:?}"
                );
                assert!(
                    et > ray.t_min && et <= ray.t_max,
                    "{name}: t outside segment"
                );
            }
            Expect::Ambiguous(Why::Edge) => tally.skipped_edge += 1,
            Expect::Ambiguous(Why::TMin) => {
                tally.skipped_tmin += 1;
                let at_t_min = |t: f32| (t as f64 - ray.t_min as f64).abs() <= T_EPS;
                if hit.is_some_and(|(t, _)| at_t_min(t)) {
                    tally.embree_hit_at_tmin += 1;
                } else {
                    // Embree passed the surface at ~t_min: beyond it, it must agree with the
                    // brute force on the rest of the segment.
                    let rest = Ray {
                        t_min: ray.t_min + 2.0 * T_EPS as f32,
                        ..*ray
                    };
                    match (brute(&rest, tris).0, hit) {
                        (Expect::Miss, None) => {}
                        (Expect::Hit { t, id }, Some((et, eid))) => {
                            assert_eq!(eid, id, "{name}: after t_min: {ray:?}");
                            assert!((et as f64 - t).abs() <= 1e-5 * (1.0 + t.abs()));
                        }
                        (Expect::Ambiguous(_), _) => {}
                        (e, h) => panic!("{name}: after t_min: {e:?} vs {h:?}: {ray:?}"),
                    }
                    tally.checked_after_tmin += 1;
                }
            }
            Expect::Ambiguous(Why::TMax) => tally.skipped_tmax += 1,
        }
    }
    println!("{name}: {} triangles, {tally:?}", tris.len());
    // The skips must stay the exception, not the rule.
    let skipped = tally.skipped_edge + tally.skipped_tmax;
    assert!(skipped * 50 < tally.rays, "{name}: too many skipped");
    assert!(tally.hits > tally.rays / 5 && tally.misses > tally.rays / 10);
    tally
}

#[test]
fn sphere_agrees_with_brute_force() {
    let tris = sphere(Vec3::new(0.1, -0.2, 0.05), 1.3, 4); // 2048 triangles
    let t = check_scene("sphere", &tris, 4000, 1);
    // A quarter of the rays start exactly on the surface; their own triangle sits at ~t_min.
    assert!(t.skipped_tmin > 0);
}

/// Without `RTC_SCENE_FLAG_ROBUST` the answers agree too, away from edges and segment ends.
#[test]
fn sphere_agrees_with_brute_force_without_robust_mode() {
    let tris = sphere(Vec3::new(0.1, -0.2, 0.05), 1.3, 4);
    check_scene_with("sphere, not robust", &tris, 4000, 4, false);
    let tris = cube(Vec3::new(-1.0, -0.7, -1.2), Vec3::new(1.1, 0.9, 0.8));
    check_scene_with("cube, not robust", &tris, 4000, 5, false);
}

#[test]
fn cube_agrees_with_brute_force() {
    let tris = cube(Vec3::new(-1.0, -0.7, -1.2), Vec3::new(1.1, 0.9, 0.8));
    check_scene("cube", &tris, 4000, 2);
}

#[test]
fn soup_agrees_with_brute_force() {
    let mut rng = Rng(99);
    let tris = soup(&mut rng, 300);
    check_scene("soup", &tris, 4000, 3);
}

#[test]
fn t_max_limits_the_segment() {
    let tris = sphere(Vec3::ZERO, 1.0, 3);
    let scene = EmbreeScene::new(&tris, EmbreeQuality::Medium, Some(1)).unwrap();
    let mut rng = Rng(7);
    let mut n = 0;
    while n < 500 {
        let o = 4.0 * rng.unit();
        let ray = Ray::new(o, rng.range(0.5, 2.0) * rng.unit(), 0.0, f32::INFINITY);
        let (Expect::Hit { t, id }, _) = brute(&ray, &tris) else {
            continue;
        };
        n += 1;
        let t = t as f32;
        let short = Ray {
            t_max: t * 0.999,
            ..ray
        };
        assert!(!scene.occluded(&short), "{short:?}");
        assert_eq!(scene.intersect(&short), None);
        let long = Ray {
            t_max: t * 1.001,
            ..ray
        };
        assert!(scene.occluded(&long));
        assert_eq!(scene.intersect(&long).map(|h| h.1), Some(id));
        // Starting past the first hit finds the far side of the sphere instead.
        let past = Ray {
            t_min: t * 1.001,
            ..ray
        };
        let far = scene.intersect(&past).expect("far side");
        assert!(far.0 > t * 1.001 && far.1 != id);
    }
}

#[test]
fn misses_return_none() {
    let tris = cube(Vec3::splat(-1.0), Vec3::splat(1.0));
    let scene = EmbreeScene::new(&tris, EmbreeQuality::Low, None).unwrap();
    for (o, d) in [
        (Vec3::new(0.0, 0.0, 3.0), Vec3::Z),  // pointing away
        (Vec3::new(2.0, 2.0, -5.0), Vec3::Z), // passing beside
        (Vec3::new(0.0, 0.0, 3.0), Vec3::new(1.0, 0.0, -0.2)), // passing over
    ] {
        let ray = Ray::new(o, d, 0.0, f32::INFINITY);
        assert!(!scene.occluded(&ray));
        assert_eq!(scene.intersect(&ray), None);
    }
    // A segment ending before the cube.
    let ray = Ray::new(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z, 0.0, 1.99);
    assert!(!scene.occluded(&ray));
    assert_eq!(scene.intersect(&ray), None);
    // Empty scene.
    let empty = EmbreeScene::new(&[], EmbreeQuality::Medium, Some(1)).unwrap();
    assert!(!empty.occluded(&ray));
    assert_eq!(empty.intersect(&ray), None);
}

/// Documents Embree 3.13's segment ends with a hit at exactly representable t = 1. The t it
/// reports is 1 or the float just below, by the kernel it picked for the CPU (the AVX-512
/// kernel's reciprocal gives 1 - 2^-24 on AMD EPYC). Robust mode decides both ends on that
/// reported t and closes both; the default mode decides on the exact t, closed at tfar and
/// open at tnear (as antumbra).
#[test]
fn segment_ends_exactly_at_a_hit() {
    let tri = [[
        Vec3::new(-1.0, -1.0, 1.0),
        Vec3::new(3.0, -1.0, 1.0),
        Vec3::new(-1.0, 3.0, 1.0),
    ]];
    let after = |t: f32| f32::from_bits(t.to_bits() + 1);
    let before = |t: f32| f32::from_bits(t.to_bits() - 1);
    for robust in [true, false] {
        let s = EmbreeScene::with_options(&tri, EmbreeQuality::Medium, Some(1), robust).unwrap();
        assert_eq!(s.robust(), robust);
        let ray = |t_min, t_max| Ray::new(Vec3::ZERO, Vec3::Z, t_min, t_max);
        let hits = |t_min, t_max| {
            let (occluded, hit) = (
                s.occluded(&ray(t_min, t_max)),
                s.intersect(&ray(t_min, t_max)),
            );
            assert_eq!(occluded, hit.is_some(), "occluded and intersect disagree");
            occluded
        };
        let (t, id) = s.intersect(&ray(0.0, 2.0)).expect("a hit at t = 1");
        assert_eq!(id, 0);
        assert!(
            t == 1.0 || t == before(1.0),
            "t {t} is not 1 within one ulp below"
        );
        // The ends: `e` is where each mode decides.
        let e = if robust { t } else { 1.0 };
        assert!(hits(0.0, e), "closed at tfar");
        assert!(!hits(0.0, before(e)));
        assert!(!hits(after(e), 2.0));
        assert_eq!(hits(e, 2.0), robust, "closed at tnear in robust mode only");
        assert!(hits(before(e), 2.0));
        // The direction need not be normalised: t is in its units.
        let half = Ray::new(Vec3::ZERO, 0.5 * Vec3::Z, 0.0, 3.0);
        let (t2, _) = s.intersect(&half).expect("a hit at t = 2");
        assert!(
            t2 == 2.0 || t2 == before(2.0),
            "t {t2} is not 2 within one ulp below"
        );
    }
}

#[test]
fn build_qualities_and_thread_counts_agree() {
    let tris = sphere(Vec3::ZERO, 1.0, 4);
    let mut rng = Rng(5);
    let rays = rays(&mut rng, &tris, 2000);
    let reference = EmbreeScene::new(&tris, EmbreeQuality::Medium, None).unwrap();
    let want: Vec<bool> = rays.iter().map(|r| reference.occluded(r)).collect();
    for (q, threads) in [
        (EmbreeQuality::Low, Some(1)),
        (EmbreeQuality::High, Some(2)),
        (EmbreeQuality::Medium, Some(1)),
    ] {
        let s = EmbreeScene::new(&tris, q, threads).unwrap();
        assert_eq!(s.triangle_count(), tris.len());
        assert!(s.build_ms() >= 0.0 && s.build_ms().is_finite());
        let mut got = vec![false; rays.len()];
        s.occluded_many(&rays, &mut got);
        // The BVH differs, not the triangle test, so the answers should not change.
        let diff = got.iter().zip(&want).filter(|(a, b)| a != b).count();
        assert_eq!(diff, 0, "{q:?} {threads:?}");
    }
}

#[test]
fn shared_across_threads() {
    fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<EmbreeScene>();
    let tris = sphere(Vec3::ZERO, 1.0, 3);
    let scene = EmbreeScene::new(&tris, EmbreeQuality::Medium, None).unwrap();
    let mut rng = Rng(11);
    let rays = rays(&mut rng, &tris, 4000);
    let want: Vec<bool> = rays.iter().map(|r| scene.occluded(r)).collect();
    let mut got = vec![false; rays.len()];
    std::thread::scope(|s| {
        for (rs, out) in rays.chunks(500).zip(got.chunks_mut(500)) {
            let scene = &scene;
            s.spawn(move || scene.occluded_many(rs, out));
        }
    });
    assert_eq!(got, want);
    // Moving the owner to another thread and dropping it there.
    std::thread::spawn(move || drop(scene)).join().unwrap();
}

#[test]
#[should_panic(expected = "not accepted by Embree")]
fn negative_t_min_panics_instead_of_aborting() {
    let scene = EmbreeScene::new(&cube(-Vec3::ONE, Vec3::ONE), EmbreeQuality::Low, None).unwrap();
    scene.occluded(&Ray::new(Vec3::ZERO, Vec3::X, -1.0, 1.0));
}

#[test]
fn embree_accepts_rejects_invalid_rays() {
    let ok = Ray::new(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY);
    assert!(embree_accepts(&ok));
    assert!(!embree_accepts(&Ray { t_min: -1e-9, ..ok }));
    assert!(!embree_accepts(&Ray {
        t_max: f32::NAN,
        ..ok
    }));
    assert!(!embree_accepts(&Ray {
        direction: Vec3::new(f32::NAN, 0.0, 1.0),
        ..ok
    }));
    assert!(!embree_accepts(&Ray {
        origin: Vec3::new(0.0, f32::INFINITY, 1.0),
        ..ok
    }));
}
