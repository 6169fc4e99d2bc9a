//! NRRD reader: the raw-encoded, axis-aligned subset volga writes and most tools emit.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use glam::{DVec3, UVec3};
use volga_core::{Dense, DenseVolume, Grid, Rgb, Transform};

use crate::nrrd_header::{Center, Endian, HeaderParser, NrrdHeader, BACKGROUND_KEY};
use crate::IoError;

/// Longest header line accepted (bytes); a longer one means a binary file.
const MAX_LINE: u64 = 1 << 20;
/// Largest header accepted (bytes).
const MAX_HEADER: u64 = 16 << 20;
/// Bytes decoded per read of the data.
const CHUNK: usize = 1 << 20;

/// Reads a 3D scalar NRRD into a [`DenseVolume`] (density only).
///
/// * Data: detached (`data file:` relative to the header's directory, or absolute)
///   or attached after the header's blank line; `line skip` and `byte skip`
///   (including `-1`) are honoured.
/// * `type`: float, double, (u)char/int8, (u)short, (u)int — converted to `f32`.
/// * `encoding: raw` only (`unsupported encoding gzip` otherwise); `endian: little`
///   (big-endian multi-byte data is an error).
/// * Geometry: `space origin` and `space directions`, which must be axis-aligned with
///   positive spacing (`(sx,0,0) (0,sy,0) (0,0,sz)`); without them `spacings` (NaN
///   read as 1) and `axis mins` (cell-centred unless `centers` says node), else
///   origin 0 and spacing 1. The origin is voxel 0's centre.
/// * The density background is the `volga_background:=` key written by
///   [`write_nrrd`](crate::write_nrrd), else 0.
///
/// Header errors are [`IoError::Format`] naming the file and line; a data size that
/// differs from the header's (truncated or extra data) names both sizes.
pub fn read_nrrd(path: &Path) -> Result<DenseVolume, IoError> {
    read_nrrd_within(path, volga_core::memory::input_limit())
}

/// [`read_nrrd`] refusing, before allocating, a volume whose voxels (4 bytes each) need
/// more than `max_bytes`; the error names the header's sizes, the bytes needed and
/// the limit.
pub fn read_nrrd_within(path: &Path, max_bytes: u64) -> Result<DenseVolume, IoError> {
    let mut nrrd = Nrrd::open(path)?;
    let grid = nrrd.grid(false)?;
    nrrd.check_memory(grid.voxel_count().saturating_mul(4), max_bytes)?;
    let background = nrrd
        .header
        .key_value(BACKGROUND_KEY)
        .and_then(|v| v.trim().parse::<f32>().ok())
        .unwrap_or(0.0);
    nrrd.check_data_size()?;
    let mut volume =
        DenseVolume::new(grid, background, false).map_err(|e| nrrd.header_error("sizes", e.to_string()))?;
    nrrd.read_samples(volume.density.as_mut_slice())?;
    Ok(volume)
}

/// Reads a density NRRD ([`read_nrrd`]) and the colour NRRD written beside it by
/// [`write_nrrd`](crate::write_nrrd) (`dimension: 4`, `sizes: 3 X Y Z`, first axis
/// without a space direction) into one [`DenseVolume`] with a colour channel. The
/// two grids must be identical.
pub fn read_nrrd_with_colour(path: &Path, colour_path: &Path) -> Result<DenseVolume, IoError> {
    let max_bytes = volga_core::memory::input_limit();
    let mut volume = read_nrrd_within(path, max_bytes)?;
    let mut nrrd = Nrrd::open(colour_path)?;
    let grid = nrrd.grid(true)?;
    nrrd.check_memory(grid.voxel_count().saturating_mul(16), max_bytes)?;
    if grid != volume.grid {
        return Err(IoError::format(
            colour_path,
            None,
            format!(
                "colour grid ({:?} voxels, {:?}) differs from the density grid of {} ({:?} voxels, {:?})",
                grid.dims().to_array(),
                grid.transform,
                path.display(),
                volume.grid.dims().to_array(),
                volume.grid.transform
            ),
        ));
    }
    nrrd.check_data_size()?;
    let shape = volume.density.shape();
    let mut colour: Dense<Rgb> = Dense::filled(shape, [0.0; 3], [0.0; 3]);
    nrrd.read_samples(colour.as_mut_slice().as_flattened_mut())?;
    volume.colour = Some(colour);
    Ok(volume)
}

