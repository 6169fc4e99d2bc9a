//! What every fuzz target runs, shared by the `cargo fuzz` targets (`fuzz/fuzz_targets`)
//! and by the deterministic corpus test of the test suite (`tests/fuzz_corpus.rs`, which
//! includes this file with `#[path]`), so both feed the readers the same way.
//!
//! Each target takes the raw bytes of one input, hands them to a reader and, when the
//! reader accepts them, exercises what a caller does next with the result. Errors are
//! expected; a panic (or abort, or hang) is a bug.
//!
//! Readers that need files get them in one temporary directory per process:
//! * `obj`, `gltf`, `binvox`: bytes read in memory (`read_obj`, `read_gltf`,
//!   `decode_binvox`), named `model.obj` / `model.gltf` / `model.binvox` in that
//!   directory, so a glTF's relative buffer URI `buffer.bin` resolves to a small file.
//! * `vdb`: `.vdb` bytes read in memory (`decode_vdb`) under a 64 MiB limit; an
//!   accepted grid is checked (bricks inside its grid, finite values), written back in
//!   every compression and at half precision, and read again: same grid, same active
//!   voxels.
//! * `nrrd`: the input is up to four parts separated by [`NRRD_SPLIT`]: a header with
//!   attached or detached data (`v.nrrd`), its data file (`v.raw`), and optionally a
//!   colour header (`c.nrrd`) and its data file (`c.raw`); the first is read with
//!   `read_nrrd`, the pair with `read_nrrd_with_colour`.
//! * `scene_ron`, `scene_json`: parsed with `parse_ron` / `parse_json`; what parses is
//!   validated as `scene.ron`/`scene.json` in that directory (a mesh path
//!   `assets/spot.obj` finds a small tetrahedron, a volume path `assets/ball.nrrd` an 8³
//!   ball) and, when valid, planned.
//! * `sculpt_file`: `.vsculpt` bytes (their last four bytes replaced by the CRC-32 of the
//!   rest, so mutations reach the parser) read with `Sculpt::from_bytes`; an accepted
//!   sculpt is written back and re-read, sampled, edited by strokes of every operation
//!   with a ball of 2.5 voxels at its centre and of radius 1 at its origin (with undo and
//!   redo), meshed and exported when its grid is at most 64³,
//!   saved in that directory and reopened.
//! * `strokes`: stroke-file text (JSON when it starts with `{`, else RON) parsed with
//!   `parse_stroke_file` from that directory; its `start` is voxelized when the grid it
//!   asks for is at most 64³ (else a 32³ ball is the sculpt), and the first
//!   [`MAX_STROKES`] strokes are validated and applied, then undone and redone.
//! * `scene_build`: RON scene text parsed, validated, resolved and planned under a
//!   256 MiB limit; scenes within [`SceneBudget`] (grid ≤ 64³, images ≤ 64², few frames,
//!   lights, strokes and chain steps, ADF tolerance ≥ 10⁻³ and depth ≤ 8) are then built
//!   into that directory.
//! * `adf_build`: a text naming the build's options and its source (shapes, OBJ lines, or
//!   both combined by CSG; see [`Harness::adf_build`]); built with at most
//!   [`ADF_MAX_CELLS`] cells and depth 8, then queried, edited, meshed and sampled.
//!
//! Every run refuses paths that leave the temporary directory (absolute, or with `..`):
//! reading devices or the machine's files is not what these targets test.

use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3, IVec3};

/// Separates the files of a `nrrd` input.
pub const NRRD_SPLIT: &[u8] = b"\n%%volga-fuzz-file%%\n";

/// A tetrahedron, the mesh scene inputs find at `assets/spot.obj`.
const TETRAHEDRON: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

/// Every target, in the order the runners list them.
pub const TARGETS: &[&str] = &[
    "obj",
    "gltf",
    "binvox",
    "nrrd",
    "vdb",
    "scene_ron",
    "scene_json",
    "sculpt_file",
    "strokes",
    "scene_build",
    "adf_build",
];

/// Strokes of a `strokes` input that are validated and applied.
pub const MAX_STROKES: usize = 16;

/// Cells an `adf_build` build may hold (it is refused beyond, as `AdfOptions::max_cells`).
pub const ADF_MAX_CELLS: usize = 20_000;

/// Deepest level of an `adf_build` build (deeper requests are clamped to it).
pub const ADF_MAX_DEPTH: u8 = 6;

/// Memory limit of the `strokes` and `scene_build` targets (bytes).
const MEMORY_LIMIT: u64 = 256 << 20;

