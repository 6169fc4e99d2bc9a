//! `volga validate` as a user runs it: voxel models made here with known answers, a
//! voxelization by volga itself, exit codes and messages on bad input.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Output;

use glam::{DVec3, IVec3, UVec3};
use serde_json::Value;

mod common;
use common::{arg, stderr, volga};

fn json(o: &Output) -> Value {
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&o.stdout)))
}

/// A `.binvox` of `dims` voxels with the given black voxels; translate 0 and scale
/// `max(dims)`, so voxel `ijk`'s centre is at world `ijk + ½`.
fn write_binvox(path: &Path, dims: UVec3, voxels: impl IntoIterator<Item = IVec3>) {
    let model = volga_io::Binvox::from_filled(
        dims,
        DVec3::ZERO,
        dims.max_element() as f64,
        voxels.into_iter().map(|v| v.as_uvec3()),
    )
    .unwrap();
    volga_io::write_binvox(path, &model).unwrap();
}

fn grid_voxels(dims: UVec3) -> impl Iterator<Item = IVec3> {
    let d = dims.as_ivec3();
    (0..d.z).flat_map(move |z| (0..d.y).flat_map(move |y| (0..d.x).map(move |x| IVec3::new(x, y, z))))
}

/// A UV sphere (vertices on the sphere, so the mesh lies just inside it) as OBJ text.
fn sphere_obj(centre: DVec3, radius: f64, slices: usize, stacks: usize) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "v {} {} {}", centre.x, centre.y, centre.z + radius);
    for i in 1..stacks {
        let theta = PI * i as f64 / stacks as f64;
        for j in 0..slices {
            let phi = 2.0 * PI * j as f64 / slices as f64;
            let p = centre + radius * DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
        }
    }
    let _ = writeln!(s, "v {} {} {}", centre.x, centre.y, centre.z - radius);
    let ring = |i: usize, j: usize| 2 + (i - 1) * slices + j % slices; // 1-based OBJ index
    let bottom = 2 + (stacks - 1) * slices;
    for j in 0..slices {
        let _ = writeln!(s, "f 1 {} {}", ring(1, j), ring(1, j + 1));
        for i in 1..stacks - 1 {
            let (a, b, c, d) = (ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1));
            let _ = writeln!(s, "f {a} {b} {c}\nf {a} {c} {d}");
        }
        let _ = writeln!(s, "f {} {bottom} {}", ring(stacks - 1, j), ring(stacks - 1, j + 1));
    }
    s
}

/// Voxels whose closed cell meets the spherical band `r − 0.05 ≤ ‖p − c‖ ≤ r`: a shell
/// that covers any surface lying in that band, so no segment between two white
/// 26-neighbours can meet such a surface (the meeting point would lie in the cell of
/// the nearer end).
fn sphere_shell(dims: UVec3, centre: DVec3, r: f64) -> Vec<IVec3> {
    grid_voxels(dims)
        .filter(|v| {
            let d = (v.as_dvec3() - centre).abs();
            let near = (d - 0.5).max(DVec3::ZERO).length();
            let far = (d + 0.5).length();
            near <= r && far >= r - 0.05
        })
        .collect()
}

struct Sphere {
    dir: tempfile::TempDir,
    shell: PathBuf,
    mesh: PathBuf,
    /// The voxel on the +x axis whose cell alone holds the sphere's point there.
    pole: IVec3,
    voxels: Vec<IVec3>,
    dims: UVec3,
}

/// A sphere of radius 6.3 voxels about voxel (10, 10, 10): its shell and its mesh in
/// the same world space (voxel centres at `ijk + ½`).
fn sphere() -> Sphere {
    let dir = tempfile::tempdir().unwrap();
    let dims = UVec3::splat(21);
    let centre = IVec3::splat(10);
    let voxels = sphere_shell(dims, centre.as_dvec3(), 6.3);
    let shell = dir.path().join("shell.binvox");
    write_binvox(&shell, dims, voxels.iter().copied());
    let mesh = dir.path().join("sphere.obj");
    std::fs::write(&mesh, sphere_obj(centre.as_dvec3() + 0.5, 6.3, 96, 48)).unwrap();
    let pole = centre + IVec3::new(6, 0, 0);
    assert!(voxels.contains(&pole));
    Sphere {
        dir,
        shell,
        mesh,
        pole,
        voxels,
        dims,
    }
}

