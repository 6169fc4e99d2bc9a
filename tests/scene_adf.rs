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
