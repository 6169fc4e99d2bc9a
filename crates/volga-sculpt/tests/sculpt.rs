//! The sculpting session against references: every operation against an independent dense
//! reference written from its documented definition (within a tolerance derived from the
//! f32 storage), a dense grid edited by the crate's own per-voxel rule (bit for bit: the
//! octree applies that rule everywhere), undo, collapse, files, meshes, threads and the hard
//! cases (docs/SCULPT.md, Tests).

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

    /// After random strokes the octree holds the dense grid's voxels bit for bit (the same
    /// per-voxel rule), samples like it to 1e-6, agrees with the independent reference
    /// within its tolerance, and is canonical (collapsed); undoing every stroke gives the
    /// starting tree back.
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
        let mut reference = Reference::block(&grid, 6.0, 24.0, CLAY);
        for (op, (x, y, z), size, boxy, angle) in &strokes {
            let stroke = stroke_from(op, DVec3::new(*x, *y, *z), *size, *boxy, *angle, &grid);
            s.apply(&stroke);
            dense.apply(&stroke);
            let (tool, op) = reference_from(op, DVec3::new(*x, *y, *z), *size, *boxy, *angle, &grid);
            reference.apply(&tool, op);
        }
        assert_same_voxels(&s, &dense);
        reference.assert_matches(&s, "random strokes");
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

// ── Independent references ────────────────────────────────────────────────────────────
//
// `Dense` above checks the octree against the crate's own per-voxel rule
// (`Stroke::voxel_after`), bit for bit: it proves the tree applies that rule everywhere
// (edit boxes, shortcuts, collapsing), not that the rule is the documented one. The
// `Reference` below is written from the definitions in docs/SCULPT.md and `edit.rs`'s
// module documentation, from scratch: its own tool distances (sphere; box rotated about y),
// its own filter ramp, its own operations, every stroke applied to every voxel of the grid
// in f64, and a start block sampled from the box's distance. No crate function computing a
// distance, a filter density or a voxel update is called.
//
//   t   = clamp(½ − d/W, 0, 1),  W = 2·(√3·h)           d: the tool's signed distance at the voxel centre
//   t_f = clamp(½ − d/W_f, 0, 1), W_f = 2·(√3·h + f)     spray: the half-width widened by the falloff f
//   carve  ρ' = min(ρ, 1 − t)        add    ρ' = max(ρ, t)       spray  ρ' = min(1, ρ + s·t_f)
//   paint  c' = c + (p − c)·s·t (ρ unchanged)
//   smooth ρ' = ρ + (ρ̄ − ρ)·s·t, ρ̄ the mean of the 3×3×3 block around the voxel (itself
//          included) before the stroke, 0 outside the grid
//
// Tolerance: the sculpt stores f32 and rounds each stroke's f64 result once, an error of at
// most half an ulp, 2⁻²⁵, for values in [0, 1] (densities and colours here); the start block
// is rounded once too. Every operation is 1-Lipschitz in the sup norm of what it reads
// (min, max, a clamped sum, convex blends — smoothing's mean included), so the errors of
// successive strokes add up and are never amplified. Evaluating the same distances by
// other means (a quaternion against the rotation written out here) differs by ~1e-15 of a
// voxel, far below 2⁻²⁵. So after k strokes every density and colour agrees to within
// (k + 1)·2⁻²⁴ (one f32 rounding per step, with a factor of 2 to spare for the f64 noise),
// and trilinear samples, convex combinations of voxels, to the same bound.
//
// The saw is a carve with a sphere of radius r swept along a polyline; the reference takes
// the exact sweep (distance to the polyline − r). The tool places copies at most `step`
// apart (documented: `Tool::swept`), so a point at distance D from the path is at most
// step/2 along it from a copy, and the copies' distance exceeds the sweep's by at most
// √(D² + step²/4) − D ≤ step²/(8D). Where the ramp is not saturated D ≥ r − √3·h, so the
// density differs by at most step²/(8(r − √3·h))/W more per saw stroke (W = 2√3·h); with
// step = h/2 that is the documented h²/(32r) surface error, taken over the filter band.

