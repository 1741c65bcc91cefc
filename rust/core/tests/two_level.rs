//! Two-level scenes (`antumbra_core::two_level`): the top level over instances and the mesh trees
//! below it answer exactly what the brute-force reference answers through the same ray
//! transforms, for mirrored, sheared and extreme instance transforms, on the binary tree and on
//! the wide trees; they agree with the flat tree of the same objects; closed meshes stay
//! watertight through instance transforms. A light's SRDH tree over the instances answers as
//! the reference does.

mod common;

use std::sync::Arc;

use antumbra_core::build::{BuildSettings, CollapseSettings};
use antumbra_core::bvh::BvhWidth;
use antumbra_core::geometry::{Aabb, Ray};
use antumbra_core::order::{OrderView, SrdhSettings};
use antumbra_core::render::WideTree;
use antumbra_core::scene::{FrameGeometry, Mesh, Object, RenderSpace, Scene};
use antumbra_core::trace::{brute_occluded, NoStats, RayQuery, TraversalStats};
use antumbra_core::two_level::{
    brute, instance_box, render_from_mesh, Instance, MeshTree, SrdhTop, SrdhTwoLevel, TopLevel,
    TwoLevel,
};
use glam::{DMat4, DVec3, Vec3};

struct Built {
    space: RenderSpace,
    meshes: Vec<MeshTree>,
    instances: Vec<Instance>,
    top: TopLevel,
}

/// The two levels of `scene`'s objects, in the flat frame's render space.
fn two_level(scene: &Scene) -> Built {
    let space = FrameGeometry::from_scene(scene).unwrap().space;
    let settings = BuildSettings::default();
    let meshes: Vec<MeshTree> = (scene.meshes.iter())
        .map(|m| MeshTree::build(m, &settings))
        .collect();
    let (instances, top) = common::place_instances(scene, &meshes);
    Built {
        space,
        meshes,
        instances,
        top,
    }
}

use common::render_space_rays as rays;

/// Every query agrees with the brute-force reference exactly on `rays`; returns the counters of
/// the wide query (to check that work is counted).
fn assert_exact(b: &Built, rays: &[Ray], label: &str) -> TraversalStats {
    let settings = CollapseSettings::default();
    let binary: Vec<_> = b.meshes.iter().map(|m| m.bvh.clone()).collect();
    let wide: Vec<Vec<WideTree>> = [BvhWidth::Four, BvhWidth::Eight]
        .iter()
        .map(|&w| {
            b.meshes
                .iter()
                .map(|m| WideTree::collapse(&m.bvh, w, &settings))
                .collect()
        })
        .collect();
    let binary_q = TwoLevel {
        top: &b.top,
        meshes: &binary,
    };
    let mut work = TraversalStats::default();
    let mut checked = 0;
    for (i, ray) in rays.iter().enumerate() {
        let closest = brute::brute_closest_hit(&b.instances, &b.meshes, ray);
        let occluded = brute::brute_occluded(&b.instances, &b.meshes, ray);
        assert_eq!(
            binary_q.closest_hit(ray, &mut NoStats),
            closest,
            "{label}: ray {i}, binary"
        );
        assert_eq!(
            binary_q.occluded(ray, &mut NoStats),
            occluded,
            "{label}: ray {i}"
        );
        for trees in &wide {
            let ordered: Vec<_> = trees
                .iter()
                .map(|t| t.ordered(OrderView::FrontToBack))
                .collect();
            let q = TwoLevel {
                top: &b.top,
                meshes: &ordered,
            };
            assert_eq!(
                q.closest_hit(ray, &mut work),
                closest,
                "{label}: ray {i}, wide"
            );
            assert_eq!(
                q.occluded(ray, &mut NoStats),
                occluded,
                "{label}: ray {i}, wide"
            );
        }
        checked += closest.is_some() as u32;
    }
    assert!(
        checked as usize > rays.len() / 4,
        "{label}: only {checked} of {} rays hit anything",
        rays.len()
    );
    work
}

