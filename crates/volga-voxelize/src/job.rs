//! The mesh-voxelize job: one mesh to one sparse volume, with the grid layout, the
//! band (filter half-width) and the memory estimate computed in one place, for the
//! command line (`volga voxelize`, `volga bench voxelize`) and for scenes.
//!
//! A job is checked in three steps, each before the expensive step it guards:
//! 1. [`MeshJob::check`] — the parameters; [`parse_bytes_bound`] — an upper bound on
//!    what reading a mesh file of a given size can allocate (before parsing);
//! 2. [`MeshJob::layout`] — the grid from the mesh's bounds;
//!    [`MeshJob::estimate`] — an upper bound on the peak memory of voxelizing and
//!    writing, from the real triangle count and a count of the bricks the band can
//!    reach (before voxelizing);
//! 3. [`MeshJob::run`] — the voxelization.
//!
//! The estimate is a measured upper bound (docs/VOXELIZE.md lists it against peaks
//! measured on five meshes): its constants come from those measurements with a margin,
//! and the brick count it rests on is an upper bound on the bricks any mode stores.

use std::fmt;

use glam::{DVec3, IVec3, UVec3};
use volga_core::{Aabb, Grid, IndexBox, Progress, SparseVolume, Transform, BRICK_DIM};
use volga_mesh::TriMesh;

use crate::profile::VoxelizeProfile;
use crate::{merge_max, voxelize_mesh_surface, MeshVoxelizer, Separability, SignStats, SurfaceMode};

/// What a mesh is voxelized into.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MeshJobMode {
    /// Binary surface with `separability`; with `solid`, the inside (winding number ≥ ½)
    /// filled as well.
    Binary {
        /// Which white paths the surface blocks.
        separability: Separability,
        /// Fill the inside too.
        solid: bool,
    },
    /// Anti-aliased (oriented box filter) surface of `thickness_voxels`, or solid.
    AntiAliased {
        /// Shell thickness in voxels (finite and > 0); with `solid` it only sets the
        /// grid's padding.
        thickness_voxels: f64,
        /// The anti-aliased solid instead of a shell.
        solid: bool,
    },
    /// Narrow-band distance field of `half_width_voxels`; `signed` (inside negative) or
    /// unsigned.
    Distance {
        /// Half-width of the band in voxels.
        half_width_voxels: f64,
        /// Negative inside (winding number ≥ ½).
        signed: bool,
    },
}

/// A mesh-voxelize job: the voxels along the longest side of the mesh's bounding box,
/// and the mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshJob {
    /// Voxels along the longest side of the mesh's bounding box.
    pub resolution: u32,
    /// What the mesh is voxelized into.
    pub mode: MeshJobMode,
}

/// Why a job cannot run; `field` names the parameter at fault (`resolution`,
/// `thickness`, `distance`, `mesh`).
#[derive(Debug, Clone, PartialEq)]
pub struct JobError {
    /// The parameter at fault.
    pub field: &'static str,
    /// What is wrong with it, in words.
    pub message: String,
}

impl fmt::Display for JobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for JobError {}

/// The memory a job is estimated to need at its peak, by stage (bytes, each an upper
/// bound on the process's resident set during that stage).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct JobEstimate {
    /// Upper bound on the bricks within the band of a triangle.
    pub band_bricks: u64,
    /// Upper bound on the bricks of a filled inside, band bricks included (0 for the
    /// modes that fill none): the bricks between two band bricks along some axis.
    pub inside_bricks: u64,
    /// Bricks of the whole grid.
    pub grid_bricks: u64,
    /// The mesh in memory (positions and triangles).
    pub mesh_bytes: u64,
    /// Peak during the voxelization (mesh, voxelizer data, result).
    pub voxelize_bytes: u64,
    /// Peak during the write (mesh and result still held, streaming writers).
    pub write_bytes: u64,
    /// The job's peak: the larger of the two.
    pub peak_bytes: u64,
}

/// Fixed resident memory of the process (code, runtime, thread stacks): measured
/// 4–9 MiB; with a margin.
pub const BASE_BYTES: u64 = 24 << 20;

