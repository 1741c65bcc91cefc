//! The one query face, `RayQuery`: every layout (binary with either order, wide 2/4/8 alone and
//! with a prepared order, the run-time-width tree, a light's SRDH tree, and the shadow pass's
//! tracer over each) answers as brute force for one ray, and its batch forms give the single-ray
//! answers and the single-ray counts, ray for ray.

use antumbra_core::build::{build_binned_sah, BuildSettings, CollapseSettings};
use antumbra_core::bvh::{Bvh, BvhWidth};
use antumbra_core::geometry::Ray;
use antumbra_core::order::{AnyHitOrder, OrderView, ShadowOrder, SrdhSettings};
use antumbra_core::render::{ShadowTracer, WideTree};
use antumbra_core::sampling::{hash_u32, unit_float};
use antumbra_core::srdh::{build_srdh, RaySet};
use antumbra_core::trace::wide::PACKET_LANES;
use antumbra_core::trace::{
    brute_closest_hit, brute_occluded, Hit, NoStats, OrderedBinary, OrderedWide, RayMode, RayQuery,
    TraversalStats,
};
use glam::Vec3;

fn r(seed: u32) -> f32 {
    unit_float(hash_u32(seed))
}

fn v(seed: u32) -> Vec3 {
    Vec3::new(r(3 * seed), r(3 * seed + 1), r(3 * seed + 2)) * 2.0 - 1.0
}

fn triangles(n: u32) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|i| {
            let c = v(i * 3);
            [c, c + 0.25 * v(i * 3 + 1), c + 0.25 * v(i * 3 + 2)]
        })
        .collect()
}

/// Segments (t in (0, 1]) and unbounded rays through the cloud, from outside and inside it.
fn rays(n: u32) -> Vec<Ray> {
    (0..n)
        .map(|k| {
            let o = 1.4 * v(50_000 + k);
            let d = v(60_000 + k) - o;
            Ray::new(o, d, 0.0, if k % 4 == 0 { f32::INFINITY } else { 1.0 })
        })
        .collect()
}

/// Fails naming the first ray whose entries differ (not printing every ray's).
fn same<T: PartialEq + std::fmt::Debug>(got: &[T], want: &[T], name: &str, what: &str) {
    assert_eq!(got.len(), want.len(), "{name}: {what}");
    if let Some(i) = (0..got.len()).find(|&i| got[i] != want[i]) {
        panic!(
            "{name}: {what}: ray {i}: {:?} against {:?}",
            got[i], want[i]
        );
    }
}

/// `q` against brute force ray by ray, and its batch forms against its single-ray forms
/// (answers and counters), counted and uncounted; returns the occluded rays.
fn check(name: &str, q: &impl RayQuery, tris: &[[Vec3; 3]], rays: &[Ray]) -> usize {
    let mut single_work = Vec::new();
    let mut single_hits = Vec::new();
    let mut single_occluded = Vec::new();
    for (i, ray) in rays.iter().enumerate() {
        let mut w = TraversalStats::default();
        let occ = q.occluded(ray, &mut w);
        let mut c = TraversalStats::default();
        let hit = q.closest_hit(ray, &mut c);
        assert_eq!(occ, brute_occluded(tris, ray), "{name}: ray {i} any hit");
        assert_eq!(
            hit.map(|h| (h.triangle, h.t)),
            brute_closest_hit(tris, ray).map(|h| (h.triangle, h.t)),
            "{name}: ray {i} closest hit"
        );
        assert_eq!(occ, q.occluded(ray, &mut NoStats), "{name}: ray {i}");
        single_occluded.push(occ);
        single_hits.push(hit);
        single_work.push((w, c));
    }
    let n = rays.len();
    let mut occluded = vec![false; n];
    let mut counted = vec![TraversalStats::default(); n];
    q.occluded_batch(rays, &mut occluded, &mut counted);
    same(&occluded, &single_occluded, name, "occluded_batch");
    let single_any: Vec<_> = single_work.iter().map(|w| w.0).collect();
    same(&counted, &single_any, name, "occluded_batch counters");
    let mut uncounted = vec![true; n];
    q.occluded_batch(rays, &mut uncounted, &mut vec![NoStats; n]);
    same(
        &uncounted,
        &single_occluded,
        name,
        "occluded_batch, no counters",
    );

    let mut hits: Vec<Option<Hit>> = vec![None; n];
    let mut counted = vec![TraversalStats::default(); n];
    q.closest_hit_batch(rays, &mut hits, &mut counted);
    same(&hits, &single_hits, name, "closest_hit_batch");
    let single_closest: Vec<_> = single_work.iter().map(|w| w.1).collect();
    same(
        &counted,
        &single_closest,
        name,
        "closest_hit_batch counters",
    );
    q.closest_hit_batch(rays, &mut hits, &mut vec![NoStats; n]);
    same(&hits, &single_hits, name, "closest_hit_batch, no counters");
    single_occluded.iter().filter(|o| **o).count()
}

