//! Planning of procedural work, checked by the counters of `report.json`: noise runs only
//! where a scene calls for it, colour channels exist only when read, and a
//! hypertexture's noise follows its soft band, not the grid.

use std::path::Path;

use volga_core::NoProgress;
use volga_scene::{build, BuildOptions, Report};

fn run(dir: &Path, name: &str, scene: &str) -> Report {
    let path = dir.join(format!("{name}.ron"));
    std::fs::write(&path, scene).unwrap();
    let options = BuildOptions {
        out_dir: dir.join(name),
        memory_limit: Some(1 << 30),
        stage_start: None,
        allow_outside_paths: false,
    };
    build(&path, &options, &NoProgress).unwrap()
}

const VIEW: &str = r#"
    lights: [(direction: (0.3, 0.5, 1.0))],
    cameras: [(name: "c", eye: (0.0, 0.0, 4.0), target: (0.0, 0.0, 0.0), projection: Orthographic(height: 2.5))],
"#;

fn cvg_scene(colour: &str) -> String {
    format!(
        r#"Scene(
    grid: (bounds: (min: (-1.0, -1.0, -1.0), max: (1.0, 1.0, 1.0)), resolution: 32),
    root: Cvg((op: Difference, operands: [
        Fuzzy((core: Sphere(center: (0.0, 0.0, 0.0)), radius: 0.9, colour: (1.0, 0.0, 0.0))),
        Object(shape: Box(min: (0.0, 0.0, 0.0), max: (1.0, 1.0, 1.0))),
    ])),
    {VIEW}
    outputs: (images: [
        (name: "lazy", camera: "c", mode: Iso(value: 0.1, colour: {colour}), width: 24, height: 24, source: Lazy),
        (name: "baked", camera: "c", mode: Iso(value: 0.1, colour: {colour}), width: 24, height: 24),
    ]),
)"#
    )
}

#[test]
fn scene_without_textures_evaluates_no_noise() {
    let dir = tempfile::tempdir().unwrap();
    let r = run(dir.path(), "cvg", &cvg_scene("FromVolume"));
    assert_eq!(r.noise_evaluations, 0);
    assert!(r.node_counters.iter().all(|c| c.noise_evaluations == 0));
    assert!(r.node_counters.iter().any(|c| c.kind == "cvg" && c.samples > 0));
    assert_eq!(r.plan.procedural.len(), 1);
    assert!(!r.plan.procedural[0].enabled);
    assert!(r.voxels.colour_bricks > 0, "the baked image reads colour");
}

#[test]
fn no_colour_output_no_colour_channel_and_no_texture_noise() {
    let dir = tempfile::tempdir().unwrap();
    let r = run(dir.path(), "plain", &cvg_scene("Constant((0.8, 0.8, 0.8))"));
    assert!(!r.plan.colour_channel);
    assert_eq!(r.voxels.colour_bricks, 0);
    // A textured object whose colour nothing reads: its noise never runs.
    let textured = format!(
        r#"Scene(
    grid: (bounds: (min: (-1.0, -1.0, -1.0), max: (1.0, 1.0, 1.0)), resolution: 32),
    root: Textured((texture: Marble(scale: 0.3), operand: Object(shape: Sphere(center: (0.0, 0.0, 0.0), radius: 0.7)))),
    {VIEW}
    outputs: (images: [
        (name: "lazy", camera: "c", mode: Iso(value: 0.5, colour: Constant((1.0, 1.0, 1.0))), width: 24, height: 24, source: Lazy),
        (name: "baked", camera: "c", mode: Iso(value: 0.5, colour: Constant((1.0, 1.0, 1.0))), width: 24, height: 24),
    ]),
)"#
    );
    let r = run(dir.path(), "textured", &textured);
    assert!(!r.plan.colour_channel);
    assert_eq!(r.noise_evaluations, 0);
    // The same scene reading colour evaluates it.
    let r = run(
        dir.path(),
        "textured_colour",
        &textured.replace("Constant((1.0, 1.0, 1.0))", "FromVolume"),
    );
    assert!(r.plan.colour_channel);
    assert!(r.noise_evaluations > 0);
}

fn hyper_scene(half_extent: f64, resolution: u32, soft: f64) -> String {
    format!(
        r#"Scene(
    grid: (bounds: (min: (-{half_extent}, -{half_extent}, -{half_extent}), max: ({half_extent}, {half_extent}, {half_extent})), resolution: {resolution}),
    root: Hypertexture((
        object: Sphere(center: (0.0, 0.0, 0.0), radius: 0.5),
        soft_width: {soft},
        chain: [Displace(noise: Turbulence(octaves: 3, frequency: 8.0), amplitude: 0.02)],
    )),
    {VIEW}
    outputs: (images: [(name: "baked", camera: "c", mode: Mip, width: 8, height: 8)]),
)"#
    )
}