/// An upper bound on the resident memory of reading a mesh file of `file_bytes` bytes
/// (before parsing it), `extension` lower-case without the dot.
///
/// OBJ: the text is read whole, then parsed by `tobj` to `f64` positions and `u32`
/// indices, then copied into the mesh; the shortest statements (`v 0 0 0`, `f 1 2 3`:
/// 8 bytes a line) give the most data per byte of text. Measured on such a file
/// (80 MB, 5M vertices, 5M triangles): 748 MiB, 9.8 bytes per byte of text; the bound
/// is 12 bytes per byte (on typical OBJ files, 5–7 bytes per byte are used). glTF/GLB:
/// the file plus its data at `f64` and `u32` with growth slack, 10 bytes per byte. A
/// `.gltf` with external buffers also reads them: it is checked again after parsing
/// ([`MeshJob::estimate`]).
pub fn parse_bytes_bound(file_bytes: u64, extension: &str) -> u64 {
    let per_byte = match extension {
        "obj" => 12,
        _ => 10,
    };
    BASE_BYTES.saturating_add(file_bytes.saturating_mul(per_byte))
}

impl MeshJob {
    /// Whether the job needs the inside of the mesh (winding numbers).
    pub fn needs_inside(&self) -> bool {
        match self.mode {
            MeshJobMode::Binary { solid, .. } | MeshJobMode::AntiAliased { solid, .. } => solid,
            MeshJobMode::Distance { signed, .. } => signed,
        }
    }

    /// Whether the result is binary (0 or 1 in every voxel).
    pub fn is_binary(&self) -> bool {
        matches!(self.mode, MeshJobMode::Binary { .. })
    }

    /// Whether the job builds a [`MeshVoxelizer`] (distances, or an inside).
    fn uses_voxelizer(&self) -> bool {
        self.needs_inside() || !self.is_binary()
    }

    /// Checks the parameters: resolution ≥ 1, thickness finite and > 0, half-width in
    /// (0, 1000] voxels.
    pub fn check(&self) -> Result<(), JobError> {
        if self.resolution == 0 {
            return Err(JobError {
                field: "resolution",
                message: "--resolution must be ≥ 1".into(),
            });
        }
        match self.mode {
            MeshJobMode::AntiAliased { thickness_voxels, .. }
                if !(thickness_voxels.is_finite() && thickness_voxels > 0.0) =>
            {
                Err(JobError {
                    field: "thickness",
                    message: format!("--thickness must be finite and > 0, got {thickness_voxels}"),
                })
            }
            MeshJobMode::Distance {
                half_width_voxels: hw, ..
            } if !(hw.is_finite() && hw > 0.0 && hw <= 1000.0) => Err(JobError {
                field: "distance",
                message: format!("--distance must lie in (0, 1000] voxels, got {hw}"),
            }),
            _ => Ok(()),
        }
    }

    /// Voxels a result reaches beyond the surface: the half-width of a distance field,
    /// half the thickness plus the filter's half-width `√3` for anti-aliased surfaces,
    /// one voxel for binary ones.
    pub fn band_voxels(&self) -> f64 {
        match self.mode {
            MeshJobMode::Distance { half_width_voxels, .. } => half_width_voxels,
            MeshJobMode::AntiAliased { thickness_voxels, .. } => 0.5 * thickness_voxels + 3f64.sqrt(),
            MeshJobMode::Binary { .. } => 1.0,
        }
    }

    /// The grid for a mesh with `bounds`: `resolution` voxels of side `h` along the
    /// longest side, padded by the band plus one voxel on every side (`ceil(band) + 1`),
    /// voxel centres at `bounds.min − pad·h + h/2 + ijk·h`.
    pub fn layout(&self, bounds: &Aabb) -> Result<Grid, JobError> {
        self.layout_with_spacing(bounds, bounds.size().max_element() / self.resolution as f64)
    }

