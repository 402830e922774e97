//! The DICOM series reader on arbitrary bytes as the one file of a folder: an image or an error,
//! never a panic, an abort or a hang. dicom-rs parses the file and decodes its pixels (every
//! transfer syntax the reader accepts: fuzz/seeds/dicom); its panics must not get through.

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
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
