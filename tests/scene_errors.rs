//! Bad scene input: one test per kind of error, each checking that the message names
//! the file and the line/column or the field path.

use std::path::{Path, PathBuf};

use volga::scene::{load_scene, SceneError};

const HELLO_RON: &str = include_str!("../scenes/hello.ron");
const HELLO_JSON: &str = include_str!("../scenes/hello.json");

/// Writes `text` to a scene file named `name` in a fresh directory and loads it.
fn load(name: &str, text: &str) -> (tempfile::TempDir, PathBuf, Result<volga::scene::Scene, SceneError>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    let r = load_scene(&path);
    (dir, path, r)
}

fn expect_parse(name: &str, text: &str, line: usize, needle: &str) {
    let (_d, path, r) = load(name, text);
    match r {
        Err(e @ SceneError::Parse { line: l, .. }) => {
            let msg = e.to_string();
            assert_eq!(l, line, "{msg}");
            assert!(msg.starts_with(&format!("{}:{line}:", path.display())), "{msg}");
            assert!(msg.contains(needle), "{msg} should mention {needle}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

fn expect_invalid(name: &str, text: &str, field: &str) -> String {
    let (_d, path, r) = load(name, text);
    match r {
        Err(e @ SceneError::Invalid { .. }) => {
            let msg = e.to_string();
            assert!(msg.contains(&path.display().to_string()), "{msg}");
            assert!(msg.contains(&format!("`{field}`")), "{msg} should name {field}");
            msg
        }
        other => panic!("expected an invalid-field error for {field}, got {other:?}"),
    }
}

fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).expect("needle in scene") + 1
}

#[test]
fn bundled_scenes_load_and_agree() {
    let (_d, _p, ron) = load("hello.ron", HELLO_RON);
    let (_d2, _p2, json) = load("hello.json", HELLO_JSON);
    let (ron, json) = (ron.unwrap(), json.unwrap());
    assert_eq!(ron.grid, json.grid);
    assert_eq!(format!("{:?}", ron.root), format!("{:?}", json.root));
    assert_eq!(ron.images.len(), 2);
    assert_eq!(ron.volumes, json.volumes);
}

#[test]
fn unknown_field_names_line_and_column() {
    let text = HELLO_RON.replace("resolution: 128,", "resolution: 128, colour_depth: 8,");
    expect_parse("s.ron", &text, line_of(&text, "colour_depth"), "colour_depth");
    let text = HELLO_JSON.replace("\"resolution\": 128", "\"resolution\": 128, \"colour_depth\": 8");
    expect_parse("s.json", &text, line_of(&text, "colour_depth"), "colour_depth");
}

#[test]
fn wrong_type_names_line_and_column() {
    let text = HELLO_RON.replace("radius: 0.62", "radius: \"big\"");
    expect_parse("s.ron", &text, line_of(&text, "\"big\""), "");
    let text = HELLO_JSON.replace("\"radius\": 0.62", "\"radius\": \"big\"");
    expect_parse("s.json", &text, line_of(&text, "\"big\""), "big");
}

#[test]
fn syntax_error_names_line() {
    let text = HELLO_RON.replace("lights: [", "lights: [[");
    let (_d, _p, r) = load("s.ron", &text);
    assert!(matches!(r, Err(SceneError::Parse { .. })), "{r:?}");
}

#[test]
fn negative_radius_names_field_path() {
    let text = HELLO_RON.replace("radius: 0.62", "radius: -0.62");
    let msg = expect_invalid("s.ron", &text, "objects[0].shape.radius");
    assert!(msg.contains("-0.62"), "{msg}");
}

#[test]
fn zero_resolution_names_field_path() {
    expect_invalid(
        "s.json",
        &HELLO_JSON.replace("\"resolution\": 128", "\"resolution\": 0"),
        "grid.resolution",
    );
}

#[test]
fn nan_names_field_path() {
    expect_invalid(
        "s.ron",
        &HELLO_RON.replace("center: (0.0, 0.15, 0.0)", "center: (0.0, NaN, 0.0)"),
        "objects[0].shape.center",
    );
    expect_invalid(
        "s.ron",
        &HELLO_RON.replace("fov_deg: 35.0", "fov_deg: NaN"),
        "cameras[0].projection.fov_deg",
    );
}

#[test]
fn colour_out_of_range_names_field_path() {
    expect_invalid(
        "s.ron",
        &HELLO_RON.replace("colour: (0.25, 0.50, 0.90)", "colour: (0.25, 1.5, 0.90)"),
        "objects[1].colour",
    );
}

#[test]
fn unknown_camera_names_field_path() {
    expect_invalid(
        "s.ron",
        &HELLO_RON.replacen("camera: \"three-quarter\"", "camera: \"top\"", 1),
        "outputs.images[0].camera",
    );
}

#[test]
fn bad_output_name_names_field_path() {
    expect_invalid(
        "s.ron",
        &HELLO_RON.replace("name: \"hello_iso\"", "name: \"../escape\""),
        "outputs.images[0].name",
    );
    expect_invalid(
        "s.ron",
        &HELLO_RON.replace("name: \"hello_volume\"", "name: \"hello_iso\""),
        "outputs.images[1].name",
    );
}

#[test]
fn degenerate_box_names_field_path() {
    expect_invalid(
        "s.ron",
        &HELLO_RON.replace("max: (0.95, -0.35, 0.55)", "max: (0.95, -0.95, 0.55)"),
        "objects[1].shape",
    );
}

#[test]
fn unsupported_extension_and_missing_file() {
    let (_d, _p, r) = load("s.yaml", HELLO_RON);
    assert!(matches!(r, Err(SceneError::Extension { .. })));
    let e = load_scene(Path::new("/nonexistent/scene.ron")).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/scene.ron"), "{e}");
}