    /// [`MeshJob::layout`] with the voxel side `h` given instead of the resolution (the
    /// same padding; `resolution` only names the grid in error messages).
    pub fn layout_with_spacing(&self, bounds: &Aabb, h: f64) -> Result<Grid, JobError> {
        if !(h.is_finite() && h > 0.0) {
            return Err(JobError {
                field: "mesh",
                message: "the mesh has no extent to voxelize".into(),
            });
        }
        let pad = self.band_voxels().ceil() + 1.0;
        let dims_f = (bounds.size() / h).ceil() + 2.0 * pad;
        let dims = UVec3::new(dims_f.x as u32, dims_f.y as u32, dims_f.z as u32).max(UVec3::ONE);
        let origin = bounds.min - DVec3::splat(pad * h) + DVec3::splat(0.5 * h);
        if dims_f.max_element() > (i32::MAX / 2) as f64 {
            return Err(JobError {
                field: "resolution",
                message: format!(
                    "--resolution {}: {:.0}×{:.0}×{:.0} voxels is more than a grid can hold",
                    self.resolution, dims_f.x, dims_f.y, dims_f.z
                ),
            });
        }
        Transform::new(origin, DVec3::splat(h))
            .and_then(|t| Grid::new(t, dims))
            .map_err(|e| JobError {
                field: "resolution",
                message: format!("--resolution {}: {e}", self.resolution),
            })
    }

    /// An upper bound on the job's peak resident memory, from the mesh and its grid
    /// (computed without allocating more than one bit per brick of the grid).
    ///
    /// The bricks are counted, not summed per triangle: every brick within the band of
    /// a triangle's bounding box is marked once in a bit set (for a triangle spanning
    /// more than a few bricks, only the bricks within the band of its plane), so bricks
    /// shared by neighbouring triangles count once.
    pub fn estimate(&self, mesh: &TriMesh, grid: &Grid) -> JobEstimate {
        self.estimate_in(mesh, grid, None)
    }

    /// An upper bound on the peak resident memory of [`MeshJob::run_region`] for
    /// `region` (index space): the estimate's bricks counted only where they meet the
    /// region, plus the region's copy on its own grid (no write stage: `write_bytes` is
    /// the voxelization's result held once more).
    pub fn estimate_region(&self, mesh: &TriMesh, grid: &Grid, region: &IndexBox) -> JobEstimate {
        self.estimate_in(mesh, grid, Some(region))
    }

    fn estimate_in(&self, mesh: &TriMesh, grid: &Grid, region: Option<&IndexBox>) -> JobEstimate {
        let band = self.band_voxels();
        let extent = volga_core::brick_extent(grid.dims());
        let grid_bricks = extent.as_u64vec3().element_product();
        let fills_inside = self.needs_inside() && !matches!(self.mode, MeshJobMode::Distance { signed: false, .. });
        let region_bricks = match region {
            None => IndexBox::new(IVec3::ZERO, extent),
            Some(r) => IndexBox::new(
                r.min.div_euclid(IVec3::splat(BRICK_DIM)),
                (r.max + BRICK_DIM - 1).div_euclid(IVec3::splat(BRICK_DIM)),
            )
            .intersection(&IndexBox::new(IVec3::ZERO, extent)),
        };
        let (band_bricks, inside_bricks) = count_bricks(mesh, grid, band, fills_inside, &region_bricks);
        let t = mesh.triangles.len() as u64;
        let v = mesh.positions.len() as u64;
        // Vectors grown by doubling hold up to twice their length.
        let mesh_bytes = 2 * (24 * v + 12 * t);
        let marks = mark_bytes(volga_core::brick_extent(grid.dims()).as_u64vec3(), fills_inside);
        // A dense brick is 2 KiB of f32 plus its map entry; a uniform brick (inside a
        // solid) is a map entry.
        const DENSE: u64 = 2048 + 128;
        const UNIFORM: u64 = 96;
        let (result, working) = match self.mode {
            // Index positions, buckets and chunk masks; the result's bricks as masks
            // before they become f32.
            MeshJobMode::Binary { solid: false, .. } => (band_bricks * DENSE, 24 * v + 16 * t + band_bricks * 160),
            // The surface, then the voxelizer's inside (dense band, uniform inside)
            // merged into it: every brick of the result is dense.
            MeshJobMode::Binary { solid: true, .. } => (
                inside_bricks * DENSE,
                24 * v
                    + 16 * t
                    + band_bricks * (160 + DENSE)
                    + inside_bricks * UNIFORM
                    + VOXELIZER_BYTES_PER_TRIANGLE * t,
            ),
            _ => (
                band_bricks * DENSE + inside_bricks * UNIFORM,
                VOXELIZER_BYTES_PER_TRIANGLE * t + band_bricks * 64,
            ),
        };
        let voxelize_bytes = BASE_BYTES + mesh_bytes + marks + result + working;
        let write_bytes = match region {
            None => BASE_BYTES + mesh_bytes + result + band_bricks.max(inside_bricks) * 16 + write_slab_bytes(grid),
            // The region moved onto its own grid: a second copy of the result at most.
            Some(_) => voxelize_bytes + result,
        };
        JobEstimate {
            band_bricks,
            inside_bricks,
            grid_bricks,
            mesh_bytes,
            voxelize_bytes,
            write_bytes,
            peak_bytes: voxelize_bytes.max(write_bytes),
        }
    }

