//! Leaf node: a triangle mesh (a file, loaded in the resolve stage, or triangles given
//! inline), as a solid: inside where its generalized winding number is ≥ ½.

use std::path::PathBuf;

use glam::{DAffine3, DQuat, DVec3};
use volga_core::memory::Bytes;
use volga_core::{Aabb, Field, Grid, IndexBox, Progress, Rgb, SparseVolume};
use volga_mesh::{Bvh, TriMesh};
use volga_shapes::OrientedBoxFilter;
use volga_voxelize::{parse_bytes_bound, MeshJob, MeshJobMode, MeshVoxelizer, SurfaceMode};

use super::{grid_filter, Clipped, Estimate, Node, Resolve};
use crate::ctx::Ctx;
use crate::model::ShapeSpec;
use crate::SceneError;

/// Where the triangles come from.
#[derive(Debug, Clone)]
enum Source {
    /// A file (relative to the scene's folder), placed by scale then translation;
    /// loaded by [`Node::resolve`].
    File {
        path: String,
        field: String,
        scale: f64,
        translate: DVec3,
    },
    Inline,
}

/// Leaf node: a triangle mesh (a file or inline triangles) as a solid, inside where its
/// generalized winding number is ≥ ½, with one colour. A file is loaded, scaled then
/// translated, in the resolve stage.
#[derive(Debug, Clone)]
pub struct MeshNode {
    name: String,
    colour: Rgb,
    source: Source,
    /// The placed mesh (world space); `None` until resolved.
    mesh: Option<TriMesh>,
}

impl MeshNode {
    /// Checks a `ShapeSpec::Mesh` or `ShapeSpec::Triangles` at field path `f`: a non-empty
    /// path, finite `translate`, `scale` > 0; or finite vertices and at least one triangle
    /// with indices in range. Reads no file.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] naming the field refused, e.g. `{f}.triangles`.
    pub fn validate(cx: &Ctx, f: &str, name: String, spec: &ShapeSpec, colour: Rgb) -> Result<Self, SceneError> {
        let (source, mesh) = match spec {
            ShapeSpec::Mesh { path, translate, scale } => {
                let translate = cx.finite3(&format!("{f}.translate"), *translate)?;
                let scale = cx.positive(&format!("{f}.scale"), *scale)?;
                if path.is_empty() {
                    return Err(cx.err(format!("{f}.path"), "must name a mesh file"));
                }
                let field = format!("{f}.path");
                let source = Source::File {
                    path: path.clone(),
                    field,
                    scale,
                    translate,
                };
                (source, None)
            }
            ShapeSpec::Triangles { vertices, triangles } => {
                let positions = vertices
                    .iter()
                    .enumerate()
                    .map(|(k, v)| cx.finite3(&format!("{f}.vertices[{k}]"), *v))
                    .collect::<Result<Vec<_>, _>>()?;
                if triangles.is_empty() {
                    return Err(cx.err(format!("{f}.triangles"), "needs at least one triangle"));
                }
                let mesh = TriMesh::new(positions, triangles.clone())
                    .map_err(|e| cx.err(format!("{f}.triangles"), e.to_string()))?;
                (Source::Inline, Some(mesh))
            }
            _ => return Err(cx.err(f, "not a mesh (dispatched by `nodes::leaf`)")),
        };
        Ok(MeshNode {
            name,
            colour,
            source,
            mesh,
        })
    }

    /// The placed mesh, once resolved.
    pub fn mesh(&self) -> Option<&TriMesh> {
        self.mesh.as_ref()
    }

    fn loaded(&self) -> Result<&TriMesh, SceneError> {
        self.mesh.as_ref().ok_or_else(|| SceneError::Invalid {
            path: PathBuf::new(),
            field: self.name.clone(),
            message: "the mesh was not loaded: call Scene::resolve before planning or building".into(),
        })
    }
}

