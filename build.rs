//! Gives the shared library its SONAME, libballoonseg.so.MAJOR, so that programs linked
//! against one major version refuse another (the ABI policy in README.md, "C API").

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let major = std::env::var("CARGO_PKG_VERSION_MAJOR").expect("cargo sets the version");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libballoonseg.so.{major}");
    }
}
