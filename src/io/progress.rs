//! Progress of reading a volume, so that a progress bar covers the part of a run before the
//! segmentation: a full-size CT takes about a second to read and inflate, a DICOM series of a
//! thousand slices longer.
//!
//! Whatever the format, a volume's bytes pass through two places only, the whole-file read
//! ([`super::files::read`]) and decompression ([`super::compression`]), under a dozen layers of
//! format-specific parsing; a DICOM series is read slice by slice. Rather than a parameter
//! through every layer, the callback is installed for the duration of one read on the reading
//! thread (a scoped, thread-local sink, as `tracing` scopes its subscriber) and taken back
//! when the read ends, however it ends. Where no sink is installed, reporting costs a
//! thread-local lookup per megabyte.

use std::cell::RefCell;
use std::io::Read;

use crate::error::{Error, Result};

/// What a read is doing when it reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadStage {
    /// Bytes coming from the disk.
    Reading,
    /// zlib or gzip data being inflated.
    Decompressing,
    /// A DICOM series' slices being parsed and decoded.
    Decoding,
}

impl ReadStage {
    pub fn name(self) -> &'static str {
        match self {
            ReadStage::Reading => "reading",
            ReadStage::Decompressing => "decompressing",
            ReadStage::Decoding => "decoding DICOM",
        }
    }
}

/// Called with the fraction of the stage done (0–1, rising within a stage; each stage starts
/// again from 0) and the stage; returning `false` cancels the read.
pub type ReadProgress = Box<dyn FnMut(f64, ReadStage) -> bool>;

thread_local! {
    static SINK: RefCell<Option<ReadProgress>> = const { RefCell::new(None) };
}

/// Runs `read` with `progress` seeing its stages, on this thread.
pub(crate) fn reporting<T>(progress: ReadProgress, read: impl FnOnce() -> Result<T>) -> Result<T> {
    struct Restore(Option<ReadProgress>);
    impl Drop for Restore {
        fn drop(&mut self) {
            SINK.with(|sink| *sink.borrow_mut() = self.0.take());
        }
    }
    let _restore = Restore(SINK.with(|sink| sink.borrow_mut().replace(progress)));
    read()
}

/// Tells the installed callback, if any, that `stage` is `fraction` done; an error when it
/// cancels.
pub(crate) fn report(fraction: f64, stage: ReadStage) -> Result<()> {
    let go_on = SINK.with(|sink| match sink.try_borrow_mut() {
        Ok(mut sink) => match sink.as_mut() {
            Some(callback) => callback(fraction.clamp(0.0, 1.0), stage),
            None => true,
        },
        // A callback that reads a volume itself: its read is not reported.
        Err(_) => true,
    });
    if go_on {
        Ok(())
    } else {
        Err(Error::cancelled(format!(
            "cancelled by the progress callback while {}",
            stage.name()
        )))
    }
}

/// Bytes passing between two progress reports of a [`Reported`] reader.
const REPORT_EVERY: u64 = 1 << 20;

/// A reader that reports to the sink how far through its `total` bytes it has read, each time
/// another MiB has passed; a cancellation becomes an I/O error for whoever reads through it
/// (a decoder), and [`Reported::cancelled`] tells it apart from a real one.
pub(crate) struct Reported<R> {
    inner: R,
    done: u64,
    total: u64,
    next_report: u64,
    stage: ReadStage,
    cancelled: Option<Error>,
}

impl<R: Read> Reported<R> {
    pub(crate) fn new(inner: R, total: u64, stage: ReadStage) -> Self {
        Self {
            inner,
            done: 0,
            total: total.max(1),
            next_report: REPORT_EVERY,
            stage,
            cancelled: None,
        }
    }

    /// The cancellation that stopped the reading, if the sink cancelled.
    pub(crate) fn cancelled(&mut self) -> Option<Error> {
        self.cancelled.take()
    }
}

