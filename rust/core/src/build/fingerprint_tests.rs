//! Fingerprints of whole trees, recorded before the builders' inner loops were rewritten for
//! speed: the rewrites must build the same trees bit for bit (node boxes, child layout, leaf
//! ranges, the triangles of each leaf). The order of triangles inside a leaf is not part of a
//! tree's shape (the partitions' order is an implementation detail), so each leaf's ids are
//! hashed sorted.

use glam::Vec3;

use super::{build_with_visibility, BuildMethod, BuildSettings, SpatialAxes};

/// 150k triangles of mixed sizes and orientations: enough for the parallel binning (more than
/// 65536 references) and parallel subtrees, with long thin triangles that spatial splits cut.
fn scene() -> Vec<[Vec3; 3]> {
    (0..150_000u32)
        .map(|i| {
            let h = i.wrapping_mul(2654435761);
            let g = h.rotate_left(13).wrapping_mul(40503);
            let p = Vec3::new(
                (h % 1000) as f32 * 0.37,
                ((h >> 10) % 1000) as f32 * 0.21,
                ((h >> 20) % 1000) as f32 * 0.53,
            );
            let s = 0.2 + (g % 97) as f32 * if i % 11 == 0 { 2.5 } else { 0.05 };
            let u = Vec3::new(s, (g >> 8) as f32 % 3.0 - 1.0, ((g >> 16) % 5) as f32 * 0.1);
            let v = Vec3::new(((g >> 4) % 7) as f32 * 0.1, s * 0.3, s * 0.7);
            [p, p + u, p + v]
        })
        .collect()
}

/// FNV-1a over every node's bounds bits, first and count, then the triangle ids in leaf order.
/// Panics unless a split builder's tree holds split (duplicated) references, so the
/// fingerprints cover spatial binning and clipping.
fn fingerprint(method: BuildMethod, settings: &BuildSettings) -> u64 {
    let tris = scene();
    let visible: Vec<bool> = (0..tris.len())
        .map(|i| tris[i][0].x < 120.0 && i % 3 != 0)
        .collect();
    let bvh = build_with_visibility(method, &tris, Some(&visible), settings);
    if method != BuildMethod::Sah {
        assert!(
            bvh.triangle_ids.len() > tris.len(),
            "{method:?}: no spatial split"
        );
    }
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |x: u32| {
        for b in x.to_le_bytes() {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    };
    let mut leaf_ids = Vec::new();
    for n in bvh.nodes.iter() {
        let a = n.bounds();
        for v in [a.min, a.max] {
            for c in v.to_array() {
                eat(c.to_bits());
            }
        }
        eat(n.first);
        eat(n.count);
        if n.is_leaf() {
            let range = n.first as usize..(n.first + n.count) as usize;
            leaf_ids.clear();
            leaf_ids.extend_from_slice(&bvh.triangle_ids[range]);
            leaf_ids.sort_unstable();
            for &id in &leaf_ids {
                eat(id);
            }
        }
    }
    h
}

#[test]
fn trees_are_unchanged_by_the_build_speed_rewrites() {
    // Clipping in every node, as when the fingerprints were taken (`clip_min_refs` came later).
    let mut s = BuildSettings::default();
    s.spatial.clip_min_refs = 0;
    let mut all = s;
    all.spatial.axes = SpatialAxes::All;
    let got = [
        fingerprint(BuildMethod::Sah, &s),
        fingerprint(BuildMethod::Sbvh, &s),
        fingerprint(BuildMethod::Osah, &s),
        fingerprint(BuildMethod::Sbvh, &all),
    ];
    assert_eq!(
        got,
        [
            0xc6c2_0644_a3ef_9e0e,
            0x11aa_f3dd_3e20_6a1e,
            0xab76_6a07_df31_22b4,
            0x4402_00aa_4264_1884,
        ],
        "{got:#x?}"
    );
}

#[test]
fn cut_box_trees_are_unchanged_by_the_build_speed_rewrites() {
    // The former default (cut boxes below 65536 references, so both spatial binning paths),
    // recorded before the binning loops were rewritten; today's default (cut boxes in every
    // node) builds the very same trees here.
    for clip_min_refs in [65536, BuildSettings::default().spatial.clip_min_refs] {
        let mut s = BuildSettings::default();
        s.spatial.clip_min_refs = clip_min_refs;
        let got = [
            fingerprint(BuildMethod::Sbvh, &s),
            fingerprint(BuildMethod::Osah, &s),
        ];
        assert_eq!(
            got,
            [0xd553_c20f_b2ca_11e1, 0xa597_be91_d176_b153],
            "clip_min_refs {clip_min_refs}: {got:#x?}"
        );
    }
}

#[test]
fn cut_box_binning_keeps_the_sah_cost() {
    // The default bins spatial splits with cut reference boxes in every node; on this scene
    // (150k references) the trees' SAH cost must stay within 1% of clipping everywhere, for
    // SBVH and OSAH.
    let tris = scene();
    let visible: Vec<bool> = (0..tris.len())
        .map(|i| tris[i][0].x < 120.0 && i % 3 != 0)
        .collect();
    let default = BuildSettings::default();
    assert!(default.spatial.clip_min_refs > tris.len());
    let mut clip_all = default;
    clip_all.spatial.clip_min_refs = 0;
    for method in [BuildMethod::Sbvh, BuildMethod::Osah] {
        let cost = |s: &BuildSettings| {
            let bvh = build_with_visibility(method, &tris, Some(&visible), s);
            bvh.sah_cost(1.0, 1.0)
        };
        let (cut, clipped) = (cost(&default), cost(&clip_all));
        assert!(
            (cut / clipped - 1.0).abs() < 0.01,
            "{method:?}: SAH cost {cut} with cut boxes, {clipped} clipping everywhere"
        );
    }
}