/// A tool's geometry, written out here.
#[derive(Debug, Clone)]
enum RefTool {
    Sphere {
        centre: DVec3,
        radius: f64,
    },
    /// The box `[lo, hi]` (its own frame) rotated by `angle` about the y axis, then moved to `at`.
    RotatedBox {
        lo: DVec3,
        hi: DVec3,
        angle: f64,
        at: DVec3,
    },
    /// The saw: a sphere of `radius` swept along the polyline `path` (exactly; the tool
    /// places copies `step` apart).
    Saw {
        path: Vec<DVec3>,
        radius: f64,
        step: f64,
    },
}

/// Distance from `p` to the segment from `a` to `b`.
fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let u = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * u)).length()
}

/// Exact signed distance to the box `[lo, hi]` (negative inside).
fn box_distance(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let q = (p - (lo + hi) * 0.5).abs() - (hi - lo) * 0.5;
    q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
}

impl RefTool {
    fn distance(&self, p: DVec3) -> f64 {
        match *self {
            RefTool::Sphere { centre, radius } => (p - centre).length() - radius,
            RefTool::RotatedBox { lo, hi, angle, at } => {
                // A rotation by θ about y maps (x, z) to (x cos θ + z sin θ, −x sin θ + z cos θ);
                // its inverse takes the world point into the box's frame.
                let q = p - at;
                let (s, c) = angle.sin_cos();
                box_distance(DVec3::new(c * q.x - s * q.z, q.y, s * q.x + c * q.z), lo, hi)
            }
            RefTool::Saw { ref path, radius, .. } => {
                let d = if path.len() == 1 {
                    (p - path[0]).length()
                } else {
                    path.windows(2)
                        .map(|w| segment_distance(p, w[0], w[1]))
                        .fold(f64::INFINITY, f64::min)
                };
                d - radius
            }
        }
    }
}

/// An operation with its parameters, as the documentation defines it.
#[derive(Debug, Clone, Copy)]
enum RefOp {
    Carve,
    Add,
    Spray { strength: f64, falloff: f64 },
    Paint { colour: [f64; 3], strength: f64 },
    Smooth { strength: f64 },
}

/// The oriented box filter's ramp of half-width `half`: 1 at `d = −half`, ½ at 0, 0 at `half`.
fn ramp(d: f64, half: f64) -> f64 {
    (0.5 - d / (2.0 * half)).clamp(0.0, 1.0)
}

/// Every voxel of the grid in f64, edited by the documented definitions.
#[derive(Clone)]
struct Reference {
    origin: DVec3,
    h: f64,
    n: i32,
    density: Vec<f64>,
    colour: Vec<[f64; 3]>,
    strokes: u32,
    /// Density the documented tool sampling may differ from the exact tools by (saws).
    slack: f64,
}

