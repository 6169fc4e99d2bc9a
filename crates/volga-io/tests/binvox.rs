//! `.binvox` reading and writing through the public API.

use std::path::Path;

use glam::{DVec3, UVec3};
use proptest::prelude::*;
use volga_io::{decode_binvox, encode_binvox, read_binvox, write_binvox, Binvox, BinvoxError, IoError};

fn encoded(model: &Binvox) -> Vec<u8> {
    let mut bytes = Vec::new();
    encode_binvox(model, &mut bytes).unwrap();
    bytes
}

fn decode(bytes: &[u8]) -> Result<Binvox, IoError> {
    decode_binvox(bytes, Path::new("model.binvox"))
}

fn error_of(bytes: &[u8]) -> String {
    let err = decode(bytes).unwrap_err();
    assert_eq!(err.path(), Path::new("model.binvox"));
    err.to_string()
}

/// dim 2 3 4 (x, y, z): 24 voxels numbered x·12 + z·3 + y.
/// Filled: (0, 1, 0) = voxel 1 and (1, 2, 3) = voxel 12 + 9 + 2 = 23.
const TINY: &[u8] = b"#binvox 1\ndim 2 3 4\ntranslate -1.5 0.25 2\nscale 3\ndata\n\x00\x01\x01\x01\x00\x15\x01\x01";

#[test]
fn reads_a_hand_written_file() {
    let model = decode(TINY).unwrap();
    assert_eq!(model.dims(), UVec3::new(2, 3, 4));
    assert_eq!(model.translate(), DVec3::new(-1.5, 0.25, 2.0));
    assert_eq!(model.scale(), 3.0);
    assert_eq!(
        model.filled().collect::<Vec<_>>(),
        vec![UVec3::new(0, 1, 0), UVec3::new(1, 2, 3)]
    );
    assert_eq!(model.filled_count(), 2);
    assert!(model.is_filled(UVec3::new(1, 2, 3)));
    assert!(!model.is_filled(UVec3::new(1, 0, 0)));
    assert!(!model.is_filled(UVec3::new(2, 0, 0)));
    // Writing the same model gives the same bytes.
    assert_eq!(encoded(&model), TINY);
}

#[test]
fn y_runs_fastest_then_z_then_x() {
    // One run of 4 over dim 2 2 2 fills voxels 0..4: x = 0, (y, z) = (0,0) (1,0) (0,1) (1,1).
    let model = decode(b"#binvox 1\ndim 2 2 2\ndata\n\x01\x04\x00\x04").unwrap();
    let filled: Vec<UVec3> = model.filled().collect();
    let expected = [(0, 0, 0), (0, 1, 0), (0, 0, 1), (0, 1, 1)].map(|(x, y, z)| UVec3::new(x, y, z));
    assert_eq!(filled, expected);
    // Defaults when translate and scale are absent; CRLF, comments, unknown keys and
    // version 2 values are accepted; bytes after the last voxel are ignored.
    assert_eq!((model.translate(), model.scale()), (DVec3::ZERO, 1.0));
    let model = decode(b"#binvox 2\r\n# made by hand\r\nfoo bar\r\ndim 1 3 1\r\ndata\r\n\x07\x02\x00\x01\xff").unwrap();
    assert_eq!(
        model.filled().collect::<Vec<_>>(),
        vec![UVec3::new(0, 0, 0), UVec3::new(0, 1, 0)]
    );
    assert_eq!(model.dims(), UVec3::new(1, 3, 1));
}

#[test]
fn long_runs_split_at_255() {
    let dims = UVec3::new(1, 300, 2);
    let model = Binvox::from_filled(dims, DVec3::ZERO, 1.0, (0..300).map(|y| UVec3::new(0, y, 0))).unwrap();
    let bytes = encoded(&model);
    // 300 filled (voxels 0..300 are z = 0), then 300 empty.
    assert_eq!(&bytes[bytes.len() - 8..], &[1, 255, 1, 45, 0, 255, 0, 45]);
    assert_eq!(decode(&bytes).unwrap(), model);
}

