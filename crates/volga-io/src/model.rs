//! Voxel models in one place: the format from a path's extension, reading and writing
//! any voxel model (`.binvox`, `.nrrd`, `.vdb`), what a NRRD's or VDB's values mean, the bytes a model
//! will take on disk and the free-space check before writing it.

use std::path::{Path, PathBuf};

use glam::{DVec3, UVec3};
use volga_core::{DenseVolume, SparseVolume};

use crate::{write_nrrd, Binvox, IoError, StagedOutputs};

/// A voxel model file format, chosen by extension ([`VoxelFormat::from_path`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VoxelFormat {
    /// `.binvox`: binary voxels (filled or empty), run-length encoded, cubic grid.
    Binvox,
    /// `.nrrd` with a detached `.raw` beside it: one `f32` per voxel.
    Nrrd,
    /// `.vdb`: OpenVDB's sparse tree ([`crate::vdb`]): a level set, fog volume or other
    /// float grid, plus a colour grid when the volume has colour.
    Vdb,
}

impl VoxelFormat {
    /// The format of `path` by its extension (case-insensitive); an error naming the
    /// file otherwise.
    pub fn from_path(path: &Path) -> Result<VoxelFormat, IoError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("binvox") => Ok(VoxelFormat::Binvox),
            Some("nrrd") => Ok(VoxelFormat::Nrrd),
            Some("vdb") => Ok(VoxelFormat::Vdb),
            _ => Err(IoError::format(
                path,
                None,
                "unknown voxel model format: expected .binvox, .nrrd or .vdb",
            )),
        }
    }

    /// `"binvox"`, `"nrrd"` or `"vdb"`.
    pub fn name(self) -> &'static str {
        match self {
            VoxelFormat::Binvox => "binvox",
            VoxelFormat::Nrrd => "nrrd",
            VoxelFormat::Vdb => "vdb",
        }
    }

    /// The files writing a model to `path` creates (or replaces): the `.binvox`, or the
    /// `.nrrd` header and its `.raw` data (plus `_colour.nrrd`/`_colour.raw` when
    /// `colour`), or the `.vdb` (colour inside it). `.binvox` models have no colour.
    pub fn output_paths(self, path: &Path, colour: bool) -> Vec<PathBuf> {
        match self {
            VoxelFormat::Binvox | VoxelFormat::Vdb => vec![path.to_owned()],
            VoxelFormat::Nrrd => {
                let stem = path
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default();
                let dir = parent_dir(path);
                let mut paths = vec![dir.join(format!("{stem}.nrrd")), dir.join(format!("{stem}.raw"))];
                if colour {
                    paths.push(dir.join(format!("{stem}_colour.nrrd")));
                    paths.push(dir.join(format!("{stem}_colour.raw")));
                }
                paths
            }
        }
    }

    /// An upper bound on the bytes writing `volume` in this format takes on disk.
    ///
    /// NRRD: 4 bytes a voxel (12 more with colour) and a header under 1 KiB per file.
    /// binvox: two bytes per run; runs are at most `2·filled + 1` plus one per 255
    /// voxels of the cubic grid (a run holds at most 255), and the header is under
    /// 1 KiB. `filled` is the count of voxels > 0.5 ([`SparseVolume::active_voxel_count`]
    /// bounds it). `.vdb`: [`crate::vdb_bytes_bound`] at full precision.
    pub fn bytes_bound(self, volume: &SparseVolume) -> u64 {
        let dims = volume.grid.dims();
        match self {
            VoxelFormat::Vdb => crate::vdb_bytes_bound(volume, false),
            VoxelFormat::Nrrd => {
                let voxels = dims.x as u64 * dims.y as u64 * dims.z as u64;
                let per_voxel = if volume.colour.is_some() { 16 } else { 4 };
                voxels.saturating_mul(per_voxel).saturating_add(4 << 10)
            }
            VoxelFormat::Binvox => {
                let side = dims.max_element() as u64;
                let total = side.saturating_mul(side).saturating_mul(side);
                let filled = volume.active_voxel_count();
                let runs = filled
                    .saturating_mul(2)
                    .saturating_add(1)
                    .saturating_add(total / 255 + 1);
                runs.min(total).saturating_mul(2).saturating_add(1 << 10)
            }
        }
    }
}