#[test]
fn every_layout_answers_through_one_face_for_a_ray_and_a_batch() {
    let tris = triangles(600);
    let rays = rays(700);
    let settings = BuildSettings {
        max_leaf_size: 3,
        ..BuildSettings::default()
    };
    let bvh: Bvh = build_binned_sah(&tris, &settings);
    let occluded = check("binary alone", &bvh, &tris, &rays);
    assert!(occluded > 100 && occluded < rays.len() - 100, "{occluded}");
    for order in [AnyHitOrder::Stored, AnyHitOrder::NearFirst] {
        let q = OrderedBinary { bvh: &bvh, order };
        check(&format!("binary {order:?}"), &q, &tris, &rays);
        check("tracer binary", &ShadowTracer::Binary(q), &tris, &rays);
    }
    let collapse = CollapseSettings::default();
    for width in [BvhWidth::Two, BvhWidth::Four, BvhWidth::Eight] {
        let tree = WideTree::collapse(&bvh, width, &collapse);
        check(&format!("{width:?} alone"), &tree, &tris, &rays);
        let prepared = tree.prepare(&ShadowOrder::Sato, None, &[]);
        let ordered = tree.ordered(prepared.view());
        check(&format!("{width:?} sato"), &ordered, &tris, &rays);
        check("tracer wide", &ShadowTracer::Wide(ordered), &tris, &rays);
        if let WideTree::Eight(bvh) = &tree {
            check("8-wide alone", bvh, &tris, &rays);
            let q = OrderedWide {
                bvh,
                order: prepared.view(),
                kernel: antumbra_core::trace::wide::BoxKernel::Scalar,
                rays: RayMode::Single,
            };
            check("8-wide sato, scalar kernel", &q, &tris, &rays);
            let stored = OrderedWide {
                order: OrderView::Stored,
                ..q
            };
            check("8-wide stored, scalar kernel", &stored, &tris, &rays);
        }
    }
    let set = RaySet::trace(&bvh, rays[..200].to_vec());
    let srdh = build_srdh(&tris, &set, &SrdhSettings::default(), &settings);
    check("srdh", &srdh, &tris, &rays);
    check("tracer srdh", &ShadowTracer::Srdh(&srdh), &tris, &rays);
}

/// A packet query's batches against its single-ray answers: occlusion, and closest hits bit
/// for bit (t, triangle, barycentrics), counted and uncounted. A ray no triangle occludes
/// enters every box it meets whatever the order, so its packet counts equal its single-ray
/// counts exactly; an occluded ray may stop elsewhere in another order. Returns the rays
/// occluded and the lanes handed to single rays.
fn check_packets(name: &str, q: &impl RayQuery, rays: &[Ray]) -> (usize, u64) {
    let n = rays.len();
    let (mut single_occ, mut single_any, mut single_hits) = (vec![], vec![], vec![]);
    for ray in rays {
        let mut w = TraversalStats::default();
        single_occ.push(q.occluded(ray, &mut w));
        single_any.push(w);
        single_hits.push(q.closest_hit(ray, &mut NoStats));
    }
    let mut occluded = vec![true; n];
    let mut counted = vec![TraversalStats::default(); n];
    q.occluded_batch(rays, &mut occluded, &mut counted);
    same(&occluded, &single_occ, name, "packets, occluded");
    for i in (0..n).filter(|&i| !single_occ[i]) {
        assert_eq!(
            per_ray(counted[i]),
            single_any[i],
            "{name}: ray {i}: an unoccluded ray's counts"
        );
    }
    let handoffs = check_packet_counts(name, rays, &counted, "any hit");
    let mut uncounted = vec![true; n];
    q.occluded_batch(rays, &mut uncounted, &mut vec![NoStats; n]);
    same(
        &uncounted,
        &single_occ,
        name,
        "packets, occluded, no counters",
    );
    let mut hits = vec![None; n];
    let mut counted = vec![TraversalStats::default(); n];
    q.closest_hit_batch(rays, &mut hits, &mut counted);
    same(&hits, &single_hits, name, "packets, closest hits");
    let handoffs = handoffs + check_packet_counts(name, rays, &counted, "closest hit");
    let mut hits = vec![None; n];
    q.closest_hit_batch(rays, &mut hits, &mut vec![NoStats; n]);
    same(
        &hits,
        &single_hits,
        name,
        "packets, closest hits, no counters",
    );
    (single_occ.iter().filter(|o| **o).count(), handoffs)
}

/// A ray's own counts, without the packet counters its packet's first ray carries.
fn per_ray(s: TraversalStats) -> TraversalStats {
    TraversalStats {
        packets: 0,
        packet_steps: 0,
        handoffs: 0,
        ..s
    }
}

