//! The backend's one mutex-poisoning policy, in one place: every lock in `gpu/` is taken
//! through [`lock`].

use std::sync::{Mutex, MutexGuard};

/// Lock `m`, taking the guard as it is when the lock is poisoned.
///
/// Why not panic on poisoning: a poisoned lock means another thread panicked while holding
/// it, and what these locks guard (the allocator, the queue, the one-shot command pool,
/// validation messages, the tile order) holds Vulkan objects that stay valid. A second
/// panic would hide the first, and in a `Drop` that runs while the first unwinds (a buffer
/// freeing its memory) it would abort the process.
pub(crate) fn lock<T: ?Sized>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}