impl<R: Read> Read for Reported<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let read = self.inner.read(buf)?;
        self.done += read as u64;
        if self.done >= self.next_report {
            self.next_report = self.done + REPORT_EVERY;
            if let Err(cancelled) = report(self.done as f64 / self.total as f64, self.stage) {
                self.cancelled = Some(cancelled);
                return Err(std::io::Error::other("cancelled by the progress callback"));
            }
        }
        Ok(read)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::io::test_images::{assert_same_voxels, pattern_image, scratch_dir};
    use crate::io::{read_image_reporting, write_image};
    use crate::{Geometry, Image, ScalarType};
    use std::io::Read;
    use std::sync::{Arc, Mutex};

    /// Every report a recorder's callback saw, in order.
    pub(crate) type Seen = Arc<Mutex<Vec<(f64, ReadStage)>>>;

    /// A callback that records what it sees and never cancels.
    pub(crate) fn recorder() -> (ReadProgress, Seen) {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&seen);
        let progress: ReadProgress = Box::new(move |fraction, stage| {
            sink.lock().unwrap().push((fraction, stage));
            true
        });
        (progress, seen)
    }

    #[test]
    fn reports_reach_the_installed_callback_only_while_its_read_runs() {
        report(0.5, ReadStage::Reading).unwrap();
        let (progress, seen) = recorder();
        reporting(progress, || {
            report(0.25, ReadStage::Reading)?;
            report(1.5, ReadStage::Decompressing)
        })
        .unwrap();
        report(0.75, ReadStage::Reading).unwrap();
        assert_eq!(
            *seen.lock().unwrap(),
            [(0.25, ReadStage::Reading), (1.0, ReadStage::Decompressing)]
        );
    }

    #[test]
    fn a_callback_that_returns_false_cancels_and_is_taken_back_after_an_error() {
        let outcome = reporting(Box::new(|_, _| false), || {
            report(0.1, ReadStage::Decoding)?;
            Ok(())
        });
        let error = outcome.unwrap_err();
        assert_eq!(error.kind(), crate::ErrorKind::Cancelled);
        assert!(
            error.to_string().contains("while decoding DICOM"),
            "{error}"
        );
        report(0.2, ReadStage::Decoding).unwrap();
    }

    /// A 256×256×80 int16 volume of incompressible bits (10 MiB, over one read chunk) written
    /// as `.nii.gz`, as the `.nii` it inflates to, as `.mha` (zlib) and as `.nrrd` (gzip).
    fn large_volume_files() -> (tempfile::TempDir, Image) {
        let dir = scratch_dir();
        let image = pattern_image(ScalarType::I16, [256, 256, 80], Geometry::identity(), 3);
        let gz = dir.path().join("v.nii.gz");
        write_image(&gz, &image).unwrap();
        write_image(&dir.path().join("v.mha"), &image).unwrap();
        write_image(&dir.path().join("v.nrrd"), &image).unwrap();
        let mut raw = Vec::new();
        flate2::read::GzDecoder::new(std::fs::File::open(&gz).unwrap())
            .read_to_end(&mut raw)
            .unwrap();
        std::fs::write(dir.path().join("v.nii"), raw).unwrap();
        (dir, image)
    }

    #[test]
    fn reading_and_inflating_a_volume_report_rising_fractions_up_to_the_end() {
        let (dir, image) = large_volume_files();
        // Each streams the file: NIfTI reports the file's bytes read (through the inflater for
        // .nii.gz), MetaImage and NRRD the compressed bytes inflated.
        for (name, stages) in [
            ("v.nii", vec![ReadStage::Reading]),
            ("v.nii.gz", vec![ReadStage::Reading]),
            ("v.mha", vec![ReadStage::Decompressing]),
            ("v.nrrd", vec![ReadStage::Decompressing]),
        ] {
            let (progress, seen) = recorder();
            let read = read_image_reporting(&dir.path().join(name), None, progress).unwrap();
            assert_same_voxels(&read, &image);
            let seen = seen.lock().unwrap();
            for stage in stages {
                let fractions: Vec<f64> = seen
                    .iter()
                    .filter(|(_, s)| *s == stage)
                    .map(|(f, _)| *f)
                    .collect();
                assert!(fractions.len() >= 2, "{name} {stage:?}: {fractions:?}");
                assert!(fractions.windows(2).all(|w| w[0] < w[1]), "{fractions:?}");
                assert!(*fractions.last().unwrap() > 0.9, "{name}: {fractions:?}");
            }
        }
    }

    #[test]
    fn a_read_cancelled_midway_ends_with_cancelled_not_a_corrupt_file() {
        let (dir, _) = large_volume_files();
        for (name, stage) in [
            ("v.nii.gz", ReadStage::Reading),
            ("v.nii", ReadStage::Reading),
            ("v.mha", ReadStage::Decompressing),
            ("v.nrrd", ReadStage::Decompressing),
        ] {
            let halfway: ReadProgress = Box::new(move |f, s| s != stage || f < 0.5);
            let Err(error) = read_image_reporting(&dir.path().join(name), None, halfway) else {
                panic!("{name}: the read was not cancelled");
            };
            assert_eq!(error.kind(), crate::ErrorKind::Cancelled, "{name}: {error}");
            let expected = format!("while {}", stage.name());
            assert!(error.to_string().contains(&expected), "{name}: {error}");
        }
    }

    #[test]
    fn a_nested_read_reports_to_its_own_callback_and_restores_the_outer_one() {
        let (outer, outer_seen) = recorder();
        let (inner, inner_seen) = recorder();
        reporting(outer, || {
            reporting(inner, || report(0.5, ReadStage::Reading))?;
            report(0.9, ReadStage::Reading)
        })
        .unwrap();
        assert_eq!(*inner_seen.lock().unwrap(), [(0.5, ReadStage::Reading)]);
        assert_eq!(*outer_seen.lock().unwrap(), [(0.9, ReadStage::Reading)]);
    }
}
