//! The scene as a node tree: the torus node (added in one node file over one geometry
//! file), lazy fields equal to baked volumes, and scenes that voxelize nothing.
//!
//! Scenes baked region by region: every region of every shipped scene (analytic shapes,
//! unions, tori, meshes with proven signs, ADFs, sculpts, CVG trees, solid textures and
//! hypertextures, voxel files) equals the same region of the whole bake **bit for bit**,
//! density and colour, for chunk shapes aligned to the 8³ bricks and not. The scenes are
//! the files in `scenes/` with their grids coarsened so the whole suite stays quick.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use volga::core::{IndexBox, SparseVolume};
use volga::glam::IVec3;
use volga::scene::nodes::Node;
use volga::scene::{bake_region, build, load_scene, parse_ron, validate, BuildOptions, SceneError};
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

/// Every scene file shipped in `scenes/`.
fn scene_files() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut out = Vec::new();
    for dir in [root.clone(), root.join("cvg")] {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            // Stroke files (`Strokes(…)`, for `volga sculpt`) live beside the scenes.
            let is_scene =
                p.extension().is_some_and(|x| x == "ron") && !std::fs::read_to_string(&p).unwrap().contains("Strokes(");
            if is_scene {
                out.push(p);
            }
        }
    }
    out.sort();
    assert!(out.len() >= 10, "{out:?}");
    out
}

/// The scene at `path` with every grid `resolution` set to `n`, validated and resolved.
fn coarse(path: &Path, n: u32) -> volga::scene::Scene {
    let text = std::fs::read_to_string(path).unwrap();
    let re_start = "resolution:";
    let mut out = String::new();
    let mut rest = text.as_str();
    while let Some(k) = rest.find(re_start) {
        out.push_str(&rest[..k + re_start.len()]);
        rest = &rest[k + re_start.len()..];
        let digits = rest.trim_start().chars().take_while(|c| c.is_ascii_digit()).count();
        if digits > 0 {
            let skip = rest.len() - rest.trim_start().len() + digits;
            out.push_str(&format!(" {n}"));
            rest = &rest[skip..];
        }
    }
    out.push_str(rest);
    let file = parse_ron(path, &out).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut scene = validate(path, &file).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    // The figures share scenes/assets with the other scenes.
    scene.allow_outside_paths = true;
    scene
        .resolve(None)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    scene
}

fn tiles(dims: IVec3, shape: IVec3) -> Vec<IndexBox> {
    let counts = (dims + shape - 1) / shape;
    IndexBox::new(IVec3::ZERO, counts)
        .iter()
        .map(|c| IndexBox::new(c * shape, ((c + 1) * shape).min(dims)))
        .collect()
}

fn density_bits(v: &SparseVolume, ijk: IVec3) -> u32 {
    v.density.get(ijk).to_bits()
}

#[test]
fn every_region_of_every_scene_equals_the_whole_bake() {
    for path in scene_files() {
        let scene = coarse(&path, 36);
        let grid = scene.grid;
        let whole = scene.root.bake(&grid, true, &NoProgress).unwrap();
        let dims = grid.dims().as_ivec3();
        let mut checked = 0u64;
        for shape in [IVec3::splat(16), IVec3::new(11, 24, 7)] {
            for region in tiles(dims, shape) {
                let part = bake_region(&scene, &region, true, None, &NoProgress).unwrap();
                assert_eq!(part.grid.dims().as_ivec3(), region.max - region.min);
                for ijk in region.iter() {
                    let local = ijk - region.min;
                    assert_eq!(
                        density_bits(&part, local),
                        density_bits(&whole, ijk),
                        "{}: density at {ijk} in chunk {:?}..{:?}",
                        path.display(),
                        region.min,
                        region.max
                    );
                    let (a, b) = (
                        part.colour.as_ref().map(|c| c.get(local).map(f32::to_bits)),
                        whole.colour.as_ref().map(|c| c.get(ijk).map(f32::to_bits)),
                    );
                    assert_eq!(a, b, "{}: colour at {ijk}", path.display());
                    checked += 1;
                }
            }
        }
        assert!(
            whole.active_voxel_count() > 0,
            "{}: an empty bake proves nothing",
            path.display()
        );
        assert_eq!(checked, 2 * grid.voxel_count());
    }
}

#[test]
fn a_region_is_checked_before_any_work() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/hello.ron");
    let scene = coarse(&path, 24);
    let dims = scene.grid.dims().as_ivec3();
    let outside = IndexBox::new(IVec3::ZERO, dims + IVec3::Z);
    match bake_region(&scene, &outside, false, None, &NoProgress) {
        Err(SceneError::Invalid { field, message, .. }) => {
            assert_eq!(field, "region");
            assert!(message.contains("not inside the grid"), "{message}");
        }
        other => panic!("{other:?}"),
    }
    match bake_region(
        &scene,
        &IndexBox::new(IVec3::ZERO, dims),
        false,
        Some(1000),
        &NoProgress,
    ) {
        Err(SceneError::TooLarge { detail, .. }) => assert!(detail.contains("region"), "{detail}"),
        other => panic!("{other:?}"),
    }
}
