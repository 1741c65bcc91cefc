//! Traversal orders in one place: the run setting ([`ShadowOrder`]), the orders made from a tree
//! (SATO, RTSAH, random) or from a light's rays (sorted permutations, SRDH kernels), and the one
//! trait, [`ChildOrder`], that the any-hit traversals are generic over.

mod child_order;
mod child_sort;
pub mod cost;
mod kernel;
mod permutation;
mod prepared;
mod rtsah_kernels;
mod setting;
mod srdh_settings;
pub mod static_orders;

pub use child_order::{ray_key, ChildOrder, Children, FrontToBack, OrderRay, Stored};
pub use child_sort::{
    sort_for_light, sort_from_stoppers, ChildHitModel, LightOrder, LoggingOrder, SortSettings,
    SortTables,
};
pub use kernel::{centre, Kernel, KernelSet, PackedKernels, RandomKernel, Uniform};
pub use permutation::{OrderView, Permutation};
pub use prepared::PreparedOrder;
pub use rtsah_kernels::rtsah_kernels;
pub use setting::{AnyHitOrder, ShadowOrder};
pub use srdh_settings::{RaySetSource, SrdhSettings, DEFAULT_MIN_OCCLUDED};
