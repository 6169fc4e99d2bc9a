//! The sculpt file: a versioned binary format with a checksum.
//!
//! Layout (little endian):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `VOLGASCT` |
//! | 4 | format version (`u32`, currently 1) |
//! | 24 + 8 + 4 | grid origin (3 × `f64`), spacing (`f64`), levels (`u32`) |
//! | … | nodes in pre-order: tag `u8` — 0 uniform (density `f32`, colour 3 × `f32`), 1 brick (512 × `f32` densities, colour tag `u8`: 0 one colour 3 × `f32`, 1 per voxel 512 × 3 × `f32`), 2 branch (its eight children follow) |
//! | 4 | CRC-32 (IEEE) of every byte before it |
//!
//! Loading checks the length, magic, version and checksum before parsing, then the
//! structure (bricks only at level 0, branches above it, finite densities in \[0, 1\],
//! colours finite, no bytes left over); any failure is an error naming what is wrong and
//! where, and builds nothing. The undo history is not saved.
//!
//! On disk: [`Sculpt::save`] writes a temporary file in the target's directory, syncs it
//! and renames it over the target, so the target is either the old file or the complete new
//! one, and a failed save leaves no temporary file behind; [`Sculpt::open`] reads regular
//! files only, refusing one too large for memory before reading it. Their errors
//! ([`SculptFileError`]) name the file.

use std::fs::File;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::DVec3;

use crate::octree::{Brick, BrickColour, Node, SculptGrid, Voxel, BRICK_VOXELS};
use crate::Sculpt;

const MAGIC: &[u8; 8] = b"VOLGASCT";
/// The version this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;
const HEADER: usize = 8 + 4 + 24 + 8 + 4;

/// Why a sculpt file was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FileError {
    /// The first eight bytes are not `VOLGASCT`.
    #[error("not a volga sculpt file (magic bytes differ)")]
    Magic,
    /// Too short for a header, a node and the checksum.
    #[error("sculpt file is truncated: {len} bytes, at least {need} needed")]
    Truncated {
        /// Bytes given.
        len: usize,
        /// The fewest bytes a sculpt file has.
        need: usize,
    },
    /// A format version this build does not read.
    #[error("sculpt file version {found} is not supported (this build reads version {FORMAT_VERSION})")]
    Version {
        /// The version in the file.
        found: u32,
    },
    /// The CRC-32 of the bytes differs from the one stored.
    #[error("sculpt file is corrupted: checksum {found:08x}, expected {expected:08x}")]
    Checksum {
        /// CRC-32 of the bytes before the stored checksum.
        found: u32,
        /// The checksum stored at the end.
        expected: u32,
    },
    /// The checksum holds but the content is not a valid sculpt.
    #[error("sculpt file is malformed at byte {offset}: {message}")]
    Malformed {
        /// Byte offset of the fault.
        offset: usize,
        /// What is wrong.
        message: String,
    },
}

/// Why a sculpt file could not be saved or opened. Every variant names the file
/// ([`SculptFileError::path`]).
#[derive(Debug, thiserror::Error)]
pub enum SculptFileError {
    /// The file could not be inspected, opened or read.
    #[error("{}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: io::Error,
    },
    /// The path is not a regular file (a directory, a device, a pipe…); nothing was read.
    #[error("{}: not a regular file", path.display())]
    NotAFile {
        /// The path.
        path: PathBuf,
    },
    /// The file is larger than the limit it was opened with; nothing was read.
    #[error(
        "{}: the file is {} ({size} bytes), more than the {} ({limit} bytes) it may take",
        path.display(), volga_core::memory::Bytes(*size as u128), volga_core::memory::Bytes(*limit as u128)
    )]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size in bytes.
        size: u64,
        /// The largest size accepted.
        limit: u64,
    },
    /// The file's bytes are not a sculpt this build reads.
    #[error("{}: {source}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong with the bytes.
        #[source]
        source: FileError,
    },
    /// The file could not be written (the temporary file created, written or synced, or
    /// renamed over the target). No temporary file is left and the target is unchanged.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The target file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: io::Error,
    },
}

impl SculptFileError {
    /// The file the error concerns.
    pub fn path(&self) -> &Path {
        match self {
            SculptFileError::Read { path, .. }
            | SculptFileError::NotAFile { path }
            | SculptFileError::TooLarge { path, .. }
            | SculptFileError::Format { path, .. }
            | SculptFileError::Write { path, .. } => path,
        }
    }
}

/// CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320).
pub fn crc32(bytes: &[u8]) -> u32 {
    static TABLE: std::sync::OnceLock<[u32; 256]> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        std::array::from_fn(|i| {
            let mut c = i as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            }
            c
        })
    });
    !bytes
        .iter()
        .fold(!0u32, |c, &b| table[((c ^ b as u32) & 0xff) as usize] ^ (c >> 8))
}

impl Sculpt {
    /// The sculpt as file bytes ([`Sculpt::save`] writes them to a path atomically).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER + self.stats().bytes as usize);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        for c in self.grid.origin().to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
        out.extend_from_slice(&self.grid.spacing().to_le_bytes());
        out.extend_from_slice(&self.grid.levels().to_le_bytes());
        write_node(&self.root, &mut out);
        let crc = crc32(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        out
    }

    /// The length of [`Sculpt::to_bytes`] without making the bytes (for a free-space
    /// check before saving).
    pub fn file_len(&self) -> u64 {
        fn node_len(n: &Node) -> u64 {
            match n {
                Node::Uniform(_) => 1 + 16,
                Node::Brick(b) => {
                    let colours = match b.colour {
                        BrickColour::Uniform(_) => 1,
                        BrickColour::PerVoxel(_) => BRICK_VOXELS as u64,
                    };
                    1 + 4 * BRICK_VOXELS as u64 + 1 + 12 * colours
                }
                Node::Branch(children) => 1 + children.iter().map(node_len).sum::<u64>(),
            }
        }
        HEADER as u64 + node_len(&self.root) + 4
    }

    /// Reads a sculpt from file bytes (see the module documentation for what is checked).
    pub fn from_bytes(bytes: &[u8]) -> Result<Sculpt, FileError> {
        if bytes.len() >= 8 && &bytes[..8] != MAGIC {
            return Err(FileError::Magic);
        }
        if bytes.len() < HEADER + 1 + 4 {
            return Err(FileError::Truncated {
                len: bytes.len(),
                need: HEADER + 5,
            });
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
        if version != FORMAT_VERSION {
            return Err(FileError::Version { found: version });
        }
        let (body, tail) = bytes.split_at(bytes.len() - 4);
        let expected = u32::from_le_bytes(tail.try_into().unwrap());
        let found = crc32(body);
        if found != expected {
            return Err(FileError::Checksum { found, expected });
        }
        let mut r = Reader { bytes: body, at: 12 };
        let origin = DVec3::new(r.f64()?, r.f64()?, r.f64()?);
        let spacing = r.f64()?;
        let levels = r.u32()?;
        let grid = SculptGrid::new(origin, spacing, levels).map_err(|e| FileError::Malformed {
            offset: 12,
            message: e.to_string(),
        })?;
        let root = read_node(&mut r, levels)?;
        if r.at != body.len() {
            return Err(r.malformed(format!("{} bytes left after the tree", body.len() - r.at)));
        }
        Ok(Sculpt::from_root(grid, root))
    }

    /// Replaces this sculpt (tree and grid; history cleared) with the one in `bytes`, or
    /// leaves it untouched and returns the error.
    pub fn load_bytes(&mut self, bytes: &[u8]) -> Result<(), FileError> {
        let loaded = Sculpt::from_bytes(bytes)?;
        *self = loaded;
        Ok(())
    }

    /// Saves the sculpt file ([`Sculpt::to_bytes`]) at `path`, atomically: the bytes go to
    /// a temporary file in `path`'s directory, which is synced and then renamed over
    /// `path`. On any error the temporary file is removed and an existing file at `path`
    /// is left as it was; a missing directory is not created. The file gets the usual
    /// permissions of a new file (`0o666` less the umask on Unix).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<(), SculptFileError> {
        let bytes = self.to_bytes();
        write_atomically(path.as_ref(), |w| w.write_all(&bytes))
    }

    /// Opens a sculpt file: [`Sculpt::open_with_limit`] with the limit half the memory
    /// available now (the bytes read and the tree built from them take about the file's
    /// size each), or no limit where the available memory is unknown.
    pub fn open(path: impl AsRef<Path>) -> Result<Sculpt, SculptFileError> {
        let limit = volga_core::memory::available_bytes().map_or(u64::MAX, |a| a / 2);
        Sculpt::open_with_limit(path, limit)
    }