impl Reference {
    /// The solid box from `lo` to `hi` voxels (as `block` builds it), sampled through the
    /// ramp of half-width √3·h, coloured `colour`.
    fn block(grid: &SculptGrid, lo: f64, hi: f64, colour: [f32; 3]) -> Reference {
        let (origin, h, n) = (grid.origin(), grid.spacing(), grid.dims());
        let mut r = Reference {
            origin,
            h,
            n,
            density: Vec::new(),
            colour: vec![colour.map(f64::from); (n * n * n) as usize],
            strokes: 0,
            slack: 0.0,
        };
        let (b0, b1) = (origin + DVec3::splat(lo * h), origin + DVec3::splat(hi * h));
        r.density = (0..n * n * n)
            .map(|k| ramp(box_distance(r.centre(r.ijk(k)), b0, b1), 3f64.sqrt() * h))
            .collect();
        r
    }
    fn ijk(&self, k: i32) -> IVec3 {
        IVec3::new(k % self.n, (k / self.n) % self.n, k / (self.n * self.n))
    }
    fn centre(&self, ijk: IVec3) -> DVec3 {
        self.origin + ijk.as_dvec3() * self.h
    }
    /// Density at `ijk` in `density` (this grid's layout), 0 outside the grid.
    fn density_in(&self, density: &[f64], ijk: IVec3) -> f64 {
        let n = self.n;
        if ijk.cmpge(IVec3::ZERO).all() && ijk.cmplt(IVec3::splat(n)).all() {
            density[(ijk.x + n * (ijk.y + n * ijk.z)) as usize]
        } else {
            0.0
        }
    }
    fn apply(&mut self, tool: &RefTool, op: RefOp) {
        let band = 3f64.sqrt() * self.h;
        let half = match op {
            RefOp::Spray { falloff, .. } => band + falloff,
            _ => band,
        };
        let before = self.density.clone();
        for k in 0..self.n * self.n * self.n {
            let ijk = self.ijk(k);
            let t = ramp(tool.distance(self.centre(ijk)), half);
            let mut sum = 0.0;
            if let RefOp::Smooth { .. } = op {
                for dz in -1..=1 {
                    for dy in -1..=1 {
                        for dx in -1..=1 {
                            sum += self.density_in(&before, ijk + IVec3::new(dx, dy, dz));
                        }
                    }
                }
            }
            let (rho, c) = (&mut self.density[k as usize], &mut self.colour[k as usize]);
            match op {
                RefOp::Carve => *rho = rho.min(1.0 - t),
                RefOp::Add => *rho = rho.max(t),
                RefOp::Spray { strength, .. } => *rho = (*rho + strength * t).min(1.0),
                RefOp::Paint { colour, strength } => {
                    for i in 0..3 {
                        c[i] += (colour[i] - c[i]) * strength * t;
                    }
                }
                RefOp::Smooth { strength } => *rho += (sum / 27.0 - *rho) * strength * t,
            }
        }
        self.strokes += 1;
        if let RefTool::Saw { radius, step, .. } = *tool {
            assert!(radius > band, "the saw's bound needs r > √3·h");
            self.slack += step * step / (8.0 * (radius - band)) / (2.0 * band);
        }
    }
    /// The bound derived above: one f32 rounding per stroke and for the start, 2⁻²⁴ each,
    /// plus the saws' sampling.
    fn tolerance(&self) -> f64 {
        f64::from(self.strokes + 1) * 2f64.powi(-24) + self.slack
    }
    /// Trilinear density, background 0.
    fn value(&self, world: DVec3) -> f64 {
        let idx = (world - self.origin) / self.h;
        let lo = idx.floor();
        let f = idx - lo;
        let mut v = 0.0;
        for c in 0..8 {
            let o = IVec3::new(c & 1, c >> 1 & 1, c >> 2 & 1);
            let w = (if o.x == 0 { 1.0 - f.x } else { f.x })
                * (if o.y == 0 { 1.0 - f.y } else { f.y })
                * (if o.z == 0 { 1.0 - f.z } else { f.z });
            v += w * self.density_in(&self.density, lo.as_ivec3() + o);
        }
        v
    }
    /// Asserts every voxel of `s` (density and colour) within the tolerance of this reference.
    fn assert_matches(&self, s: &Sculpt, what: &str) {
        assert_eq!(s.grid().dims(), self.n);
        let tol = self.tolerance();
        let (mut worst, mut at) = (0.0f64, IVec3::ZERO);
        for k in 0..self.n * self.n * self.n {
            let ijk = self.ijk(k);
            let v = s.voxel(ijk).unwrap();
            let mut e = (f64::from(v.density) - self.density[k as usize]).abs();
            for i in 0..3 {
                e = e.max((f64::from(v.colour[i]) - self.colour[k as usize][i]).abs());
            }
            if e > worst {
                (worst, at) = (e, ijk);
            }
        }
        let k = (at.x + self.n * (at.y + self.n * at.z)) as usize;
        assert!(
            worst <= tol,
            "{what}: voxel {at} is {:?}, the reference has density {} colour {:?}: error {worst:e} > tolerance {tol:e}",
            s.voxel(at).unwrap(),
            self.density[k],
            self.colour[k]
        );
    }
    /// Voxels whose density or colour differs from `other`'s by more than `by`.
    fn changed_from(&self, other: &Reference, by: f64) -> usize {
        (0..self.density.len())
            .filter(|&k| {
                (self.density[k] - other.density[k]).abs() > by
                    || (0..3).any(|i| (self.colour[k][i] - other.colour[k][i]).abs() > by)
            })
            .count()
    }
}

