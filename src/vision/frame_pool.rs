//! Frame-sized f32 work buffers reused between calls on the same thread.
//!
//! Why: candidate finding needs three 4 MB work frames per 1024x1024 frame.
//! Fresh allocations of that size cost page faults (new pages) or a memset
//! (`calloc` of recycled heap memory), about 1 ms a frame together, a tenth
//! of the time budget; the closed loop analyses frames of one size over and
//! over on one thread. A buffer taken from the pool holds stale values: every
//! user writes all of it before reading.

use std::cell::RefCell;
use std::ops::{Deref, DerefMut};

/// Buffers kept per thread; more are freed on return.
const KEPT: usize = 6;

thread_local! {
    static POOL: RefCell<Vec<Vec<f32>>> = const { RefCell::new(Vec::new()) };
}

/// A work buffer of f32 with unspecified contents, returned to this thread's
/// pool when dropped.
#[derive(Debug)]
pub struct WorkBuffer(Vec<f32>);

/// A buffer of `len` values, reused from this thread's pool when one is there
/// (contents unspecified: overwrite before reading).
pub fn take(len: usize) -> WorkBuffer {
    let mut v = POOL.with(|p| p.borrow_mut().pop()).unwrap_or_default();
    v.resize(len, 0.0);
    WorkBuffer(v)
}

impl Drop for WorkBuffer {
    fn drop(&mut self) {
        let v = std::mem::take(&mut self.0);
        // `try_with`: during thread teardown the pool may already be gone.
        let _ = POOL.try_with(|p| {
            let mut p = p.borrow_mut();
            if p.len() < KEPT {
                p.push(v);
            }
        });
    }
}

impl Deref for WorkBuffer {
    type Target = [f32];
    fn deref(&self) -> &[f32] {
        &self.0
    }
}

impl DerefMut for WorkBuffer {
    fn deref_mut(&mut self) -> &mut [f32] {
        &mut self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buffers_are_reused_and_sized_on_take() {
        let ptr = {
            let mut a = take(1000);
            a[999] = 7.0;
            a.as_ptr()
        };
        let b = take(1000);
        assert_eq!(b.as_ptr(), ptr, "the returned buffer is handed out again");
        assert_eq!(b.len(), 1000);
        drop(b);
        assert_eq!(take(10).len(), 10);
        assert_eq!(take(5000).len(), 5000);
    }
}
