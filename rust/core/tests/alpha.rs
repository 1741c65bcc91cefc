//! Alpha traversal (issue 38): transmission through alpha-textured cards and the closest hit
//! past transparent hits equal the brute-force reference bit for bit, on binary SAH and SBVH
//! trees (split references) and 2-, 4- and 8-wide trees with every box kernel and any-hit
//! order; opaque scenes answer as today; the hit limit and the once-per-triangle rule are
//! pinned.

use antumbra_core::alpha::{
    AlphaImage, AlphaOp, AlphaProgram, AlphaScene, AlphaTriangles, Extension, FlaggedTriangle,
    Interpolation,
};
use antumbra_core::build::{
    build, check_references, BuildMethod, BuildSettings, SpatialAxes, SpatialSettings,
};
use antumbra_core::bvh::{Bvh, WideBvh};
use antumbra_core::geometry::Ray;
use antumbra_core::order::{AnyHitOrder, OrderView};
use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::trace::wide::{BoxKernel, WideQueries};
use antumbra_core::trace::{
    brute_closest_hit_alpha, brute_transmission, AlphaQuery, AlphaStats, Counters, Hit, HitFilter,
    NoStats, OrderedBinary, OrderedWide, RayMode, RayQuery, TraversalStats,
};
use glam::{Vec2, Vec3};

fn r(seed: u32) -> f32 {
    unit_float(hash_u32(seed))
}

fn rand3(seed: u32) -> Vec3 {
    Vec3::new(r(seed), r(seed ^ 0x5555_5555), r(seed ^ 0x3333_3333))
}

/// A 16x16 image of random alphas with exact 0s and 1s among them.
fn image(seed: u32) -> AlphaImage {
    let texels = (0..256)
        .map(|i| match hash_u32(seed + i) % 5 {
            0 => 0.0,
            1 => 1.0,
            _ => r(seed + 1000 + i),
        })
        .collect();
    AlphaImage {
        width: 16,
        height: 16,
        texels,
    }
}

fn programs() -> Vec<AlphaProgram> {
    use Extension::*;
    use Interpolation::*;
    let with = |mut p: AlphaProgram, ops: Vec<AlphaOp>| {
        p.ops = ops;
        p
    };
    vec![
        AlphaProgram::image(0, 0, Closest, Repeat),
        with(
            AlphaProgram::image(1, 1, Linear, Extend),
            vec![AlphaOp::Multiply(1.5), AlphaOp::Clamp],
        ),
        AlphaProgram::constant(0.5),
        with(
            AlphaProgram::image(0, 1, Linear, Clip),
            vec![AlphaOp::GreaterThan(0.5)],
        ),
        AlphaProgram::image(1, 0, Cubic, Mirror),
        AlphaProgram::constant(1.0),
        with(
            AlphaProgram::image(0, 0, Closest, Extend),
            vec![AlphaOp::OneMinus, AlphaOp::Power(2.0)],
        ),
    ]
}

/// Random cards (two triangles each, UVs scaled and shifted past [0, 1]); one card in six
/// unflagged (opaque), the others over every material.
fn cards(n: u32, seed: u32) -> (Vec<[Vec3; 3]>, AlphaScene) {
    let mut tris = Vec::new();
    let mut flagged = Vec::new();
    for i in 0..n {
        let s = seed + 17 * i;
        let c = rand3(s) * 10.0 - 5.0;
        let e1 = (rand3(s + 1) - 0.5) * 4.0;
        let e2 = (rand3(s + 2) - 0.5) * 4.0;
        let corners = [c, c + e1, c + e1 + e2, c + e2];
        let scale = 0.5 + 3.0 * r(s + 3);
        let offset = Vec2::new(r(s + 4), r(s + 5)) * 4.0 - 2.0;
        let uv = |k: usize| {
            let base = [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y][k];
            let p = base * scale + offset;
            [p.x, p.y]
        };
        let material = hash_u32(s + 6) % 8;
        for tri in [[0, 1, 2], [0, 2, 3]] {
            let id = tris.len() as u32;
            tris.push(tri.map(|k| corners[k]));
            if material < 7 {
                let set0 = tri.map(uv);
                let set1 = tri.map(|k| {
                    let [u, v] = uv(k);
                    [v * 0.5, -u]
                });
                flagged.push(FlaggedTriangle {
                    triangle: id,
                    material,
                    uvs: vec![set0, set1],
                });
            }
        }
    }
    let triangles = AlphaTriangles::new(tris.len() as u32, 2, flagged).unwrap();
    let alpha = AlphaScene::new(vec![image(seed), image(seed + 9)], programs(), triangles).unwrap();
    (tris, alpha)
}