    /// Opens a sculpt file of at most `max_bytes` bytes. Only regular files are read (a
    /// directory, device or pipe is refused without opening it), and their size is checked
    /// against `max_bytes` before a byte is read; then the bytes are checked as by
    /// [`Sculpt::from_bytes`]. Errors name the file.
    pub fn open_with_limit(path: impl AsRef<Path>, max_bytes: u64) -> Result<Sculpt, SculptFileError> {
        let path = path.as_ref();
        let read_error = |source| SculptFileError::Read {
            path: path.to_path_buf(),
            source,
        };
        let check = |meta: &std::fs::Metadata| {
            if !meta.is_file() {
                return Err(SculptFileError::NotAFile {
                    path: path.to_path_buf(),
                });
            }
            match usize::try_from(meta.len()) {
                Ok(len) if meta.len() <= max_bytes => Ok(len),
                _ => Err(SculptFileError::TooLarge {
                    path: path.to_path_buf(),
                    size: meta.len(),
                    limit: max_bytes,
                }),
            }
        };
        // Checked by path before opening (opening a pipe would wait for a writer), and
        // again on the open file (the path may have been replaced in between).
        check(&std::fs::metadata(path).map_err(read_error)?)?;
        let file = File::open(path).map_err(read_error)?;
        let len = check(&file.metadata().map_err(read_error)?)?;
        let mut bytes = Vec::new();
        bytes.try_reserve_exact(len).map_err(|_| SculptFileError::TooLarge {
            path: path.to_path_buf(),
            size: len as u64,
            limit: max_bytes,
        })?;
        // A file that grew meanwhile is read to its checked size (its checksum then fails).
        file.take(len as u64).read_to_end(&mut bytes).map_err(read_error)?;
        Sculpt::from_bytes(&bytes).map_err(|source| SculptFileError::Format {
            path: path.to_path_buf(),
            source,
        })
    }
}