    /// The mode's description in reports, e.g. `binary 26-separating surface`.
    pub fn mode_name(&self) -> String {
        match self.mode {
            MeshJobMode::Binary { separability, solid } => format!(
                "binary {}-separating {}",
                separability.number(),
                if solid { "solid" } else { "surface" }
            ),
            MeshJobMode::Distance {
                half_width_voxels,
                signed,
            } => format!(
                "{} distance, half-width {half_width_voxels} voxels",
                if signed { "signed" } else { "unsigned" }
            ),
            MeshJobMode::AntiAliased { solid: true, .. } => "anti-aliased solid".to_string(),
            MeshJobMode::AntiAliased {
                thickness_voxels,
                solid: false,
            } => format!("anti-aliased surface, thickness {thickness_voxels} voxels"),
        }
    }

    /// The voxelization: the volume, the mesh's boundary-edge count when the job needed
    /// its topology (a [`MeshVoxelizer`] counts it while it is built), and how the signs
    /// were proven when the job used them.
    pub fn run(&self, mesh: &TriMesh, grid: &Grid, progress: &dyn Progress) -> MeshRun {
        let voxelizer = self.uses_voxelizer().then(|| MeshVoxelizer::new(mesh));
        self.run_with(mesh, voxelizer.as_ref(), grid, None, progress, None)
    }

    /// [`MeshJob::run`], and where its time went: the mesh's preparation
    /// ([`MeshVoxelizer::prepare_profile`]) and the voxelization's stages (see
    /// [`VoxelizeProfile`]). The volume is the same; timing costs a few clock reads per
    /// brick.
    pub fn run_profiled(&self, mesh: &TriMesh, grid: &Grid, progress: &dyn Progress) -> (MeshRun, VoxelizeProfile) {
        let mut profile = VoxelizeProfile::default();
        let voxelizer = self.uses_voxelizer().then(|| MeshVoxelizer::new(mesh));
        if let Some(v) = &voxelizer {
            profile.extend(v.prepare_profile());
        }
        let run = self.run_with(mesh, voxelizer.as_ref(), grid, None, progress, Some(&mut profile));
        (run, profile)
    }

    /// The voxels of `region` (index space, `0 ≤ min < max ≤ dims`) of [`MeshJob::run`]
    /// on `grid`, bit for bit, as a volume on [`Grid::window`]`(region)`, without
    /// voxelizing the rest of the grid (see [`MeshVoxelizer::voxelize_region`]). With
    /// `voxelizer`, the mesh's prepared voxelizer is reused (build it once with
    /// [`MeshJob::voxelizer`] to compute many regions of one mesh); without, one is built
    /// when the mode needs it.
    ///
    /// Errors with [`volga_core::CoreError::BadRegion`] for a region that is empty or
    /// not inside the grid.
    pub fn run_region(
        &self,
        mesh: &TriMesh,
        voxelizer: Option<&MeshVoxelizer>,
        grid: &Grid,
        region: &IndexBox,
        progress: &dyn Progress,
    ) -> Result<MeshRun, volga_core::CoreError> {
        grid.window(region)?;
        let built = match (voxelizer, self.uses_voxelizer()) {
            (None, true) => Some(MeshVoxelizer::new(mesh)),
            _ => None,
        };
        let voxelizer = voxelizer.filter(|_| self.uses_voxelizer()).or(built.as_ref());
        let bricks = IndexBox::new(
            region.min.div_euclid(IVec3::splat(BRICK_DIM)),
            (region.max + BRICK_DIM - 1).div_euclid(IVec3::splat(BRICK_DIM)),
        );
        let clip = IndexBox::new(bricks.min * BRICK_DIM, bricks.max * BRICK_DIM).intersection(&grid.index_box());
        let mut run = self.run_with(mesh, voxelizer, grid, Some(&clip), progress, None);
        run.volume = run.volume.window(region)?;
        Ok(run)
    }

