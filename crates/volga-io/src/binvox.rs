//! `.binvox` binary voxel files (Patrick Min's `binvox`; format by Michael Kazhdan).
//!
//! ```text
//! #binvox 1
//! dim DX DY DZ
//! translate TX TY TZ
//! scale S
//! data
//! <(value, count) byte pairs>
//! ```
//! The data is run-length encoded: each pair repeats `value` (0 empty, non-zero
//! filled) `count` times, `1 ≤ count ≤ 255`. Voxels are in the file's quirky order:
//! **y runs fastest, then z, then x** — voxel `(x, y, z)` is number
//! `x·DY·DZ + z·DY + y`. The `dim` line lists the extents along x, y and z (the spec
//! only shows cubic grids; non-cubic ones, as written by trimesh and by `binvox -fit`,
//! are read and written with this order).

use std::fmt::Display;
use std::io::{self, Write};
use std::path::Path;
use std::str::FromStr;

use glam::{DVec3, UVec3};
use volga_core::{CoreError, Transform};

use crate::{write_atomic, IoError};

/// Errors constructing a [`Binvox`] in memory (file errors are [`IoError`]s).
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum BinvoxError {
    /// A `dim` with a zero extent, or whose voxel count `DX·DY·DZ` overflows `u64`;
    /// holds, and the message shows, the dims given.
    #[error("binvox dimensions must be ≥ 1 on every axis with a voxel count that fits in 64 bits, got {0:?}")]
    BadDims([u32; 3]),
    /// A `translate` with an infinite or NaN component, or a `scale` that is not finite
    /// and > 0; the message names both.
    #[error("binvox translate must be finite and scale finite and > 0, got translate {translate:?}, scale {scale}")]
    BadTransform {
        /// The `translate` given (world units).
        translate: [f64; 3],
        /// The `scale` given (world units: the edge of the cube the grid's longest axis
        /// spans).
        scale: f64,
    },
    /// A filled voxel given to [`Binvox::from_filled`] lies outside `0 ≤ ijk < dims`;
    /// the message names the voxel and the dims.
    #[error("voxel {ijk:?} lies outside the binvox grid 0..{dims:?}")]
    OutsideGrid {
        /// The first voxel found outside (x, y, z).
        ijk: [u32; 3],
        /// The grid's extents along x, y, z.
        dims: [u32; 3],
    },
}

/// A binary voxel model as stored in a `.binvox` file: extents, the normalization
/// transform (`translate`, `scale`) and the filled voxels.
///
/// The `dim` line lists the extents `DX DY DZ` along x, y, z; the data's voxel order
/// has y fastest, then z, then x (voxel `(x, y, z)` is number `x·DY·DZ + z·DY + y`).
/// Filled voxels are kept as runs of that order, so memory follows the file's size,
/// not `DX·DY·DZ` (a 1024³ model is not expanded to 2³⁰ bytes).
#[derive(Debug, Clone, PartialEq)]
pub struct Binvox {
    dims: UVec3,
    translate: DVec3,
    scale: f64,
    /// Filled voxels as `(first, count)` in file order: sorted, disjoint, merged.
    runs: Vec<(u64, u64)>,
}

impl Binvox {
    /// A model of `dims` voxels holding the `filled` voxels (any order, duplicates
    /// allowed).
    pub fn from_filled(
        dims: UVec3,
        translate: DVec3,
        scale: f64,
        filled: impl IntoIterator<Item = UVec3>,
    ) -> Result<Self, BinvoxError> {
        voxel_total(dims).ok_or(BinvoxError::BadDims(dims.to_array()))?;
        if !translate.is_finite() || !scale.is_finite() || scale <= 0.0 {
            return Err(BinvoxError::BadTransform {
                translate: translate.to_array(),
                scale,
            });
        }
        let mut indices = Vec::new();
        for ijk in filled {
            if ijk.cmpge(dims).any() {
                return Err(BinvoxError::OutsideGrid {
                    ijk: ijk.to_array(),
                    dims: dims.to_array(),
                });
            }
            indices.push(file_index(dims, ijk));
        }
        indices.sort_unstable();
        indices.dedup();
        let mut runs = Runs::default();
        for i in indices {
            runs.push(i, 1);
        }
        Ok(Binvox {
            dims,
            translate,
            scale,
            runs: runs.0,
        })
    }

