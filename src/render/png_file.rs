//! PNG files of pictures: 8-bit RGB, encoded by the `png` crate. Deflate, filtering and CRCs are
//! a PNG encoder's job, not this library's.

use std::path::Path;

use super::raster::RgbImage;
use crate::error::{Error, Result};

/// Writes `image` to `path`, which must end in `.png`.
pub fn write_png(path: &Path, image: &RgbImage) -> Result<()> {
    if !path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        return Err(Error::invalid_argument(format!(
            "{}: pictures are written as PNG; give the file a .png extension",
            path.display()
        )));
    }
    if image.width() == 0 || image.height() == 0 {
        return Err(Error::invalid_argument(format!(
            "{}: the picture is empty ({} × {} pixels)",
            path.display(),
            image.width(),
            image.height()
        )));
    }
    crate::io::files::write(path, |out| {
        let mut encoder = png::Encoder::new(out, image.width(), image.height());
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
        writer
            .write_image_data(image.as_bytes())
            .map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use std::io::BufReader;

    use super::*;

    /// Decodes a PNG file into its size and RGB bytes.
    pub(crate) fn read_png(path: &Path) -> (u32, u32, Vec<u8>) {
        let file = std::fs::File::open(path).unwrap();
        let mut reader = png::Decoder::new(BufReader::new(file)).read_info().unwrap();
        let mut bytes = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut bytes).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        bytes.truncate(info.buffer_size());
        (info.width, info.height, bytes)
    }

    #[test]
    fn a_picture_survives_a_round_trip_through_a_png_file() {
        let mut image = RgbImage::new(7, 5, [10, 20, 30]);
        image.set(0, 0, [255, 0, 0]);
        image.set(6, 4, [0, 255, 0]);
        image.set(3, 2, [1, 2, 3]);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("picture.PNG");
        write_png(&path, &image).unwrap();
        let (width, height, bytes) = read_png(&path);
        assert_eq!((width, height), (7, 5));
        assert_eq!(bytes, image.as_bytes());
        assert_eq!(&bytes[3 * (2 * 7 + 3)..][..3], &[1, 2, 3]);
    }

    #[test]
    fn bad_names_and_empty_pictures_are_errors_naming_the_file() {
        let image = RgbImage::new(2, 2, [0; 3]);
        let e = write_png(Path::new("/tmp/picture.jpg"), &image).unwrap_err();
        assert!(
            e.message().contains("picture.jpg") && e.message().contains(".png"),
            "{e}"
        );
        let e = write_png(Path::new("/nonexistent/folder/a.png"), &image).unwrap_err();
        assert_eq!(e.kind(), crate::ErrorKind::Io);
        assert!(e.message().contains("/nonexistent/folder/a.png"), "{e}");
        let e = write_png(Path::new("/tmp/empty.png"), &RgbImage::new(0, 3, [0; 3])).unwrap_err();
        assert!(e.message().contains("empty"), "{e}");
    }
}
