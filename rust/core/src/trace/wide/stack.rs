//! The traversal stack of the wide BVH: a fixed inline array, no heap.
//!
//! Everything on the stack is a sibling of a node on the current root-to-leaf path, and a wide
//! node pushes at most N - 1 of its children, so a tree with D interior levels never holds more
//! than (N - 1) * D + 1 entries. A wide tree is collapsed from a binary tree, which it is never
//! deeper than, and every builder bounds the binary depth by `MAX_DEPTH`.

use std::mem::MaybeUninit;

use crate::bvh::MAX_DEPTH;

/// Entries of the stack: enough for an 8-wide tree of `MAX_DEPTH` interior levels (673
/// entries, 5-8 KB of the thread's stack, left uninitialised).
pub(crate) const CAPACITY: usize = 7 * MAX_DEPTH + 1;

/// Entries below `len` are initialised; the rest are not: zeroing the array would cost a
/// `memset` per ray.
///
/// No call may stay in the traversal loop, not even one that never runs: every vector register
/// is caller-saved, so the register allocator keeps the ray's constants on the memory stack
/// across the whole loop around such a call (it did around the old heap spill). An overflow,
/// which a tree from the builders cannot cause, ends in a panic: a call that does not return
/// costs nothing in the loop.
#[repr(C)]
pub(crate) struct Stack<T: Copy> {
    len: usize,
    items: [MaybeUninit<T>; CAPACITY],
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Stack {
            len: 0,
            items: [const { MaybeUninit::uninit() }; CAPACITY],
        }
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, v: T) {
        if self.len >= CAPACITY {
            overflow();
        }
        // SAFETY: `len < CAPACITY`, so the write stays inside the array.
        unsafe { self.items.get_unchecked_mut(self.len).write(v) };
        self.len += 1;
    }

    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries below the old `len` were written by `push` and lie inside the array.
        Some(unsafe { self.items.get_unchecked(self.len).assume_init_read() })
    }
}

#[cold]
#[inline(never)]
fn overflow() -> ! {
    panic!("wide BVH traversal stack overflow: the tree is deeper than MAX_DEPTH levels")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn last_in_first_out_up_to_capacity() {
        let mut s = Stack::<u32>::new();
        assert_eq!(s.pop(), None);
        for v in 0..CAPACITY as u32 {
            s.push(v);
        }
        for v in (0..CAPACITY as u32).rev() {
            assert_eq!(s.pop(), Some(v));
        }
        assert_eq!(s.pop(), None);
    }

    #[test]
    #[should_panic(expected = "stack overflow")]
    fn pushing_past_capacity_panics() {
        let mut s = Stack::<u32>::new();
        for v in 0..=CAPACITY as u32 {
            s.push(v);
        }
    }
}
