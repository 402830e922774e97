//! The boundary every exported function body runs in: it catches panics (turning them into
//! `BALLOON_PANIC`), turns failures into a status, and keeps the last failure's message per
//! thread for `balloon_last_error_message` (errno-like: kept until the next failure on the
//! same thread).

use std::cell::RefCell;
use std::ffi::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};

use super::status::BalloonStatus;
use crate::error::Error;

/// Why a C call failed: its status and the message for `balloon_last_error_message`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Failure {
    pub status: BalloonStatus,
    pub message: String,
}

impl Failure {
    pub fn new(status: BalloonStatus, message: impl Into<String>) -> Self {
        Failure {
            status,
            message: message.into(),
        }
    }

    /// A required pointer argument, named as in the header, was NULL.
    pub fn null(argument: &str) -> Self {
        Self::new(
            BalloonStatus::BALLOON_NULL_POINTER,
            format!("{argument} is NULL; pass a valid pointer"),
        )
    }
}

/// Fails with `BALLOON_NULL_POINTER`, naming `argument`, when `ptr` is NULL.
pub(crate) fn require<T>(ptr: *const T, argument: &str) -> Result<(), Failure> {
    if ptr.is_null() {
        Err(Failure::null(argument))
    } else {
        Ok(())
    }
}

impl From<Error> for Failure {
    fn from(e: Error) -> Self {
        Failure::new(BalloonStatus::from_kind(e.kind()), e.message())
    }
}

thread_local! {
    static LAST_ERROR: RefCell<String> = const { RefCell::new(String::new()) };
}

fn remember(status: BalloonStatus, message: String) {
    let message = if message.is_empty() {
        status.description().to_string_lossy().into_owned()
    } else {
        message
    };
    // Fails only while the thread is being torn down, when nobody can ask for the message.
    let _ = LAST_ERROR.try_with(|last| *last.borrow_mut() = message);
}

/// Runs `body`, catching a panic; the one `catch_unwind` of the C ABI.
fn catching<T>(body: impl FnOnce() -> T) -> Result<T, String> {
    catch_unwind(AssertUnwindSafe(body)).map_err(|payload| {
        let what = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".to_string());
        format!(
            "a Rust panic was caught at the C boundary: {what}. This is a bug in balloonseg; \
             please report it with the input. Only balloon_free is safe on the handle now"
        )
    })
}

/// Runs the body of a fallible C function: `BALLOON_OK`, or the failure's status with its
/// message remembered for this thread.
pub(crate) fn run(body: impl FnOnce() -> Result<(), Failure>) -> BalloonStatus {
    match catching(body) {
        Ok(Ok(())) => BalloonStatus::BALLOON_OK,
        Ok(Err(failure)) => {
            remember(failure.status, failure.message);
            failure.status
        }
        Err(message) => {
            remember(BalloonStatus::BALLOON_PANIC, message);
            BalloonStatus::BALLOON_PANIC
        }
    }
}

/// Runs the body of a C function that cannot report a status (`balloon_free`...): a panic
/// is remembered as the last error and `fallback` returned.
pub(crate) fn run_infallible<T>(fallback: T, body: impl FnOnce() -> T) -> T {
    catching(body).unwrap_or_else(|message| {
        remember(BalloonStatus::BALLOON_PANIC, message);
        fallback
    })
}

/// Copies the last error message of this thread into `buffer` the way `snprintf` does: at
/// most `buffer_size - 1` bytes and a NUL (nothing when `buffer` is NULL or `buffer_size` is
/// 0). Returns the full length of the message in bytes, without the NUL; 0 when no call on
/// this thread has failed yet.
///
/// # Safety
/// `buffer` must be NULL or point to `buffer_size` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn balloon_last_error_message(
    buffer: *mut c_char,
    buffer_size: usize,
) -> usize {
    run_infallible(0, || {
        LAST_ERROR
            .try_with(|last| {
                let last = last.borrow();
                let bytes = last.as_bytes();
                if !buffer.is_null() && buffer_size > 0 {
                    let n = bytes.len().min(buffer_size - 1);
                    // SAFETY: the caller gives `buffer_size` writable bytes; n < buffer_size.
                    unsafe {
                        std::ptr::copy_nonoverlapping(bytes.as_ptr(), buffer.cast::<u8>(), n);
                        *buffer.add(n) = 0;
                    }
                }
                bytes.len()
            })
            .unwrap_or(0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn last_message() -> String {
        let n = unsafe { balloon_last_error_message(std::ptr::null_mut(), 0) };
        let mut buffer = vec![0 as c_char; n + 1];
        assert_eq!(
            unsafe { balloon_last_error_message(buffer.as_mut_ptr(), buffer.len()) },
            n
        );
        let bytes: Vec<u8> = buffer[..n].iter().map(|&c| c as u8).collect();
        assert_eq!(buffer[n], 0);
        String::from_utf8(bytes).unwrap()
    }

    #[test]
    fn a_panic_becomes_balloon_panic_with_its_message() {
        let status = run(|| panic!("the tortoise fell over"));
        assert_eq!(status, BalloonStatus::BALLOON_PANIC);
        let message = last_message();
        assert!(message.contains("the tortoise fell over"), "{message}");
        assert!(message.contains("bug"), "{message}");
        assert_eq!(run_infallible(7, || panic!("{}", 3)), 7);
        assert!(last_message().contains(": 3."), "{}", last_message());
    }

    #[test]
    fn failures_keep_their_message_until_the_next_failure() {
        let status = run(|| Err(Error::invalid_mesh("mesh number 5 is broken").into()));
        assert_eq!(status, BalloonStatus::BALLOON_INVALID_MESH);
        assert_eq!(run(|| Ok(())), BalloonStatus::BALLOON_OK);
        assert_eq!(last_message(), "mesh number 5 is broken");
        run(|| Err(Failure::new(BalloonStatus::BALLOON_LEAK, "")));
        assert_eq!(
            last_message(),
            BalloonStatus::BALLOON_LEAK.description().to_str().unwrap()
        );
    }

    #[test]
    fn the_message_is_truncated_like_snprintf() {
        run(|| Err(Failure::null("out")));
        let full = "out is NULL; pass a valid pointer";
        let mut buffer = [0x55 as c_char; 8];
        let n = unsafe { balloon_last_error_message(buffer.as_mut_ptr(), 4) };
        assert_eq!(n, full.len());
        assert_eq!(
            buffer[..4].iter().map(|&c| c as u8).collect::<Vec<_>>(),
            b"out\0"
        );
        assert_eq!(buffer[4], 0x55, "nothing written past buffer_size");
        let n = unsafe { balloon_last_error_message(buffer.as_mut_ptr(), 1) };
        assert_eq!((n, buffer[0]), (full.len(), 0));
    }

    #[test]
    fn a_new_thread_has_no_message() {
        std::thread::spawn(|| {
            assert_eq!(
                unsafe { balloon_last_error_message(std::ptr::null_mut(), 0) },
                0
            );
        })
        .join()
        .unwrap();
    }
}