/// Writes `path` through a temporary file in its directory (see [`Sculpt::save`]).
fn write_atomically(path: &Path, write: impl FnOnce(&mut File) -> io::Result<()>) -> Result<(), SculptFileError> {
    let write_error = |source| SculptFileError::Write {
        path: path.to_path_buf(),
        source,
    };
    let name = path.file_name().ok_or_else(|| {
        write_error(io::Error::new(
            io::ErrorKind::InvalidInput,
            "output path has no file name",
        ))
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let mut prefix = std::ffi::OsString::from(".");
    prefix.push(name);
    prefix.push(".");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        // Created with mode 0o666, so the umask decides as for any new file (tempfile's
        // default, 0o600, would leave saved sculpts readable by their owner only).
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    // From here on, dropping `temp` (any early return) deletes the temporary file.
    let mut temp = builder.tempfile_in(dir).map_err(|e| write_error(os_error_of(e)))?;
    write(temp.as_file_mut()).map_err(write_error)?;
    temp.as_file().sync_all().map_err(write_error)?;
    temp.persist(path).map_err(|e| write_error(e.error))?;
    // Make the rename durable (best effort: not every platform can sync a directory).
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// The operating system's error inside one of `tempfile`'s, which appends
/// ` at path "<the temporary file>"` to the message: messages name only the target.
fn os_error_of(e: io::Error) -> io::Error {
    let message = e.to_string();
    match message.split_once(" at path ") {
        Some((os, _)) => io::Error::new(e.kind(), os.to_string()),
        None => e,
    }
}

fn put_voxel(v: &Voxel, out: &mut Vec<u8>) {
    out.extend_from_slice(&v.density.to_le_bytes());
    for c in v.colour {
        out.extend_from_slice(&c.to_le_bytes());
    }
}

fn write_node(n: &Node, out: &mut Vec<u8>) {
    match n {
        Node::Uniform(v) => {
            out.push(0);
            put_voxel(v, out);
        }
        Node::Brick(b) => {
            out.push(1);
            for d in b.density {
                out.extend_from_slice(&d.to_le_bytes());
            }
            match &b.colour {
                BrickColour::Uniform(c) => {
                    out.push(0);
                    c.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
                }
                BrickColour::PerVoxel(cs) => {
                    out.push(1);
                    cs.iter()
                        .flatten()
                        .for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
                }
            }
        }
        Node::Branch(children) => {
            out.push(2);
            children.iter().for_each(|c| write_node(c, out));
        }
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn malformed(&self, message: String) -> FileError {
        FileError::Malformed {
            offset: self.at,
            message,
        }
    }
    fn take<const N: usize>(&mut self) -> Result<[u8; N], FileError> {
        let end = self.at.checked_add(N).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(self.malformed("unexpected end of the tree".into()));
        };
        let out = self.bytes[self.at..end].try_into().unwrap();
        self.at = end;
        Ok(out)
    }
    fn u8(&mut self) -> Result<u8, FileError> {
        Ok(self.take::<1>()?[0])
    }
    fn u32(&mut self) -> Result<u32, FileError> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    fn f64(&mut self) -> Result<f64, FileError> {
        Ok(f64::from_le_bytes(self.take()?))
    }
    fn f32(&mut self) -> Result<f32, FileError> {
        Ok(f32::from_le_bytes(self.take()?))
    }
    fn density(&mut self) -> Result<f32, FileError> {
        let d = self.f32()?;
        if !(0.0..=1.0).contains(&d) {
            return Err(FileError::Malformed {
                offset: self.at - 4,
                message: format!("density {d} outside [0, 1]"),
            });
        }
        Ok(d)
    }
    fn colour(&mut self) -> Result<[f32; 3], FileError> {
        let c = [self.f32()?, self.f32()?, self.f32()?];
        if !c.iter().all(|x| x.is_finite()) {
            return Err(FileError::Malformed {
                offset: self.at - 12,
                message: "colour is not finite".into(),
            });
        }
        Ok(c)
    }
}

fn read_node(r: &mut Reader, level: u32) -> Result<Node, FileError> {
    let tag_at = r.at;
    match r.u8()? {
        0 => Ok(Node::Uniform(Voxel {
            density: r.density()?,
            colour: r.colour()?,
        })),
        1 if level == 0 => {
            let mut voxels = [Voxel {
                density: 0.0,
                colour: [0.0; 3],
            }; BRICK_VOXELS];
            for v in voxels.iter_mut() {
                v.density = r.density()?;
            }
            match r.u8()? {
                0 => {
                    let c = r.colour()?;
                    voxels.iter_mut().for_each(|v| v.colour = c);
                }
                1 => {
                    for v in voxels.iter_mut() {
                        v.colour = r.colour()?;
                    }
                }
                t => return Err(r.malformed(format!("unknown brick colour tag {t}"))),
            }
            // Canonical form: a brick of equal voxels is stored as a uniform node.
            let node = Brick::from_voxels(&voxels);
            match &node {
                Node::Brick(b) => Ok(Node::Brick(Arc::clone(b))),
                _ => Err(FileError::Malformed {
                    offset: tag_at,
                    message: "brick of equal voxels (must be a uniform node)".into(),
                }),
            }
        }
        2 if level > 0 => {
            let mut children = Vec::with_capacity(8);
            for _ in 0..8 {
                children.push(read_node(r, level - 1)?);
            }
            let children: [Node; 8] = children.try_into().expect("eight");
            match Node::branch(children) {
                n @ Node::Branch(_) => Ok(n),
                _ => Err(FileError::Malformed {
                    offset: tag_at,
                    message: "branch of eight equal uniform children (must be one uniform node)".into(),
                }),
            }
        }
        1 => Err(FileError::Malformed {
            offset: tag_at,
            message: format!("brick at level {level} (bricks are level 0)"),
        }),
        2 => Err(FileError::Malformed {
            offset: tag_at,
            message: "branch below level 0".into(),
        }),
        t => Err(FileError::Malformed {
            offset: tag_at,
            message: format!("unknown node tag {t}"),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc32_of_the_check_string() {
        // The standard check value of CRC-32/ISO-HDLC.
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    /// A write failing half-way (as a full disk would) leaves the existing file as it was
    /// and no temporary file; a complete write replaces it.
    #[test]
    fn a_write_failing_midway_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.vsculpt");
        std::fs::write(&path, b"the old file").unwrap();
        let e = write_atomically(&path, |w| {
            w.write_all(&[7u8; 10_000])?;
            Err(io::Error::other("the disk is full"))
        })
        .unwrap_err();
        assert!(matches!(e, SculptFileError::Write { .. }));
        assert_eq!(e.path(), path);
        assert!(
            e.to_string().contains("s.vsculpt") && e.to_string().contains("the disk is full"),
            "{e}"
        );
        assert_eq!(std::fs::read(&path).unwrap(), b"the old file");
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["s.vsculpt"], "no temporary file left");
        write_atomically(&path, |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_path_without_a_file_name_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let e = write_atomically(&dir.path().join(".."), |w| w.write_all(b"x")).unwrap_err();
        assert!(e.to_string().contains("no file name"), "{e}");
    }
}