/// The crate's stroke for a reference tool and operation (parameters only: the geometry
/// and the update are computed by the crate, the reference computes its own).
fn crate_stroke(tool: &RefTool, op: RefOp) -> Stroke {
    let tool = match tool {
        RefTool::Sphere { centre, radius } => Tool::sphere(*centre, *radius).unwrap(),
        RefTool::RotatedBox { lo, hi, angle, at } => Tool::new(
            ToolShape::Shape(Shape::AxisBox(AxisBox::new(*lo, *hi).unwrap())),
            Pose::new(DQuat::from_rotation_y(*angle), *at).unwrap(),
        )
        .unwrap(),
        RefTool::Saw { path, radius, step } => Tool::sphere(DVec3::ZERO, *radius).unwrap().swept(path, *step).unwrap(),
    };
    let operation = match op {
        RefOp::Carve => Operation::Carve,
        RefOp::Add => Operation::Add,
        RefOp::Spray { strength, falloff } => Operation::Spray {
            strength,
            falloff_world: falloff,
        },
        RefOp::Paint { colour, strength } => Operation::Paint {
            // The reference's colours are f32 values, so this is exact.
            colour: colour.map(|c| c as f32),
            strength,
        },
        RefOp::Smooth { strength } => Operation::Smooth { strength },
    };
    Stroke::new(tool, operation).unwrap()
}

/// The reference of `stroke_from`'s stroke (same parameters).
fn reference_from(op: &Op, centre: DVec3, size: f64, boxy: bool, angle: f64, grid: &SculptGrid) -> (RefTool, RefOp) {
    let (h, at) = (grid.spacing(), grid.origin() + centre * grid.spacing());
    let r = size * h;
    let tool = if boxy {
        RefTool::RotatedBox {
            lo: DVec3::splat(-r),
            hi: DVec3::new(r, r * 0.5, r * 0.7),
            angle,
            at,
        }
    } else {
        RefTool::Sphere { centre: at, radius: r }
    };
    let op = match *op {
        Op::Carve => RefOp::Carve,
        Op::Add => RefOp::Add,
        Op::Spray(strength, f) => RefOp::Spray {
            strength,
            falloff: f * h,
        },
        Op::Paint(strength) => RefOp::Paint {
            colour: [0.2f32, (strength * 0.5) as f32, 0.9].map(f64::from),
            strength,
        },
        Op::Smooth(strength) => RefOp::Smooth { strength },
    };
    (tool, op)
}

/// The grid of the reference tests: 32³ voxels of 0.5 at an origin off the lattice.
fn reference_grid() -> SculptGrid {
    SculptGrid::new(DVec3::new(0.25, -1.0, 3.0), 0.5, 2).unwrap()
}

/// World position of the voxel coordinates `(x, y, z)` of `reference_grid()`.
fn at(x: f64, y: f64, z: f64) -> DVec3 {
    DVec3::new(0.25, -1.0, 3.0) + DVec3::new(x, y, z) * 0.5
}

/// Applies `strokes` to the sculpt `block(lo, hi)` and to its reference, comparing every
/// voxel (density and colour) and 300 trilinear samples after each stroke. Each stroke must
/// change at least 20 voxels of the reference by more than 0.01, so no comparison is vacuous.
fn check_against_reference(what: &str, lo: f64, hi: f64, strokes: &[(RefTool, RefOp)]) {
    let grid = reference_grid();
    let mut s = block(grid, lo, hi);
    let mut r = Reference::block(&grid, lo, hi, CLAY);
    r.assert_matches(&s, &format!("{what}: the start"));
    for (k, (tool, op)) in strokes.iter().enumerate() {
        let before = r.clone();
        s.apply(&crate_stroke(tool, *op));
        r.apply(tool, *op);
        let changed = r.changed_from(&before, 0.01);
        assert!(changed >= 20, "{what}: stroke {k} changes only {changed} voxels");
        r.assert_matches(&s, &format!("{what}: stroke {k} ({op:?} with {tool:?})"));
        let tol = r.tolerance() + 1e-12;
        for j in 0..300 {
            let p = at(
                (j * 37 % 101) as f64 * 0.33 - 1.0,
                (j * 53 % 97) as f64 * 0.34 - 1.0,
                (j * 71 % 89) as f64 * 0.37 - 1.0,
            );
            let (a, b) = (s.value(p), r.value(p));
            assert!(
                (a - b).abs() <= tol,
                "{what}: stroke {k}: value at {p}: {a} vs reference {b}"
            );
        }
    }
}

fn rotated_box(size: f64, angle: f64, x: f64, y: f64, z: f64) -> RefTool {
    let r = size * 0.5;
    RefTool::RotatedBox {
        lo: DVec3::new(-r, -0.6 * r, -0.8 * r),
        hi: DVec3::new(r, 0.9 * r, 0.5 * r),
        angle,
        at: at(x, y, z),
    }
}

