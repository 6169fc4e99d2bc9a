//! `volga sculpt` as a user runs it: a stroke file with a start object, then more strokes on
//! the saved sculpt; the same bytes for 1 and 2 threads; a damaged sculpt refused with exit
//! code 2 and nothing written.

use std::path::{Path, PathBuf};
use std::process::Command;

fn volga(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_volga")).args(args).output().unwrap()
}

fn demo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/sculpt_demo.ron")
}

#[test]
fn sculpt_from_a_stroke_file_then_apply_more_strokes() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n).display().to_string();
    let demo = demo().display().to_string();
    for threads in ["1", "2"] {
        let out = volga(&[
            "--threads",
            threads,
            "sculpt",
            "--strokes",
            &demo,
            "--out",
            &p(&format!("a{threads}.vsculpt")),
            "--mesh",
            &p(&format!("a{threads}.obj")),
            "--image",
            &p(&format!("a{threads}.png")),
            "--size",
            "48",
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(report["strokes"], 7);
    }
    for ext in ["vsculpt", "obj", "png"] {
        assert_eq!(
            std::fs::read(p(&format!("a1.{ext}"))).unwrap(),
            std::fs::read(p(&format!("a2.{ext}"))).unwrap(),
            "{ext}"
        );
    }
    // More strokes on the saved sculpt (no start needed).
    let more = dir.path().join("more.json");
    std::fs::write(
        &more,
        r#"{"strokes": [{"op": "Carve", "tool": {"Sphere": {"center": [0, 0, 0.7], "radius": 0.3}}}]}"#,
    )
    .unwrap();
    let out = volga(&[
        "sculpt",
        "--strokes",
        &more.display().to_string(),
        "--sculpt",
        &p("a1.vsculpt"),
        "--out",
        &p("b.vsculpt"),
        "--volume",
        &p("b.nrrd"),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_ne!(
        std::fs::read(p("a1.vsculpt")).unwrap(),
        std::fs::read(p("b.vsculpt")).unwrap()
    );
    assert!(Path::new(&p("b.raw")).exists());

    // A damaged sculpt is refused, and the output that existed is left as it was.
    let mut bytes = std::fs::read(p("a1.vsculpt")).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 1;
    std::fs::write(p("bad.vsculpt"), &bytes).unwrap();
    let before = std::fs::read(p("b.vsculpt")).unwrap();
    let out = volga(&[
        "sculpt",
        "--strokes",
        &more.display().to_string(),
        "--sculpt",
        &p("bad.vsculpt"),
        "--out",
        &p("b.vsculpt"),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("checksum"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(std::fs::read(p("b.vsculpt")).unwrap(), before);
    // No start and no sculpt: a clear error.
    let out = volga(&["sculpt", "--strokes", &more.display().to_string()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no `start`"));
}