#[test]
fn two_level_answers_equal_brute_force_through_mirrored_and_sheared_instances() {
    let scene = common::instanced_scene(300);
    let b = two_level(&scene);
    assert_eq!(b.instances.len(), 300);
    assert_eq!(b.meshes.len(), 3, "three meshes, one tree each");
    let work = assert_exact(&b, &rays(3000, 11), "instanced");
    assert!(work.inner > 0 && work.leaves > 0 && work.triangles > 0 && work.boxes > 0);
}

#[test]
fn hits_name_the_object_and_the_mesh_triangle() {
    let scene = common::instanced_scene(50);
    let b = two_level(&scene);
    let q = TwoLevel {
        top: &b.top,
        meshes: &b.meshes.iter().map(|m| m.bvh.clone()).collect::<Vec<_>>(),
    };
    let mut named = 0;
    for ray in rays(2000, 3) {
        let Some(h) = q.closest_hit(&ray, &mut NoStats) else {
            continue;
        };
        // The hit point lies on the named object's triangle, in render space.
        let object = &scene.objects[h.instance as usize];
        let mesh = &b.meshes[object.mesh];
        let m = render_from_mesh(&b.space, &object.world_from_object, &mesh.space);
        let v = mesh.triangles[h.triangle as usize].map(|p| m.transform_point3(p.as_dvec3()));
        let on_triangle = v[0] * h.b0 as f64 + v[1] * h.b1 as f64 + v[2] * h.b2 as f64;
        let along_ray = (ray.origin + ray.direction * h.t).as_dvec3();
        assert!(
            (on_triangle - along_ray).length() < 1e-4,
            "{on_triangle} against {along_ray}"
        );
        // And the primitive index names the same triangle in the scene's mesh.
        let primitive = mesh.primitives[h.triangle as usize] as usize;
        let source = scene.meshes[object.mesh].triangles[primitive];
        let expect = source.map(|i| {
            mesh.space
                .point(scene.meshes[object.mesh].positions[i as usize].as_dvec3())
                .as_vec3()
        });
        assert_eq!(expect, mesh.triangles[h.triangle as usize]);
        named += 1;
    }
    assert!(named > 200, "{named}");
}

#[test]
fn two_level_agrees_with_the_flat_tree_of_the_same_objects() {
    let scene = common::instanced_scene(200);
    let b = two_level(&scene);
    let flat = FrameGeometry::from_scene(&scene).unwrap();
    let q = TwoLevel {
        top: &b.top,
        meshes: &b.meshes.iter().map(|m| m.bvh.clone()).collect::<Vec<_>>(),
    };
    let rays = rays(4000, 17);
    let disagree = rays
        .iter()
        .filter(|r| q.occluded(r, &mut NoStats) != brute_occluded(&flat.camera.vertices, r))
        .count();
    // The f32 rounding differs (object to render space for the flat set, render to mesh space
    // for the ray); only rays through an edge or a vertex may differ.
    assert!(disagree <= 4, "{disagree} of {} rays disagree", rays.len());
}

