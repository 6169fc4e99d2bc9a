//! Leaf node: a sampled volume read from a voxel model file (`.binvox` occupancy, a
//! `.nrrd` of densities, or a `.vdb` fog volume or level set;
//! `volga_io::read_voxel_model`), placed where the file says (binvox
//! `translate`/`scale`, NRRD origin and spacing, the VDB transform), sampled
//! trilinearly. Distance NRRDs are refused: a CVG operand is a density. A VDB level set
//! becomes the density `clamp(½ − d / 2h, 0, 1)` (`h` its smallest voxel size): ½ on
//! its zero set, rising inwards over two voxels.

use std::sync::Arc;

use serde::{Deserialize, Serialize};
use volga_core::{Aabb, Field, Filter, Grid, Sampled, SparseVolume};
use volga_io::{VoxelModel, VoxelValues};

use super::procedural::{Counted, Counters, NodeCounters};
use super::{bricks_within, Clipped, Estimate, Node, Resolve};
use crate::ctx::Ctx;
use crate::model::V3;
use crate::SceneError;

/// `Volume(path: "bunny.binvox", colour: ..)`; the path is relative to the scene file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeSpec {
    /// A label for the report; default `volumeN`, N counting the tree's leaf nodes
    /// (objects, `Fuzzy`, `Volume`, `Hypertexture`, `Adf`) in file order from 0.
    #[serde(default)]
    pub name: Option<String>,
    /// The `.binvox` (occupancy: 1 in filled voxels, 0 elsewhere), `.nrrd` (densities;
    /// NRRDs of distances are refused) or `.vdb` (its first float grid: a fog volume's
    /// densities, or a level set as the density ½ − d/2h) file, relative to the scene
    /// file's folder; read in the resolve stage and refused when it exceeds the memory
    /// limit.
    pub path: String,
    /// Linear RGB in \[0, 1\]; white when absent.
    #[serde(default)]
    pub colour: Option<V3>,
}

/// Leaf node: a voxel model read from a file in the resolve stage, placed where the file
/// says and sampled trilinearly.
#[derive(Debug)]
pub struct VolumeNode {
    name: String,
    path: String,
    field: String,
    colour: volga_core::Rgb,
    volume: Option<Arc<SparseVolume>>,
    counters: Counters,
}

impl VolumeNode {
    /// Checks a `Volume` spec at field path `f` (`root.Volume`): a non-empty path and the
    /// colour; `index` numbers its default name `volume{index}`. Reads no file.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming `{f}.path` or `{f}.colour`.
    pub fn validate(cx: &Ctx, f: &str, spec: &VolumeSpec, index: usize) -> Result<Self, SceneError> {
        if spec.path.is_empty() {
            return Err(cx.err(format!("{f}.path"), "must name a .binvox, .nrrd or .vdb file"));
        }
        Ok(VolumeNode {
            name: spec.name.clone().unwrap_or_else(|| format!("volume{index}")),
            path: spec.path.clone(),
            field: format!("{f}.path"),
            colour: cx.colour(&format!("{f}.colour"), spec.colour)?,
            volume: None,
            counters: Counters::default(),
        })
    }

    /// The volume, once resolved.
    pub fn volume(&self) -> Option<&SparseVolume> {
        self.volume.as_deref()
    }
}

