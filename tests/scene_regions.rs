//! Scenes baked region by region: every region of every shipped scene (analytic shapes,
//! unions, tori, meshes with proven signs, ADFs, sculpts, CVG trees, solid textures and
//! hypertextures, voxel files) equals the same region of the whole bake **bit for bit**,
//! density and colour, for chunk shapes aligned to the 8³ bricks and not. The scenes are
//! the files in `scenes/` with their grids coarsened so the whole suite stays quick.

use std::path::{Path, PathBuf};

use volga::core::{IndexBox, SparseVolume};
use volga::glam::IVec3;
use volga::scene::nodes::Node;
use volga::scene::{bake_region, parse_ron, validate, SceneError};
use volga::NoProgress;

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
