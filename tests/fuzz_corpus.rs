//! Every fuzz target against the committed fuzz corpus (`fuzz/corpus/<target>/`) and a
//! fixed set of deterministic mutations of it: no input may panic. The long runs are
//! `fuzz/run.sh` (docs/FUZZING.md); this test keeps the readers, and what callers do next
//! with what they read, from regressing on what those runs found, in a few seconds.

#[path = "../fuzz/src/harness.rs"]
mod harness;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use harness::{Harness, Mutator, TARGETS};

/// Mutated inputs per reader target (each one to four mutations of a corpus file).
const MUTATIONS: u64 = 1500;

/// Mutated inputs of the targets that build (a sculpt, a scene, an ADF) after reading:
/// fewer, so each stays about a second.
const SCULPT_MUTATIONS: u64 = 400;
const STROKE_MUTATIONS: u64 = 300;
const SCENE_BUILD_MUTATIONS: u64 = 100;
const ADF_MUTATIONS: u64 = 12;

fn corpus(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus").join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.unwrap().path())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{} holds no seeds", dir.display());
    files
        .into_iter()
        .map(|path| {
            let bytes = std::fs::read(&path).unwrap();
            (path, bytes)
        })
        .collect()
}

/// Runs `target` on `data`; on a panic, saves the input and fails naming it.
fn run_one(harness: &Harness, target: &str, data: &[u8], origin: &str) {
    if catch_unwind(AssertUnwindSafe(|| harness.run(target, data))).is_err() {
        let saved = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("fuzz-{target}-panic"));
        std::fs::write(&saved, data).unwrap();
        panic!(
            "{target} panicked on {origin}; input saved as {} (reproduce with \
             `cargo run --profile fuzz-stable --no-default-features --bin stable -- --replay {target} {0}` \
             in fuzz/)",
            saved.display()
        );
    }
}

fn check_target(target: &str) {
    check_target_with(target, MUTATIONS);
}

fn check_target_with(target: &str, mutations: u64) {
    let harness = Harness::new();
    let seeds = corpus(target);
    for (path, bytes) in &seeds {
        run_one(&harness, target, bytes, &path.display().to_string());
    }
    // Seeded by the target's name, so each target's sequence is fixed.
    let seed = target.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
    });
    let mut mutator = Mutator::new(seed);
    for i in 0..mutations {
        let (path, bytes) = &seeds[mutator.next_u64() as usize % seeds.len()];
        let (_, other) = &seeds[mutator.next_u64() as usize % seeds.len()];
        let data = mutator.mutate(bytes, other);
        run_one(&harness, target, &data, &format!("mutation {i} of {}", path.display()));
    }
}

#[test]
fn obj_corpus_never_panics() {
    check_target("obj");
}

#[test]
fn gltf_corpus_never_panics() {
    check_target("gltf");
}

#[test]
fn binvox_corpus_never_panics() {
    check_target("binvox");
}

#[test]
fn nrrd_corpus_never_panics() {
    check_target("nrrd");
}

#[test]
fn vdb_corpus_never_panics() {
    check_target("vdb");
}

#[test]
fn scene_ron_corpus_never_panics() {
    check_target("scene_ron");
}

#[test]
fn scene_json_corpus_never_panics() {
    check_target("scene_json");
}

#[test]
fn sculpt_file_corpus_never_panics() {
    check_target_with("sculpt_file", SCULPT_MUTATIONS);
}

#[test]
fn strokes_corpus_never_panics() {
    check_target_with("strokes", STROKE_MUTATIONS);
}

#[test]
fn scene_build_corpus_never_panics() {
    check_target_with("scene_build", SCENE_BUILD_MUTATIONS);
}

#[test]
fn adf_build_corpus_never_panics() {
    check_target_with("adf_build", ADF_MUTATIONS);
}

/// The seeds are worth mutating: every seed of every target is accepted by its target
/// (scenes built, strokes applied, ADFs built), except the OBJ heads (first lines of the
/// shared meshes, faces may point past them) and the `refused-*` seeds: inputs that once
/// crashed and are now refused before work (the other tests replay them).
#[test]
fn seeds_are_valid_inputs() {
    let harness = Harness::new();
    for &target in TARGETS {
        for (path, bytes) in corpus(target) {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            if !name.ends_with("-head.obj") && !name.starts_with("refused-") {
                assert!(harness.run(target, &bytes), "{target}: seed {name} is refused");
            }
        }
    }
}
