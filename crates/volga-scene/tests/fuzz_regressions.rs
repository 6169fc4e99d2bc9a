//! Scenes found by fuzzing (fuzz/, docs/FUZZING.md): parsing, validating and planning
//! each must give a result or an error, never a panic.

use std::path::Path;

/// A triangle of ~1e19 world units (far beyond the grid) overflowed the per-triangle
/// brick estimate of `MeshVoxelizer::estimate_bricks` while planning (in release the
/// product wrapped, so the memory bound could come out too small).
#[test]
fn planning_a_huge_triangle_does_not_overflow() {
    let text = r#"Scene(
        grid: (bounds: (min: (-1.0, -1.0, -1.0), max: (1.0, 1.0, 2.0)), voxel_size: (0.25, 0.25, 0.5)),
        objects: [(shape: Triangles(
            vertices: [(9223372036854775807, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)],
            triangles: [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]))],
        cameras: [],
        outputs: (images: [], volumes: [(name: "v", colour: false)]),
    )"#;
    let path = Path::new("huge.ron");
    let file = volga_scene::parse_ron(path, text).unwrap();
    let scene = volga_scene::validate(path, &file).unwrap();
    let plan = volga_scene::plan::plan(&scene, Some(1 << 40)).unwrap();
    // The saturated estimate is capped by the grid's own few bricks (8×8×6 voxels and
    // the filter band round them), not wrapped to an arbitrary number.
    assert!(plan.memory.bricks_upper_bound < 64, "{:?}", plan.memory);
}
