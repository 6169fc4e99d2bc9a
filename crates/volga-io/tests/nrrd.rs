//! NRRD round trips and reader errors through the public API.

use std::fs;
use std::path::{Path, PathBuf};

use glam::{DVec3, IVec3, UVec3};
use proptest::prelude::*;
use volga_core::{Brick, Grid, SparseVolume, Transform, BRICK_VOXELS};
use volga_io::{read_nrrd, read_nrrd_with_colour, write_nrrd, IoError, StagedOutputs};

const DIMS: UVec3 = UVec3::new(13, 9, 5);

/// 13×9×5 voxels, anisotropic spacing, far origin; uniform, dense, absent and
/// out-of-grid bricks; negative values.
fn test_volume(background: f32, with_colour: bool) -> SparseVolume {
    let t = Transform::new(DVec3::new(1e6, -3.0, 0.25), DVec3::new(0.5, 1.0, 2.0)).unwrap();
    let grid = Grid::new(t, DIMS).unwrap();
    let mut v = SparseVolume::new(grid, background, with_colour);
    v.density.insert_brick(IVec3::new(0, 0, 0), Brick::Uniform(2.5));
    let mut dense = Box::new([0.0f32; BRICK_VOXELS]);
    for (i, d) in dense.iter_mut().enumerate() {
        *d = -(i as f32) * 0.125 + 3.0;
    }
    v.density.insert_brick(IVec3::new(1, 1, 0), Brick::Dense(dense.into()));
    v.density.set(IVec3::new(12, 0, 4), -7.25);
    v.density.set(IVec3::new(3, 8, 2), f32::MIN_POSITIVE);
    // Outside the grid: must not be written.
    v.density.set(IVec3::new(-1, 0, 0), 99.0);
    v.density.set(IVec3::new(13, 8, 4), 99.0);
    if let Some(c) = v.colour.as_mut() {
        c.insert_brick(IVec3::new(1, 0, 0), Brick::Uniform([0.25, 0.5, 1.0]));
        c.set(IVec3::new(2, 3, 4), [1.0, -0.0, 0.125]);
        c.set(IVec3::new(13, 0, 0), [9.0; 3]);
    }
    v
}

fn write_committed(dir: &Path, stem: &str, v: &SparseVolume) -> Vec<PathBuf> {
    let mut out = StagedOutputs::new();
    let paths = write_nrrd(dir, stem, v, &mut out).unwrap();
    assert_eq!(out.staged_paths(), paths);
    assert_eq!(out.commit().unwrap(), paths);
    paths
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn density_round_trip_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    let v = test_volume(0.0, false);
    let paths = write_committed(dir.path(), "vol", &v);
    let header = dir.path().join("vol.nrrd");
    let raw = dir.path().join("vol.raw");
    assert_eq!(paths, vec![header.clone(), raw.clone()]);
    assert_eq!(entries(dir.path()), vec!["vol.nrrd", "vol.raw"]);
    assert_eq!(fs::metadata(&raw).unwrap().len(), 4 * 13 * 9 * 5);

    let text = fs::read_to_string(&header).unwrap();
    for line in [
        "type: float",
        "dimension: 3",
        "sizes: 13 9 5",
        "encoding: raw",
        "endian: little",
        "space dimension: 3",
        "space directions: (0.5,0,0) (0,1.0,0) (0,0,2.0)",
        "space origin: (1000000.0,-3.0,0.25)",
        "kinds: domain domain domain",
        "data file: vol.raw",
    ] {
        assert!(text.lines().any(|l| l == line), "no `{line}` in\n{text}");
    }

    let back = read_nrrd(&header).unwrap();
    let expected = v.to_dense().unwrap();
    assert_eq!(back.grid, v.grid);
    assert_eq!(back.grid.transform.origin(), DVec3::new(1e6, -3.0, 0.25));
    assert_eq!(back.grid.transform.spacing(), DVec3::new(0.5, 1.0, 2.0));
    let bits = |s: &[f32]| s.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(back.density.as_slice()), bits(expected.density.as_slice()));
    assert_eq!(back, expected);
    assert!(back.colour.is_none());
    // Spot checks of the layout (x fastest) and of each brick kind.
    let at = |x: usize, y: usize, z: usize| back.density.as_slice()[x + 13 * (y + 9 * z)];
    assert_eq!(at(0, 0, 0), 2.5);
    assert_eq!(at(12, 0, 4), -7.25);
    assert_eq!(at(9, 8, 0), 3.0 - 0.125);
    assert_eq!(at(0, 8, 4), 0.0);
}

