//! Every input bounded, as a hostile user meets it from the command line: each case once
//! panicked, aborted, ran away, clobbered an output or answered wrongly. Now each ends
//! with exit 2 (bad input, or a valid input larger than the memory limit) and a message
//! naming the field or flag, the size needed and the limit, and leaves no output.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn volga(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_volga"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

/// Runs `volga` and fails the test if it does not end within `limit` (a FIFO read, say).
fn volga_within(args: &[&str], limit: Duration) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_volga"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            child.kill().unwrap();
            panic!("volga {args:?} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit 2 with every `needles` in the message; nothing panicked.
#[track_caller]
fn refused(o: &Output, needles: &[&str]) -> String {
    let e = stderr(o);
    assert_eq!(
        o.status.code(),
        Some(2),
        "stderr: {e}\nstdout: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(!e.contains("panicked"), "{e}");
    for n in needles {
        assert!(e.contains(n), "`{n}` missing from: {e}");
    }
    e
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

const SPHERE_START: &str =
    "start: Start(object: (shape: Sphere(center: (0, 0, 0), radius: 0.5)), bounds: (min: (-1, -1, -1), max: (1, 1, 1)), voxel_size: 0.125)";

/// A scene around `root` or `objects`, with `images` and `extra` top-level fields.
fn scene(grid: &str, body: &str, images: &str, extra: &str) -> String {
    format!(
        "Scene(grid: {grid}, {body}, {extra} cameras: [(name: \"c\", eye: (0, 0, 4), target: (0, 0, 0), projection: Perspective(fov_deg: 40.0))], outputs: (images: [{images}]))"
    )
}

const GRID: &str = "(bounds: (min: (-1, -1, -1), max: (1, 1, 1)), resolution: 16)";
const BALL: &str = "objects: [(shape: Sphere(center: (0, 0, 0), radius: 0.5))]";
const ISO16: &str = "(name: \"i\", camera: \"c\", mode: Iso(value: 0.5), width: 16, height: 16)";

/// A valid sculpt file holding one uniform root node, with the grid given (bytes written
/// as `volga-sculpt`'s format: header, node, CRC-32).
fn sculpt_file(origin: [f64; 3], spacing: f64, levels: u32, density: f32) -> Vec<u8> {
    let mut b = Vec::new();
    b.extend_from_slice(b"VOLGASCT");
    b.extend_from_slice(&1u32.to_le_bytes());
    for c in origin {
        b.extend_from_slice(&c.to_le_bytes());
    }
    b.extend_from_slice(&spacing.to_le_bytes());
    b.extend_from_slice(&levels.to_le_bytes());
    b.push(0);
    for x in [density, 0.5, 0.5, 0.5] {
        b.extend_from_slice(&x.to_le_bytes());
    }
    let crc = volga_sculpt::crc32(&b);
    b.extend_from_slice(&crc.to_le_bytes());
    b
}

// 1. Panic: a spray falloff that overflows with half a voxel; a sculpt file at spacing 1.5e308.

#[test]
fn huge_spray_falloff_is_refused_in_stroke_files_and_scenes() {
    let dir = tempfile::tempdir().unwrap();
    let strokes = write(
        dir.path(),
        "s.ron",
        &format!(
            "Strokes({SPHERE_START}, strokes: [(op: Spray(strength: 1.0, falloff: 1.797e308), tool: Sphere(center: (0, 0, 0), radius: 0.3))])"
        ),
    );
    let out = dir.path().join("o.vsculpt");
    let o = volga(&["sculpt", "--strokes", &s(&strokes), "--out", &s(&out)]);
    refused(&o, &["strokes[0].op", "falloff"]);
    assert!(!out.exists());

    let sc = write(
        dir.path(),
        "scene.ron",
        &scene(
            GRID,
            "root: Sculpt(operand: Object(shape: Sphere(center: (0, 0, 0), radius: 0.5)), strokes: [(op: Spray(strength: 1.0, falloff: 1.797e308), tool: Sphere(center: (0, 0, 0), radius: 0.3))])",
            ISO16,
            "",
        ),
    );
    refused(&volga(&["plan", &s(&sc)]), &["root.Sculpt.strokes[0].op", "falloff"]);
    let o = volga(&["build", &s(&sc), "--out", &s(&dir.path().join("b"))]);
    refused(&o, &["falloff"]);
    assert!(files_in(&dir.path().join("b")).is_empty());
}

#[test]
fn sculpt_file_with_a_spacing_beyond_the_world_bound_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("far.vsculpt");
    std::fs::write(&file, sculpt_file([0.0; 3], 1.5e308, 0, 0.0)).unwrap();
    let strokes = write(
        dir.path(),
        "s.ron",
        "Strokes(strokes: [(op: Add, tool: Sphere(center: (0, 0, 0), radius: 1.0))])",
    );
    let o = volga(&[
        "sculpt",
        "--strokes",
        &s(&strokes),
        "--sculpt",
        &s(&file),
        "--mesh",
        &s(&dir.path().join("m.obj")),
    ]);
    refused(&o, &["far.vsculpt", "spacing 1.5e308"]);
    assert_eq!(files_in(dir.path()), ["far.vsculpt", "s.ron"]);
}

// 2. Aborts: a NRRD claiming more voxels than memory holds.

/// A NRRD header of `n³` unsigned bytes with detached data `name.raw`, made sparse at
/// the full size (no disk used).
fn huge_nrrd(dir: &Path, name: &str, n: u64) -> PathBuf {
    let header = dir.join(format!("{name}.nrrd"));
    std::fs::write(
        &header,
        format!("NRRD0004\ntype: uchar\ndimension: 3\nsizes: {n} {n} {n}\nencoding: raw\ndata file: {name}.raw\n\n"),
    )
    .unwrap();
    std::fs::File::create(dir.join(format!("{name}.raw")))
        .unwrap()
        .set_len(n * n * n)
        .unwrap();
    header
}

#[test]
fn nrrd_larger_than_memory_is_refused_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let header = huge_nrrd(dir.path(), "v", 8000);
    // 8000³ voxels: 512 GB on disk (sparse), 2 TB as f32.
    let o = volga(&["validate", &s(&header)]);
    refused(&o, &["v.nrrd", "sizes 8000 8000 8000", "1.86 TiB", "memory"]);

    let sc = write(
        dir.path(),
        "scene.ron",
        &scene(GRID, "root: Volume((path: \"v.nrrd\"))", ISO16, ""),
    );
    for cmd in ["plan", "build"] {
        let mut args = vec![cmd, sc.to_str().unwrap(), "--memory-limit", "512M"];
        let out = dir.path().join("out");
        if cmd == "build" {
            args.extend(["--out", out.to_str().unwrap()]);
        }
        refused(
            &volga(&args),
            &["root.Volume.path", "sizes 8000 8000 8000", "512.00 MiB"],
        );
        assert!(files_in(&out).is_empty());
    }
    let sc = write(
        dir.path(),
        "hyper.ron",
        &scene(
            GRID,
            "root: Hypertexture((object: Volume(path: \"v.nrrd\"), soft_width: 0.1))",
            ISO16,
            "",
        ),
    );
    refused(
        &volga(&["plan", &s(&sc), "--memory-limit", "512M"]),
        &["sizes 8000 8000 8000"],
    );
}

// 3. Data loss: outputs compared as files, not as text.

#[test]
fn two_spellings_of_one_output_are_refused_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("d/sub")).unwrap();
    let strokes = write(
        dir.path(),
        "s.ron",
        &format!("Strokes({SPHERE_START}, strokes: [(op: Carve, tool: Sphere(center: (0.5, 0, 0), radius: 0.3))])"),
    );
    let out = dir.path().join("d/sub/../v.raw");
    let volume = dir.path().join("d/v.nrrd");
    let o = volga(&[
        "sculpt",
        "--strokes",
        &s(&strokes),
        "--out",
        &s(&out),
        "--volume",
        &s(&volume),
    ]);
    refused(&o, &["--out", "--volume", "same file"]);
    assert_eq!(files_in(&dir.path().join("d")), ["sub"]);
}

