//! OpenVDB `.vdb` files: the volume format of Blender, Houdini, Maya, Unreal and most
//! film and simulation pipelines.
//!
//! **Writing** ([`write_vdb`], [`encode_vdb`]) turns a [`SparseVolume`] into OpenVDB's
//! standard 5-4-3 tree without densifying: each 8³ brick is an OpenVDB leaf, a uniform
//! brick (or a whole uniform node) becomes a tile. What the density channel holds picks
//! the grid ([`VdbGridKind::of`]):
//!
//! | channel | grid | class | background | active voxels |
//! |---|---|---|---|---|
//! | signed distance (world units) | `surface`, float | level set | the band half-width | `|d| <` background; inactive values `±background` |
//! | density, binary occupancy | `density`, float | fog volume | 0 | density ≠ 0 |
//! | colour (when present) | `color`, Vec3f | unknown | (0, 0, 0) | colour ≠ black |
//!
//! Any other background makes the float grid's class `unknown` (active: ≠ background).
//! The transform maps voxel centres (OpenVDB index space, integers) to world exactly as
//! volga does: `world = origin + ijk ⊙ spacing`, a `UniformScaleTranslateMap` (or a
//! `ScaleTranslateMap` for anisotropic voxels). Metadata: `class`, `creator`,
//! `file_bbox_min/max`, `file_compression`, `file_mem_bytes`, `file_voxel_count`,
//! `name`, `is_saved_as_half_float` for half grids, and `volga_grid_dims` (the grid's
//! extent, so reading a volga file back restores it). Node values are mask-compressed
//! (active values only, plus an inside/outside mask where needed) and then stored raw,
//! zlib-compressed ([`VdbCompression::Zip`]) or Blosc-LZ4-compressed
//! ([`VdbCompression::Blosc`], OpenVDB's own default); [`VdbOptions::half`] stores
//! values as 16-bit floats. The file format is OpenVDB 10's (version 224).
//!
//! **Reading** ([`read_vdb`], [`read_vdb_within`]) loads the first float grid of a
//! file (level set or fog volume; zip, Blosc-LZ4 or no compression; full or half
//! floats) into a [`SparseVolume`]: a level set's channel holds signed distances, a fog
//! volume's densities. The volume spans the grid's active voxels (a volga file: its
//! recorded grid), starting at a multiple of 8 in the file's index space
//! ([`VdbVolume::index_offset`]). Other value types, instanced grids, rotated
//! transforms, unknown compression and file versions newer than 225 are refused with an
//! error naming the file; a hostile file is an error, never a panic, and the memory it
//! would take is checked against the limit before any value is decoded.

mod blosc;
mod format;
mod read;
mod write;

use std::path::{Path, PathBuf};

use glam::UVec3;
use volga_core::{ChannelKind, SparseVolume};

pub use read::{VdbGridInfo, VdbVolume};

use crate::{IoError, StagedOutputs};

/// How node values are compressed after mask compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VdbCompression {
    /// Stored raw.
    None,
    /// zlib (`COMPRESS_ZIP`), readable by every OpenVDB build (also those without
    /// Blosc); slower, and on level sets no smaller than Blosc (unshuffled float noise).
    Zip,
    /// Blosc with LZ4 and byte shuffle (`COMPRESS_BLOSC`), OpenVDB's own default (and
    /// Blender's, Houdini's): the default here too.
    #[default]
    Blosc,
}

impl VdbCompression {
    /// `"none"`, `"zip"` or `"blosc"`.
    pub fn name(self) -> &'static str {
        match self {
            VdbCompression::None => "none",
            VdbCompression::Zip => "zip",
            VdbCompression::Blosc => "blosc",
        }
    }

    /// The compression named `name` (`none`, `zip`, `blosc`).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "none" => Some(VdbCompression::None),
            "zip" => Some(VdbCompression::Zip),
            "blosc" => Some(VdbCompression::Blosc),
            _ => None,
        }
    }
}

