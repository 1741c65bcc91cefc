//! Normalisation and the t interval: a scene moved 1e6 away or scaled by 2^±13 gives the base
//! scene's answers bit for bit (the render space absorbs both exactly), t is the caller's own
//! parameter, and the interval's ends behave as documented.

mod common;

use antumbra_rays::{BuildOptions, Interval, Ray, Scene, TraceOptions};
use common::{rays, soup, Rng};
use glam::DVec3;

/// The soup and its rays moved by `x -> x * scale + offset` in f64 (exact for these values).
fn moved(
    vertices: &[[f32; 3]],
    rays: &[Ray],
    scale: f64,
    offset: f64,
) -> (Vec<[f64; 3]>, Vec<Ray>) {
    let v = vertices
        .iter()
        .map(|p| p.map(|c| c as f64 * scale + offset))
        .collect();
    let r = rays
        .iter()
        .map(|r| Ray {
            origin: r.origin.map(|c| c * scale + offset),
            direction: r.direction.map(|c| c * scale),
            ..*r
        })
        .collect();
    (v, r)
}

#[test]
fn far_away_huge_and_tiny_scenes_trace_the_base_answers() {
    let mut rng = Rng(3);
    let (vertices, triangles) = soup(&mut rng, 500);
    let rays = rays(&mut rng, 2000);
    let trace = TraceOptions::default();
    let base = Scene::build(&vertices, &triangles, &BuildOptions::default()).unwrap();
    let hits = base.intersect(&rays, &trace).unwrap();
    let blocked = base.occluded(&rays, &trace).unwrap();
    assert!(hits.iter().flatten().count() > rays.len() / 4);
    for (scale, offset) in [
        (1.0, 1e6),
        (8192.0, 0.0),
        (1.0 / 8192.0, 0.0),
        (8192.0, -1e6),
    ] {
        let (v, r) = moved(&vertices, &rays, scale, offset);
        let scene = Scene::build(&v, &triangles, &BuildOptions::default()).unwrap();
        assert_eq!(
            scene.intersect(&r, &trace).unwrap(),
            hits,
            "x{scale} +{offset}"
        );
        assert_eq!(
            scene.occluded(&r, &trace).unwrap(),
            blocked,
            "x{scale} +{offset}"
        );
    }
    // Without the normalisation a scene at 1e6 in f32 keeps 1/16-unit steps: its triangles
    // (up to 4 units) would be mangled. Here the far scene's hit points land on their triangles.
    let (v, r) = moved(&vertices, &rays, 1.0, 1e6);
    let scene = Scene::build(&v, &triangles, &BuildOptions::default()).unwrap();
    for (ray, hit) in r.iter().zip(scene.intersect(&r, &trace).unwrap()) {
        let Some(h) = hit else { continue };
        let p = DVec3::from(ray.origin) + DVec3::from(ray.direction) * h.t as f64;
        let [a, b, c] = triangles[h.triangle as usize].map(|i| DVec3::from(v[i as usize]));
        let on = a * (1.0 - h.u as f64 - h.v as f64) + b * h.u as f64 + c * h.v as f64;
        assert!((p - on).length() < 1e-4, "{p} against {on}");
    }
}

fn one_triangle() -> Scene {
    let v = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    Scene::build(&v, &[[0, 1, 2]], &BuildOptions::default()).unwrap()
}

#[test]
fn the_interval_excludes_t_near_by_default_and_includes_it_as_embree() {
    let scene = one_triangle();
    let closed = TraceOptions {
        interval: Interval::Closed,
        ..TraceOptions::default()
    };
    let open = TraceOptions::default();
    // Starting on the triangle (t = 0), towards it from t_near = 2 (hit at t = 2), ending on it.
    let on = Ray::new([0.25, 0.25, 0.0], [0.0, 0.0, -1.0]);
    let at_near = Ray::segment([0.25, 0.25, 4.0], [0.0, 0.0, -2.0], 2.0, 5.0);
    let at_far = Ray::segment([0.25, 0.25, 4.0], [0.0, 0.0, -2.0], 0.0, 2.0);
    let short = Ray::segment([0.25, 0.25, 4.0], [0.0, 0.0, -2.0], 0.0, 1.999_999_9);
    let rays = [on, at_near, at_far, short];
    assert_eq!(
        scene.occluded(&rays, &open).unwrap(),
        [false, false, true, false]
    );
    assert_eq!(
        scene.occluded(&rays, &closed).unwrap(),
        [true, true, true, false]
    );
    let t: Vec<Option<f32>> = scene
        .intersect(&rays, &closed)
        .unwrap()
        .iter()
        .map(|h| h.map(|h| h.t))
        .collect();
    // t is in units of the caller's direction (length 2 here), not of distance.
    assert_eq!(t, [Some(0.0), Some(2.0), Some(2.0), None]);
}

#[test]
fn a_ray_through_a_shared_edge_hits_one_of_its_triangles() {
    let v = [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    let scene = Scene::build(&v, &[[0, 1, 2], [1, 3, 2]], &BuildOptions::default()).unwrap();
    let ray = Ray::new([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]);
    let hit = scene.intersect(&[ray], &TraceOptions::default()).unwrap()[0].unwrap();
    // Both are hit at t = 1; the tie goes to the smaller index.
    assert_eq!((hit.t, hit.triangle), (1.0, 0));
}