#[test]
fn sphere_shell_is_separating_covering_and_reports_its_components() {
    let s = sphere();
    let o = volga(&["validate", arg(&s.shell), "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let j = json(&o);
    assert_eq!(j["format"], "binvox");
    assert_eq!(j["report"]["connectivity"], 26);
    assert_eq!(j["report"]["separating"], true);
    assert_eq!(j["report"]["white_component_count"], 2);
    assert_eq!(j["report"]["white_components"][0]["region"], "outside");
    assert_eq!(j["report"]["white_components"][1]["region"], "inside");
    assert_eq!(j["report"]["cavities"], 1);
    assert_eq!(j["report"]["mesh"], Value::Null);
    assert_eq!(j["requirements"][0]["name"], "separating");
    assert_eq!(j["passed"], true);

    for n in ["6", "18", "26"] {
        let o = volga(&[
            "validate",
            arg(&s.shell),
            "--mesh",
            arg(&s.mesh),
            "--connectivity",
            n,
            "--require",
            "separating,cover",
            "--json",
        ]);
        assert_eq!(o.status.code(), Some(0), "{n}: {}", stderr(&o));
        let m = &json(&o)["report"]["mesh"];
        assert_eq!(m["tunnel_count"], 0, "{n}");
        assert_eq!(m["covers"], true, "{n}");
        assert_eq!(m["triangles"], 96 * 2 * 47);
    }

    // The readable summary by default.
    let o = volga(&["validate", arg(&s.shell), "--mesh", arg(&s.mesh)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("26-tunnels: 0"), "{text}");
    assert!(text.contains("required separating: holds"), "{text}");
}

#[test]
fn one_voxel_removed_from_the_shell_leaks_there() {
    let s = sphere();
    let holed = s.dir.path().join("holed.binvox");
    write_binvox(&holed, s.dims, s.voxels.iter().copied().filter(|&v| v != s.pole));

    // Without a mesh: inside and outside merge, so white is one component.
    let o = volga(&["validate", arg(&holed), "--require", "separating", "--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let j = json(&o);
    assert_eq!(j["report"]["white_component_count"], 1);
    assert_eq!(j["passed"], false);
    assert_eq!(j["requirements"][0]["holds"], false);

    // With the mesh: every tunnel passes through the removed voxel, and the sphere is
    // uncovered there.
    let o = volga(&["validate", arg(&holed), "--mesh", arg(&s.mesh), "--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let m = json(&o)["report"]["mesh"].clone();
    assert!(m["tunnel_count"].as_u64().unwrap() >= 1);
    let pole = serde_json::json!(s.pole.to_array());
    for t in m["tunnels"].as_array().unwrap() {
        assert!(t["a"] == pole || t["b"] == pole, "{t}");
    }
    let straight = m["tunnels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["b"] == serde_json::json!((s.pole + IVec3::X).to_array()))
        .expect("the pair straight through the pole");
    // World position of the crossing: on the sphere's +x pole, x = 10.5 + 6.3.
    let world: Vec<f64> = serde_json::from_value(straight["world"].clone()).unwrap();
    assert!(
        (world[0] - 16.8).abs() < 1e-9 && (world[1] - 10.5).abs() < 1e-9,
        "{world:?}"
    );
    assert_eq!(m["covers"], false);
    assert_eq!(m["uncovered"][0]["voxel"], pole);

    // The summary points at it too.
    let o = volga(&["validate", arg(&holed), "--mesh", arg(&s.mesh)]);
    assert_eq!(o.status.code(), Some(1));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("required separating: FAILS"), "{text}");
    assert!(text.contains("(16, 10, 10)"), "{text}");
}

#[test]
fn doubled_layer_is_separating_but_not_minimal() {
    let dir = tempfile::tempdir().unwrap();
    let dims = UVec3::splat(8);
    let layer = dir.path().join("layer.binvox");
    write_binvox(&layer, dims, grid_voxels(dims).filter(|v| v.z == 3 || v.z == 4));
    let o = volga(&["validate", arg(&layer), "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = volga(&["validate", arg(&layer), "--require", "separating,minimal", "--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let j = json(&o);
    assert_eq!(j["report"]["separating"], true);
    assert_eq!(j["report"]["minimal"], false);
    assert_eq!(j["report"]["simple_voxel_count"], 128);
    assert_eq!(j["report"]["simple_voxels"][0], serde_json::json!([0, 0, 3]));
    assert_eq!(j["report"]["simple_voxels"].as_array().unwrap().len(), 32);
    let holds: Vec<bool> = j["requirements"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["holds"].as_bool().unwrap())
        .collect();
    assert_eq!(holds, [true, false]);

    // A single layer is minimal.
    let single = dir.path().join("single.binvox");
    write_binvox(&single, dims, grid_voxels(dims).filter(|v| v.z == 3));
    let o = volga(&["validate", arg(&single), "--require", "minimal"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn nrrd_models_and_padding() {
    // A plane across an NRRD density volume separates the grid, but not once a white
    // layer around it lets white go around the plane's edge.
    let dir = tempfile::tempdir().unwrap();
    let t = volga_core::Transform::new(DVec3::new(-3.0, 2.0, 0.25), DVec3::splat(0.5)).unwrap();
    let grid = volga_core::Grid::new(t, UVec3::splat(6)).unwrap();
    let mut volume = volga_core::SparseVolume::new(grid, 0.0, false);
    for v in grid_voxels(UVec3::splat(6)).filter(|v| v.y == 2) {
        volume.density.set(v, if v.x == 0 { 0.5 } else { 0.9 });
    }
    volume.density.set(IVec3::new(1, 4, 1), 0.49); // below the threshold
    let mut staged = volga_io::StagedOutputs::new();
    volga_io::write_nrrd(dir.path(), "plane", &volume, &mut staged).unwrap();
    staged.commit().unwrap();
    let nrrd = dir.path().join("plane.nrrd");

    let o = volga(&["validate", arg(&nrrd), "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let j = json(&o);
    assert_eq!(j["format"], "nrrd");
    assert_eq!(j["report"]["voxels"], 36);
    assert_eq!(j["origin"], serde_json::json!([-3.0, 2.0, 0.25]));

    let o = volga(&["validate", arg(&nrrd), "--pad", "--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let j = json(&o);
    assert_eq!(j["padded"], true);
    assert_eq!(j["report"]["dims"], serde_json::json!([8, 8, 8]));
    assert_eq!(j["report"]["white_component_count"], 1);
    assert_eq!(j["origin"], serde_json::json!([-3.5, 1.5, -0.25]));
}

#[test]
fn volga_voxelization_of_spot_is_separating_and_covers() {
    // The repository's own copy (scenes/assets), so the test needs nothing beside the clone.
    let spot = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/assets/spot.obj");
    assert!(spot.is_file(), "{} missing", spot.display());
    let dir = tempfile::tempdir().unwrap();
    for (sep, requires) in [("26", "separating,cover"), ("6", "separating")] {
        let out = dir.path().join(format!("spot{sep}.binvox"));
        let o = volga(&[
            "voxelize",
            arg(&spot),
            "--resolution",
            "48",
            "--separability",
            sep,
            "--out",
            arg(&out),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let o = volga(&[
            "validate",
            arg(&out),
            "--mesh",
            arg(&spot),
            "--connectivity",
            sep,
            "--require",
            requires,
            "--json",
        ]);
        assert_eq!(o.status.code(), Some(0), "{sep}: {}", stderr(&o));
        let j = json(&o);
        let m = &j["report"]["mesh"];
        assert_eq!(m["tunnel_count"], 0, "{sep}");
        assert_eq!(j["mesh"]["closed"], true);
        // A closed surface: white splits into inside and outside as well.
        assert_eq!(j["report"]["separating"], true, "{sep}");
        assert_eq!(j["report"]["white_component_count"], 2, "{sep}");
    }
}

#[test]
fn bad_input_exits_2_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let garbage = dir.path().join("garbage.binvox");
    std::fs::write(&garbage, b"this is not a binvox file\n\x00\x01").unwrap();
    let o = volga(&["validate", arg(&garbage)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("garbage.binvox"), "{}", stderr(&o));

    let truncated = dir.path().join("truncated.binvox");
    std::fs::write(&truncated, b"#binvox 1\ndim 4 4 4\ndata\n\x01\x10").unwrap();
    let o = volga(&["validate", arg(&truncated)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("truncated.binvox"), "{}", stderr(&o));

    let missing = dir.path().join("missing.nrrd");
    let o = volga(&["validate", arg(&missing)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("missing.nrrd"), "{}", stderr(&o));

    let unknown = dir.path().join("model.vox");
    std::fs::write(&unknown, b"").unwrap();
    let o = volga(&["validate", arg(&unknown)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("model.vox"), "{}", stderr(&o));

    // A valid model with a cover requirement but no mesh, or a mesh that is not there.
    let model = dir.path().join("ok.binvox");
    write_binvox(&model, UVec3::splat(4), [IVec3::ONE]);
    let o = volga(&["validate", arg(&model), "--require", "cover"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("ok.binvox") && stderr(&o).contains("--mesh"),
        "{}",
        stderr(&o)
    );
    let o = volga(&["validate", arg(&model), "--mesh", arg(&dir.path().join("nowhere.obj"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("nowhere.obj"), "{}", stderr(&o));

    // Unknown requirement or connectivity: usage errors.
    assert_eq!(
        volga(&["validate", arg(&model), "--require", "watertight"])
            .status
            .code(),
        Some(2)
    );
    assert_eq!(
        volga(&["validate", arg(&model), "--connectivity", "8"]).status.code(),
        Some(2)
    );
}