fn rays(n: u32, seed: u32) -> Vec<Ray> {
    (0..n)
        .map(|i| {
            let o = rand3(seed + 2 * i) * 14.0 - 7.0;
            let mut d = rand3(seed + 2 * i + 1) * 2.0 - 1.0;
            if i % 9 == 0 {
                d = Vec3::new(d.x, 0.0, -0.0);
            }
            let t_max = if i % 3 == 0 { 2.0 } else { f32::INFINITY };
            Ray::new(o, d, 0.0, t_max)
        })
        .filter(|r| r.direction != Vec3::ZERO)
        .collect()
}

/// Leaves of at most `leaf` triangles; spatial splits (SBVH) on every axis, so that split
/// references are common.
fn settings(leaf: usize) -> BuildSettings {
    BuildSettings {
        max_leaf_size: leaf,
        spatial: SpatialSettings {
            axes: SpatialAxes::All,
            max_growth: 2.0,
            ..SpatialSettings::default()
        },
        ..BuildSettings::default()
    }
}

fn key(h: Option<Hit>) -> Option<(u32, u32, [u32; 3])> {
    h.map(|h| {
        (
            h.triangle,
            h.t.to_bits(),
            [h.b0, h.b1, h.b2].map(f32::to_bits),
        )
    })
}

const MAX_HITS: u32 = 1024;
const CLIP: f32 = 0.5;

/// One query face against the reference on every ray: transmission bits and closest hits, with
/// and without counting (same answers), alpha lookups counted.
fn check<Q: AlphaQuery>(q: &Q, tris: &[[Vec3; 3]], alpha: &AlphaScene, rays: &[Ray], label: &str) {
    let (mut partial, mut lookups) = (0, 0);
    for (i, ray) in rays.iter().enumerate() {
        let want = brute_transmission(tris, ray, alpha, MAX_HITS);
        let mut stats = AlphaStats::default();
        let got = q.transmission(ray, alpha, MAX_HITS, &mut stats);
        assert_eq!(
            got.to_bits(),
            want.to_bits(),
            "{label} ray {i}: {got} vs {want}"
        );
        let quiet = q.transmission(ray, alpha, MAX_HITS, &mut NoStats);
        assert_eq!(quiet.to_bits(), want.to_bits(), "{label} ray {i} uncounted");
        partial += (want > 0.0 && want < 1.0) as u32;
        lookups += stats.alpha_lookups;
        let want = brute_closest_hit_alpha(tris, ray, alpha, CLIP);
        let got = q.closest_hit_alpha(ray, alpha, CLIP, &mut AlphaStats::default());
        assert_eq!(key(got), key(want), "{label} ray {i} closest");
        let quiet = q.closest_hit_alpha(ray, alpha, CLIP, &mut NoStats);
        assert_eq!(key(quiet), key(want), "{label} ray {i} closest uncounted");
    }
    assert!(
        partial > rays.len() as u32 / 20,
        "{label}: {partial} partial"
    );
    assert!(lookups > 0, "{label}: no alpha lookups counted");
}

fn check_wide<const N: usize>(bvh: &Bvh, tris: &[[Vec3; 3]], alpha: &AlphaScene, rays: &[Ray])
where
    WideBvh<N>: WideQueries,
{
    let wide = WideBvh::<N>::collapse(bvh);
    check(&wide, tris, alpha, rays, &format!("{N}-wide"));
    for kernel in [
        BoxKernel::Scalar,
        BoxKernel::Sse,
        BoxKernel::Avx2,
        BoxKernel::Auto,
    ] {
        for order in [OrderView::Stored, OrderView::FrontToBack] {
            let q = OrderedWide {
                bvh: &wide,
                order,
                kernel,
                rays: RayMode::Packet,
            };
            check(
                &q,
                tris,
                alpha,
                rays,
                &format!("{N}-wide {kernel:?} {order:?}"),
            );
        }
    }
}

