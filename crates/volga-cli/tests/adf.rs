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
