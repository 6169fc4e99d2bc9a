//! `volga adf` and `volga bench adf`: outputs, JSON keys, and bad input refused with exit
//! code 2 and nothing written.

mod common;

use common::{arg, stderr, volga};

/// A closed octahedron as OBJ text.
const OCTAHEDRON: &str = "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n\
f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";

#[test]
fn adf_writes_statistics_and_a_render() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("octa.obj");
    std::fs::write(&mesh, OCTAHEDRON).unwrap();
    let out = dir.path().join("out");
    let o = volga(&[
        "adf",
        arg(&mesh),
        "--tolerance",
        "1e-2",
        "--max-depth",
        "7",
        "--points",
        "2000",
        "--size",
        "64",
        "--out",
        arg(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("adf.json")).unwrap()).unwrap();
    for key in ["build_s", "cells", "bytes", "max_error", "rms_error"] {
        assert!(json[key].is_number(), "{key} missing: {json}");
    }
    // A closed mesh with flat faces: within the tolerance away from its sharp edges.
    assert!(json["max_error_below_max_depth"].as_f64().unwrap() <= 1e-2, "{json}");
    let (width, height, rgba) = volga_io::decode_png(&out.join("adf.png")).unwrap();
    assert_eq!((width, height), (64, 64));
    // The octahedron covers the middle of the image; the corners are background.
    let px = |x: u32, y: u32| rgba[((y * 64 + x) * 4) as usize..][..3].to_vec();
    assert_ne!(px(32, 32), px(0, 0));
}

