//! Voxelize a sphere with the oriented box filter, render its iso-surface, and compare
//! what the raycaster finds with the true radius.
//!
//! `cargo run --release --example sphere`

use glam::{DVec3, UVec3, Vec3};
use volga::render::{
    first_hit, render, Camera, Iso, Light, Lighting, Mode, Projection, Ray, RenderSettings, SurfaceColour,
};
use volga::voxelize::{shapes::Sphere, voxelize_solids, Shape, Solid};
use volga::{Filter, Grid, NoProgress, Sampled, Transform};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // 64³ voxels of size 1/32 around the origin.
    let grid = Grid::new(
        Transform::new(DVec3::splat(-1.0), DVec3::splat(1.0 / 32.0))?,
        UVec3::splat(64),
    )?;
    let radius = 0.7;
    let ball = Solid::new(Shape::Sphere(Sphere::new(DVec3::ZERO, radius)?), [0.9, 0.4, 0.2]);
    let volume = voxelize_solids(&grid, &[ball], true, &NoProgress);
    println!(
        "{} active voxels in {} bricks ({} dense)",
        volume.active_voxel_count(),
        volume.density.brick_count(),
        volume.density.dense_brick_count()
    );

    let field = Sampled::new(&volume, Filter::Trilinear);
    let hit = first_hit(
        &field,
        &Ray {
            origin: DVec3::new(-2.0, 0.1, 0.05),
            dir: DVec3::X,
        },
        0.5,
        0.01,
    )
    .expect("the ray hits the sphere");
    let error_voxels = (hit.world_pos.length() - radius).abs() * 32.0;
    println!(
        "iso-surface hit at {:.5}, {error_voxels:.4} voxel from the true sphere",
        hit.world_pos
    );

    let camera = Camera::look_at(
        DVec3::new(2.0, 1.5, 3.0),
        DVec3::ZERO,
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 35.0 },
    )?;
    let settings = RenderSettings {
        lighting: Lighting {
            lights: vec![Light {
                direction: DVec3::new(1.0, 1.0, 1.0),
                colour: Vec3::ONE,
            }],
            ..Default::default()
        },
        ..RenderSettings::new(256, 256)
    };
    let mode = Mode::Iso(Iso {
        value: 0.5,
        colour: SurfaceColour::FromField,
    });
    let (image, stats) = render(&field, &camera, &mode, &settings, &NoProgress)?;
    let out = std::env::temp_dir().join("volga_sphere.png");
    volga::io::write_png(&out, image.width, image.height, &image.to_rgba8())?;
    println!(
        "rendered {} rays, {} samples → {}",
        stats.rays,
        stats.samples,
        out.display()
    );
    Ok(())
}