/// The packet counters of a batch: one packet per octant present in each run of 16 rays,
/// counted on its first ray; a step takes at least two active lanes (a lane alone goes on as
/// a single ray), each counting the node.
fn check_packet_counts(name: &str, rays: &[Ray], counted: &[TraversalStats], what: &str) -> u64 {
    use antumbra_core::trace::wide::WideRay;
    let mut want = 0;
    let mut firsts = Vec::new();
    for (c, chunk) in rays.chunks(PACKET_LANES).enumerate() {
        let mut seen = [false; 8];
        for (k, ray) in chunk.iter().enumerate() {
            let octant = WideRay::<8>::octant(ray);
            if !seen[octant] {
                seen[octant] = true;
                want += 1;
                firsts.push(c * PACKET_LANES + k);
            }
        }
    }
    let total = counted.iter().fold(TraversalStats::default(), |mut t, c| {
        t += *c;
        t
    });
    assert_eq!(total.packets, want, "{name} {what}: packets");
    for (i, c) in counted.iter().enumerate() {
        assert_eq!(
            c.packets,
            firsts.contains(&i) as u64,
            "{name} {what}: ray {i}'s packets"
        );
    }
    assert!(
        2 * total.packet_steps <= total.inner,
        "{name} {what}: {} steps, {} nodes",
        total.packet_steps,
        total.inner
    );
    total.handoffs
}

/// Coherent rays as the passes make them: a grid of camera rays from one point, and shadow
/// rays from points spread over the cloud toward one point light, both in row-major tiles of
/// 4x4 so that each 16 consecutive rays are neighbours; some along axis planes (a zero
/// direction component), where packets mix fixed and free octants.
fn coherent_rays() -> Vec<Ray> {
    let eye = Vec3::new(0.1, 0.2, 2.5);
    let light = Vec3::new(-0.3, 1.6, 0.4);
    let mut rays = Vec::new();
    for tile in 0..64u32 {
        for k in 0..16u32 {
            let (x, y) = ((tile % 8) * 4 + k % 4, (tile / 8) * 4 + k / 4);
            let (u, w) = (x as f32 / 16.0 - 1.0, y as f32 / 16.0 - 1.0);
            // The middle column and row are exactly on axis planes.
            rays.push(Ray::new(eye, Vec3::new(u, w, -1.0), 0.0, f32::INFINITY));
            let p = Vec3::new(u, 0.5 * w, 0.9 * u * w);
            rays.push(Ray::new(p, light - p, 1e-4, 1.0));
        }
    }
    // Camera rays then shadow rays, each in their tiles of 16.
    let (camera, shadow): (Vec<_>, Vec<_>) = rays.iter().enumerate().partition(|(i, _)| i % 2 == 0);
    camera.into_iter().chain(shadow).map(|(_, r)| *r).collect()
}

#[test]
fn packets_answer_as_single_rays_on_every_width_order_and_kernel() {
    use antumbra_core::trace::wide::BoxKernel;
    let tris = triangles(1500);
    let settings = BuildSettings {
        max_leaf_size: 4,
        ..BuildSettings::default()
    };
    let bvh: Bvh = build_binned_sah(&tris, &settings);
    let mut ray_sets = vec![("coherent", coherent_rays()), ("random", rays(700))];
    // A short last chunk and a single ray.
    ray_sets.push(("coherent, 37", coherent_rays()[..37].to_vec()));
    let collapse = CollapseSettings::default();
    let (mut occluded, mut handoffs) = (0, 0);
    for width in [BvhWidth::Two, BvhWidth::Four, BvhWidth::Eight] {
        let tree = WideTree::collapse(&bvh, width, &collapse);
        let tables = tree.sort_tables();
        let representative = &coherent_rays()[1024..];
        let sorted = ShadowOrder::Sorted(Default::default());
        for order in [ShadowOrder::Fbto, ShadowOrder::Sato, sorted] {
            let prepared = tree.prepare(&order, Some(&tables), representative);
            for kernel in [
                BoxKernel::Auto,
                BoxKernel::Avx2,
                BoxKernel::Sse,
                BoxKernel::Scalar,
            ] {
                for (set, rays) in &ray_sets {
                    let mut q = tree.ordered(prepared.view()).with_rays(RayMode::Packet);
                    q.kernel = kernel;
                    let name = format!("{width:?} {order:?} {kernel:?} {set}");
                    let (o, h) = check_packets(&name, &q, rays);
                    occluded += o;
                    handoffs += h;
                }
            }
        }
    }
    assert!(occluded > 1000, "{occluded} occluded rays in all");
    assert!(
        handoffs > 1000,
        "{handoffs} lanes handed to single rays in all"
    );
    // The packets' answers are brute force's (not only the single rays').
    let tree = WideTree::collapse(&bvh, BvhWidth::Eight, &collapse);
    let q = tree
        .ordered(OrderView::FrontToBack)
        .with_rays(RayMode::Packet);
    let rays = coherent_rays();
    let mut hits = vec![None; rays.len()];
    q.closest_hit_batch(&rays, &mut hits, &mut vec![NoStats; rays.len()]);
    for (i, (ray, hit)) in rays.iter().zip(&hits).enumerate() {
        let want = brute_closest_hit(&tris, ray).map(|h| (h.triangle, h.t));
        assert_eq!(hit.map(|h| (h.triangle, h.t)), want, "ray {i}");
    }
}