// 4. Unbounded reads: devices and FIFOs are not files to read.

#[test]
fn devices_and_fifos_are_refused_without_reading() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let link = |name: &str| {
        let p = d.join(name);
        std::os::unix::fs::symlink("/dev/zero", &p).unwrap();
        s(&p)
    };
    let limit = Duration::from_secs(30);
    let out = s(&d.join("o.binvox"));
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "voxelize".into(),
                link("zero.obj"),
                "--resolution".into(),
                "8".into(),
                "--separability".into(),
                "26".into(),
                "--out".into(),
                out.clone(),
            ],
            "character device",
        ),
        (vec!["validate".into(), link("zero.binvox")], "character device"),
        (vec!["plan".into(), link("zero.ron")], "character device"),
        (
            vec!["sculpt".into(), "--strokes".into(), link("zs.ron")],
            "character device",
        ),
    ];
    for (args, needle) in &cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(&volga_within(&args, limit), &[needle]);
    }
    // A sculpt file that is /dev/zero.
    let strokes = write(d, "s.ron", "Strokes(strokes: [])");
    let o = volga_within(&["sculpt", "--strokes", &s(&strokes), "--sculpt", "/dev/zero"], limit);
    refused(&o, &["/dev/zero"]);
    // A FIFO never opened (opening it would wait for a writer).
    let fifo = d.join("pipe.ron");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    refused(&volga_within(&["plan", &s(&fifo)], limit), &["FIFO"]);
    let fifo_obj = d.join("pipe.obj");
    assert!(Command::new("mkfifo").arg(&fifo_obj).status().unwrap().success());
    refused(
        &volga_within(
            &[
                "voxelize",
                &s(&fifo_obj),
                "--resolution",
                "8",
                "--separability",
                "26",
                "--out",
                &out,
            ],
            limit,
        ),
        &["FIFO"],
    );
    assert!(!d.join("o.binvox").exists());
}

