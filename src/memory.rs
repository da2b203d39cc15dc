//! Host memory requests to the system: huge pages for the big arrays a load fills once, and
//! the freed pages handed back at a phase's end.

use std::mem::MaybeUninit;

/// Asks the system to back the not yet touched memory of `spare` with 2 MB pages where it can
/// (`MADV_HUGEPAGE` on Linux with glibc; elsewhere, and for arrays under a few pages, nothing happens).
///
/// Filling fresh memory costs a page fault per 4 KB page first: the 10M-triangle build
/// benchmark made about a million of them, 460K once the builder's big arrays asked for 2 MB
/// pages (a 512th as many faults for those arrays; docs/BENCHMARKS.md, fourteenth session).
pub fn advise_huge_pages<T>(spare: &mut [MaybeUninit<T>]) {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        const HUGE: usize = 2 << 20;
        let start = spare.as_mut_ptr() as usize;
        let end = start + std::mem::size_of_val(spare);
        // Only whole 2 MB pages inside the array: the pages around it may hold other data.
        let (first, last) = (start.next_multiple_of(HUGE), end / HUGE * HUGE);
        if first < last {
            // SAFETY: the range lies inside memory this array owns; the advice changes how
            // the kernel backs it, never its contents.
            unsafe {
                libc::madvise(first as *mut libc::c_void, last - first, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(all(target_os = "linux", target_env = "gnu")))]
    let _ = spare;
}

/// An empty vector with room for `capacity` items, its memory advised to huge pages. For
/// arrays filled once and never grown: growing moves an array, and moving huge pages to an
/// address that is not 2 MB aligned splits them all (0.2-0.3 s for 367 MB on the GPU host).
pub fn with_huge_pages<T>(capacity: usize) -> Vec<T> {
    let mut v = Vec::with_capacity(capacity);
    advise_huge_pages(v.spare_capacity_mut());
    v
}

/// Hands the memory that the last phase freed back to the system. A phase boundary is where
/// a load's temporaries (the parser's chunks, the builder's records) have just been freed,
/// but glibc keeps freed pages in its per-thread arenas, so they would add to the next
/// phase's peak: at 2M triangles, 55 bytes a triangle more before the upload.
pub fn return_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only releases free pages of the allocator's own heaps.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Drops `value` on a thread of its own. Unmapping a big array page by page takes time (the
/// 367 MB of a 10M-triangle model's BVH nodes about 30 ms on the GPU host) that nobody needs
/// to wait for once the data is on the GPU.
pub fn free_in_background<T: Send + 'static>(value: T) {
    // Should no thread start, the closure is dropped here, and the value with it.
    let _ = std::thread::Builder::new().name("free".into()).spawn(move || drop(value));
}
