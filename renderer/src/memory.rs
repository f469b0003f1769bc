//! Memory the process has freed, handed back to the system before the steps that make
//! its peaks: a big scene's BVH build and its leaf blocks ([`crate::geometry::bvh8`];
//! docs/performance.md, big meshes).

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
