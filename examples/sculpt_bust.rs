//! Sculpts a bust from a block with a few dozen strokes, like the survey's figure 46
//! (§17.9), and renders it.
//!
//! `cargo run --release --example sculpt_bust -- docs/images/sculpt_bust.png`
//!
//! The block is carved (spheres, boxes), sawn (a sphere swept along a polyline around the
//! neck), sprayed (nose, brows, ears), painted (eyes, lips) and smoothed, then rendered as
//! the shaded ½ iso-surface in its own colours. It prints one line per stroke (the world
//! box it changed, the node count) and the final octree size against a dense grid.

use std::f64::consts::TAU;

use glam::{DQuat, DVec3, Vec3};
use volga::core::NoProgress;
use volga::render::{Camera, Iso, Projection, RenderSettings, Renderer, SurfaceColour};
use volga::sculpt::{Operation, Pose, Sculpt, SculptGrid, Stroke, Tool, ToolShape};
use volga::shapes::{AxisBox, Capsule, Ellipsoid, FilteredDensity, OrientedBoxFilter, Shape};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "sculpt_bust.png".into());
    let h = 0.01; // voxel size: the block is 1.4 × 2.1 × 1.1 units in a 256³ grid
    let grid = SculptGrid::covering(
        &volga::Aabb::new(DVec3::new(-1.0, -1.05, -0.6), DVec3::new(1.0, 1.05, 0.6)),
        h,
    )?;
    let block = FilteredDensity::new(
        AxisBox::new(DVec3::new(-0.7, -1.05, -0.55), DVec3::new(0.7, 1.05, 0.55))?,
        OrientedBoxFilter::for_spacing(DVec3::splat(h)),
    );
    let mut sculpt = Sculpt::from_field(grid, &block, [0.78, 0.72, 0.64]);

    let sphere = |c: [f64; 3], r: f64| Tool::sphere(DVec3::from_array(c), r);
    let carve = Operation::Carve;
    let mut strokes: Vec<Stroke> = Vec::new();
    let mut add =
        |tool: Result<Tool, volga::sculpt::ToolError>, op: Operation| -> Result<(), Box<dyn std::error::Error>> {
            strokes.push(Stroke::new(tool?, op)?);
            Ok(())
        };
    let shape = |s: Shape| Tool::new(ToolShape::Shape(s), Pose::IDENTITY);

    // 1. Rough out: cut the block down to its shoulders and round them.
    let b = |lo: [f64; 3], hi: [f64; 3]| AxisBox::new(DVec3::from_array(lo), DVec3::from_array(hi)).map(Shape::AxisBox);
    add(shape(b([-0.8, -0.25, -0.7], [0.8, 1.2, 0.7])?), carve)?;
    for side in [-1.0, 1.0] {
        add(sphere([side * 0.95, -0.05, 0.0], 0.55), carve)?; // sloping shoulders
        for z in [-1.0, 1.0] {
            add(sphere([side * 0.72, -0.3, z * 0.56], 0.24), carve)?; // rounded corners
            add(sphere([side * 0.3, 0.05, z * 0.85], 0.5), carve)?; // chest and back slope
        }
    }
    // 2. Spray on the neck and the head (additive tools), then saw a groove round the neck.
    let solid = Operation::Spray {
        strength: 1.0,
        falloff_world: 0.0,
    };
    let head = |c: [f64; 3], r: [f64; 3]| {
        Ellipsoid::new(
            DVec3::from_array(c),
            DVec3::from_array(r),
            DQuat::from_rotation_x(-0.15),
        )
        .map(Shape::Ellipsoid)
    };
    add(
        shape(Shape::Capsule(Capsule::new(
            DVec3::new(0.0, -0.4, -0.03),
            DVec3::new(0.0, 0.25, 0.0),
            0.16,
        )?)),
        solid,
    )?;
    add(shape(head([0.0, 0.52, 0.0], [0.31, 0.42, 0.36])?), solid)?; // cranium
    add(shape(head([0.0, 0.3, 0.08], [0.23, 0.2, 0.27])?), solid)?; // jaw
    let ring = |radius: f64, y: f64| -> Vec<DVec3> {
        (0..=32)
            .map(|k| {
                let a = TAU * k as f64 / 32.0;
                DVec3::new(radius * a.cos(), y, radius * a.sin() - 0.02)
            })
            .collect()
    };
    add(
        Tool::sphere(DVec3::ZERO, 0.025).and_then(|t| t.swept(&ring(0.165, -0.12), h * 0.5)),
        carve,
    )?;
    // 3. The face: eye sockets and eyeballs, brows, ears, nose, mouth, chin.
    for side in [-1.0, 1.0] {
        add(sphere([side * 0.12, 0.55, 0.37], 0.07), carve)?; // eye socket
        add(sphere([side * 0.12, 0.55, 0.31], 0.052), Operation::Add)?; // eyeball
        add(
            shape(Shape::Capsule(Capsule::new(
                DVec3::new(side * 0.04, 0.65, 0.33),
                DVec3::new(side * 0.2, 0.66, 0.29),
                0.03,
            )?)),
            Operation::Spray {
                strength: 0.8,
                falloff_world: 0.02,
            },
        )?; // brow
        add(
            shape(Shape::Ellipsoid(Ellipsoid::new(
                DVec3::new(side * 0.31, 0.5, 0.0),
                DVec3::new(0.05, 0.11, 0.07),
                DQuat::IDENTITY,
            )?)),
            Operation::Add,
        )?; // ear
    }
    add(
        shape(Shape::Capsule(Capsule::new(
            DVec3::new(0.0, 0.56, 0.34),
            DVec3::new(0.0, 0.43, 0.42),
            0.04,
        )?)),
        Operation::Add,
    )?; // nose bridge
    add(sphere([0.0, 0.42, 0.42], 0.045), Operation::Add)?; // nose tip
    add(
        Tool::sphere(DVec3::ZERO, 0.014).and_then(|t| {
            t.swept(
                &[
                    DVec3::new(-0.08, 0.31, 0.32),
                    DVec3::new(0.0, 0.3, 0.335),
                    DVec3::new(0.08, 0.31, 0.32),
                ],
                h * 0.5,
            )
        }),
        carve,
    )?; // mouth line (a short saw)
    add(
        sphere([0.0, 0.16, 0.22], 0.06),
        Operation::Spray {
            strength: 0.7,
            falloff_world: 0.03,
        },
    )?; // chin
        // 4. Paint: eyes, lips, a scarf over the shoulders.
    for side in [-1.0, 1.0] {
        add(
            sphere([side * 0.12, 0.55, 0.36], 0.03),
            Operation::Paint {
                colour: [0.1, 0.25, 0.6],
                strength: 1.0,
            },
        )?;
    }
    add(
        sphere([0.0, 0.3, 0.34], 0.05),
        Operation::Paint {
            colour: [0.7, 0.25, 0.22],
            strength: 0.8,
        },
    )?;
    add(
        Tool::sphere(DVec3::ZERO, 0.16).and_then(|t| t.swept(&ring(0.3, -0.3), h * 0.5)),
        Operation::Paint {
            colour: [0.55, 0.12, 0.15],
            strength: 1.0,
        },
    )?;
    // 5. Smooth where neck meets shoulders and jaw.
    for c in [[0.0, -0.3, 0.0], [0.0, 0.2, -0.1], [0.0, 0.2, 0.25]] {
        add(sphere(c, 0.2), Operation::Smooth { strength: 1.0 })?;
    }

    let dense_bytes = (grid.dims() as u64).pow(3) * 4;
    for (i, stroke) in strokes.iter().enumerate() {
        let report = sculpt.apply(stroke);
        let b = report.changed_world;
        println!(
            "stroke {i:2}: {:?} changed {:?}, {} nodes",
            stroke.operation,
            b.map(|b| (b.min.to_array(), b.max.to_array())),
            sculpt.stats().nodes()
        );
    }
    let stats = sculpt.stats();
    println!(
        "{} strokes; octree {} nodes, {} bricks, {:.1} MB ({:.2} % of a dense {}³ f32 grid); undo history {:.1} MB",
        strokes.len(),
        stats.nodes(),
        stats.bricks,
        stats.bytes as f64 / 1e6,
        100.0 * stats.bytes as f64 / dense_bytes as f64,
        grid.dims(),
        sculpt.history_bytes() as f64 / 1e6
    );

    // Render: three-quarter view from the front.
    let camera = Camera::look_at(
        DVec3::new(1.9, 1.0, 4.4),
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::Y,
        Projection::Perspective { fov_y_deg: 30.0 },
    )?;
    let mut settings = RenderSettings::new(512, 512);
    settings.lighting.lights[0].direction = DVec3::new(0.5, 0.7, 1.0);
    settings.lighting.ambient_colour = Vec3::splat(0.3);
    let iso = Iso {
        value: 0.5,
        colour: SurfaceColour::FromField,
    };
    let (image, _) = Renderer::new(&sculpt, &iso, &settings)?.render(&camera, &NoProgress);
    let rgba = image.to_rgba8();
    volga::io::write_png(std::path::Path::new(&out), image.width, image.height, &rgba)?;
    println!("wrote {out}");
    Ok(())
}
