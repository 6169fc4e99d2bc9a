//! Exports: a sparse volume (for NRRD, `.binvox` and the renderer's sampled path, written by
//! `volga-io`) and a mesh of the ½ iso-surface (volga-mesh's shared extractor).

use glam::{DVec3, IVec3, UVec3};
use volga_core::{Brick as CoreBrick, Field, Grid, SparseVolume, Transform, BRICK_VOXELS};
use volga_mesh::{extract_surface_bounded, ExtractError, ExtractMethod, Extraction, Surface, VertexPlacement};

use crate::octree::{child_offset, node_size, BrickColour, Node};
use crate::Sculpt;

impl Sculpt {
    /// The voxels as a [`SparseVolume`] on the same grid (origin, spacing, `8·2^levels`
    /// voxels per axis): density channel, and colour when `with_colour`. Octree bricks map
    /// one to one onto the volume's 8³ bricks; uniform nodes become uniform bricks (empty
    /// ones are not stored).
    pub fn to_sparse_volume(&self, with_colour: bool) -> SparseVolume {
        let transform = Transform::new(self.grid.origin(), DVec3::splat(self.grid.spacing())).expect("validated grid");
        let grid = Grid::new(transform, UVec3::splat(self.grid.dims() as u32)).expect("validated grid");
        let mut out = SparseVolume::new(grid, 0.0, with_colour);
        fill(&self.root, IVec3::ZERO, self.grid.levels(), &mut out);
        out
    }

    /// The ½ iso-surface (the volume-sampled surface) as a closed, manifold mesh with
    /// outward normals, on a lattice of `cell_voxels` voxels (1 = the voxel grid), vertices
    /// refined onto the trilinear surface (to 1e-6 in density). Homogeneous nodes are
    /// skipped through `value_range`.
    pub fn surface(&self, cell_voxels: f64) -> Result<Surface, ExtractError> {
        self.surface_bounded(cell_voxels, u64::MAX)
    }

    /// [`surface`](Sculpt::surface) over the material only (the box of the voxels with
    /// density above 0, grown by two voxels; an empty sculpt has no surface), stopping with
    /// [`ExtractError::TooManyTriangles`] past `max_triangles`.
    pub fn surface_bounded(&self, cell_voxels: f64, max_triangles: u64) -> Result<Surface, ExtractError> {
        self.surface_with(cell_voxels, ExtractMethod::default(), 0.0, max_triangles)
    }

    /// [`surface_bounded`](Sculpt::surface_bounded) by a chosen extraction method, simplified
    /// within `adaptivity` cells (0 keeps every triangle; see `volga_mesh::extract::simplify`).
    pub fn surface_with(
        &self,
        cell_voxels: f64,
        method: ExtractMethod,
        adaptivity: f64,
        max_triangles: u64,
    ) -> Result<Surface, ExtractError> {
        let Some(content) = self.content_bounds() else {
            return Ok(Surface::default());
        };
        // The whole grid's lattice (from one voxel below the grid), cut to whole blocks of
        // 16 lattice cubes around the material, so the lattice points are the whole grid's.
        let h = self.grid.spacing();
        let cell = cell_voxels * h;
        let full = self.bounds();
        let pad = DVec3::splat(2.0 * h.max(cell));
        let block = 16.0 * cell;
        let k_lo = ((content.min - pad - full.min) / block).floor().max(DVec3::ZERO);
        let k_hi = ((content.max + pad - full.min) / block).ceil();
        let region = volga_core::Aabb::new(full.min + k_lo * block, (full.min + k_hi * block).min(full.max));
        extract_surface_bounded(
            self,
            &Extraction::new(region, cell_voxels * self.grid.spacing(), 0.5)
                .with_placement(VertexPlacement::Refined {
                    tolerance: 1e-6,
                    max_iterations: 16,
                })
                .with_method(method)
                .with_adaptivity(adaptivity),
            max_triangles,
        )
    }
}

fn fill(node: &Node, origin: IVec3, level: u32, out: &mut SparseVolume) {
    match node {
        Node::Uniform(v) => {
            if v.density == 0.0 && out.colour.is_none() {
                return;
            }
            let n = node_size(level) / 8;
            let b0 = origin / 8;
            for z in 0..n {
                for y in 0..n {
                    for x in 0..n {
                        let b = b0 + IVec3::new(x, y, z);
                        if v.density != 0.0 {
                            out.density.insert_brick(b, CoreBrick::Uniform(v.density));
                        }
                        if let Some(c) = out.colour.as_mut() {
                            if v.density != 0.0 {
                                c.insert_brick(b, CoreBrick::Uniform(v.colour));
                            }
                        }
                    }
                }
            }
        }
        Node::Brick(b) => {
            let brick = origin / 8;
            out.density.insert_brick(brick, CoreBrick::from_voxels(&b.density));
            if let Some(c) = out.colour.as_mut() {
                let colours: [[f32; 3]; BRICK_VOXELS] = match &b.colour {
                    BrickColour::Uniform(u) => [*u; BRICK_VOXELS],
                    BrickColour::PerVoxel(p) => **p,
                };
                c.insert_brick(brick, CoreBrick::from_voxels(&colours));
            }
        }
        Node::Branch(children) => {
            for (k, c) in children.iter().enumerate() {
                fill(c, origin + child_offset(k, level), level - 1, out);
            }
        }
    }
}