    /// [`MeshJob::run`] with the mesh's prepared voxelizer given (from
    /// [`MeshJob::voxelizer`]); without, one is built when the mode needs it.
    pub fn run_with_voxelizer(
        &self,
        mesh: &TriMesh,
        voxelizer: Option<&MeshVoxelizer>,
        grid: &Grid,
        progress: &dyn Progress,
    ) -> MeshRun {
        let built = match (voxelizer, self.uses_voxelizer()) {
            (None, true) => Some(MeshVoxelizer::new(mesh)),
            _ => None,
        };
        let voxelizer = voxelizer.filter(|_| self.uses_voxelizer()).or(built.as_ref());
        self.run_with(mesh, voxelizer, grid, None, progress, None)
    }

    /// The mesh prepared for this job's mode, when the mode uses it (every mode but the
    /// binary surface): to share between [`MeshJob::run_region`] calls.
    pub fn voxelizer(&self, mesh: &TriMesh) -> Option<MeshVoxelizer> {
        self.uses_voxelizer().then(|| MeshVoxelizer::new(mesh))
    }

    /// [`MeshJob::run`] with the voxelizer given, on the bricks of `clip` (whole bricks
    /// clipped to the grid) or the whole grid.
    fn run_with(
        &self,
        mesh: &TriMesh,
        voxelizer: Option<&MeshVoxelizer>,
        grid: &Grid,
        clip: Option<&IndexBox>,
        progress: &dyn Progress,
        mut profile: Option<&mut VoxelizeProfile>,
    ) -> MeshRun {
        let whole = grid.index_box();
        let clip = clip.unwrap_or(&whole);
        let surface = |separability, profile: Option<&mut VoxelizeProfile>| {
            let start = std::time::Instant::now();
            let volume = if *clip == whole {
                voxelize_mesh_surface(grid, mesh, separability, progress)
            } else {
                crate::binary::voxelize_mesh_surface_in(grid, mesh, separability, clip, progress)
            };
            if let Some(p) = profile {
                let s = start.elapsed().as_secs_f64();
                p.push("binary_surface", s, s);
            }
            volume
        };
        let boundary_edges = voxelizer.as_ref().map(|v| v.boundary_edge_count());
        let mut sign = None;
        let mut signed = |voxelizer: &MeshVoxelizer, mode: SurfaceMode, profile: Option<&mut VoxelizeProfile>| {
            let (volume, stats) = voxelizer.voxelize_profiled(grid, mode, clip, progress, profile);
            if matches!(
                mode,
                SurfaceMode::Solid | SurfaceMode::Inside | SurfaceMode::Distance { signed: true, .. }
            ) {
                sign = Some(stats);
            }
            volume
        };
        let volume = match (self.mode, voxelizer) {
            (MeshJobMode::Binary { separability, .. }, None) => surface(separability, profile),
            (MeshJobMode::Binary { separability, .. }, Some(voxelizer)) => {
                let mut surface = surface(separability, profile.as_deref_mut());
                let inside = signed(voxelizer, SurfaceMode::Inside, profile);
                merge_max(&mut surface, &inside, [1.0; 3]);
                surface
            }
            (
                MeshJobMode::Distance {
                    half_width_voxels,
                    signed: is_signed,
                },
                Some(voxelizer),
            ) => signed(
                voxelizer,
                SurfaceMode::Distance {
                    half_width_voxels,
                    signed: is_signed,
                },
                profile,
            ),
            (
                MeshJobMode::AntiAliased {
                    thickness_voxels,
                    solid,
                },
                Some(voxelizer),
            ) => {
                let thickness = thickness_voxels * grid.transform.spacing().x;
                let mode = if solid {
                    SurfaceMode::Solid
                } else {
                    SurfaceMode::Shell { thickness }
                };
                signed(voxelizer, mode, profile)
            }
            // `uses_voxelizer` holds for every non-binary mode.
            (_, None) => {
                MeshVoxelizer::new(mesh)
                    .voxelize_clipped(grid, SurfaceMode::Solid, clip, progress)
                    .0
            }
        };
        MeshRun {
            volume,
            boundary_edges,
            sign,
        }
    }
}