/// Whether `stroke` fits the harness's memory budget by the bound `volga sculpt` checks
/// before applying it (the sculpt's bricks are bounded before work, as a caller must).
fn within_budget(sculpt: &volga_sculpt::Sculpt, stroke: &volga_sculpt::Stroke) -> bool {
    sculpt.stroke_brick_bound(stroke) * volga_sculpt::BRICK_BYTES_BOUND as u128 <= MEMORY_LIMIT as u128 / 4
}

/// The temporary directory the targets read and write their files in.
pub struct Harness {
    dir: tempfile::TempDir,
}

impl Default for Harness {
    fn default() -> Self {
        Self::new()
    }
}

impl Harness {
    pub fn new() -> Self {
        let dir = tempfile::Builder::new()
            .prefix("volga-fuzz")
            .tempdir()
            .expect("temporary directory");
        // 64 bytes: a glTF buffer `{"uri": "buffer.bin", "byteLength": ≤ 64}`.
        let buffer: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
            .iter()
            .flat_map(|f| f.to_le_bytes())
            .chain([0u8, 0, 1, 0, 2, 0].into_iter().chain(std::iter::repeat_n(0, 22)))
            .collect();
        std::fs::write(dir.path().join("buffer.bin"), buffer).expect("write buffer.bin");
        std::fs::create_dir(dir.path().join("assets")).expect("create assets");
        std::fs::write(dir.path().join("assets/spot.obj"), TETRAHEDRON).expect("write tetrahedron");
        std::fs::write(dir.path().join("assets/ball.nrrd"), ball_nrrd()).expect("write ball.nrrd");
        std::fs::create_dir(dir.path().join("out")).expect("create out");
        Harness { dir }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Runs the target named `target` (one of [`TARGETS`]) on `data`; true when the
    /// reader accepted it (for scenes: when it also validated; for `scene_build`, when it
    /// was built; for `strokes`, when every stroke applied).
    pub fn run(&self, target: &str, data: &[u8]) -> bool {
        match target {
            "obj" => self.obj(data),
            "gltf" => self.gltf(data),
            "binvox" => self.binvox(data),
            "nrrd" => self.nrrd(data),
            "vdb" => self.vdb(data),
            "scene_ron" => self.scene_ron(data),
            "scene_json" => self.scene_json(data),
            "sculpt_file" => self.sculpt_file(data),
            "strokes" => self.strokes(data),
            "scene_build" => self.scene_build(data),
            "adf_build" => self.adf_build(data),
            _ => panic!("unknown fuzz target `{target}`"),
        }
    }

    pub fn obj(&self, data: &[u8]) -> bool {
        let mesh = volga_mesh::read_obj(data, &self.path("model.obj"));
        mesh.map(|mesh| check_mesh(&mesh)).is_ok()
    }

    pub fn gltf(&self, data: &[u8]) -> bool {
        let mesh = volga_mesh::read_gltf(data, &self.path("model.gltf"));
        // `read_gltf` turns a panic of the parser into an error; for fuzzing it is a panic.
        if let Err(e @ volga_mesh::MeshError::GltfPanic { .. }) = &mesh {
            panic!("the glTF reader panicked: {e}");
        }
        mesh.map(|mesh| check_mesh(&mesh)).is_ok()
    }

    pub fn binvox(&self, data: &[u8]) -> bool {
        let Ok(model) = volga_io::decode_binvox(data, &self.path("model.binvox")) else {
            return false;
        };
        let dims = model.dims();
        let _ = model.transform();
        let _ = model.is_filled(dims / 2);
        let filled = model.filled_count();
        // Every filled voxel lies in the grid (runs are bounded by the data's size).
        for ijk in model.filled().take(1 << 16) {
            assert!(ijk.cmplt(dims).all(), "filled voxel {ijk} outside {dims}");
        }
        assert!(filled <= 255 * data.len() as u64);
        true
    }

    pub fn nrrd(&self, data: &[u8]) -> bool {
        let mut parts = split(data, NRRD_SPLIT).into_iter();
        let names = ["v.nrrd", "v.raw", "c.nrrd", "c.raw"];
        let mut written = 0;
        for (name, part) in names.iter().zip(parts.by_ref()) {
            std::fs::write(self.path(name), part).expect("write nrrd part");
            written += 1;
        }
        for name in &names[written..] {
            let _ = std::fs::remove_file(self.path(name));
        }
        let density = volga_io::read_nrrd(&self.path("v.nrrd"));
        if let Ok(volume) = &density {
            assert_eq!(volume.density.as_slice().len() as u64, volume.grid.voxel_count());
        }
        if written > 2 {
            return volga_io::read_nrrd_with_colour(&self.path("v.nrrd"), &self.path("c.nrrd")).is_ok();
        }
        density.is_ok()
    }

    pub fn vdb(&self, data: &[u8]) -> bool {
        let Ok(read) = volga_io::decode_vdb(data, 64 << 20) else {
            return false;
        };
        let v = &read.volume;
        let dims = v.grid.dims();
        assert!(dims.cmpgt(glam::UVec3::ZERO).all(), "empty grid {dims}");
        let ext = volga_core::brick_extent(dims);
        for b in v.density.sorted_bricks() {
            assert!(
                b.cmpge(IVec3::ZERO).all() && b.cmplt(ext).all(),
                "brick {b} outside {ext}"
            );
        }
        // Re-encoding touches every brick: only for small grids.
        if v.density.brick_count() > 4096 {
            return true;
        }
        let active = volga_io::vdb_active_voxels(v);
        for compression in [
            volga_io::VdbCompression::None,
            volga_io::VdbCompression::Zip,
            volga_io::VdbCompression::Blosc,
        ] {
            for half in [false, true] {
                let bytes = volga_io::encode_vdb(v, &volga_io::VdbOptions { compression, half });
                let back = volga_io::decode_vdb(&bytes, 1 << 30);
                match back {
                    Ok(back) => {
                        assert_eq!(back.volume.grid.dims(), dims);
                        if !half {
                            assert_eq!(back.active_voxels, active, "{compression:?}");
                        }
                    }
                    // A grid with no active voxel is refused on reading.
                    Err(e) => assert!(active == 0 || half, "{compression:?} half {half}: {e}"),
                }
            }
        }
        true
    }

    pub fn scene_ron(&self, data: &[u8]) -> bool {
        let Ok(text) = std::str::from_utf8(data) else {
            return false;
        };
        let path = self.path("scene.ron");
        volga_scene::parse_ron(&path, text).is_ok_and(|file| check_scene(&path, &file))
    }

    /// `.vsculpt` bytes, then what a caller does with a sculpt it opened.
    pub fn sculpt_file(&self, data: &[u8]) -> bool {
        use volga_core::Field;
        use volga_sculpt::{Operation, Sculpt, Stroke, Tool};

        let bytes = with_crc(data);
        let Ok(mut sculpt) = Sculpt::from_bytes(&bytes) else {
            return false;
        };
        let grid = *sculpt.grid();
        let again = Sculpt::from_bytes(&sculpt.to_bytes()).expect("a sculpt's own bytes read back");
        assert!(again.same_tree(&sculpt), "written and re-read sculpt differs");
        assert_eq!(sculpt.file_len(), sculpt.to_bytes().len() as u64);
        let _ = sculpt.stats();
        let _ = sculpt.content_bounds();
        let n = grid.dims();
        let centre = grid.voxel_center(IVec3::splat(n / 2));
        for ijk in [IVec3::ZERO, IVec3::splat(n / 2), IVec3::splat(n - 1), IVec3::splat(n)] {
            let _ = sculpt.voxel(ijk);
        }
        for p in [centre, grid.origin(), grid.voxel_center(IVec3::splat(n - 1))] {
            let v = sculpt.value(p);
            assert!((0.0..=1.0).contains(&v), "density {v} at {p} outside [0, 1]");
        }
        // A small stroke of every operation at the grid's centre, as an editor would.
        let h = grid.spacing();
        let operations = [
            Operation::Carve,
            Operation::Add,
            Operation::Spray {
                strength: 0.5,
                falloff_world: h,
            },
            Operation::Paint {
                colour: [0.2, 0.4, 0.8],
                strength: 0.5,
            },
            Operation::Smooth { strength: 1.0 },
        ];
        // Tools sized in voxels, and in world units as a stroke file gives them.
        let tools = [Tool::sphere(centre, 2.5 * h), Tool::sphere(grid.origin(), 1.0)];
        for tool in tools.into_iter().flatten() {
            for operation in operations {
                if let Ok(stroke) = Stroke::new(tool.clone(), operation) {
                    // What `volga sculpt` checks before a stroke: its memory bound.
                    if within_budget(&sculpt, &stroke) {
                        let _ = sculpt.apply(&stroke);
                    }
                }
            }
        }
        let v = sculpt.value(centre);
        assert!((0.0..=1.0).contains(&v), "density {v} after the strokes");
        if sculpt.undo_len() > 0 {
            assert!(sculpt.undo());
            assert!(sculpt.redo());
        }
        if n <= 64 {
            let _ = sculpt.surface(2.0);
            let volume = sculpt.to_sparse_volume(true);
            assert!(volume.colour.is_some());
        }
        let path = self.path("out/model.vsculpt");
        if sculpt.save(&path).is_ok() {
            let reopened = Sculpt::open_with_limit(&path, 64 << 20).expect("a saved sculpt reopens");
            assert!(reopened.same_tree(&sculpt), "saved and reopened sculpt differs");
        }
        true
    }

    /// Stroke-file text, then the strokes applied to its start (or to a small ball).
    pub fn strokes(&self, data: &[u8]) -> bool {
        use volga_core::Field;
        use volga_scene::strokes;
        use volga_sculpt::{Sculpt, SculptGrid};

        let Ok(text) = std::str::from_utf8(data) else {
            return false;
        };
        let name = if text.trim_start().starts_with('{') {
            "strokes.json"
        } else {
            "strokes.ron"
        };
        let path = self.path(name);
        std::fs::write(&path, text).expect("write the stroke file");
        let Ok(mut file) = strokes::parse_stroke_file(&path) else {
            return false;
        };
        if leaves_the_folder(serde_json::to_value(&file)) {
            return false;
        }
        let mut sculpt = match &file.start {
            Some(start) => {
                let extent = (0..3)
                    .map(|a| start.bounds.max[a] - start.bounds.min[a])
                    .fold(0.0f64, f64::max);
                // Grids over 64³ are refused here (the build's cost, not a bug).
                if extent / start.voxel_size > 56.0 {
                    return false;
                }
                match strokes::start_sculpt(&path, start, MEMORY_LIMIT, false) {
                    Ok(sculpt) => sculpt,
                    Err(_) => return false,
                }
            }
            None => {
                let grid = SculptGrid::new(DVec3::splat(-1.0), 2.0 / 31.0, 2).expect("a 32³ grid");
                let ball = volga_shapes::FilteredDensity::new(
                    volga_shapes::Sphere::new(DVec3::ZERO, 0.7).expect("a ball"),
                    volga_shapes::OrientedBoxFilter::for_spacing(DVec3::splat(grid.spacing())),
                );
                Sculpt::from_field(grid, &ball, [0.8, 0.7, 0.6])
            }
        };
        file.strokes.truncate(MAX_STROKES);
        let Ok(list) = strokes::validate_strokes(&path, &file, sculpt.grid().spacing(), false) else {
            return false;
        };
        let before = sculpt.clone();
        for stroke in &list {
            if within_budget(&sculpt, stroke) {
                let _ = sculpt.apply(stroke);
            }
        }
        let grid = *sculpt.grid();
        let v = sculpt.value(grid.voxel_center(IVec3::splat(grid.dims() / 2)));
        assert!((0.0..=1.0).contains(&v), "density {v} after the strokes");
        // Strokes that change nothing leave no history step.
        let steps = sculpt.undo_len();
        assert!(steps <= list.len(), "{steps} undo steps for {} strokes", list.len());
        let after = sculpt.clone();
        for _ in 0..steps {
            assert!(sculpt.undo());
        }
        assert!(
            sculpt.same_tree(&before),
            "undoing every stroke does not restore the start"
        );
        for _ in 0..steps {
            assert!(sculpt.redo());
        }
        assert!(
            sculpt.same_tree(&after),
            "redoing every stroke does not restore the end"
        );
        let _ = Sculpt::from_bytes(&sculpt.to_bytes()).expect("a sculpt's own bytes read back");
        true
    }

    /// RON scene text, validated, resolved, planned and, within [`SceneBudget`], built.
    pub fn scene_build(&self, data: &[u8]) -> bool {
        let Ok(text) = std::str::from_utf8(data) else {
            return false;
        };
        let path = self.path("scene.ron");
        let Ok(file) = volga_scene::parse_ron(&path, text) else {
            return false;
        };
        if leaves_the_folder(serde_json::to_value(&file)) {
            return false;
        }
        let Ok(mut scene) = volga_scene::validate(&path, &file) else {
            return false;
        };
        if !SceneBudget::SMALL.admits(&scene, &file) {
            return false;
        }
        if scene.resolve(Some(MEMORY_LIMIT)).is_err() {
            return false;
        }
        if volga_scene::plan::plan(&scene, Some(MEMORY_LIMIT)).is_err() {
            return false;
        }
        let options = volga_scene::BuildOptions {
            out_dir: self.path("out/scene"),
            memory_limit: Some(MEMORY_LIMIT),
            stage_start: None,
            allow_outside_paths: false,
        };
        volga_scene::build_parsed(&path, &file, &options, &volga_core::NoProgress).is_ok()
    }

    /// An ADF build from a text, then queries, an edit and conversions.
    ///
    /// The text's lines (blank lines and `#` comments skipped):
    /// * `adf TOLERANCE DEPTH BAND MARGIN OP`, all optional (defaults `0.01 6 0 -
    ///   union`; a margin `-` is the default 5 %; `OP` is `union`, `intersection` or
    ///   `difference`, combining the first two sources);
    /// * a shape: `sphere CX CY CZ R`, `box X0 Y0 Z0 X1 Y1 Z1`,
    ///   `cylinder CX CY CZ AX AY AZ R HALF_LENGTH`, `capsule AX AY AZ BX BY BZ R`,
    ///   `cone AX AY AZ DX DY DZ HALF_ANGLE_DEG HEIGHT`,
    ///   `ellipsoid CX CY CZ RX RY RZ`, `torus CX CY CZ AX AY AZ MAJOR MINOR`;
    /// * any other line is OBJ: the mesh they make is a source too.
    pub fn adf_build(&self, data: &[u8]) -> bool {
        use volga_adf::{Adf, AdfOptions, CsgOp, ShapeSource};

        let Ok(text) = std::str::from_utf8(data) else {
            return false;
        };
        let mut options = AdfOptions {
            tolerance: 0.01,
            max_depth: 6,
            max_cells: ADF_MAX_CELLS,
            margin: None,
            band: 0.0,
        };
        let mut op = CsgOp::Union;
        let mut sources: Vec<Box<dyn volga_adf::AdfSource>> = Vec::new();
        let mut obj = String::new();
        for line in text.lines() {
            let mut words = line.split_whitespace();
            let Some(head) = words.next() else { continue };
            let words: Vec<&str> = words.collect();
            let num = |i: usize, default: f64| words.get(i).and_then(|w| w.parse::<f64>().ok()).unwrap_or(default);
            let v3 = |i: usize| DVec3::new(num(i, 0.0), num(i + 1, 0.0), num(i + 2, 0.0));
            match head {
                "adf" => {
                    options.tolerance = num(0, 0.01);
                    let depth = words.get(1).and_then(|w| w.parse::<u8>().ok()).unwrap_or(6);
                    // Deeper than supported is refused by the build; within, clamped here.
                    options.max_depth = match depth > volga_adf::MAX_SUPPORTED_DEPTH {
                        true => depth,
                        false => depth.min(ADF_MAX_DEPTH),
                    };
                    options.band = num(2, 0.0);
                    options.margin = words.get(3).and_then(|w| w.parse::<f64>().ok());
                    op = match words.get(4).copied() {
                        Some("intersection") => CsgOp::Intersection,
                        Some("difference") => CsgOp::Difference,
                        _ => CsgOp::Union,
                    };
                }
                "sphere" | "box" | "cylinder" | "capsule" | "cone" | "ellipsoid" | "torus" => {
                    use volga_shapes::*;
                    let shape: Result<Box<dyn volga_adf::AdfSource>, InvalidShape> = match head {
                        "sphere" => Sphere::new(v3(0), num(3, 1.0)).map(|s| boxed(ShapeSource(s))),
                        "box" => AxisBox::new(v3(0), v3(3)).map(|s| boxed(ShapeSource(s))),
                        "cylinder" => {
                            Cylinder::new(v3(0), v3(3), num(6, 1.0), Some(num(7, 1.0))).map(|s| boxed(ShapeSource(s)))
                        }
                        "capsule" => Capsule::new(v3(0), v3(3), num(6, 1.0)).map(|s| boxed(ShapeSource(s))),
                        "cone" => Cone::new(v3(0), v3(3), num(6, 30.0).to_radians(), Some(num(7, 1.0)))
                            .map(|s| boxed(ShapeSource(s))),
                        "ellipsoid" => Ellipsoid::new(v3(0), v3(3), DQuat::IDENTITY).map(|s| boxed(ShapeSource(s))),
                        _ => Torus::new(v3(0), v3(3), num(6, 1.0), num(7, 0.25)).map(|s| boxed(ShapeSource(s))),
                    };
                    match shape {
                        Ok(shape) => sources.push(shape),
                        Err(_) => return false,
                    }
                }
                _ => {
                    obj.push_str(line);
                    obj.push('\n');
                }
            }
        }
        if obj.contains("v ") {
            let Ok(mesh) = volga_mesh::read_obj(obj.as_bytes(), &self.path("adf.obj")) else {
                return false;
            };
            let Ok(source) = volga_adf::MeshSource::new(&mesh) else {
                return false;
            };
            sources.insert(0, Box::new(source));
        }
        let mut sources = sources.into_iter();
        let (Some(a), b) = (sources.next(), sources.next()) else {
            return false;
        };
        let built = match b {
            None => Adf::build(&a, options),
            Some(b) => Adf::build(&volga_adf::Csg { op, a, b }, options),
        };
        let Ok(mut adf) = built else {
            return false;
        };
        check_adf(&adf);
        // An edit, as a modeller would carve: a ball at the root's centre.
        let root = adf.root_box();
        if let Ok(ball) = volga_shapes::Sphere::new(root.center(), root.size().x * 0.125) {
            if adf.edit(&ShapeSource(ball), CsgOp::Difference).is_ok() {
                check_adf(&adf);
            }
        }
        let _ = adf.to_mesh(root.size().x / 16.0);
        if let Ok(transform) = volga_core::Transform::new(root.min, root.size() / 15.0) {
            if let Ok(grid) = volga_core::Grid::new(transform, glam::UVec3::splat(16)) {
                let _ = adf.to_narrow_band(grid, root.size().x / 8.0);
            }
        }
        true
    }

    pub fn scene_json(&self, data: &[u8]) -> bool {
        let Ok(text) = std::str::from_utf8(data) else {
            return false;
        };
        let path = self.path("scene.json");
        volga_scene::parse_json(&path, text).is_ok_and(|file| check_scene(&path, &file))
    }
}

fn check_mesh(mesh: &volga_mesh::TriMesh) {
    let n = mesh.positions.len();
    for t in &mesh.triangles {
        assert!(
            t.iter().all(|&i| (i as usize) < n),
            "triangle {t:?} indexes past {n} vertices"
        );
    }
    assert!(mesh.positions.iter().all(|p| p.is_finite()), "non-finite vertex");
}

/// Validates and plans a parsed scene; true when it validates.
fn check_scene(path: &Path, file: &volga_scene::model::SceneFile) -> bool {
    let Ok(scene) = volga_scene::validate(path, file) else {
        return false;
    };
    // A fixed limit: planning must not read the machine's free memory here.
    let _ = volga_scene::plan::plan(&scene, Some(1 << 30));
    true
}

fn boxed<S: volga_adf::AdfSource + 'static>(s: S) -> Box<dyn volga_adf::AdfSource> {
    Box::new(s)
}

