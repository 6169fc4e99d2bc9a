//! NRRD writer: detached text header + raw little-endian data, streamed slab by slab.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use glam::IVec3;
use volga_core::{Brick, Grid, SparseGrid, SparseVolume, BRICK_DIM};

use crate::nrrd_header::{fmt_vector, BACKGROUND_KEY, MAGIC};
use crate::{IoError, StagedOutputs};

/// Writes `volume` as NRRD with a **detached** header, staged in `outputs` (nothing
/// appears on disk until `outputs` is committed):
///
/// * `{dir}/{stem}.nrrd`, the text header, and `{dir}/{stem}.raw`, the density:
///   `type: float`, `dimension: 3`, `sizes: X Y Z`, `space dimension: 3`,
///   `space directions: (sx,0,0) (0,sy,0) (0,0,sz)`, `space origin: (ox,oy,oz)` (the
///   world position of voxel 0's centre), `kinds: domain domain domain`,
///   `endian: little`, `encoding: raw`, `data file: {stem}.raw`. Numbers are written
///   in shortest round-trip form, so they parse back to the same `f64`. The density
///   background is recorded as the key/value pair `volga_background:=…` (other NRRD
///   readers ignore it).
/// * if the volume has a colour channel, `{stem}_colour.nrrd` + `{stem}_colour.raw`:
///   `dimension: 4`, `sizes: 3 X Y Z`, `kinds: RGB-color domain domain domain`,
///   `space directions: none (sx,0,0) (0,sy,0) (0,0,sz)`, components interleaved.
///
/// Only voxels inside the grid (`0 ≤ ijk < dims`) are written, little endian, x
/// fastest. The data are streamed one z-slab at a time straight from the bricks:
/// memory stays at one slab however large the volume.
///
/// Returns the final paths staged, in staging order (header, data, then the colour
/// header and data). `stem` must be a plain file name without whitespace (a NRRD
/// `data file:` with spaces means a list of files).
pub fn write_nrrd(
    dir: &Path,
    stem: &str,
    volume: &SparseVolume,
    outputs: &mut StagedOutputs,
) -> Result<Vec<PathBuf>, IoError> {
    let header_path = dir.join(format!("{stem}.nrrd"));
    if stem.is_empty()
        || stem == "."
        || stem == ".."
        || stem.contains(['/', '\\'])
        || stem.contains(char::is_whitespace)
    {
        return Err(IoError::format(
            &header_path,
            None,
            format!("NRRD stem `{stem}` must be a plain file name without whitespace"),
        ));
    }
    // All or nothing: a failure discards what this call staged, so a caller that
    // commits anyway never publishes a header without its data.
    let mark = outputs.len();
    let staged = stage_nrrd(dir, stem, volume, outputs);
    if staged.is_err() {
        outputs.truncate(mark);
    }
    staged
}

