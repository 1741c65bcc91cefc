//! How `auto` chooses: the candidate of least estimated cost (work measured on earlier frames,
//! priced by [`WEIGHTS`], plus its preparation amortised over this frame's rays), and when to
//! measure another candidate instead (exploration; see docs/auto.md).
//!
//! Exploration, bounded and seeded: a candidate never measured (for a light, or for the camera
//! tree) is measured on the next frame: a light's orders on a sample of its rays, one a frame,
//! those with per-light preparation only if they can win; a
//! measurement older than [`STALE_FRAMES`] frames is taken again on frames where a hash of the
//! seed, the frame and the light picks one in [`EXPLORE_ONE_IN`].

use super::cost::WEIGHTS;
use super::history::{BuildChoice, History, OrderChoice};
use crate::sampling::hash_combine;

/// Lights with fewer shadow rays than this in a frame get no per-light preparation.
pub const MIN_PREP_RAYS: u64 = 1024;
/// A measurement this many frames old is taken again (on an exploration frame).
pub const STALE_FRAMES: u64 = 24;
/// Stale candidates are measured again on one frame in this many (per light, seeded).
pub const EXPLORE_ONE_IN: u32 = 8;
/// An order with per-light preparation is tried only if that preparation is estimated below
/// this share of the light's best estimate: it must also save on tracing to win.
pub const WIN_SHARE: f64 = 0.5;
/// The share of a light's pixels whose rays measure an order without per-light preparation.
pub const SAMPLE_SHARE: f32 = 0.03;

/// What `auto` chose and the estimate behind it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Choice<T> {
    pub choice: T,
    /// Estimated cost of the choice this frame, ns (0 when it was never measured).
    pub estimate_ns: f64,
    /// Taken to measure it, not because it was estimated cheapest.
    pub explore: bool,
}

impl<T> Choice<T> {
    /// The statistics column's text: the choice's name, `explore:` first when exploring.
    pub fn label(&self, name: impl Fn(&T) -> &'static str) -> String {
        let n = name(&self.choice);
        if self.explore {
            format!("explore:{n}")
        } else {
            n.to_string()
        }
    }
}

/// Where in the run a choice is made: the seed and the renderer's frame count.
#[derive(Clone, Copy, Debug)]
pub struct Moment {
    pub seed: u32,
    pub frame: u64,
}

impl Moment {
    /// Whether stale candidates of `key` (a light's index; `u32::MAX` for the camera tree) are
    /// measured again this frame.
    fn explores(&self, key: u32) -> bool {
        let h = hash_combine(hash_combine(self.seed, self.frame as u32), key);
        h.is_multiple_of(EXPLORE_ONE_IN)
    }
}

/// One light in one frame, as the order choice sees it.
#[derive(Clone, Copy, Debug)]
pub struct LightContext<'a> {
    pub name: &'a str,
    pub index: u32,
    /// This frame's shadow rays of the light (pixels with a surface times its samples).
    pub rays: u64,
    /// A wide tree (width 4 or 8): SATO and sorted are candidates.
    pub wide: bool,
    pub wide_nodes: u64,
    /// Primitives an SRDH tree is built over: the shadow set's triangles, on two levels the
    /// shadow top level's instances.
    pub triangles: u64,
    /// Representative rays of the light's SRDH build.
    pub srdh_rays: u64,
    /// Logged representative rays of the light's sorting.
    pub log_rays: u64,
    /// The tree already has SATO, or the sorting tables.
    pub sato_ready: bool,
    pub tables_ready: bool,
}

/// The orders `auto` considers for a light: every order on a wide tree, front to back and SRDH
/// on the binary one; for a light with few rays only those with nothing to prepare this frame
/// (front to back, and SATO where the tree has it already): its whole pass may cost less than
/// any preparation, and a sample of its few rays may hold none to measure an order by.
pub fn order_candidates(c: &LightContext) -> Vec<OrderChoice> {
    OrderChoice::ALL
        .into_iter()
        .filter(|o| c.wide || matches!(o, OrderChoice::Fbto | OrderChoice::Srdh))
        .filter(|&o| c.rays >= MIN_PREP_RAYS || prep_ns(c, o, true) == 0.0)
        .collect()
}