/// An opened NRRD: parsed header and the file holding its data.
struct Nrrd {
    path: PathBuf,
    header: NrrdHeader,
    /// Line where the header ended (for errors about absent fields).
    end_line: usize,
    data_path: PathBuf,
    data: BufReader<File>,
    /// Offset of the first sample in `data` (after line/byte skips).
    data_start: u64,
    /// Bytes from `data_start` to the end of the data file.
    data_len: u64,
}

impl Nrrd {
    fn open(path: &Path) -> Result<Nrrd, IoError> {
        let (file, _) = volga_core::input::open_regular(path).map_err(|e| IoError::io(path, e))?;
        let mut reader = BufReader::new(file);
        let mut parser = HeaderParser::new();
        let mut line_no = 0;
        let mut header_bytes = 0u64;
        let mut buf = Vec::new();
        loop {
            buf.clear();
            let n = (&mut reader)
                .take(MAX_LINE + 1)
                .read_until(b'\n', &mut buf)
                .map_err(|e| IoError::io(path, e))?;
            if n == 0 {
                break;
            }
            line_no += 1;
            header_bytes += n as u64;
            let text = match buf.strip_suffix(b"\n") {
                Some(t) => t,
                None if n as u64 > MAX_LINE => {
                    return Err(IoError::format(
                        path,
                        Some(line_no),
                        "header line longer than 1 MiB (not a NRRD header?)",
                    ))
                }
                None => &buf[..],
            };
            if header_bytes > MAX_HEADER {
                return Err(IoError::format(
                    path,
                    Some(line_no),
                    "header longer than 16 MiB (missing blank line before the data?)",
                ));
            }
            let Ok(text) = std::str::from_utf8(text) else {
                let message = if line_no == 1 {
                    "not a NRRD file: the first line is not text"
                } else {
                    "header line is not text (missing blank line before the data?)"
                };
                return Err(IoError::format(path, Some(line_no), message));
            };
            let more = parser
                .line(line_no, text)
                .map_err(|e| IoError::format(path, e.line, e.message))?;
            if !more {
                break;
            }
        }
        let end_line = line_no.max(1);
        let header = parser
            .finish(end_line)
            .map_err(|e| IoError::format(path, e.line, e.message))?;

        let (data_path, mut data, start) = match &header.data_file {
            Some(name) => {
                let dir = path.parent().unwrap_or(Path::new(""));
                let data_path = volga_core::input::confine(dir, name).map_err(|why| {
                    IoError::format(
                        path,
                        header.line_of("data file"),
                        format!("data file `{name}` {why}; only files in the header's folder are read"),
                    )
                })?;
                let (file, _) = volga_core::input::open_regular(&data_path).map_err(|e| IoError::io(&data_path, e))?;
                (data_path, BufReader::new(file), 0)
            }
            None => (path.to_path_buf(), reader, header_bytes),
        };
        let io = |e| IoError::io(&data_path, e);
        let file_len = data.get_ref().metadata().map_err(io)?.len();
        data.seek(SeekFrom::Start(start)).map_err(io)?;
        let mut pos = start;
        for skipped in 0..header.line_skip {
            // Bounded by the file's length: a device such as /dev/zero never ends a line.
            let n = (&mut data)
                .take(file_len.saturating_sub(pos))
                .skip_until(b'\n')
                .map_err(io)?;
            if n == 0 {
                return Err(IoError::format(
                    path,
                    header.line_of("line skip"),
                    format!(
                        "line skip {} passes the end of {} after {skipped} lines",
                        header.line_skip,
                        data_path.display()
                    ),
                ));
            }
            pos += n as u64;
        }
        let mut nrrd = Nrrd {
            path: path.to_path_buf(),
            header,
            end_line,
            data_path,
            data,
            data_start: pos,
            data_len: file_len.saturating_sub(pos),
        };
        let expected = nrrd.expected_bytes()?;
        match nrrd.header.byte_skip {
            -1 => {
                if nrrd.data_len >= expected {
                    nrrd.data_start = file_len - expected;
                    nrrd.data_len = expected;
                }
            }
            skip => {
                let skip = skip as u64;
                if skip > nrrd.data_len {
                    return Err(nrrd.header_error(
                        "byte skip",
                        format!(
                            "byte skip {skip} passes the end of {} ({} bytes left)",
                            nrrd.data_path.display(),
                            nrrd.data_len
                        ),
                    ));
                }
                nrrd.data_start += skip;
                nrrd.data_len -= skip;
            }
        }
        Ok(nrrd)
    }

