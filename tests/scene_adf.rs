//! The `Adf` scene node: ADFs built from a mesh and a shape, their lazy field equal to
//! their baked volume, within the ADF tolerance of the exact shape's filtered density, and
//! option errors naming their field path.

use std::path::{Path, PathBuf};

use glam::DVec3;
use volga::scene::load_scene;
use volga::scene::nodes::Node;
use volga::shapes::{Cylinder, OrientedBoxFilter, SignedDistance};
use volga::NoProgress;

const SCENE: &str = include_str!("../scenes/adf.ron");

fn scene_in(dir: &Path, text: &str) -> PathBuf {
    std::fs::create_dir_all(dir.join("assets")).unwrap();
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/assets/spot.obj"),
        dir.join("assets/spot.obj"),
    )
    .unwrap();
    let p = dir.join("scene.ron");
    std::fs::write(&p, text).unwrap();
    p
}

fn small() -> String {
    SCENE
        .replace("resolution: 128", "resolution: 40")
        .replace("tolerance: 1e-3, max_depth: 9", "tolerance: 1e-2, max_depth: 7")
}

#[test]
fn adf_nodes_bake_what_they_render_within_the_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(&scene_in(dir.path(), &small())).unwrap();
    let kinds: Vec<_> = scene.root.children().iter().map(|c| c.kind()).collect();
    assert_eq!(kinds, ["adf", "adf"]);
    let baked = scene.root.bake(&scene.grid, false, &NoProgress).unwrap();
    let lazy = scene.root.lazy_field(&scene.grid).unwrap();
    // The post alone, against its exact distance through the same filter.
    let post = Cylinder::new(DVec3::new(0.0, -0.85, 0.0), DVec3::Y, 0.25, Some(0.3)).unwrap();
    let post_node = &scene.root.children()[1];
    let post_field = post_node.lazy_field(&scene.grid).unwrap();
    let filter = OrientedBoxFilter::for_spacing(scene.grid.transform.spacing());
    let tolerance = 1e-3 * post.bounds().size().length();
    let slope = 1.0 / (2.0 * filter.half_width());
    let mut inside = 0;
    for ijk in scene.grid.index_box().iter() {
        let p = scene.grid.transform.index_to_world(ijk.as_dvec3());
        let (l, b) = (lazy.value(p), baked.density.get(ijk) as f64);
        assert!((l - b).abs() <= 1e-6, "{ijk}: lazy {l} vs baked {b}");
        inside += (b >= 0.5) as usize;
        let exact = filter.density(post.signed_distance(p));
        let got = post_field.value(p);
        // Pruned cells (far from the surface) are saturated on both sides.
        assert!(
            (got - exact).abs() <= tolerance * slope + 1e-9,
            "{p}: ADF {got} vs exact {exact}"
        );
    }
    assert!(inside > 500, "{inside} voxels inside");
}

#[test]
fn adf_option_errors_name_their_field_path() {
    let dir = tempfile::tempdir().unwrap();
    for (from, to, field) in [
        (
            "tolerance: 1e-2, max_depth: 7",
            "tolerance: -1.0, max_depth: 7",
            "root.Union[0].Adf.tolerance",
        ),
        (
            "tolerance: 1e-2, max_depth: 7",
            "tolerance: 1e-2, max_depth: 40",
            "root.Union[0].Adf.max_depth",
        ),
        ("radius: 0.25", "radius: -0.25", "root.Union[1].Adf.source"),
        ("assets/spot.obj", "assets/missing.obj", "root.Union[0].Adf.source.path"),
    ] {
        let text = small().replace(from, to);
        assert_ne!(text, small(), "{from}");
        let e = load_scene(&scene_in(dir.path(), &text)).unwrap_err().to_string();
        assert!(e.contains(field), "{field}: {e}");
    }
}

#[test]
fn an_unbounded_source_is_named_as_such() {
    // Regression (issue 28): an infinite cylinder was refused as a bad tolerance
    // ("got inf", its diagonal being infinite).
    let dir = tempfile::tempdir().unwrap();
    let text = small().replace("radius: 0.25, half_length: 0.3", "radius: 0.25");
    assert_ne!(text, small());
    let e = load_scene(&scene_in(dir.path(), &text)).unwrap_err().to_string();
    assert!(e.contains("root.Union[1].Adf.source") && e.contains("unbounded"), "{e}");
    assert!(!e.contains("inf"), "{e}");
}

/// The scene with spot's ADF at `tolerance` (default depth 10), validated and resolved
/// under `limit` bytes, then planned.
fn plan_spot(dir: &Path, tolerance: &str, limit: u64) -> Result<volga::scene::plan::Plan, String> {
    let text = small().replace("tolerance: 1e-2, max_depth: 7", &format!("tolerance: {tolerance}"));
    let mut scene = volga::scene::validate_scene(&scene_in(dir, &text)).map_err(|e| e.to_string())?;
    scene.resolve(Some(limit)).map_err(|e| e.to_string())?;
    volga::scene::plan::plan(&scene, Some(limit)).map_err(|e| e.to_string())
}