/// Reads a voxel model as a density volume; `field` names the scene field in errors.
pub fn load_density(cx: &Resolve, path: &str, field: &str) -> Result<SparseVolume, SceneError> {
    let file = cx.file(field, path)?;
    let invalid = |message: String| SceneError::Invalid {
        path: cx.scene.to_owned(),
        field: field.to_string(),
        message,
    };
    if let Ok(meta) = std::fs::metadata(&file) {
        // A dense f32 copy of the file's voxels at most 4× its size for NRRD raw data;
        // binvox runs expand, bounded by the grid its header names (checked after).
        if meta.len().saturating_mul(8) > cx.memory_limit {
            return Err(invalid(format!(
                "{} is too large to load ({} bytes)",
                file.display(),
                meta.len()
            )));
        }
    }
    // Voxels bounded by the limit wherever they live (a NRRD's detached data included).
    let model = volga_io::read_voxel_model_within(&file, cx.memory_limit).map_err(|e| invalid(e.to_string()))?;
    match model {
        VoxelModel::Binvox(ref b) => {
            let dims = b.dims();
            let voxels = dims.x as u64 * dims.y as u64 * dims.z as u64;
            if voxels.saturating_mul(4) > cx.memory_limit {
                return Err(invalid(format!(
                    "{}: a {dims} grid exceeds the memory limit",
                    file.display()
                )));
            }
            let v = model.into_volume(&file).map_err(|e| invalid(e.to_string()))?;
            Ok(v.with_density_kind(volga_core::ChannelKind::Density))
        }
        VoxelModel::Nrrd { volume, values } => match values {
            VoxelValues::Distance { .. } => Err(invalid(format!(
                "{} holds distances, not densities in [0, 1]",
                file.display()
            ))),
            _ => Ok(SparseVolume::from_dense(&volume)),
        },
        VoxelModel::Vdb { grid, .. } if grid.class == volga_io::VdbClass::LevelSet => {
            Ok(density_of_level_set(&grid.volume))
        }
        VoxelModel::Vdb { grid, values } => match values {
            VoxelValues::Distance { min, max, background } => Err(invalid(format!(
                "{}: grid {:?} holds values {min} … {max} over background {background}, not densities in [0, 1] \
                 (a level set must say `class = level set`)",
                file.display(),
                grid.name
            ))),
            _ => Ok(grid.volume.with_density_kind(volga_core::ChannelKind::Density)),
        },
    }
}

/// The density of a level set: `clamp(½ − d / 2h, 0, 1)`, `h` the smallest voxel size,
/// so the ½ iso-surface is the zero set and trilinear sampling keeps it in place.
pub fn density_of_level_set(volume: &SparseVolume) -> SparseVolume {
    let h = volume.grid.transform.min_spacing();
    volume
        .map_density(|d| (0.5 - d as f64 / (2.0 * h)).clamp(0.0, 1.0) as f32)
        .with_density_kind(volga_core::ChannelKind::Density)
}

impl Node for VolumeNode {
    fn kind(&self) -> &'static str {
        "volume"
    }
    fn name(&self) -> &str {
        &self.name
    }
    fn colour(&self) -> volga_core::Rgb {
        self.colour
    }
    fn resolve(&mut self, cx: &Resolve) -> Result<(), SceneError> {
        self.volume = Some(Arc::new(load_density(cx, &self.path, &self.field)?));
        Ok(())
    }
    /// Unknown before resolving: everything.
    fn bounds(&self) -> Aabb {
        self.volume.as_ref().map_or(
            Aabb::new(glam::DVec3::splat(f64::NEG_INFINITY), glam::DVec3::splat(f64::INFINITY)),
            |v| v.grid.sampled_bounds(),
        )
    }
    fn estimate(&self, grid: &Grid) -> Estimate {
        Estimate {
            bricks: bricks_within(grid, &self.bounds()),
            extra_bytes: self.volume.as_ref().map_or(0, |v| v.memory_bytes()),
        }
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        let volume = self.volume.as_deref().ok_or_else(|| SceneError::Invalid {
            path: Default::default(),
            field: self.field.clone(),
            message: "the volume was not loaded (resolve stage)".into(),
        })?;
        let sampled = Sampled::new(volume, Filter::Trilinear);
        Ok(Box::new(Counted {
            field: Clipped::new(sampled, grid.world_bounds()).tinted(self.colour),
            samples: &self.counters.samples,
        }))
    }
    fn counters(&self) -> Vec<NodeCounters> {
        vec![NodeCounters {
            node: self.name.clone(),
            kind: self.kind().into(),
            samples: self.counters.samples.get(),
            noise_evaluations: 0,
        }]
    }
}
