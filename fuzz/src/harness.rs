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
//! * `nrrd`: the input is up to four parts separated by [`NRRD_SPLIT`]: a header with
//!   attached or detached data (`v.nrrd`), its data file (`v.raw`), and optionally a
//!   colour header (`c.nrrd`) and its data file (`c.raw`); the first is read with
//!   `read_nrrd`, the pair with `read_nrrd_with_colour`.
//! * `scene_ron`, `scene_json`: parsed with `parse_ron` / `parse_json`; what parses is
//!   validated as `scene.ron`/`scene.json` in that directory (a mesh path
//!   `assets/spot.obj` finds a small tetrahedron) and, when valid, planned.

use std::path::{Path, PathBuf};

/// Separates the files of a `nrrd` input.
pub const NRRD_SPLIT: &[u8] = b"\n%%volga-fuzz-file%%\n";

/// A tetrahedron, the mesh scene inputs find at `assets/spot.obj`.
const TETRAHEDRON: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

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
        Harness { dir }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Runs the target named `target` (`obj`, `gltf`, `binvox`, `nrrd`, `scene_ron`,
    /// `scene_json`) on `data`; true when the reader accepted it (for scenes: when it
    /// also validated).
    pub fn run(&self, target: &str, data: &[u8]) -> bool {
        match target {
            "obj" => self.obj(data),
            "gltf" => self.gltf(data),
            "binvox" => self.binvox(data),
            "nrrd" => self.nrrd(data),
            "scene_ron" => self.scene_ron(data),
            "scene_json" => self.scene_json(data),
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

    pub fn scene_ron(&self, data: &[u8]) -> bool {
        let Ok(text) = std::str::from_utf8(data) else {
            return false;
        };
        let path = self.path("scene.ron");
        volga_scene::parse_ron(&path, text).is_ok_and(|file| check_scene(&path, &file))
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

/// A deterministic byte mutator (xorshift64*), for the corpus test: bit flips, byte
/// insertion and deletion, chunk duplication and splicing from another input,
/// interesting bytes and numbers (written as text over a number of the input, since
/// all but the binary parts of these formats are text), truncation.
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

impl Mutator {
    pub fn new(seed: u64) -> Self {
        Mutator {
            state: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1,
        }
    }

    pub fn next(&mut self) -> u64 {
        self.state ^= self.state >> 12;
        self.state ^= self.state << 25;
        self.state ^= self.state >> 27;
        self.state.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
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
        match self.below(9) {
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
                let byte = self.next() as u8;
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
            _ if len > 0 => data.truncate(self.below(len)),
            _ => data.push(self.next() as u8),
        }
    }
}