/// Queries an ADF at its root's centre, corners and a point outside, checking what they
/// promise: finite distances, ranges holding the distance, a hit on the ray's segment.
fn check_adf(adf: &volga_adf::Adf) {
    let root = adf.root_box();
    let size = root.size();
    let points = [
        root.center(),
        root.min,
        root.max,
        root.min + size * DVec3::new(0.25, 0.5, 0.75),
        root.max + size,
    ];
    for p in points {
        let d = adf.distance(p);
        assert!(d.is_finite(), "distance {d} at {p}");
        let _ = adf.gradient(p);
        let _ = adf.closest_point(p);
        let _ = adf.inside(p);
        let _ = adf.leaf_at(p);
    }
    for (lo, hi) in [
        (root.min, root.max),
        (root.center() - size * 0.1, root.center() + size * 0.05),
    ] {
        let b = volga_core::Aabb::new(lo, hi);
        let (r0, r1) = adf.range(&b);
        let d = adf.distance(b.center());
        let slack = 1e-6 * size.x.max(1e-300);
        assert!(r0 - slack <= d && d <= r1 + slack, "range [{r0}, {r1}] misses {d}");
    }
    let origin = root.min - size * 0.5;
    let dir = (root.center() - origin).normalize();
    if let Some(hit) = adf.ray_hit(origin, dir, 4.0 * size.length()) {
        assert!(hit.t.is_finite() && hit.t >= 0.0, "ray hit at t = {}", hit.t);
    }
}

