//! Holds voxelized signs against a brute-force generalized winding number: the check
//! behind the `sign_check` example and the sign tests (not used by the voxelizer). Test
//! scaffolding, compiled only with the cargo feature `testing`.

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use volga_core::{Grid, NoProgress, SparseVolume};
use volga_mesh::{winding_number, TriMesh};

use crate::{MeshVoxelizer, SignStats, SurfaceMode};

/// Wrong signs of one mode: voxels checked, wrong ones (|w − ½| > 1e-9), ties skipped,
/// the worst `|w − ½|` among the wrong ones, and how the signs were proven.
#[derive(Debug, Clone, Default)]
pub struct SignCheck {
    /// The mode checked: `signed distance`, `anti-aliased solid` or `binary inside`.
    pub mode: &'static str,
    /// Voxels compared with the brute-force winding number (ties included; a value
    /// that does not tell the side, an anti-aliased density of exactly ½, is skipped).
    pub checked: u64,
    /// Voxels on the wrong side of ½ by more than 1e-9.
    pub wrong: u64,
    /// Of those, voxels with `w` within 1e-9 of ½, where either side is right.
    pub ties: u64,
    /// The largest `|w − ½|` among the wrong voxels (0 when none).
    pub worst: f64,
    /// How the voxelizer proved the signs of this mode.
    pub stats: SignStats,
}

/// The three modes that use the sign: signed distance (band `half_width` voxels),
/// anti-aliased solid and binary inside, each checked at every voxel of the distance
/// band and at `random` more voxels of the whole grid (a fixed sequence from `seed`).
pub fn check_signs(mesh: &TriMesh, grid: &Grid, half_width: f64, random: usize, seed: u64) -> Vec<SignCheck> {
    let voxelizer = MeshVoxelizer::new(mesh);
    let progress = NoProgress;
    let distance_mode = SurfaceMode::Distance {
        half_width_voxels: half_width,
        signed: true,
    };
    let (distance, distance_stats) = voxelizer.voxelize_with_stats(grid, distance_mode, &progress);
    let band = (half_width * grid.max_spacing()) as f32;
    // The voxels to check: the band, then random ones.
    let mut voxels: Vec<IVec3> = Vec::new();
    for (ijk, v) in active_voxels(&distance) {
        if v.abs() < band {
            voxels.push(ijk);
        }
    }
    let dims = grid.dims().as_ivec3();
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    for _ in 0..random {
        let mut next = |n: i32| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % n as u64) as i32
        };
        voxels.push(IVec3::new(next(dims.x), next(dims.y), next(dims.z)));
    }
    let reference: Vec<f64> = voxels
        .par_iter()
        .map(|&ijk| winding_number(mesh, grid.transform.voxel_center(ijk)))
        .collect();
    let (solid, solid_stats) = voxelizer.voxelize_with_stats(grid, SurfaceMode::Solid, &progress);
    let (inside, inside_stats) = voxelizer.voxelize_with_stats(grid, SurfaceMode::Inside, &progress);
    type Run<'a> = (&'static str, &'a SparseVolume, SignStats, fn(f32) -> Option<bool>);
    let runs: [Run; 3] = [
        ("signed distance", &distance, distance_stats, |v| {
            Some(v.is_sign_negative())
        }),
        ("anti-aliased solid", &solid, solid_stats, |v| {
            (v != 0.5).then_some(v > 0.5)
        }),
        ("binary inside", &inside, inside_stats, |v| Some(v == 1.0)),
    ];
    runs.iter()
        .map(|&(mode, volume, stats, side)| {
            let mut check = SignCheck {
                mode,
                stats,
                ..SignCheck::default()
            };
            for (ijk, w) in voxels.iter().zip(&reference) {
                let Some(inside) = side(volume.density.get(*ijk)) else {
                    continue;
                };
                check.checked += 1;
                if (w - 0.5).abs() <= 1e-9 {
                    check.ties += 1;
                } else if inside != (*w >= 0.5) {
                    check.wrong += 1;
                    check.worst = check.worst.max((w - 0.5).abs());
                }
            }
            check
        })
        .collect()
}

/// Every stored voxel with its value.
fn active_voxels(volume: &SparseVolume) -> Vec<(IVec3, f32)> {
    let grid_box = volume.grid.index_box();
    let mut out = Vec::new();
    for ijk in grid_box.iter() {
        out.push((ijk, volume.density.get(ijk)));
    }
    out
}

/// A grid of `n` voxels along the mesh's longest side, padded by `pad` voxels, with
/// its origin moved by `shift` voxels (½ puts voxel centres on the planes a
/// `shift = 0` grid has faces on).
pub fn grid_for(mesh: &TriMesh, n: u32, pad: f64, shift: DVec3) -> Grid {
    let b = mesh.bounds();
    let h = b.size().max_element() / n as f64;
    let dims = ((b.size() / h).ceil() + 2.0 * pad).as_uvec3().max(glam::UVec3::ONE);
    let origin = b.min - DVec3::splat(pad * h) + (DVec3::splat(0.5) + shift) * h;
    Grid::new(volga_core::Transform::new(origin, DVec3::splat(h)).unwrap(), dims).unwrap()
}
