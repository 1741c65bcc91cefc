//! Giving freed memory back to the system when a session ends: allocators keep what a thread
//! freed (glibc arenas, mimalloc's delayed purge), so a daemon that is idle afterwards would
//! hold the buffers of its largest past requests for good.

/// Returns the C allocator's free memory to the system: glibc's `malloc_trim` over every arena
/// (elsewhere nothing). The default of [`crate::DaemonConfig::release_memory`]; a binary with
/// another global allocator sets its own.
pub fn trim_system_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only releases free memory; it is thread-safe in glibc.
    unsafe {
        libc::malloc_trim(0);
    }
}
