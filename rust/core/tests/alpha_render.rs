//! The renderer through alpha (issue 38): every shadow method, order, width, build and ray
//! mode gives masks equal bit for bit to `brute_transmission` on the same rays and camera hits
//! equal to `brute_closest_hit_alpha`; alpha off and opaque materials keep today's answers and
//! counters; glass panes cast their constant; the transparent-bounce limit blackens; two levels
//! trace alpha per instance as the flat tree does; bad input is an error naming what is wrong.

#[path = "common/alpha_ref.rs"]
mod alpha_ref;
mod common;

use std::sync::Arc;

use antumbra_core::alpha::{AlphaImage, AlphaProgram, Extension, Interpolation};
use antumbra_core::render::{Pick, RenderSettings, Renderer, SceneStructure, StatsMode};
use antumbra_core::scene::{
    AlphaMaterial, Camera, Light, LightKind, Mesh, Object, Resolution, Scene, SceneAlpha, UvMap,
};
use antumbra_core::trace::RayMode;
use glam::{DMat4, DQuat, DVec3};

/// A 16x16 leaf: an ellipse with a soft rim.
fn leaf() -> AlphaImage {
    let texels = (0..256)
        .map(|i| {
            let (u, v) = (
                ((i % 16) as f32 + 0.5) / 16.0,
                ((i / 16) as f32 + 0.5) / 16.0,
            );
            let d = (((u - 0.5) / 0.3).powi(2) + ((v - 0.5) / 0.45).powi(2)).sqrt();
            ((1.0 - d) * 4.0).clamp(0.0, 1.0)
        })
        .collect();
    AlphaImage {
        width: 16,
        height: 16,
        texels,
    }
}

/// `n` random unit cards in [-4,4]^2 x [0.5,3], UVs over [0, 1.5]^2 in the map "UV".
fn cards(name: &str, n: u32, seed: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut corners = Vec::new();
    for k in 0..n {
        let s = seed * 7919 + k * 13;
        let centre = DVec3::new(
            -4.0 + 8.0 * common::rand(s),
            -4.0 + 8.0 * common::rand(s + 1),
            0.5 + 2.5 * common::rand(s + 2),
        );
        let axis = (common::rand3(s + 3) - DVec3::splat(0.5)).normalize_or(DVec3::Z);
        let q = DQuat::from_axis_angle(axis, std::f64::consts::TAU * common::rand(s + 4));
        let base = positions.len() as u32;
        for (x, y) in [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)] {
            positions.push((centre + q * DVec3::new(x, y, 0.0)).as_vec3());
        }
        let uv = [[0.0, 0.0], [1.5, 0.0], [1.5, 1.5], [0.0, 1.5]];
        for [a, b, c] in [[0usize, 1, 2], [0, 2, 3]] {
            triangles.push([base + a as u32, base + b as u32, base + c as u32]);
            corners.push([uv[a], uv[b], uv[c]]);
        }
    }
    let map = UvMap {
        name: "UV".into(),
        corners,
    };
    Mesh::new(name, positions, triangles).with_alpha(Vec::new(), vec![map])
}

/// A `w` x `h` horizontal pane centred at `c` (two triangles, no UVs).
fn pane(name: &str, c: DVec3, w: f64, h: f64) -> Mesh {
    let p = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .map(|(x, y)| (c + DVec3::new(x * w / 2.0, y * h / 2.0, 0.0)).as_vec3());
    Mesh::new(name, p.to_vec(), vec![[0, 1, 2], [0, 2, 3]])
}

fn material(name: &str, uv_map: &str, program: AlphaProgram) -> AlphaMaterial {
    AlphaMaterial {
        name: name.into(),
        uv_map: uv_map.into(),
        program,
    }
}