/// What [`MeshJob::run`] returns.
pub struct MeshRun {
    /// The voxelized mesh.
    pub volume: SparseVolume,
    /// Edges used by one triangle, when the job built the mesh's topology.
    pub boundary_edges: Option<usize>,
    /// How every sign was proven, for jobs that use the inside.
    pub sign: Option<SignStats>,
}

/// The distance voxelizer's data per triangle (BVH, normals, feature regions, Morton
/// order): measured ≈ 2.4 KB; with a margin.
const VOXELIZER_BYTES_PER_TRIANGLE: u64 = 3000;

/// Slab buffers of the streaming NRRD writer (three slabs of `f32`).
fn write_slab_bytes(grid: &Grid) -> u64 {
    let d = grid.dims().as_u64vec3();
    d.x * d.y * 4 * 3
}

/// Grids of more bricks than this are not marked in a bit set (128 MiB): the
/// bricks are then summed per triangle (an upper bound as well, looser).
const MAX_MARKED_BRICKS: u64 = 1 << 30;
/// Grids with more brick columns than this (along x, y and z together) do not bound
/// their inside by column spans (8 bytes per column: 128 MiB); the inside is then the
/// whole grid. A grid 1 brick thick and 16 384 wide has 2^28 columns along its thin axis.
const MAX_SPAN_COLUMNS: u64 = 1 << 24;

/// Brick columns along x, y and z of a grid of `e` bricks.
fn columns(e: glam::U64Vec3) -> u64 {
    e.y.saturating_mul(e.z)
        .saturating_add(e.x.saturating_mul(e.z))
        .saturating_add(e.x.saturating_mul(e.y))
}

/// Bytes [`count_bricks`] allocates for a grid of `e` bricks: the bit set, and with
/// `inside` the column spans.
fn mark_bytes(e: glam::U64Vec3, inside: bool) -> u64 {
    let total = e.element_product();
    if total > MAX_MARKED_BRICKS {
        return 0;
    }
    let spans = if inside && columns(e) <= MAX_SPAN_COLUMNS {
        8 * columns(e)
    } else {
        0
    };
    total.div_ceil(8) + spans
}

