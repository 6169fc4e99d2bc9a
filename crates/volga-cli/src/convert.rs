//! `volga convert IN OUT`: a voxel model from one format to another (`.binvox`, `.nrrd`,
//! `.vdb`), placed where the input says. A NRRD of distances becomes a `.vdb` level set,
//! a `.vdb` level set a NRRD of distances; `.binvox` outputs take occupancy only.

use std::path::PathBuf;

use clap::Args;
use volga_io::{VoxelFormat, VoxelModel};

use crate::failure::{bad_input, Failure};
use crate::voxelize::VdbArgs;

#[derive(Args)]
pub struct ConvertArgs {
    /// Input voxel model: .binvox, .nrrd or .vdb (its first float grid).
    pub input: PathBuf,
    /// Output: .binvox (occupancy inputs only), .nrrd (+ .raw) or .vdb.
    pub output: PathBuf,
    /// Refuse inputs that need more memory than this (e.g. 512M, 8G); default: the
    /// machine's available memory.
    #[arg(long, value_parser = crate::parse_size)]
    pub memory_limit: Option<u64>,
    #[command(flatten)]
    pub vdb: VdbArgs,
}

fn describe(model: &VoxelModel) -> String {
    match model {
        VoxelModel::Vdb { grid, values } => format!(
            "vdb grid {:?}, {}, {} active voxels, {}",
            grid.name,
            grid.class.name(),
            grid.active_voxels,
            values.name()
        ),
        m => format!("{}, {}", m.format().name(), m.values().name()),
    }
}

pub fn run(args: ConvertArgs) -> Result<(), Failure> {
    volga_core::memory::set_input_limit(args.memory_limit);
    let out_format = VoxelFormat::from_path(&args.output).map_err(|e| bad_input(e.to_string()))?;
    let vdb = args.vdb.options(&args.output)?;
    let input = volga_io::output_identity(&args.input);
    if let Some(p) = out_format
        .output_paths(&args.output, true)
        .iter()
        .find(|p| volga_io::output_identity(p) == input)
    {
        return Err(bad_input(format!(
            "{}: the output would replace the input",
            p.display()
        )));
    }
    let model = volga_io::read_voxel_model(&args.input).map_err(|e| bad_input(e.to_string()))?;
    let summary = describe(&model);
    if out_format == VoxelFormat::Binvox && model.values().name() != "occupancy" {
        return Err(bad_input(format!(
            "{}: .binvox holds occupancy; {} holds {}",
            args.output.display(),
            args.input.display(),
            model.values().name()
        )));
    }
    let volume = model.into_volume(&args.input).map_err(|e| bad_input(e.to_string()))?;
    let outputs = crate::voxelize::write_outputs(&args.output, &volume, &vdb, None)?;
    let dims = volume.grid.dims();
    println!(
        "{} ({summary}) → {} ({}×{}×{} grid, origin {:?}, voxel {:?})",
        args.input.display(),
        outputs
            .iter()
            .map(|p: &PathBuf| p.display().to_string())
            .collect::<Vec<_>>()
            .join(" + "),
        dims.x,
        dims.y,
        dims.z,
        volume.grid.transform.origin().to_array(),
        volume.grid.transform.spacing().to_array(),
    );
    Ok(())
}
