//! The traversal stack of the wide BVH: a small inline array that covers every realistic tree,
//! spilling into a heap vector only for pathological depths (a wide node pushes up to N - 1
//! entries, and the collapse does not bound the depth of a degenerate binary tree).

use std::mem::MaybeUninit;

const INLINE: usize = 64;

/// Entries below `len` are initialised; the rest are not: zeroing the array was a `memset` per
/// ray, ~4% of the traversal's instructions in a callgrind profile. `repr(C)` with the array
/// last: with `len` next to it, LLVM merged the `len = 0` store and the uninitialised array
/// into one `memset`.
#[repr(C)]
pub(crate) struct Stack<T: Copy> {
    len: usize,
    spill: Vec<T>,
    inline: MaybeUninit<[T; INLINE]>,
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Stack {
            len: 0,
            spill: Vec::new(),
            inline: MaybeUninit::uninit(),
        }
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, v: T) {
        if self.len < INLINE {
            // SAFETY: `len < INLINE`, so the write stays inside the array.
            unsafe { self.inline.as_mut_ptr().cast::<T>().add(self.len).write(v) };
            self.len += 1;
        } else {
            self.push_spill(v);
        }
    }

    /// Out of line: a call in the traversal loop makes the register allocator keep the ray's
    /// vector constants on the stack (every vector register is caller-saved), even when the
    /// call never runs.
    #[cold]
    #[inline(never)]
    fn push_spill(&mut self, v: T) {
        self.spill.push(v);
    }

    #[inline(always)]
    pub(crate) fn pop(&mut self) -> Option<T> {
        if let Some(v) = self.spill.pop() {
            return Some(v);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries below the old `len` were written by `push` and lie inside the array.
        Some(unsafe { self.inline.as_ptr().cast::<T>().add(self.len).read() })
    }
}