#[test]
fn errors_name_the_file_and_the_fault() {
    let cases: [(&[u8], &str); 10] = [
        (b"", "not a binvox file"),
        (b"P6\n3 3\n", "not a binvox file"),
        (
            b"#binvox 3\ndim 1 1 1\ndata\n\x00\x01",
            "unsupported binvox version `3`",
        ),
        (
            b"#binvox 1\ntranslate 0 0 0\ndata\n\x00\x01",
            "line 3: header has no `dim` line",
        ),
        (
            b"#binvox 1\ndim 2 2\ndata\n",
            "line 2: `dim` needs three positive integers, got `2 2`",
        ),
        (b"#binvox 1\ndim 0 2 2\ndata\n", "line 2: dim [0, 2, 2]"),
        (
            b"#binvox 1\ndim 2 2 2\nscale -1\ndata\n",
            "line 3: scale must be finite and > 0",
        ),
        (b"#binvox 1\ndim 2 2 2\n", "header ends without a `data` line"),
        (
            b"#binvox 1\ndim 2 2 2\ndata\n\x01\x03",
            "truncated data: the data ends after 3 of the 8 voxels",
        ),
        (
            b"#binvox 1\ndim 2 2 2\ndata\n\x01\x03\x00\x06",
            "run at byte 27 overflows the grid: it ends at voxel 9",
        ),
    ];
    for (bytes, expected) in cases {
        let message = error_of(bytes);
        assert!(message.starts_with("model.binvox"), "{message}");
        assert!(message.contains(expected), "{message:?} lacks {expected:?}");
    }
    assert!(error_of(b"#binvox 1\ndim 1 1 2\ndata\n\x01\x00\x01\x02").contains("run of count 0 at byte 25"));
    assert!(
        error_of(b"#binvox 1\ndim 1 1 2\ndata\n\x01\x01\x01").contains("the value byte at byte 27 has no count byte")
    );
    assert!(error_of(b"#binvox 1\ndim 99999999 99999999 99999999\ndata\n").contains("fits in 64 bits"));
}

#[test]
fn construction_is_validated() {
    let dims = UVec3::new(2, 2, 2);
    assert_eq!(
        Binvox::from_filled(dims, DVec3::ZERO, 1.0, [UVec3::new(0, 2, 0)]),
        Err(BinvoxError::OutsideGrid {
            ijk: [0, 2, 0],
            dims: [2, 2, 2]
        })
    );
    assert!(matches!(
        Binvox::from_filled(dims, DVec3::ZERO, 0.0, []),
        Err(BinvoxError::BadTransform { .. })
    ));
    assert!(matches!(
        Binvox::from_filled(UVec3::new(0, 1, 1), DVec3::ZERO, 1.0, []),
        Err(BinvoxError::BadDims(_))
    ));
}

#[test]
fn transform_matches_the_binvox_normalization() {
    // Voxel ijk of a d³ grid has its centre at translate + scale · (ijk + ½) / d.
    let model = Binvox::from_filled(UVec3::splat(4), DVec3::new(-1.0, 2.0, 0.5), 2.0, []).unwrap();
    let t = model.transform().unwrap();
    assert_eq!(t.voxel_center(glam::IVec3::new(0, 1, 3)), DVec3::new(-0.75, 2.75, 2.25));
}

#[test]
fn file_round_trip_is_atomic_and_exact() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.binvox");
    let model = Binvox::from_filled(
        UVec3::new(5, 3, 7),
        DVec3::new(0.1, -1e6, 1.0 / 3.0),
        0.123456789012345,
        [UVec3::new(4, 2, 6), UVec3::new(0, 0, 0), UVec3::new(1, 2, 3)],
    )
    .unwrap();
    write_binvox(&path, &model).unwrap();
    assert_eq!(read_binvox(&path).unwrap(), model);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temp file left");
    let missing = dir.path().join("nope.binvox");
    assert!(read_binvox(&missing).unwrap_err().to_string().contains("nope.binvox"));
}

proptest! {
    #[test]
    fn random_models_round_trip(
        dims in (1u32..12, 1u32..12, 1u32..12),
        filled in proptest::collection::vec((0u32..12, 0u32..12, 0u32..12), 0..200),
        translate in (-1e3f64..1e3, -1e3f64..1e3, -1e3f64..1e3),
        scale in 1e-3f64..1e3,
    ) {
        let dims = UVec3::new(dims.0, dims.1, dims.2);
        let filled: Vec<UVec3> = filled.into_iter().map(UVec3::from).filter(|v| v.cmplt(dims).all()).collect();
        let model = Binvox::from_filled(dims, DVec3::from(translate), scale, filled.iter().copied()).unwrap();
        let back = decode(&encoded(&model)).unwrap();
        prop_assert_eq!(&back, &model);
        let mut expected = filled.clone();
        expected.sort_by_key(|v| (v.x, v.z, v.y));
        expected.dedup();
        prop_assert_eq!(back.filled().collect::<Vec<_>>(), expected);
    }

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
        let _ = decode(&bytes);
        let mut with_header = b"#binvox 1\ndim 3 4 5\ndata\n".to_vec();
        with_header.extend_from_slice(&bytes);
        if let Ok(model) = decode(&with_header) {
            prop_assert!(model.filled_count() <= 60);
        }
    }

    #[test]
    fn corrupted_files_never_panic(index in 0usize..80, byte in any::<u8>()) {
        let mut bytes = TINY.to_vec();
        if index < bytes.len() {
            bytes[index] = byte;
        } else {
            bytes.truncate(index % bytes.len());
        }
        let _ = decode(&bytes);
    }
}