#[test]
fn extreme_instance_transforms_stay_exact_and_keep_their_answers() {
    let scene = common::instanced_scene(120);
    let reference = two_level(&scene);
    let rays = rays(1500, 29);
    let q = |b: &Built, r: &Ray| {
        let trees: Vec<_> = b.meshes.iter().map(|m| m.bvh.clone()).collect();
        TwoLevel {
            top: &b.top,
            meshes: &trees,
        }
        .occluded(r, &mut NoStats)
    };
    let base: Vec<bool> = rays.iter().map(|r| q(&reference, r)).collect();
    for (label, m) in [
        (
            "translated by 1e6",
            DMat4::from_translation(DVec3::new(1e6, -1e6, 3e5)),
        ),
        (
            "scaled by 2^-14",
            DMat4::from_scale(DVec3::splat(2f64.powi(-14))),
        ),
        (
            "scaled by 2^13",
            DMat4::from_scale(DVec3::splat(2f64.powi(13))),
        ),
        ("scaled by 1e-4", DMat4::from_scale(DVec3::splat(1e-4))),
        ("scaled by 1e4", DMat4::from_scale(DVec3::splat(1e4))),
    ] {
        let moved = common::transform_scene(&scene, m);
        let b = two_level(&moved);
        assert_exact(&b, &rays[..300], label);
        if label.contains("1e-4") || label.contains("1e4") {
            // Render space takes a translation or a power-of-two scale away exactly (it
            // re-centres and scales by a power of two), so the same render-space rays see the
            // same scene; 1e-4 and 1e4 scale it by a factor that is not a power of two.
            continue;
        }
        let differ = rays
            .iter()
            .zip(&base)
            .filter(|(r, o)| q(&b, r) != **o)
            .count();
        assert!(differ <= 2, "{label}: {differ} rays changed answer");
    }
    // Objects placed at extreme scales inside one scene: a 1e-4 and a 1e4 instance.
    let mut mixed = scene.clone();
    mixed.objects[0].world_from_object = DMat4::from_scale(DVec3::splat(1e-4));
    mixed.objects[1].world_from_object = DMat4::from_scale(DVec3::splat(1e4));
    assert_exact(&two_level(&mixed), &rays[..300], "mixed scales");
}

#[test]
fn closed_sphere_is_watertight_through_a_sheared_mirrored_instance() {
    let sphere = common::sphere("sphere", 120, 240);
    let mut shear = DMat4::IDENTITY;
    shear.y_axis.x = 0.45;
    shear.z_axis.y = -0.3;
    let m = DMat4::from_translation(DVec3::new(1e6, 2.0, -3.0))
        * DMat4::from_scale(DVec3::new(-2.0, 0.7, 1.3))
        * shear;
    let mut scene = common::boxes_scene(32);
    scene.meshes = vec![Arc::new(sphere)];
    scene.objects = vec![Object::new("sphere", 0, m)];
    let b = two_level(&scene);
    let trees: Vec<_> = b
        .meshes
        .iter()
        .map(|t| WideTree::collapse(&t.bvh, BvhWidth::Eight, &CollapseSettings::default()))
        .collect();
    let ordered: Vec<_> = trees
        .iter()
        .map(|t| t.ordered(OrderView::FrontToBack))
        .collect();
    let q = TwoLevel {
        top: &b.top,
        meshes: &ordered,
    };
    let r = render_from_mesh(&b.space, &m, &b.meshes[0].space);
    let mut escaped = 0;
    for i in 0..20_000u32 {
        let inside = r.transform_point3(
            (common::rand3(i) - 0.5) * 0.4 + b.meshes[0].space.point(DVec3::ZERO),
        );
        let d = (common::rand3(i ^ 0x55) - 0.5).as_vec3();
        let ray = Ray::new(inside.as_vec3(), d, 0.0, f32::INFINITY);
        if q.closest_hit(&ray, &mut NoStats).is_none() || !q.occluded(&ray, &mut NoStats) {
            escaped += 1;
        }
    }
    assert_eq!(escaped, 0, "rays escaped the closed sphere");
}

#[test]
fn objects_scaled_to_nothing_are_left_out() {
    let mesh = Mesh::new("tri", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]);
    let space = RenderSpace::IDENTITY;
    let tree = MeshTree::build(&mesh, &BuildSettings::default());
    let flat = render_from_mesh(
        &space,
        &DMat4::from_scale(DVec3::new(1.0, 0.0, 1.0)),
        &tree.space,
    );
    assert_eq!(Instance::new(&flat, 0, 0), None);
    let fine = render_from_mesh(&space, &DMat4::IDENTITY, &tree.space);
    assert!(Instance::new(&fine, 0, 0).is_some());
    assert!(!instance_box(&fine, &tree.bounds).is_empty());
    assert_eq!(instance_box(&fine, &Aabb::EMPTY), Aabb::EMPTY);
}

