//! Operator node: a sculpt. The operand is sampled into `volga-sculpt`'s octree on the scene
//! grid (same origin and voxel size, padded to `8·2^L` voxels) and edited by the strokes;
//! its lazy field is the sculpt itself, its baked volume the sculpt's voxels on the grid.
//! Strokes are checked in the resolve stage (mesh tools are files) and rebuilt for the
//! grid's voxel size when sampled (saws place a tool copy every half voxel).

use std::path::PathBuf;

use glam::{DVec3, IVec3};
use volga_core::{Aabb, Field, Grid, IndexBox, Progress, Rgb, SparseVolume};
use volga_sculpt::{Sculpt, SculptGrid, BRICK_BYTES_BOUND};

use super::{Clipped, Estimate, Node, Resolve};
use crate::strokes::{validate_stroke_list, StrokeSpec};
use crate::SceneError;

/// Operator node: its operand sampled into a sculpt on the scene grid and edited by strokes
/// (`NodeSpec::Sculpt`). Needs cubic voxels; strokes may add material anywhere in the grid.
#[derive(Debug)]
pub struct SculptNode {
    field: String,
    children: Vec<Box<dyn Node>>,
    strokes: Vec<StrokeSpec>,
    /// The scene file, known from the resolve stage (stroke errors name it; mesh tools
    /// are relative to its folder).
    scene: Option<PathBuf>,
    /// Whether mesh tools may be read from outside the scene's folder (from the resolve stage).
    allow_outside: bool,
}

impl SculptNode {
    /// `field` is the node's field path (`root.Sculpt`).
    pub fn new(field: &str, operand: Box<dyn Node>, strokes: Vec<StrokeSpec>) -> Self {
        SculptNode {
            field: field.to_owned(),
            children: vec![operand],
            strokes,
            scene: None,
            allow_outside: false,
        }
    }

    /// The operand sampled on `grid` and sculpted.
    fn sculpt(&self, grid: &Grid) -> Result<Sculpt, SceneError> {
        let scene = self.scene.clone().unwrap_or_default();
        let err = |message: String| SceneError::Invalid {
            path: scene.clone(),
            field: self.field.clone(),
            message,
        };
        let h = grid.transform.spacing();
        let sculpt_grid = sculpt_grid(grid).map_err(err)?;
        let operand = &self.children[0];
        let field = operand.lazy_field(grid)?;
        let mut sculpt = Sculpt::from_field(sculpt_grid, &*field, operand.colour());
        let strokes = validate_stroke_list(
            &scene,
            &format!("{}.strokes", self.field),
            &self.strokes,
            h.x,
            self.allow_outside,
        )?;
        for stroke in &strokes {
            sculpt.apply(stroke);
        }
        sculpt.clear_history();
        Ok(sculpt)
    }
}

/// The octree grid a sculpt node samples its operand on: the scene grid's origin and
/// (cubic) voxel size, enough levels to cover its voxels.
fn sculpt_grid(grid: &Grid) -> Result<SculptGrid, String> {
    let h = grid.transform.spacing();
    if h.x != h.y || h.y != h.z {
        return Err(format!("a sculpt needs cubic voxels, the grid's are {h:?}"));
    }
    let dims = grid.dims().max_element();
    let mut levels = 0;
    while (8u32 << levels) < dims {
        levels += 1;
    }
    SculptGrid::new(grid.transform.origin(), h.x, levels).map_err(|e| e.to_string())
}

impl Node for SculptNode {
    fn kind(&self) -> &'static str {
        "sculpt"
    }
    fn name(&self) -> &str {
        &self.field
    }
    fn children(&self) -> &[Box<dyn Node>] {
        &self.children
    }
    fn resolve(&mut self, cx: &Resolve) -> Result<(), SceneError> {
        self.children[0].resolve(cx)?;
        // Every stroke checked now (voxel size 1 for the saws' spacing; rebuilt when sampled).
        validate_stroke_list(
            cx.scene,
            &format!("{}.strokes", self.field),
            &self.strokes,
            1.0,
            cx.allow_outside,
        )?;
        self.scene = Some(cx.scene.to_owned());
        self.allow_outside = cx.allow_outside;
        Ok(())
    }
    /// Strokes may add material anywhere in the grid.
    fn bounds(&self) -> Aabb {
        Aabb::new(DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY))
    }
    fn colour(&self) -> Rgb {
        self.children[0].colour()
    }
    /// The operand's bricks twice (the octree and its baked copy), and the bricks every
    /// stroke may make dense ([`Sculpt::stroke_brick_bound`]) twice as well: in the octree
    /// (at [`BRICK_BYTES_BOUND`] bytes each) and in the baked volume.
    fn estimate(&self, grid: &Grid) -> Estimate {
        let e = self.children[0].estimate(grid);
        let mut total = e.plus(e);
        let Ok(sculpt_grid) = sculpt_grid(grid) else {
            return total;
        };
        let scene = self.scene.clone().unwrap_or_default();
        let field = format!("{}.strokes", self.field);
        let h = grid.transform.spacing().x;
        let Ok(strokes) = validate_stroke_list(&scene, &field, &self.strokes, h, self.allow_outside) else {
            return total;
        };
        let empty = Sculpt::empty(sculpt_grid, [0.0; 3]);
        let bricks: u128 = strokes.iter().map(|s| empty.stroke_brick_bound(s)).sum();
        let bricks = u64::try_from(bricks).unwrap_or(u64::MAX);
        total = total.plus(Estimate {
            bricks,
            extra_bytes: bricks.saturating_mul(BRICK_BYTES_BOUND),
        });
        total
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        let sculpt = self.sculpt(grid)?;
        Ok(Box::new(Clipped::new(sculpt, grid.world_bounds())))
    }
    fn bake_in(
        &self,
        grid: &Grid,
        colour: bool,
        clip: &IndexBox,
        _progress: &dyn Progress,
    ) -> Result<SparseVolume, SceneError> {
        let padded = self.sculpt(grid)?.to_sparse_volume(colour);
        // Same origin and voxel size: the bricks inside the scene grid carry over as they are.
        let mut out = SparseVolume::new(*grid, 0.0, colour);
        let wanted = volga_core::bricks_meeting(&clip.intersection(&grid.index_box()));
        let inside = |b: IVec3| wanted.contains(b);
        for b in padded.density.sorted_bricks().into_iter().filter(|b| inside(*b)) {
            if let Some(brick) = padded.density.brick(b) {
                out.density.insert_brick(b, brick.clone());
            }
        }
        if let (Some(dst), Some(src)) = (out.colour.as_mut(), padded.colour.as_ref()) {
            for b in src.sorted_bricks().into_iter().filter(|b| inside(*b)) {
                if let Some(brick) = src.brick(b) {
                    dst.insert_brick(b, brick.clone());
                }
            }
        }
        Ok(out)
    }
}
