//! [`Scene`]: a tree over the caller's triangles in render space, and the two queries on it.

use std::sync::OnceLock;

use antumbra_core::build::{build_with_visibility, CollapseSettings};
use antumbra_core::bvh::{Bvh, BvhWidth};
use antumbra_core::geometry::Ray as RenderRay;
use antumbra_core::order::{AnyHitOrder, OrderView, ShadowOrder};
use antumbra_core::render::WideTree;
use antumbra_core::sampling::hash_u32;
use antumbra_core::scene::RenderSpace;
use antumbra_core::trace::wide::BoxKernel;
use antumbra_core::trace::{
    Counters, Hit as RenderHit, NoStats, OrderedBinary, OrderedWide, RayMode, TraversalStats,
};
use antumbra_core::{Error, Result};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::space::{fit, render_rays, Point};
use crate::{batch, BuildOptions, Hit, Ray, TraceOptions};

/// A BVH over the caller's triangles, ready for any-hit and closest-hit queries of the caller's
/// rays. Immutable once built; queries may run from many threads at once.
#[derive(Debug)]
pub struct Scene {
    space: RenderSpace,
    bvh: Bvh,
    width: BvhWidth,
    collapse: CollapseSettings,
    /// The collapse of `bvh` at `width`: made with the scene for widths 4 and 8, on the first
    /// query that needs it at width 2 (an order the binary traversal lacks).
    wide: OnceLock<WideTree>,
    /// The caller's index of each traced triangle (zero-area triangles are left out).
    caller_ids: Vec<u32>,
    triangles: usize,
}

impl Scene {
    /// Builds the tree over `triangles` (three indices into `vertices` each) with `options`.
    ///
    /// The vertices are checked (finite) and moved into render space; triangles of zero area
    /// (in the caller's space, or once rounded to f32) can never be hit and are left out.
    pub fn build<P: Point>(
        vertices: &[P],
        triangles: &[[u32; 3]],
        options: &BuildOptions,
    ) -> Result<Scene> {
        options.check(triangles.len())?;
        if triangles.len() >= u32::MAX as usize {
            return Err(Error::invalid(
                "triangles",
                format!(
                    "{} triangles; at most {} fit 32-bit ids",
                    triangles.len(),
                    u32::MAX - 1
                ),
            ));
        }
        for (t, tri) in triangles.iter().enumerate() {
            if let Some(&vertex) = tri.iter().find(|&&i| i as usize >= vertices.len()) {
                return Err(Error::IndexOutOfRange {
                    mesh: "triangles".into(),
                    triangle: t,
                    vertex,
                    vertex_count: vertices.len(),
                });
            }
        }
        let space = fit(vertices)?;
        in_pool(options.threads, || {
            let render: Vec<Vec3> = vertices
                .par_iter()
                .map(|p| space.point(p.to_dvec3()).as_vec3())
                .collect();
            let mut kept = Vec::with_capacity(triangles.len());
            let mut caller_ids = Vec::with_capacity(triangles.len());
            for (t, tri) in triangles.iter().enumerate() {
                let v = tri.map(|i| render[i as usize]);
                if zero_area(tri.map(|i| vertices[i as usize].to_dvec3()))
                    || (v[1] - v[0]).cross(v[2] - v[0]) == Vec3::ZERO
                {
                    continue;
                }
                kept.push(v);
                caller_ids.push(t as u32);
            }
            let visible: Option<Vec<bool>> = options
                .visible
                .as_ref()
                .map(|v| caller_ids.iter().map(|&t| v[t as usize]).collect());
            let bvh =
                build_with_visibility(options.method, &kept, visible.as_deref(), &options.settings);
            let scene = Scene {
                space,
                bvh,
                width: options.width,
                collapse: options.collapse,
                wide: OnceLock::new(),
                caller_ids,
                triangles: triangles.len(),
            };
            if scene.width != BvhWidth::Two {
                scene.wide_tree();
            }
            scene
        })
    }

    /// The map from the caller's space into render space (`point`, `vector`).
    pub fn space(&self) -> RenderSpace {
        self.space
    }

    pub fn width(&self) -> BvhWidth {
        self.width
    }

    /// Triangles handed to [`Scene::build`].
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// Triangles left out for their zero area.
    pub fn degenerate_count(&self) -> usize {
        self.triangles - self.caller_ids.len()
    }

    /// The binary tree (its triangle ids index the traced triangles, not the caller's).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// The closest hit of each ray (ties in t go to the smaller triangle id).
    pub fn intersect(&self, rays: &[Ray], options: &TraceOptions) -> Result<Vec<Option<Hit>>> {
        Ok(self.closest::<NoStats>(rays, options)?.0)
    }

    /// As [`Scene::intersect`], with each ray's traversal work.
    pub fn intersect_counted(
        &self,
        rays: &[Ray],
        options: &TraceOptions,
    ) -> Result<(Vec<Option<Hit>>, Vec<TraversalStats>)> {
        self.closest(rays, options)
    }

    /// Whether any triangle blocks each ray.
    pub fn occluded(&self, rays: &[Ray], options: &TraceOptions) -> Result<Vec<bool>> {
        Ok(self.any::<NoStats>(rays, options)?.0)
    }

    /// As [`Scene::occluded`], with each ray's traversal work.
    pub fn occluded_counted(
        &self,
        rays: &[Ray],
        options: &TraceOptions,
    ) -> Result<(Vec<bool>, Vec<TraversalStats>)> {
        self.any(rays, options)
    }

