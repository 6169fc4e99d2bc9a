//! Bad input that used to be accepted, or outputs that were not all or nothing:
//! `--threads` beyond what the machine can run, flags a mode ignores, a report on the
//! model's own file, an unwritable report, a disk too small, a distance NRRD handed
//! to `validate`.

use std::path::{Path, PathBuf};

mod common;
use common::{arg, stderr, volga};

/// A closed tetrahedron, small enough to voxelize in milliseconds.
fn tetrahedron(dir: &Path) -> PathBuf {
    let path = dir.join("tet.obj");
    std::fs::write(
        &path,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .unwrap();
    path
}

#[test]
fn threads_beyond_the_cap_are_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = tetrahedron(dir.path());
    let out = dir.path().join("t.binvox");
    for n in ["100000", "1025"] {
        let o = volga(&[
            "--threads",
            n,
            "voxelize",
            arg(&mesh),
            "--resolution",
            "8",
            "--separability",
            "26",
            "--out",
            arg(&out),
        ]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains(&format!("--threads {n}")) && stderr(&o).contains("at most"),
            "{}",
            stderr(&o)
        );
    }
    assert!(!out.exists());
    // 16 threads are always allowed.
    let o = volga(&[
        "--threads",
        "16",
        "voxelize",
        arg(&mesh),
        "--resolution",
        "8",
        "--separability",
        "26",
        "--out",
        arg(&out),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn flags_a_mode_would_ignore_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = tetrahedron(dir.path());
    let binvox = dir.path().join("x.binvox");
    let nrrd = dir.path().join("x.nrrd");
    // (flags, output, the flags the message must name)
    let cases: [(&[&str], &Path, [&str; 2]); 6] = [
        (
            &["--separability", "26", "--unsigned"],
            &binvox,
            ["--unsigned", "--separability"],
        ),
        (
            &["--separability", "26", "--thickness", "2"],
            &binvox,
            ["--thickness", "--separability"],
        ),
        (
            &["--anti-aliased", "--unsigned"],
            &nrrd,
            ["--unsigned", "--anti-aliased"],
        ),
        (
            &["--anti-aliased", "--solid", "--thickness", "2"],
            &nrrd,
            ["--thickness", "--solid"],
        ),
        (&["--distance", "2", "--solid"], &nrrd, ["--solid", "--distance"]),
        (
            &["--distance", "2", "--thickness", "2"],
            &nrrd,
            ["--thickness", "--distance"],
        ),
    ];
    for (flags, out, named) in cases {
        let mut args = vec!["voxelize", arg(&mesh), "--resolution", "8", "--out", arg(out)];
        args.extend(flags);
        let o = volga(&args);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {}", stderr(&o));
        for flag in named {
            assert!(
                stderr(&o).contains(flag),
                "{flags:?} should name {flag}: {}",
                stderr(&o)
            );
        }
        assert!(!out.exists(), "{flags:?} wrote an output");
    }
    // The same flags where they mean something are accepted.
    for flags in [
        &["--distance", "2", "--unsigned"][..],
        &["--anti-aliased", "--thickness", "2"],
        &["--anti-aliased", "--solid"],
        &["--separability", "6", "--solid"],
    ] {
        let out = if flags[0] == "--separability" { &binvox } else { &nrrd };
        let mut args = vec!["voxelize", arg(&mesh), "--resolution", "8", "--out", arg(out)];
        args.extend(flags);
        let o = volga(&args);
        assert_eq!(o.status.code(), Some(0), "{flags:?}: {}", stderr(&o));
    }
}

#[test]
fn a_report_on_the_model_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = tetrahedron(dir.path());
    std::fs::create_dir(dir.path().join("d")).unwrap();
    let binvox = dir.path().join("d/x.binvox");
    std::fs::write(&binvox, b"old model").unwrap();
    let cases: Vec<(Vec<&str>, PathBuf)> = vec![
        (vec!["--separability", "26"], binvox.clone()),
        (vec!["--separability", "26"], dir.path().join("d/../d/./x.binvox")),
        (vec!["--distance", "2"], dir.path().join("d/x.nrrd")),
        (vec!["--distance", "2"], dir.path().join("d/x.raw")),
    ];
    #[cfg(unix)]
    std::os::unix::fs::symlink(dir.path().join("d"), dir.path().join("link")).unwrap();
    let mut cases = cases;
    #[cfg(unix)]
    cases.push((vec!["--separability", "26"], dir.path().join("link/x.binvox")));
    for (mode, report) in cases {
        let out = if mode[0] == "--separability" {
            binvox.clone()
        } else {
            dir.path().join("d/x.nrrd")
        };
        let mut args = vec!["voxelize", arg(&mesh), "--resolution", "8", "--out", arg(&out)];
        args.extend(&mode);
        args.extend(["--report", arg(&report)]);
        let o = volga(&args);
        assert_eq!(o.status.code(), Some(2), "{report:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("same file"), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read(&binvox).unwrap(), b"old model");
    assert!(!dir.path().join("d/x.nrrd").exists());
}

#[test]
fn an_unwritable_report_leaves_the_existing_model() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = tetrahedron(dir.path());
    let binvox = dir.path().join("x.binvox");
    std::fs::write(&binvox, b"old model").unwrap();
    // A directory where the report goes, and a report in a missing directory.
    let report_dir = dir.path().join("r.json");
    std::fs::create_dir(&report_dir).unwrap();
    for report in [report_dir.clone(), dir.path().join("missing/r.json")] {
        let o = volga(&[
            "voxelize",
            arg(&mesh),
            "--resolution",
            "8",
            "--separability",
            "26",
            "--out",
            arg(&binvox),
            "--report",
            arg(&report),
        ]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(stderr(&o).contains("r.json"), "{}", stderr(&o));
        assert_eq!(std::fs::read(&binvox).unwrap(), b"old model", "the model was replaced");
    }
    // NRRD: neither the header nor the data appear.
    let nrrd = dir.path().join("v.nrrd");
    let o = volga(&[
        "voxelize",
        arg(&mesh),
        "--resolution",
        "8",
        "--distance",
        "2",
        "--out",
        arg(&nrrd),
        "--report",
        arg(&report_dir),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(!nrrd.exists() && !dir.path().join("v.raw").exists());
    // No temporary files are left behind.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.contains(".tmp-")), "{names:?}");
}

#[test]
fn outputs_larger_than_the_free_space_are_refused_before_voxelizing() {
    let dir = tempfile::tempdir().unwrap();
    // Two tiny triangles at opposite corners: a huge grid with almost nothing in it,
    // so memory is no obstacle but a dense NRRD would need ~800 TB.
    let mesh = dir.path().join("corners.obj");
    std::fs::write(
        &mesh,
        "v 0 0 0\nv 0.00001 0 0\nv 0 0.00001 0\nv 1 1 1\nv 0.99999 1 1\nv 1 0.99999 1\nf 1 2 3\nf 4 5 6\n",
    )
    .unwrap();
    let nrrd = dir.path().join("huge.nrrd");
    let o = volga(&[
        "voxelize",
        arg(&mesh),
        "--resolution",
        "60000",
        "--distance",
        "1",
        "--unsigned",
        "--memory-limit",
        "1T",
        "--out",
        arg(&nrrd),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("not enough free space") && e.contains("TiB") && e.contains("available"),
        "{e}"
    );
    assert!(!nrrd.exists());
}

#[test]
fn validate_says_a_nrrd_holds_distances() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = tetrahedron(dir.path());
    let distance = dir.path().join("d.nrrd");
    let density = dir.path().join("a.nrrd");
    for (flags, out) in [
        (&["--distance", "2"], &distance),
        (&["--anti-aliased", "--solid"], &density),
    ] {
        let mut args = vec!["voxelize", arg(&mesh), "--resolution", "16", "--out", arg(out)];
        args.extend(flags);
        let o = volga(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let o = volga(&["validate", arg(&distance)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("d.nrrd") && e.contains("holds distances") && e.contains("threshold"),
        "{e}"
    );

    // A solid does not separate white (exit 1), but it is read: not bad input.
    let o = volga(&["validate", arg(&density), "--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(r["values"], "density");
    assert!(r["report"]["voxels"].as_u64().unwrap() > 0);
    let o = volga(&["validate", arg(&density)]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("black = density ≥ 0.5"));
}