/// The directory a path lives in (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    path.parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
}

/// What the values of a voxel model mean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum VoxelValues {
    /// Every voxel is 0 or 1 (a `.binvox`, or a NRRD holding only 0 and 1).
    Occupancy,
    /// Densities in [0, 1] (anti-aliased voxelization): black means density ≥ 0.5.
    Density,
    /// Distances (volga's narrow-band fields, or any NRRD whose values leave [0, 1]):
    /// not occupancy. `min`/`max` are the sample range, `background` the value outside
    /// the band (volga writes `+half-width`).
    Distance {
        /// Smallest sample value.
        min: f32,
        /// Largest sample value.
        max: f32,
        /// The volume's background, the value outside the grid (volga writes
        /// `+half-width`, the band's outer value).
        background: f32,
    },
}

impl VoxelValues {
    /// The rule, applied to a NRRD density volume: **distances** when the recorded
    /// background (`volga_background`, written by volga as `+half-width` for distance
    /// fields and 0 for densities) is not 0, or any sample lies outside [0, 1] (a
    /// negative value is an inside distance); else **occupancy** if every sample is 0
    /// or 1, else **density**. Non-finite samples are an error (reported by
    /// [`read_voxel_model`]).
    pub fn classify(volume: &DenseVolume) -> VoxelValues {
        let background = volume.density.background();
        let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
        let mut binary = true;
        for &v in volume.density.as_slice() {
            min = min.min(v);
            max = max.max(v);
            binary &= v == 0.0 || v == 1.0;
        }
        if volume.density.as_slice().is_empty() {
            (min, max) = (background, background);
        }
        VoxelValues::decide(min, max, background, false, || binary)
    }

    /// The rule of [`VoxelValues::classify`] from a volume's value range, background and
    /// (asked only when needed) whether every value is 0 or 1.
    fn decide(min: f32, max: f32, background: f32, level_set: bool, binary: impl FnOnce() -> bool) -> VoxelValues {
        if level_set || background != 0.0 || min < 0.0 || max > 1.0 {
            VoxelValues::Distance { min, max, background }
        } else if binary() {
            VoxelValues::Occupancy
        } else {
            VoxelValues::Density
        }
    }

    /// [`VoxelValues::classify`] of a sparse volume's voxels inside its grid; a level
    /// set (`level_set`) is always distances.
    pub fn classify_sparse(volume: &SparseVolume, level_set: bool) -> VoxelValues {
        let background = volume.density.background();
        let index_box = volume.grid.index_box();
        let (min, max) = volume.density.range_in(&index_box);
        let (min, max) = if min > max {
            (background, background)
        } else {
            (min, max)
        };
        VoxelValues::decide(min, max, background, level_set, || {
            volume
                .density
                .sorted_bricks()
                .into_iter()
                .all(|b| match volume.density.brick(b) {
                    Some(volga_core::Brick::Uniform(v)) => *v == 0.0 || *v == 1.0,
                    Some(volga_core::Brick::Dense(d)) => d.iter().all(|v| *v == 0.0 || *v == 1.0),
                    None => true,
                })
        })
    }

    /// `"occupancy"`, `"density"` or `"distance"`.
    pub fn name(&self) -> &'static str {
        match self {
            VoxelValues::Occupancy => "occupancy",
            VoxelValues::Density => "density",
            VoxelValues::Distance { .. } => "distance",
        }
    }
}

