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

/// `n` copies of `value` on huge pages, written on every core: `vec![value; n]` writes (and
/// faults in) its pages on one thread, 60 MB for a 10M-triangle file's positions, and the
/// page faults of threads that each allocate their own buffers queue on the process's
/// memory map instead.
pub fn filled<T: Copy + Send + Sync>(n: usize, value: T) -> Vec<T> {
    use rayon::prelude::*;
    let mut v = with_huge_pages(n);
    v.par_extend(rayon::iter::repeat_n(value, n));
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

/// Frees a big array now, its pages handed back on every core first. A plain drop unmaps
/// them on one thread (tens of milliseconds for a 400 MB file's text), and meanwhile every
/// allocation of the process waits for the memory map: freed on a thread of its own, the
/// text held up the next phase's allocations by 25 ms (docs/BENCHMARKS.md, twenty-seventh
/// session). Arrays under 16 MB are just dropped.
pub fn free_on_every_core<T: Copy + Send>(v: Vec<T>) {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        use rayon::prelude::*;
        const PART: usize = 4 << 20;
        let bytes = v.capacity() * std::mem::size_of::<T>();
        // SAFETY: sysconf only reads a constant of the system.
        let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) }.max(1) as usize;
        let start = v.as_ptr() as usize;
        // Only whole pages inside the array: the allocator keeps its records beside it.
        let (first, last) = (start.next_multiple_of(page), (start + bytes) / page * page);
        if bytes >= 16 << 20 && first < last {
            // Parts on PART boundaries, so that no 2 MB page is split between two calls.
            (first / PART..last.div_ceil(PART)).into_par_iter().for_each(|k| {
                let (from, to) = ((k * PART).max(first), ((k + 1) * PART).min(last));
                // SAFETY: the range lies inside memory this array owns, whose items need no
                // drop (`Copy`) and are never read again: it is freed just below.
                unsafe {
                    libc::madvise(from as *mut libc::c_void, to - from, libc::MADV_DONTNEED);
                }
            });
        }
    }
    drop(v);
}

/// Drops `value` on a thread of its own. Unmapping a big array page by page takes time (the
/// 367 MB of a 10M-triangle model's BVH nodes about 30 ms on the GPU host) that nobody needs
/// to wait for once the data is on the GPU.
pub fn free_in_background<T: Send + 'static>(value: T) {
    // Should no thread start, the closure is dropped here, and the value with it.
    let _ = std::thread::Builder::new().name("free".into()).spawn(move || drop(value));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_array_freed_on_every_core_leaves_its_neighbours_alone() {
        // Odd sizes, so the arrays' ends fall inside pages that the allocator shares.
        let pattern = |n: usize, seed: u8| -> Vec<u8> {
            (0..n).map(|i| (i as u8).wrapping_mul(31).wrapping_add(seed)).collect()
        };
        for round in 0..3u8 {
            let small_before = pattern(1000 + round as usize, 1);
            let big = pattern((20 << 20) + 123, 2);
            let small_after = pattern(777, 3);
            let other_big: Vec<u32> = (0..(5 << 20) + 7).collect();
            free_on_every_core(big);
            assert_eq!(small_before, pattern(1000 + round as usize, 1));
            assert_eq!(small_after, pattern(777, 3));
            assert!(other_big.iter().enumerate().all(|(i, &v)| v == i as u32));
            // The allocator hands the room out again, and it holds what is written.
            let again = pattern((20 << 20) + 123, 4);
            let expected = |i: usize| (i as u8).wrapping_mul(31).wrapping_add(4);
            assert!(again.iter().enumerate().step_by(4099).all(|(i, &b)| b == expected(i)));
            free_on_every_core(other_big);
        }
    }
}
