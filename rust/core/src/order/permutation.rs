//! Per-node child permutations (SATO, RTSAH, random, per-light sorted), stored in 8 bytes per
//! node so that lights share one topology, and [`OrderView`]: the order a traversal reads,
//! chosen at run time among slot order, front to back and a permutation table.

use super::child_order::{ChildOrder, Children, OrderRay};

/// A node's child permutation: position `k` holds the slot visited k-th in bits `3k..3k+3`
/// (3 bits per child covers N = 8), and slot `s` its position (rank) in bits `32+3s..35+3s`,
/// so the traversal orders the children a ray hits without scanning all N positions. Bit 31
/// marks the permutation as present; a node without one uses the fallback order of its
/// [`OrderView`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Permutation(pub u64);

const PRESENT: u64 = 1 << 31;
const RANKS: u32 = 32;

impl Permutation {
    /// No permutation: the node uses the fallback order.
    pub const NONE: Permutation = Permutation(0);

    /// Packs slots in visiting order (at most 8).
    pub fn from_slots(slots: &[usize]) -> Self {
        debug_assert!(slots.len() <= 8);
        let bits = slots.iter().enumerate().fold(0u64, |acc, (k, &s)| {
            acc | ((s as u64) << (3 * k)) | ((k as u64) << (RANKS as usize + 3 * s))
        });
        Permutation(bits | PRESENT)
    }

    pub fn identity(n: usize) -> Self {
        Self::from_slots(&(0..n).collect::<Vec<_>>())
    }

    #[inline(always)]
    pub fn is_present(self) -> bool {
        self.0 & PRESENT != 0
    }

    /// The slot visited at position `k`.
    #[inline(always)]
    pub fn slot(self, k: usize) -> usize {
        ((self.0 >> (3 * k)) & 7) as usize
    }

    /// The position at which slot `s` is visited (meaningful for slots in the permutation).
    #[inline(always)]
    pub fn rank(self, s: usize) -> usize {
        ((self.0 >> (RANKS as usize + 3 * s)) & 7) as usize
    }

    pub fn slots(self, n: usize) -> Vec<usize> {
        (0..n).map(|k| self.slot(k)).collect()
    }
}

/// What the occlusion traversal uses at a node to order the children its ray hits.
#[derive(Clone, Copy, Debug)]
pub enum OrderView<'a> {
    /// Slot order, as the collapse stored the children.
    Stored,
    /// Front to back by box entry distance (ties by slot).
    FrontToBack,
    /// `perms[node]` where present, else front to back (`fallback_fbto`) or slot order.
    Permuted {
        perms: &'a [Permutation],
        fallback_fbto: bool,
    },
}

/// How one node orders the children a ray hits.
enum NodeOrder {
    Permuted(Permutation),
    Slots,
    FrontToBack,
}

impl OrderView<'_> {
    #[inline(always)]
    fn node_order(&self, node: usize) -> NodeOrder {
        match *self {
            OrderView::Stored => NodeOrder::Slots,
            OrderView::FrontToBack => NodeOrder::FrontToBack,
            OrderView::Permuted {
                perms,
                fallback_fbto,
            } => {
                let p = perms[node];
                if p.is_present() {
                    NodeOrder::Permuted(p)
                } else if fallback_fbto {
                    NodeOrder::FrontToBack
                } else {
                    NodeOrder::Slots
                }
            }
        }
    }
}

/// One instantiation of a traversal serves every permutation order and the two orders without
/// a table: the choice is one well-predicted branch per node.
impl ChildOrder for OrderView<'_> {
    #[inline(always)]
    fn second_first<K: Children>(
        &self,
        node: usize,
        a: usize,
        b: usize,
        _: &OrderRay,
        children: &K,
    ) -> bool {
        match self.node_order(node) {
            NodeOrder::Permuted(p) => p.rank(b) < p.rank(a),
            NodeOrder::Slots => false,
            // Ties by slot: insertion moves `b` ahead only when strictly nearer.
            NodeOrder::FrontToBack => children.t_near(a) > children.t_near(b),
        }
    }

    #[inline(always)]
    fn ordered_hits<const N: usize, K: Children>(
        &self,
        node: usize,
        mask: u32,
        _: &OrderRay,
        children: &K,
        out: &mut [u8; N],
    ) -> usize {
        let fbto = match self.node_order(node) {
            NodeOrder::Slots => false,
            NodeOrder::FrontToBack => true,
            NodeOrder::Permuted(p) => return by_rank(p, mask, out),
        };
        let mut n = 0;
        let mut m = mask;
        while m != 0 {
            let s = m.trailing_zeros() as usize;
            m &= m - 1;
            // Insertion by entry distance; equal distances keep slot order.
            let mut k = n;
            if fbto {
                while k > 0 && children.t_near(out[k - 1] as usize) > children.t_near(s) {
                    out[k] = out[k - 1];
                    k -= 1;
                }
            }
            out[k] = s as u8;
            n += 1;
        }
        n
    }
}

