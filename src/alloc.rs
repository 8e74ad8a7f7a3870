//! The process's allocator: the system's, with every large block offered transparent huge pages
//! (Linux `madvise(MADV_HUGEPAGE)`; kernels set to THP `madvise`, the common default, give huge
//! pages only where asked). A per-pixel buffer of a 4K frame is 33 MB: with 4 KB pages every fresh
//! one costs ~8 000 page faults, taken one by one as the threads first touch it. On the mask of a
//! 3840×2160 frame they were about a quarter of the computation and most of what kept two threads
//! from doing twice the work of one (BENCHMARKS.md, "Mask").

use std::alloc::{GlobalAlloc, Layout, System};

/// The system allocator plus the huge-page advice.
pub struct HugePageAlloc;

/// A huge page (x86-64, aarch64 with 4 KB base pages).
const HUGE_PAGE: usize = 2 << 20;

/// Advise the whole huge pages inside `[ptr, ptr + size)`; blocks smaller than two huge pages
/// are left alone (they would hold at most one, and the system allocator packs small blocks
/// together).
#[cfg(target_os = "linux")]
fn advise(ptr: *mut u8, size: usize) {
    if ptr.is_null() || size < 2 * HUGE_PAGE {
        return;
    }
    let start = (ptr as usize).next_multiple_of(HUGE_PAGE);
    let end = (ptr as usize + size) / HUGE_PAGE * HUGE_PAGE;
    if end > start {
        // SAFETY: `madvise` only advises; [start, end) lies inside the block just handed out.
        // Its failure (a kernel without THP) changes nothing, so the result is ignored.
        unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise(_ptr: *mut u8, _size: usize) {}

// SAFETY: every call is forwarded to `System` unchanged; the advice does not touch the memory.
unsafe impl GlobalAlloc for HugePageAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller's contract is `System`'s.
        let ptr = unsafe { System.alloc(layout) };
        advise(ptr, layout.size());
        ptr
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as for `alloc`.
        let ptr = unsafe { System.alloc_zeroed(layout) };
        advise(ptr, layout.size());
        ptr
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as for `alloc`.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as for `alloc`.
        let new = unsafe { System.realloc(ptr, layout, new_size) };
        advise(new, new_size);
        new
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn large_blocks_work_as_ever() {
        // Big enough to be advised, grown by `realloc`, and zeroed where asked.
        let mut v = vec![0u32; 5 << 20];
        assert!(v.iter().all(|&x| x == 0));
        v.iter_mut().enumerate().for_each(|(i, x)| *x = i as u32);
        v.extend(0..(3u32 << 20));
        assert_eq!(v[(5 << 20) - 1], (5 << 20) - 1);
        assert_eq!(v[5 << 20], 0);
        assert_eq!(v.len(), 8 << 20);
    }
}