/// Ground, a box, leaf cards (one object seen by the camera, one casting shadows only, one
/// whose material reads a UV map its mesh lacks), a glass pane; a soft sun, a soft and a hard
/// point light.
fn garden() -> Scene {
    let mut scene = common::boxes_scene(40);
    scene.resolution = Resolution::new(48, 36);
    scene.meshes.push(Arc::new(cards("Leaves", 150, 1)));
    scene.meshes.push(Arc::new(cards("Hidden leaves", 60, 2)));
    scene
        .meshes
        .push(Arc::new(pane("Pane", DVec3::new(1.0, -1.0, 2.5), 3.0, 2.0)));
    let n = scene.meshes.len();
    let mut add = |name: &str, mesh: usize, material: Option<u32>| {
        let mut o = Object::new(name, mesh, DMat4::IDENTITY);
        o.materials = vec![material];
        scene.objects.push(o);
    };
    add("Leaves", n - 3, Some(0));
    add("Leaves without map", n - 3, Some(1));
    add("Hidden leaves", n - 2, Some(0));
    add("Glass", n - 1, Some(2));
    let hidden = scene.objects.len() - 2;
    scene.objects[hidden].visible_to_camera = false;
    // The second copy sits higher, so it is not the first one's twin.
    let copy = scene.objects.len() - 3;
    scene.objects[copy].world_from_object = DMat4::from_translation(DVec3::new(0.5, 0.3, 0.7));
    scene.alpha = SceneAlpha {
        images: vec![Arc::new(leaf())],
        materials: vec![
            material(
                "Leaf",
                "UV",
                AlphaProgram::image(0, 0, Interpolation::Linear, Extension::Repeat),
            ),
            material(
                "Leaf without map",
                "Missing",
                AlphaProgram::image(0, 0, Interpolation::Closest, Extension::Clip),
            ),
            material("Glass", "", AlphaProgram::constant(0.5)),
        ],
    };
    scene.lights[0].kind = LightKind::Sun { angle: 0.08 };
    scene.lights[1].kind = LightKind::Point { radius: 0.3 };
    let mut hard = scene.lights[1].clone();
    hard.name = "Hard".into();
    hard.world_from_light = DMat4::from_translation(DVec3::new(3.0, 2.0, 6.0));
    hard.kind = LightKind::Point { radius: 0.0 };
    scene.lights.push(hard);
    scene
}

fn settings(text: &[(&str, &str)]) -> RenderSettings {
    let mut s = RenderSettings::baseline();
    for (k, v) in text {
        match *k {
            "build" => s.build = v.parse().unwrap(),
            "order" => s.shadow_order = v.parse().unwrap(),
            "width" => s.width = v.parse().unwrap(),
            _ => unreachable!("{k}"),
        }
    }
    s
}

#[test]
fn every_method_equals_brute_force_bit_for_bit() {
    let scene = garden();
    let base = RenderSettings::baseline();
    let (first, renderer) = alpha_ref::render(&scene, &base, "baseline");
    let reference = alpha_ref::reference(&scene, &base, &renderer);
    alpha_ref::compare(&first, &reference, "baseline");
    // Transparent shadows give fractions, and the clipped camera sees the ground through cards.
    assert!(first.masks[2].data.iter().any(|&v| v > 0.0 && v < 1.0));
    let lookups = renderer.alpha_stats().expect("alpha traced");
    assert!(lookups.primary > 0 && lookups.shadow.iter().all(|(_, n)| *n > 0));
    // The rows say the same per ray.
    for row in &first.stats {
        let n = match row.pass.as_str() {
            "primary" => lookups.primary,
            _ => {
                lookups
                    .shadow
                    .iter()
                    .find(|(l, _)| *l == row.light)
                    .unwrap()
                    .1
            }
        };
        assert_eq!(
            row.alpha_lookups_per_ray,
            n as f64 / row.rays as f64,
            "{row:?}"
        );
    }
    let orders = [
        "stored",
        "fbto",
        "sato",
        "rtsah",
        "random:seed=1",
        "sorted:budget=0.2",
        "srdh:rays=all:min_occluded=0",
    ];
    for build in ["sah", "sbvh"] {
        for width in ["2", "4", "8"] {
            for order in orders {
                let mut s = settings(&[("build", build), ("width", width), ("order", order)]);
                let label = s.method_name();
                let (r, _) = alpha_ref::render(&scene, &s, &label);
                alpha_ref::compare(&r, &reference, &label);
                if width != "2" {
                    s.rays = Pick::Fixed(RayMode::Packet);
                    s.stats = StatsMode::CountsAndTiming;
                    let (r, _) = alpha_ref::render(&scene, &s, &format!("{label} packets"));
                    alpha_ref::compare(&r, &reference, &label);
                }
            }
        }
    }
    // `auto` over a few frames (it explores, samples and may keep trees), timed only too.
    for stats in [StatsMode::Counts, StatsMode::TimingOnly] {
        let s = RenderSettings {
            spp: base.spp,
            stats,
            ..RenderSettings::default()
        };
        let mut renderer = Renderer::new();
        for frame in 1..=3 {
            let mut scene = scene.clone();
            scene.frame = frame;
            let r = renderer.render("alpha", &scene, &s).unwrap();
            alpha_ref::compare(&r, &reference, &format!("auto frame {frame}"));
        }
    }
}