    /// Extents along x, y, z (the `dim` line).
    pub fn dims(&self) -> UVec3 {
        self.dims
    }

    /// The `translate` line (0 when the file has none).
    pub fn translate(&self) -> DVec3 {
        self.translate
    }

    /// The `scale` line (1 when the file has none).
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Number of filled voxels.
    pub fn filled_count(&self) -> u64 {
        self.runs.iter().map(|r| r.1).sum()
    }

    /// Whether voxel `ijk` is filled (false outside the grid).
    pub fn is_filled(&self, ijk: UVec3) -> bool {
        if ijk.cmpge(self.dims).any() {
            return false;
        }
        let i = file_index(self.dims, ijk);
        let k = self.runs.partition_point(|r| r.0 <= i);
        k > 0 && i < self.runs[k - 1].0 + self.runs[k - 1].1
    }

    /// The filled voxels in file order (x slowest, then z, y fastest).
    pub fn filled(&self) -> impl Iterator<Item = UVec3> + '_ {
        let dims = self.dims;
        self.runs
            .iter()
            .flat_map(move |&(first, count)| (first..first + count).map(move |i| voxel_of(dims, i)))
    }

    /// The world transform of the voxel centres in volga's convention
    /// (`world = origin + ijk ⊙ spacing`, see [`volga_core`]).
    ///
    /// binvox maps voxel `ijk` of a `d`³ grid to the unit cube, `(ijk + ½) / d`, then
    /// scales by `scale` and translates by `translate`: spacing `scale / d`, origin
    /// `translate + ½·scale / d`. For non-cubic grids `d` is the largest extent (the
    /// unit cube holds the longest axis).
    pub fn transform(&self) -> Result<Transform, CoreError> {
        let spacing = self.scale / self.dims.max_element() as f64;
        Transform::new(self.translate + DVec3::splat(0.5 * spacing), DVec3::splat(spacing))
    }
}

/// Accumulates filled runs, merging touching ones.
#[derive(Default)]
struct Runs(Vec<(u64, u64)>);

impl Runs {
    fn push(&mut self, first: u64, count: u64) {
        match self.0.last_mut() {
            Some(last) if last.0 + last.1 == first => last.1 += count,
            _ => self.0.push((first, count)),
        }
    }
}

fn voxel_total(dims: UVec3) -> Option<u64> {
    if dims.cmpeq(UVec3::ZERO).any() {
        return None;
    }
    (dims.x as u64).checked_mul(dims.y as u64)?.checked_mul(dims.z as u64)
}

/// `x·DY·DZ + z·DY + y`: y fastest, then z, then x.
fn file_index(dims: UVec3, ijk: UVec3) -> u64 {
    let (dy, dz) = (dims.y as u64, dims.z as u64);
    ijk.x as u64 * dy * dz + ijk.z as u64 * dy + ijk.y as u64
}

fn voxel_of(dims: UVec3, i: u64) -> UVec3 {
    let (dy, dz) = (dims.y as u64, dims.z as u64);
    UVec3::new((i / (dy * dz)) as u32, (i % dy) as u32, ((i / dy) % dz) as u32)
}

/// Reads a `.binvox` file (version 1, or 2 whose filled values > 1 read as filled).
///
/// Header lines may come in any order between the first line and `data`; `dim` is
/// required, `translate` and `scale` default to 0 and 1; blank lines, `#` comments
/// and unknown keywords are skipped, as binvox's own reader does. Errors name the
/// file and the header line or data byte at fault: a first line other than
/// `#binvox N`, a missing or malformed `dim`, a run of count 0, a run past the voxel
/// count, data ending before the last voxel. Bytes after the last voxel are ignored.
pub fn read_binvox(path: &Path) -> Result<Binvox, IoError> {
    let bytes = volga_core::input::read_input(path).map_err(|e| IoError::io(path, e))?;
    decode_binvox(&bytes, path)
}

