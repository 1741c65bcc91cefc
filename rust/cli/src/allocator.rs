//! The process's allocator: mimalloc, told to keep freed memory for a few seconds.
//!
//! Each frame's BVH build allocates and frees tens of megabytes that the next build needs again;
//! glibc's malloc hands large blocks back to the kernel, so every build faulted its pages in
//! anew. mimalloc's purge delay (default 1 s, shorter than the gaps between builds) is raised so
//! that the memory of one frame's build serves the next.

#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// mimalloc's `mi_option_purge_delay` (the bindings export no constant for it; the test below
/// checks the number against the option's documented default).
const PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// How long freed memory stays with the process before mimalloc returns it to the kernel.
const KEEP_FREED_MS: std::ffi::c_long = 10_000;

/// Keeps freed memory for [`KEEP_FREED_MS`]; called first thing in `main`.
pub fn keep_freed_memory() {
    // SAFETY: called at the start of `main`, before any thread is spawned (mimalloc's option
    // setters are not thread-safe); the option number is mimalloc's purge delay (tested).
    unsafe { libmimalloc_sys::mi_option_set(PURGE_DELAY, KEEP_FREED_MS) };
}

/// Returns freed memory to the kernel now, purging what the delay would keep: for the daemon,
/// whose sessions end and leave it idle (mimalloc purges only when it is next called).
pub fn release_freed_memory() {
    // SAFETY: mimalloc's collection is thread-safe; `force` also purges the delayed memory.
    unsafe { libmimalloc_sys::mi_collect(true) };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_purge_delay_option_is_mimallocs() {
        // Untouched in the test process, the option reads mimalloc's documented default for
        // the purge delay (1000 ms, v3); a different number would name another option.
        // SAFETY: reading an option.
        let value = unsafe { libmimalloc_sys::mi_option_get(PURGE_DELAY) };
        assert_eq!(value, 1000, "option {PURGE_DELAY} is not the purge delay");
    }

    #[test]
    fn the_global_allocator_serves_large_blocks() {
        let v = vec![7u8; 64 << 20];
        // SAFETY: mimalloc's own query on a pointer it allocated.
        assert!(unsafe { libmimalloc_sys::mi_is_in_heap_region(v.as_ptr().cast()) });
        assert_eq!(v[(64 << 20) - 1], 7);
    }
}
