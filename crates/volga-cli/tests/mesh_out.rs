//! Meshes from the command line: `voxelize --mesh`, `sculpt --mesh`, `adf --mesh` with each
//! extraction method and adaptivity, closed and manifold by the edge–face check; bad flags
//! end with exit 2 naming the flag, writing nothing.

use std::collections::HashMap;
use std::path::Path;

mod common;
use common::{arg, stderr, volga};

fn data(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data")
        .join(name)
        .to_string_lossy()
        .into_owned()
}

/// Every undirected edge in exactly two triangles, once in each direction.
fn closed_and_oriented(path: &Path) -> usize {
    let mesh = volga_mesh::load_obj(path).unwrap();
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &directed {
        assert_eq!(n, 1, "{}: edge {a}->{b} used {n} times", path.display());
        assert_eq!(directed.get(&(b, a)), Some(&1), "{}: edge {a}-{b} open", path.display());
    }
    mesh.triangles.len()
}

#[test]
fn voxelize_writes_a_mesh_by_each_method() {
    let dir = tempfile::tempdir().unwrap();
    let spot = data("spot.obj");
    let mut counts = HashMap::new();
    for (method, adaptivity) in [("tetrahedra", "0"), ("cubes", "0"), ("dual", "0"), ("cubes", "0.5")] {
        let out = dir.path().join("v.nrrd");
        let mesh = dir.path().join(format!("{method}{adaptivity}.obj"));
        let o = volga(&[
            "voxelize",
            &spot,
            "--resolution",
            "32",
            "--anti-aliased",
            "--solid",
            "--out",
            arg(&out),
            "--mesh",
            arg(&mesh),
            "--mesh-method",
            method,
            "--mesh-adaptivity",
            adaptivity,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        counts.insert((method, adaptivity), closed_and_oriented(&mesh));
    }
    assert!(counts[&("cubes", "0")] * 2 < counts[&("tetrahedra", "0")], "{counts:?}");
    assert!(counts[&("cubes", "0.5")] < counts[&("cubes", "0")], "{counts:?}");
    // A narrow band meshes at its zero level.
    let mesh = dir.path().join("band.ply");
    let o = volga(&[
        "voxelize",
        &spot,
        "--resolution",
        "32",
        "--distance",
        "2",
        "--out",
        arg(&dir.path().join("band.nrrd")),
        "--mesh",
        arg(&mesh),
        "--report",
        arg(&dir.path().join("band.json")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::metadata(&mesh).unwrap().len() > 1000);
    // The report times the mesh as a stage of its own.
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("band.json")).unwrap()).unwrap();
    let stages: Vec<&str> = report["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    assert_eq!(stages, ["read_mesh", "voxelize", "mesh", "write"]);
}

#[test]
fn bad_mesh_flags_are_refused_with_exit_2_and_nothing_written() {
    let dir = tempfile::tempdir().unwrap();
    let spot = data("spot.obj");
    let out = dir.path().join("v.nrrd");
    let mesh = dir.path().join("m.obj");
    let cases: [(&[&str], &str); 4] = [
        (&["--mesh", arg(&mesh), "--mesh-method", "nets"], "--mesh-method"),
        (&["--mesh", arg(&mesh), "--mesh-adaptivity", "11"], "--mesh-adaptivity"),
        (&["--mesh-method", "dual"], "need --mesh"),
        (&["--mesh", "m.stl"], "expected .obj or .ply"),
    ];
    for (extra, message) in cases {
        let mut args = vec![
            "voxelize",
            &spot,
            "--resolution",
            "16",
            "--anti-aliased",
            "--out",
            arg(&out),
        ];
        args.extend_from_slice(extra);
        let o = volga(&args);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(message), "{extra:?}: {}", stderr(&o));
        assert!(!out.exists() && !mesh.exists());
    }
}

#[test]
fn sculpt_and_adf_write_meshes_by_the_chosen_method() {
    let dir = tempfile::tempdir().unwrap();
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/sculpt_demo.ron");
    let mesh = dir.path().join("sculpt.obj");
    let o = volga(&[
        "sculpt",
        "--strokes",
        arg(&demo),
        "--mesh",
        arg(&mesh),
        "--mesh-method",
        "dual",
        "--mesh-adaptivity",
        "0.25",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    closed_and_oriented(&mesh);
    let adf_mesh = dir.path().join("adf.obj");
    let o = volga(&[
        "adf",
        &data("fandisk.obj"),
        "--tolerance",
        "1e-2",
        "--size",
        "32",
        "--out",
        arg(&dir.path().join("adf")),
        "--mesh",
        arg(&adf_mesh),
        "--mesh-resolution",
        "48",
        "--mesh-method",
        "dual",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    closed_and_oriented(&adf_mesh);
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("adf/adf.json")).unwrap()).unwrap();
    assert_eq!(report["mesh"]["method"], "dual");
}

#[test]
fn adf_meshes_on_its_own_leaves() {
    let dir = tempfile::tempdir().unwrap();
    let adf_mesh = dir.path().join("leaves.obj");
    let out = dir.path().join("adf");
    let base = |extra: &[&str]| {
        let mut args = vec![
            "adf".to_string(),
            data("fandisk.obj"),
            "--tolerance".into(),
            "1e-2".into(),
            "--size".into(),
            "32".into(),
            "--points".into(),
            "100".into(),
            "--out".into(),
            arg(&out).to_string(),
        ];
        args.extend(extra.iter().map(|s| s.to_string()));
        args
    };
    let run = |extra: &[&str]| {
        let args = base(extra);
        volga(&args.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let o = run(&["--mesh", arg(&adf_mesh), "--mesh-on-leaves"]);
    assert!(o.status.success(), "{}", stderr(&o));
    closed_and_oriented(&adf_mesh);
    let report: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("adf.json")).unwrap()).unwrap();
    assert_eq!(report["mesh"]["on_leaves"], true);
    assert!(report["mesh"]["triangles"].as_u64().unwrap() > 100);
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_file(&adf_mesh).unwrap();
    let refused: [(&[&str], &str); 3] = [
        (
            &["--mesh", arg(&adf_mesh), "--mesh-on-leaves", "--mesh-method", "dual"],
            "--mesh-on-leaves",
        ),
        (&["--mesh-on-leaves"], "need --mesh"),
        (
            &["--mesh", arg(&adf_mesh), "--mesh-on-leaves", "--mesh-resolution", "64"],
            "--mesh-resolution",
        ),
    ];
    for (extra, message) in refused {
        let o = run(extra);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(message), "{extra:?}: {}", stderr(&o));
        assert!(!out.exists() && !adf_mesh.exists(), "{extra:?}: output written");
    }
}
