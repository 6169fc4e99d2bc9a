//! `volga build` through the library: outputs, report, refusal of oversized grids,
//! and atomic outputs when a build fails.

use std::path::Path;

use volga::scene::{build, BuildError, BuildOptions, SceneError};

/// hello.ron scaled down for test speed (coarser grid, smaller images).
fn small_hello() -> String {
    include_str!("../scenes/hello.ron")
        .replace("resolution: 128", "resolution: 48")
        .replace("width: 512, height: 512", "width: 64, height: 48")
}

/// Builds `scene` into `out` with an optional memory limit.
fn build_to(
    scene: &Path,
    out: std::path::PathBuf,
    memory_limit: Option<u64>,
) -> Result<volga::scene::Report, BuildError> {
    build_seen(scene, out, memory_limit, &volga::NoProgress)
}

fn build_seen(
    scene: &Path,
    out: std::path::PathBuf,
    memory_limit: Option<u64>,
    progress: &dyn volga::Progress,
) -> Result<volga::scene::Report, BuildError> {
    build(
        scene,
        &BuildOptions {
            out_dir: out,
            memory_limit,
            stage_start: None,
            allow_outside_paths: false,
        },
        progress,
    )
}

/// The steps a build announced, in order.
#[derive(Default)]
struct SeenSteps(std::sync::Mutex<Vec<String>>);

impl volga::Progress for SeenSteps {
    fn start(&self, stage: &str, _total: u64) {
        self.0.lock().unwrap().push(stage.to_string());
    }
    fn inc(&self, _n: u64) {}
    fn finish(&self) {}
}

fn write_scene(dir: &Path, text: &str) -> std::path::PathBuf {
    let p = dir.join("scene.ron");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn build_writes_images_volume_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), &small_hello());
    let out = dir.path().join("out");
    let report = build_to(&scene, out.clone(), None).unwrap();

    for f in [
        "hello_iso.png",
        "hello_volume.png",
        "hello.nrrd",
        "hello.raw",
        "report.json",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let names: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(names.len(), 5, "no stray temporary files: {names:?}");

    let d = report.grid.dims;
    assert_eq!(d, [48, 48, 48]);
    assert_eq!(
        std::fs::metadata(out.join("hello.raw")).unwrap().len(),
        4 * 48 * 48 * 48
    );
    let vol = volga::io::read_nrrd(&out.join("hello.nrrd")).unwrap();
    assert_eq!(vol.grid.dims().to_array(), d);

    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("report.json")).unwrap()).unwrap();
    let stages: Vec<&str> = json["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["name"].as_str().unwrap())
        .collect();
    for s in [
        "load",
        "plan",
        "voxelize",
        "render:hello_iso",
        "render:hello_volume",
        "write",
    ] {
        assert!(stages.contains(&s), "stage {s} missing from {stages:?}");
    }
    for s in json["stages"].as_array().unwrap() {
        assert!(s["wall_s"].as_f64().is_some_and(|t| t.is_finite() && t > 0.0), "{s}");
        assert!(s["peak_mem_bytes"].as_u64().unwrap() > 0);
    }
    assert!(json["voxels"]["active"].as_u64().unwrap() > 1000);
    // The images read colour, so the plan allocates the colour channel and says why.
    let colour = json["plan"]["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "colour")
        .unwrap();
    assert_eq!(colour["enabled"], true);
    assert!(colour["why"].as_str().unwrap().contains("hello_iso"));
}

#[test]
fn unread_colour_channel_is_not_allocated_and_unlit_images_compute_no_gradients() {
    let dir = tempfile::tempdir().unwrap();
    let text = small_hello()
        .replace("colour: FromVolume", "colour: Constant((0.8, 0.8, 0.8))")
        .replace("Volume(colour_from_volume: true)", "Volume(colour_from_volume: false)")
        .replace(
            "lights: [\n        (direction: (0.6, 0.8, 0.9), colour: (1.0, 1.0, 1.0)),\n    ],",
            "lights: [],",
        );
    assert!(text.contains("lights: [],"));
    let scene = write_scene(dir.path(), &text);
    let report = build_to(&scene, dir.path().join("out"), None).unwrap();
    assert_eq!(report.voxels.colour_bricks, 0);
    assert!(
        !report
            .plan
            .channels
            .iter()
            .find(|c| c.name == "colour")
            .unwrap()
            .enabled
    );
    for im in &report.images {
        assert_eq!(
            im.gradient_evaluations, 0,
            "{} computed gradients without lights",
            im.name
        );
    }
}

#[test]
fn oversized_grid_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let text = small_hello().replace("resolution: 48", "resolution: 100000");
    let scene = write_scene(dir.path(), &text);
    let seen = SeenSteps::default();
    let err = build_seen(&scene, dir.path().join("out"), None, &seen).unwrap_err();
    match &err {
        BuildError::Scene(SceneError::TooLarge { needed, limit, .. }) => assert!(needed > limit),
        other => panic!("expected TooLarge, got {other:?}"),
    }
    let msg = err.to_string();
    assert!(
        msg.contains("needs an estimated") && msg.contains("PiB") && msg.contains("100000×100000×100000"),
        "{msg}"
    );
    assert!(err.is_bad_input());
    // Refused at planning: no step of the build was started.
    assert!(seen.0.lock().unwrap().is_empty(), "{:?}", seen.0.lock().unwrap());
    assert!(
        !dir.path().join("out").exists(),
        "no output directory for a refused build"
    );
}