/// Bounds on what a fuzzed scene may ask of `scene_build`, so each build stays under a
/// second: over them, a scene is refused before resolving (the limits are the harness's,
/// not volga's).
pub struct SceneBudget {
    /// Voxels per axis of the grid.
    pub grid_dim: u32,
    /// Pixels per image (width × height × supersampling²).
    pub image_pixels: u64,
    /// Images, turntable frames counted.
    pub frames: u64,
    /// Lights.
    pub lights: usize,
    /// Items of any list in the scene's tree (strokes, saw paths, hypertexture chains,
    /// CVG operands, objects).
    pub list: usize,
    /// Smallest ray step and shadow step, in voxels.
    pub min_step_voxels: f64,
    /// Smallest `Adf` tolerance (a fraction of the source's diagonal) and deepest level.
    pub adf_tolerance: f64,
    /// Deepest `Adf` level.
    pub adf_depth: u64,
}

impl SceneBudget {
    /// What `scene_build` builds: 64³ voxels, 64² pixels, 4 frames.
    pub const SMALL: SceneBudget = SceneBudget {
        grid_dim: 64,
        image_pixels: 64 * 64,
        frames: 4,
        lights: 4,
        list: 16,
        min_step_voxels: 0.1,
        adf_tolerance: 1e-3,
        adf_depth: 8,
    };