/// The garden with every alpha material swapped for `program`.
fn with_programs(scene: &Scene, program: AlphaProgram) -> Scene {
    let mut s = scene.clone();
    for m in &mut s.alpha.materials {
        m.program = program.clone();
    }
    s
}

/// The garden with no alpha at all.
fn stripped(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    for o in &mut s.objects {
        o.materials.clear();
    }
    s.alpha = SceneAlpha::default();
    s
}

#[test]
fn alpha_off_and_opaque_materials_keep_todays_masks_and_counters() {
    let scene = garden();
    for width in ["2", "8"] {
        let on = settings(&[("width", width), ("order", "sato")]);
        let off = RenderSettings {
            alpha: false,
            ..on.clone()
        };
        let opaque = Renderer::new().render("t", &stripped(&scene), &on).unwrap();
        let mut renderer = Renderer::new();
        let r = renderer.render("t", &scene, &off).unwrap();
        assert!(renderer.alpha_stats().is_none());
        assert_eq!(r.masks, opaque.masks, "{width}");
        assert_eq!(r.primary_hits, opaque.primary_hits);
        let untimed = |r: &antumbra_core::render::FrameResult| {
            r.stats.iter().map(|s| s.untimed()).collect::<Vec<_>>()
        };
        assert_eq!(untimed(&r), untimed(&opaque), "{width}");
        // A slot mapped to a material no triangle uses flags nothing: the opaque path.
        let mut unused = stripped(&scene);
        unused.alpha = scene.alpha.clone();
        unused.objects[0].materials = vec![None, Some(0)];
        let mut renderer = Renderer::new();
        let r = renderer.render("t", &unused, &on).unwrap();
        assert!(renderer.alpha_stats().is_none());
        assert_eq!(r.masks, opaque.masks, "{width}");
        assert_eq!(untimed(&r), untimed(&opaque), "{width}");
        // Flagged triangles of alpha 1: the alpha path, today's answers and work.
        let mut renderer = Renderer::new();
        let ones = with_programs(&scene, AlphaProgram::constant(1.0));
        let r = renderer.render("t", &ones, &on).unwrap();
        assert!(renderer.alpha_stats().is_some_and(|a| a.primary > 0));
        assert_eq!(r.masks, opaque.masks, "{width}");
        assert_eq!(r.primary_hits, opaque.primary_hits);
        // The same rows but the lookups, which only the alpha path makes.
        assert!(r.stats.iter().all(|s| s.alpha_lookups_per_ray > 0.0));
        assert!(opaque.stats.iter().all(|s| s.alpha_lookups_per_ray == 0.0));
        let without_lookups = |r: &antumbra_core::render::FrameResult| {
            let mut rows = untimed(r);
            rows.iter_mut().for_each(|s| s.alpha_lookups_per_ray = 0.0);
            rows
        };
        assert_eq!(without_lookups(&r), untimed(&opaque), "{width}");
    }
}

