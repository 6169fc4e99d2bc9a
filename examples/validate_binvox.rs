//! Validate a binary voxel model: does it 26-separate the space (≥ 2 white components)?
//! Prints the validator's verdict as JSON (as `volga validate --json`; minimality and the
//! rest are reported too) and exits 1 when the required property fails.
//!
//! `cargo run --release --example obj_to_binvox -- tests/data/spot.obj 64 spot.binvox`
//! `cargo run --release --example validate_binvox -- spot.binvox`

use std::path::PathBuf;

use volga::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "spot.binvox".into()));
    let VoxelModel::Binvox(model) = read_voxel_model(&path)? else {
        return Err(format!("{}: not a .binvox model", path.display()).into());
    };
    let set = VoxelSet::from_voxels(model.dims(), model.filled().map(|v| v.as_ivec3()))?;
    let result = verdict(VerdictInput {
        model: Some(path),
        format: "binvox",
        values: "occupancy",
        set,
        transform: model.transform()?,
        connectivity: Connectivity::TwentySix,
        mesh: None,
        requirements: &[Requirement::Separating],
        pad: true, // a white layer around the grid, so the outside is one component
        listed: 10,
    })?;
    println!("{}", serde_json::to_string_pretty(&result)?);
    std::process::exit(if result.passed { 0 } else { 1 });
}