    /// Whether `scene` (validated from `file`) is within the budget.
    pub fn admits(&self, scene: &volga_scene::Scene, file: &volga_scene::model::SceneFile) -> bool {
        if scene.grid.dims().max_element() > self.grid_dim || file.lights.len() > self.lights {
            return false;
        }
        let mut frames = 0u64;
        for im in &file.outputs.images {
            let ss = im.supersampling.unwrap_or(1) as u64;
            let pixels = (im.width as u64 * im.height as u64).saturating_mul(ss * ss);
            let steps = [im.step_voxels, im.shadow_step_voxels];
            if pixels > self.image_pixels || steps.iter().flatten().any(|&s| s < self.min_step_voxels) {
                return false;
            }
            frames += im.turntable.as_ref().map_or(1, |t| t.frames as u64);
        }
        if frames > self.frames {
            return false;
        }
        let tree = serde_json::to_value(file).expect("a scene serializes");
        self.admits_tree(&tree)
    }

    fn admits_tree(&self, v: &serde_json::Value) -> bool {
        use serde_json::Value;
        match v {
            Value::Array(items) => items.len() <= self.list && items.iter().all(|i| self.admits_tree(i)),
            Value::Object(map) => {
                if let Some(Value::Object(adf)) = map.get("Adf") {
                    let tolerance = adf.get("tolerance").and_then(Value::as_f64).unwrap_or(0.0);
                    let depth = adf.get("max_depth").and_then(Value::as_u64).unwrap_or(u64::MAX);
                    if tolerance.is_nan() || tolerance < self.adf_tolerance || depth > self.adf_depth {
                        return false;
                    }
                }
                map.values().all(|i| self.admits_tree(i))
            }
            _ => true,
        }
    }
}