fn stage_nrrd(
    dir: &Path,
    stem: &str,
    volume: &SparseVolume,
    outputs: &mut StagedOutputs,
) -> Result<Vec<PathBuf>, IoError> {
    let grid = volume.grid;
    let mut paths = Vec::new();
    let header_path = dir.join(format!("{stem}.nrrd"));

    let raw_name = format!("{stem}.raw");
    let raw_path = dir.join(&raw_name);
    let background = volume.density.background();
    let header = header_text(&grid, false, &raw_name, &[(BACKGROUND_KEY, format!("{background:?}"))]);
    outputs.stage(&header_path, |w| w.write_all(header.as_bytes()))?;
    paths.push(header_path);
    outputs.stage(&raw_path, |w| {
        write_slabs(w, &volume.density, &grid, |v: f32, out: &mut Vec<u8>| {
            out.extend_from_slice(&v.to_le_bytes())
        })
    })?;
    paths.push(raw_path);

    if let Some(colour) = &volume.colour {
        let header_path = dir.join(format!("{stem}_colour.nrrd"));
        let raw_name = format!("{stem}_colour.raw");
        let raw_path = dir.join(&raw_name);
        let header = header_text(&grid, true, &raw_name, &[]);
        outputs.stage(&header_path, |w| w.write_all(header.as_bytes()))?;
        paths.push(header_path);
        outputs.stage(&raw_path, |w| {
            write_slabs(w, colour, &grid, |c: [f32; 3], out: &mut Vec<u8>| {
                for v in c {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            })
        })?;
        paths.push(raw_path);
    }
    Ok(paths)
}

/// The detached header of the density (`colour == false`) or colour file.
fn header_text(grid: &Grid, colour: bool, data_file: &str, key_values: &[(&str, String)]) -> String {
    let dims = grid.dims();
    let spacing = grid.transform.spacing();
    let origin = grid.transform.origin();
    let axis = |k: usize| {
        let mut v = [0.0; 3];
        v[k] = spacing[k];
        fmt_vector(&v)
    };
    let directions = format!("{} {} {}", axis(0), axis(1), axis(2));
    let (dimension, sizes, kinds, directions) = if colour {
        (
            4,
            format!("3 {} {} {}", dims.x, dims.y, dims.z),
            "RGB-color domain domain domain",
            format!("none {directions}"),
        )
    } else {
        (
            3,
            format!("{} {} {}", dims.x, dims.y, dims.z),
            "domain domain domain",
            directions,
        )
    };
    let mut h = String::new();
    h.push_str(MAGIC);
    h.push('\n');
    h.push_str("# volga volume: voxel ijk is the sample at space origin + ijk * spacing\n");
    h.push_str("type: float\n");
    h.push_str(&format!("dimension: {dimension}\n"));
    h.push_str("space dimension: 3\n");
    h.push_str(&format!("sizes: {sizes}\n"));
    h.push_str(&format!("space directions: {directions}\n"));
    h.push_str(&format!("kinds: {kinds}\n"));
    h.push_str("endian: little\n");
    h.push_str("encoding: raw\n");
    h.push_str(&format!("space origin: {}\n", fmt_vector(&origin.to_array())));
    for (k, v) in key_values {
        h.push_str(&format!("{k}:={v}\n"));
    }
    h.push_str(&format!("data file: {data_file}\n"));
    h
}

/// Streams the in-grid voxels of `channel` z-slab by z-slab (x fastest), each voxel
/// encoded by `encode`.
fn write_slabs<T: Copy + PartialEq + Send + Sync>(
    w: &mut dyn Write,
    channel: &SparseGrid<T>,
    grid: &Grid,
    encode: impl Fn(T, &mut Vec<u8>),
) -> io::Result<()> {
    let dims = grid.dims().as_ivec3();
    let plane = dims.x as usize * dims.y as usize;
    let mut slab = vec![channel.background(); plane];
    let mut bytes = Vec::with_capacity(plane * std::mem::size_of::<T>());
    for z in 0..dims.z {
        fill_slab(channel, dims, z, &mut slab);
        bytes.clear();
        for &v in &slab {
            encode(v, &mut bytes);
        }
        w.write_all(&bytes)?;
    }
    Ok(())
}

/// Copies the voxels `(0..X, 0..Y, z)` of `channel` into `slab` (x fastest), brick by
/// brick rather than voxel by voxel.
fn fill_slab<T: Copy + PartialEq + Send + Sync>(channel: &SparseGrid<T>, dims: IVec3, z: i32, slab: &mut [T]) {
    let row = dims.x as usize;
    let bricks_x = (dims.x + BRICK_DIM - 1) / BRICK_DIM;
    let bricks_y = (dims.y + BRICK_DIM - 1) / BRICK_DIM;
    let bz = z.div_euclid(BRICK_DIM);
    for by in 0..bricks_y {
        let y0 = by * BRICK_DIM;
        let y1 = (y0 + BRICK_DIM).min(dims.y);
        for bx in 0..bricks_x {
            let x0 = bx * BRICK_DIM;
            let x1 = (x0 + BRICK_DIM).min(dims.x);
            let n = (x1 - x0) as usize;
            let brick = channel.brick(IVec3::new(bx, by, bz));
            for y in y0..y1 {
                let start = y as usize * row + x0 as usize;
                let dst = &mut slab[start..start + n];
                match brick {
                    None => dst.fill(channel.background()),
                    Some(Brick::Uniform(v)) => dst.fill(*v),
                    Some(Brick::Dense(d)) => {
                        let off = Brick::<T>::local_offset(IVec3::new(x0, y, z));
                        dst.copy_from_slice(&d[off..off + n]);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use volga_core::Transform;

    #[test]
    fn slab_matches_voxel_reads() {
        let grid = Grid::new(
            Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(),
            glam::UVec3::new(19, 10, 11),
        )
        .unwrap();
        let mut g = SparseGrid::new(-2.0f32);
        g.insert_brick(IVec3::new(1, 0, 1), Brick::Uniform(3.0));
        for (i, ijk) in grid.index_box().iter().enumerate() {
            if i % 5 == 0 && ijk.x < 8 {
                g.set(ijk, i as f32);
            }
        }
        // Bricks outside the grid must not leak in.
        g.set(IVec3::new(-1, 0, 0), 99.0);
        g.set(IVec3::new(19, 0, 0), 99.0);
        let dims = grid.dims().as_ivec3();
        let mut slab = vec![0.0; 19 * 10];
        for z in 0..dims.z {
            fill_slab(&g, dims, z, &mut slab);
            for y in 0..dims.y {
                for x in 0..dims.x {
                    assert_eq!(slab[(x + 19 * y) as usize], g.get(IVec3::new(x, y, z)));
                }
            }
        }
    }

    #[test]
    fn header_has_the_documented_fields() {
        let grid = Grid::new(
            Transform::new(DVec3::new(1e6, -3.0, 0.25), DVec3::new(0.5, 1.0, 2.0)).unwrap(),
            glam::UVec3::new(13, 9, 5),
        )
        .unwrap();
        let h = header_text(&grid, false, "v.raw", &[]);
        assert!(h.starts_with("NRRD0004\n"));
        for line in [
            "type: float",
            "dimension: 3",
            "space dimension: 3",
            "sizes: 13 9 5",
            "space directions: (0.5,0,0) (0,1.0,0) (0,0,2.0)",
            "space origin: (1000000.0,-3.0,0.25)",
            "kinds: domain domain domain",
            "endian: little",
            "encoding: raw",
            "data file: v.raw",
        ] {
            assert!(h.lines().any(|l| l == line), "missing `{line}` in\n{h}");
        }
        let h = header_text(&grid, true, "v_colour.raw", &[]);
        for line in [
            "dimension: 4",
            "sizes: 3 13 9 5",
            "kinds: RGB-color domain domain domain",
            "space directions: none (0.5,0,0) (0,1.0,0) (0,0,2.0)",
        ] {
            assert!(h.lines().any(|l| l == line), "missing `{line}` in\n{h}");
        }
    }
}