/// An upper bound on the bricks within `band` voxels of the triangles: each brick
/// counted once, through a bit per brick of the grid (on grids of at most
/// [`MAX_MARKED_BRICKS`] bricks; beyond, the per-triangle sum, capped at the grid).
///
/// With `inside`, also an upper bound on the bricks of a filled inside: a brick
/// lies between two band bricks along at least one axis (its column along x, y or z
/// holds band bricks on both sides of it, or it is one). A point inside a closed mesh
/// has surface on both sides along every axis; for an open mesh, inside is winding
/// number ≥ ½, and where a ray leaves through a hole the other axes still meet the
/// surface on both sides unless the hole is as large as the body (then use a closed
/// mesh). Beyond [`MAX_MARKED_BRICKS`] the inside is bounded by the grid.
///
/// Only bricks inside `within` (brick coordinates) are counted.
fn count_bricks(mesh: &TriMesh, grid: &Grid, band: f64, inside: bool, within: &IndexBox) -> (u64, u64) {
    let e = volga_core::brick_extent(grid.dims()).as_i64vec3();
    let total = within.volume();
    let t = &grid.transform;
    let brick = BRICK_DIM as f64;
    // Half the diagonal of a brick, in voxels.
    let brick_radius = 0.5 * brick * 3f64.sqrt();
    let all = (e.x * e.y * e.z) as u64;
    let mut marks = (all <= MAX_MARKED_BRICKS).then(|| vec![0u64; all.div_ceil(64) as usize]);
    let mut sum = 0u64;
    for tri in &mesh.triangles {
        let p = tri.map(|v| t.world_to_index(mesh.positions[v as usize]));
        if !p.iter().all(|q| q.is_finite()) {
            continue;
        }
        let lo = p[0].min(p[1]).min(p[2]) - DVec3::splat(band + 0.5);
        let hi = p[0].max(p[1]).max(p[2]) + DVec3::splat(band + 0.5);
        let to_brick = |x: DVec3| (x / brick).floor().clamp(DVec3::ZERO, (e - 1).as_dvec3()).as_ivec3();
        let (b0, b1) = (to_brick(lo), to_brick(hi));
        let span = (b1 - b0 + IVec3::ONE).as_i64vec3();
        let Some(marks) = marks.as_mut() else {
            sum = sum.saturating_add(IndexBox::new(b0, b1 + IVec3::ONE).intersection(within).volume());
            continue;
        };
        let normal = (p[1] - p[0]).cross(p[2] - p[0]);
        let length = normal.length();
        let plane = (span.x * span.y * span.z > 8 && length > 0.0 && length.is_finite()).then(|| normal / length);
        for z in b0.z..=b1.z {
            for y in b0.y..=b1.y {
                for x in b0.x..=b1.x {
                    if let Some(n) = plane {
                        // Voxel centres of brick b lie in [8b, 8b + 7]; its centre is 8b + 3.5.
                        let centre = DVec3::new(x as f64, y as f64, z as f64) * brick + DVec3::splat(0.5 * brick - 0.5);
                        if n.dot(centre - p[0]).abs() > brick_radius + band + 0.5 {
                            continue;
                        }
                    }
                    let i = (x as i64 + e.x * (y as i64 + e.y * z as i64)) as usize;
                    marks[i / 64] |= 1 << (i % 64);
                }
            }
        }
    }
    let Some(marks) = marks else {
        return (sum.min(total), if inside { total } else { 0 });
    };
    let (nx, ny, nz) = (e.x as usize, e.y as usize, e.z as usize);
    let marked = |x: usize, y: usize, z: usize| {
        let i = x + nx * (y + ny * z);
        marks[i / 64] >> (i % 64) & 1 == 1
    };
    let band_bricks = if within.volume() == all {
        marks.iter().map(|w| w.count_ones() as u64).sum()
    } else {
        within
            .iter()
            .filter(|b| marked(b.x as usize, b.y as usize, b.z as usize))
            .count() as u64
    };
    if !inside {
        return (band_bricks, 0);
    }
    if columns(e.as_u64vec3()) > MAX_SPAN_COLUMNS {
        return (band_bricks, total);
    }
    let within_box = *within;
    // Span (first, last marked) of every column along each axis; empty = (MAX, 0).
    let empty = (u32::MAX, 0u32);
    let mut span_x = vec![empty; ny * nz];
    let mut span_y = vec![empty; nx * nz];
    let mut span_z = vec![empty; nx * ny];
    let widen = |s: &mut (u32, u32), k: usize| {
        s.0 = s.0.min(k as u32);
        s.1 = s.1.max(k as u32);
    };
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if marked(x, y, z) {
                    widen(&mut span_x[y + ny * z], x);
                    widen(&mut span_y[x + nx * z], y);
                    widen(&mut span_z[x + nx * y], z);
                }
            }
        }
    }
    let within = |s: (u32, u32), k: usize| s.0 <= k as u32 && k as u32 <= s.1;
    let mut inside_bricks = 0u64;
    for b in within_box.iter() {
        let (x, y, z) = (b.x as usize, b.y as usize, b.z as usize);
        if within(span_x[y + ny * z], x) || within(span_y[x + nx * z], y) || within(span_z[x + nx * y], z) {
            inside_bricks += 1;
        }
    }
    (band_bricks, inside_bricks)
}