/// Whether any string of `value` is a path out of the harness's folder (absolute, or
/// with a `..` component).
fn leaves_the_folder(value: serde_json::Result<serde_json::Value>) -> bool {
    fn walk(v: &serde_json::Value) -> bool {
        use serde_json::Value;
        match v {
            Value::String(s) => {
                let p = Path::new(s);
                p.is_absolute() || p.components().any(|c| matches!(c, std::path::Component::ParentDir))
            }
            Value::Array(items) => items.iter().any(walk),
            Value::Object(map) => map.values().any(walk),
            _ => false,
        }
    }
    value.is_ok_and(|v| walk(&v))
}

/// `data` with its last four bytes replaced by the CRC-32 of the rest (little-endian), as
/// a sculpt file ends; shorter inputs unchanged.
fn with_crc(data: &[u8]) -> Vec<u8> {
    let mut bytes = data.to_vec();
    if bytes.len() >= 4 {
        let body = bytes.len() - 4;
        let crc = volga_sculpt::crc32(&bytes[..body]);
        bytes[body..].copy_from_slice(&crc.to_le_bytes());
    }
    bytes
}

/// An 8³ `float` NRRD of a ball's densities (voxel size 0.25, centred on the origin), the
/// volume scene inputs find at `assets/ball.nrrd`.
fn ball_nrrd() -> Vec<u8> {
    let mut bytes = b"NRRD0004\ntype: float\nendian: little\ndimension: 3\nsizes: 8 8 8\n\
        spacings: 0.25 0.25 0.25\naxis mins: -0.875 -0.875 -0.875\nencoding: raw\n\n"
        .to_vec();
    for z in 0..8 {
        for y in 0..8 {
            for x in 0..8 {
                let r = (DVec3::new(x as f64, y as f64, z as f64) - DVec3::splat(3.5)).length();
                let density = (3.0 - r + 0.5).clamp(0.0, 1.0) as f32;
                bytes.extend_from_slice(&density.to_le_bytes());
            }
        }
    }
    bytes
}

