//! Voxelization objects in scene files: quadrics, capsules and meshes load, validate
//! with field paths, and build (scaled down for test speed).

use std::path::Path;

use volga::scene::nodes::Node;
use volga::scene::{build, load_scene, BuildOptions, SceneError};

const SHAPES: &str = include_str!("../scenes/shapes.ron");

/// shapes.ron written next to a copy of its mesh asset, so relative paths resolve.
fn scene_in(dir: &Path, text: &str) -> std::path::PathBuf {
    std::fs::create_dir_all(dir.join("assets")).unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/assets/spot.obj"),
        dir.join("assets/spot.obj"),
    )
    .unwrap();
    let p = dir.join("shapes.ron");
    std::fs::write(&p, text).unwrap();
    p
}

fn kinds(scene: &volga::scene::Scene) -> Vec<&'static str> {
    scene.root.children().iter().map(|c| c.kind()).collect()
}

fn solids(scene: &volga::scene::Scene) -> Vec<volga::voxelize::Solid> {
    scene.root.children().iter().filter_map(|c| c.as_solid()).collect()
}

#[test]
fn shapes_scene_builds_every_object_kind() {
    let dir = tempfile::tempdir().unwrap();
    let text = SHAPES
        .replace("resolution: 192", "resolution: 64")
        .replace("width: 640, height: 480", "width: 64, height: 48");
    let path = scene_in(dir.path(), &text);
    let scene = load_scene(&path).unwrap();
    let kinds = kinds(&scene);
    assert_eq!(kinds.iter().filter(|k| **k == "shape").count(), 8, "{kinds:?}");
    assert_eq!(kinds.iter().filter(|k| **k == "mesh").count(), 1, "{kinds:?}");
    let report = build(
        &path,
        &BuildOptions {
            out_dir: dir.path().join("out"),
            memory_limit: None,
            stage_start: None,
            allow_outside_paths: false,
        },
        &volga::NoProgress,
    )
    .unwrap();
    // Every object contributes voxels: more than the analytic solids alone.
    let solids_only =
        volga::voxelize::voxelize_solids(&scene.grid, &solids(&scene), false, &volga::NoProgress).active_voxel_count();
    assert!(
        report.voxels.active > solids_only + 1000,
        "{} vs {solids_only}",
        report.voxels.active
    );
    assert!(dir.path().join("out/shapes_iso.png").is_file());
    // The plan's bound covers the volume built (the mesh's through MeshJob::estimate).
    assert!(
        report.plan.memory.volume_bytes >= report.voxels.volume_memory_bytes,
        "{} < {}",
        report.plan.memory.volume_bytes,
        report.voxels.volume_memory_bytes
    );
}

fn expect_field(text: &str, field: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = scene_in(dir.path(), text);
    match load_scene(&path) {
        Err(e @ SceneError::Invalid { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains(&format!("`{field}`")), "{msg}");
            msg
        }
        other => panic!("expected an invalid {field}, got {other:?}"),
    }
}

#[test]
fn missing_mesh_names_the_field_and_the_file() {
    let msg = expect_field(
        &SHAPES.replace("assets/spot.obj", "assets/nothere.obj"),
        "objects[0].shape.path",
    );
    assert!(msg.contains("nothere.obj"), "{msg}");
}

#[test]
fn bad_quadric_parameters_name_their_field() {
    expect_field(
        &SHAPES.replace("half_angle_deg: 22.0", "half_angle_deg: 95.0"),
        "objects[3].shape.half_angle_deg",
    );
    expect_field(
        &SHAPES.replace("axis: (0.3, 1.0, 0.2)", "axis: (0.0, 0.0, 0.0)"),
        "objects[2].shape.axis",
    );
    expect_field(
        &SHAPES.replace("radii: (0.55, 0.3, 0.4)", "radii: (0.55, -0.3, 0.4)"),
        "objects[1].shape.radii[1]",
    );
    expect_field(
        &SHAPES.replace("radius: 0.06), colour", "radius: 0.0), colour"),
        "objects[5].shape.radius",
    );
    expect_field(&SHAPES.replace("scale: 0.8", "scale: -0.8"), "objects[0].shape.scale");
}

#[test]
fn inline_triangles_are_a_solid_and_bad_indices_name_the_field() {
    // A closed tetrahedron given inline, outward oriented.
    let tetra = r#"(name: "tetra", shape: Triangles(vertices: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)],
        triangles: [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]), colour: (1.0, 0.0, 0.0)),"#;
    let text = SHAPES.replace(
        "        (name: \"spot\"",
        &format!("        {tetra}\n        (name: \"spot\""),
    );
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(&scene_in(dir.path(), &text)).unwrap();
    assert_eq!(kinds(&scene).iter().filter(|k| **k == "mesh").count(), 2);
    // Inline triangles need no resolving: their bounds are the tetrahedron's.
    let tetra = scene.root.children().iter().find(|c| c.name() == "tetra").unwrap();
    assert_eq!(tetra.kind(), "mesh");
    assert_eq!(tetra.bounds(), volga::Aabb::new(glam::DVec3::ZERO, glam::DVec3::ONE));
    expect_field(&text.replace("(1, 2, 3)]", "(1, 2, 9)]"), "objects[0].shape.triangles");
    expect_field(
        &text.replace("(0.0, 0.0, 1.0)]", "(0.0, 0.0, NaN)]"),
        "objects[0].shape.vertices[3]",
    );
}