#[cfg(test)]
mod tests {
    use super::*;
    use volga_core::NoProgress;

    fn tetrahedron(scale: f64) -> TriMesh {
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z].map(|v| v * scale);
        TriMesh::new(p.to_vec(), vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]).unwrap()
    }

    /// A grid one brick thick and 16 384 bricks wide has 2^28 brick columns along its thin
    /// axis: bounding a solid's inside by column spans would take 2 GiB. The estimate
    /// falls back to the whole grid instead (found by fuzzing `volga plan`).
    #[test]
    fn thin_wide_grids_bound_the_inside_without_column_spans() {
        let mesh = tetrahedron(10.0);
        let transform = volga_core::Transform::new(DVec3::ZERO, DVec3::splat(1.0)).unwrap();
        let grid = Grid::new(transform, UVec3::new(8, 131_072, 131_072)).unwrap();
        let job = MeshJob {
            resolution: 131_072,
            mode: MeshJobMode::AntiAliased {
                thickness_voxels: 1.0,
                solid: true,
            },
        };
        let e = job.estimate(&mesh, &grid);
        assert_eq!(e.grid_bricks, 1 << 28);
        assert_eq!(e.inside_bricks, e.grid_bricks);
        assert!(e.band_bricks < 64, "{e:?}");
        assert_eq!(mark_bytes(glam::U64Vec3::new(1, 1 << 14, 1 << 14), true), (1 << 28) / 8);
        assert_eq!(
            mark_bytes(glam::U64Vec3::splat(64), true),
            64 * 64 * 64 / 8 + 8 * 3 * 64 * 64
        );
    }

    #[test]
    fn brick_bound_covers_every_stored_brick() {
        let mesh = tetrahedron(10.0);
        for mode in [
            MeshJobMode::Binary {
                separability: Separability::TwentySix,
                solid: false,
            },
            MeshJobMode::Binary {
                separability: Separability::Six,
                solid: false,
            },
            MeshJobMode::AntiAliased {
                thickness_voxels: 1.0,
                solid: false,
            },
            MeshJobMode::Distance {
                half_width_voxels: 3.0,
                signed: false,
            },
            MeshJobMode::Distance {
                half_width_voxels: 1.0,
                signed: true,
            },
            MeshJobMode::Binary {
                separability: Separability::TwentySix,
                solid: true,
            },
            MeshJobMode::AntiAliased {
                thickness_voxels: 1.0,
                solid: true,
            },
        ] {
            for resolution in [5, 40, 97] {
                let job = MeshJob { resolution, mode };
                let grid = job.layout(&mesh.bounds()).unwrap();
                let estimate = job.estimate(&mesh, &grid);
                let volume = job.run(&mesh, &grid, &NoProgress).volume;
                let stored = volume.density.brick_count() as u64;
                let bound = if job.needs_inside() {
                    estimate.inside_bricks
                } else {
                    estimate.band_bricks
                };
                assert!(stored <= bound, "{mode:?} at {resolution}: {stored} > {bound}");
            }
        }
    }

    #[test]
    fn parameters_are_checked() {
        let job = |mode| MeshJob { resolution: 8, mode };
        assert_eq!(
            job(MeshJobMode::AntiAliased {
                thickness_voxels: f64::NAN,
                solid: false
            })
            .check()
            .unwrap_err()
            .field,
            "thickness"
        );
        assert_eq!(
            job(MeshJobMode::Distance {
                half_width_voxels: 0.0,
                signed: true
            })
            .check()
            .unwrap_err()
            .field,
            "distance"
        );
        let flat = TriMesh::new(vec![DVec3::ZERO; 3], vec![[0, 1, 2]]).unwrap();
        let e = job(MeshJobMode::Distance {
            half_width_voxels: 1.0,
            signed: true,
        })
        .layout(&flat.bounds())
        .unwrap_err();
        assert_eq!(e.field, "mesh");
    }
}