impl Node for MeshNode {
    fn kind(&self) -> &'static str {
        "mesh"
    }
    fn name(&self) -> &str {
        &self.name
    }
    fn colour(&self) -> Rgb {
        self.colour
    }
    fn resolve(&mut self, cx: &Resolve) -> Result<(), SceneError> {
        if let Source::File {
            path,
            field,
            scale,
            translate,
        } = &self.source
        {
            let file = cx.file(field, path)?;
            check_parse_memory(cx, &file, field)?;
            let mesh = volga_mesh::load_mesh(&file).map_err(|e| SceneError::Invalid {
                path: cx.scene.to_owned(),
                field: field.clone(),
                message: e.to_string(),
            })?;
            let placement =
                DAffine3::from_scale_rotation_translation(DVec3::splat(*scale), DQuat::IDENTITY, *translate);
            self.mesh = Some(mesh.transformed(&placement));
        }
        Ok(())
    }
    /// Unknown before resolving: everything.
    fn bounds(&self) -> Aabb {
        self.mesh.as_ref().map_or(
            Aabb::new(DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY)),
            |m| m.bounds(),
        )
    }
    /// The mesh-voxelize job's measured bound (`MeshJob::estimate`, the one `volga
    /// voxelize` checks) for an anti-aliased solid on the scene's grid. The union merges
    /// the result voxel by voxel, so every brick of the band and the inside may be dense
    /// in the scene's volume until it is pruned: they count as bricks, the job's own
    /// peak (mesh, voxelizer data, its volume) as extra bytes.
    fn estimate(&self, grid: &Grid) -> Estimate {
        let Some(mesh) = &self.mesh else {
            return Estimate::default();
        };
        let job = MeshJob {
            resolution: grid.dims().max_element(),
            mode: MeshJobMode::AntiAliased {
                thickness_voxels: 1.0,
                solid: true,
            },
        };
        let e = job.estimate(mesh, grid);
        Estimate {
            bricks: e.inside_bricks.max(e.band_bricks),
            extra_bytes: e.voxelize_bytes,
        }
    }
    fn lazy_field(&self, grid: &Grid) -> Result<Box<dyn Field + '_>, SceneError> {
        let mesh = self.loaded()?;
        let filter = grid_filter(grid);
        let field = MeshDensity {
            bvh: Bvh::build(mesh),
            filter,
            bounds: mesh.bounds().expanded(DVec3::splat(filter.half_width())),
            step: grid.transform.spacing(),
        };
        Ok(Box::new(Clipped::new(field, grid.world_bounds()).tinted(self.colour)))
    }
    fn bake_in(
        &self,
        grid: &Grid,
        _colour: bool,
        clip: &IndexBox,
        progress: &dyn Progress,
    ) -> Result<SparseVolume, SceneError> {
        Ok(MeshVoxelizer::new(self.loaded()?)
            .voxelize_in(grid, SurfaceMode::Solid, clip, progress)
            .0)
    }
}

/// Refuses a mesh file whose parsing may need more than the memory limit, before
/// reading it (the bound grows with the file's size: `volga_voxelize::parse_bytes_bound`).
fn check_parse_memory(cx: &Resolve, file: &std::path::Path, field: &str) -> Result<(), SceneError> {
    let Ok(meta) = std::fs::metadata(file) else {
        return Ok(()); // the loader names the missing file
    };
    let ext = file
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let needed = parse_bytes_bound(meta.len(), &ext);
    if needed > cx.memory_limit {
        return Err(SceneError::TooLarge {
            path: cx.scene.to_owned(),
            needed: Bytes(needed as u128),
            limit: Bytes(cx.memory_limit as u128),
            detail: format!(
                "field `{field}`: parsing {} ({} bytes) may take that much",
                file.display(),
                meta.len()
            ),
        });
    }
    Ok(())
}

/// A mesh's filtered density evaluated per sample: exact distance to the nearest
/// triangle, inside where the winding number is ≥ ½.
#[derive(Debug)]
struct MeshDensity {
    bvh: Bvh,
    filter: OrientedBoxFilter,
    bounds: Aabb,
    step: DVec3,
}

impl Field for MeshDensity {
    fn bounds(&self) -> Aabb {
        self.bounds
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        self.filter.density(volga_mesh::signed_distance(&self.bvh, world_pos))
    }
    fn gradient_step(&self) -> DVec3 {
        self.step
    }
    /// The unsigned distance is 1-Lipschitz, but the winding number of an open mesh may
    /// cross ½ away from the surface, so only the band is bounded tightly: a box whose
    /// centre is farther than its half-diagonal plus the filter width from every
    /// triangle holds densities 0 or 1 only, which is as wide as (0, 1) for skipping.
    fn value_range(&self, _world_box: &Aabb) -> (f64, f64) {
        (0.0, 1.0)
    }
}
