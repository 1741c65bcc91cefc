//! Bad input is an error that names what is wrong, never a panic.

use antumbra_rays::{BuildMethod, BuildOptions, Ray, Scene, ShadowOrder, TraceOptions};

const V: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

fn build_error(vertices: &[[f32; 3]], triangles: &[[u32; 3]], options: &BuildOptions) -> String {
    Scene::build(vertices, triangles, options)
        .unwrap_err()
        .to_string()
}

#[test]
fn bad_meshes_and_build_options_are_named() {
    let ok = BuildOptions::default();
    let nan = [[0.0, 0.0, 0.0], [1.0, f32::NAN, 0.0], [0.0, 1.0, 0.0]];
    let e = build_error(&nan, &[[0, 1, 2]], &ok);
    assert!(e.contains("vertex 1") && e.contains("NaN"), "{e}");
    let inf = [[0.0, 0.0, f32::INFINITY]; 3];
    assert!(build_error(&inf, &[[0, 1, 2]], &ok).contains("vertex 0"));
    let e = build_error(&V, &[[0, 1, 2], [0, 3, 1]], &ok);
    assert!(e.contains("triangle 1") && e.contains("vertex 3"), "{e}");
    // `auto` is the renderer's per-frame policy, not a builder: no method is spelled so.
    assert!("auto".parse::<BuildMethod>().is_err());
    let mut bins = BuildOptions::default();
    bins.settings.bins = 1;
    assert!(build_error(&V, &[[0, 1, 2]], &bins).starts_with("settings.bins:"));
    let mut leaves = BuildOptions::default();
    leaves.settings.min_leaf_size = 9;
    assert!(build_error(&V, &[[0, 1, 2]], &leaves).starts_with("settings.min_leaf_size:"));
    let visible = BuildOptions {
        visible: Some(vec![true; 2]),
        ..BuildOptions::default()
    };
    assert!(build_error(&V, &[[0, 1, 2]], &visible).contains("2 entries for 1 triangles"));
    let threads = BuildOptions {
        threads: usize::MAX,
        ..BuildOptions::default()
    };
    assert!(build_error(&V, &[[0, 1, 2]], &threads).starts_with("threads:"));
}

#[test]
fn empty_and_degenerate_meshes_are_scenes_that_nothing_hits() {
    let ray = [Ray::new([0.2, 0.2, 1.0], [0.0, 0.0, -1.0])];
    let trace = TraceOptions::default();
    let empty = Scene::build::<[f32; 3]>(&[], &[], &BuildOptions::default()).unwrap();
    assert_eq!(empty.intersect(&ray, &trace).unwrap(), [None]);
    let line = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
    let flat = Scene::build(&line, &[[0, 1, 2]], &BuildOptions::default()).unwrap();
    assert_eq!(flat.degenerate_count(), 1);
    assert_eq!(flat.occluded(&ray, &trace).unwrap(), [false]);
}

#[test]
fn bad_rays_and_trace_options_are_named() {
    let scene = Scene::build(&V, &[[0, 1, 2]], &BuildOptions::default()).unwrap();
    let trace = TraceOptions::default();
    let good = Ray::new([0.2, 0.2, 1.0], [0.0, 0.0, -1.0]);
    let cases = [
        (
            Ray {
                origin: [f64::NAN, 0.0, 0.0],
                ..good
            },
            "origin of ray 1",
        ),
        (
            Ray {
                direction: [0.0, f64::INFINITY, 0.0],
                ..good
            },
            "direction of ray 1",
        ),
        (
            Ray {
                direction: [0.0, 0.0, -0.0],
                ..good
            },
            "ray 1: direction is zero",
        ),
        (
            Ray {
                t_far: f32::NAN,
                ..good
            },
            "ray 1: t_near",
        ),
        (
            Ray {
                origin: [1e300, 0.0, 0.0],
                ..good
            },
            "ray 1: origin",
        ),
        (
            Ray {
                direction: [1e-300, 0.0, 0.0],
                ..good
            },
            "ray 1: direction",
        ),
    ];
    for (bad, expected) in cases {
        let e = scene
            .occluded(&[good, bad], &trace)
            .unwrap_err()
            .to_string();
        assert!(e.contains(expected), "{e}");
        let e = scene
            .intersect(&[good, bad], &trace)
            .unwrap_err()
            .to_string();
        assert!(e.contains(expected), "{e}");
    }
    let srdh = TraceOptions {
        order: "srdh".parse::<ShadowOrder>().unwrap(),
        ..TraceOptions::default()
    };
    let e = scene.occluded(&[good], &srdh).unwrap_err().to_string();
    assert!(e.starts_with("order:"), "{e}");
    // `auto` is the renderer's per-light policy, not an order.
    assert!("auto".parse::<ShadowOrder>().is_err());
    let threads = TraceOptions {
        threads: 1 << 40,
        ..TraceOptions::default()
    };
    let e = scene.occluded(&[good], &threads).unwrap_err().to_string();
    assert!(e.starts_with("threads: must be in 0..=1024"), "{e}");
    // t_near beyond t_far is an empty segment, not an error.
    let empty = Ray::segment(good.origin, good.direction, 2.0, 1.0);
    assert_eq!(scene.occluded(&[empty], &trace).unwrap(), [false]);
}
