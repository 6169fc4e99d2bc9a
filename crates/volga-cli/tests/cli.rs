//! The `volga` binary as a user runs it: outputs, exit codes, messages, threads.

use std::path::{Path, PathBuf};

mod common;
use common::{stderr, volga};

const HELLO: &str = include_str!("../../../scenes/hello.ron");

fn small_hello(dir: &Path) -> PathBuf {
    let text = HELLO
        .replace("resolution: 128", "resolution: 40")
        .replace("width: 512, height: 512", "width: 96, height: 96");
    let p = dir.join("hello.ron");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn build_succeeds_with_exit_0_and_writes_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_hello(dir.path());
    let out = dir.path().join("out");
    let o = volga(&["build", scene.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for f in [
        "hello_iso.png",
        "hello_volume.png",
        "hello.nrrd",
        "hello.raw",
        "report.json",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    // stderr is not a terminal here: no progress bar noise.
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
}

#[test]
fn same_png_bytes_with_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_hello(dir.path());
    let mut images = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.path().join(format!("out{threads}"));
        let o = volga(&[
            "--threads",
            threads,
            "build",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        images.push([
            std::fs::read(out.join("hello_iso.png")).unwrap(),
            std::fs::read(out.join("hello_volume.png")).unwrap(),
            std::fs::read(out.join("hello.raw")).unwrap(),
        ]);
        let report: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
        assert_eq!(report["threads"].as_u64().unwrap().to_string(), threads);
    }
    assert!(images[0] == images[1], "outputs differ between 1 and 2 threads");
}

#[test]
fn bad_input_exits_2_naming_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("bad.ron");
    std::fs::write(&scene, HELLO.replace("radius: 0.62", "radius: -1.0")).unwrap();
    let o = volga(&[
        "build",
        scene.to_str().unwrap(),
        "--out",
        dir.path().join("out").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("bad.ron") && e.contains("objects[0].shape.radius"), "{e}");

    let o = volga(&["build", "/nonexistent.ron", "--out", dir.path().to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("/nonexistent.ron"));

    let o = volga(&["build"]);
    assert_eq!(o.status.code(), Some(2), "usage errors are bad input");
}

#[test]
fn oversized_grid_exits_2_with_the_size_needed() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("huge.ron");
    std::fs::write(&scene, HELLO.replace("resolution: 128", "resolution: 100000")).unwrap();
    let o = volga(&[
        "build",
        scene.to_str().unwrap(),
        "--out",
        dir.path().join("out").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("huge.ron") && e.contains("needs an estimated") && e.contains("available"),
        "{e}"
    );
}

#[test]
fn failed_output_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_hello(dir.path());
    let out = dir.path().join("out");
    std::fs::create_dir_all(out.join("hello.nrrd")).unwrap();
    let o = volga(&["build", scene.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("hello.nrrd"), "{}", stderr(&o));
}

#[test]
fn help_on_every_subcommand_and_plan_prints_json() {
    for args in [&["--help"][..], &["build", "--help"], &["plan", "--help"]] {
        let o = volga(args);
        assert_eq!(o.status.code(), Some(0));
        assert!(String::from_utf8_lossy(&o.stdout).contains("Usage"));
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = small_hello(dir.path());
    let o = volga(&["plan", scene.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let plan: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(plan["memory"]["total_bytes"].as_u64().unwrap() > 0);
}
