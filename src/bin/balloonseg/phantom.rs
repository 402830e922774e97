//! `balloonseg phantom NAME -o OUT.mha`: writes a synthetic test volume and prints its seed —
//! one of the fixed shapes, rendered as the look flags say, variant N of a family, which draws
//! its own look (so the look flags are an error with a family), or variant N of the
//! clinical-size angiogram on a grid of `--dims` voxels.

use std::process::ExitCode;

use balloonseg::phantom::{self, Angiogram, Family, Parameter, PhantomOptions, Shape};
use balloonseg::{io, Error, Result};
use serde_json::{json, Map, Value};

#[derive(clap::Args)]
pub struct Args {
    /// A shape (sphere, torus, double-torus, y-vessel, touching-tubes, fading-tube), a family
    /// (ct-scene, thin-wall, touching-pair, thin-vessels, stent, vessel-chamber) or
    /// `angiogram` (an abdominal CT angiogram at clinical size).
    name: String,
    /// The family's or the angiogram's variant number (default 0); every number gives another
    /// scene.
    #[arg(long)]
    variant: Option<u64>,
    /// The angiogram's grid, voxels "x,y,z" (default 512,512,600, a clinical scan).
    #[arg(long, value_parser = parse_dims)]
    dims: Option<[usize; 3]>,
    #[command(flatten)]
    look: Look,
    #[command(flatten)]
    output: crate::Output,
}

/// How a shape is rendered (a family draws its own).
#[derive(clap::Args, Clone)]
pub struct Look {
    /// Voxel spacing in mm, "x,y,z" (default 1,1,1).
    #[arg(long, value_parser = crate::parse_triple)]
    pub spacing: Option<[f64; 3]>,
    /// Rotate the grid obliquely (25° about (1,2,3)); otherwise axis-aligned.
    #[arg(long)]
    pub oblique: bool,
    /// Gaussian noise σ as a fraction of the contrast (0.1 = 10%; default 0).
    #[arg(long)]
    pub noise: Option<f64>,
    /// Gaussian blur σ in mm (default 0).
    #[arg(long)]
    pub blur: Option<f64>,
    /// Seed of the noise generator (default 1).
    #[arg(long)]
    pub noise_seed: Option<u64>,
}

impl Look {
    pub fn options(&self) -> PhantomOptions {
        let defaults = PhantomOptions::default();
        PhantomOptions {
            spacing: self.spacing.unwrap_or(defaults.spacing),
            direction: if self.oblique {
                phantom::oblique_direction()
            } else {
                defaults.direction
            },
            noise: self.noise.unwrap_or(defaults.noise),
            blur_mm: self.blur.unwrap_or(defaults.blur_mm),
            noise_seed: self.noise_seed.unwrap_or(defaults.noise_seed),
            ..defaults
        }
    }

    /// The look flags given, by name.
    fn given(&self) -> Vec<&'static str> {
        [
            ("--spacing", self.spacing.is_some()),
            ("--oblique", self.oblique),
            ("--noise", self.noise.is_some()),
            ("--blur", self.blur.is_some()),
            ("--noise-seed", self.noise_seed.is_some()),
        ]
        .into_iter()
        .filter_map(|(name, given)| given.then_some(name))
        .collect()
    }
}

/// The name that asks for the angiogram.
const ANGIOGRAM: &str = "angiogram";

fn parse_dims(text: &str) -> std::result::Result<[usize; 3], String> {
    let values: Vec<usize> = text
        .split(',')
        .map(|v| v.trim().parse())
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| format!("'{text}' is not three voxel counts x,y,z: {e}"))?;
    values
        .try_into()
        .map_err(|_| format!("'{text}' is not three voxel counts x,y,z"))
}

pub fn run(args: &Args) -> Result<ExitCode> {
    if args.dims.is_some() && args.name != ANGIOGRAM {
        return Err(Error::invalid_argument(format!(
            "--dims sets the angiogram's grid; '{}' has its own (leave --dims out)",
            args.name
        )));
    }
    let summary = if args.name == ANGIOGRAM {
        write_angiogram(args)?
    } else {
        match Family::from_name(&args.name) {
            Ok(family) => write_variant(args, family)?,
            Err(_) => write_shape(args)?,
        }
    };
    let json = serde_json::to_string_pretty(&summary).expect("plain JSON values");
    crate::print_out(&format!("{json}\n"))?;
    Ok(ExitCode::SUCCESS)
}

