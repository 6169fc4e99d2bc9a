//! Scene files asking for the raycaster's effects: point lights, shadows per light,
//! pre-integration and turntables — built through the library, and refused with the
//! field path when wrong.

use std::path::Path;

use volga::scene::{build, BuildOptions};

/// A ball over a floor, lit by a red point light that casts shadows and a blue
/// directional light that does not; `{images}` is replaced by the image list.
const SCENE: &str = r#"Scene(
    grid: (bounds: (min: (-1.0, -1.0, -1.0), max: (1.0, 1.0, 1.0)), resolution: 24),
    objects: [
        (name: "ball", shape: Sphere(center: (0.0, 0.1, 0.0), radius: 0.5)),
        (name: "floor", shape: Box(min: (-0.9, -0.8, -0.9), max: (0.9, -0.6, 0.9))),
    ],
    transfer_function: [
        (value: 0.0, rgba: (1.0, 1.0, 1.0, 0.0)),
        (value: 0.5, rgba: (1.0, 1.0, 1.0, 0.3)),
        (value: 1.0, rgba: (1.0, 1.0, 1.0, 0.5)),
    ],
    lights: [
        (position: (0.9, 1.5, 0.6), colour: (1.0, 0.3, 0.2), attenuation: (0.5, 0.0, 0.2), shadows: true),
        (direction: (-0.5, 1.0, 0.3), colour: (0.2, 0.3, 1.0)),
    ],
    cameras: [(name: "c", eye: (1.5, 1.2, 2.5), target: (0.0, -0.2, 0.0), projection: Perspective(fov_deg: 40.0))],
    outputs: (images: [{images}]),
)"#;

fn scene(images: &str) -> String {
    SCENE.replace("{images}", images)
}

fn build_scene(dir: &Path, text: &str) -> Result<volga::scene::Report, volga::scene::BuildError> {
    let p = dir.join("scene.ron");
    std::fs::write(&p, text).unwrap();
    build(
        &p,
        &BuildOptions {
            out_dir: dir.join("out"),
            memory_limit: None,
            stage_start: None,
            allow_outside_paths: false,
        },
        &volga::NoProgress,
    )
}

#[test]
fn a_turntable_writes_numbered_frames_atomically() {
    let dir = tempfile::tempdir().unwrap();
    let text = scene(
        r#"(name: "spin", camera: "c", mode: Iso(value: 0.5), width: 16, height: 12,
            turntable: (frames: 4, axis: (0.0, 1.0, 0.0)))"#,
    );
    let report = build_scene(dir.path(), &text).unwrap();
    let out = dir.path().join("out");
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "report.json",
            "spin_0000.png",
            "spin_0001.png",
            "spin_0002.png",
            "spin_0003.png"
        ]
    );
    assert_eq!(report.images.len(), 4);
    assert_eq!(report.images[2].name, "spin_0002");
    // The frames are different views (the scene is not symmetric about the axis) and
    // the light that casts shadows spends shadow rays in every frame.
    let bytes: Vec<Vec<u8>> = (0..4)
        .map(|k| std::fs::read(out.join(format!("spin_{k:04}.png"))).unwrap())
        .collect();
    assert_ne!(bytes[0], bytes[1]);
    assert_ne!(bytes[1], bytes[2]);
    assert!(report.images.iter().all(|i| i.shadow_rays > 0));

    // A second build whose turntable fails validation leaves the frames alone.
    let bad = scene(
        r#"(name: "spin", camera: "c", mode: Iso(value: 0.5), width: 16, height: 12,
            turntable: (frames: 0))"#,
    );
    let err = build_scene(dir.path(), &bad).unwrap_err().to_string();
    assert!(err.contains("outputs.images[0].turntable.frames"), "{err}");
    assert_eq!(std::fs::read(out.join("spin_0001.png")).unwrap(), bytes[1]);
}

#[test]
fn shadows_and_pre_integration_are_planned_only_where_asked() {
    let dir = tempfile::tempdir().unwrap();
    let text = scene(
        r#"(name: "lit", camera: "c", mode: Volume(), width: 12, height: 12, pre_integration: true, shadow_step_voxels: 2.0),
           (name: "flat", camera: "c", mode: Volume(), width: 12, height: 12, shading: false),
           (name: "mip", camera: "c", mode: Mip, width: 12, height: 12)"#,
    );
    let report = build_scene(dir.path(), &text).unwrap();
    let by_name = |n: &str| report.images.iter().find(|i| i.name == n).unwrap();
    assert!(by_name("lit").shadow_rays > 0 && by_name("lit").shadow_samples > 0);
    for n in ["flat", "mip"] {
        assert_eq!((by_name(n).shadow_rays, by_name(n).shadow_samples), (0, 0), "{n}");
    }
}

#[test]
fn bad_lights_and_effect_settings_name_their_field() {
    let image = r#"(name: "a", camera: "c", mode: Iso(value: 0.5), width: 8, height: 8)"#;
    let cases = [
        (
            SCENE.replace(
                "(position: (0.9, 1.5, 0.6),",
                "(position: (0.9, 1.5, 0.6), direction: (1.0, 0.0, 0.0),",
            ),
            "lights[0]",
        ),
        (
            SCENE.replace("attenuation: (0.5, 0.0, 0.2)", "attenuation: (0.0, 0.0, 0.0)"),
            "lights[0].attenuation",
        ),
        (
            SCENE.replace(
                "colour: (0.2, 0.3, 1.0))",
                "colour: (0.2, 0.3, 1.0), attenuation: (1.0, 0.0, 0.0))",
            ),
            "lights[1].attenuation",
        ),
        (
            SCENE.replace("position: (0.9, 1.5, 0.6)", "position: (0.9, inf, 0.6)"),
            "lights[0].position",
        ),
    ];
    for (text, path) in cases {
        let dir = tempfile::tempdir().unwrap();
        let err = build_scene(dir.path(), &text.replace("{images}", image))
            .unwrap_err()
            .to_string();
        assert!(err.contains(path), "{path}: {err}");
    }
    for (image, path) in [
        (
            r#"(name: "a", camera: "c", mode: Iso(value: 0.5), width: 8, height: 8, shadow_step_voxels: 0.0)"#,
            "outputs.images[0].shadow_step_voxels",
        ),
        (
            r#"(name: "a", camera: "c", mode: Iso(value: 0.5), width: 8, height: 8, pre_integration: true)"#,
            "outputs.images[0].pre_integration",
        ),
        (
            r#"(name: "a", camera: "c", mode: Mip, width: 8, height: 8, light_space_shadows: true)"#,
            "outputs.images[0].light_space_shadows",
        ),
        (
            r#"(name: "a", camera: "c", mode: Iso(value: 0.5), width: 8, height: 8, turntable: (frames: 2, axis: (0.0, 0.0, 0.0)))"#,
            "outputs.images[0].turntable.axis",
        ),
        (
            r#"(name: "a_0001", camera: "c", mode: Mip, width: 8, height: 8), (name: "a", camera: "c", mode: Mip, width: 8, height: 8, turntable: (frames: 2))"#,
            "outputs.images[1].name",
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let err = build_scene(dir.path(), &scene(image)).unwrap_err().to_string();
        assert!(err.contains(path), "{path}: {err}");
    }
}
