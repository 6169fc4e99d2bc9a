//! Inputs found by fuzzing the readers (fuzz/, docs/FUZZING.md): each must give an
//! error, never a panic, a hang or an allocation the file does not pay for.

use std::path::Path;

use volga_io::{read_nrrd, IoError};

fn format_message(result: Result<impl std::fmt::Debug, IoError>) -> String {
    match result {
        Err(IoError::Format { message, .. }) => message,
        other => panic!("expected a format error, got {other:?}"),
    }
}

/// A data file that never ends a line (a device such as `/dev/zero`) used to be read
/// forever by `line skip`: a device is no data file (refused before it is opened), and
/// an absolute `data file` is refused as leaving the header's folder.
#[test]
fn devices_are_not_data_files() {
    let dir = tempfile::tempdir().unwrap();
    let header = |data: &str| {
        format!("NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: raw\nline skip: 1\ndata file: {data}\n")
    };
    let path = dir.path().join("zero.nrrd");
    std::fs::write(&path, header("/dev/zero")).unwrap();
    let message = format_message(read_nrrd(&path));
    assert!(message.contains("is an absolute path"), "{message}");
    if Path::new("/dev/zero").exists() {
        std::os::unix::fs::symlink("/dev/zero", dir.path().join("zero.raw")).unwrap();
        std::fs::write(&path, header("zero.raw")).unwrap();
        match read_nrrd(&path) {
            Err(IoError::Io { source, .. }) => assert!(source.to_string().contains("character device"), "{source}"),
            other => panic!("expected an I/O error, got {other:?}"),
        }
    }
}
