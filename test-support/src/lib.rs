//! # centaur-test-support
//!
//! What Centaur's tests share across crates: [`CountingAllocator`], the global allocator of
//! the no-allocation tests ("hot paths allocate nothing after construction"). A test binary
//! installs it with
//!
//! ```ignore
//! #[global_allocator]
//! static GLOBAL: centaur_test_support::CountingAllocator = centaur_test_support::CountingAllocator;
//! ```
//!
//! and measures with [`allocations`]. Allocations are counted per thread, so work on other
//! threads (a test harness, a solver's worker thread) is not charged to the code measured.
#![allow(unsafe_code)] // a global allocator cannot be written without it

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The system allocator, counting every allocation and reallocation of each thread.
pub struct CountingAllocator;

thread_local! {
    /// Allocations this thread has made.
    static COUNT: Cell<usize> = const { Cell::new(0) };
}

fn count_one() {
    // `try_with`: the allocator runs during thread teardown too, after the slot is gone.
    let _ = COUNT.try_with(|c| c.set(c.get() + 1));
}

// SAFETY: every call is forwarded unchanged to `System`; only a thread-local counter is
// touched besides.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_one();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_one();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Allocations this thread has made so far (only meaningful with [`CountingAllocator`]
/// installed as the global allocator).
pub fn thread_allocations() -> usize {
    COUNT.try_with(Cell::get).unwrap_or(0)
}

/// Allocations this thread makes inside `f`; its result is passed through
/// `std::hint::black_box` so that the work is not optimised away.
pub fn allocations<R>(f: impl FnOnce() -> R) -> usize {
    let before = thread_allocations();
    std::hint::black_box(f());
    thread_allocations() - before
}