    /// Refuses, before anything is allocated, voxels needing more than `max_bytes`.
    fn check_memory(&self, needed: u64, max_bytes: u64) -> Result<(), IoError> {
        if needed <= max_bytes {
            return Ok(());
        }
        use volga_core::memory::Bytes;
        Err(self.header_error(
            "sizes",
            format!(
                "sizes {} need {} ({needed} bytes) of voxels, more than the {} ({max_bytes} bytes) of memory this read may use (raise --memory-limit or free memory)",
                self.header.sizes.iter().map(|s| s.to_string()).collect::<Vec<_>>().join(" "),
                Bytes(needed as u128),
                Bytes(max_bytes as u128)
            ),
        ))
    }

    /// A header error at `field`'s line (or where the header ended).
    fn header_error(&self, field: &str, message: impl Into<String>) -> IoError {
        let line = self.header.line_of(field).unwrap_or(self.end_line);
        IoError::format(&self.path, Some(line), message)
    }

    /// Bytes the header's sizes and type call for.
    fn expected_bytes(&self) -> Result<u64, IoError> {
        let scalar = self.scalar();
        self.header
            .sample_count()
            .and_then(|n| n.checked_mul(scalar.size() as u64))
            .ok_or_else(|| self.header_error("sizes", "sizes multiply beyond 2^64 bytes"))
    }

    fn scalar(&self) -> crate::nrrd_header::ScalarType {
        self.header.scalar.expect("HeaderParser::finish requires `type`")
    }

