//! Memory the process has freed, handed back to the system before and after the steps
//! that make its peaks (a big scene's BVH build and its leaf blocks,
//! [`crate::geometry::bvh8`]), and the allocator kept to one arena for a render
//! (docs/performance.md, big meshes).

/// Returns the free pages of the allocator to the system. glibc keeps what its worker
/// threads' arenas freed until asked: about 100 MB after reading a 4M-triangle OBJ on all
/// cores, and the BVH build's drafts. Elsewhere a no-op.
pub fn release_freed() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free pages of the allocator's arenas to the system.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Makes every thread allocate from one arena (glibc's `M_ARENA_MAX`). Each worker
/// thread's arena otherwise keeps 15-30 MB of a big scene's reading and building at the
/// render's peak, partly filled pages that [`release_freed`] cannot return (measured on a
/// 4M-triangle OBJ: peak RSS 408 -> 378 MB, wall unchanged on 2 cores; threads still
/// allocate small blocks from their own caches). Call before any thread is spawned.
/// Elsewhere a no-op.
pub fn use_one_arena() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets a limit that glibc reads when a thread first allocates.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, 1);
    }
}