/// A voxel model read from disk.
#[derive(Debug, Clone)]
pub enum VoxelModel {
    /// A `.binvox` model: binary occupancy.
    Binvox(Binvox),
    /// A NRRD volume and what its values mean.
    Nrrd {
        /// The density channel as [`read_nrrd`](crate::read_nrrd) reads it (no colour), every sample
        /// finite.
        volume: DenseVolume,
        /// What the samples mean ([`VoxelValues::classify`] of `volume`).
        values: VoxelValues,
    },
    /// The first float grid of a `.vdb` file ([`crate::read_vdb`]).
    Vdb {
        /// The grid, its name and class.
        grid: crate::VdbVolume,
        /// What the values mean: distances for a level set (or values outside
        /// \[0, 1\] or a background other than 0), else occupancy or density
        /// ([`VoxelValues::classify_sparse`]).
        values: VoxelValues,
    },
}

impl VoxelModel {
    /// The format the model was read from.
    pub fn format(&self) -> VoxelFormat {
        match self {
            VoxelModel::Binvox(_) => VoxelFormat::Binvox,
            VoxelModel::Nrrd { .. } => VoxelFormat::Nrrd,
            VoxelModel::Vdb { .. } => VoxelFormat::Vdb,
        }
    }

    /// The model as a sparse volume placed where the file says: a `.binvox`'s filled
    /// voxels as occupancy 1 (kind [`ChannelKind::Binary`](volga_core::ChannelKind)), a
    /// NRRD's samples (kind from [`VoxelValues`]: signed distance, binary or density),
    /// a VDB grid as read. `path` names the file in errors.
    pub fn into_volume(self, path: &Path) -> Result<SparseVolume, IoError> {
        use volga_core::ChannelKind;
        match self {
            VoxelModel::Binvox(b) => {
                let transform = b.transform().map_err(|e| IoError::format(path, None, e.to_string()))?;
                let grid = volga_core::Grid::new(transform, b.dims())
                    .map_err(|e| IoError::format(path, None, e.to_string()))?;
                let mut v = SparseVolume::new(grid, 0.0, false).with_density_kind(ChannelKind::Binary);
                for ijk in b.filled() {
                    v.density.set(ijk.as_ivec3(), 1.0);
                }
                v.density.prune();
                Ok(v)
            }
            VoxelModel::Nrrd { volume, values } => {
                let kind = match values {
                    VoxelValues::Distance { .. } => ChannelKind::SignedDistance,
                    VoxelValues::Occupancy => ChannelKind::Binary,
                    VoxelValues::Density => ChannelKind::Density,
                };
                Ok(SparseVolume::from_dense(&volume).with_density_kind(kind))
            }
            VoxelModel::Vdb { grid, .. } => Ok(grid.volume),
        }
    }

    /// What the model's values mean (binvox is always occupancy).
    pub fn values(&self) -> VoxelValues {
        match self {
            VoxelModel::Binvox(_) => VoxelValues::Occupancy,
            VoxelModel::Nrrd { values, .. } | VoxelModel::Vdb { values, .. } => *values,
        }
    }
}

/// Reads a `.binvox`, `.nrrd` or `.vdb` model (format by extension), classifying a
/// NRRD's or VDB's values ([`VoxelValues::classify`]). Errors name the file: unknown
/// extension, malformed contents, and samples that are NaN or infinite (first voxel
/// named).
pub fn read_voxel_model(path: &Path) -> Result<VoxelModel, IoError> {
    read_voxel_model_within(path, volga_core::memory::input_limit())
}

