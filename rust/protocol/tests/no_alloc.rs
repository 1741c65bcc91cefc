//! A length prefix above the limit is refused without allocating: a counting global allocator
//! records the largest single allocation while the readers look at a 4 GiB prefix (the largest a
//! 4-byte prefix can announce) and a 900 MiB prefix that the stream never backs.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use antumbra_protocol::*;

struct Counting;

static LARGEST: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::SeqCst);
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::SeqCst);
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

// One test function only: the allocator's maximum is process-wide.
#[test]
fn oversized_and_unbacked_prefixes_allocate_nothing_large() {
    let limits = Limits::default();
    let mut huge = u32::MAX.to_le_bytes().to_vec();
    huge.extend_from_slice(&[0; 64]);
    let mut unbacked = (900u32 << 20).to_le_bytes().to_vec();
    unbacked.extend_from_slice(&[0; 64]);

    LARGEST.store(0, Ordering::SeqCst);
    let e1 = read_message::<_, Request>(&mut &huge[..], &limits).unwrap_err();
    let mut d = FrameDecoder::new(&limits);
    d.push(&huge);
    let e2 = d.next_message::<Request>().unwrap_err();
    let e3 = read_message::<_, Request>(&mut &unbacked[..], &limits).unwrap_err();
    let mut d = FrameDecoder::new(&limits);
    d.push(&unbacked);
    assert!(d.next_message::<Request>().unwrap().is_none());
    let e4 = d.finish();
    let largest = LARGEST.load(Ordering::SeqCst);

    assert!(matches!(e1, FrameError::TooLarge { .. }), "{e1}");
    assert!(matches!(e2, FrameError::TooLarge { .. }), "{e2}");
    assert!(matches!(e3, FrameError::Truncated { .. }), "{e3}");
    assert!(matches!(e4, FrameError::Truncated { .. }), "{e4}");
    assert!(largest <= 256 * 1024, "largest allocation {largest} bytes");
}