fn write_shape(args: &Args) -> Result<Value> {
    let shape = Shape::from_name(&args.name).map_err(|_| {
        let names: Vec<_> = Shape::ALL
            .iter()
            .map(|s| s.name())
            .chain(Family::ALL.iter().map(|f| f.name()))
            .chain([ANGIOGRAM])
            .collect();
        Error::invalid_argument(format!(
            "unknown phantom '{}'; choose one of {}",
            args.name,
            names.join(", ")
        ))
    })?;
    if args.variant.is_some() {
        return Err(Error::invalid_argument(format!(
            "--variant goes with a family, and '{}' is a fixed shape",
            args.name
        )));
    }
    let phantom = phantom::render(shape, &args.look.options())?;
    io::write_image(&args.output.path, &phantom.image)?;
    let seed = phantom.seed_world();
    let index = phantom.image.geometry().world_to_index(seed);
    Ok(json!({
        "file": crate::shown(&args.output.path),
        "phantom": shape.name(),
        "dims": phantom.image.dims(),
        "seed_world": seed.to_array(),
        "seed_index": index.to_array(),
        "genus": shape.genus(),
    }))
}

/// Errors when look flags are given to a phantom that draws its own look.
fn refuse_look(args: &Args) -> Result<()> {
    let given = args.look.given();
    if given.is_empty() {
        return Ok(());
    }
    Err(Error::invalid_argument(format!(
        "{} set how a fixed shape looks; '{}' draws its own spacing, direction, blur and noise \
         from the variant number: leave them out, or pick another --variant",
        given.join(", "),
        args.name
    )))
}

/// The drawn parameters as a JSON object.
fn parameters_json(parameters: &[Parameter]) -> Map<String, Value> {
    parameters
        .iter()
        .map(|p| {
            let value = match p.values.as_slice() {
                [one] => json!(one),
                many => json!(many),
            };
            (p.name.to_string(), value)
        })
        .collect()
}

fn write_angiogram(args: &Args) -> Result<Value> {
    refuse_look(args)?;
    let number = args.variant.unwrap_or(0);
    let angiogram = Angiogram::new(number, args.dims.unwrap_or(Angiogram::FULL_SIZE))?;
    let image = angiogram.render()?;
    io::write_image(&args.output.path, &image)?;
    let geometry = image.geometry();
    let seed = angiogram.seed();
    Ok(json!({
        "file": crate::shown(&args.output.path),
        "phantom": ANGIOGRAM,
        "variant": number,
        "dims": image.dims(),
        "spacing": geometry.spacing(),
        "scalar_type": image.scalar_type().name(),
        "seed_world": seed.to_array(),
        "seed_index": geometry.world_to_index(seed).to_array(),
        "genus": angiogram.genus(),
        "parameters": parameters_json(angiogram.describe()),
    }))
}

fn write_variant(args: &Args, family: Family) -> Result<Value> {
    refuse_look(args)?;
    let number = args.variant.unwrap_or(0);
    let variant = family.variant(number)?;
    io::write_image(&args.output.path, &variant.image)?;
    let geometry = variant.image.geometry();
    let seed = variant.seed();
    let parameters = parameters_json(variant.describe());
    Ok(json!({
        "file": crate::shown(&args.output.path),
        "phantom": family.name(),
        "variant": number,
        "dims": variant.image.dims(),
        "spacing": geometry.spacing(),
        "scalar_type": variant.image.scalar_type().name(),
        "seed_world": seed.to_array(),
        "seed_index": geometry.world_to_index(seed).to_array(),
        "other_seed_world": variant.other_seed().map(|s| s.to_array()),
        "other_seed_index": variant.other_seed().map(|s| geometry.world_to_index(s).to_array()),
        "genus": variant.genus(),
        "contrast": variant.contrast(),
        "parameters": parameters,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Command {
        #[command(flatten)]
        args: Args,
    }

    fn run_with(words: &[&str]) -> Result<ExitCode> {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let out = dir.path().join("out.nii.gz");
        let mut line = vec!["phantom"];
        line.extend_from_slice(words);
        line.extend(["-o", out.to_str().expect("a UTF-8 path")]);
        let result = run(&Command::parse_from(line).args);
        if result.is_ok() {
            io::read_image(&out)?;
        }
        result
    }

    #[test]
    fn families_and_shapes_take_their_own_flags() {
        run_with(&["thin-wall", "--variant", "7"]).unwrap();
        run_with(&["torus", "--spacing", "2,2,2", "--oblique"]).unwrap();
        let error = run_with(&["stent", "--spacing", "1,1,1", "--noise", "0.1"]).unwrap_err();
        assert!(
            error.message().contains("--spacing, --noise"),
            "{}",
            error.message()
        );
        let error = run_with(&["sphere", "--variant", "2"]).unwrap_err();
        assert!(error.message().contains("--variant"), "{}", error.message());
        let error = run_with(&["cube"]).unwrap_err();
        assert!(error.message().contains("ct-scene"), "{}", error.message());
        assert!(error.message().contains("angiogram"), "{}", error.message());
        let error = run_with(&["torus", "--dims", "100,100,100"]).unwrap_err();
        assert!(error.message().contains("--dims"), "{}", error.message());
        let error = run_with(&["angiogram", "--dims", "100,100,100", "--blur", "1"]).unwrap_err();
        assert!(error.message().contains("--blur"), "{}", error.message());
    }
}
