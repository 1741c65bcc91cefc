//! VSAH: a binned SAH tree over the visible triangles alone. A reference, not a renderer: it
//! answers only rays whose closest hit is visible, and shows how much a perfect knowledge of
//! visibility could save (the paper's upper bound for visibility-driven builds).

use std::time::Instant;

use glam::Vec3;

use super::sah::build_binned_sah;
use super::settings::BuildSettings;
use crate::bvh::Bvh;

/// A SAH tree over the triangles with `visible[i]`; triangle ids stay those of `triangles`.
pub(super) fn build_vsah(
    triangles: &[[Vec3; 3]],
    visible: &[bool],
    settings: &BuildSettings,
) -> Bvh {
    let start = Instant::now();
    let ids: Vec<u32> = (0..triangles.len() as u32)
        .filter(|&i| visible[i as usize])
        .collect();
    let subset: Vec<[Vec3; 3]> = ids.iter().map(|&i| triangles[i as usize]).collect();
    let mut bvh = build_binned_sah(&subset, settings);
    for id in &mut bvh.triangle_ids {
        *id = ids[*id as usize];
    }
    bvh.build_ms = start.elapsed().as_secs_f64() * 1e3;
    bvh
}
