//! `balloonseg phantom NAME -o OUT.mha`: writes a synthetic test volume and prints its seed.

use std::process::ExitCode;

use balloonseg::phantom::{self, PhantomOptions, Shape};
use balloonseg::{io, Result};
use serde_json::json;

#[derive(clap::Args)]
pub struct Args {
    /// sphere, torus, double-torus, y-vessel, touching-tubes or fading-tube.
    name: String,
    #[command(flatten)]
    look: Look,
    #[command(flatten)]
    output: crate::Output,
}

/// How a phantom is rendered; shared with `demo`.
#[derive(clap::Args, Clone)]
pub struct Look {
    /// Voxel spacing in mm, "x,y,z".
    #[arg(long, value_parser = crate::parse_triple, default_value = "1,1,1")]
    pub spacing: [f64; 3],
    /// Rotate the grid obliquely (25° about (1,2,3)); otherwise axis-aligned.
    #[arg(long)]
    pub oblique: bool,
    /// Gaussian noise σ as a fraction of the contrast (0.1 = 10%).
    #[arg(long, default_value_t = 0.0)]
    pub noise: f64,
    /// Gaussian blur σ in mm.
    #[arg(long, default_value_t = 0.0)]
    pub blur: f64,
    /// Seed of the noise generator.
    #[arg(long, default_value_t = 1)]
    pub noise_seed: u64,
}

impl Look {
    pub fn options(&self) -> PhantomOptions {
        let defaults = PhantomOptions::default();
        PhantomOptions {
            spacing: self.spacing,
            direction: if self.oblique {
                phantom::oblique_direction()
            } else {
                defaults.direction
            },
            noise: self.noise,
            blur_mm: self.blur,
            noise_seed: self.noise_seed,
            ..defaults
        }
    }
}

pub fn run(args: &Args) -> Result<ExitCode> {
    let shape = Shape::from_name(&args.name)?;
    let phantom = phantom::render(shape, &args.look.options())?;
    io::write_image(&args.output.path, &phantom.image)?;
    let seed = phantom.seed_world();
    let index = phantom.image.geometry().world_to_index(seed);
    let summary = json!({
        "file": crate::shown(&args.output.path),
        "phantom": shape.name(),
        "dims": phantom.image.dims(),
        "seed_world": seed.to_array(),
        "seed_index": index.to_array(),
        "genus": shape.genus(),
    });
    println!(
        "{}",
        serde_json::to_string_pretty(&summary).expect("plain JSON values")
    );
    Ok(ExitCode::SUCCESS)
}
