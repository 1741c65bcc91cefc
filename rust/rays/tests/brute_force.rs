//! Every build method at every width gives exactly the brute-force answers (closest hit: t,
//! triangle, barycentrics, bit for bit; any hit: every order and box kernel) on random triangle
//! soups, with and without counters, on one thread and on several.

mod common;

use antumbra_rays::{
    BoxKernel, BuildMethod, BuildOptions, BvhWidth, Scene, ShadowOrder, TraceOptions,
};
use common::{brute_blocked, brute_hit, rays, render_ray, render_triangles, soup, Rng};

const METHODS: [BuildMethod; 5] = [
    BuildMethod::Sah,
    BuildMethod::Sbvh,
    BuildMethod::Abvh,
    BuildMethod::Osah,
    BuildMethod::Vsah,
];
const WIDTHS: [BvhWidth; 3] = [BvhWidth::Two, BvhWidth::Four, BvhWidth::Eight];
const ORDERS: [&str; 6] = [
    "stored",
    "fbto",
    "sato",
    "rtsah",
    "random:seed=3",
    "sorted:budget=0.25",
];
const KERNELS: [BoxKernel; 4] = [
    BoxKernel::Auto,
    BoxKernel::Scalar,
    BoxKernel::Sse,
    BoxKernel::Avx2,
];

#[test]
fn every_method_and_width_gives_the_brute_force_answers() {
    let mut rng = Rng(7);
    let (vertices, triangles) = soup(&mut rng, 800);
    let rays = rays(&mut rng, 3000);
    // ABVH and OSAH read a visible set (a third of the triangles); VSAH gets every triangle,
    // so that its tree is complete.
    let third: Vec<bool> = (0..triangles.len()).map(|i| i % 3 == 0).collect();
    let mut hits_seen = 0;
    for method in METHODS {
        for width in WIDTHS {
            let visible = match method {
                BuildMethod::Abvh | BuildMethod::Osah => Some(third.clone()),
                _ => None,
            };
            let options = BuildOptions {
                method,
                width,
                visible,
                ..BuildOptions::default()
            };
            let scene = Scene::build(&vertices, &triangles, &options).unwrap();
            let tris = render_triangles(&scene, &vertices, &triangles);
            let expected: Vec<_> = rays
                .iter()
                .map(|r| brute_hit(&tris, &render_ray(&scene, r)))
                .collect();
            let blocked: Vec<bool> = rays
                .iter()
                .map(|r| brute_blocked(&tris, &render_ray(&scene, r)))
                .collect();
            let what = format!("{} width {width}", method.name());
            let hits = scene.intersect(&rays, &TraceOptions::default()).unwrap();
            assert_hits_equal(&hits, &expected, &what);
            hits_seen += hits.iter().flatten().count();
            for order in ORDERS {
                for kernel in KERNELS {
                    let trace = TraceOptions {
                        order: order.parse::<ShadowOrder>().unwrap(),
                        kernel,
                        ..TraceOptions::default()
                    };
                    let got = scene.occluded(&rays, &trace).unwrap();
                    assert_eq!(got, blocked, "{what} {order} {kernel:?}");
                }
            }
        }
    }
    // The soup is dense enough that many rays hit something.
    assert!(
        hits_seen > METHODS.len() * WIDTHS.len() * rays.len() / 4,
        "{hits_seen}"
    );
}

fn assert_hits_equal(
    got: &[Option<antumbra_rays::Hit>],
    expected: &[Option<antumbra_rays::Hit>],
    what: &str,
) {
    assert_eq!(got.len(), expected.len());
    for (i, (g, e)) in got.iter().zip(expected).enumerate() {
        let bits = |h: &Option<antumbra_rays::Hit>| {
            h.map(|h| (h.t.to_bits(), h.triangle, h.u.to_bits(), h.v.to_bits()))
        };
        assert_eq!(bits(g), bits(e), "{what}: ray {i}: {g:?} against {e:?}");
    }
}

#[test]
fn counters_kernels_and_threads_change_no_answer_and_kernels_no_count() {
    let mut rng = Rng(11);
    let (vertices, triangles) = soup(&mut rng, 300);
    let rays = rays(&mut rng, 2000);
    let scene = Scene::build(&vertices, &triangles, &BuildOptions::default()).unwrap();
    let base = TraceOptions::default();
    let hits = scene.intersect(&rays, &base).unwrap();
    let blocked = scene.occluded(&rays, &base).unwrap();
    let (counted_hits, hit_work) = scene.intersect_counted(&rays, &base).unwrap();
    let (counted_blocked, any_work) = scene.occluded_counted(&rays, &base).unwrap();
    assert_eq!(counted_hits, hits);
    assert_eq!(counted_blocked, blocked);
    assert_eq!((hit_work.len(), any_work.len()), (rays.len(), rays.len()));
    // Every ray tests at least the root's box; rays that hit entered a leaf and tested a triangle.
    for (h, w) in hits.iter().zip(&hit_work) {
        assert!(w.boxes >= 1);
        if h.is_some() {
            assert!(w.leaves >= 1 && w.triangles >= 1, "{w:?}");
        }
    }
    for kernel in KERNELS {
        for threads in [1, 3] {
            let trace = TraceOptions {
                kernel,
                threads,
                ..TraceOptions::default()
            };
            let (h, hw) = scene.intersect_counted(&rays, &trace).unwrap();
            let (b, bw) = scene.occluded_counted(&rays, &trace).unwrap();
            assert_eq!(
                (h, b),
                (hits.clone(), blocked.clone()),
                "{kernel:?} {threads}"
            );
            assert_eq!((hw, bw), (hit_work.clone(), any_work.clone()), "{kernel:?}");
        }
    }
}
