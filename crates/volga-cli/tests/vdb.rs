//! OpenVDB files from the command line: every command that writes volumes writes `.vdb`,
//! `validate`, `convert` and scenes read it back, and bad flags or files end with exit 2
//! naming the flag or file, writing nothing.

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

#[test]
fn voxelize_writes_vdb_that_converts_back_to_the_same_voxels() {
    let dir = tempfile::tempdir().unwrap();
    let teapot = data("teapot.obj");
    for (mode, extra) in [("--distance", vec!["2"]), ("--anti-aliased", vec!["--solid"])] {
        let vdb = dir.path().join("t.vdb");
        let nrrd = dir.path().join("t.nrrd");
        let back = dir.path().join("back.nrrd");
        for out in [&vdb, &nrrd] {
            let mut args = vec!["voxelize", &teapot, "--resolution", "24", mode];
            args.extend(extra.iter().copied());
            args.extend(["--out", arg(out)]);
            let o = volga(&args);
            assert!(o.status.success(), "{}", stderr(&o));
        }
        let o = volga(&["convert", arg(&vdb), arg(&back)]);
        assert!(o.status.success(), "{}", stderr(&o));
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(
            stdout.contains(if mode == "--distance" {
                "level set"
            } else {
                "fog volume"
            }),
            "{stdout}"
        );
        // The NRRD written directly and the one converted from the VDB hold the same
        // voxels: a level set's inactive voxels are ±band in both.
        let a = volga_io::read_nrrd(&nrrd).unwrap();
        let b = volga_io::read_nrrd(&back).unwrap();
        assert_eq!(a.grid.dims(), b.grid.dims());
        assert_eq!(a.grid.transform, b.grid.transform);
        assert_eq!(a.density.as_slice(), b.density.as_slice(), "{mode}");
    }
}

#[test]
fn validate_reads_vdb_fog_and_level_sets() {
    let dir = tempfile::tempdir().unwrap();
    let teapot = data("teapot.obj");
    let binary = dir.path().join("b.vdb");
    let o = volga(&[
        "voxelize",
        &teapot,
        "--resolution",
        "24",
        "--separability",
        "26",
        "--out",
        arg(&binary),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = volga(&["validate", arg(&binary), "--json"]);
    assert!(o.status.code() == Some(0), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["format"], "vdb");
    assert_eq!(report["values"], "occupancy");
    let level_set = dir.path().join("d.vdb");
    let o = volga(&[
        "voxelize",
        &teapot,
        "--resolution",
        "24",
        "--distance",
        "3",
        "--out",
        arg(&level_set),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = volga(&["validate", arg(&level_set)]);
    assert!(o.status.code().is_some_and(|c| c < 2), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("level set: black = distance ≤ 0"));
}

#[test]
fn bad_vdb_flags_and_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let teapot = data("teapot.obj");
    let nrrd = dir.path().join("t.nrrd");
    let o = volga(&[
        "voxelize",
        &teapot,
        "--resolution",
        "8",
        "--distance",
        "1",
        "--out",
        arg(&nrrd),
        "--vdb-half",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("apply to .vdb outputs only"), "{}", stderr(&o));
    let vdb = dir.path().join("t.vdb");
    let o = volga(&[
        "voxelize",
        &teapot,
        "--resolution",
        "8",
        "--distance",
        "1",
        "--out",
        arg(&vdb),
        "--vdb-compression",
        "lzma",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--vdb-compression `lzma`"), "{}", stderr(&o));
    assert!(!vdb.exists() && !nrrd.exists());
    // A truncated file: exit 2, the file named, nothing written.
    let o = volga(&[
        "voxelize",
        &teapot,
        "--resolution",
        "8",
        "--distance",
        "1",
        "--out",
        arg(&vdb),
    ]);
    assert!(o.status.success());
    let bytes = std::fs::read(&vdb).unwrap();
    let cut = dir.path().join("cut.vdb");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let out = dir.path().join("cut.nrrd");
    let o = volga(&["convert", arg(&cut), arg(&out)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("cut.vdb") && stderr(&o).contains("truncated"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
    // A grid type volga does not read.
    let mut other = bytes.clone();
    let at = other.windows(16).position(|w| w == b"Tree_float_5_4_3").unwrap();
    other[at + 5..at + 10].copy_from_slice(b"int32");
    let odd = dir.path().join("odd.vdb");
    std::fs::write(&odd, &other).unwrap();
    let o = volga(&["validate", arg(&odd)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no float grid"), "{}", stderr(&o));
    // A VDB larger than the memory limit allows.
    let o = volga(&["convert", arg(&vdb), arg(&out), "--memory-limit", "4K"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn scenes_write_vdb_volumes_and_read_them_as_volume_nodes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.ron");
    let text = r#"Scene(
    grid: (bounds: (min: (-1.0, -1.0, -1.0), max: (1.0, 1.0, 1.0)), resolution: 32),
    root: Object(name: "ball", shape: Sphere(center: (0.0, 0.0, 0.0), radius: 0.6), colour: (0.9, 0.3, 0.2)),
    cameras: [],
    outputs: (volumes: [(name: "ball", colour: true, format: Vdb), (name: "ball_nrrd")]),
)"#;
    std::fs::write(&scene, text).unwrap();
    let out = dir.path().join("out");
    let o = volga(&["build", arg(&scene), "--out", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let read = volga_io::read_vdb(&out.join("ball.vdb")).unwrap();
    let nrrd = volga_io::read_nrrd(&out.join("ball_nrrd.nrrd")).unwrap();
    assert_eq!(read.class, volga_io::VdbClass::FogVolume);
    assert_eq!(read.volume.grid.dims(), nrrd.grid.dims());
    for ijk in nrrd.grid.index_box().iter() {
        assert_eq!(read.volume.density.get(ijk), nrrd.density.get(ijk));
    }
    assert!(read
        .grids
        .iter()
        .any(|g| g.name == "color" && g.type_name == "Tree_vec3s_5_4_3"));
    // The .vdb as a Volume node of another scene.
    let again = dir.path().join("out/again.ron");
    std::fs::write(
        &again,
        r#"Scene(
    grid: (bounds: (min: (-1.0, -1.0, -1.0), max: (1.0, 1.0, 1.0)), resolution: 32),
    root: Volume((path: "ball.vdb")),
    cameras: [],
    outputs: (volumes: [(name: "copy")]),
)"#,
    )
    .unwrap();
    let o = volga(&["build", arg(&again), "--out", arg(&dir.path().join("out2"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    let copy = volga_io::read_nrrd(&dir.path().join("out2/copy.nrrd")).unwrap();
    // Same grid, trilinear sampling at the voxel centres: the same densities.
    for ijk in nrrd.grid.index_box().iter() {
        let (a, b) = (copy.density.get(ijk), nrrd.density.get(ijk));
        assert!((a - b).abs() < 1e-6, "{ijk}: {a} vs {b}");
    }
    // half only with format: Vdb.
    std::fs::write(
        &scene,
        text.replace("(name: \"ball_nrrd\")", "(name: \"ball_nrrd\", half: true)"),
    )
    .unwrap();
    let o = volga(&["build", arg(&scene), "--out", arg(&dir.path().join("out3"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("outputs.volumes[1].half"), "{}", stderr(&o));
}
