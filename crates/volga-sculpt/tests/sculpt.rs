//! The sculpting session against exact references: a dense voxel grid edited by the same
//! per-voxel rule, undo, collapse, files, meshes, threads and the hard cases (docs/SCULPT.md, Tests).

use std::collections::HashMap;

use glam::{DQuat, DVec3, IVec3};
use proptest::prelude::*;
use volga_core::{Aabb, Field};
use volga_sculpt::{Operation, Pose, Sculpt, SculptGrid, Stroke, Tool, ToolShape, Voxel};
use volga_shapes::{AxisBox, FilteredDensity, OrientedBoxFilter, Shape, Sphere};

const CLAY: [f32; 3] = [0.8, 0.7, 0.6];

fn block(grid: SculptGrid, lo: f64, hi: f64) -> Sculpt {
    let h = grid.spacing();
    let o = grid.origin();
    let b = FilteredDensity::new(
        AxisBox::new(o + DVec3::splat(lo * h), o + DVec3::splat(hi * h)).unwrap(),
        OrientedBoxFilter::for_spacing(DVec3::splat(h)),
    );
    Sculpt::from_field(grid, &b, CLAY)
}

fn sphere(c: DVec3, r: f64, op: Operation) -> Stroke {
    Stroke::new(Tool::sphere(c, r).unwrap(), op).unwrap()
}

/// The brute-force reference: every voxel stored, every stroke applied to every voxel.
struct Dense {
    grid: SculptGrid,
    voxels: Vec<Voxel>,
}

impl Dense {
    fn of(s: &Sculpt) -> Dense {
        let n = s.grid().dims();
        let voxels = (0..n * n * n)
            .map(|k| s.voxel(IVec3::new(k % n, (k / n) % n, k / (n * n))).unwrap())
            .collect();
        Dense {
            grid: *s.grid(),
            voxels,
        }
    }
    fn at(&self, ijk: IVec3) -> Option<Voxel> {
        let n = self.grid.dims();
        (ijk.cmpge(IVec3::ZERO).all() && ijk.cmplt(IVec3::splat(n)).all())
            .then(|| self.voxels[(ijk.x + n * (ijk.y + n * ijk.z)) as usize])
    }
    fn apply(&mut self, stroke: &Stroke) {
        let n = self.grid.dims();
        let old = self.voxels.clone();
        let get = |ijk: IVec3| -> f64 {
            if ijk.cmpge(IVec3::ZERO).all() && ijk.cmplt(IVec3::splat(n)).all() {
                old[(ijk.x + n * (ijk.y + n * ijk.z)) as usize].density as f64
            } else {
                0.0
            }
        };
        for (k, voxel) in self.voxels.iter_mut().enumerate() {
            let ijk = IVec3::new(k as i32 % n, (k as i32 / n) % n, k as i32 / (n * n));
            let mut sum = 0.0;
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        sum += get(ijk + IVec3::new(dx, dy, dz));
                    }
                }
            }
            *voxel = stroke.voxel_after(&self.grid, ijk, old[k], sum / 27.0);
        }
    }
    /// Trilinear density, background 0 (the reference for the sculpt's `Field::value`).
    fn value(&self, world: DVec3) -> f64 {
        let idx = (world - self.grid.origin()) / self.grid.spacing();
        let lo = idx.floor();
        let f = idx - lo;
        let mut v = 0.0;
        for c in 0..8 {
            let o = IVec3::new(c & 1, c >> 1 & 1, c >> 2 & 1);
            let w = (if o.x == 0 { 1.0 - f.x } else { f.x })
                * (if o.y == 0 { 1.0 - f.y } else { f.y })
                * (if o.z == 0 { 1.0 - f.z } else { f.z });
            v += w * self.at(lo.as_ivec3() + o).map_or(0.0, |x| x.density as f64);
        }
        v
    }
}

fn assert_same_voxels(s: &Sculpt, d: &Dense) {
    let n = s.grid().dims();
    for k in 0..n * n * n {
        let ijk = IVec3::new(k % n, (k / n) % n, k / (n * n));
        assert_eq!(s.voxel(ijk).unwrap(), d.at(ijk).unwrap(), "voxel {ijk}");
    }
}