#[test]
fn rays_at_an_instance_boxs_faces_still_enter_it() {
    // A flat square placed by rotated, stretched and moved instances; rays aimed at points of
    // its edges and corners (placed in f64, then rounded to f32): the top level culls no hit
    // the reference finds, and closest hits at edges equal the reference's bit for bit. (The
    // box test's own margin, 1/65536 of the ray's magnitude, is wider than the boxes' padding,
    // so these rays would pass without it: the next test pins the padding itself.)
    let square = Mesh::new(
        "square",
        vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    );
    let settings = BuildSettings::default();
    let meshes = vec![MeshTree::build(&square, &settings)];
    let space = RenderSpace::fit(DVec3::splat(-40.0), DVec3::splat(40.0));
    let (mut instances, mut boxes, mut maps) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..64u32 {
        let s = 7 + i * 31;
        let axis = (common::rand3(s) - 0.5).normalize_or(DVec3::Z);
        let rotation = glam::DQuat::from_axis_angle(axis, common::rand(s + 1) * 6.3);
        let scale = DVec3::new(0.1, 0.1, 0.1) + common::rand3(s + 2) * 4.0;
        let at = (common::rand3(s + 3) - 0.5) * 60.0;
        let world = DMat4::from_scale_rotation_translation(scale, rotation, at);
        let m = render_from_mesh(&space, &world, &meshes[0].space);
        let instance = Instance::new(&m, 0, i).unwrap();
        instances.push(instance);
        boxes.push(instance_box(&m, &meshes[0].bounds));
        maps.push(m);
    }
    let top = TopLevel::build(instances.clone(), boxes, &settings);
    let trees: Vec<_> = meshes.iter().map(|m| m.bvh.clone()).collect();
    let q = TwoLevel {
        top: &top,
        meshes: &trees,
    };
    let corners = meshes[0].triangles[0]
        .iter()
        .chain(&meshes[0].triangles[1])
        .map(|v| v.as_dvec3())
        .collect::<Vec<_>>();
    let (mut hits, mut culled) = (0, 0);
    for (k, m) in maps.iter().enumerate() {
        for e in 0..corners.len() {
            let (a, b) = (corners[e], corners[(e + 1) % corners.len()]);
            for j in 0..=16 {
                let target = m.transform_point3(a.lerp(b, j as f64 / 16.0)).as_vec3();
                let seed = (k * 1000 + e * 20 + j) as u32;
                let origin = target + ((common::rand3(seed) - 0.5) * 8.0).as_vec3();
                let ray = Ray::new(origin, target - origin, 0.0, 1.5);
                let want = brute::brute_occluded(&instances, &meshes, &ray);
                hits += want as u32;
                culled += (want && !q.occluded(&ray, &mut NoStats)) as u32;
                assert_eq!(
                    q.closest_hit(&ray, &mut NoStats),
                    brute::brute_closest_hit(&instances, &meshes, &ray),
                    "instance {k}, edge {e}, point {j}"
                );
            }
        }
    }
    assert_eq!(
        culled, 0,
        "{culled} of {hits} hits culled by an instance box"
    );
    assert!(hits > 2000, "{hits} rays hit an edge");
}

#[test]
fn instance_boxes_are_widened_past_their_corners() {
    // `instance_box` holds the mesh box's corners (placed in f64) with 2^-20 of the box's size
    // and magnitude to spare, rounded outward: at least half of that must show on every side.
    let bounds = Aabb::new(Vec3::new(-1.0, -0.5, -0.25), Vec3::new(1.0, 0.75, 0.5));
    let space = RenderSpace::fit(DVec3::splat(-40.0), DVec3::splat(40.0));
    for i in 0..200u32 {
        let s = 11 + i * 37;
        let axis = (common::rand3(s) - 0.5).normalize_or(DVec3::Z);
        let rotation = glam::DQuat::from_axis_angle(axis, common::rand(s + 1) * 6.3);
        let scale = DVec3::splat(1e-3) + common::rand3(s + 2) * 4.0;
        let at = (common::rand3(s + 3) - 0.5) * 60.0;
        let world = DMat4::from_scale_rotation_translation(scale, rotation, at);
        let m = render_from_mesh(&space, &world, &RenderSpace::IDENTITY);
        let (mut min, mut max) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for corner in 0..8 {
            let pick =
                |bit: usize, lo: f32, hi: f32| if corner & bit == 0 { lo } else { hi } as f64;
            let c = DVec3::new(
                pick(1, bounds.min.x, bounds.max.x),
                pick(2, bounds.min.y, bounds.max.y),
                pick(4, bounds.min.z, bounds.max.z),
            );
            let p = m.transform_point3(c);
            min = min.min(p);
            max = max.max(p);
        }
        let magnitude = min.abs().max(max.abs()).max_element();
        let spare = ((max - min).max_element() + magnitude) * 2f64.powi(-21);
        let b = instance_box(&m, &bounds);
        assert!(
            b.min.as_dvec3().cmple(min - spare).all() && b.max.as_dvec3().cmpge(max + spare).all(),
            "instance {i}: {b:?} against {min}..{max}, spare {spare}"
        );
    }
}