/// Ground under one pane (x in [-3, 1]) and a second (x in [-1, 3]) above it, the sun
/// straight down, the camera above looking down through them (clip 0.6 > the glass's 0.5).
fn panes(two: bool) -> Scene {
    let mut meshes = vec![
        Arc::new(common::grid("ground", 2)),
        Arc::new(pane("Low", DVec3::new(-1.0, 0.0, 2.0), 4.0, 4.0)),
    ];
    if two {
        meshes.push(Arc::new(pane("High", DVec3::new(1.0, 0.0, 3.0), 4.0, 4.0)));
    }
    let mut objects = vec![Object::new(
        "Ground",
        0,
        DMat4::from_scale(DVec3::splat(10.0)),
    )];
    for (m, mesh) in meshes.iter().enumerate().skip(1) {
        let mut o = Object::new(mesh.name.clone(), m, DMat4::IDENTITY);
        o.materials = vec![Some(0)];
        objects.push(o);
    }
    let down = DMat4::look_at_rh(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, DVec3::Y).inverse();
    Scene {
        frame: 1,
        meshes,
        objects,
        camera: Camera::look_at(DVec3::new(0.0, 0.0, 12.0), DVec3::ZERO, DVec3::Y),
        lights: vec![Light::new("Sun", down, LightKind::Sun { angle: 0.0 })],
        resolution: Resolution::new(40, 30),
        alpha: SceneAlpha {
            images: Vec::new(),
            materials: vec![material("Glass", "", AlphaProgram::constant(0.5))],
        },
    }
}

/// How many pixels of the mask hold each of `values` (and that it holds no other).
fn census(mask: &[f32], values: &[f32]) -> Vec<usize> {
    for v in mask {
        assert!(values.contains(v), "{v} not in {values:?}");
    }
    values
        .iter()
        .map(|v| mask.iter().filter(|m| *m == v).count())
        .collect()
}

#[test]
fn glass_panes_cast_their_alpha_and_the_bounce_limit_blackens() {
    let glass = |bounces: u32| RenderSettings {
        alpha_clip: 0.6,
        transparent_bounces: bounces,
        width: "8".parse().unwrap(),
        ..RenderSettings::baseline()
    };
    let one = Renderer::new()
        .render("t", &panes(false), &glass(8))
        .unwrap();
    let n = census(&one.masks[0].data, &[1.0, 0.5]);
    assert!(n.iter().all(|&k| k > 0), "{n:?}");
    let two = Renderer::new()
        .render("t", &panes(true), &glass(8))
        .unwrap();
    let n = census(&two.masks[0].data, &[1.0, 0.5, 0.25]);
    assert!(n.iter().all(|&k| k > 0), "{n:?}");
    // Two transparent bounces let one transparent hit through: two panes are black.
    let limited = Renderer::new()
        .render("t", &panes(true), &glass(2))
        .unwrap();
    let m = census(&limited.masks[0].data, &[1.0, 0.5, 0.0]);
    assert_eq!(m[2], n[2], "the doubly covered pixels are black");
    // One bounce lets none through.
    let none = Renderer::new()
        .render("t", &panes(false), &glass(1))
        .unwrap();
    census(&none.masks[0].data, &[1.0, 0.0]);
    // The camera clipping nothing sees the pane: every pixel under it is lit (nothing above).
    let seen = RenderSettings {
        alpha_clip: 0.5,
        ..glass(8)
    };
    let r = Renderer::new().render("t", &panes(false), &seen).unwrap();
    census(&r.masks[0].data, &[1.0]);
}

#[test]
fn bad_input_is_an_error_naming_what_is_wrong() {
    let render = |scene: &Scene, s: &RenderSettings| {
        Renderer::new()
            .render("t", scene, s)
            .err()
            .map(|e| e.to_string())
            .expect("an error")
    };
    let base = RenderSettings::baseline();
    let mut scene = garden();
    let leaves = scene
        .objects
        .iter()
        .position(|o| o.name == "Leaves")
        .unwrap();
    scene.objects[leaves].materials = vec![Some(7)];
    let e = render(&scene, &base);
    assert!(e.contains("'Leaves'") && e.contains("materials[0]"), "{e}");

    let mut scene = garden();
    let mut mesh = (*scene.meshes[scene.objects[leaves].mesh]).clone();
    mesh.uv_maps[0].corners[3][1][0] = f32::NAN;
    let index = scene.objects[leaves].mesh;
    scene.meshes[index] = Arc::new(mesh);
    let e = render(&scene, &base);
    assert!(e.contains("Leaves") && e.contains("'UV'"), "{e}");

    let mut scene = garden();
    scene.alpha.images[0] = Arc::new(AlphaImage {
        width: 0,
        height: 16,
        texels: Vec::new(),
    });
    let e = render(&scene, &base);
    assert!(
        e.contains("alpha.images[0]") && e.contains("0 pixels"),
        "{e}"
    );

    for (bad, name) in [
        (
            RenderSettings {
                alpha_clip: f32::NAN,
                ..base.clone()
            },
            "alpha_clip",
        ),
        (
            RenderSettings {
                alpha_clip: 1.5,
                ..base.clone()
            },
            "alpha_clip",
        ),
        (
            RenderSettings {
                transparent_bounces: 5000,
                ..base.clone()
            },
            "transparent_bounces",
        ),
    ] {
        let e = render(&garden(), &bad);
        assert!(e.contains(name), "{e}");
    }
}

