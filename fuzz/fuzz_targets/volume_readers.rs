//! Every volume reader on arbitrary bytes: an image or an error, never a panic, an abort or a
//! hang (libFuzzer's -timeout and -malloc_limit_mb catch the last two).

#![no_main]

#[path = "as_file.rs"]
mod as_file;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let extensions = ["mha", "nrrd", "nii", "nii.gz", "vti", "vtk"];
    if let Some(path) = as_file::as_file(data, &extensions) {
        if let Ok(image) = balloonseg::io::read_image(&path) {
            // What a reader returns must be a volume the library accepts.
            let _ = image.view();
        }
    }
});
