//! The library's own worker threads: a rayon pool whose threads are joined when it is dropped.
//!
//! A dropped `rayon::ThreadPool` only tells its threads to stop and returns while they are
//! still exiting. The library runs inside host applications that make and free many
//! segmenters: a freed segmenter (`balloon_free`) should leave no thread of its own behind,
//! and a leak checker run at that moment (LeakSanitizer under the fuzzer did) should find a
//! thread's exit done, not half-way through its thread-local destructors. So the threads are
//! started by hand (rayon's `spawn_handler`) and their handles joined on drop.

use std::ops::Deref;
use std::thread::JoinHandle;

use crate::error::{Error, Result};

/// A rayon pool of a given size; use it as one (`install`). Dropping it returns once its
/// threads have exited. It must not be dropped from one of its own threads, which would wait
/// for itself.
pub(crate) struct ThreadPool {
    // Dropped first: the threads are told to stop before they are waited for.
    pool: rayon::ThreadPool,
    _threads: Joined,
}

impl ThreadPool {
    /// `threads` workers (0: one per core, as rayon counts them).
    pub(crate) fn new(threads: usize) -> Result<ThreadPool> {
        let mut handles = Vec::new();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .spawn_handler(|thread| {
                let mut builder = std::thread::Builder::new();
                if let Some(name) = thread.name() {
                    builder = builder.name(name.to_owned());
                }
                if let Some(size) = thread.stack_size() {
                    builder = builder.stack_size(size);
                }
                handles.push(builder.spawn(|| thread.run())?);
                Ok(())
            })
            .build();
        // Joined whether or not the pool was made: a pool that failed at its n-th thread has
        // started the others, which stop when its registry is dropped.
        let joined = Joined(handles);
        let pool = pool.map_err(|e| {
            Error::invalid_argument(format!(
                "cannot start {threads} worker threads (0: one per core): {e}"
            ))
        })?;
        Ok(ThreadPool {
            pool,
            _threads: joined,
        })
    }
}

impl Deref for ThreadPool {
    type Target = rayon::ThreadPool;

    fn deref(&self) -> &rayon::ThreadPool {
        &self.pool
    }
}

/// Handles of threads, joined on drop.
struct Joined(Vec<JoinHandle<()>>);

impl Drop for Joined {
    fn drop(&mut self) {
        for handle in self.0.drain(..) {
            // A worker that panicked has already reported it through rayon's handler.
            let _ = handle.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;

    #[test]
    fn dropping_the_pool_returns_after_its_threads_have_exited() {
        let exited = Arc::new(AtomicUsize::new(0));
        struct CountsExit(Arc<AtomicUsize>);
        impl Drop for CountsExit {
            fn drop(&mut self) {
                self.0.fetch_add(1, Ordering::SeqCst);
            }
        }
        thread_local! {
            static EXIT: std::cell::RefCell<Option<CountsExit>> = const { std::cell::RefCell::new(None) };
        }
        for round in 1..=20 {
            let pool = ThreadPool::new(3).unwrap();
            pool.broadcast(|_| EXIT.with(|e| *e.borrow_mut() = Some(CountsExit(exited.clone()))));
            assert_eq!(pool.current_num_threads(), 3);
            drop(pool);
            // Thread-local destructors run as a thread exits: all three have, every round.
            assert_eq!(exited.load(Ordering::SeqCst), 3 * round);
        }
    }
}
