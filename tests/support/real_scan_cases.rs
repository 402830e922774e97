//! The seeds of ../shared/data/README.md's newer scans and what each result must show there,
//! run by `examples/score_real_scans.rs`, which prints the numbers BENCHMARKS.md quotes and
//! what each result misses. Seeds are voxel indices, as in the README.

use std::path::Path;
use std::time::Instant;

use balloonseg::balloon::{BalloonParams, Segmenter};
use balloonseg::evaluation::Overlap;
use balloonseg::winding_number::inside_mask;
use balloonseg::{io, mesh_checks, Image, Result};
use glam::DVec3;

/// One seed of one scan and the README's expectation for it.
pub struct Case {
    pub name: &'static str,
    /// The scan's folder under the data folder; its image is `image.nii.gz`.
    pub scan: &'static str,
    pub seed: [usize; 3],
    /// The label (`label_<name>.nii.gz`) Dice is taken against, and the least Dice.
    pub dice_against: Option<(&'static str, f64)>,
    /// Genus bounds, inclusive.
    pub genus: (i64, i64),
    /// Volume bounds (cm³), inclusive.
    pub volume_cm3: (f64, f64),
}

pub const ANY_GENUS: (i64, i64) = (0, i64::MAX);
pub const ANY_VOLUME: (f64, f64) = (0.0, f64::INFINITY);

pub const CASES: &[Case] = &[
    Case {
        name: "ircad_aorta",
        scan: "ircad17_liver_cect",
        seed: [232, 267, 103],
        dice_against: Some(("artery", 0.85)),
        genus: (0, 2),
        volume_cm3: ANY_VOLUME,
    },
    Case {
        name: "ircad_portal_vein",
        scan: "ircad17_liver_cect",
        seed: [209, 198, 45],
        dice_against: Some(("portalvein", 0.70)),
        genus: (0, 8),
        volume_cm3: ANY_VOLUME,
    },
    Case {
        name: "ircad_ivc",
        scan: "ircad17_liver_cect",
        seed: [195, 196, 103],
        dice_against: Some(("venoussystem", 0.60)),
        genus: ANY_GENUS,
        volume_cm3: ANY_VOLUME,
    },
    Case {
        name: "ircad_liver",
        scan: "ircad17_liver_cect",
        seed: [75, 248, 42],
        dice_against: Some(("liver", 0.85)),
        genus: ANY_GENUS,
        volume_cm3: ANY_VOLUME,
    },
    Case {
        name: "slab_aorta",
        scan: "ts_abdomen_slab_ct",
        seed: [263, 299, 11],
        dice_against: Some(("aorta", 0.90)),
        genus: (0, 0),
        volume_cm3: ANY_VOLUME,
    },
    Case {
        name: "slab_liver",
        scan: "ts_abdomen_slab_ct",
        seed: [212, 219, 9],
        dice_against: Some(("liver", 0.85)),
        genus: ANY_GENUS,
        volume_cm3: ANY_VOLUME,
    },
    Case {
        name: "slab_portal_vein",
        scan: "ts_abdomen_slab_ct",
        seed: [201, 265, 8],
        dice_against: Some(("portal_splenic_vein", 0.60)),
        genus: ANY_GENUS,
        volume_cm3: ANY_VOLUME,
    },
    Case {
        name: "fistula_main_vein",
        scan: "avf_arm_mra",
        seed: [19, 16, 8],
        dice_against: Some(("reference_surface", 0.85)),
        genus: (0, 0),
        volume_cm3: ANY_VOLUME,
    },
    Case {
        name: "fistula_thin_arm",
        scan: "avf_arm_mra",
        seed: [59, 19, 8],
        dice_against: Some(("reference_surface", 0.85)),
        genus: ANY_GENUS,
        volume_cm3: ANY_VOLUME,
    },
    Case {
        name: "head_carotid",
        scan: "vsseg001_head_t1gd",
        seed: [202, 242, 23],
        dice_against: None,
        genus: ANY_GENUS,
        volume_cm3: (0.0, 6.0),
    },
    Case {
        name: "head_basilar",
        scan: "vsseg001_head_t1gd",
        seed: [253, 236, 35],
        dice_against: None,
        genus: ANY_GENUS,
        volume_cm3: (0.0, 6.0),
    },
    Case {
        name: "head_sagittal_sinus",
        scan: "vsseg001_head_t1gd",
        seed: [262, 451, 71],
        dice_against: None,
        genus: ANY_GENUS,
        volume_cm3: (5.0, 40.0),
    },
    Case {
        name: "head_schwannoma",
        scan: "vsseg001_head_t1gd",
        seed: [310, 271, 29],
        dice_against: None,
        genus: (0, 0),
        volume_cm3: (1.5, 10.0),
    },
    Case {
        name: "heart_aorta",
        scan: "seg3d_heart_cemr",
        seed: [341, 415, 21],
        dice_against: None,
        genus: ANY_GENUS,
        volume_cm3: ANY_VOLUME,
    },
    Case {
        name: "heart_blood_pool",
        scan: "seg3d_heart_cemr",
        seed: [305, 329, 15],
        dice_against: None,
        genus: ANY_GENUS,
        volume_cm3: (0.0, 1000.0),
    },
];

/// What the balloon gave for a case, with the defaults and the seed alone.
#[derive(Debug)]
pub struct Outcome {
    pub valid: bool,
    pub components: usize,
    pub genus: Option<i64>,
    pub volume_cm3: f64,
    pub dice: Option<f64>,
    pub window: String,
    pub seconds: f64,
    pub mesh: balloonseg::TriMesh,
    /// The scan, the seed (world mm) and the display window of a picture of the result.
    pub image: Image,
    pub seed: DVec3,
    pub display_window: (f64, f64),
}

impl Outcome {
    /// The README's expectations this outcome misses, empty when it meets them all.
    pub fn misses(&self, case: &Case) -> Vec<String> {
        let mut misses = Vec::new();
        if !self.valid {
            misses.push("the mesh is not a valid closed surface".to_string());
        }
        let genus = self.genus.unwrap_or(-1);
        if genus < case.genus.0 || genus > case.genus.1 {
            misses.push(format!("genus {genus} outside {:?}", case.genus));
        }
        let (lo, hi) = case.volume_cm3;
        if self.volume_cm3 < lo || self.volume_cm3 > hi {
            misses.push(format!(
                "volume {:.2} cm³ outside {lo}…{hi}",
                self.volume_cm3
            ));
        }
        if let (Some((label, least)), Some(dice)) = (case.dice_against, self.dice) {
            if dice < least {
                misses.push(format!("Dice {dice:.3} against {label} below {least}"));
            }
        }
        misses
    }
}

/// Segments `case` from the scans in `data` with `params` and scores it.
pub fn run(case: &Case, data: &Path, params: BalloonParams) -> Result<Outcome> {
    let folder = data.join(case.scan);
    let image = io::read_image(&folder.join("image.nii.gz"))?;
    let seed = image
        .geometry()
        .index_to_world(DVec3::from(case.seed.map(|v| v as f64)));
    let start = Instant::now();
    let mut segmenter = Segmenter::new(image.view(), params, seed)?;
    let (mesh, _) = segmenter.segment()?;
    let seconds = start.elapsed().as_secs_f64();
    let stats = segmenter.stats().clone();
    let report = mesh_checks::check(&mesh);
    let dice = match case.dice_against {
        Some((label, _)) => {
            let label = io::read_image(&folder.join(format!("label_{label}.nii.gz")))?;
            let inside = inside_mask(&mesh, label.dims(), label.geometry())?;
            let view = label.view();
            let [ni, nj, _] = label.dims();
            let voxel: f64 = label.geometry().spacing().iter().product();
            let mut overlap = Overlap {
                mesh: 0.0,
                truth: 0.0,
                both: 0.0,
            };
            for (n, &m) in inside.iter().enumerate() {
                let t = view.get_f64(n % ni, n / ni % nj, n / (ni * nj)) > 0.0;
                overlap.mesh += f64::from(u8::from(m)) * voxel;
                overlap.truth += f64::from(u8::from(t)) * voxel;
                overlap.both += f64::from(u8::from(m && t)) * voxel;
            }
            Some(overlap.dice())
        }
        None => None,
    };
    Ok(Outcome {
        valid: report.is_valid_closed_surface(),
        components: report.components,
        genus: report.genus(),
        volume_cm3: report.signed_volume / 1000.0,
        dice,
        window: stats.window.to_string(),
        seconds,
        mesh,
        display_window: stats.display_window(),
        image,
        seed,
    })
}