/// How a `.vdb` file is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct VdbOptions {
    /// Compression of node values (default Blosc).
    pub compression: VdbCompression,
    /// Store values as 16-bit floats (grid type `…_HalfFloat`): half the bytes, values
    /// rounded to 11 significant bits.
    pub half: bool,
}

/// OpenVDB's grid class (`class` metadata), which tells tools how to treat the values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VdbClass {
    /// A narrow-band signed distance field: negative inside, background = band width.
    LevelSet,
    /// Densities, background 0.
    FogVolume,
    /// Anything else.
    Unknown,
}

impl VdbClass {
    /// The `class` metadata string: `level set`, `fog volume`, `unknown`.
    pub fn name(self) -> &'static str {
        match self {
            VdbClass::LevelSet => "level set",
            VdbClass::FogVolume => "fog volume",
            VdbClass::Unknown => "unknown",
        }
    }
}

/// The float grid a volume is written as: its name, class and active-voxel rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VdbGridKind {
    /// Grid name: `surface` (level set), `density` (fog volume or unknown).
    pub name: &'static str,
    /// The grid class.
    pub class: VdbClass,
}

impl VdbGridKind {
    /// The grid for `volume`'s density channel: a level set for signed distances with a
    /// positive background, a fog volume for densities and occupancy over background 0,
    /// else `unknown`.
    pub fn of(volume: &SparseVolume) -> VdbGridKind {
        let bg = volume.density.background();
        match volume.density_kind {
            ChannelKind::SignedDistance if bg > 0.0 => VdbGridKind {
                name: "surface",
                class: VdbClass::LevelSet,
            },
            ChannelKind::Density | ChannelKind::Binary if bg == 0.0 => VdbGridKind {
                name: "density",
                class: VdbClass::FogVolume,
            },
            _ => VdbGridKind {
                name: "density",
                class: VdbClass::Unknown,
            },
        }
    }
}

impl VdbGridKind {
    /// Whether a voxel of this grid holding `value` is active: `|value| <` background
    /// for a level set, `value ≠` background otherwise.
    pub fn is_active(&self, value: f32, background: f32) -> bool {
        match self.class {
            VdbClass::LevelSet => value.abs() < background,
            _ => value != background,
        }
    }
}

/// The active voxels `volume`'s density grid will have in a `.vdb` file (what OpenVDB
/// reports as its active voxel count): voxels inside the grid, brick by brick.
pub fn vdb_active_voxels(volume: &SparseVolume) -> u64 {
    let kind = VdbGridKind::of(volume);
    let bg = volume.density.background();
    let grid_box = volume.grid.index_box();
    volume
        .density
        .sorted_bricks()
        .into_iter()
        .map(|b| {
            volga_core::brick_index_box(b)
                .intersection(&grid_box)
                .iter()
                .filter(|ijk| kind.is_active(volume.density.get(*ijk), bg))
                .count() as u64
        })
        .sum()
}

/// The bytes of `volume` as a `.vdb` file: its density channel as a float grid (see
/// the module documentation) and, when present, its colour as a Vec3f grid `color`.
/// Equal volumes and options give equal bytes whatever the thread count.
pub fn encode_vdb(volume: &SparseVolume, options: &VdbOptions) -> Vec<u8> {
    let kind = VdbGridKind::of(volume);
    let bg = volume.density.background();
    let level_set = move |v: f32| {
        if kind.is_active(v, bg) {
            (v, true)
        } else {
            (bg.copysign(v), false)
        }
    };
    let other = move |v: f32| (v, kind.is_active(v, bg));
    let classify: &(dyn Fn(f32) -> (f32, bool) + Sync) = match kind.class {
        VdbClass::LevelSet => &level_set,
        _ => &other,
    };
    let dims: UVec3 = volume.grid.dims();
    let origin = volume.grid.transform.origin();
    let spacing = volume.grid.transform.spacing();
    let mut out = write::header(1 + volume.colour.is_some() as u32);
    write::put_grid(
        &mut out,
        &write::GridIn {
            name: kind.name,
            class: kind.class,
            values: &volume.density,
            dims,
            background: bg,
            classify,
            vector_type: None,
        },
        origin,
        spacing,
        options,
    );
    if let Some(colour) = &volume.colour {
        let cbg = colour.background();
        let classify = move |v: [f32; 3]| (v, v != cbg);
        write::put_grid(
            &mut out,
            &write::GridIn {
                name: "color",
                class: VdbClass::Unknown,
                values: colour,
                dims,
                background: cbg,
                classify: &classify,
                vector_type: Some("invariant"),
            },
            origin,
            spacing,
            options,
        );
    }
    write::stamp_uuid(&mut out);
    out
}