/// Places each hit slot at its rank, then reads the ranks in order: work in the number of
/// children hit, not in N.
#[inline(always)]
fn by_rank<const N: usize>(p: Permutation, mask: u32, out: &mut [u8; N]) -> usize {
    let mut by_rank = [0u8; 8];
    let mut ranks = 0u32;
    let mut m = mask;
    while m != 0 {
        let s = m.trailing_zeros() as usize;
        m &= m - 1;
        let r = p.rank(s);
        // Permutations list every used slot, and only used slots are hit.
        debug_assert!(ranks & (1 << r) == 0, "slot {s} not in the permutation");
        by_rank[r] = s as u8;
        ranks |= 1 << r;
    }
    let mut n = 0;
    while ranks != 0 {
        out[n] = by_rank[ranks.trailing_zeros() as usize];
        ranks &= ranks - 1;
        n += 1;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Entry distances by slot, for the tests.
    struct Near<'a>(&'a [f32; 8]);
    impl Children for Near<'_> {
        fn t_near(&self, slot: usize) -> f32 {
            self.0[slot]
        }
        fn centre(&self, _: usize) -> Vec3 {
            Vec3::ZERO
        }
    }
    const RAY: OrderRay = OrderRay {
        origin: Vec3::ZERO,
        key: 0,
    };

    /// A node with fewer children than N visits each hit child once, in the permutation's
    /// order (unused positions once decoded as slot 0 and queued it a second time).
    #[test]
    fn permuted_order_lists_each_hit_child_once() {
        let perms = [Permutation::from_slots(&[2, 0, 1])];
        let order = OrderView::Permuted {
            perms: &perms,
            fallback_fbto: false,
        };
        let mut out = [0u8; 8];
        let near = Near(&[0.0; 8]);
        let n = order.ordered_hits(0, 0b111, &RAY, &near, &mut out);
        assert_eq!(&out[..n], &[2, 0, 1]);
        let n = order.ordered_hits(0, 0b011, &RAY, &near, &mut out);
        assert_eq!(&out[..n], &[0, 1]);
    }

    /// The two-hit shortcut orders every pair of slots as the general loops do, in every
    /// order view (with and without a permutation, ties and strict distances), and the orders
    /// as types agree with their run-time views.
    #[test]
    fn two_hit_shortcut_equals_the_general_order() {
        use super::super::child_order::{FrontToBack, Stored};
        let perms = [
            Permutation::from_slots(&[5, 2, 7, 0, 3, 1, 6, 4]),
            Permutation::NONE,
        ];
        let t_near = [3.0, 1.0, 1.0, 7.0, 0.5, 3.0, 2.0, 0.5];
        let near = Near(&t_near);
        let views = [
            OrderView::Stored,
            OrderView::FrontToBack,
            OrderView::Permuted {
                perms: &perms,
                fallback_fbto: false,
            },
            OrderView::Permuted {
                perms: &perms,
                fallback_fbto: true,
            },
        ];
        for view in views {
            for node in 0..2 {
                for mask in 1u32..256 {
                    let mut out = [0u8; 8];
                    let n = view.ordered_hits(node, mask, &RAY, &near, &mut out);
                    let mut typed = [0u8; 8];
                    let m = match view {
                        OrderView::Stored => {
                            Stored.ordered_hits(node, mask, &RAY, &near, &mut typed)
                        }
                        OrderView::FrontToBack => {
                            FrontToBack.ordered_hits(node, mask, &RAY, &near, &mut typed)
                        }
                        _ => view.ordered_hits(node, mask, &RAY, &near, &mut typed),
                    };
                    assert_eq!((n, out), (m, typed), "{view:?} node {node} mask {mask:08b}");
                }
                for a in 0..8usize {
                    for b in a + 1..8 {
                        let mut out = [0u8; 8];
                        let n = view.ordered_hits(node, 1 << a | 1 << b, &RAY, &near, &mut out);
                        assert_eq!(n, 2);
                        let swapped = view.second_first(node, a, b, &RAY, &near);
                        let expect = if swapped { [b, a] } else { [a, b] };
                        assert_eq!(
                            out[..2],
                            expect.map(|s| s as u8),
                            "{view:?} node {node} slots {a} {b}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn ranks_invert_the_order() {
        let order = [5, 0, 7, 2, 1];
        let p = Permutation::from_slots(&order);
        assert!(p.is_present());
        for (k, &s) in order.iter().enumerate() {
            assert_eq!(p.slot(k), s);
            assert_eq!(p.rank(s), k);
        }
        assert!(!Permutation::NONE.is_present());
    }
}