#[test]
fn background_and_raw_layout() {
    let dir = tempfile::tempdir().unwrap();
    let v = test_volume(-1.5, false);
    write_committed(dir.path(), "bg", &v);
    let back = read_nrrd(&dir.path().join("bg.nrrd")).unwrap();
    assert_eq!(back.density.background(), -1.5);
    assert_eq!(back, v.to_dense().unwrap());

    let raw = fs::read(dir.path().join("bg.raw")).unwrap();
    let value = |ijk: IVec3| {
        let i = 4 * (ijk.x + 13 * (ijk.y + 9 * ijk.z)) as usize;
        f32::from_le_bytes(raw[i..i + 4].try_into().unwrap())
    };
    for ijk in v.grid.index_box().iter() {
        assert_eq!(value(ijk), v.density.get(ijk), "{ijk}");
    }
}

#[test]
fn colour_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let v = test_volume(0.0, true);
    let paths = write_committed(dir.path(), "c", &v);
    let names: Vec<_> = paths.iter().map(|p| p.file_name().unwrap().to_str().unwrap()).collect();
    assert_eq!(names, vec!["c.nrrd", "c.raw", "c_colour.nrrd", "c_colour.raw"]);
    assert_eq!(
        fs::metadata(dir.path().join("c_colour.raw")).unwrap().len(),
        12 * 13 * 9 * 5
    );
    let text = fs::read_to_string(dir.path().join("c_colour.nrrd")).unwrap();
    for line in [
        "dimension: 4",
        "sizes: 3 13 9 5",
        "kinds: RGB-color domain domain domain",
        "space directions: none (0.5,0,0) (0,1.0,0) (0,0,2.0)",
        "data file: c_colour.raw",
    ] {
        assert!(text.lines().any(|l| l == line), "no `{line}` in\n{text}");
    }
    let back = read_nrrd_with_colour(&dir.path().join("c.nrrd"), &dir.path().join("c_colour.nrrd")).unwrap();
    assert_eq!(back, v.to_dense().unwrap());

    // The colour file is not a scalar volume.
    let e = read_nrrd(&dir.path().join("c_colour.nrrd")).unwrap_err();
    assert!(e.to_string().contains("dimension"), "{e}");
}

#[test]
fn uncommitted_nrrd_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("old.nrrd"), "previous").unwrap();
    let mut out = StagedOutputs::new();
    write_nrrd(dir.path(), "old", &test_volume(0.0, true), &mut out).unwrap();
    assert_eq!(out.staged_paths().len(), 4);
    drop(out);
    assert_eq!(entries(dir.path()), vec!["old.nrrd"]);
    assert_eq!(fs::read_to_string(dir.path().join("old.nrrd")).unwrap(), "previous");

    let mut out = StagedOutputs::new();
    for bad in ["", "a/b", "has space", ".."] {
        assert!(write_nrrd(dir.path(), bad, &test_volume(0.0, false), &mut out).is_err());
    }
    assert!(out.is_empty());

    // A failure half-way discards what write_nrrd staged, and only that.
    out.stage(&dir.path().join("x.raw"), |w| w.write_all(b"other")).unwrap();
    assert!(write_nrrd(dir.path(), "x", &test_volume(0.0, false), &mut out).is_err());
    assert_eq!(out.staged_paths(), vec![dir.path().join("x.raw")]);
    drop(out);
    assert_eq!(entries(dir.path()), vec!["old.nrrd"]);
}

/// Writes a volume, then rewrites its header with `edit`.
fn edited_header(dir: &Path, edit: impl Fn(&str) -> String) -> PathBuf {
    write_committed(dir, "e", &test_volume(0.0, false));
    let header = dir.join("e.nrrd");
    let text = fs::read_to_string(&header).unwrap();
    fs::write(&header, edit(&text)).unwrap();
    header
}

fn format_error(e: IoError) -> (PathBuf, Option<usize>, String) {
    match e {
        IoError::Format { path, line, message } => (path, line, message),
        e => panic!("expected a format error, got {e:?}"),
    }
}

#[test]
fn missing_sizes_is_a_format_error() {
    let dir = tempfile::tempdir().unwrap();
    let header = edited_header(dir.path(), |t| {
        t.lines()
            .filter(|l| !l.starts_with("sizes:"))
            .map(|l| format!("{l}\n"))
            .collect()
    });
    let e = read_nrrd(&header).unwrap_err();
    let shown = e.to_string();
    let (path, line, message) = format_error(e);
    assert_eq!(path, header);
    assert!(line.is_some());
    assert!(message.contains("sizes"), "{message}");
    assert!(shown.contains("e.nrrd line "), "{shown}");
}