/// Every tree, kernel and order against the reference.
#[test]
fn alpha_queries_equal_brute_force_on_every_tree() {
    let (tris, alpha) = cards(300, 7);
    let rays = rays(1500, 99);
    for method in [BuildMethod::Sah, BuildMethod::Sbvh] {
        for leaf in [1, 4] {
            let bvh = build(method, &tris, &settings(leaf));
            if method == BuildMethod::Sbvh {
                check_references(&bvh, &tris, 1e-5).unwrap();
                assert!(bvh.triangle_ids.len() > tris.len(), "no split references");
            } else {
                bvh.validate().unwrap();
            }
            let label = format!("{method:?} leaf {leaf}");
            check(&bvh, &tris, &alpha, &rays, &label);
            for order in [AnyHitOrder::Stored, AnyHitOrder::NearFirst] {
                let q = OrderedBinary { bvh: &bvh, order };
                check(&q, &tris, &alpha, &rays, &format!("{label} {order:?}"));
            }
            check_wide::<2>(&bvh, &tris, &alpha, &rays);
            check_wide::<4>(&bvh, &tris, &alpha, &rays);
            check_wide::<8>(&bvh, &tris, &alpha, &rays);
        }
    }
}

/// The batch form answers ray for ray as the single-ray form.
#[test]
fn transmission_batch_equals_single_rays() {
    let (tris, alpha) = cards(200, 3);
    let rays = rays(500, 5);
    let wide = WideBvh::<8>::collapse(&build(BuildMethod::Sbvh, &tris, &settings(4)));
    let mut out = vec![f32::NAN; rays.len()];
    let mut counters = vec![AlphaStats::default(); rays.len()];
    wide.transmission_batch(&rays, &alpha, MAX_HITS, &mut out, &mut counters);
    for (i, ray) in rays.iter().enumerate() {
        let want = brute_transmission(&tris, ray, &alpha, MAX_HITS);
        assert_eq!(out[i].to_bits(), want.to_bits(), "ray {i}");
    }
}

/// With no flagged triangle, the alpha queries are today's: transmission is 0 exactly where
/// `occluded` is true (1 elsewhere), the closest hit is `closest_hit`'s, and the traversal does
/// the same work (no alpha lookup).
#[test]
fn opaque_triangles_answer_as_today() {
    let (tris, _) = cards(300, 11);
    let none = AlphaTriangles::new(tris.len() as u32, 0, vec![]).unwrap();
    let alpha = AlphaScene::new(vec![], vec![], none).unwrap();
    let rays = rays(1500, 12);
    let bvh = build(BuildMethod::Sbvh, &tris, &settings(4));
    let wide = WideBvh::<8>::collapse(&bvh);
    let (mut blocked, mut free) = (0, 0);
    for ray in &rays {
        let (mut today, mut with_alpha) = (TraversalStats::default(), AlphaStats::default());
        let occ = bvh.occluded(ray, &mut today);
        let t = bvh.transmission(ray, &alpha, MAX_HITS, &mut with_alpha);
        assert_eq!(t, if occ { 0.0 } else { 1.0 });
        assert_eq!(with_alpha.traversal, today);
        assert_eq!(with_alpha.alpha_lookups, 0);
        blocked += occ as u32;
        free += !occ as u32;

        for kernel in [BoxKernel::Scalar, BoxKernel::Sse, BoxKernel::Auto] {
            let (mut today, mut with_alpha) = (TraversalStats::default(), AlphaStats::default());
            let order = OrderView::FrontToBack;
            let occ = WideQueries::occluded(&wide, ray, order, kernel, &mut today);
            let q = OrderedWide {
                bvh: &wide,
                order,
                kernel,
                rays: RayMode::Single,
            };
            let t = q.transmission(ray, &alpha, MAX_HITS, &mut with_alpha);
            assert_eq!(t, if occ { 0.0 } else { 1.0 });
            assert_eq!(with_alpha.traversal, today, "{kernel:?}");

            let mut today = TraversalStats::default();
            let want = WideQueries::closest_hit(&wide, ray, kernel, &mut today);
            let mut with_alpha = AlphaStats::default();
            let got = q.closest_hit_alpha(ray, &alpha, CLIP, &mut with_alpha);
            assert_eq!(key(got), key(want));
            assert_eq!(with_alpha.traversal, today, "{kernel:?} closest");
        }
        let mut today = TraversalStats::default();
        let want = bvh.closest_hit(ray, &mut today);
        let mut with_alpha = AlphaStats::default();
        assert_eq!(
            key(bvh.closest_hit_alpha(ray, &alpha, CLIP, &mut with_alpha)),
            key(want)
        );
        assert_eq!(with_alpha.traversal, today);
    }
    assert!(
        blocked > 100 && free > 100,
        "{blocked} blocked, {free} free"
    );
}