#[test]
fn carve_then_undo_restores_the_octree_exactly_and_redo_reapplies() {
    let grid = SculptGrid::new(DVec3::new(-3.0, 1.0, 2.0), 0.5, 3).unwrap();
    let mut s = block(grid, 10.0, 50.0);
    let start = s.clone();
    let report = s.apply(&sphere(
        grid.voxel_center(IVec3::new(30, 30, 10)),
        7.0,
        Operation::Carve,
    ));
    let after = s.clone();
    assert!(report.changed_voxels.is_some());
    assert!(!s.same_tree(&start));
    assert!(s.history_bytes() > 0);
    assert!(s.undo());
    assert!(s.same_tree(&start), "structure and values restored");
    assert_same_voxels(&s, &Dense::of(&start));
    assert!(s.redo());
    assert!(s.same_tree(&after));
    assert!(!s.redo());
    // A history step costs the changed subtrees, far less than the tree.
    assert!(
        s.history_bytes() < s.stats().bytes,
        "{} vs {}",
        s.history_bytes(),
        s.stats().bytes
    );
}

#[derive(Debug, Clone)]
enum Op {
    Carve,
    Add,
    Spray(f64, f64),
    Paint(f64),
    Smooth(f64),
}

fn op_strategy() -> impl Strategy<Value = Op> {
    prop_oneof![
        Just(Op::Carve),
        Just(Op::Add),
        (0.1..1.0f64, 0.0..3.0f64).prop_map(|(s, f)| Op::Spray(s, f)),
        (0.1..1.0f64).prop_map(Op::Paint),
        (0.1..1.0f64).prop_map(Op::Smooth),
    ]
}

fn stroke_from(op: &Op, centre: DVec3, size: f64, boxy: bool, angle: f64, grid: &SculptGrid) -> Stroke {
    let c = grid.origin() + centre * grid.spacing();
    let r = size * grid.spacing();
    let tool = if boxy {
        let shape = Shape::AxisBox(AxisBox::new(DVec3::splat(-r), DVec3::new(r, r * 0.5, r * 0.7)).unwrap());
        Tool::new(
            ToolShape::Shape(shape),
            Pose::new(DQuat::from_rotation_y(angle), c).unwrap(),
        )
        .unwrap()
    } else {
        Tool::sphere(c, r).unwrap()
    };
    let operation = match *op {
        Op::Carve => Operation::Carve,
        Op::Add => Operation::Add,
        Op::Spray(strength, f) => Operation::Spray {
            strength,
            falloff_world: f * grid.spacing(),
        },
        Op::Paint(strength) => Operation::Paint {
            colour: [0.2, (strength * 0.5) as f32, 0.9],
            strength,
        },
        Op::Smooth(strength) => Operation::Smooth { strength },
    };
    Stroke::new(tool, operation).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// After random strokes the octree holds the dense reference's voxels bit for bit,
    /// samples like it to 1e-6, and is canonical (collapsed); undoing every stroke gives
    /// the starting tree back.
    #[test]
    fn random_strokes_match_a_dense_grid(
        strokes in proptest::collection::vec(
            (op_strategy(), (-6.0..38.0f64, -6.0..38.0f64, -6.0..38.0f64), 0.3..12.0f64, any::<bool>(), 0.0..3.0f64),
            1..6),
        probes in proptest::collection::vec((-2.0..34.0f64, -2.0..34.0f64, -2.0..34.0f64), 20),
    ) {
        let grid = SculptGrid::new(DVec3::new(0.25, -1.0, 3.0), 0.5, 2).unwrap(); // 32³
        let mut s = block(grid, 6.0, 24.0);
        let start = s.clone();
        let mut dense = Dense::of(&s);
        for (op, (x, y, z), size, boxy, angle) in &strokes {
            let stroke = stroke_from(op, DVec3::new(*x, *y, *z), *size, *boxy, *angle, &grid);
            s.apply(&stroke);
            dense.apply(&stroke);
        }
        assert_same_voxels(&s, &dense);
        prop_assert!(s.is_canonical());
        for (x, y, z) in probes {
            let p = grid.origin() + DVec3::new(x, y, z) * grid.spacing();
            prop_assert!((s.value(p) - dense.value(p)).abs() <= 1e-6, "at {p}");
        }
        while s.undo() {}
        prop_assert!(s.same_tree(&start));
    }
}