/// [`read_voxel_model`] refusing, before reading it, a model that needs more than
/// `max_bytes` of memory: a `.binvox` file larger than that, a NRRD whose voxels (the
/// header's sizes, 4 bytes each, wherever its data lives) take more, a `.vdb` whose
/// file or volume does.
pub fn read_voxel_model_within(path: &Path, max_bytes: u64) -> Result<VoxelModel, IoError> {
    match VoxelFormat::from_path(path)? {
        VoxelFormat::Vdb => {
            let grid = crate::read_vdb_within(path, max_bytes)?;
            let values = VoxelValues::classify_sparse(&grid.volume, grid.class == crate::VdbClass::LevelSet);
            Ok(VoxelModel::Vdb { grid, values })
        }
        VoxelFormat::Binvox => {
            let bytes = volga_core::input::read_regular(path, max_bytes).map_err(|e| IoError::io(path, e))?;
            Ok(VoxelModel::Binvox(crate::decode_binvox(&bytes, path)?))
        }
        VoxelFormat::Nrrd => {
            let volume = crate::read_nrrd_within(path, max_bytes)?;
            if let Some(i) = volume.density.as_slice().iter().position(|v| !v.is_finite()) {
                let d = volume.grid.dims();
                let (x, y, z) = (
                    i as u64 % d.x as u64,
                    (i as u64 / d.x as u64) % d.y as u64,
                    i as u64 / (d.x as u64 * d.y as u64),
                );
                return Err(IoError::format(
                    path,
                    None,
                    format!(
                        "voxel ({x}, {y}, {z}) holds {}, not a finite value",
                        volume.density.as_slice()[i]
                    ),
                ));
            }
            let values = VoxelValues::classify(&volume);
            Ok(VoxelModel::Nrrd { volume, values })
        }
    }
}

/// The `.binvox` model of a binary volume: the voxels of `volume` whose density is
/// above 0.5. binvox grids are cubes (`dim D D D`; other tools assume it), so the grid
/// is padded with empty voxels to its largest extent, voxel 0 staying where it is.
pub fn binvox_from_volume(volume: &SparseVolume, path: &Path) -> Result<Binvox, IoError> {
    let g = &volume.grid;
    let h = g.transform.spacing().x;
    let dims = g.dims();
    let filled = volume.density.sorted_bricks().into_iter().flat_map(|b| {
        volga_core::brick_index_box(b)
            .intersection(&g.index_box())
            .iter()
            .filter(|ijk| volume.density.get(*ijk) > 0.5)
            .map(|ijk| ijk.as_uvec3())
            .collect::<Vec<_>>()
    });
    Binvox::from_filled(
        UVec3::splat(dims.max_element()),
        g.transform.origin() - DVec3::splat(0.5 * h),
        h * dims.max_element() as f64,
        filled,
    )
    .map_err(|e| IoError::format(path, None, e.to_string()))
}

/// Writes the `.binvox` of a binary volume ([`binvox_from_volume`]'s model, the same
/// bytes as [`encode_binvox`](crate::encode_binvox) of it) streaming: runs are formed
/// in file order straight from the bricks, so memory stays at one list of brick
/// coordinates (12 bytes a brick) however many voxels are filled.
pub fn encode_binvox_volume(volume: &SparseVolume, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    use volga_core::{Brick, BRICK_DIM};
    let g = &volume.grid;
    let h = g.transform.spacing().x;
    let dims = g.dims();
    let side = dims.max_element();
    let t = g.transform.origin() - DVec3::splat(0.5 * h);
    let scale = h * side as f64;
    write!(
        w,
        "#binvox 1\ndim {side} {side} {side}\ntranslate {} {} {}\nscale {scale}\ndata\n",
        t.x, t.y, t.z
    )?;
    let d = side as u64;
    let total = d * d * d;
    // Bricks inside the grid, ordered as the file runs: x slowest, then z, y fastest.
    let mut bricks: Vec<glam::IVec3> = volume
        .density
        .sorted_bricks()
        .into_iter()
        .filter(|b| b.cmpge(glam::IVec3::ZERO).all() && (*b * BRICK_DIM).cmplt(dims.as_ivec3()).all())
        .collect();
    bricks.sort_unstable_by_key(|b| (b.x, b.z, b.y));
    let mut writer = RunWriter {
        w,
        cursor: 0,
        run: None,
    };
    let mut start = 0;
    while start < bricks.len() {
        // Bricks of one x-slab of bricks, then columns of one (bx, bz).
        let bx = bricks[start].x;
        let end = start + bricks[start..].partition_point(|b| b.x == bx);
        let slab = &bricks[start..end];
        for x in (bx * BRICK_DIM)..((bx + 1) * BRICK_DIM).min(dims.x as i32) {
            let mut c = 0;
            while c < slab.len() {
                let bz = slab[c].z;
                let c_end = c + slab[c..].partition_point(|b| b.z == bz);
                for z in (bz * BRICK_DIM)..((bz + 1) * BRICK_DIM).min(dims.z as i32) {
                    for b in &slab[c..c_end] {
                        let Some(brick) = volume.density.brick(*b) else {
                            continue;
                        };
                        for y in (b.y * BRICK_DIM)..((b.y + 1) * BRICK_DIM).min(dims.y as i32) {
                            let ijk = glam::IVec3::new(x, y, z);
                            if brick.get_local(Brick::<f32>::local_offset(ijk)) > 0.5 {
                                let i = x as u64 * d * d + z as u64 * d + y as u64;
                                writer.filled(i)?;
                            }
                        }
                    }
                }
                c = c_end;
            }
        }
        start = end;
    }
    writer.finish(total)
}