/// `n` parallel unit cards in front of each other along +z, each of material 0.
fn stack_of_cards(n: u32, program: AlphaProgram) -> (Vec<[Vec3; 3]>, AlphaScene) {
    let mut tris = Vec::new();
    let mut flagged = Vec::new();
    for i in 0..n {
        let z = i as f32;
        let c = [
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        ];
        for tri in [[0, 1, 2], [0, 2, 3]] {
            flagged.push(FlaggedTriangle {
                triangle: tris.len() as u32,
                material: 0,
                uvs: vec![],
            });
            tris.push(tri.map(|k| c[k]));
        }
    }
    let triangles = AlphaTriangles::new(tris.len() as u32, 0, flagged).unwrap();
    (
        tris,
        AlphaScene::new(vec![], vec![program], triangles).unwrap(),
    )
}

/// Up to `max_hits` transparent hits multiply; one more blocks the ray (Cycles' filter: opaque
/// once `num_hits >= max_hits`), in the reference and in every tree.
#[test]
fn more_than_max_hits_transparent_hits_block_the_ray() {
    let (tris, alpha) = stack_of_cards(6, AlphaProgram::constant(0.5));
    let ray = Ray::new(Vec3::new(0.3, 0.2, -1.0), Vec3::Z, 0.0, f32::INFINITY);
    let bvh = build(BuildMethod::Sah, &tris, &settings(1));
    let wide = WideBvh::<4>::collapse(&bvh);
    for (max_hits, want) in [(6, 0.5f32.powi(6)), (7, 0.5f32.powi(6)), (5, 0.0), (0, 0.0)] {
        let label = format!("max_hits {max_hits}");
        assert_eq!(
            brute_transmission(&tris, &ray, &alpha, max_hits),
            want,
            "{label}"
        );
        assert_eq!(
            bvh.transmission(&ray, &alpha, max_hits, &mut NoStats),
            want,
            "{label}"
        );
        assert_eq!(
            wide.transmission(&ray, &alpha, max_hits, &mut NoStats),
            want,
            "{label}"
        );
    }
}

/// A filter that counts every hit it is handed per triangle (transparent: never stops).
struct CountCalls(Vec<u32>);

impl HitFilter for CountCalls {
    const OPAQUE: bool = false;
    fn stops<C: Counters>(&mut self, triangle: u32, _: f32, _: [f32; 3], _: &mut C) -> bool {
        self.0[triangle as usize] += 1;
        false
    }
    fn accepts<C: Counters>(&mut self, _: u32, _: [f32; 3], _: &mut C) -> bool {
        true
    }
}

/// A split tree hands the traversal the same triangle from two leaves; the transmission counts
/// it once. The first half shows the duplicates happen on these rays (so the second half would
/// fail if the once-per-triangle rule went).
#[test]
fn a_triangle_in_two_leaves_counts_once() {
    // The random cards, every triangle glass: the SBVH splits their references.
    let (tris, _) = cards(300, 7);
    let flagged = (0..tris.len() as u32)
        .map(|t| FlaggedTriangle {
            triangle: t,
            material: 0,
            uvs: vec![],
        })
        .collect();
    let triangles = AlphaTriangles::new(tris.len() as u32, 0, flagged).unwrap();
    let alpha = AlphaScene::new(vec![], vec![AlphaProgram::constant(0.25)], triangles).unwrap();
    let bvh = build(BuildMethod::Sbvh, &tris, &settings(1));
    assert!(bvh.triangle_ids.len() > tris.len(), "no split references");
    let wide = WideBvh::<4>::collapse(&bvh);
    let rays = rays(2000, 41);
    let mut twice = 0;
    for ray in &rays {
        let mut calls = CountCalls(vec![0; tris.len()]);
        bvh.stopped(ray, &mut calls, &mut NoStats);
        twice += calls.0.iter().any(|&c| c > 1) as u32;
        // One alpha lookup per distinct triangle, however often the traversal meets it.
        let distinct = calls.0.iter().filter(|&&c| c > 0).count() as u64;
        let mut stats = AlphaStats::default();
        bvh.transmission(ray, &alpha, MAX_HITS, &mut stats);
        assert_eq!(stats.alpha_lookups, distinct);
        let mut calls = CountCalls(vec![0; tris.len()]);
        wide.stopped(ray, &mut calls, &mut NoStats);
        twice += calls.0.iter().any(|&c| c > 1) as u32;
        let distinct = calls.0.iter().filter(|&&c| c > 0).count() as u64;
        let mut stats = AlphaStats::default();
        wide.transmission(ray, &alpha, MAX_HITS, &mut stats);
        assert_eq!(stats.alpha_lookups, distinct);
    }
    assert!(twice >= 3, "only {twice} rays met a triangle twice");
    for (i, ray) in rays.iter().enumerate() {
        let want = brute_transmission(&tris, ray, &alpha, MAX_HITS);
        let got = bvh.transmission(ray, &alpha, MAX_HITS, &mut NoStats);
        assert_eq!(got.to_bits(), want.to_bits(), "binary ray {i}");
        let got = wide.transmission(ray, &alpha, MAX_HITS, &mut NoStats);
        assert_eq!(got.to_bits(), want.to_bits(), "wide ray {i}");
    }
}