#[test]
fn carving_then_spraying_the_same_tool_collapses_back() {
    let grid = SculptGrid::new(DVec3::ZERO, 1.0, 3).unwrap();
    let mut s = block(grid, 4.0, 60.0);
    let start = s.clone();
    let nodes = s.stats().nodes();
    let tool = Tool::sphere(DVec3::new(30.3, 29.1, 31.7), 9.5).unwrap();
    s.apply(&Stroke::new(tool.clone(), Operation::Carve).unwrap());
    assert!(s.stats().nodes() > nodes, "the carve inserts detail");
    s.apply(
        &Stroke::new(
            tool,
            Operation::Spray {
                strength: 1.0,
                falloff_world: 0.0,
            },
        )
        .unwrap(),
    );
    assert_eq!(s.stats().nodes(), nodes, "children collapse when homogeneous again");
    assert!(s.same_tree(&start));
}

#[test]
fn save_load_round_trip_and_damaged_files_are_refused() {
    let grid = SculptGrid::new(DVec3::new(1e6, -2.0, 0.5), 0.25, 2).unwrap();
    let mut s = block(grid, 5.0, 27.0);
    s.apply(&sphere(grid.voxel_center(IVec3::new(16, 16, 5)), 2.5, Operation::Carve));
    s.apply(
        &Stroke::new(
            Tool::sphere(grid.voxel_center(IVec3::new(10, 20, 16)), 2.0).unwrap(),
            Operation::Paint {
                colour: [0.1, 0.9, 0.2],
                strength: 0.7,
            },
        )
        .unwrap(),
    );
    let bytes = s.to_bytes();
    let back = Sculpt::from_bytes(&bytes).unwrap();
    assert!(back.same_tree(&s));
    assert_eq!(back.to_bytes(), bytes);

    let mut target = block(grid, 2.0, 9.0);
    let untouched = target.clone();
    // Every truncation is refused (the checksum or the length catches it).
    for len in (0..bytes.len()).step_by(97).chain([bytes.len() - 1, 11, 12, 40]) {
        let e = target.load_bytes(&bytes[..len]).unwrap_err();
        assert!(!e.to_string().is_empty());
        assert!(target.same_tree(&untouched));
    }
    // Single flipped bits anywhere are refused.
    for at in (0..bytes.len()).step_by(131).chain([0, 9, bytes.len() - 1]) {
        let mut bad = bytes.clone();
        bad[at] ^= 0x10;
        assert!(target.load_bytes(&bad).is_err(), "flip at {at} accepted");
        assert!(target.same_tree(&untouched));
    }
    let mut future = bytes.clone();
    future[8] = 2;
    assert!(matches!(
        Sculpt::from_bytes(&future),
        Err(volga_sculpt::FileError::Version { found: 2 })
    ));
    target.load_bytes(&bytes).unwrap();
    assert!(target.same_tree(&s));
}

fn check_manifold(mesh: &volga_mesh::TriMesh) {
    let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    assert!(!uses.is_empty());
    assert!(uses.values().all(|&n| n == 2), "every edge in exactly two faces");
}

#[test]
fn extracted_sculpt_meshes_are_closed_manifold_and_on_the_half_surface() {
    let grid = SculptGrid::new(DVec3::ZERO, 1.0, 2).unwrap();
    let mut s = block(grid, 5.0, 26.0);
    s.apply(&sphere(DVec3::new(16.0, 16.0, 26.0), 6.0, Operation::Carve));
    s.apply(&sphere(DVec3::new(16.0, 16.0, 3.0), 4.0, Operation::Add));
    let surface = s.surface(1.0).unwrap();
    check_manifold(&surface.mesh);
    assert!(surface.blocks_sampled > 0);
    for p in &surface.mesh.positions {
        assert!((s.value(*p) - 0.5).abs() <= 1e-6, "vertex {p} off the ½ surface");
    }
}

#[test]
fn edits_are_identical_for_1_and_2_threads() {
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let grid = SculptGrid::new(DVec3::ZERO, 1.0, 4).unwrap(); // 128³: parallel levels
                let mut s = block(grid, 4.0, 124.0);
                // The first box covers the whole 128³ grid: large enough to run on several threads.
                let mut reports = vec![s.apply(&sphere(DVec3::splat(64.0), 62.0, Operation::Carve))];
                reports.push(s.apply(&sphere(
                    DVec3::new(30.0, 64.0, 64.0),
                    20.0,
                    Operation::Smooth { strength: 0.8 },
                )));
                reports.push(
                    s.apply(
                        &Stroke::new(
                            Tool::sphere(DVec3::new(64.0, 100.0, 64.0), 30.0).unwrap(),
                            Operation::Paint {
                                colour: [1.0, 0.0, 0.0],
                                strength: 1.0,
                            },
                        )
                        .unwrap(),
                    ),
                );
                (s.to_bytes(), reports)
            })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn a_tool_larger_than_the_object_removes_it_and_the_tree_collapses_to_one_node() {
    let grid = SculptGrid::new(DVec3::ZERO, 1.0, 3).unwrap();
    let mut s = block(grid, 20.0, 40.0);
    s.apply(&sphere(DVec3::splat(30.0), 200.0, Operation::Carve));
    assert_eq!(s.stats().nodes(), 1);
    assert_eq!(s.voxel(IVec3::splat(30)).unwrap().density, 0.0);
}