/// `data` cut at every occurrence of `separator`.
fn split<'a>(data: &'a [u8], separator: &[u8]) -> Vec<&'a [u8]> {
    let mut parts = Vec::new();
    let mut rest = data;
    while let Some(at) = rest.windows(separator.len()).position(|w| w == separator) {
        parts.push(&rest[..at]);
        rest = &rest[at + separator.len()..];
    }
    parts.push(rest);
    parts
}

/// A deterministic byte mutator (xorshift64*), for the corpus test and the stable runner:
/// bit flips, byte insertion and deletion, chunk duplication and splicing from another
/// input, interesting bytes and numbers (written as text over a number of the input, and
/// as little-endian `f64` or 32-bit integers over any 8 or 4 bytes), truncation.
pub struct Mutator {
    state: u64,
}

/// Numbers that find limits: zero, signs, powers of two at type boundaries, floats.
const INTERESTING: &[&str] = &[
    "0",
    "-1",
    "1",
    "-0",
    "255",
    "256",
    "65535",
    "65536",
    "2147483647",
    "-2147483648",
    "4294967295",
    "4294967296",
    "1073741824",
    "1099511627776",
    "9223372036854775807",
    "18446744073709551615",
    "18446744073709551616",
    "1e308",
    "1e-320",
    "NaN",
    "inf",
    "-inf",
    "0.5",
    "3",
];