/// Writes binvox `(value, count)` pairs for filled voxels given in increasing order.
struct RunWriter<'a> {
    w: &'a mut dyn std::io::Write,
    /// File index of the first voxel not yet written.
    cursor: u64,
    /// The filled run being formed: `(first, count)`.
    run: Option<(u64, u64)>,
}

impl RunWriter<'_> {
    fn filled(&mut self, i: u64) -> std::io::Result<()> {
        match &mut self.run {
            Some((first, count)) if *first + *count == i => *count += 1,
            _ => {
                self.flush()?;
                self.run = Some((i, 1));
            }
        }
        Ok(())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if let Some((first, count)) = self.run.take() {
            write_pairs(self.w, 0, first - self.cursor)?;
            write_pairs(self.w, 1, count)?;
            self.cursor = first + count;
        }
        Ok(())
    }

    fn finish(mut self, total: u64) -> std::io::Result<()> {
        self.flush()?;
        write_pairs(self.w, 0, total - self.cursor)
    }
}

fn write_pairs(w: &mut dyn std::io::Write, value: u8, mut count: u64) -> std::io::Result<()> {
    while count > 0 {
        let n = count.min(255);
        w.write_all(&[value, n as u8])?;
        count -= n;
    }
    Ok(())
}

/// Stages `volume` as the model `path` (format by extension) in `outputs`: nothing
/// appears on disk until `outputs` is committed, so a model and its report can be
/// published together. `.binvox` keeps the voxels above 0.5, padded to a cube
/// ([`binvox_from_volume`], streamed by [`encode_binvox_volume`]); `.nrrd` writes the
/// header and `.raw` data ([`write_nrrd`]); `.vdb` the volume's grids with the default
/// [`VdbOptions`](crate::VdbOptions) ([`write_voxel_model_with`] chooses them). Returns
/// the final paths staged.
pub fn write_voxel_model(
    path: &Path,
    volume: &SparseVolume,
    outputs: &mut StagedOutputs,
) -> Result<Vec<PathBuf>, IoError> {
    write_voxel_model_with(path, volume, &crate::VdbOptions::default(), outputs)
}

