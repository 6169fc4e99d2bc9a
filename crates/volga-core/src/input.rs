//! Reading input files within bounds: regular files only (a FIFO, a device such as
//! `/dev/zero` or a directory is refused before it is opened), and a file's size is
//! checked against the memory a reader may use before any of it is read.
//!
//! Every volga reader that takes a path goes through [`read_regular`] or
//! [`open_regular`]; the errors are [`std::io::Error`]s whose messages say what the
//! path is and, for a file too large, its size and the limit, so the readers' own error
//! types (which name the path) carry them unchanged.

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

use crate::memory::{self, Bytes};

/// What a path is, in words, when it is not a regular file.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

/// Opens `path` for reading if it is a regular file (symbolic links followed), and
/// returns it with its size in bytes. A FIFO is refused without being opened (opening
/// one would wait for a writer).
///
/// # Errors
/// [`io::ErrorKind::InvalidInput`] for anything but a regular file; the operating
/// system's error when the path cannot be examined or opened.
pub fn open_regular(path: &Path) -> io::Result<(File, u64)> {
    let meta = std::fs::metadata(path)?;
    if !meta.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "{} is {}; volga reads only regular files",
                path.display(),
                kind_of(&meta)
            ),
        ));
    }
    let file = File::open(path)?;
    // The path may have been replaced between the two looks: judge the opened file.
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "{} is {}; volga reads only regular files",
                path.display(),
                kind_of(&meta)
            ),
        ));
    }
    Ok((file, meta.len()))
}

/// The error of a file larger than a reader may hold.
pub fn too_large(path: &Path, size: u64, limit: u64) -> io::Error {
    io::Error::new(
        io::ErrorKind::OutOfMemory,
        format!(
            "{} is {} ({size} bytes), more than the {} ({limit} bytes) of memory this read may use (raise --memory-limit or free memory)",
            path.display(),
            Bytes(size as u128),
            Bytes(limit as u128)
        ),
    )
}

/// Reads the whole of the regular file `path` if it holds at most `max_bytes` bytes.
/// A file that grows while being read is cut at `max_bytes + 1` and refused.
///
/// # Errors
/// As [`open_regular`]; [`io::ErrorKind::OutOfMemory`] (naming the size and the limit)
/// when the file is larger than `max_bytes`.
pub fn read_regular(path: &Path, max_bytes: u64) -> io::Result<Vec<u8>> {
    let (file, len) = open_regular(path)?;
    if len > max_bytes {
        return Err(too_large(path, len, max_bytes));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(max_bytes.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_large(path, bytes.len() as u64, max_bytes));
    }
    Ok(bytes)
}

/// [`read_regular`] as UTF-8 text.
///
/// # Errors
/// As [`read_regular`]; [`io::ErrorKind::InvalidData`] when the file is not UTF-8.
pub fn read_regular_text(path: &Path, max_bytes: u64) -> io::Result<String> {
    String::from_utf8(read_regular(path, max_bytes)?).map_err(|e| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "{} is not UTF-8 text (byte {})",
                path.display(),
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// [`read_regular`] bounded by [`memory::input_limit`].
pub fn read_input(path: &Path) -> io::Result<Vec<u8>> {
    read_regular(path, memory::input_limit())
}

/// [`read_regular_text`] bounded by [`memory::input_limit`].
pub fn read_input_text(path: &Path) -> io::Result<String> {
    read_regular_text(path, memory::input_limit())
}

/// `relative` joined to `dir` if it names a file inside `dir`: a relative path whose
/// `..` components never climb above `dir` (judged on the text, before any file is
/// touched). The error says why the path is refused.
///
/// # Errors
/// An absolute path, an empty one, one that leaves `dir` or names `dir` itself.
pub fn confine(dir: &Path, relative: &str) -> Result<std::path::PathBuf, &'static str> {
    use std::path::Component;
    if relative.is_empty() {
        return Err("is empty");
    }
    let mut inside = std::path::PathBuf::new();
    let mut depth = 0usize;
    for component in Path::new(relative).components() {
        match component {
            Component::Normal(part) => {
                inside.push(part);
                depth += 1;
            }
            Component::CurDir => {}
            Component::ParentDir => {
                if depth == 0 {
                    return Err("leaves the folder");
                }
                inside.pop();
                depth -= 1;
            }
            Component::RootDir | Component::Prefix(_) => return Err("is an absolute path"),
        }
    }
    if depth == 0 {
        return Err("names the folder itself");
    }
    Ok(dir.join(inside))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn confine_keeps_paths_in_their_folder() {
        let d = Path::new("scenes");
        assert_eq!(confine(d, "a/../b.raw").unwrap(), Path::new("scenes/b.raw"));
        assert_eq!(confine(d, "./x/y.obj").unwrap(), Path::new("scenes/x/y.obj"));
        assert_eq!(confine(d, "/etc/shadow"), Err("is an absolute path"));
        assert_eq!(confine(d, "../x.obj"), Err("leaves the folder"));
        assert_eq!(confine(d, "a/../../x.obj"), Err("leaves the folder"));
        assert_eq!(confine(d, ""), Err("is empty"));
        assert_eq!(confine(d, "a/.."), Err("names the folder itself"));
    }

    #[test]
    fn refuses_what_is_not_a_regular_file() {
        for p in ["/dev/zero", "/dev/null", "/"] {
            let e = read_regular(Path::new(p), 1 << 20).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput, "{p}: {e}");
            assert!(e.to_string().contains("regular file"), "{e}");
        }
        let dir = std::env::temp_dir().join(format!("volga-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let link = dir.join("zero.obj");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        let e = read_regular(&link, 1 << 20).unwrap_err();
        assert!(e.to_string().contains("character device"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn refuses_files_over_the_limit_before_reading() {
        let dir = std::env::temp_dir().join(format!("volga-input-size-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("big.bin");
        let f = File::create(&p).unwrap();
        // Sparse: 1 TiB claimed, nothing written.
        f.set_len(1 << 40).unwrap();
        let e = read_regular(&p, 1 << 20).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::OutOfMemory);
        assert!(
            e.to_string().contains("1.00 TiB") && e.to_string().contains("1.00 MiB"),
            "{e}"
        );
        std::fs::write(&p, b"abc").unwrap();
        assert_eq!(read_regular(&p, 3).unwrap(), b"abc");
        assert!(read_regular(&p, 2).is_err());
        std::fs::write(&p, [0xff, 0xfe]).unwrap();
        assert_eq!(
            read_regular_text(&p, 10).unwrap_err().kind(),
            io::ErrorKind::InvalidData
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
