//! # volga-io — file formats and safe output writes
//!
//! * **Atomic writes.** Every file this crate writes goes first to a temporary file
//!   `.{name}.tmp-{pid}-{counter}` in the *same directory* as its final path; the
//!   temp file is flushed and `fsync`ed, then renamed over the final path. A failed or
//!   interrupted write therefore never leaves a half-written output, and an existing
//!   file is untouched until the new one is complete ([`write_atomic`]).
//!   [`StagedOutputs`] extends this to a set of files committed together (a render
//!   and its volume dump, a NRRD header and its data file): nothing is renamed until
//!   every file of the set has been written.
//!
//! ```
//! use volga_io::{write_atomic, StagedOutputs};
//! let dir = tempfile::tempdir().unwrap();
//! let a = dir.path().join("a.txt");
//! write_atomic(&a, |w| w.write_all(b"hello")).unwrap();
//! let mut outputs = StagedOutputs::new();
//! outputs.stage(&a, |w| w.write_all(b"replaced")).unwrap();
//! outputs.stage(&dir.path().join("b.txt"), |w| w.write_all(b"new")).unwrap();
//! assert_eq!(std::fs::read_to_string(&a).unwrap(), "hello"); // nothing renamed yet
//! outputs.commit().unwrap();
//! assert_eq!(std::fs::read_to_string(&a).unwrap(), "replaced");
//! ```
//! * **Any voxel model** ([`VoxelFormat::from_path`], [`read_voxel_model`],
//!   [`write_voxel_model`]): `.binvox`, `.nrrd` and `.vdb` by extension, with what a NRRD's
//!   values mean ([`VoxelValues`]: occupancy, density or distance) and the free-space
//!   check before writing ([`check_free_space`], [`VoxelFormat::bytes_bound`]).
//! * **OpenVDB** `.vdb` files ([`vdb`]): volumes written as level sets, fog volumes
//!   and colour grids without densifying, float grids read back into sparse volumes.
//! * **PNG** images, 8-bit RGBA, non-interlaced ([`encode_png`], 16-bit [`encode_png16`], [`decode_png`],
//!   [`write_png`]).
//! * **NRRD** volumes with a detached header (`{stem}.nrrd` + `{stem}.raw`)
//!   ([`write_nrrd`]) and a reader for the common subset of the format
//!   ([`read_nrrd`], [`read_nrrd_with_colour`]).
//!
//! ## Binary layout
//! Raw voxel data is **little endian** with **x varying fastest**, then y, then z
//! (`linear = x + X·(y + Y·z)`, the layout of [`volga_core::Shape3`]). Colour data
//! interleaves the three components per voxel (`r g b` of voxel 0, then voxel 1, …).
//!
//! ## Geometry
//! A NRRD's `space origin` is the world position of voxel 0's *centre* and its
//! `space directions` are the per-axis spacing vectors, which is exactly volga's voxel
//! convention (`world = origin + ijk ⊙ spacing`, see [`volga_core`]), so a volume
//! round-trips through [`write_nrrd`] and [`read_nrrd`] with its transform bit-exact.
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod atomic;
mod binvox;
mod model;
mod nrrd_header;
mod nrrd_read;
mod nrrd_write;
mod png_io;
pub mod vdb;

use std::path::{Path, PathBuf};

pub use atomic::{output_identity, remove_temp_files, write_atomic, StagedOutputs};
pub use binvox::{decode_binvox, encode_binvox, read_binvox, write_binvox, Binvox, BinvoxError};
pub use model::{
    binvox_from_volume, check_free_space, check_free_space_for, encode_binvox_volume, free_space, read_voxel_model,
    read_voxel_model_within, save_voxel_model, write_voxel_model, write_voxel_model_with, VoxelFormat, VoxelModel,
    VoxelValues,
};
pub use nrrd_read::{read_nrrd, read_nrrd_with_colour, read_nrrd_within};
pub use nrrd_write::write_nrrd;
pub use png_io::{decode_png, encode_png, encode_png16, write_png};
pub use vdb::{
    decode_vdb, encode_vdb, read_vdb, read_vdb_within, vdb_active_voxels, vdb_bytes_bound, write_vdb, VdbClass,
    VdbCompression, VdbGridKind, VdbOptions, VdbVolume,
};

/// Errors of this crate; every message names the file it concerns.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The operating system refused an operation on `path` (open, write, rename…).
    #[error("cannot access {}: {source}", path.display())]
    Io {
        /// The file or directory the operation concerned.
        path: PathBuf,
        /// The operating system's error (also the error's
        /// [`source`](std::error::Error::source)).
        #[source]
        source: std::io::Error,
    },
    /// The contents of `path` (at `line` of its text header, when known) are not
    /// what the format requires, or a volume cannot be represented in it.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(" line {l}")).unwrap_or_default())]
    Format {
        /// The file whose contents are wrong, or the output that cannot be written.
        path: PathBuf,
        /// 1-based line of the file's text header, when the problem is on one line of it.
        line: Option<usize>,
        /// What is wrong, e.g. ``unknown field `foo` ``.
        message: String,
    },
    /// The filesystem of directory `path` has less free space than the outputs need.
    #[error(
        "{}: not enough free space: the outputs need {} ({needed} bytes), the filesystem has {} ({available} bytes) available",
        path.display(), volga_core::memory::Bytes(*needed as u128), volga_core::memory::Bytes(*available as u128)
    )]
    NoSpace {
        /// The directory checked.
        path: PathBuf,
        /// Bytes the outputs need in that directory.
        needed: u64,
        /// Bytes available to an unprivileged user on its filesystem.
        available: u64,
    },
}

impl IoError {
    /// The file the error concerns.
    pub fn path(&self) -> &Path {
        match self {
            IoError::Io { path, .. } | IoError::Format { path, .. } | IoError::NoSpace { path, .. } => path,
        }
    }

    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        IoError::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    pub(crate) fn format(path: &Path, line: Option<usize>, message: impl Into<String>) -> Self {
        IoError::Format {
            path: path.to_path_buf(),
            line,
            message: message.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_path_and_line() {
        let e = IoError::format(Path::new("out/v.nrrd"), Some(3), "unknown field `foo`");
        assert_eq!(e.to_string(), "out/v.nrrd line 3: unknown field `foo`");
        let e = IoError::format(Path::new("out/v.raw"), None, "truncated");
        assert_eq!(e.to_string(), "out/v.raw: truncated");
        let e = IoError::io(
            Path::new("out/a.png"),
            std::io::Error::new(std::io::ErrorKind::PermissionDenied, "Permission denied"),
        );
        assert_eq!(e.to_string(), "cannot access out/a.png: Permission denied");
        assert_eq!(e.path(), Path::new("out/a.png"));
    }
}
