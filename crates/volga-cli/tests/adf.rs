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
    for key in ["build_s", "cells", "bytes", "max_error", "rms_error", "render_fps"] {
        assert!(json[key].is_number(), "{key} missing: {json}");
    }
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