/// [`read_binvox`] on bytes already in memory; `path` names them in errors.
pub fn decode_binvox(bytes: &[u8], path: &Path) -> Result<Binvox, IoError> {
    let (header, data) = parse_header(bytes, path)?;
    let runs = decode_runs(data, header.dims, bytes.len() - data.len(), path)?;
    Ok(Binvox {
        dims: header.dims,
        translate: header.translate,
        scale: header.scale,
        runs,
    })
}

struct Header {
    dims: UVec3,
    translate: DVec3,
    scale: f64,
}

/// Parses the text header; returns it and the data bytes after the `data` line.
fn parse_header<'a>(bytes: &'a [u8], path: &Path) -> Result<(Header, &'a [u8]), IoError> {
    let mut rest = bytes;

    let first = next_line(&mut rest).unwrap_or_default();
    let version = std::str::from_utf8(first)
        .ok()
        .and_then(|l| l.strip_prefix("#binvox"))
        .map(str::trim);
    match version {
        Some("1" | "2") => {}
        Some(v) => {
            return Err(IoError::format(
                path,
                Some(1),
                format!("unsupported binvox version `{v}` (1 and 2 are read)"),
            ))
        }
        None => {
            let shown: String = String::from_utf8_lossy(&first[..first.len().min(40)]).into();
            return Err(IoError::format(
                path,
                Some(1),
                format!(
                    "not a binvox file: the first line must be `#binvox 1`, found `{}`",
                    shown.escape_debug()
                ),
            ));
        }
    }

    let mut dims = None;
    let mut translate = DVec3::ZERO;
    let mut scale = 1.0;
    let mut line = 1;
    loop {
        let Some(text) = next_line(&mut rest) else {
            return Err(IoError::format(path, None, "header ends without a `data` line"));
        };
        line += 1;
        let text = std::str::from_utf8(text)
            .map_err(|_| IoError::format(path, Some(line), "header line is not text (missing `data` line?)"))?;
        let mut words = text.split_whitespace();
        let keyword = words.next();
        let values: Vec<&str> = words.collect();
        match keyword {
            None => continue,
            Some(w) if w.starts_with('#') => continue,
            Some("data") => break,
            Some("dim") => {
                let d: [u32; 3] = parse_values(&values, path, line, "dim", "three positive integers")?;
                if voxel_total(UVec3::from(d)).is_none() {
                    return Err(IoError::format(
                        path,
                        Some(line),
                        format!("dim {d:?}: extents must be ≥ 1 with a voxel count that fits in 64 bits"),
                    ));
                }
                dims = Some(UVec3::from(d));
            }
            Some("translate") => {
                let t: [f64; 3] = parse_values(&values, path, line, "translate", "three finite numbers")?;
                translate = DVec3::from(t);
                if !translate.is_finite() {
                    return Err(IoError::format(
                        path,
                        Some(line),
                        "translate must be three finite numbers",
                    ));
                }
            }
            Some("scale") => {
                let [s]: [f64; 1] = parse_values(&values, path, line, "scale", "one finite number > 0")?;
                if !s.is_finite() || s <= 0.0 {
                    return Err(IoError::format(
                        path,
                        Some(line),
                        format!("scale must be finite and > 0, got {s}"),
                    ));
                }
                scale = s;
            }
            Some(_) => continue, // unknown keyword: skipped, as binvox's reader does
        }
    }
    let dims = dims.ok_or_else(|| IoError::format(path, Some(line), "header has no `dim` line before `data`"))?;
    Ok((Header { dims, translate, scale }, rest))
}

/// Splits off the first line of `rest` (without `\n` or `\r\n`); `None` at the end.
fn next_line<'a>(rest: &mut &'a [u8]) -> Option<&'a [u8]> {
    if rest.is_empty() {
        return None;
    }
    let end = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
    let line = &rest[..end];
    *rest = &rest[(end + 1).min(rest.len())..];
    Some(line.strip_suffix(b"\r").unwrap_or(line))
}

