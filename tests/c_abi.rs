//! The C ABI as a C program sees it, inside `cargo test`: `cpp_tests/c_api/test_c_api.c` (every
//! function on its success path and on every error path) compiled against
//! `include/balloonseg.h` with the C compiler the `cc` crate finds, linked with the static
//! library this very build produced, and run. A Rust developer sees a C break here without the
//! shell scripts; `scripts/test_c_api.sh` runs the same program, and its C++ twin, under
//! AddressSanitizer, UBSan and valgrind.

#![cfg(target_os = "linux")]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The static library of this build: cargo compiles the library with all its crate types,
/// `libballoonseg.a` among them, beside this test's executable in `target/<profile>/deps`.
fn static_library() -> PathBuf {
    let exe = std::env::current_exe().expect("the test's own path");
    let library = exe.with_file_name("libballoonseg.a");
    assert!(
        library.exists(),
        "{} is missing: cargo builds it with the library's crate types",
        library.display()
    );
    library
}

#[test]
fn the_c_test_program_passes_against_this_build() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let source = root.join("cpp_tests/c_api/test_c_api.c");
    let out = tempfile::tempdir().expect("a temporary folder");
    let program = out.path().join("test_c_api");
    let compiler = cc::Build::new()
        .cargo_metadata(false)
        .target(env!("BALLOONSEG_TARGET"))
        .host(env!("BALLOONSEG_HOST"))
        .opt_level(1)
        .debug(true)
        .get_compiler();
    let built = compiler
        .to_command()
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror"])
        .arg("-I")
        .arg(root.join("include"))
        .arg(&source)
        .arg("-o")
        .arg(&program)
        .arg(static_library())
        // What a Rust static library needs from the system (rustc --print native-static-libs).
        .args(["-lpthread", "-ldl", "-lm", "-lgcc_s"])
        .output()
        .expect("the C compiler runs");
    assert!(
        built.status.success(),
        "compiling {} failed:\n{}",
        source.display(),
        String::from_utf8_lossy(&built.stderr)
    );
    let ran = Command::new(&program).output().expect("the C test runs");
    assert!(
        ran.status.success(),
        "{} failed ({}):\n{}\n{}",
        program.display(),
        ran.status,
        String::from_utf8_lossy(&ran.stdout),
        String::from_utf8_lossy(&ran.stderr)
    );
}