/// Estimated preparation of `order` for the light this frame, ns; `built`: whether the
/// light's last SRDH attempt made a tree (else only its rays are traced).
pub fn prep_ns(c: &LightContext, order: OrderChoice, built: bool) -> f64 {
    let w = &WEIGHTS;
    let nodes = c.wide_nodes as f64;
    let once = |ready: bool, weight: f64| if ready { 0.0 } else { weight * nodes };
    match order {
        OrderChoice::Fbto => 0.0,
        OrderChoice::Sato => once(c.sato_ready, w.per_tree_node),
        OrderChoice::Sorted => {
            once(c.tables_ready, w.tables_node)
                + w.log_ray * c.log_rays as f64
                + w.sort_node * nodes
        }
        OrderChoice::Srdh => {
            w.srdh_ray * c.srdh_rays as f64
                + if built {
                    w.srdh_triangle * c.triangles as f64
                } else {
                    0.0
                }
        }
    }
}

/// The estimated cost of `order` for the light this frame, if it was ever measured.
pub fn order_estimate(h: &History, c: &LightContext, order: OrderChoice) -> Option<f64> {
    let m = h.order(c.name, order)?;
    Some(m.per_ray_ns * c.rays as f64 + prep_ns(c, order, m.built))
}

/// One light's orders this frame: the order that traces it, and an order without per-light
/// preparation to measure on a sample of its rays beside it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrderPlan {
    pub choice: Choice<OrderChoice>,
    pub sample: Option<OrderChoice>,
}

/// The orders of one light this frame. The least estimate traces the light (on the first frame
/// SATO where it is a candidate, else front to back). One order due a measurement (never
/// measured, or stale on an exploration frame) is prepared and measured on a [`SAMPLE_SHARE`]
/// of the rays beside it: one without per-light preparation first; one with it only if that preparation
/// costs less than [`WIN_SHARE`] of the best estimate, since otherwise it can hardly win.
pub fn choose_order(h: &History, c: &LightContext, at: Moment) -> OrderPlan {
    let candidates = order_candidates(c);
    let best = candidates
        .iter()
        .filter_map(|&o| order_estimate(h, c, o).map(|e| (o, e)))
        .fold(None::<(OrderChoice, f64)>, |acc, (o, e)| match acc {
            Some((_, b)) if b <= e => acc,
            _ => Some((o, e)),
        });
    let first = if candidates.contains(&OrderChoice::Sato) {
        OrderChoice::Sato
    } else {
        OrderChoice::Fbto
    };
    let (chosen, estimate_ns) = best.unwrap_or((first, 0.0));
    let due = |o: OrderChoice| match h.order(c.name, o) {
        None => true,
        Some(m) => at.frame.saturating_sub(m.frame) >= STALE_FRAMES && at.explores(c.index),
    };
    let others = || {
        candidates
            .iter()
            .copied()
            .filter(|&o| o != chosen && due(o))
    };
    let can_win = |o: OrderChoice| {
        let built = h.order(c.name, o).is_none_or(|m| m.built);
        best.is_some_and(|(_, e)| prep_ns(c, o, built) < WIN_SHARE * e)
    };
    // Without per-light preparation first; those with it once something is measured.
    let sample = others()
        .find(|o| !o.per_light())
        .or_else(|| others().find(|&o| can_win(o)));
    let choice = Choice {
        choice: chosen,
        estimate_ns,
        explore: false,
    };
    OrderPlan { choice, sample }
}

/// One frame's camera tree, as the build choice sees it.
#[derive(Clone, Copy, Debug)]
pub struct BuildContext {
    /// Primary rays this frame.
    pub rays: u64,
    /// Triangles the build reads (camera set, and shadow set where it is apart).
    pub triangles: u64,
    /// Last frame's tree exists and no geometry moved since.
    pub unchanged: bool,
    /// What last frame's tree is (SAH or OSAH), if there is one.
    pub current: Option<BuildChoice>,
    /// A visible set exists for an OSAH build.
    pub visible: bool,
    /// Widths 4 and 8 collapse each new tree.
    pub wide: bool,
}

/// Estimated cost of building the tree by `b`, ns.
pub fn build_ns(c: &BuildContext, b: BuildChoice) -> f64 {
    let w = &WEIGHTS;
    let t = c.triangles as f64;
    let collapse = if c.wide { w.collapse_triangle * t } else { 0.0 };
    match b {
        BuildChoice::Keep => 0.0,
        BuildChoice::Sah => w.sah_triangle * t + collapse,
        BuildChoice::Osah => w.osah_triangle * t + collapse,
    }
}

/// The builds `auto` considers: keeping last frame's tree when nothing moved (or SAH, if that
/// tree is not SAH), else SAH; OSAH wherever a visible set exists.
pub fn build_candidates(c: &BuildContext) -> Vec<BuildChoice> {
    let mut out = Vec::new();
    if c.unchanged {
        out.push(BuildChoice::Keep);
        if c.current != Some(BuildChoice::Sah) {
            out.push(BuildChoice::Sah);
        }
    } else {
        out.push(BuildChoice::Sah);
    }
    if c.visible {
        out.push(BuildChoice::Osah);
    }
    out
}

