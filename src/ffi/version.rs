//! The library's version at compile time (macros in the header) and at run time.

use std::ffi::c_char;

use super::boundary::run_infallible;

/// Incompatible ABI changes; also the SONAME (libballoonseg.so.MAJOR).
pub const BALLOON_VERSION_MAJOR: u32 = 0;
/// Compatible additions.
pub const BALLOON_VERSION_MINOR: u32 = 3;
pub const BALLOON_VERSION_PATCH: u32 = 0;

/// The version of the library, "MAJOR.MINOR.PATCH" (static, never NULL).
#[no_mangle]
pub extern "C" fn balloon_version() -> *const c_char {
    const VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), "\0");
    run_infallible(VERSION.as_ptr().cast(), || VERSION.as_ptr().cast())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_macros_and_the_string_are_the_crate_version() {
        let parts = [
            BALLOON_VERSION_MAJOR,
            BALLOON_VERSION_MINOR,
            BALLOON_VERSION_PATCH,
        ];
        assert_eq!(
            parts.map(|p| p.to_string()),
            [
                env!("CARGO_PKG_VERSION_MAJOR"),
                env!("CARGO_PKG_VERSION_MINOR"),
                env!("CARGO_PKG_VERSION_PATCH")
            ]
        );
        let s = unsafe { std::ffi::CStr::from_ptr(balloon_version()) };
        assert_eq!(s.to_str().unwrap(), env!("CARGO_PKG_VERSION"));
    }
}