    fn closest<C: Counters + Default + Clone + Send>(
        &self,
        rays: &[Ray],
        options: &TraceOptions,
    ) -> Result<(Vec<Option<Hit>>, Vec<C>)> {
        options.check()?;
        in_pool(options.threads, || -> Result<_> {
            let rays = render_rays(&self.space, rays, options.interval)?;
            let (hits, stats) = self.closest_render::<C>(&rays, options.kernel);
            let hits = hits
                .into_iter()
                .map(|h| h.map(|h| self.caller_hit(h)))
                .collect();
            Ok((hits, stats))
        })?
    }

    /// Closest hits of render-space rays, with the render's triangle ids.
    pub(crate) fn closest_render<C: Counters>(
        &self,
        rays: &[RenderRay],
        kernel: BoxKernel,
    ) -> (Vec<Option<RenderHit>>, Vec<C>) {
        // A closest hit reads no any-hit order.
        let order = OrderView::FrontToBack;
        match self.wide.get() {
            _ if self.width == BvhWidth::Two => batch::closest_hits(&self.bvh, rays),
            Some(WideTree::Four(bvh)) => batch::closest_hits(
                &OrderedWide {
                    bvh,
                    order,
                    kernel,
                    rays: RayMode::Single,
                },
                rays,
            ),
            Some(WideTree::Eight(bvh)) => batch::closest_hits(
                &OrderedWide {
                    bvh,
                    order,
                    kernel,
                    rays: RayMode::Single,
                },
                rays,
            ),
            _ => unreachable!("4- and 8-wide scenes collapse when built"),
        }
    }

    fn any<C: Counters + Default + Clone + Send>(
        &self,
        rays: &[Ray],
        options: &TraceOptions,
    ) -> Result<(Vec<bool>, Vec<C>)> {
        options.check()?;
        in_pool(options.threads, || -> Result<_> {
            let rays = render_rays(&self.space, rays, options.interval)?;
            Ok(self.occluded_render(&rays, &options.order, options.kernel))
        })?
    }

    /// Occlusion of render-space rays, children in `order` (prepared here, the sorted order
    /// from a sample of `rays`): the binary traversal where the order is one it has at width 2,
    /// else the wide tree with the prepared order, as the renderer chooses.
    pub(crate) fn occluded_render<C: Counters>(
        &self,
        rays: &[RenderRay],
        order: &ShadowOrder,
        kernel: BoxKernel,
    ) -> (Vec<bool>, Vec<C>) {
        if let Some(order) = self.binary_order(order) {
            let query = OrderedBinary {
                bvh: &self.bvh,
                order,
            };
            return batch::occlusion(&query, rays);
        }
        let tree = self.wide_tree();
        let prepared = tree.prepare(order, None, &sample(rays, order));
        let order = prepared.view();
        match tree {
            WideTree::Two(bvh) => batch::occlusion(
                &OrderedWide {
                    bvh,
                    order,
                    kernel,
                    rays: RayMode::Single,
                },
                rays,
            ),
            WideTree::Four(bvh) => batch::occlusion(
                &OrderedWide {
                    bvh,
                    order,
                    kernel,
                    rays: RayMode::Single,
                },
                rays,
            ),
            WideTree::Eight(bvh) => batch::occlusion(
                &OrderedWide {
                    bvh,
                    order,
                    kernel,
                    rays: RayMode::Single,
                },
                rays,
            ),
        }
    }

    fn binary_order(&self, order: &ShadowOrder) -> Option<AnyHitOrder> {
        (self.width == BvhWidth::Two)
            .then(|| order.binary())
            .flatten()
    }

    fn wide_tree(&self) -> &WideTree {
        self.wide
            .get_or_init(|| WideTree::collapse(&self.bvh, self.width, &self.collapse))
    }

    fn caller_hit(&self, h: RenderHit) -> Hit {
        Hit {
            t: h.t,
            triangle: self.caller_ids[h.triangle as usize],
            u: h.b1,
            v: h.b2,
        }
    }
}

/// The rays a sorted order is prepared from: a pseudo-random `budget` share of the batch, by a
/// hash of each ray's index (as the renderer picks pixels), so the choice is the same every run.
fn sample(rays: &[RenderRay], order: &ShadowOrder) -> Vec<RenderRay> {
    let ShadowOrder::Sorted(s) = order else {
        return Vec::new();
    };
    let threshold = (s.budget.clamp(0.0, 1.0) as f64 * u32::MAX as f64) as u32;
    rays.iter()
        .enumerate()
        .filter(|(i, _)| s.budget >= 1.0 || hash_u32(*i as u32 ^ 0x9e37_79b9) < threshold)
        .map(|(_, r)| *r)
        .collect()
}

/// Zero area in the caller's f64 coordinates (as `FrameGeometry` decides it in object space).
fn zero_area(v: [DVec3; 3]) -> bool {
    (v[1] - v[0]).cross(v[2] - v[0]) == DVec3::ZERO
}

/// Runs `f` on rayon's global pool (`threads` 0) or on a pool of `threads` threads of its own.
fn in_pool<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> Result<R> {
    if threads == 0 {
        return Ok(f());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::invalid("threads", format!("no pool of {threads} threads: {e}")))?;
    Ok(pool.install(f))
}
