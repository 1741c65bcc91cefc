//! Child visiting orders of the wide occlusion traversal, as the traversal reads them: front to
//! back by entry distance, or a fixed permutation per node (SATO, RTSAH, random, per-light
//! sorted), stored in 8 bytes per node so that lights share one topology.

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

#[cfg(test)]
mod tests {
    use super::*;

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