#[test]
fn two_levels_trace_alpha_per_instance_as_the_flat_tree_does() {
    // The garden places its leaf mesh twice under two materials (a tree of its own, read two
    // ways) and its boxes once (the static group).
    let scene = garden();
    let flat_settings = RenderSettings {
        structure: Pick::Fixed(SceneStructure::Flat),
        ..RenderSettings::baseline()
    };
    let flat = Renderer::new().render("t", &scene, &flat_settings).unwrap();
    let mut two_level = None;
    for width in ["2", "4", "8"] {
        for order in ["fbto", "stored", "sato", "sorted", "srdh:min_occluded=0"] {
            for rays in [RayMode::Single, RayMode::Packet] {
                let s = RenderSettings {
                    structure: Pick::Fixed(SceneStructure::TwoLevel),
                    width: width.parse().unwrap(),
                    shadow_order: order.parse().unwrap(),
                    rays: Pick::Fixed(rays),
                    ..flat_settings.clone()
                };
                let label = s.method_name();
                let mut renderer = Renderer::new();
                let r = renderer.render("t", &scene, &s).unwrap();
                assert_eq!(r.structure, SceneStructure::TwoLevel, "{label}");
                let stats = renderer.alpha_stats().expect("alpha traced");
                assert!(stats.primary > 0 && stats.shadow.iter().all(|(_, n)| *n > 0));
                // Every width, order and ray mode: the same answers, bit for bit.
                match &two_level {
                    None => two_level = Some(r),
                    Some(first) => {
                        assert!(r.primary_hits == first.primary_hits, "{label}: camera hits");
                        for (a, b) in r.masks.iter().zip(&first.masks) {
                            let same = (a.data.iter().zip(&b.data))
                                .all(|(x, y)| x.to_bits() == y.to_bits());
                            assert!(same, "{label}: light '{}'", a.name);
                        }
                    }
                }
            }
        }
    }
    let two_level = two_level.unwrap();
    // Against the flat tree: the same camera hits and masks but where f32 rounding differs
    // (object to render space there, render to mesh space here) at an edge or a texel.
    let pixels = flat.primary_hits.len();
    let hits_differ = (flat.primary_hits.iter().zip(&two_level.primary_hits))
        .filter(|(a, b)| a != b)
        .count();
    assert!(
        hits_differ * 100 <= pixels,
        "{hits_differ} of {pixels} camera hits differ"
    );
    let mut fractional = 0;
    for (a, b) in flat.masks.iter().zip(&two_level.masks) {
        let differ = (a.data.iter().zip(&b.data))
            .filter(|(x, y)| (*x - *y).abs() > 1e-5)
            .count();
        assert!(
            differ * 100 <= pixels,
            "light '{}': {differ} of {pixels} pixels differ",
            a.name
        );
        fractional += b.data.iter().filter(|&&v| v > 0.0 && v < 1.0).count();
    }
    assert!(
        fractional > 50,
        "{fractional} fractional pixels: alpha was traced"
    );
    // `auto` may now take two levels with alpha: its answer is one of the two.
    let auto = RenderSettings {
        structure: Pick::Auto,
        ..flat_settings.clone()
    };
    let r = Renderer::new().render("t", &scene, &auto).unwrap();
    let expect = match r.structure {
        SceneStructure::Flat => &flat,
        SceneStructure::TwoLevel => &two_level,
    };
    assert!(r.masks == expect.masks, "auto ({:?})", r.structure);
}