#[test]
fn bench_adf_prints_one_json_object() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("octa.obj");
    std::fs::write(&mesh, OCTAHEDRON).unwrap();
    let o = volga(&[
        "bench",
        "adf",
        arg(&mesh),
        "--tolerance",
        "1e-2",
        "--max-depth",
        "6",
        "--points",
        "1000",
        "--size",
        "32",
        "--repeat",
        "1",
        "--frames",
        "1",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in [
        "build_s",
        "cells",
        "bytes",
        "max_error",
        "rms_error",
        "render_fps",
        "ray_leaves_mean",
    ] {
        assert!(json[key].is_number(), "{key} missing: {json}");
    }
}

#[test]
fn bench_adf_writes_the_error_probes() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("octa.obj");
    std::fs::write(&mesh, OCTAHEDRON).unwrap();
    let probes = dir.path().join("probes.json");
    let o = volga(&[
        "bench",
        "adf",
        arg(&mesh),
        "--tolerance",
        "1e-2",
        "--max-depth",
        "6",
        "--points",
        "500",
        "--size",
        "16",
        "--repeat",
        "1",
        "--frames",
        "1",
        "--probes-out",
        arg(&probes),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bench: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let file: serde_json::Value = serde_json::from_slice(&std::fs::read(&probes).unwrap()).unwrap();
    assert_eq!(file["format"], "volga-adf-probes/1");
    let diagonal = file["diagonal"].as_f64().unwrap();
    assert!(
        (diagonal - 12f64.sqrt()).abs() < 1e-12,
        "the octahedron's box is [-1, 1]³"
    );
    let rows = file["probes"].as_array().unwrap();
    assert_eq!(rows.len(), 500);
    // The file's points give the reported maximum error, and their exact distances are
    // the octahedron's: (|x| + |y| + |z| − 1)/√3 on the faces' side of the band.
    let mut max_error = 0f64;
    for row in rows {
        let v: Vec<f64> = row.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let (p, exact, adf) = ([v[0], v[1], v[2]], v[3], v[4]);
        max_error = max_error.max((adf - exact).abs());
        assert!(exact.abs() <= 0.02 * diagonal + 1e-12);
        let plane = (p[0].abs() + p[1].abs() + p[2].abs() - 1.0) / 3f64.sqrt();
        if exact < 0.0 {
            assert!((plane - exact).abs() < 1e-9, "{p:?}: {exact} vs {plane}");
        }
    }
    let reported = bench["max_error"].as_f64().unwrap() * diagonal;
    assert!(
        (max_error - reported).abs() <= 1e-12 * diagonal,
        "{max_error} vs {reported}"
    );
}

#[test]
fn bad_input_is_refused_with_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("octa.obj");
    std::fs::write(&mesh, OCTAHEDRON).unwrap();
    let out = dir.path().join("out");
    for (tolerance, what) in [("0", "tolerance"), ("-1", "tolerance"), ("nan", "tolerance")] {
        let o = volga(&["adf", arg(&mesh), "--tolerance", tolerance, "--out", arg(&out)]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(what), "{}", stderr(&o));
    }
    let o = volga(&["adf", arg(&dir.path().join("missing.obj")), "--out", arg(&out)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("missing.obj"), "{}", stderr(&o));
    assert!(!out.exists(), "nothing written on bad input");
}

/// The Stanford bunny vendored in `tests/data`.
fn bunny() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/stanford-bunny.obj")
}

/// Runs `volga adf` on the octahedron with `extra` flags into a fresh `out`: (output,
/// whether `out` exists afterwards).
fn adf_octahedron(extra: &[&str]) -> (std::process::Output, bool) {
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("octa.obj");
    std::fs::write(&mesh, OCTAHEDRON).unwrap();
    let out = dir.path().join("out");
    let mut args = vec!["adf", arg(&mesh), "--max-depth", "5", "--out", arg(&out)];
    args.extend_from_slice(extra);
    let o = volga(&args);
    let exists = out.exists();
    (o, exists)
}

#[test]
fn points_are_bounded_and_zero_points_is_refused() {
    // Regression (issue 28): `--points 1000000000` aborted on a 48 GB allocation after
    // the build, and `--points 0` reported `max_error 0.0`, a perfect build.
    for points in ["0", "1000000000"] {
        let (o, written) = adf_octahedron(&["--points", points]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(
            e.contains(&format!("--points {points}")) && e.contains("10000000"),
            "{e}"
        );
        assert!(!written, "nothing written");
    }
}

#[test]
fn size_and_out_are_checked_before_the_build() {
    // Regression (issue 28): these failed only after the whole build.
    for (size, limit) in [("0", "16384"), ("100000", "16384")] {
        let (o, written) = adf_octahedron(&["--size", size]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(e.contains(&format!("--size {size}")) && e.contains(limit), "{e}");
        assert!(!written);
    }
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("octa.obj");
    std::fs::write(&mesh, OCTAHEDRON).unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, "keep").unwrap();
    for out in [file.clone(), file.join("sub")] {
        let o = volga(&["adf", arg(&mesh), "--max-depth", "5", "--out", arg(&out)]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(e.contains("--out") && e.contains("not a directory"), "{e}");
        // Refused before the build: the build's statistics are never printed.
        assert!(o.stdout.is_empty());
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep");
}

#[test]
fn a_negative_tolerance_is_reported_as_given() {
    // Regression (issue 28): `--tolerance -1` was reported in world units (−1 × the
    // diagonal).
    let (o, written) = adf_octahedron(&["--tolerance", "-1"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--tolerance -1:"), "{e}");
    assert!(!e.contains("3.46"), "not the world value: {e}");
    assert!(!written);
}

#[test]
fn a_tolerance_the_memory_cannot_hold_is_refused_before_the_build() {
    // Regression (issue 28): the bunny at 1e-7 ran with no estimate and no output (4 GB
    // after 60 s; it needs about 100 M cells, 7.5 GB at its peak). Now the estimate is
    // checked against --memory-limit before the build (exit 1: valid input, too little
    // memory), naming the flag, the cells and bytes needed and the limit.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = volga(&[
        "adf",
        arg(&bunny()),
        "--tolerance",
        "1e-7",
        "--memory-limit",
        "1G",
        "--out",
        arg(&out),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("--tolerance") && e.contains("cells") && e.contains("--memory-limit, 1.00 GiB"),
        "{e}"
    );
    assert!(e.contains("GiB while building"), "{e}");
    assert!(!out.exists(), "nothing written");
}

#[test]
fn a_build_past_the_memory_limit_stops_cleanly() {
    // The estimate is a model: a mesh of zero-area triangles (a segment) has no area or
    // face angles to count, so its estimate is a few cells, while its distance (a
    // cylinder's around the segment) refines to the maximum depth along it. The build
    // stops at the cells the limit allows (exit 1), instead of running on.
    let dir = tempfile::tempdir().unwrap();
    let mesh = dir.path().join("segment.obj");
    std::fs::write(&mesh, "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 3 2 1\n").unwrap();
    let out = dir.path().join("out");
    let o = volga(&[
        "adf",
        arg(&mesh),
        "--tolerance",
        "1e-9",
        "--max-depth",
        "14",
        "--size",
        "16",
        "--memory-limit",
        "60M",
        "--out",
        arg(&out),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("--tolerance") && e.contains("stopped at its limit of") && e.contains("cells"),
        "{e}"
    );
    assert!(!out.exists(), "nothing written");
}