    /// The grid of a scalar volume (`colour == false`: axes 0..3) or of a colour
    /// volume (`colour == true`: axis 0 holds 3 components, axes 1..4 are space).
    fn grid(&self, colour: bool) -> Result<Grid, IoError> {
        let h = &self.header;
        let want = if colour { 4 } else { 3 };
        if h.dimension != want {
            let what = if colour {
                "an RGB colour volume (dimension: 4, sizes: 3 X Y Z)"
            } else {
                "a 3D scalar volume (dimension: 3)"
            };
            return Err(self.header_error("dimension", format!("dimension is {}; expected {what}", h.dimension)));
        }
        let first = want - 3;
        if colour && h.sizes[0] != 3 {
            return Err(self.header_error(
                "sizes",
                format!("colour axis has {} components, expected 3", h.sizes[0]),
            ));
        }
        if h.space_directions.is_some() || h.space_origin.is_some() {
            if let Some(sd) = h.space_dimension.filter(|&sd| sd != 3) {
                let field = if h.line_of("space").is_some() {
                    "space"
                } else {
                    "space dimension"
                };
                return Err(self.header_error(
                    field,
                    format!("space dimension is {sd}; volga volumes live in 3D space"),
                ));
            }
        }

        let mut spacing = [1.0f64; 3];
        let mut origin = [0.0f64; 3];
        if let Some(dirs) = &h.space_directions {
            if colour && dirs[0].is_some() {
                return Err(self.header_error("space directions", "the colour axis must have space direction `none`"));
            }
            for k in 0..3 {
                match &dirs[first + k] {
                    Some(v)
                        if v.len() == 3 && v[k].is_finite() && v[k] > 0.0 && (0..3).all(|j| j == k || v[j] == 0.0) =>
                    {
                        spacing[k] = v[k]
                    }
                    v => {
                        let shown = match v {
                            Some(v) => crate::nrrd_header::fmt_vector(v),
                            None => "none".into(),
                        };
                        return Err(self.header_error(
                            "space directions",
                            format!(
                                "direction {shown} of axis {}: volga reads axis-aligned grids \
                                 with positive spacing, (sx,0,0) (0,sy,0) (0,0,sz)",
                                first + k
                            ),
                        ));
                    }
                }
            }
        } else if let Some(spacings) = &h.spacings {
            for k in 0..3 {
                let s = spacings[first + k];
                if s.is_nan() {
                    continue;
                }
                if !(s.is_finite() && s > 0.0) {
                    return Err(self.header_error(
                        "spacings",
                        format!("spacing {s} of axis {}: must be finite and > 0", first + k),
                    ));
                }
                spacing[k] = s;
            }
        }
        if let Some(o) = &h.space_origin {
            origin.copy_from_slice(&o[..3]);
        } else if let Some(mins) = &h.axis_mins {
            for k in 0..3 {
                let a = first + k;
                let min = mins[a];
                if min.is_finite() {
                    let node = h.centers.as_ref().is_some_and(|c| c[a] == Center::Node);
                    origin[k] = if node { min } else { min + spacing[k] / 2.0 };
                }
            }
        }
        let field = if h.space_origin.is_some() {
            "space origin"
        } else {
            "axis mins"
        };
        let transform = Transform::new(DVec3::from_array(origin), DVec3::from_array(spacing))
            .map_err(|e| self.header_error(field, e.to_string()))?;
        let size = |k: usize| {
            u32::try_from(h.sizes[first + k]).map_err(|_| self.header_error("sizes", "a size exceeds 2^32 voxels"))
        };
        let dims = UVec3::new(size(0)?, size(1)?, size(2)?);
        Grid::new(transform, dims).map_err(|e| self.header_error("sizes", e.to_string()))
    }

    /// Errors unless the data file holds exactly the bytes the header asks for, and
    /// unless the samples are little endian. Called before any large allocation.
    fn check_data_size(&self) -> Result<(), IoError> {
        let scalar = self.scalar();
        if scalar.size() > 1 {
            match self.header.endian {
                Some(Endian::Little) => {}
                Some(Endian::Big) => {
                    return Err(
                        self.header_error("endian", format!("big-endian {} data is not supported", scalar.name()))
                    )
                }
                None => {
                    return Err(self.header_error(
                        "type",
                        format!("missing field `endian` (required for type {})", scalar.name()),
                    ))
                }
            }
        }
        let expected = self.expected_bytes()?;
        if self.data_len != expected {
            let sizes: Vec<String> = self.header.sizes.iter().map(u64::to_string).collect();
            let what = if self.data_len < expected {
                "truncated data"
            } else {
                "more data than the header describes"
            };
            let source = if self.data_path == self.path {
                "attached data".to_string()
            } else {
                format!("data file {}", self.data_path.display())
            };
            return Err(IoError::format(
                &self.path,
                None,
                format!(
                    "{what}: {source} holds {} bytes, but sizes {} of type {} need {expected} bytes",
                    self.data_len,
                    sizes.join(" "),
                    scalar.name()
                ),
            ));
        }
        Ok(())
    }