#[test]
fn a_tolerance_the_memory_cannot_hold_is_refused_before_the_build() {
    // Regression (issue 28): an `Adf` node at 1e-12 under --memory-limit 1G was planned
    // without its cells and ran on (4 GB after 60 s). Its estimated build alone is now
    // refused when the scene is resolved, naming the field, the cells and bytes needed
    // and the limit.
    let dir = tempfile::tempdir().unwrap();
    let e = plan_spot(dir.path(), "1e-12", 1 << 30).unwrap_err();
    assert!(e.contains("root.Union[0].Adf.tolerance") && e.contains("cells"), "{e}");
    assert!(e.contains("1.00 GiB"), "{e}");
    // Within the limit alone, yet not with the grid's band (the tolerance must hold in
    // the filter's ramp, which keeps more cells): the plan counts the ADF's build among
    // the nodes' data and refuses the whole.
    let e = plan_spot(dir.path(), "1e-12", 3 << 30).unwrap_err();
    assert!(e.contains("ADF builds") && e.contains("3.00 GiB"), "{e}");
    // A coarse tolerance is planned, its ADF counted.
    let plan = plan_spot(dir.path(), "1e-2", 3 << 30).unwrap();
    assert!(plan.memory.nodes_bytes > 0, "{:?}", plan.memory);
}

/// Records the stages a progress is told of.
#[derive(Default)]
struct Stages(std::sync::Mutex<Vec<String>>);

impl volga::core::Progress for Stages {
    fn start(&self, stage: &str, _total: u64) {
        self.0.lock().unwrap().push(stage.to_owned());
    }
    fn inc(&self, _n: u64) {}
    fn finish(&self) {}
}

#[test]
fn baking_an_adf_node_reports_its_build() {
    // Regression (issue 28): the `Adf` node's build showed no progress.
    let dir = tempfile::tempdir().unwrap();
    let scene = load_scene(&scene_in(dir.path(), &small())).unwrap();
    let stages = Stages::default();
    scene.root.children()[1].bake(&scene.grid, false, &stages).unwrap();
    assert!(
        stages.0.lock().unwrap().iter().any(|s| s == "adf cells"),
        "{:?}",
        stages.0
    );
}

/// The baked `Adf` node of an open, self-intersecting mesh (the teapot) against the
/// brute-force winding number and exact distance at every voxel. The bake is the ADF's
/// reconstruction through the filter (lazy equals baked), so it keeps the ADF's sign
/// promise (docs/ADF.md, "What the sign promises"): a wrong side lies where the true
/// side changes within the voxel's leaf, here within the tolerance of the mesh or where
/// `w` is within 0.05 of ½ (the jump across the spout's and lid's openings). Away from
/// those, the baked density is within the tolerance (over the filter's slope) of the
/// exact distance's.
#[test]
fn a_baked_open_mesh_keeps_the_adf_sign_promise_and_its_tolerance() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("assets")).unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/teapot.obj");
    std::fs::copy(&data, dir.path().join("assets/teapot.obj")).unwrap();
    let mesh = volga::mesh::load_mesh(&data).unwrap();
    let bounds = mesh
        .bounds()
        .expanded(DVec3::splat(0.05 * mesh.bounds().size().max_element()));
    let (lo, hi) = (bounds.min, bounds.max);
    let text = format!(
        "Scene(grid: (bounds: (min: ({}, {}, {}), max: ({}, {}, {})), resolution: 56),
         root: Adf((source: Mesh(path: \"assets/teapot.obj\"), tolerance: 2e-3, max_depth: 8)),
         lights: [(direction: (0.5, 0.9, 0.7))],
         cameras: [(name: \"front\", eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), projection: Perspective(fov_deg: 40.0))],
         outputs: (volumes: [(name: \"teapot\", colour: false)]))",
        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
    );
    let path = dir.path().join("scene.ron");
    std::fs::write(&path, text).unwrap();
    let scene = load_scene(&path).unwrap();
    let baked = scene.root.bake(&scene.grid, false, &NoProgress).unwrap();
    let filter = OrientedBoxFilter::for_spacing(scene.grid.transform.spacing());
    let slope = 1.0 / (2.0 * filter.half_width());
    let tolerance = 2e-3 * mesh.bounds().size().length();
    let bvh = volga::mesh::Bvh::build(&mesh);
    let (mut voxels, mut wrong, mut near_jump, mut worst) = (0, 0, 0, 0.0f64);
    for ijk in scene.grid.index_box().iter() {
        let p = scene.grid.transform.index_to_world(ijk.as_dvec3());
        let b = baked.density.get(ijk) as f64;
        let w = bvh.winding_number_exact(p);
        let d = bvh.closest(p).map_or(f64::INFINITY, |c| c.distance);
        voxels += 1;
        if (b >= 0.5) != (w >= 0.5) {
            wrong += 1;
            assert!(
                d <= tolerance || (w - 0.5).abs() <= 0.05,
                "{ijk}: baked {b} but w = {w}, {:.2} tolerances from the mesh",
                d / tolerance
            );
            continue;
        }
        if (w - 0.5).abs() <= 0.05 {
            near_jump += 1; // the jump's place is the sign field's, not the distance's
            continue;
        }
        let exact = filter.density(if w >= 0.5 { -d } else { d });
        worst = worst.max((b - exact).abs() / (tolerance * slope));
    }
    eprintln!("teapot bake: {voxels} voxels, {wrong} wrong sides, {near_jump} right within 0.05 of w = ½, worst error {worst:.3} tolerances");
    assert!(worst <= 1.0, "baked density off by {worst} tolerances");
}