#[test]
fn a_sub_voxel_tool_changes_a_few_voxels_by_a_bounded_amount() {
    let grid = SculptGrid::new(DVec3::ZERO, 1.0, 2).unwrap();
    let mut s = block(grid, 4.0, 28.0);
    let c = DVec3::new(16.3, 16.1, 15.8);
    let report = s.apply(&sphere(c, 0.2, Operation::Carve));
    let changed = report.changed_voxels.unwrap();
    assert!(changed.volume() <= 64, "{changed:?}");
    // Deepest dent: a voxel centre is at distance ≥ −0.2 from the tool, where the filter's
    // density is at most ½ + 0.2/(2√3), so no voxel drops below 1 − that.
    let floor = 0.5 - 0.2 / (2.0 * 3f64.sqrt()) - 1e-7;
    let mut dented = 0;
    for ijk in changed.iter() {
        let d = s.voxel(ijk).unwrap().density as f64;
        assert!(d.is_finite() && d >= floor && d <= 1.0, "{ijk}: {d}");
        dented += (d < 1.0) as u32;
    }
    assert!(dented >= 8, "the voxels around the tool are dented ({dented})");
}

#[test]
fn strokes_at_maximum_depth_stay_local() {
    // 8·2^17 = 1 048 576 voxels per axis: a carve builds one path of 17 levels.
    let grid = SculptGrid::new(DVec3::ZERO, 1.0, volga_sculpt::MAX_LEVELS).unwrap();
    let mut s = Sculpt::empty(grid, CLAY);
    let deep = DVec3::new(1_048_000.5, 3.25, 524_288.0);
    s.apply(&sphere(deep, 3.0, Operation::Add));
    let st = s.stats();
    // The tool's box (6 voxels plus the filter band) meets at most 3 bricks per axis:
    // at most 27 bricks, each on a path of 17 branches.
    assert!(
        st.branches >= 17 && st.bricks >= 1 && st.bricks <= 27 && st.branches <= 17 * 27,
        "{st:?}"
    );
    assert!(st.bytes < 200_000, "{st:?}");
    assert!((s.value(deep) - 1.0).abs() < 1e-12);
    assert!(s.value(deep + DVec3::X * 10.0) == 0.0);
    s.apply(&sphere(deep, 3.0, Operation::Carve));
    assert!(s.value(deep) < 0.5);
    // A tool straddling the grid's far corner is clipped, not an error.
    let r = s.apply(&sphere(DVec3::splat(1_048_576.0), 5.0, Operation::Add));
    assert!(r.changed_voxels.unwrap().max.cmple(IVec3::splat(grid.dims())).all());
}

#[test]
fn a_stroke_far_outside_the_object_creates_no_nodes() {
    let grid = SculptGrid::new(DVec3::ZERO, 1.0, 3).unwrap();
    let mut s = block(grid, 10.0, 20.0);
    let before = s.clone();
    for c in [DVec3::new(50.0, 50.0, 50.0), DVec3::splat(1e5), DVec3::splat(-300.0)] {
        let r = s.apply(&sphere(c, 4.0, Operation::Carve));
        assert_eq!(r.changed_voxels, None);
        assert_eq!(r.changed_world, None);
    }
    assert!(s.same_tree(&before));
    assert_eq!(s.undo_len(), 0, "nothing changed, nothing to undo");
}

