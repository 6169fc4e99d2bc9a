//! Build a scene made by a program (a row of growing spheres, as `serde_json::json!` data
//! checked like a scene file) into a PNG, a NRRD volume and `report.json`.
//!
//! `cargo run --release --example scene_from_code -- out/`

use std::path::{Path, PathBuf};

use serde_json::json;
use volga::prelude::*;
use volga::scene::{build_parsed, model::SceneFile};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out_dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".into()));
    let spheres: Vec<_> = (0..5)
        .map(|i| {
            let x = -1.6 + 0.8 * i as f64;
            json!({ "shape": { "Sphere": { "center": [x, 0.0, 0.0], "radius": 0.15 + 0.05 * i as f64 } },
                    "colour": [0.2 + 0.15 * i as f64, 0.4, 0.9 - 0.15 * i as f64] })
        })
        .collect();
    let scene: SceneFile = serde_json::from_value(json!({
        "grid": { "bounds": { "min": [-2.0, -0.5, -0.5], "max": [2.0, 0.5, 0.5] }, "resolution": 160 },
        "objects": spheres,
        "lights": [{ "direction": [0.5, 0.8, 1.0], "colour": [1.0, 1.0, 1.0] }],
        "cameras": [{ "name": "front", "eye": [0.0, 1.2, 4.0], "target": [0.0, 0.0, 0.0],
                      "projection": { "Perspective": { "fov_deg": 45.0 } } }],
        "outputs": { "images": [{ "name": "row", "camera": "front", "width": 480, "height": 240,
                                  "mode": { "Iso": { "value": 0.5, "colour": "FromVolume" } } }],
                     "volumes": [{ "name": "row_volume" }] },
    }))?;
    let options = BuildOptions {
        out_dir,
        memory_limit: None,
        stage_start: None,
        allow_outside_paths: false,
    };
    // The path names the scene in messages and is where relative file paths start.
    let report = build_parsed(Path::new("row_of_spheres"), &scene, &options, &NoProgress)?;
    println!("wrote {:?}", report.outputs);
    Ok(())
}
