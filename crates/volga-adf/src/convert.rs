//! Conversions: an ADF to a narrow-band sparse volume.

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use volga_core::{brick_index_box, Aabb, Brick, ChannelKind, Grid, SparseVolume, BRICK_DIM, BRICK_VOXELS};

use crate::Adf;

impl Adf {
    /// The narrow-band signed distance volume of `grid`: each voxel holds the
    /// reconstruction at its centre clamped to `±half_width` (world units), the
    /// background is `+half_width`, and bricks wholly beyond the band are not sampled
    /// (their range, from the tree, proves it): outside ones are left out, inside ones are
    /// one uniform `−half_width` value. Bricks are computed in parallel and inserted in
    /// sorted order, so the volume is identical for any thread count.
    pub fn to_narrow_band(&self, grid: Grid, half_width: f64) -> SparseVolume {
        let w = half_width.abs();
        let extent = volga_core::brick_extent(grid.dims());
        let bricks: Vec<IVec3> = (0..extent.z)
            .flat_map(|z| (0..extent.y).flat_map(move |y| (0..extent.x).map(move |x| IVec3::new(x, y, z))))
            .collect();
        let filled: Vec<(IVec3, Brick<f32>)> = bricks
            .par_iter()
            .filter_map(|&b| {
                let ib = brick_index_box(b);
                let lo = grid.transform.index_to_world(ib.min.as_dvec3());
                let hi = grid.transform.index_to_world((ib.max - IVec3::ONE).as_dvec3());
                let (r0, r1) = self.range(&Aabb::new(lo.min(hi), lo.max(hi)));
                if r0 >= w {
                    return None;
                }
                if r1 <= -w {
                    return Some((b, Brick::Uniform(-w as f32)));
                }
                let mut voxels = [w as f32; BRICK_VOXELS];
                for (k, v) in voxels.iter_mut().enumerate() {
                    let k = k as i32;
                    let ijk =
                        ib.min + IVec3::new(k % BRICK_DIM, (k / BRICK_DIM) % BRICK_DIM, k / (BRICK_DIM * BRICK_DIM));
                    if grid.contains(ijk) {
                        let p: DVec3 = grid.transform.index_to_world(ijk.as_dvec3());
                        *v = self.distance(p).clamp(-w, w) as f32;
                    }
                }
                let brick = Brick::from_voxels(&voxels).collapsed();
                (!matches!(brick, Brick::Uniform(v) if v == w as f32)).then_some((b, brick))
            })
            .collect();
        let mut volume = SparseVolume::new(grid, w as f32, false).with_density_kind(ChannelKind::SignedDistance);
        for (b, brick) in filled {
            volume.density.insert_brick(b, brick);
        }
        volume
    }
}

impl Adf {
    /// The zero iso-surface as a triangle mesh, through the shared extractor
    /// (`volga_mesh::extract_surface`: marching cubes on a lattice of spacing `cell`
    /// over the root cube, vertices refined onto the reconstruction, normals from its
    /// gradient; blocks whose range excludes 0 are skipped by the tree's ranges).
    pub fn to_mesh(&self, cell: f64) -> Result<volga_mesh::Surface, volga_mesh::ExtractError> {
        volga_mesh::extract_surface(self, self.root_box(), cell, 0.0)
    }

    /// The zero iso-surface over `region` by any extraction job (`job.region` and
    /// `job.iso` as given: pass 0 for the surface), stopping past `max_triangles`.
    pub fn to_mesh_with(
        &self,
        job: &volga_mesh::Extraction,
        max_triangles: u64,
    ) -> Result<volga_mesh::Surface, volga_mesh::ExtractError> {
        volga_mesh::extract_surface_bounded(self, job, max_triangles)
    }
}