#[test]
fn memory_limit_option_is_honoured() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), &small_hello());
    let err = build_to(&scene, dir.path().join("out"), Some(1 << 16)).unwrap_err();
    assert!(matches!(err, BuildError::Scene(SceneError::TooLarge { .. })), "{err:?}");
}

#[test]
fn failed_build_leaves_existing_outputs_intact() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), &small_hello());
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("hello_iso.png"), b"old image").unwrap();
    std::fs::write(out.join("report.json"), b"old report").unwrap();
    // A directory where the raw volume must go makes the build fail late, after the
    // images are rendered and staged.
    std::fs::create_dir(out.join("hello.raw")).unwrap();
    let err = build_to(&scene, out.clone(), None).unwrap_err();
    assert!(
        !err.is_bad_input(),
        "an output failure is a failed build (exit 1): {err}"
    );
    assert_eq!(std::fs::read(out.join("hello_iso.png")).unwrap(), b"old image");
    assert_eq!(std::fs::read(out.join("report.json")).unwrap(), b"old report");
    let names: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(
        sorted,
        ["hello.raw", "hello_iso.png", "report.json"],
        "temporary files left behind"
    );
}

#[test]
fn report_that_cannot_be_written_replaces_no_output() {
    // `report.json` is a directory: before, the images and volume were committed first
    // and only the report failed; now the report is staged with them.
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), &small_hello());
    let out = dir.path().join("out");
    std::fs::create_dir_all(out.join("report.json")).unwrap();
    std::fs::write(out.join("hello_iso.png"), b"old image").unwrap();
    let err = build_to(&scene, out.clone(), None).unwrap_err();
    assert!(!err.is_bad_input(), "{err}");
    assert_eq!(std::fs::read(out.join("hello_iso.png")).unwrap(), b"old image");
    assert!(!out.join("hello_volume.png").exists());
    assert!(!out.join("hello.nrrd").exists());
}

#[test]
fn volumes_larger_than_the_free_space_are_refused_before_voxelizing() {
    // A tiny sphere in a 100000 × 10 × 100000 grid: a few bricks of memory, but the
    // dense raw volume would take 400 GB.
    let dir = tempfile::tempdir().unwrap();
    let text = r#"Scene(
        grid: (bounds: (min: (0.0, 0.0, 0.0), max: (100000.0, 10.0, 100000.0)), voxel_size: 1.0),
        objects: [(shape: Sphere(center: (5.0, 5.0, 5.0), radius: 3.0))],
        cameras: [(name: "c", eye: (5.0, 5.0, 50.0), target: (5.0, 5.0, 5.0), projection: Orthographic(height: 10.0))],
        outputs: (volumes: [(name: "huge")]),
    )"#;
    let scene = write_scene(dir.path(), text);
    let seen = SeenSteps::default();
    let err = build_seen(&scene, dir.path().join("out"), Some(1 << 30), &seen).unwrap_err();
    assert!(!err.is_bad_input(), "{err}");
    let msg = err.to_string();
    assert!(msg.contains("not enough free space"), "{msg}");
    // Refused before voxelizing: the voxelize step never started.
    let seen = seen.0.lock().unwrap();
    assert!(
        !seen.iter().any(|s| s.contains("voxel")),
        "refused only after working: {seen:?}"
    );
    assert!(!dir.path().join("out/huge.raw").exists());
}

#[test]
fn mesh_files_too_large_to_parse_are_refused_before_reading() {
    let dir = tempfile::tempdir().unwrap();
    // 2 MB of OBJ text: parsing it is bounded by 24 MiB + 12 bytes a byte.
    let mut obj = String::new();
    while obj.len() < 2_000_000 {
        obj.push_str("v 0.125 0.25 0.5\n");
    }
    obj.push_str("f 1 2 3\n");
    std::fs::write(dir.path().join("big.obj"), obj).unwrap();
    let text = small_hello().replace(
        "    objects: [",
        "    objects: [\n        (name: \"big\", shape: Mesh(path: \"big.obj\")),",
    );
    let scene = write_scene(dir.path(), &text);
    let err = build_to(&scene, dir.path().join("out"), Some(40 << 20)).unwrap_err();
    assert!(err.is_bad_input(), "{err}");
    let msg = err.to_string();
    assert!(
        msg.contains("objects[0].shape.path") && msg.contains("big.obj"),
        "{msg}"
    );
}
