//! The scene as a node tree: the torus node (added in one node file over one geometry
//! file), lazy fields equal to baked volumes, and scenes that voxelize nothing.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use volga::scene::nodes::Node;
use volga::scene::{build, load_scene, BuildOptions, SceneError};
use volga::NoProgress;

const TORUS: &str = include_str!("../scenes/torus.ron");

fn scene_in(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("scene.ron");
    std::fs::write(&p, text).unwrap();
    p
}

/// torus.ron scaled down for test speed.
fn small_torus() -> String {
    TORUS
        .replace("resolution: 128", "resolution: 48")
        .replace("width: 384, height: 384", "width: 48, height: 48")
}

#[test]
fn lazy_tree_equals_the_baked_volume_at_every_voxel_centre() {
    let dir = tempfile::tempdir().unwrap();
    // Add an inline closed mesh so every leaf kind is in the union.
    let tetra = r#"Object(name: "tetra", shape: Triangles(vertices: [(0.6, 0.6, -0.4), (1.4, 0.6, -0.4), (0.6, 1.4, -0.4), (0.6, 0.6, 0.4)],
        triangles: [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]), colour: (0.2, 0.9, 0.3)),"#;
    let text = small_torus().replace(
        "        Object(name: \"ball\"",
        &format!("        {tetra}\n        Object(name: \"ball\""),
    );
    let scene = load_scene(&scene_in(dir.path(), &text)).unwrap();
    let kinds: Vec<_> = scene.root.children().iter().map(|c| c.kind()).collect();
    assert_eq!(kinds, ["torus", "mesh", "shape"]);

    let baked = scene.root.bake(&scene.grid, true, &NoProgress).unwrap();
    let lazy = scene.root.lazy_field(&scene.grid).unwrap();
    let colours = baked.colour.as_ref().unwrap();
    let (mut inside, mut band) = (0, 0);
    for ijk in scene.grid.index_box().iter() {
        let p = scene.grid.transform.index_to_world(ijk.as_dvec3());
        let (l, b) = (lazy.value(p), baked.density.get(ijk) as f64);
        assert!((l - b).abs() <= 1e-7, "{ijk}: lazy {l} vs baked {b}");
        if b > 0.0 {
            let lc = lazy.colour(p).unwrap();
            let bc = glam::Vec3::from(colours.get(ijk));
            assert!((lc - bc).abs().max_element() <= 1e-6, "{ijk}: colour {lc} vs {bc}");
        }
        inside += (b == 1.0) as u32;
        band += (b > 0.0 && b < 1.0) as u32;
    }
    // Not a vacuous comparison: every leaf reaches the grid.
    assert!(inside > 1000 && band > 1000, "{inside} inside, {band} in the band");
    // Each leaf is in the lazy union: deep inside the ball, the tube and the tetrahedron.
    for (name, p) in [
        ("ball", glam::DVec3::ZERO),
        ("ring", glam::DVec3::new(1.0, 0.0, 0.0)),
        ("tetra", glam::DVec3::new(0.8, 0.8, -0.2)),
    ] {
        assert_eq!(lazy.value(p), 1.0, "{name}");
    }
}

