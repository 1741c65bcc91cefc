//! What a traversal does with a triangle hit: [`HitFilter`]. Today's traversals run with
//! [`Opaque`] (every hit stops an any-hit ray and counts for a closest hit; its `OPAQUE`
//! constant selects the unchanged code at compile time). The alpha filters evaluate
//! [`AlphaScene`] at hits on flagged triangles: [`Transmission`] gathers Cycles' transparent
//! shadows, [`AlphaClip`] lets camera rays pass transparent hits.

use super::Counters;
use crate::alpha::AlphaScene;

/// Where the alpha filters read a triangle's alpha: one scene whose ids are a flat tree's, or
/// (two levels) a scene per instance whose ids are its mesh tree's.
pub trait AlphaScenes: Sync {
    /// The alpha of the triangles of `instance` (the object a two-level query enters).
    fn for_instance(&self, instance: u32) -> &AlphaScene;
}

/// A flat tree's ids: one scene for every hit.
impl AlphaScenes for AlphaScene {
    #[inline(always)]
    fn for_instance(&self, _: u32) -> &AlphaScene {
        self
    }
}

/// A traversal's rule for triangle hits.
pub trait HitFilter {
    /// True for [`Opaque`]: the traversal takes today's path (no barycentrics, no call).
    const OPAQUE: bool;
    /// A two-level query is about to trace `instance`'s mesh tree: the triangle ids of the
    /// hits that follow are that tree's.
    #[inline(always)]
    fn enter_instance(&mut self, _instance: u32) {}
    /// Any hit: `triangle` (its id) was hit at `t` with barycentrics `b`; true stops the ray.
    fn stops<C: Counters>(&mut self, triangle: u32, t: f32, b: [f32; 3], stats: &mut C) -> bool;
    /// Closest hit: whether the hit counts (false: the ray goes on through it).
    fn accepts<C: Counters>(&mut self, triangle: u32, b: [f32; 3], stats: &mut C) -> bool;
}

/// Every triangle opaque: today's behaviour, compiled to today's code.
#[derive(Clone, Copy, Debug, Default)]
pub struct Opaque;

impl HitFilter for Opaque {
    const OPAQUE: bool = true;
    #[inline(always)]
    fn stops<C: Counters>(&mut self, _: u32, _: f32, _: [f32; 3], _: &mut C) -> bool {
        true
    }
    #[inline(always)]
    fn accepts<C: Counters>(&mut self, _: u32, _: [f32; 3], _: &mut C) -> bool {
        true
    }
}

/// Camera rays: a flagged triangle's hit counts only where its alpha is at least `clip`
/// (EEVEE's alpha clip; Cycles' camera rays pass stochastically instead, see `docs/alpha.md`).
#[derive(Clone, Copy)]
pub struct AlphaClip<'a, S: ?Sized = AlphaScene> {
    source: &'a S,
    /// The scene of the instance being traced (`source`'s only scene on a flat tree).
    alpha: &'a AlphaScene,
    pub clip: f32,
}

impl<'a, S: AlphaScenes + ?Sized> AlphaClip<'a, S> {
    pub fn new(source: &'a S, clip: f32) -> Self {
        AlphaClip {
            source,
            alpha: source.for_instance(0),
            clip,
        }
    }
}

impl<S: AlphaScenes + ?Sized> HitFilter for AlphaClip<'_, S> {
    const OPAQUE: bool = false;
    #[inline(always)]
    fn enter_instance(&mut self, instance: u32) {
        self.alpha = self.source.for_instance(instance);
    }
    #[inline(always)]
    fn stops<C: Counters>(&mut self, triangle: u32, _: f32, b: [f32; 3], stats: &mut C) -> bool {
        self.accepts(triangle, b, stats)
    }
    #[inline(always)]
    fn accepts<C: Counters>(&mut self, triangle: u32, b: [f32; 3], stats: &mut C) -> bool {
        if self.alpha.triangles().rank(triangle).is_none() {
            return true;
        }
        stats.alpha_lookups(1);
        self.alpha.alpha(triangle, b).is_none_or(|a| a >= self.clip)
    }
}

/// One distinct transparent hit of a shadow ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransparentHit {
    pub t: f32,
    /// The instance whose mesh tree `triangle` is in (0 on a flat tree).
    pub instance: u32,
    pub triangle: u32,
    /// 1 - alpha.
    pub transmission: f32,
}

/// Shadow rays through alpha (Cycles' transparent shadows): an unflagged triangle, or a flagged
/// one of alpha 1, stops the ray; every other hit is recorded once per triangle (a split tree
/// finds a triangle in each leaf that references it, as Embree may call Cycles' filter twice);
/// more than `max_hits` distinct transparent hits stop the ray (Cycles' filter sets
/// `opaque_hit` once `num_hits >= max_hits`). The answer, [`Transmission::value`], multiplies the
/// recorded hits in (t, instance, triangle) order, so every traversal order gives the same bits.
#[derive(Clone)]
pub struct Transmission<'a, S: ?Sized = AlphaScene> {
    source: &'a S,
    /// The scene of the instance being traced (`source`'s only scene on a flat tree).
    alpha: &'a AlphaScene,
    instance: u32,
    pub max_hits: u32,
    pub hits: Vec<TransparentHit>,
}

impl<'a, S: AlphaScenes + ?Sized> Transmission<'a, S> {
    pub fn new(source: &'a S, max_hits: u32) -> Self {
        Transmission {
            source,
            alpha: source.for_instance(0),
            instance: 0,
            max_hits,
            hits: Vec::new(),
        }
    }

    /// The transmission of a ray that was not stopped: the product of the recorded hits'
    /// transmissions in (t, instance, triangle) order (1 with none). Sorts `hits`.
    pub fn value(&mut self) -> f32 {
        self.hits.sort_unstable_by(|a, b| {
            (a.t.total_cmp(&b.t))
                .then(a.instance.cmp(&b.instance))
                .then(a.triangle.cmp(&b.triangle))
        });
        self.hits.iter().fold(1.0, |p, h| p * h.transmission)
    }
}

impl<S: AlphaScenes + ?Sized> HitFilter for Transmission<'_, S> {
    const OPAQUE: bool = false;
    #[inline(always)]
    fn enter_instance(&mut self, instance: u32) {
        self.alpha = self.source.for_instance(instance);
        self.instance = instance;
    }
    #[inline]
    fn stops<C: Counters>(&mut self, triangle: u32, t: f32, b: [f32; 3], stats: &mut C) -> bool {
        if self.alpha.triangles().rank(triangle).is_none() {
            return true;
        }
        // A triangle seen in another leaf of a split tree: same test, same values; once only.
        let instance = self.instance;
        if (self.hits.iter()).any(|h| h.triangle == triangle && h.instance == instance) {
            return false;
        }
        stats.alpha_lookups(1);
        let alpha = self.alpha.alpha(triangle, b).unwrap_or(1.0);
        let transmission = 1.0 - alpha;
        if transmission == 0.0 || self.hits.len() as u32 >= self.max_hits {
            return true;
        }
        self.hits.push(TransparentHit {
            t,
            instance,
            triangle,
            transmission,
        });
        false
    }
    #[inline(always)]
    fn accepts<C: Counters>(&mut self, triangle: u32, b: [f32; 3], stats: &mut C) -> bool {
        // Not used by the shadow queries; a hit counts unless fully transparent.
        if self.alpha.triangles().rank(triangle).is_none() {
            return true;
        }
        stats.alpha_lookups(1);
        self.alpha.alpha(triangle, b).is_none_or(|a| a > 0.0)
    }
}
