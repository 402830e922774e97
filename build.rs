//! Gives the shared library its SONAME, libballoonseg.so.MAJOR, so that programs linked
//! against one major version refuse another (the ABI policy in docs/interfaces.md, "C API"), and
//! tells the tests the target and host triples, with which `tests/c_abi.rs` asks the `cc` crate
//! for the C compiler.

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    for (name, variable) in [("BALLOONSEG_TARGET", "TARGET"), ("BALLOONSEG_HOST", "HOST")] {
        let triple = std::env::var(variable).expect("cargo sets the triples");
        println!("cargo:rustc-env={name}={triple}");
    }
    let major = std::env::var("CARGO_PKG_VERSION_MAJOR").expect("cargo sets the version");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("linux") {
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libballoonseg.so.{major}");
    }
}