// 5. --memory-limit kept: detached data, sculpt nodes, sculpt outputs, mesh outputs.

#[test]
fn detached_nrrd_data_counts_against_the_memory_limit() {
    let dir = tempfile::tempdir().unwrap();
    // 1024³ bytes of data (sparse) behind a 100-byte header: 4 GiB as f32.
    huge_nrrd(dir.path(), "v", 1024);
    let sc = write(
        dir.path(),
        "scene.ron",
        &scene(GRID, "root: Volume((path: \"v.nrrd\"))", ISO16, ""),
    );
    refused(
        &volga(&["plan", &s(&sc), "--memory-limit", "512M"]),
        &["sizes 1024 1024 1024", "4.00 GiB", "512.00 MiB"],
    );
}

#[test]
fn sculpt_node_strokes_count_in_the_plan() {
    let dir = tempfile::tempdir().unwrap();
    let sc = write(
        dir.path(),
        "scene.ron",
        &scene(
            "(bounds: (min: (-1, -1, -1), max: (1, 1, 1)), resolution: 16384)",
            "root: Sculpt(operand: Object(shape: Sphere(center: (0, 0, 0), radius: 0.01)), strokes: [(op: Add, tool: Box(min: (-0.9, -0.9, -0.9), max: (0.9, 0.9, 0.9)))])",
            &ISO16.replace("width: 16", "width: 16, source: Lazy"),
            "",
        ),
    );
    let e = refused(&volga(&["plan", &s(&sc), "--memory-limit", "2G"]), &["2.00 GiB"]);
    assert!(e.contains("needs") || e.contains("estimate"), "{e}");
}

