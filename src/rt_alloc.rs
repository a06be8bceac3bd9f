//! The allocator of drumsim's binary, for its real-time threads: a thread that calls
//! [`RtPool::enter`] gets its own region of memory, carved into blocks of power-of-two size
//! classes (16 B to 256 KiB) kept on free lists of its own. Its allocations come from those
//! lists and its frees go back to them, so in steady state it never calls the system
//! allocator and never takes its locks. Every other thread, and any allocation too large or
//! too aligned for the classes, uses the system allocator.
//!
//! Why: rapier 0.36 allocates about eight times per 10 kHz physics step (buffers taken and
//! rebuilt in `PhysicsPipeline::step`, its solver's set-up, the modified-bodies list), which
//! on the system allocator means a malloc and a free (and possibly a lock) 80,000 times a
//! second. On the live body's thread these now come from its free lists.
//!
//! A block the owner frees goes on its list at once. A block another thread frees (an
//! object made on the real-time thread and dropped elsewhere) is pushed onto the region's
//! lock-free remote list, which the owner takes back whole when a class runs out. Each
//! region's use is counted: how many allocations and frees of the owning thread still reached
//! the system allocator ([`RtPool::system_calls`]), so tests and reports can show zero.

#![allow(unsafe_code)] // a global allocator; each block says why it holds

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::ptr::null_mut;
use std::sync::atomic::{AtomicPtr, AtomicU64, AtomicUsize, Ordering};

/// Size classes 16 B (2^4) .. 256 KiB (2^18).
const MIN_SHIFT: u32 = 4;
const MAX_SHIFT: u32 = 18;
const CLASSES: usize = (MAX_SHIFT - MIN_SHIFT + 1) as usize;
/// Blocks are aligned to their size, up to this.
const MAX_ALIGN: usize = 4096;
/// Regions that can exist at once (real-time threads entered over the process's life).
const REGIONS: usize = 16;

/// The global allocator (see the module's documentation).
pub struct RtPool;

/// One real-time thread's memory.
struct Region {
    start: AtomicUsize,
    end: AtomicUsize,
    /// Blocks freed by other threads: a lock-free stack (word 0: next, word 1: class).
    remote: AtomicPtr<u8>,
    /// Calls of the owning thread that reached the system allocator since it entered.
    system_calls: AtomicU64,
    /// Allocations the region served.
    served: AtomicU64,
}

#[allow(clippy::declare_interior_mutable_const)]
const EMPTY: Region = Region {
    start: AtomicUsize::new(0),
    end: AtomicUsize::new(0),
    remote: AtomicPtr::new(null_mut()),
    system_calls: AtomicU64::new(0),
    served: AtomicU64::new(0),
};
static REGIONS_IN_USE: [Region; REGIONS] = [EMPTY; REGIONS];
static NEXT_REGION: AtomicUsize = AtomicUsize::new(0);

/// The owning thread's view of its region.
struct Local {
    /// Index into `REGIONS_IN_USE`, +1 (0: this thread has not entered).
    region: Cell<usize>,
    bump: Cell<usize>,
    end: Cell<usize>,
    free: [Cell<*mut u8>; CLASSES],
}

thread_local! {
    static LOCAL: Local = const {
        Local {
            region: Cell::new(0),
            bump: Cell::new(0),
            end: Cell::new(0),
            free: [const { Cell::new(null_mut()) }; CLASSES],
        }
    };
}

/// The class of a layout, or None for the system allocator.
fn class_of(layout: Layout) -> Option<usize> {
    if layout.align() > MAX_ALIGN {
        return None;
    }
    let size = layout.size().max(layout.align()).max(1 << MIN_SHIFT).next_power_of_two();
    let shift = size.trailing_zeros();
    (shift <= MAX_SHIFT).then(|| (shift - MIN_SHIFT) as usize)
}

fn class_size(class: usize) -> usize {
    1 << (class as u32 + MIN_SHIFT)
}

/// The region a pointer lies in, if any.
fn region_of(p: usize) -> Option<&'static Region> {
    let n = NEXT_REGION.load(Ordering::Acquire).min(REGIONS);
    REGIONS_IN_USE[..n].iter().find(|r| p >= r.start.load(Ordering::Acquire) && p < r.end.load(Ordering::Acquire))
}

impl RtPool {
    /// Make the calling thread a real-time thread with a region of `bytes` (taken from the
    /// system allocator now, once). False if it already is one or no region is left.
    pub fn enter(bytes: usize) -> bool {
        LOCAL.with(|l| {
            if l.region.get() != 0 {
                return false;
            }
            let i = NEXT_REGION.load(Ordering::Acquire);
            if i >= REGIONS {
                return false;
            }
            let Ok(layout) = Layout::from_size_align(bytes.max(MAX_ALIGN), MAX_ALIGN) else { return false };
            // SAFETY: the layout has a non-zero size.
            let start = unsafe { System.alloc(layout) } as usize;
            if start == 0 {
                return false;
            }
            if NEXT_REGION.compare_exchange(i, i + 1, Ordering::AcqRel, Ordering::Acquire).is_err() {
                // SAFETY: allocated just above with this layout.
                unsafe { System.dealloc(start as *mut u8, layout) };
                return false;
            }
            let r = &REGIONS_IN_USE[i];
            r.end.store(start + layout.size(), Ordering::Release);
            r.start.store(start, Ordering::Release);
            l.region.set(i + 1);
            l.bump.set(start);
            l.end.set(start + layout.size());
            true
        })
    }

