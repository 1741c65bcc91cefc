use serde::{Deserialize, Serialize};
use std::ops::AddAssign;

/// Traversal work counters. Implemented by [`TraversalStats`] (counts) and [`NoStats`] (nothing;
/// every call compiles away). A pass keeps one per ray of a batch, sums a pixel's and reads the
/// sums as [`TraversalStats`] (all zero for [`NoStats`]).
pub trait Counters: Copy + Default + Send + AddAssign + Into<TraversalStats> {
    /// False for [`NoStats`]: lets a traversal skip work that only feeds the counters.
    const COUNTING: bool = true;
    /// Entering an interior node (N_B).
    fn inner(&mut self);
    /// Entering a leaf (N_L).
    fn leaf(&mut self);
    /// Ray/triangle tests (N_T).
    fn triangles(&mut self, n: u32);
    /// Ray/box tests (N_box).
    fn boxes(&mut self, n: u32);
    /// Alpha evaluations at hits on flagged triangles (see [`crate::alpha`]); counted by
    /// [`AlphaStats`] only, so today's counters and their columns are unchanged.
    #[inline(always)]
    fn alpha_lookups(&mut self, _n: u32) {}
    /// The alpha lookups counted so far (0 but for [`AlphaStats`]): what a pass sums before
    /// its counters become [`TraversalStats`].
    #[inline(always)]
    fn lookups(&self) -> u64 {
        0
    }
    /// One packet traced (see [`TraversalStats::packets`]): `steps` interior nodes the packet
    /// took together, `to_single` lane hand-offs to the single-ray traversal. Counted on
    /// the counters of the packet's first ray, so that a pass's sum counts each packet once.
    #[inline(always)]
    fn packet(&mut self, _steps: u32, _to_single: u32) {}
}

/// No counting.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStats;

impl AddAssign for NoStats {
    #[inline(always)]
    fn add_assign(&mut self, _: Self) {}
}

impl From<NoStats> for TraversalStats {
    #[inline(always)]
    fn from(_: NoStats) -> Self {
        TraversalStats::default()
    }
}

impl Counters for NoStats {
    const COUNTING: bool = false;
    #[inline(always)]
    fn inner(&mut self) {}
    #[inline(always)]
    fn leaf(&mut self) {}
    #[inline(always)]
    fn triangles(&mut self, _: u32) {}
    #[inline(always)]
    fn boxes(&mut self, _: u32) {}
}

/// Exact work counts of one or many rays.
///
/// - `inner` (N_B): interior nodes entered (a node is entered when its box test passed and it was
///   not culled by a closer hit when taken from the stack);
/// - `leaves` (N_L): leaves entered, same rule;
/// - `triangles` (N_T): ray/triangle tests;
/// - `boxes` (N_box): ray/box tests, including the root's.
///
/// Rays traced in packets count the above per ray (a ray counts a node, its boxes and a leaf
/// where it is active in its packet), and the packets apart, on each packet's first ray:
/// - `packets`: packets traced;
/// - `packet_steps`: interior nodes a packet took together (a node taken by the packet counts
///   one step, whatever its active lanes);
/// - `handoffs`: lanes a packet handed to the single-ray traversal at a subtree where few
///   lanes stayed active (a lane not occluded there stays in the packet's other subtrees and
///   may be handed off again).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TraversalStats {
    pub inner: u64,
    pub leaves: u64,
    pub triangles: u64,
    pub boxes: u64,
    #[serde(default)]
    pub packets: u64,
    #[serde(default)]
    pub packet_steps: u64,
    #[serde(default)]
    pub handoffs: u64,
}

impl Counters for TraversalStats {
    #[inline(always)]
    fn inner(&mut self) {
        self.inner += 1;
    }
    #[inline(always)]
    fn leaf(&mut self) {
        self.leaves += 1;
    }
    #[inline(always)]
    fn triangles(&mut self, n: u32) {
        self.triangles += n as u64;
    }
    #[inline(always)]
    fn boxes(&mut self, n: u32) {
        self.boxes += n as u64;
    }
    #[inline(always)]
    fn packet(&mut self, steps: u32, to_single: u32) {
        self.packets += 1;
        self.packet_steps += steps as u64;
        self.handoffs += to_single as u64;
    }
}

impl AddAssign for TraversalStats {
    fn add_assign(&mut self, o: Self) {
        self.inner += o.inner;
        self.leaves += o.leaves;
        self.triangles += o.triangles;
        self.boxes += o.boxes;
        self.packets += o.packets;
        self.packet_steps += o.packet_steps;
        self.handoffs += o.handoffs;
    }
}

/// [`TraversalStats`] and the alpha lookups of the alpha traversals (a type of its own rather
/// than a field of `TraversalStats`, whose struct literals elsewhere stay as they are; the
/// conversion into `TraversalStats` drops the lookups).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct AlphaStats {
    pub traversal: TraversalStats,
    pub alpha_lookups: u64,
}

impl Counters for AlphaStats {
    #[inline(always)]
    fn inner(&mut self) {
        self.traversal.inner();
    }
    #[inline(always)]
    fn leaf(&mut self) {
        self.traversal.leaf();
    }
    #[inline(always)]
    fn triangles(&mut self, n: u32) {
        self.traversal.triangles(n);
    }
    #[inline(always)]
    fn boxes(&mut self, n: u32) {
        self.traversal.boxes(n);
    }
    #[inline(always)]
    fn packet(&mut self, steps: u32, to_single: u32) {
        self.traversal.packet(steps, to_single);
    }
    #[inline(always)]
    fn alpha_lookups(&mut self, n: u32) {
        self.alpha_lookups += n as u64;
    }
    #[inline(always)]
    fn lookups(&self) -> u64 {
        self.alpha_lookups
    }
}

impl AddAssign for AlphaStats {
    fn add_assign(&mut self, o: Self) {
        self.traversal += o.traversal;
        self.alpha_lookups += o.alpha_lookups;
    }
}

impl From<AlphaStats> for TraversalStats {
    fn from(s: AlphaStats) -> Self {
        s.traversal
    }
}