#[test]
fn sculpt_outputs_are_bounded_by_the_memory_limit() {
    let dir = tempfile::tempdir().unwrap();
    // A full sculpt of 17 levels (the format's deepest): 2^51 voxels, one node on disk.
    let full = dir.path().join("full.vsculpt");
    std::fs::write(&full, sculpt_file([0.0; 3], 1.0, 17, 1.0)).unwrap();
    let strokes = write(dir.path(), "s.ron", "Strokes(strokes: [])");
    let vol = dir.path().join("v.nrrd");
    let o = volga(&[
        "sculpt",
        "--strokes",
        &s(&strokes),
        "--sculpt",
        &s(&full),
        "--volume",
        &s(&vol),
        "--memory-limit",
        "1G",
    ]);
    refused(&o, &["--volume", "bricks", "1.00 GiB"]);
    let mesh = dir.path().join("m.obj");
    let o = volga(&[
        "sculpt",
        "--strokes",
        &s(&strokes),
        "--sculpt",
        &s(&full),
        "--mesh",
        &s(&mesh),
        "--memory-limit",
        "1G",
    ]);
    refused(&o, &["--mesh"]);
    assert_eq!(files_in(dir.path()), ["full.vsculpt", "s.ron"]);

    // A stroke adding a box across a 16384³ start: refused before it runs.
    let big = write(
        dir.path(),
        "big.ron",
        "Strokes(start: Start(object: (shape: Sphere(center: (0, 0, 0), radius: 0.01)), bounds: (min: (-1, -1, -1), max: (1, 1, 1)), voxel_size: 0.000125), strokes: [(op: Add, tool: Box(min: (-0.9, -0.9, -0.9), max: (0.9, 0.9, 0.9)))])",
    );
    let o = volga(&[
        "sculpt",
        "--strokes",
        &s(&big),
        "--out",
        &s(&dir.path().join("o.vsculpt")),
        "--memory-limit",
        "2G",
    ]);
    refused(&o, &["strokes[0..=0]", "2.00 GiB"]);
}