/// Binary floats that find limits: zero, signs, the extremes, subnormals, non-finite.
const INTERESTING_F64: &[f64] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    1e-300,
    5e-324,
    1.5e308,
    f64::MAX,
    f64::MIN_POSITIVE,
    f64::NAN,
    f64::INFINITY,
    9007199254740992.0,
];

/// Binary integers that find limits (levels, counts, sizes).
const INTERESTING_U32: &[u32] = &[
    0,
    1,
    2,
    8,
    16,
    17,
    255,
    256,
    65535,
    65536,
    0x7fff_ffff,
    0x8000_0000,
    u32::MAX,
];

impl Mutator {
    pub fn new(seed: u64) -> Self {
        Mutator {
            state: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
        }
    }

    pub fn next_u64(&mut self) -> u64 {
        self.state ^= self.state >> 12;
        self.state ^= self.state << 25;
        self.state ^= self.state >> 27;
        self.state.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }

    /// `input` changed by one to four mutations; `other` is a second corpus input to
    /// splice from.
    pub fn mutate(&mut self, input: &[u8], other: &[u8]) -> Vec<u8> {
        let mut data = input.to_vec();
        for _ in 0..1 + self.below(4) {
            self.mutate_once(&mut data, other);
        }
        data
    }

    fn mutate_once(&mut self, data: &mut Vec<u8>, other: &[u8]) {
        let len = data.len();
        match self.below(11) {
            0 if len > 0 => {
                let i = self.below(len);
                data[i] ^= 1 << self.below(8);
            }
            1 if len > 0 => {
                let i = self.below(len);
                data[i] = [0, 0xff, 0x7f, 0x80, b'\n', b' ', b'-', b'9'][self.below(8)];
            }
            2 => {
                let i = self.below(len + 1);
                let byte = self.next_u64() as u8;
                data.insert(i, byte);
            }
            3 if len > 0 => {
                let i = self.below(len);
                let n = 1 + self.below((len - i).min(64));
                data.drain(i..i + n);
            }
            4 if len > 0 => {
                let i = self.below(len);
                let n = 1 + self.below((len - i).min(256));
                let chunk = data[i..i + n].to_vec();
                let at = self.below(len + 1);
                data.splice(at..at, chunk);
            }
            5 if !other.is_empty() => {
                let i = self.below(other.len());
                let n = 1 + self.below((other.len() - i).min(256));
                let at = self.below(len + 1);
                let end = (at + self.below(64)).min(len);
                data.splice(at..end, other[i..i + n].iter().copied());
            }
            6 | 7 => {
                // Replace a number (a run of digits, signs, dots, e) by an interesting one.
                let starts: Vec<usize> = (0..len)
                    .filter(|&i| data[i].is_ascii_digit() && (i == 0 || !data[i - 1].is_ascii_digit()))
                    .collect();
                if starts.is_empty() {
                    return;
                }
                let start = starts[self.below(starts.len())];
                let end = (start..len)
                    .find(|&i| !(data[i].is_ascii_digit() || b".eE+-".contains(&data[i])))
                    .unwrap_or(len);
                let number = INTERESTING[self.below(INTERESTING.len())].as_bytes();
                data.splice(start..end, number.iter().copied());
            }
            // A binary number (little-endian, at any offset): an f64 or a 32-bit integer
            // from the boundary values, for the binary formats (sculpt files, binvox, GLB).
            9 if len >= 8 => {
                let i = self.below(len - 7);
                let value = INTERESTING_F64[self.below(INTERESTING_F64.len())];
                data[i..i + 8].copy_from_slice(&value.to_le_bytes());
            }
            10 if len >= 4 => {
                let i = self.below(len - 3);
                let value = INTERESTING_U32[self.below(INTERESTING_U32.len())];
                data[i..i + 4].copy_from_slice(&value.to_le_bytes());
            }
            _ if len > 0 => data.truncate(self.below(len)),
            _ => data.push(self.next_u64() as u8),
        }
    }
}
