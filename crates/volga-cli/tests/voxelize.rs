//! `volga voxelize` as a user runs it: outputs, the report's shape, the open-mesh
//! warning, exit codes for bad input.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::{stderr, volga};

/// A mesh vendored in tests/data (see its README for provenance and licences).
fn shared(name: &str) -> PathBuf {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data")
        .join(name);
    assert!(p.is_file(), "{} is missing", p.display());
    p
}

#[test]
fn binary_and_distance_outputs_with_report() {
    let spot = shared("spot.obj");
    let dir = tempfile::tempdir().unwrap();
    let binvox = dir.path().join("spot.binvox");
    let report = dir.path().join("r.json");
    let o = volga(&[
        "voxelize",
        spot.to_str().unwrap(),
        "--resolution",
        "32",
        "--separability",
        "26",
        "--out",
        binvox.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let model = volga_io::read_binvox(&binvox).unwrap();
    let r: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(r["voxels"]["active"].as_u64().unwrap(), model.filled_count());
    let stages: Vec<&str> = r["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    assert_eq!(stages, ["read_mesh", "voxelize", "write"]);
    assert_eq!(r["closed"], true);
    // The longest side has the requested resolution plus padding on both sides.
    assert_eq!(
        r["grid"]["dims"]
            .as_array()
            .unwrap()
            .iter()
            .map(|d| d.as_u64().unwrap())
            .max(),
        Some(32 + 4)
    );

    let nrrd = dir.path().join("spot.nrrd");
    let o = volga(&[
        "voxelize",
        spot.to_str().unwrap(),
        "--resolution",
        "32",
        "--distance",
        "3",
        "--out",
        nrrd.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v = volga_io::read_nrrd(&nrrd).unwrap();
    let h = v.grid.transform.spacing().x as f32;
    let values = v.density.as_slice();
    assert!(values.iter().all(|d| d.abs() <= 3.0 * h * 1.0001));
    assert!(values.iter().any(|d| *d < -2.9 * h), "the inside is marked negative");
}

#[test]
fn open_mesh_solid_warns_about_boundary_edges() {
    let bunny = shared("stanford-bunny.obj");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b.binvox");
    let o = volga(&[
        "voxelize",
        bunny.to_str().unwrap(),
        "--resolution",
        "24",
        "--separability",
        "6",
        "--solid",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("223 boundary edges") && stderr(&o).contains("winding number"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_input_exits_2() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0\nf 1 2 3\n").unwrap();
    let out = dir.path().join("x.nrrd");
    let o = volga(&[
        "voxelize",
        bad.to_str().unwrap(),
        "--resolution",
        "8",
        "--distance",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("bad.obj:2"), "{}", stderr(&o));
    assert!(!out.exists());

    let spot = shared("spot.obj");
    for args in [
        vec!["--resolution", "8", "--anti-aliased", "--out", "x.binvox"],
        vec!["--resolution", "8", "--out", "x.nrrd"],
        vec!["--resolution", "0", "--distance", "2", "--out", "x.nrrd"],
        vec!["--resolution", "8", "--separability", "7", "--out", "x.binvox"],
        vec!["--resolution", "8", "--distance", "2", "--out", "x.png"],
        vec![
            "--resolution",
            "60000",
            "--distance",
            "2",
            "--memory-limit",
            "1M",
            "--out",
            "x.nrrd",
        ],
    ] {
        let mut all = vec!["voxelize", spot.to_str().unwrap()];
        all.extend(args.iter());
        let o = volga(&all);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
}

#[test]
fn bench_times_warm_runs_and_serves_the_same_result() {
    use std::io::{BufRead, BufReader, Write};
    use std::process::Stdio;

    let spot = shared("spot.obj");
    let dir = tempfile::tempdir().unwrap();
    let spot = spot.to_str().unwrap();
    let fresh = dir.path().join("fresh.binvox");
    let served = dir.path().join("served.binvox");
    let job = ["--resolution", "24", "--separability", "18"];

    let mut args = vec!["voxelize", spot];
    args.extend(job);
    args.extend(["--out", fresh.to_str().unwrap()]);
    let o = volga(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let fresh_count = volga_io::read_binvox(&fresh).unwrap().filled_count();

    // One JSON report: every timed run, their median, the voxel count.
    let mut args = vec!["bench", "voxelize", spot];
    args.extend(job);
    args.extend(["--repeat", "3", "--warmup", "0"]);
    let o = volga(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let times: Vec<f64> = r["times_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_f64().unwrap())
        .collect();
    assert_eq!(times.len(), 3);
    let mut sorted = times.clone();
    sorted.sort_by(f64::total_cmp);
    assert_eq!(r["median_s"].as_f64().unwrap(), sorted[1]);
    assert_eq!(r["voxels"].as_u64().unwrap(), fresh_count);

    // `--profile`: the same voxels, and the stages' medians with their shares of 1.
    let mut args = vec!["bench", "voxelize", spot];
    args.extend(job);
    args.extend(["--repeat", "3", "--warmup", "0", "--profile"]);
    let o = volga(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(r["voxels"].as_u64().unwrap(), fresh_count);
    let stages = r["profile"].as_array().unwrap();
    let names: Vec<&str> = stages.iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["binary_surface"], "a binary surface needs no mesh preparation");
    let share: f64 = stages.iter().map(|s| s["share"].as_f64().unwrap()).sum();
    assert!((share - 1.0).abs() < 1e-9, "{r}");
    assert!(stages
        .iter()
        .all(|s| s["wall_s"].as_f64().unwrap() >= 0.0 && s["cpu_s"].as_f64().unwrap() >= 0.0));

    // The serve protocol: ready, run, dump, then an unknown request is bad input.
    let mut args = vec!["bench", "voxelize", spot];
    args.extend(job);
    args.push("--serve");
    let mut child = Command::new(env!("CARGO_BIN_EXE_volga"))
        .args(&args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let mut read = || -> serde_json::Value { serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap() };
    assert_eq!(read()["ready"], true);
    writeln!(stdin, "run").unwrap();
    let ran = read();
    assert_eq!(ran["voxels"].as_u64().unwrap(), fresh_count);
    assert!(ran["t"].as_f64().is_some_and(|t| t.is_finite() && t > 0.0), "{ran}");
    writeln!(stdin, "dump {}", served.display()).unwrap();
    assert_eq!(read()["ok"], true);
    writeln!(stdin, "nonsense").unwrap();
    drop(stdin);
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(2), "an unknown request is bad input");
    assert!(stderr(&o).contains("unknown request `nonsense`"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&served).unwrap(), std::fs::read(&fresh).unwrap());
}