/// The camera tree of this frame.
pub fn choose_build(h: &History, c: &BuildContext, at: Moment) -> Choice<BuildChoice> {
    let candidates = build_candidates(c);
    let estimates: Vec<(BuildChoice, Option<f64>)> = candidates
        .iter()
        .map(|&b| {
            let e = h
                .build(b)
                .map(|m| m.per_ray_ns * c.rays as f64 + build_ns(c, b));
            (b, e)
        })
        .collect();
    // Keeping is measured by every frame: it is never explored.
    let measured = |b: BuildChoice| match b {
        BuildChoice::Keep => Some(at.frame),
        _ => h.build(b).map(|m| m.frame),
    };
    // Another build can win only by saving on the camera rays more than it costs over the best
    // choice's build: tried only if that extra build is below WIN_SHARE of the best's trace.
    let can_win = |b: BuildChoice, best: BuildChoice, best_ns: f64| {
        let trace_ns = best_ns - build_ns(c, best);
        build_ns(c, b) - build_ns(c, best) < WIN_SHARE * trace_ns
    };
    explore_or_exploit(&estimates, measured, can_win, at, u32::MAX, candidates[0])
}

/// The candidate of least estimate (the first on ties; `fallback` when none was measured yet),
/// unless another that `can_win` against it is due a measurement: the first never measured,
/// else on an exploration frame the one measured longest ago if that is at least
/// [`STALE_FRAMES`] old.
fn explore_or_exploit<T: Copy + PartialEq>(
    estimates: &[(T, Option<f64>)],
    measured_at: impl Fn(T) -> Option<u64>,
    can_win: impl Fn(T, T, f64) -> bool,
    at: Moment,
    key: u32,
    fallback: T,
) -> Choice<T> {
    let best = estimates
        .iter()
        .filter_map(|&(o, e)| e.map(|e| (o, e)))
        .fold(None::<(T, f64)>, |acc, (o, e)| match acc {
            Some((_, b)) if b <= e => acc,
            _ => Some((o, e)),
        });
    let exploit = match best {
        Some((o, e)) => Choice {
            choice: o,
            estimate_ns: e,
            explore: false,
        },
        // Nothing measured yet: the fallback is the first measurement.
        None => {
            return Choice {
                choice: fallback,
                estimate_ns: 0.0,
                explore: false,
            }
        }
    };
    let others = || {
        let can_win = &can_win;
        estimates.iter().filter(move |(o, _)| {
            *o != exploit.choice && can_win(*o, exploit.choice, exploit.estimate_ns)
        })
    };
    let explore = |&(o, e): &(T, Option<f64>)| Choice {
        choice: o,
        estimate_ns: e.unwrap_or(0.0),
        explore: true,
    };
    if let Some(unmeasured) = others().find(|(o, _)| measured_at(*o).is_none()) {
        return explore(unmeasured);
    }
    let stale = others()
        .filter_map(|c| measured_at(c.0).map(|f| (c, f)))
        .filter(|(_, f)| at.frame.saturating_sub(*f) >= STALE_FRAMES)
        .min_by_key(|(_, f)| *f);
    match stale {
        Some((c, _)) if at.explores(key) => explore(c),
        _ => exploit,
    }
}

#[cfg(test)]
mod tests {
    use super::super::history::Measured;
    use super::*;