#[test]
fn a_deep_sculpt_with_little_material_is_meshed() {
    let dir = tempfile::tempdir().unwrap();
    // 17 levels, a small ball at the origin corner: only the material's blocks are meshed.
    let strokes = write(
        dir.path(),
        "s.ron",
        "Strokes(strokes: [(op: Add, tool: Sphere(center: (8, 8, 8), radius: 5))])",
    );
    let deep = dir.path().join("deep.vsculpt");
    std::fs::write(&deep, sculpt_file([0.0; 3], 1.0, 17, 0.0)).unwrap();
    let mesh = dir.path().join("m.obj");
    let o = volga(&[
        "sculpt",
        "--strokes",
        &s(&strokes),
        "--sculpt",
        &s(&deep),
        "--mesh",
        &s(&mesh),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(report["mesh_triangles"].as_u64().unwrap() > 100, "{report}");
}

#[test]
fn mesh_output_stops_at_the_memory_limit() {
    let dir = tempfile::tempdir().unwrap();
    let sc = write(
        dir.path(),
        "scene.ron",
        "Scene(grid: (bounds: (min: (-1, -1, -1), max: (1, 1, 1)), resolution: 1000), objects: [(shape: Sphere(center: (0, 0, 0), radius: 0.9))], cameras: [], outputs: (meshes: [(name: \"m\", format: Obj)]))",
    );
    let out = dir.path().join("out");
    let o = volga(&["build", &s(&sc), "--out", &s(&out), "--memory-limit", "64M"]);
    // Stopped while running (exit 1), not refused before work.
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("outputs.meshes.m") && e.contains("triangles"), "{e}");
    assert!(
        files_in(&out).iter().all(|f| !f.ends_with(".obj")),
        "{:?}",
        files_in(&out)
    );
}

// 6. Runaway work: lights, shadow steps, hypertexture chains, turntables.

#[test]
fn work_beyond_the_bounds_is_refused_by_the_plan() {
    let dir = tempfile::tempdir().unwrap();
    let lights = (0..10_000)
        .map(|_| "(direction: (0, 0, 1), colour: (1, 1, 1), shadows: true)")
        .collect::<Vec<_>>()
        .join(", ");
    let sc = write(
        dir.path(),
        "lights.ron",
        &scene(GRID, BALL, ISO16, &format!("lights: [{lights}],")),
    );
    refused(&volga(&["plan", &s(&sc)]), &["lights", "10000", "at most 64"]);

    let shadow = ISO16.replace("height: 16", "height: 16, shadow_step_voxels: 1e-6");
    let sc = write(
        dir.path(),
        "shadow.ron",
        &scene(
            GRID,
            BALL,
            &shadow,
            "lights: [(direction: (0, 0, 1), colour: (1, 1, 1), shadows: true)],",
        ),
    );
    refused(
        &volga(&["plan", &s(&sc)]),
        &["outputs.images[0].shadow_step_voxels", "samples"],
    );

    let steps = (0..100_000).map(|_| "Bias(0.5)").collect::<Vec<_>>().join(", ");
    let sc = write(
        dir.path(),
        "chain.ron",
        &scene(
            GRID,
            &format!("root: Hypertexture((object: Sphere(center: (0, 0, 0), radius: 0.5), soft_width: 0.1, chain: [{steps}]))"),
            ISO16,
            "",
        ),
    );
    refused(&volga(&["plan", &s(&sc)]), &["root.Hypertexture.chain", "at most 64"]);

    let turntable =
        "(name: \"t\", camera: \"c\", mode: Iso(value: 0.5), width: 16384, height: 16384, turntable: (frames: 3600))";
    let sc = write(dir.path(), "turn.ron", &scene(GRID, BALL, turntable, ""));
    refused(&volga(&["plan", &s(&sc)]), &["field samples", "3600 image files"]);
}

// 7. Late checks now early.

#[test]
fn settings_that_fail_late_are_refused_by_plan() {
    let dir = tempfile::tempdir().unwrap();
    let shadow = ISO16.replace("height: 16", "height: 16, shadow_step_voxels: 1e-9");
    let sc = write(
        dir.path(),
        "shadow.ron",
        &scene(
            GRID,
            BALL,
            &shadow,
            "lights: [(direction: (0, 0, 1), colour: (1, 1, 1), shadows: true)],",
        ),
    );
    refused(&volga(&["plan", &s(&sc)]), &["shadow_step_voxels"]);

    std::fs::write(dir.path().join("v.binvox"), binvox_cube()).unwrap();
    let sc = write(
        dir.path(),
        "far.ron",
        &scene(
            GRID,
            "root: Hypertexture((object: Volume(path: \"v.binvox\", translate: (1e308, 0, 0)), soft_width: 0.1))",
            ISO16,
            "",
        ),
    );
    refused(
        &volga(&["plan", &s(&sc)]),
        &["root.Hypertexture.object.Volume.translate", "1e100"],
    );

    let sc = write(
        dir.path(),
        "tiny.ron",
        &scene(
            "(bounds: (min: (0, 0, 0), max: (1e-299, 1e-299, 1e-299)), resolution: 16)",
            "objects: [(shape: Sphere(center: (5e-300, 5e-300, 5e-300), radius: 3e-300))]",
            ISO16,
            "",
        ),
    );
    refused(&volga(&["plan", &s(&sc)]), &["grid.resolution", "1e-100"]);
}

/// A 4³ binvox model, all filled.
fn binvox_cube() -> Vec<u8> {
    let mut b = b"#binvox 1\ndim 4 4 4\ntranslate 0 0 0\nscale 0.5\ndata\n".to_vec();
    b.extend_from_slice(&[1, 64]);
    b
}

// 8. Messages that name the cause.

#[test]
fn messages_name_the_cause() {
    let dir = tempfile::tempdir().unwrap();
    // Deep CVG nesting.
    let mut node = "Object(shape: Sphere(center: (0, 0, 0), radius: 0.5))".to_string();
    for _ in 0..40 {
        node = format!("Cvg((op: Union, operands: [{node}]))");
    }
    let sc = write(
        dir.path(),
        "deep.ron",
        &scene(GRID, &format!("root: {node}"), ISO16, ""),
    );
    let e = refused(&volga(&["plan", &s(&sc)]), &["nests deeper", "Union"]);
    assert!(!e.contains("serde_stacker"), "{e}");

    // A resolution whose rays need too many samples names the grid, not only the step.
    let sc = write(
        dir.path(),
        "res.ron",
        &scene(
            "(bounds: (min: (-1, -1, -1), max: (1, 1, 1)), resolution: 1000000000)",
            BALL,
            &ISO16.replace("height: 16", "height: 16, source: Lazy"),
            "",
        ),
    );
    refused(
        &volga(&["plan", &s(&sc)]),
        &["1000000000×1000000000×1000000000 grid", "lower the grid's resolution"],
    );

    // A saw path too long for its step.
    let strokes = write(
        dir.path(),
        "saw.ron",
        &format!("Strokes({SPHERE_START}, strokes: [(op: Carve, tool: Sphere(center: (0, 0, 0), radius: 0.1), path: [(0, 0, 0), (1e300, 0, 0)])])"),
    );
    let e = refused(
        &volga(&["sculpt", "--strokes", &s(&strokes)]),
        &["strokes[0].path", "segment 0"],
    );
    assert!(!e.contains("18446744073709551615"), "{e}");

    // A NRRD naming a data file outside its folder.
    let header = write(
        dir.path(),
        "x.nrrd",
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: /etc/passwd\n\n",
    );
    let e = refused(&volga(&["validate", &s(&header)]), &["x.nrrd", "absolute path"]);
    assert!(!e.contains("bytes left"), "{e}");
}

// Scene paths confined to the scene's folder unless allowed.

#[test]
fn scene_paths_stay_in_the_scene_folder_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let inner = dir.path().join("scenes");
    std::fs::create_dir_all(&inner).unwrap();
    let mesh = dir.path().join("tet.obj");
    std::fs::write(
        &mesh,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .unwrap();
    for path in ["../tet.obj".to_string(), s(&mesh)] {
        let sc = write(
            &inner,
            "s.ron",
            &scene(GRID, &format!("objects: [(shape: Mesh(path: \"{path}\"))]"), ISO16, ""),
        );
        refused(&volga(&["plan", &s(&sc)]), &["objects[0]", "--allow-outside-paths"]);
        let o = volga(&["plan", &s(&sc), "--allow-outside-paths"]);
        assert!(o.status.success(), "{path}: {}", stderr(&o));
    }
    // Stroke files' mesh tools likewise.
    let strokes = write(
        &inner,
        "st.ron",
        &format!("Strokes({SPHERE_START}, strokes: [(op: Carve, tool: Mesh(path: \"../tet.obj\"))])"),
    );
    refused(
        &volga(&["sculpt", "--strokes", &s(&strokes)]),
        &["strokes[0].tool.path", "--allow-outside-paths"],
    );
    let o = volga(&["sculpt", "--strokes", &s(&strokes), "--allow-outside-paths"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

// Interrupted builds leave no temp files and no partial outputs.

#[test]
fn interrupt_removes_temp_files() {
    let dir = tempfile::tempdir().unwrap();
    let frames =
        "(name: \"t\", camera: \"c\", mode: Iso(value: 0.5), width: 64, height: 64, turntable: (frames: 3600))";
    let sc = write(dir.path(), "turn.ron", &scene(GRID, BALL, frames, ""));
    let out = dir.path().join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_volga"))
        .args(["build", &s(&sc), "--out", &s(&out)])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait for staged frames (temp files) to exist, then interrupt.
    let start = Instant::now();
    loop {
        if files_in(&out).iter().any(|f| f.contains(".tmp-")) {
            break;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the build ended before any frame was staged"
        );
        assert!(start.elapsed() < Duration::from_secs(120), "no temp file after 120 s");
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap()
        .success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(files_in(&out).is_empty(), "left behind: {:?}", files_in(&out));
    let _ = std::io::stderr().flush();
}