/// Stages `volume` as the `.vdb` file `path` in `outputs` ([`encode_vdb`]); nothing
/// appears until `outputs` is committed. Returns the path staged.
pub fn write_vdb(
    path: &Path,
    volume: &SparseVolume,
    options: &VdbOptions,
    outputs: &mut StagedOutputs,
) -> Result<Vec<PathBuf>, IoError> {
    let bytes = encode_vdb(volume, options);
    outputs.stage(path, |w| w.write_all(&bytes))?;
    Ok(vec![path.to_owned()])
}

/// An upper bound on the bytes of `volume`'s `.vdb` file at any compression: per
/// stored brick a leaf (two masks, metadata, inactive values, a selection mask, a size
/// field and 512 values), per 128³ and 4096³ region holding bricks an internal node
/// (masks and values), and the headers; each channel counted.
pub fn vdb_bytes_bound(volume: &SparseVolume, half: bool) -> u64 {
    fn nodes<T: Copy + PartialEq + Send + Sync>(g: &volga_core::SparseGrid<T>) -> (u64, u64, u64) {
        let bricks = g.sorted_bricks();
        let count = |shift: i32| {
            let mut keys: Vec<(i32, i32, i32)> = bricks
                .iter()
                .map(|b| (b.x >> shift, b.y >> shift, b.z >> shift))
                .collect();
            keys.sort_unstable();
            keys.dedup();
            keys.len() as u64
        };
        (bricks.len() as u64, count(4), count(9))
    }
    let per_value: u64 = if half { 2 } else { 4 };
    let bound = |(bricks, l1, l2): (u64, u64, u64), components: u64| {
        let v = per_value * components;
        let meta = 1 + 2 * 4 * components + 8;
        let leaf = 128 + meta + 64 + 512 * v;
        let l1_bytes = 1024 + meta + 512 + 4096 * v + 12;
        let l2_bytes = 8192 + meta + 4096 + 32768 * v + 12;
        bricks
            .saturating_mul(leaf)
            .saturating_add(l1.saturating_mul(l1_bytes))
            .saturating_add(l2.saturating_mul(l2_bytes))
            .saturating_add(4 << 10)
    };
    bound(nodes(&volume.density), 1)
        .saturating_add(volume.colour.as_ref().map_or(0, |c| bound(nodes(c), 3)))
        .saturating_add(1 << 10)
}

/// Reads the first float grid of the `.vdb` file `path` ([`read_vdb_within`] with the
/// memory a read may use, [`volga_core::memory::input_limit`]).
pub fn read_vdb(path: &Path) -> Result<VdbVolume, IoError> {
    read_vdb_within(path, volga_core::memory::input_limit())
}

/// Reads the first float grid of the `.vdb` file `path` into a [`SparseVolume`],
/// refusing a file larger than `max_bytes`, and a grid whose nodes or volume need
/// more, before decoding its values. Errors name the file.
pub fn read_vdb_within(path: &Path, max_bytes: u64) -> Result<VdbVolume, IoError> {
    let bytes = volga_core::input::read_regular(path, max_bytes).map_err(|e| IoError::io(path, e))?;
    decode_vdb(&bytes, max_bytes).map_err(|m| IoError::format(path, None, m))
}

/// [`read_vdb_within`] of a file already in memory; the error says what is wrong
/// (without a path).
pub fn decode_vdb(bytes: &[u8], max_bytes: u64) -> Result<VdbVolume, String> {
    read::parse(bytes, max_bytes)
}

#[cfg(test)]
mod tests;