    /// Calls of the calling thread that reached the system allocator since it entered (0
    /// if it has not entered).
    pub fn system_calls() -> u64 {
        LOCAL.with(|l| match l.region.get() {
            0 => 0,
            i => REGIONS_IN_USE[i - 1].system_calls.load(Ordering::Relaxed),
        })
    }
}

impl RtPool {
    /// Allocations of the calling thread its region served since it entered.
    pub fn served() -> u64 {
        LOCAL.with(|l| l.region().map_or(0, |r| r.served.load(Ordering::Relaxed)))
    }
}

impl Local {
    fn region(&self) -> Option<&'static Region> {
        match self.region.get() {
            0 => None,
            i => Some(&REGIONS_IN_USE[i - 1]),
        }
    }

    /// A block of `class`: its free list, else the blocks other threads freed, else carved.
    fn take(&self, r: &Region, class: usize) -> *mut u8 {
        let head = self.free[class].get();
        if !head.is_null() {
            // SAFETY: a free block of this class holds the next free block in its first word.
            self.free[class].set(unsafe { *(head as *mut *mut u8) });
            return head;
        }
        let mut remote = r.remote.swap(null_mut(), Ordering::Acquire);
        while !remote.is_null() {
            // SAFETY: blocks on the remote stack hold (next, class) in their first two words.
            let (next, c) = unsafe { (*(remote as *mut *mut u8), *(remote as *mut usize).add(1)) };
            self.give(remote, c);
            remote = next;
        }
        let head = self.free[class].get();
        if !head.is_null() {
            // SAFETY: as above.
            self.free[class].set(unsafe { *(head as *mut *mut u8) });
            return head;
        }
        let size = class_size(class);
        let at = (self.bump.get() + size.min(MAX_ALIGN) - 1) & !(size.min(MAX_ALIGN) - 1);
        if at + size > self.end.get() {
            return null_mut();
        }
        self.bump.set(at + size);
        at as *mut u8
    }

    fn give(&self, p: *mut u8, class: usize) {
        // SAFETY: `p` is a block of at least 16 bytes of this region, no longer in use.
        unsafe { *(p as *mut *mut u8) = self.free[class].get() };
        self.free[class].set(p);
    }
}

// SAFETY: blocks handed out are never handed out twice while in use: each is on at most one
// free list, lists are per thread (thread-local cells), and other threads only push onto the
// owner's remote stack, which the owner takes whole. Blocks are aligned to
// min(class size, 4096) >= the layout's alignment. Everything else is the system allocator's.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for RtPool {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let local = LOCAL.try_with(|l| match (l.region(), class_of(layout)) {
            (Some(r), Some(class)) => {
                let p = l.take(r, class);
                let counter = if p.is_null() { &r.system_calls } else { &r.served };
                counter.fetch_add(1, Ordering::Relaxed);
                p
            }
            (Some(r), None) => {
                r.system_calls.fetch_add(1, Ordering::Relaxed);
                null_mut()
            }
            _ => null_mut(),
        });
        match local {
            Ok(p) if !p.is_null() => p,
            // SAFETY: the caller's layout, as GlobalAlloc requires.
            _ => unsafe { System.alloc(layout) },
        }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        let Some(region) = region_of(ptr as usize) else {
            let _ = LOCAL.try_with(|l| {
                if let Some(r) = l.region() {
                    r.system_calls.fetch_add(1, Ordering::Relaxed);
                }
            });
            // SAFETY: not a pool block, so the system allocator's, with this layout.
            return unsafe { System.dealloc(ptr, layout) };
        };
        let class = class_of(layout).expect("a pool block has a class");
        let mine = LOCAL.try_with(|l| l.region().is_some_and(|r| std::ptr::eq(r, region))).unwrap_or(false);
        if mine {
            let _ = LOCAL.try_with(|l| l.give(ptr, class));
            return;
        }
        // Another thread's block: onto its owner's remote stack.
        // SAFETY: the block is at least 16 bytes and no longer in use.
        unsafe { *(ptr as *mut usize).add(1) = class };
        let mut head = region.remote.load(Ordering::Relaxed);
        loop {
            // SAFETY: as above.
            unsafe { *(ptr as *mut *mut u8) = head };
            match region.remote.compare_exchange_weak(head, ptr, Ordering::Release, Ordering::Relaxed) {
                Ok(_) => return,
                Err(h) => head = h,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classes_cover_size_and_alignment() {
        let c = |s, a| class_of(Layout::from_size_align(s, a).unwrap());
        assert_eq!(c(1, 1), Some(0));
        assert_eq!(c(16, 8), Some(0));
        assert_eq!(c(17, 8), Some(1));
        assert_eq!(c(8, 64), Some(2), "64-byte alignment: a 64-byte block");
        assert_eq!(c(1 << 18, 8), Some(CLASSES - 1));
        assert_eq!(c((1 << 18) + 1, 8), None);
        assert_eq!(c(64, 8192), None);
    }
}
