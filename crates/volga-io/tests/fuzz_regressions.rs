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

/// `line skip` on a data file that never ends a line (a device: its length is 0) used
/// to read forever.
#[test]
fn line_skip_stops_at_the_data_files_length() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("zero.nrrd");
    std::fs::write(
        &path,
        "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: raw\nline skip: 1\ndata file: /dev/zero\n",
    )
    .unwrap();
    if Path::new("/dev/zero").exists() {
        let message = format_message(read_nrrd(&path));
        assert!(message.contains("line skip 1 passes the end of /dev/zero"), "{message}");
    }
}