fn parse_values<T: FromStr + Copy + Default, const K: usize>(
    values: &[&str],
    path: &Path,
    line: usize,
    keyword: &str,
    expected: &str,
) -> Result<[T; K], IoError>
where
    T::Err: Display,
{
    let bad = || {
        IoError::format(
            path,
            Some(line),
            format!("`{keyword}` needs {expected}, got `{}`", values.join(" ")),
        )
    };
    if values.len() != K {
        return Err(bad());
    }
    let mut out = [T::default(); K];
    for (o, v) in out.iter_mut().zip(values) {
        *o = v.parse().map_err(|_| bad())?;
    }
    Ok(out)
}

/// Decodes the `(value, count)` pairs; `data_offset` is the file offset of `data`.
fn decode_runs(data: &[u8], dims: UVec3, data_offset: usize, path: &Path) -> Result<Vec<(u64, u64)>, IoError> {
    let total = voxel_total(dims).expect("validated by the header parser");
    let mut runs = Runs::default();
    let mut index = 0u64;
    let mut pos = 0;
    while index < total {
        let offset = data_offset + pos;
        let (value, count) = match data.get(pos..pos + 2) {
            Some(&[value, count]) => (value, count),
            _ => {
                let what = if pos < data.len() {
                    format!("the value byte at byte {offset} has no count byte")
                } else {
                    "the data ends".to_string()
                };
                return Err(IoError::format(
                    path,
                    None,
                    format!(
                        "truncated data: {what} after {index} of the {total} voxels of dim {}",
                        dims_text(dims)
                    ),
                ));
            }
        };
        pos += 2;
        if count == 0 {
            return Err(IoError::format(
                path,
                None,
                format!("run of count 0 at byte {offset} (counts are 1..=255)"),
            ));
        }
        let count = count as u64;
        if index + count > total {
            return Err(IoError::format(
                path,
                None,
                format!(
                    "run at byte {offset} overflows the grid: it ends at voxel {}, but dim {} has {total}",
                    index + count,
                    dims_text(dims)
                ),
            ));
        }
        if value != 0 {
            runs.push(index, count);
        }
        index += count;
    }
    Ok(runs.0)
}

fn dims_text(d: UVec3) -> String {
    format!("{} {} {}", d.x, d.y, d.z)
}

/// Writes `model` in the binvox format (version 1, value byte 1 for filled voxels,
/// runs of at most 255) to `w`. Numbers are printed in Rust's shortest round-trip
/// form, so reading the file back gives the same `translate` and `scale` bits.
pub fn encode_binvox(model: &Binvox, w: &mut dyn Write) -> io::Result<()> {
    let (d, t) = (model.dims, model.translate);
    write!(
        w,
        "#binvox 1\ndim {} {} {}\ntranslate {} {} {}\nscale {}\ndata\n",
        d.x, d.y, d.z, t.x, t.y, t.z, model.scale
    )?;
    let total = voxel_total(d).expect("validated at construction");
    let mut cursor = 0;
    for &(first, count) in &model.runs {
        write_run(w, 0, first - cursor)?;
        write_run(w, 1, count)?;
        cursor = first + count;
    }
    write_run(w, 0, total - cursor)
}

fn write_run(w: &mut dyn Write, value: u8, mut count: u64) -> io::Result<()> {
    while count > 0 {
        let n = count.min(255);
        w.write_all(&[value, n as u8])?;
        count -= n;
    }
    Ok(())
}

/// Writes `model` to `path` atomically ([`write_atomic`]): an existing file is
/// replaced only once the new one is complete. To commit it with other outputs, stage
/// [`encode_binvox`] in a [`StagedOutputs`](crate::StagedOutputs).
pub fn write_binvox(path: &Path, model: &Binvox) -> Result<(), IoError> {
    write_atomic(path, |w| encode_binvox(model, w))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_order_is_y_then_z_then_x() {
        let dims = UVec3::new(2, 3, 4);
        assert_eq!(file_index(dims, UVec3::new(0, 1, 0)), 1);
        assert_eq!(file_index(dims, UVec3::new(0, 0, 1)), 3);
        assert_eq!(file_index(dims, UVec3::new(1, 0, 0)), 12);
        for i in 0..24 {
            assert_eq!(file_index(dims, voxel_of(dims, i)), i);
        }
    }
}