/// [`write_voxel_model`] with the options of a `.vdb` output (ignored by other formats).
pub fn write_voxel_model_with(
    path: &Path,
    volume: &SparseVolume,
    vdb: &crate::VdbOptions,
    outputs: &mut StagedOutputs,
) -> Result<Vec<PathBuf>, IoError> {
    match VoxelFormat::from_path(path)? {
        VoxelFormat::Vdb => crate::write_vdb(path, volume, vdb, outputs),
        VoxelFormat::Binvox => {
            // The model's header must be valid: the same checks as `Binvox::from_filled`.
            let dims = volume.grid.dims();
            let side = dims.max_element();
            Binvox::from_filled(
                UVec3::splat(side),
                volume.grid.transform.origin() - DVec3::splat(0.5 * volume.grid.transform.spacing().x),
                volume.grid.transform.spacing().x * side as f64,
                std::iter::empty(),
            )
            .map_err(|e| IoError::format(path, None, e.to_string()))?;
            outputs.stage(path, |w| encode_binvox_volume(volume, w))?;
            Ok(vec![path.to_owned()])
        }
        VoxelFormat::Nrrd => {
            let stem = path
                .file_stem()
                .and_then(|s| s.to_str())
                .ok_or_else(|| IoError::format(path, None, "the output name is not valid UTF-8"))?;
            write_nrrd(parent_dir(path), stem, volume, outputs)
        }
    }
}

/// Writes `volume` as the model `path` (format by extension, as [`write_voxel_model`])
/// all or nothing: the files appear only once all of them are complete, and nothing is
/// left behind on error. Returns the paths written (an NRRD header and its `.raw`).
pub fn save_voxel_model(path: &Path, volume: &SparseVolume) -> Result<Vec<PathBuf>, IoError> {
    let mut outputs = StagedOutputs::new();
    write_voxel_model(path, volume, &mut outputs)?;
    outputs.commit()
}

/// Refuses to write `bytes` into `dir` when its filesystem has less free space (for an
/// unprivileged user) than that: the error names the directory, the bytes needed and
/// the bytes available. `dir` must exist. On platforms without `statvfs` the check
/// passes.
pub fn check_free_space(dir: &Path, bytes: u64) -> Result<(), IoError> {
    let available = free_space(dir)?;
    match available {
        Some(available) if available < bytes => Err(IoError::NoSpace {
            path: dir.to_owned(),
            needed: bytes,
            available,
        }),
        _ => Ok(()),
    }
}

/// Bytes available to an unprivileged user on the filesystem of `dir` (`None` where
/// the platform cannot tell).
pub fn free_space(dir: &Path) -> Result<Option<u64>, IoError> {
    #[cfg(unix)]
    {
        let stat = rustix::fs::statvfs(dir).map_err(|e| IoError::io(dir, e.into()))?;
        Ok(Some(stat.f_bavail.saturating_mul(stat.f_frsize)))
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        Ok(None)
    }
}

