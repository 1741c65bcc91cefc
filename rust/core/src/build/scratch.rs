//! Per-thread working memory of the builders: bins, partition buffers and node arrays, taken
//! by a node's work and put back after, so the recursion (and the thousands of small subtrees
//! the split builders hand to the SAH builder) allocates almost nothing.

use std::cell::Cell;
use std::thread::LocalKey;

use glam::Vec4;

use super::binning::{Binning, CountVisible};
use super::primref::PrimRef;
use super::settings::MAX_BINS;
use crate::bvh::BvhNode;

/// The SAH builder's working memory.
pub(crate) struct SahScratch {
    pub(crate) bins: Binning<u32>,
    /// Per bin boundary: the SAH work of the references right of it.
    pub(crate) right_cost: Vec<f32>,
}

thread_local! {
    /// A thread's spare [`SahScratch`]: a fresh one per subtree cost more than the binning of
    /// the split builders' small subtrees.
    static SAH_SCRATCH: Cell<Option<Box<SahScratch>>> = const { Cell::new(None) };
    /// A thread's spare bins of the split builder's object splits.
    static OBJECT_BINS: Cell<Option<Binning<CountVisible>>> = const { Cell::new(None) };
    /// A thread's spare partition buffer (see [`with_other_buffer`]).
    pub(super) static SPARE_REFS: Cell<Vec<PrimRef>> = const { Cell::new(Vec::new()) };
    /// A thread's spare uncompacted node and size arrays (see `sah::build_sah_nodes`).
    static SPARE_NODES: Cell<Option<(Vec<BvhNode>, Vec<u32>)>> = const { Cell::new(None) };
}

/// Runs `f` with this thread's value in `slot`, a new one if it is in use further up the
/// stack (rayon may run another subtree inside a join), and puts it back after.
fn with_spare<T: 'static, R>(
    slot: &'static LocalKey<Cell<Option<T>>>,
    new: impl FnOnce() -> T,
    f: impl FnOnce(&mut T) -> R,
) -> R {
    let mut value = slot.take().unwrap_or_else(new);
    let result = f(&mut value);
    slot.set(Some(value));
    result
}

/// Runs `f` with this thread's spare SAH scratch.
pub(crate) fn with_sah_scratch<R>(f: impl FnOnce(&mut SahScratch) -> R) -> R {
    with_spare(
        &SAH_SCRATCH,
        || {
            Box::new(SahScratch {
                bins: Binning::new(),
                right_cost: vec![0.0; MAX_BINS],
            })
        },
        |s| f(s),
    )
}

/// Runs `f` with this thread's spare object-split bins.
pub(crate) fn with_object_bins<R>(f: impl FnOnce(&mut Binning<CountVisible>) -> R) -> R {
    with_spare(&OBJECT_BINS, Binning::new, f)
}

/// The most references a thread's spare partition buffer holds (4 MiB): a thread keeps one
/// only this large, or the root of a large scene would leave one its size on every thread.
pub(super) const SPARE_REFS_MAX: usize = 1 << 17;

/// Runs `f` with a buffer of `n` references: this thread's spare one, or for more than
/// [`SPARE_REFS_MAX`] references (the root of a large scene) one of its own. (Not from zeroed
/// memory: the allocator maps fresh pages for that on every build, and their faults cost more
/// than filling reused ones.)
pub(crate) fn with_other_buffer<R>(n: usize, f: impl FnOnce(&mut [PrimRef]) -> R) -> R {
    const STALE: PrimRef = PrimRef {
        lo: Vec4::ZERO,
        hi: Vec4::ZERO,
    };
    if n > SPARE_REFS_MAX {
        return f(&mut vec![STALE; n]);
    }
    let mut spare = SPARE_REFS.take();
    if spare.len() < n {
        spare.resize(n, STALE);
    }
    let result = f(&mut spare[..n]);
    SPARE_REFS.set(spare);
    result
}

/// The most uncompacted nodes a thread keeps spare (4 MiB of nodes, 0.5 MiB of sizes): larger
/// subtrees allocate zeroed arrays of their own.
pub(crate) const SPARE_NODES_MAX: usize = 1 << 17;

/// This thread's spare uncompacted node and size arrays, if they are not in use further up
/// the stack; give them back with [`put_spare_nodes`].
pub(crate) fn take_spare_nodes() -> Option<(Vec<BvhNode>, Vec<u32>)> {
    SPARE_NODES.take()
}

pub(crate) fn put_spare_nodes(nodes: Vec<BvhNode>, sizes: Vec<u32>) {
    SPARE_NODES.set(Some((nodes, sizes)));
}