#[test]
fn hypertexture_noise_follows_the_soft_band_not_the_grid() {
    let dir = tempfile::tempdir().unwrap();
    // Same voxel size (1/32), the second grid 8× the voxels; voxel centres and bricks
    // coincide (the origins differ by 32 voxels).
    let small = run(dir.path(), "small", &hyper_scene(1.0, 64, 0.05));
    let large = run(dir.path(), "large", &hyper_scene(2.0, 128, 0.05));
    assert!(small.noise_evaluations > 0);
    assert_eq!(small.noise_evaluations, large.noise_evaluations);
    assert!(
        large.noise_evaluations < large.grid.voxels / 4,
        "{} of {}",
        large.noise_evaluations,
        large.grid.voxels
    );
    // A soft band twice as wide (reach 0.05 + 0.04 → 0.10 + 0.04) costs more noise.
    let wide = run(dir.path(), "wide", &hyper_scene(1.0, 64, 0.10));
    let ratio = wide.noise_evaluations as f64 / small.noise_evaluations as f64;
    assert!((1.2..2.5).contains(&ratio), "ratio {ratio}");
    assert!(small.plan.procedural[0].enabled);
}

/// Errors in the new node kinds name their field paths.
#[test]
fn procedural_errors_name_field_paths() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            cvg_scene("FromVolume").replace("op: Difference", "op: Blend(2.0)"),
            "root.Cvg.op.Blend",
        ),
        (
            cvg_scene("FromVolume").replace("radius: 0.9", "radius: -1.0"),
            "root.Cvg.operands[0].Fuzzy.radius",
        ),
        (
            hyper_scene(1.0, 16, 0.05).replace("octaves: 3", "octaves: 40"),
            "root.Hypertexture.chain[0].Displace.noise.Turbulence.octaves",
        ),
        (
            hyper_scene(1.0, 16, 0.05).replace("soft_width: 0.05", "soft_width: 0.0"),
            "root.Hypertexture.soft_width",
        ),
    ];
    for (i, (scene, field)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("bad{i}.ron"));
        std::fs::write(&path, scene).unwrap();
        let err = volga_scene::validate_scene(&path).unwrap_err().to_string();
        assert!(err.contains(field), "{err} should name {field}");
    }
    // A missing volume file is an error at resolve time naming the field, not a panic.
    let missing = hyper_scene(1.0, 16, 0.05).replace(
        "Sphere(center: (0.0, 0.0, 0.0), radius: 0.5)",
        "Volume(path: \"missing.binvox\")",
    );
    let path = dir.path().join("missing.ron");
    std::fs::write(&path, missing).unwrap();
    let err = volga_scene::load_scene(&path).unwrap_err().to_string();
    assert!(err.contains("root.Hypertexture.object.Volume.path"), "{err}");
}

/// A mixture: a sampled volume (a `.binvox` ball read as a scene leaf) cut by an analytic
/// box with the fuzzy difference, and intersected with a fuzzy sphere; lazy and baked
/// agree at every voxel centre.
#[test]
fn sampled_volume_cut_by_a_box_lazy_equals_baked() {
    use glam::{DVec3, IVec3, UVec3};
    use volga_scene::nodes::Node;
    let dir = tempfile::tempdir().unwrap();
    // A ball of radius 6 voxels in a 16³ binvox over [-1, 1]³.
    let filled = (0..16u32).flat_map(|z| (0..16u32).flat_map(move |y| (0..16u32).map(move |x| UVec3::new(x, y, z))));
    let ball: Vec<UVec3> = filled.filter(|v| (v.as_dvec3() + 0.5 - 8.0).length() <= 6.0).collect();
    let model = volga_io::Binvox::from_filled(UVec3::splat(16), DVec3::splat(-1.0), 2.0, ball).unwrap();
    volga_io::write_binvox(&dir.path().join("ball.binvox"), &model).unwrap();
    let scene = format!(
        r#"Scene(
    grid: (bounds: (min: (-1.0, -1.0, -1.0), max: (1.0, 1.0, 1.0)), resolution: 24),
    root: Cvg((op: Intersection, operands: [
        Cvg((op: Difference, operands: [
            Volume((path: "ball.binvox", colour: (0.2, 0.4, 0.9))),
            Object(shape: Box(min: (0.0, 0.0, 0.0), max: (1.0, 1.0, 1.0))),
        ])),
        Fuzzy((core: Sphere(center: (0.1, 0.0, 0.0)), radius: 1.2)),
    ])),
    {VIEW}
    outputs: (images: [(name: "baked", camera: "c", mode: Iso(value: 0.5), width: 16, height: 16)]),
)"#
    );
    let path = dir.path().join("mixture.ron");
    std::fs::write(&path, scene).unwrap();
    let scene = volga_scene::load_scene(&path).unwrap();
    let baked = scene.root.bake(&scene.grid, true, &NoProgress).unwrap();
    let lazy = scene.root.lazy_field(&scene.grid).unwrap();
    let mut inside = 0;
    for ijk in scene.grid.index_box().iter() {
        let p = scene.grid.transform.voxel_center(ijk);
        let v = if lazy.bounds().contains(p) {
            lazy.value(p)
        } else {
            lazy.background()
        };
        assert!(
            (baked.density.get(ijk) as f64 - v).abs() <= 1e-6,
            "{ijk}: {} vs {v}",
            baked.density.get(ijk)
        );
        inside += (v > 0.5) as u32;
    }
    assert!(inside > 100, "the mixture is not empty ({inside} voxels)");
    // The box cut the octant x, y, z > 0 away.
    assert!(baked.density.get(IVec3::new(16, 16, 16)) < 0.5);
    assert!(baked.density.get(IVec3::new(8, 8, 8)) > 0.5);
}