/// The filtered density integrates to the torus's volume 2π²Rr² plus the curvature
/// term of the ramp, (w²/3)·∫H dA = (w²/3)·2π²R (the Gaussian-curvature term vanishes:
/// ∫K dA = 0 on a torus). Checks the torus node end to end against theory.
#[test]
fn torus_node_bakes_to_its_analytic_volume() {
    let (major, minor) = (1.0, 0.35);
    let text = format!(
        "Scene(grid: (bounds: (min: (-1.5, -1.5, -0.5), max: (1.5, 1.5, 0.5)), resolution: 103),
          objects: [(shape: Torus(center: (0.0, 0.0, 0.0), axis: (0.0, 0.0, 1.0), major_radius: {major}, minor_radius: {minor}))],
          cameras: [(name: \"c\", eye: (0.0, 0.0, 5.0), target: (0.0, 0.0, 0.0), projection: Orthographic(height: 3.0))],
          outputs: (volumes: [(name: \"v\")]))"
    );
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(&scene_in(dir.path(), &text)).unwrap();
    let vol = scene.root.bake(&scene.grid, false, &NoProgress).unwrap();
    let h = scene.grid.transform.spacing();
    let cell = h.x * h.y * h.z;
    let sum: f64 = scene
        .grid
        .index_box()
        .iter()
        .map(|ijk| vol.density.get(ijk) as f64)
        .sum::<f64>()
        * cell;
    let w = h.length();
    let exact = 2.0 * PI * PI * major * minor * minor;
    let predicted = exact + w * w / 3.0 * 2.0 * PI * PI * major;
    let rel = (sum - predicted).abs() / exact;
    assert!(rel < 1e-3, "sum {sum}, predicted {predicted} (exact {exact}): {rel}");
    // The curvature term is resolved: it is several times the tolerance.
    assert!((predicted - exact) / exact > 5e-3);
}

#[test]
fn lazy_only_scene_voxelizes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let text = small_torus().replace(
        "            (name: \"torus_baked\", camera: \"front\", mode: Iso(value: 0.5, colour: FromVolume), width: 48, height: 48),\n",
        "",
    );
    assert!(!text.contains("torus_baked"));
    let report = build(
        &scene_in(dir.path(), &text),
        &BuildOptions {
            out_dir: dir.path().join("out"),
            memory_limit: None,
            stage_start: None,
            allow_outside_paths: false,
        },
        &NoProgress,
    )
    .unwrap();
    assert!(!report.plan.voxelize.enabled, "{:?}", report.plan.voxelize);
    // The lazy image reads colour from the nodes: no colour channel is planned.
    assert!(!report.plan.colour_channel);
    assert_eq!(report.voxels.active, 0);
    assert_eq!(report.plan.memory.bricks_upper_bound, 0);
    assert!(report.stages.iter().all(|s| s.name != "voxelize"));
    assert!(report.images[0].samples > 0);
    assert!(dir.path().join("out/torus_lazy.png").is_file());
}

#[test]
fn baked_and_lazy_images_agree() {
    let dir = tempfile::tempdir().unwrap();
    let report = build(
        &scene_in(dir.path(), &small_torus()),
        &BuildOptions {
            out_dir: dir.path().join("out"),
            memory_limit: None,
            stage_start: None,
            allow_outside_paths: false,
        },
        &NoProgress,
    )
    .unwrap();
    assert!(report.plan.voxelize.enabled);
    let read = |name: &str| {
        let file = std::fs::File::open(dir.path().join("out").join(name)).unwrap();
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        reader.next_frame(&mut buf).unwrap();
        buf
    };
    let (a, b) = (read("torus_baked.png"), read("torus_lazy.png"));
    // Trilinear reconstruction of the linear ramp vs the exact ramp: same silhouette
    // except at a few grazing pixels, shading within a few levels.
    let differing = a
        .chunks(4)
        .zip(b.chunks(4))
        .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.abs_diff(*y) > 12))
        .count();
    assert!(
        differing * 50 < a.len() / 4,
        "{differing} of {} pixels differ",
        a.len() / 4
    );
}

#[test]
fn torus_parameters_are_checked_with_field_paths() {
    let dir = tempfile::tempdir().unwrap();
    for (bad, field) in [
        ("minor_radius: 0.35", "minor_radius: 1.5"),
        ("axis: (0.0, 0.3, 1.0)", "axis: (0.0, 0.0, 0.0)"),
    ] {
        let text = small_torus().replace(bad, field);
        let err = load_scene(&scene_in(dir.path(), &text)).unwrap_err();
        let expected = if field.starts_with("axis") {
            "`root.Union[0].Object.shape.axis`"
        } else {
            "`root.Union[0].Object.shape.major_radius`"
        };
        assert!(matches!(err, SceneError::Invalid { .. }), "{err}");
        assert!(err.to_string().contains(expected), "{err}");
    }
    // Both `root` and `objects`, or neither: a clear error.
    let both = small_torus().replace("    root: Union(", "    objects: [],\n    root: Union(");
    assert!(load_scene(&scene_in(dir.path(), &both))
        .unwrap_err()
        .to_string()
        .contains("`root`"));
}