/// Checks the free space for a set of outputs (`(final path, bytes)`), summing the
/// bytes per directory: the first directory short of space is an error. A directory
/// that does not exist yet is checked through its nearest existing ancestor.
pub fn check_free_space_for(outputs: &[(PathBuf, u64)]) -> Result<(), IoError> {
    let mut per_dir: Vec<(PathBuf, u64)> = Vec::new();
    for (path, bytes) in outputs {
        let mut dir = parent_dir(path).to_path_buf();
        while !dir.exists() {
            match dir.parent().filter(|p| !p.as_os_str().is_empty()) {
                Some(p) => dir = p.to_path_buf(),
                None => {
                    dir = PathBuf::from(".");
                    break;
                }
            }
        }
        match per_dir.iter_mut().find(|(d, _)| *d == dir) {
            Some((_, total)) => *total = total.saturating_add(*bytes),
            None => per_dir.push((dir, *bytes)),
        }
    }
    for (dir, bytes) in per_dir {
        check_free_space(&dir, bytes)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use volga_core::{Grid, Transform};

    #[test]
    fn formats_by_extension() {
        assert_eq!(
            VoxelFormat::from_path(Path::new("a/b.BinVox")).unwrap(),
            VoxelFormat::Binvox
        );
        assert_eq!(VoxelFormat::from_path(Path::new("b.nrrd")).unwrap(), VoxelFormat::Nrrd);
        assert_eq!(VoxelFormat::from_path(Path::new("b.VDB")).unwrap(), VoxelFormat::Vdb);
        let e = VoxelFormat::from_path(Path::new("out/b.vtk")).unwrap_err();
        assert!(
            e.to_string().starts_with("out/b.vtk: unknown voxel model format"),
            "{e}"
        );
        assert_eq!(
            VoxelFormat::Nrrd.output_paths(Path::new("out/v.nrrd"), false),
            vec![PathBuf::from("out/v.nrrd"), PathBuf::from("out/v.raw")]
        );
        assert_eq!(
            VoxelFormat::Nrrd.output_paths(Path::new("v.nrrd"), false),
            vec![PathBuf::from("./v.nrrd"), PathBuf::from("./v.raw")]
        );
    }

    fn dense(values: &[f32], background: f32) -> DenseVolume {
        let grid = Grid::new(
            Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(),
            UVec3::new(values.len() as u32, 1, 1),
        )
        .unwrap();
        let mut v = DenseVolume::new(grid, background, false).unwrap();
        v.density.as_mut_slice().copy_from_slice(values);
        v
    }

    #[test]
    fn nrrd_values_are_classified() {
        assert_eq!(
            VoxelValues::classify(&dense(&[0.0, 1.0, 1.0], 0.0)),
            VoxelValues::Occupancy
        );
        assert_eq!(
            VoxelValues::classify(&dense(&[0.0, 0.3, 1.0], 0.0)),
            VoxelValues::Density
        );
        assert_eq!(
            VoxelValues::classify(&dense(&[-0.5, 0.2, 0.5], 0.0)),
            VoxelValues::Distance {
                min: -0.5,
                max: 0.5,
                background: 0.0
            }
        );
        // A volga distance field whose samples all lie in [0, 1] is still distances.
        assert!(matches!(
            VoxelValues::classify(&dense(&[0.1, 0.2], 0.3)),
            VoxelValues::Distance { .. }
        ));
        assert!(matches!(
            VoxelValues::classify(&dense(&[0.0, 2.0], 0.0)),
            VoxelValues::Distance { .. }
        ));
    }

    #[test]
    fn streamed_binvox_equals_the_model_encoding() {
        use volga_core::SparseVolume;
        // A non-cubic grid with voxels in scattered bricks, runs across brick borders
        // and runs longer than 255.
        let grid = Grid::new(
            Transform::new(DVec3::new(-1.5, 2.0, 0.25), DVec3::splat(0.5)).unwrap(),
            UVec3::new(37, 300, 21),
        )
        .unwrap();
        let mut volume = SparseVolume::new(grid, 0.0, false);
        let mut state = 12345u64;
        for _ in 0..4000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let ijk = glam::IVec3::new(
                (state >> 33) as i32 % 37,
                (state >> 17) as i32 % 300,
                (state >> 5) as i32 % 21,
            );
            volume.density.set(ijk, if state % 7 == 0 { 0.5 } else { 1.0 });
        }
        for y in 0..300 {
            volume.density.set(glam::IVec3::new(3, y, 4), 1.0);
        }
        let mut streamed = Vec::new();
        encode_binvox_volume(&volume, &mut streamed).unwrap();
        let mut reference = Vec::new();
        crate::encode_binvox(
            &binvox_from_volume(&volume, Path::new("x.binvox")).unwrap(),
            &mut reference,
        )
        .unwrap();
        assert_eq!(streamed, reference);
        // and the bound holds
        assert!((streamed.len() as u64) <= VoxelFormat::Binvox.bytes_bound(&volume));
    }

    #[test]
    fn free_space_is_checked() {
        let dir = tempfile::tempdir().unwrap();
        check_free_space(dir.path(), 1).unwrap();
        let e = check_free_space(dir.path(), u64::MAX).unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains(&dir.path().display().to_string()) && m.contains("the outputs need") && m.contains("available"),
            "{m}"
        );
        let nested = dir.path().join("not/yet/there/v.nrrd");
        check_free_space_for(&[(nested.clone(), 10)]).unwrap();
        assert!(check_free_space_for(&[(nested.clone(), u64::MAX / 2), (nested, u64::MAX / 2 + 10)]).is_err());
    }
}
