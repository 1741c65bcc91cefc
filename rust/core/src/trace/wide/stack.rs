//! The traversal stack of the wide BVH: a small inline array that covers every realistic tree,
//! spilling into a heap vector only for pathological depths (a wide node pushes up to N - 1
//! entries, and the collapse does not bound the depth of a degenerate binary tree).

const INLINE: usize = 64;

pub(crate) struct Stack<T: Copy + Default> {
    inline: [T; INLINE],
    len: usize,
    spill: Vec<T>,
}

impl<T: Copy + Default> Stack<T> {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Stack {
            inline: [T::default(); INLINE],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, v: T) {
        if self.len < INLINE {
            self.inline[self.len] = v;
            self.len += 1;
        } else {
            self.spill.push(v);
        }
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
        Some(self.inline[self.len])
    }
}