fn ball(x: f64, y: f64, z: f64, size: f64) -> RefTool {
    RefTool::Sphere {
        centre: at(x, y, z),
        radius: size * 0.5,
    }
}

#[test]
fn carve_matches_the_fuzzy_difference_computed_independently() {
    check_against_reference(
        "carve",
        6.0,
        24.0,
        &[
            (ball(15.3, 14.7, 24.2, 5.3), RefOp::Carve),
            (rotated_box(4.0, 0.6, 7.0, 16.0, 16.0), RefOp::Carve),
            (ball(20.2, 21.9, 16.4, 7.7), RefOp::Carve),
        ],
    );
}

#[test]
fn add_matches_the_fuzzy_union_computed_independently() {
    check_against_reference(
        "add",
        6.0,
        24.0,
        &[
            (ball(15.5, 16.2, 26.0, 4.4), RefOp::Add),
            (rotated_box(3.5, 1.1, 26.0, 10.0, 12.0), RefOp::Add),
            (ball(3.1, 28.4, 5.2, 2.6), RefOp::Add),
        ],
    );
}

#[test]
fn spray_matches_the_additive_falloff_computed_independently() {
    check_against_reference(
        "spray",
        6.0,
        24.0,
        &[
            // Partly inside the block: the sum saturates at 1 there.
            (
                ball(16.0, 16.0, 25.0, 3.5),
                RefOp::Spray {
                    strength: 0.6,
                    falloff: 1.3 * 0.5,
                },
            ),
            // In empty space: the falloff's ramp shows undiluted.
            (
                ball(16.2, 15.1, 29.3, 2.0),
                RefOp::Spray {
                    strength: 0.35,
                    falloff: 2.7 * 0.5,
                },
            ),
            (
                rotated_box(3.0, 0.8, 27.0, 27.0, 10.0),
                RefOp::Spray {
                    strength: 1.0,
                    falloff: 0.0,
                },
            ),
            // Sprayed twice: additive.
            (
                ball(16.2, 15.1, 29.3, 2.0),
                RefOp::Spray {
                    strength: 0.35,
                    falloff: 2.7 * 0.5,
                },
            ),
        ],
    );
}

#[test]
fn paint_matches_the_colour_blend_computed_independently() {
    check_against_reference(
        "paint",
        6.0,
        24.0,
        &[
            (
                ball(12.0, 12.0, 24.0, 5.0),
                RefOp::Paint {
                    colour: [0.25, 0.5, 0.875],
                    strength: 0.7,
                },
            ),
            (
                rotated_box(4.0, 0.3, 14.0, 13.0, 22.0),
                RefOp::Paint {
                    colour: [1.0, 0.0, 0.125],
                    strength: 1.0,
                },
            ),
            (
                ball(13.0, 12.5, 23.0, 3.0),
                RefOp::Paint {
                    colour: [0.0, 0.75, 0.25],
                    strength: 0.45,
                },
            ),
        ],
    );
}

#[test]
fn smooth_matches_the_27_neighbour_blend_computed_independently() {
    // The block reaches the grid's faces at 0 (from −4), where the mean reads the background 0.
    check_against_reference(
        "smooth",
        -4.0,
        20.0,
        &[
            (ball(1.0, 10.0, 10.0, 6.0), RefOp::Smooth { strength: 0.8 }),
            (rotated_box(5.0, 0.4, 20.0, 20.0, 20.0), RefOp::Smooth { strength: 0.5 }),
            (ball(1.0, 10.0, 10.0, 6.0), RefOp::Smooth { strength: 1.0 }),
        ],
    );
}

#[test]
fn saw_matches_the_exact_sweep_within_the_sampling_bound() {
    check_against_reference(
        "saw",
        6.0,
        24.0,
        &[
            (
                RefTool::Saw {
                    path: vec![at(9.0, 16.0, 24.0), at(23.0, 17.0, 23.5), at(23.0, 8.0, 20.0)],
                    radius: 1.5,
                    step: 0.25,
                },
                RefOp::Carve,
            ),
            (
                RefTool::Saw {
                    path: vec![at(6.0, 6.0, 12.0), at(6.0, 25.0, 12.0)],
                    radius: 2.0,
                    step: 0.25,
                },
                RefOp::Carve,
            ),
        ],
    );
}
