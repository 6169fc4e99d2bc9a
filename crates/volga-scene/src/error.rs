use std::path::PathBuf;

use thiserror::Error;
use volga_core::memory::Bytes;

/// Bad input in a scene: every message names the file and the line/column or the
/// field path, so the user can go straight to the mistake.
#[derive(Debug, Error)]
pub enum SceneError {
    /// A scene or stroke file could not be read (missing, unreadable, not UTF-8); the
    /// message names the file and the operating system's reason.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file that could not be read.
        path: PathBuf,
        /// Why the operating system refused it.
        source: std::io::Error,
    },
    /// The file's extension is neither `.ron` nor `.json` (any case), so its syntax is
    /// unknown; nothing was parsed.
    #[error("{}: unsupported scene file extension (expected .ron or .json)", path.display())]
    Extension {
        /// The file given.
        path: PathBuf,
    },
    /// The text is not a scene (or stroke file): bad syntax, an unknown field, a missing
    /// required field or a value of the wrong type, at `line:column`.
    #[error("{}:{line}:{column}: {message}", path.display())]
    Parse {
        /// The file parsed.
        path: PathBuf,
        /// Line of the error, 1-based.
        line: usize,
        /// Column of the error, 1-based.
        column: usize,
        /// The parser's description of the problem.
        message: String,
    },
    /// A value parsed but is refused: out of range, inconsistent with another field, or
    /// naming a file that cannot be loaded (in the resolve stage). `field` is its path in
    /// the scene, e.g. `objects[1].shape.radius` or `root.Cvg.operands[0].Fuzzy.radius`.
    #[error("{}: field `{field}`: {message}", path.display())]
    Invalid {
        /// The scene (or stroke) file; empty in the errors a mesh, volume, hypertexture or
        /// ADF node raises when it is used (rendered, baked) without its data.
        path: PathBuf,
        /// Field path of the refused value.
        field: String,
        /// What is wrong and what is accepted, e.g. `must be finite and > 0, got -1`.
        message: String,
    },
    /// The plan's upper bound on the build's memory, or on what parsing a mesh file
    /// takes, exceeds the limit (the machine's available memory unless the caller gives
    /// one); refused before anything is allocated.
    #[error(
        "{}: the build needs an estimated {needed} of memory ({detail}), more than the {limit} available; \
         lower grid.resolution or shrink grid.bounds",
        path.display()
    )]
    TooLarge {
        /// The scene file.
        path: PathBuf,
        /// The estimated need.
        needed: Bytes,
        /// The memory limit it exceeds.
        limit: Bytes,
        /// What the estimate counts: the grid's voxels and bricks, or the mesh file and
        /// its size.
        detail: String,
    },
    /// The plan's bound on the images' work exceeds [`crate::plan::MAX_SAMPLES`].
    #[error("{}: scene refused before building: {detail}", path.display())]
    TooMuchWork {
        /// The scene file.
        path: PathBuf,
        /// What the bound counts and what to change.
        detail: String,
    },
}

/// A build that was planned but failed while running (an output could not be
/// written, say). Earlier outputs are left as they were.
#[derive(Debug, Error)]
pub enum BuildError {
    /// The scene was refused (parsing, validation, resolving, planning), or a node
    /// failed while being baked or meshed; counted as bad input
    /// ([`BuildError::is_bad_input`]).
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// An output could not be written: the output folder could not be created, the disk
    /// lacks space for the volumes (checked before any work), or a file could not be
    /// written or renamed into place.
    #[error(transparent)]
    Io(#[from] volga_io::IoError),
    /// The renderer failed on an image (or one turntable frame), e.g. a node's lazy
    /// field could not be built.
    #[error("rendering image `{image}` failed: {message}")]
    Render {
        /// The image's file stem (`name`, or `{name}_0007` for a turntable frame).
        image: String,
        /// The renderer's error.
        message: String,
    },
    /// An output outgrew what the memory limit leaves it while being made (a mesh output
    /// with more triangles than fit) and was stopped; nothing was written.
    #[error("{output}: stopped at the memory limit: {message}")]
    Limit {
        /// The output's field path (`outputs.meshes.m`).
        output: String,
        /// What passed the limit.
        message: String,
    },
}

impl BuildError {
    /// True when the user's input was at fault (CLI exit code 2), false when the build
    /// itself failed (exit code 1).
    pub fn is_bad_input(&self) -> bool {
        matches!(self, BuildError::Scene(_))
    }
}