    fn light(rays: u64) -> LightContext<'static> {
        LightContext {
            name: "L",
            index: 0,
            rays,
            wide: true,
            wide_nodes: 1000,
            triangles: 5000,
            srdh_rays: 256,
            log_rays: rays / 20,
            sato_ready: false,
            tables_ready: false,
        }
    }

    fn at(frame: u64) -> Moment {
        Moment { seed: 0, frame }
    }

    fn measured(per_ray_ns: f64, frame: u64) -> Measured {
        Measured {
            per_ray_ns,
            frame,
            built: true,
        }
    }

    #[test]
    fn every_candidate_is_measured_once_then_the_cheapest_wins() {
        let mut h = History::default();
        let c = light(1_000_000);
        let per_ray = |o| match o {
            OrderChoice::Sorted => 50.0,
            OrderChoice::Fbto => 300.0,
            _ => 100.0,
        };
        let (mut traced, mut sampled) = (Vec::new(), Vec::new());
        for frame in 0..3 {
            let plan = choose_order(&h, &c, at(frame));
            traced.push(plan.choice.choice);
            sampled.extend(plan.sample);
            for o in std::iter::once(plan.choice.choice).chain(plan.sample) {
                h.record_order("L", o, measured(per_ray(o), frame));
            }
        }
        use OrderChoice::*;
        assert_eq!(traced, vec![Sato, Sato, Sorted]);
        assert_eq!(sampled, vec![Fbto, Sorted, Srdh]);
        let plan = choose_order(&h, &c, at(3));
        assert_eq!((plan.choice.choice, plan.sample), (Sorted, None));
        assert!(plan.choice.estimate_ns > 50.0 * 1_000_000.0);
    }

    #[test]
    fn orders_that_cannot_win_are_never_tried() {
        let mut h = History::default();
        let c = light(10_000);
        h.record_order("L", OrderChoice::Fbto, measured(1.0, 0));
        h.record_order("L", OrderChoice::Sato, measured(1.0, 0));
        // Preparing SRDH or sorting costs more than tracing the light front to back.
        let plan = choose_order(&h, &c, at(1));
        assert_eq!(
            (plan.choice.choice, plan.choice.explore),
            (OrderChoice::Fbto, false)
        );
    }

    #[test]
    fn few_rays_get_nothing_prepared() {
        let c = light(MIN_PREP_RAYS - 1);
        assert_eq!(order_candidates(&c), vec![OrderChoice::Fbto]);
        // Nothing to measure beside it, and front to back from the first frame on.
        let plan = choose_order(&History::default(), &c, at(0));
        assert_eq!((plan.choice.choice, plan.sample), (OrderChoice::Fbto, None));
        let ready = LightContext {
            sato_ready: true,
            ..c
        };
        assert_eq!(
            order_candidates(&ready),
            vec![OrderChoice::Fbto, OrderChoice::Sato]
        );
        let binary = LightContext {
            wide: false,
            ..light(100_000)
        };
        assert_eq!(
            order_candidates(&binary),
            vec![OrderChoice::Fbto, OrderChoice::Srdh]
        );
    }

    #[test]
    fn preparation_is_amortised_over_the_rays() {
        let mut h = History::default();
        for o in OrderChoice::ALL {
            let per_ray = if o == OrderChoice::Srdh { 60.0 } else { 100.0 };
            h.record_order("L", o, measured(per_ray, 0));
        }
        // SRDH saves 40 ns a ray; its build pays only over enough rays.
        let traced = |rays| choose_order(&h, &light(rays), at(1)).choice.choice;
        assert_eq!(traced(10_000), OrderChoice::Fbto);
        assert_eq!(traced(10_000_000), OrderChoice::Srdh);
    }

    #[test]
    fn stale_measurements_are_retaken_on_seeded_frames_only() {
        let mut h = History::default();
        for o in OrderChoice::ALL {
            let per_ray = if o == OrderChoice::Fbto { 10.0 } else { 100.0 };
            h.record_order("L", o, measured(per_ray, 0));
        }
        let c = light(100_000);
        let explored: Vec<u64> = (1..200)
            .filter(|&f| choose_order(&h, &c, at(f)).sample.is_some())
            .collect();
        assert!(explored.iter().all(|&f| f >= STALE_FRAMES), "{explored:?}");
        let share = explored.len() as f64 / (200 - STALE_FRAMES) as f64;
        assert!(
            share > 0.0 && share < 2.5 / EXPLORE_ONE_IN as f64,
            "{share}"
        );
    }

    #[test]
    fn builds_keep_an_unchanged_tree_unless_osah_pays() {
        let mut h = History::default();
        let c = BuildContext {
            rays: 100_000,
            triangles: 10_000,
            unchanged: true,
            current: Some(BuildChoice::Sah),
            visible: true,
            wide: true,
        };
        assert_eq!(
            build_candidates(&c),
            vec![BuildChoice::Keep, BuildChoice::Osah]
        );
        h.record_build(BuildChoice::Sah, measured(100.0, 0));
        // OSAH never measured: explored on the next frame, if its build could pay back.
        let ch = choose_build(&h, &c, at(1));
        assert_eq!((ch.choice, ch.explore), (BuildChoice::Osah, true));
        let few_rays = BuildContext { rays: 1000, ..c };
        let ch = choose_build(&h, &few_rays, at(1));
        assert_eq!((ch.choice, ch.explore), (BuildChoice::Keep, false));
        // OSAH saves half or twice its build over this frame's rays.
        let build_per_ray = build_ns(&c, BuildChoice::Osah) / c.rays as f64;
        for (saving, expected) in [(0.5, BuildChoice::Keep), (2.0, BuildChoice::Osah)] {
            h.record_build(
                BuildChoice::Osah,
                measured(100.0 - saving * build_per_ray, 1),
            );
            h.record_build(BuildChoice::Keep, measured(100.0, 1));
            assert_eq!(choose_build(&h, &c, at(2)).choice, expected, "{saving}");
        }
    }
}
