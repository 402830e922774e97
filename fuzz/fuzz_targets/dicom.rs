//! The DICOM series reader on arbitrary bytes as the one file of a folder: an image or an error,
//! never a panic, an abort or a hang. dicom-rs parses the file and decodes its pixels (every
//! transfer syntax the reader accepts: fuzz/seeds/dicom).

#![no_main]

use std::sync::Once;

use libfuzzer_sys::fuzz_target;

static HOOK: Once = Once::new();

fuzz_target!(|data: &[u8]| {
    // The reader catches the panics of dicom-rs's pixel decoders (their RLE decoder indexes past
    // a corrupt segment) and returns an error; libfuzzer-sys's hook would abort on them before
    // they were caught. A panic that escapes the reader still ends the run as a finding:
    // libfuzzer-sys aborts on any panic that reaches it.
    HOOK.call_once(|| std::panic::set_hook(Box::new(|info| eprintln!("{info}"))));
    let folder = std::env::temp_dir().join(format!("balloonseg-fuzz-dicom-{}", std::process::id()));
    if std::fs::create_dir_all(&folder).is_err()
        || std::fs::write(folder.join("slice.dcm"), data).is_err()
    {
        return;
    }
    if let Ok(image) = balloonseg::io::read_image_series(&folder, None) {
        let _ = image.view();
    }
});