#[test]
fn unknown_field_and_encoding_name_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let header = edited_header(dir.path(), |t| t.replace("encoding: raw", "encoding: gzip"));
    let line_no = fs::read_to_string(&header)
        .unwrap()
        .lines()
        .position(|l| l == "encoding: gzip")
        .unwrap()
        + 1;
    let (path, line, message) = format_error(read_nrrd(&header).unwrap_err());
    assert_eq!(path, header);
    assert_eq!(line, Some(line_no));
    assert!(message.contains("unsupported encoding gzip"), "{message}");

    let header = edited_header(dir.path(), |t| t.replace("kinds:", "foo:"));
    let e = read_nrrd(&header).unwrap_err();
    assert!(e.to_string().ends_with("unknown field `foo`"), "{e}");
    assert!(format_error(e).1.is_some());
}

#[test]
fn truncated_and_oversized_data_name_both_sizes() {
    let dir = tempfile::tempdir().unwrap();
    write_committed(dir.path(), "t", &test_volume(0.0, false));
    let header = dir.path().join("t.nrrd");
    let raw = dir.path().join("t.raw");
    let full = fs::read(&raw).unwrap();
    fs::write(&raw, &full[..1000]).unwrap();
    let (path, _, message) = format_error(read_nrrd(&header).unwrap_err());
    assert_eq!(path, header);
    assert!(message.contains("1000") && message.contains("2340"), "{message}");
    assert!(message.contains("t.raw"), "{message}");

    let mut longer = full.clone();
    longer.push(0);
    fs::write(&raw, &longer).unwrap();
    let (_, _, message) = format_error(read_nrrd(&header).unwrap_err());
    assert!(message.contains("2341") && message.contains("2340"), "{message}");

    fs::remove_file(&raw).unwrap();
    match read_nrrd(&header).unwrap_err() {
        IoError::Io { path, .. } => assert_eq!(path, raw),
        e => panic!("{e:?}"),
    }
    assert!(matches!(
        read_nrrd(&dir.path().join("absent.nrrd")),
        Err(IoError::Io { .. })
    ));
}

#[test]
fn attached_data_round_trip() {
    // A header with the data appended after a blank line.
    let dir = tempfile::tempdir().unwrap();
    write_committed(dir.path(), "a", &test_volume(0.0, false));
    let text = fs::read_to_string(dir.path().join("a.nrrd")).unwrap();
    let mut attached: Vec<u8> = text
        .lines()
        .filter(|l| !l.starts_with("data file:"))
        .flat_map(|l| format!("{l}\n").into_bytes())
        .collect();
    attached.push(b'\n');
    attached.extend(fs::read(dir.path().join("a.raw")).unwrap());
    let path = dir.path().join("attached.nrrd");
    fs::write(&path, attached).unwrap();
    assert_eq!(read_nrrd(&path).unwrap(), test_volume(0.0, false).to_dense().unwrap());
}

fn header_line() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::sample::select(vec![
            "type: float",
            "type: uchar",
            "type: double",
            "dimension: 3",
            "dimension: 4",
            "sizes: 2 2 2",
            "sizes: 3 1 1 1",
            "sizes: 4294967295 4294967295 4294967295",
            "sizes: 100000 100000 100000",
            "encoding: raw",
            "endian: little",
            "space dimension: 3",
            "space directions: (1,0,0) (0,1,0) (0,0,1)",
            "space directions: (0,0,0) (0,1,0) (0,0,1)",
            "space origin: (1,2,3)",
            "spacings: 1 nan -1",
            "line skip: 3",
            "byte skip: -1",
            "byte skip: 99999999999",
            "data file: missing.raw",
            "",
        ])
        .prop_map(str::to_string),
        "[ -~]{0,30}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Arbitrary headers followed by arbitrary bytes: an error or a volume, never a
    /// panic or an absurd allocation.
    #[test]
    fn read_nrrd_never_panics(
        lines in prop::collection::vec(header_line(), 0..12),
        data in prop::collection::vec(any::<u8>(), 0..64),
        magic in any::<bool>(),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.nrrd");
        let mut bytes = if magic { b"NRRD0004\n".to_vec() } else { Vec::new() };
        for l in &lines {
            bytes.extend_from_slice(l.as_bytes());
            bytes.push(b'\n');
        }
        bytes.extend_from_slice(&data);
        fs::write(&path, &bytes).unwrap();
        match read_nrrd(&path) {
            Ok(v) => prop_assert!(v.grid.voxel_count() <= 64),
            Err(e) => prop_assert!(e.to_string().contains("f.nrrd") || e.to_string().contains("missing.raw")),
        }
    }
}
