//! The fuzzer's bytes as a file with a chosen extension, for the reader targets: the readers'
//! entry points take paths (detached headers name their data files).

use std::path::PathBuf;

/// `data` split into a format, chosen by its first byte among `extensions`, and the file's
/// contents, written to a file of this process in the temporary directory.
pub fn as_file(data: &[u8], extensions: &[&str]) -> Option<PathBuf> {
    let (&choice, contents) = data.split_first()?;
    let extension = extensions[choice as usize % extensions.len()];
    let path = std::env::temp_dir().join(format!(
        "balloonseg-fuzz-{}.{extension}",
        std::process::id()
    ));
    std::fs::write(&path, contents).ok()?;
    Some(path)
}