#[test]
fn saw_paths_with_repeated_points_or_zero_length() {
    let grid = SculptGrid::new(DVec3::ZERO, 1.0, 3).unwrap();
    let base = block(grid, 8.0, 56.0);
    let blade = || Tool::sphere(DVec3::ZERO, 3.0).unwrap();
    let saw = |path: &[DVec3]| Stroke::new(blade().swept(path, 0.5).unwrap(), Operation::Carve).unwrap();
    // Zero length equals carving the sphere at that point.
    let p = DVec3::new(32.0, 32.0, 56.0);
    let (mut a, mut b) = (base.clone(), base.clone());
    a.apply(&saw(&[p, p, p]));
    b.apply(&sphere(p, 3.0, Operation::Carve));
    assert!(a.same_tree(&b));
    // Repeated points change nothing compared with the path without them.
    let path = [
        DVec3::new(20.0, 32.0, 56.0),
        DVec3::new(44.0, 32.0, 56.0),
        DVec3::new(44.0, 40.0, 50.0),
    ];
    let repeated = [path[0], path[0], path[1], path[1], path[1], path[2], path[2]];
    let (mut c, mut d) = (base.clone(), base.clone());
    c.apply(&saw(&path));
    d.apply(&saw(&repeated));
    assert!(c.same_tree(&d));
    // The cut is smooth: along the groove's floor the density varies by less than 1 %.
    let floor: Vec<f64> = (0..40)
        .map(|k| c.value(DVec3::new(22.0 + k as f64 * 0.5, 32.0, 53.0)))
        .collect();
    let (lo, hi) = floor
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    assert!(hi - lo < 0.01, "{lo} .. {hi}");
}

#[test]
fn a_sculpt_far_from_the_origin_edits_like_one_at_the_origin() {
    let near = SculptGrid::new(DVec3::ZERO, 1.0, 2).unwrap();
    let far = SculptGrid::new(DVec3::splat(1e6), 1.0, 2).unwrap();
    let (mut a, mut b) = (block(near, 4.0, 28.0), block(far, 4.0, 28.0));
    let c = DVec3::new(16.25, 15.5, 26.0);
    a.apply(&sphere(c, 5.5, Operation::Carve));
    b.apply(&sphere(c + DVec3::splat(1e6), 5.5, Operation::Carve));
    let n = near.dims();
    for k in 0..n * n * n {
        let ijk = IVec3::new(k % n, (k / n) % n, k / (n * n));
        let (x, y) = (a.voxel(ijk).unwrap().density, b.voxel(ijk).unwrap().density);
        assert!((x - y).abs() <= 1e-6, "{ijk}: {x} vs {y}");
    }
    let p = DVec3::new(16.0, 16.0, 21.0);
    assert!((a.value(p) - b.value(p + DVec3::splat(1e6))).abs() < 1e-6);
}

#[test]
fn value_range_is_conservative_and_bounds_hold_the_content() {
    let grid = SculptGrid::new(DVec3::new(0.5, 0.0, -1.0), 0.5, 2).unwrap();
    let mut s = block(grid, 6.0, 26.0);
    s.apply(&sphere(grid.voxel_center(IVec3::splat(16)), 4.0, Operation::Carve));
    let bounds = s.bounds();
    for k in 0..300 {
        let c = bounds.min
            + DVec3::new((k * 37 % 101) as f64, (k * 53 % 97) as f64, (k * 71 % 89) as f64) / 100.0 * bounds.size();
        let b = Aabb::new(c, c + DVec3::splat(0.3 + (k % 5) as f64));
        let (lo, hi) = s.value_range(&b);
        for t in 0..8 {
            let p = b.min + DVec3::new((t & 1) as f64, (t >> 1 & 1) as f64, (t >> 2) as f64) * b.size();
            let v = s.value(p);
            assert!(lo <= v && v <= hi, "{v} outside [{lo}, {hi}] at {p}");
        }
    }
    assert_eq!(s.value(bounds.min - DVec3::ONE), 0.0);
}

#[test]
fn sparse_volume_export_holds_the_same_voxels() {
    let grid = SculptGrid::new(DVec3::new(2.0, 3.0, 4.0), 0.5, 2).unwrap();
    let mut s = block(grid, 6.0, 26.0);
    s.apply(
        &Stroke::new(
            Tool::sphere(grid.voxel_center(IVec3::splat(8)), 3.0).unwrap(),
            Operation::Paint {
                colour: [0.0, 0.0, 1.0],
                strength: 1.0,
            },
        )
        .unwrap(),
    );
    let v = s.to_sparse_volume(true);
    let colour = v.colour.as_ref().unwrap();
    for ijk in grid.index_box().iter() {
        let x = s.voxel(ijk).unwrap();
        assert_eq!(v.density.get(ijk), x.density);
        if x.density != 0.0 {
            assert_eq!(colour.get(ijk), x.colour);
        }
    }
    let _ = Sphere::new(DVec3::ZERO, 1.0);
}
