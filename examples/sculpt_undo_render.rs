//! Sculpt: carve two holes into a ball, undo the second, save the session atomically,
//! open it again and render the iso-surface to a PNG.
//!
//! `cargo run --release --example sculpt_undo_render -- ball.vsculpt ball.png`

use volga::prelude::*;
use volga::render::{Iso, SurfaceColour};
use volga::sculpt::SculptGrid;
use volga::shapes::{FilteredDensity, OrientedBoxFilter, Sphere};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let file = args.first().map_or("ball.vsculpt", |s| s.as_str());
    let png = args.get(1).map_or("ball.png", |s| s.as_str());
    let h = 1.0 / 64.0; // voxel size of the octree's finest level
    let grid = SculptGrid::covering(&Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)), h)?;
    let ball = FilteredDensity::new(
        Sphere::new(DVec3::ZERO, 0.7)?,
        OrientedBoxFilter::for_spacing(DVec3::splat(h)),
    );
    let mut sculpt = Sculpt::from_field(grid, &ball, [0.8, 0.7, 0.6]);
    for center in [DVec3::new(0.0, 0.0, 0.7), DVec3::new(0.7, 0.0, 0.0)] {
        sculpt.apply(&Stroke::new(Tool::sphere(center, 0.3)?, Operation::Carve)?);
    }
    sculpt.undo(); // the second hole is gone; `redo` would bring it back
    sculpt.save(file)?; // temporary file, then rename: never a partial file
    let sculpt = Sculpt::open(file)?;
    let view = Projection::Perspective { fov_y_deg: 35.0 };
    let camera = Camera::look_at(DVec3::new(1.5, 1.0, 2.5), DVec3::ZERO, DVec3::Y, view)?;
    let iso = Iso {
        value: 0.5,
        colour: SurfaceColour::FromField,
    };
    let (image, _) = Renderer::new(&sculpt, &iso, &RenderSettings::new(384, 384))?.render(&camera, &NoProgress);
    write_png(png.as_ref(), image.width, image.height, &image.to_rgba8())?;
    println!("saved {file}, rendered {png}");
    Ok(())
}