#[test]
fn an_srdh_tree_over_instances_answers_as_brute_force_and_lists_every_occluding_instance() {
    let scene = common::instanced_scene(300);
    let b = two_level(&scene);
    let binary: Vec<_> = b.meshes.iter().map(|m| m.bvh.clone()).collect();
    let levels = TwoLevel {
        top: &b.top,
        meshes: &binary,
    };
    // The hit lists: every instance of the top level whose triangles the ray hits.
    let built_from = rays(1500, 5);
    let set = levels.instance_ray_set(built_from.clone());
    let mut listed = 0;
    for (i, ray) in built_from.iter().enumerate() {
        let expect: Vec<u32> = (0..b.top.len() as u32)
            .filter(|&k| brute::brute_occluded(&b.top.instances[k as usize..][..1], &b.meshes, ray))
            .collect();
        assert_eq!(set.hits(i), &expect[..], "ray {i}");
        listed += expect.len();
    }
    assert!(
        set.occluded_count() > built_from.len() / 4 && listed > set.occluded_count(),
        "the rays must be occluded, some by several instances: {listed} listed, {} occluded",
        set.occluded_count()
    );
    // The tree over the instances' render-space boxes, in the top level's order.
    let boxes: Vec<Aabb> = (b.top.instances.iter())
        .map(|instance| {
            let object = &scene.objects[instance.object as usize];
            let mesh = &b.meshes[instance.mesh as usize];
            let m = render_from_mesh(&b.space, &object.world_from_object, &mesh.space);
            instance_box(&m, &mesh.bounds)
        })
        .collect();
    for leaf in [1, 3] {
        let settings = SrdhSettings {
            leaf,
            min_occluded: 0.0,
            ..SrdhSettings::default()
        };
        let srdh = SrdhTop::build(boxes.clone(), &set, &settings, &BuildSettings::default());
        let mut ids = srdh.tree.bvh.triangle_ids.clone();
        ids.sort_unstable();
        assert_eq!(
            ids,
            (0..b.top.len() as u32).collect::<Vec<_>>(),
            "leaf {leaf}"
        );
        assert!(srdh.tree.bvh.triangles.is_empty());
        let q = SrdhTwoLevel {
            levels: TwoLevel {
                top: &b.top,
                meshes: &binary,
            },
            srdh: &srdh,
        };
        let mut work = TraversalStats::default();
        // The rays it was built from and others, through binary mesh trees.
        for (i, ray) in built_from.iter().chain(&rays(1500, 23)).enumerate() {
            let occluded = brute::brute_occluded(&b.top.instances, &b.meshes, ray);
            assert_eq!(q.occluded(ray, &mut work), occluded, "leaf {leaf}: ray {i}");
            assert_eq!(
                q.closest_hit(ray, &mut NoStats),
                brute::brute_closest_hit(&b.top.instances, &b.meshes, ray),
                "leaf {leaf}: ray {i}"
            );
        }
        assert!(work.inner > 0 && work.leaves > 0 && work.triangles > 0);
    }
}