/// The UV at a hit is the corners' UVs weighted by the hit's barycentrics, vertex for vertex:
/// a glass triangle whose UVs are its positions reads the texel under the hit point.
#[test]
fn the_hit_reads_the_texel_under_it() {
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    // 2x2: bottom row 0.1, 0.2; top row 0.3, 0.4 (bottom row first).
    let img = AlphaImage {
        width: 2,
        height: 2,
        texels: vec![0.1, 0.2, 0.3, 0.4],
    };
    let program = AlphaProgram::image(0, 0, Interpolation::Closest, Extension::Clip);
    let uvs = vec![[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]];
    let flagged = vec![FlaggedTriangle {
        triangle: 0,
        material: 0,
        uvs,
    }];
    let triangles = AlphaTriangles::new(1, 1, flagged).unwrap();
    let alpha = AlphaScene::new(vec![img], vec![program], triangles).unwrap();
    let bvh = build(BuildMethod::Sah, &[tri], &settings(1));
    for (x, y, texel) in [
        (0.1, 0.1, 0.1f32),
        (0.7, 0.1, 0.2),
        (0.1, 0.7, 0.3),
        (0.6, 0.3, 0.2),
    ] {
        let ray = Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z, 0.0, f32::INFINITY);
        let t = bvh.transmission(&ray, &alpha, MAX_HITS, &mut NoStats);
        assert_eq!(t, 1.0 - texel, "at ({x}, {y})");
        assert_eq!(
            brute_transmission(&[tri], &ray, &alpha, MAX_HITS),
            1.0 - texel
        );
    }
}

/// A camera ray goes on through a hit whose alpha is below the clip threshold and stops at one
/// at or above it.
#[test]
fn closest_hit_skips_hits_below_the_clip() {
    let (tris, alpha) = stack_of_cards(3, AlphaProgram::constant(0.4));
    let ray = Ray::new(Vec3::new(0.3, 0.2, -1.0), Vec3::Z, 0.0, f32::INFINITY);
    let bvh = build(BuildMethod::Sah, &tris, &settings(1));
    assert_eq!(bvh.closest_hit_alpha(&ray, &alpha, 0.5, &mut NoStats), None);
    let hit = bvh
        .closest_hit_alpha(&ray, &alpha, 0.4, &mut NoStats)
        .unwrap();
    assert_eq!(hit.t, 1.0);
    // An unflagged card behind the glass ones stops the ray whatever the clip.
    let (mut tris, alpha) = stack_of_cards(2, AlphaProgram::constant(0.0));
    let back = tris[0].map(|v| v + Vec3::Z * 5.0);
    tris.push(back);
    let triangles = alpha.triangles().clone();
    let grown = AlphaTriangles::new(
        5,
        0,
        (0..triangles.triangle_count())
            .map(|t| FlaggedTriangle {
                triangle: t,
                material: 0,
                uvs: vec![],
            })
            .collect(),
    )
    .unwrap();
    let alpha = AlphaScene::new(vec![], alpha.programs().to_vec(), grown).unwrap();
    let bvh = build(BuildMethod::Sah, &tris, &settings(1));
    let ray = Ray::new(Vec3::new(0.5, -0.5, -1.0), Vec3::Z, 0.0, f32::INFINITY);
    let hit = bvh
        .closest_hit_alpha(&ray, &alpha, 0.5, &mut NoStats)
        .unwrap();
    assert_eq!((hit.triangle, hit.t), (4, 6.0));
    assert_eq!(bvh.transmission(&ray, &alpha, MAX_HITS, &mut NoStats), 0.0);
}