    /// Decodes all samples into `out` (`out.len()` = sample count).
    fn read_samples(&mut self, out: &mut [f32]) -> Result<(), IoError> {
        let scalar = self.scalar();
        let size = scalar.size();
        let data_path = self.data_path.clone();
        let io = |e: io::Error| {
            if e.kind() == io::ErrorKind::UnexpectedEof {
                IoError::format(&data_path, None, "data ended early (file changed while reading?)")
            } else {
                IoError::io(&data_path, e)
            }
        };
        self.data.seek(SeekFrom::Start(self.data_start)).map_err(io)?;
        let per_chunk = CHUNK / size;
        let mut bytes = vec![0u8; per_chunk.min(out.len()) * size];
        for dst in out.chunks_mut(per_chunk) {
            let src = &mut bytes[..dst.len() * size];
            self.data.read_exact(src).map_err(io)?;
            scalar.decode_le(src, dst);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    fn write_attached(dir: &Path, name: &str, header: &str, data: &[u8]) -> PathBuf {
        let path = dir.join(name);
        let mut bytes = header.as_bytes().to_vec();
        bytes.extend_from_slice(data);
        fs::write(&path, bytes).unwrap();
        path
    }

    #[test]
    fn reads_attached_uchar_with_spacings() {
        let dir = tempfile::tempdir().unwrap();
        let header = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 1\nspacings: 0.5 2 NaN\n\
                      axis mins: 0 0 0\nencoding: raw\n\n";
        let path = write_attached(dir.path(), "a.nrrd", header, &[1, 2, 3, 250]);
        let v = read_nrrd(&path).unwrap();
        assert_eq!(v.density.as_slice(), &[1.0, 2.0, 3.0, 250.0]);
        assert_eq!(v.grid.transform.spacing(), DVec3::new(0.5, 2.0, 1.0));
        // Cell-centred axis mins: the first centre is half a spacing in.
        assert_eq!(v.grid.transform.origin(), DVec3::new(0.25, 1.0, 0.5));
    }

    #[test]
    fn reads_double_short_with_skips() {
        let dir = tempfile::tempdir().unwrap();
        let mut data = b"junk line\n".to_vec();
        data.extend_from_slice(&[9, 9]);
        for v in [1.5f64, -2.0] {
            data.extend_from_slice(&v.to_le_bytes());
        }
        fs::write(dir.path().join("d.bin"), &data).unwrap();
        let header = "NRRD0005\ntype: double\ndimension: 3\nsizes: 1 2 1\nendian: little\n\
                      encoding: raw\nline skip: 1\nbyte skip: 2\ndata file: d.bin\n";
        let path = write_attached(dir.path(), "d.nhdr", header, &[]);
        let v = read_nrrd(&path).unwrap();
        assert_eq!(v.density.as_slice(), &[1.5, -2.0]);

        let mut data = vec![7u8; 5];
        data.extend_from_slice(&(-300i16).to_le_bytes());
        fs::write(dir.path().join("s.bin"), &data).unwrap();
        let header = "NRRD0004\ntype: short\ndimension: 3\nsizes: 1 1 1\nendian: little\n\
                      encoding: raw\nbyte skip: -1\ndata file: s.bin\n";
        let path = write_attached(dir.path(), "s.nhdr", header, &[]);
        assert_eq!(read_nrrd(&path).unwrap().density.as_slice(), &[-300.0]);
    }

    #[test]
    fn rejects_what_it_cannot_represent() {
        let dir = tempfile::tempdir().unwrap();
        let base = "NRRD0004\ntype: float\ndimension: 3\nsizes: 1 1 1\nendian: little\n\
                    encoding: raw\nspace dimension: 3\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n";
        let data = 1.0f32.to_le_bytes();
        let cases = [
            ("(1,0,0) (0,1,0)", "(1,0,0) (1,1,0)", 8),
            ("(0,0,1)\n", "(0,0,-1)\n", 8),
            ("endian: little", "endian: big", 5),
            ("endian: little\n", "", 2),
            (
                "space dimension: 3\nspace directions: (1,0,0) (0,1,0) (0,0,1)",
                "space dimension: 2\nspace directions: (1,0) (0,1) (0,0)",
                7,
            ),
            ("dimension: 3", "dimension: 2", 4),
        ];
        for (from, to, line) in cases {
            let header = format!("{}\n", base.replace(from, to));
            let path = write_attached(dir.path(), "x.nrrd", &header, &data);
            match read_nrrd(&path) {
                Err(IoError::Format {
                    path: p,
                    line: l,
                    message,
                }) => {
                    assert_eq!(p, path);
                    assert_eq!(l, Some(line), "{to}: {message}");
                }
                other => panic!("{to}: {other:?}"),
            }
        }
        let path = write_attached(dir.path(), "ok.nrrd", &format!("{base}\n"), &data);
        assert_eq!(read_nrrd(&path).unwrap().density.as_slice(), &[1.0]);
    }
}
