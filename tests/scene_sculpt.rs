//! The `Sculpt` scene operator: an object sampled into the octree and edited by strokes,
//! its lazy field equal to its baked volume, stroke errors naming their field path, and a
//! build writing its images.

use std::path::{Path, PathBuf};

use volga::scene::nodes::Node;
use volga::scene::{build, load_scene, BuildOptions};
use volga::NoProgress;

const SCENE: &str = include_str!("../scenes/sculpt.ron");

fn scene_in(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("scene.ron");
    std::fs::write(&p, text).unwrap();
    p
}

fn small() -> String {
    SCENE
        .replace("resolution: 128", "resolution: 40")
        .replace("width: 384, height: 384", "width: 40, height: 40")
}

#[test]
fn sculpt_node_lazy_equals_baked_and_the_strokes_apply() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(&scene_in(dir.path(), &small())).unwrap();
    // The scene's root wraps its node in a union of one.
    let kinds: Vec<_> = scene.root.children().iter().map(|c| c.kind()).collect();
    assert_eq!(kinds, ["sculpt"]);
    let baked = scene.root.bake(&scene.grid, true, &NoProgress).unwrap();
    let lazy = scene.root.lazy_field(&scene.grid).unwrap();
    let colours = baked.colour.as_ref().unwrap();
    let mut painted = 0;
    for ijk in scene.grid.index_box().iter() {
        let p = scene.grid.transform.index_to_world(ijk.as_dvec3());
        let (l, b) = (lazy.value(p), baked.density.get(ijk) as f64);
        assert!((l - b).abs() <= 1e-7, "{ijk}: lazy {l} vs baked {b}");
        if b > 0.0 {
            let c = colours.get(ijk);
            assert!((glam::Vec3::from(c) - lazy.colour(p).unwrap()).abs().max_element() <= 1e-6);
            painted += (c[2] > 0.7) as u32;
        }
    }
    assert!(painted > 0, "the paint stroke shows in the baked colours");
    // The carve removed the top of the ball; the ball is solid below it.
    assert_eq!(lazy.value(glam::DVec3::new(0.0, 0.7, 0.0)), 0.0);
    assert_eq!(lazy.value(glam::DVec3::new(0.0, -0.5, 0.0)), 1.0);
}

#[test]
fn stroke_errors_name_their_field_path_and_the_scene_builds() {
    let dir = tempfile::tempdir().unwrap();
    let bad = small().replace(
        "Sphere(center: (0.35, -0.3, 0.8), radius: 0.2)",
        "Sphere(center: (0.35, -0.3, 0.8), radius: -0.2)",
    );
    let e = load_scene(&scene_in(dir.path(), &bad)).unwrap_err().to_string();
    assert!(e.contains("root.Sculpt.strokes[2].tool"), "{e}");
    let out = dir.path().join("out");
    build(
        &scene_in(dir.path(), &small()),
        &BuildOptions {
            out_dir: out.clone(),
            memory_limit: None,
            stage_start: None,
            allow_outside_paths: false,
        },
        &NoProgress,
    )
    .unwrap();
    assert!(out.join("sculpt_baked.png").exists() && out.join("sculpt_lazy.png").exists());
    assert!(out.join("sculpt_mesh.ply").exists());
}

#[test]
fn a_mesh_output_of_any_object_is_a_closed_manifold_torus() {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"Scene(grid: (bounds: (min: (-1, -1, -1), max: (1, 1, 1)), resolution: 32),
        objects: [(shape: Torus(center: (0.05, 0, 0), axis: (0, 0.2, 1), major_radius: 0.6, minor_radius: 0.25))],
        cameras: [], outputs: (meshes: [(name: "torus", format: Obj),
            (name: "torus_dual", format: Obj, method: Dual, adaptivity: 0.3),
            (name: "torus_tetrahedra", format: Obj, method: Tetrahedra)]))"#;
    let out = dir.path().join("out");
    build(
        &scene_in(dir.path(), text),
        &BuildOptions {
            out_dir: out.clone(),
            memory_limit: None,
            stage_start: None,
            allow_outside_paths: false,
        },
        &NoProgress,
    )
    .unwrap();
    let mut triangles = Vec::new();
    for name in ["torus", "torus_dual", "torus_tetrahedra"] {
        let mesh = volga::mesh::load_obj(out.join(format!("{name}.obj"))).unwrap();
        let stats = mesh.edge_stats();
        assert_eq!((stats.boundary_edges, stats.non_manifold_edges), (0, 0), "{name}");
        let euler = stats.welded_vertices as i64 - stats.edges as i64 + mesh.triangle_count() as i64;
        assert_eq!(euler, 0, "{name}: a torus");
        triangles.push(mesh.triangle_count());
    }
    // Marching cubes: about a third of the tetrahedra's; the simplified dual mesh: fewer.
    assert!(
        triangles[0] * 2 < triangles[2] && triangles[1] < triangles[0],
        "{triangles:?}"
    );
    // An adaptivity out of bounds is refused naming the field.
    let bad = r#"Scene(grid: (bounds: (min: (-1, -1, -1), max: (1, 1, 1)), resolution: 8),
        objects: [(shape: Sphere(center: (0, 0, 0), radius: 0.5))],
        cameras: [], outputs: (meshes: [(name: "s", format: Obj, adaptivity: 11.0)]))"#;
    let e = build(
        &scene_in(dir.path(), bad),
        &BuildOptions {
            out_dir: dir.path().join("bad"),
            memory_limit: None,
            stage_start: None,
            allow_outside_paths: false,
        },
        &NoProgress,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("outputs.meshes[0].adaptivity"), "{e}");
}
