//! Planning: decide before running what the scene calls for (channels, effects) and
//! what it will cost in memory, and refuse what does not fit (design rule: simulate only
//! the effects a scene calls for; check memory before allocating).

use serde::Serialize;
use volga_core::memory::{self, Bytes};
use volga_core::BRICK_VOXELS;

use crate::nodes::Node;
use crate::{RenderSource, Scene, SceneError};

/// One decision of the plan with the reason for it, as shown in `report.json`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Decision {
    /// What was decided, e.g. `voxelize`, `colour` or `{image}: shadow rays`.
    pub name: String,
    /// Whether it is on.
    pub enabled: bool,
    /// Why, in words.
    pub why: String,
}

impl Decision {
    fn new(name: impl Into<String>, enabled: bool, why: impl Into<String>) -> Self {
        Decision {
            name: name.into(),
            enabled,
            why: why.into(),
        }
    }
}

/// Upper bounds on the memory a build holds at once.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct MemoryEstimate {
    /// Bricks the voxelizer may allocate (bricks within the filter band of any solid).
    pub bricks_upper_bound: u64,
    /// Bytes of the baked volume's bricks (density, and colour when allocated) plus the
    /// nodes' own data (meshes' BVHs, loaded volumes).
    pub volume_bytes: u64,
    /// The largest image's buffers (float pixels, 8-bit copy, PNG).
    pub image_bytes: u64,
    /// One z-slab of every written volume (raw output is streamed slab by slab).
    pub output_slab_bytes: u64,
    /// Of `volume_bytes`, the nodes' own data: meshes' BVHs, loaded volumes, ADF builds
    /// (their estimated cells, `volga_adf::Adf::estimate`).
    pub nodes_bytes: u64,
    /// The sum of the above, checked against the memory limit.
    pub total_bytes: u64,
}

/// Upper bounds on the work and disk of the images, decided before anything runs.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WorkEstimate {
    /// Images written: one per image output, `frames` per turntable.
    pub image_files: u64,
    /// Rays cast by all images (pixels × supersampling² × frames).
    pub rays: u64,
    /// At most this many field samples: every ray crossing the grid's whole diagonal
    /// at its step, and from every sample a shadow ray per shadow-casting light crossing
    /// it at the shadow step (early ray termination and empty-space skipping only lower
    /// it). Saturates at `u64::MAX`.
    pub samples_upper_bound: u64,
    /// Bytes the PNG files may take at most (uncompressed pixels, filter bytes, headers).
    pub image_disk_bytes: u64,
}

/// Most field samples a build's images may take at most ([`WorkEstimate::samples_upper_bound`],
/// 2^44 ≈ 1.8·10^13, hours to days on a few cores): more is refused before any work.
pub const MAX_SAMPLES: u64 = 1 << 44;

/// What a build will do and what it will cost, decided before anything runs.
#[derive(Debug, Clone, Serialize)]
pub struct Plan {
    /// Whether the node tree is voxelized at all.
    pub voxelize: Decision,
    /// The volume channels: `density` (always) and `colour` (when an output reads it).
    pub channels: Vec<Decision>,
    /// Per image: gradients, shadow rays, early ray termination and empty-space skipping,
    /// as its mode asks under its settings.
    pub effects: Vec<Decision>,
    /// Where procedural work (noise) runs, per node; one disabled entry when nowhere.
    pub procedural: Vec<Decision>,
    /// Upper bounds on the memory the build holds.
    pub memory: MemoryEstimate,
    /// Upper bounds on the images' samples and disk.
    pub work: WorkEstimate,
    /// The limit `memory` was checked against, in bytes: the caller's, else the machine's
    /// available memory.
    pub memory_limit_bytes: u64,
    /// Whether the colour channel is allocated.
    #[serde(skip)]
    pub colour_channel: bool,
}

/// Bytes a hash-map entry costs beyond its payload (key, enum tag, box pointer, control).
const BRICK_OVERHEAD_BYTES: u64 = 48;

/// Plans a validated and resolved scene: which channels and effects each output calls for,
/// whether the tree is voxelized, and an upper bound on memory. `memory_limit` (bytes)
/// defaults to the machine's available memory.
///
/// # Errors
/// [`SceneError::TooLarge`] when the estimate exceeds the limit; nothing has been
/// allocated.
pub fn plan(scene: &Scene, memory_limit: Option<u64>) -> Result<Plan, SceneError> {
    let colour_readers: Vec<&str> = scene
        .images
        .iter()
        // Lazy images read colour from the nodes, not from a channel.
        .filter(|i| i.reads_colour && i.source == RenderSource::Baked)
        .map(|i| i.name.as_str())
        .chain(scene.volumes.iter().filter(|v| v.colour).map(|v| v.name.as_str()))
        .collect();
    let colour_channel = !colour_readers.is_empty();
    let channels = vec![
        Decision::new("density", true, "every image and volume output reads density"),
        if colour_channel {
            Decision::new("colour", true, format!("read by {}", colour_readers.join(", ")))
        } else {
            Decision::new("colour", false, "no image or volume output reads colour")
        },
    ];

    // Each image's mode declares what it needs under its settings.
    let mut effects = Vec::new();
    for im in &scene.images {
        let n = &im.name;
        let e = im.mode.integrator().effects(&im.settings);
        for (what, effect) in [
            ("gradients", e.gradients),
            ("shadow rays", e.shadows),
            ("early ray termination", e.early_ray_termination),
            ("empty-space skipping", e.empty_space_skipping),
        ] {
            effects.push(Decision::new(format!("{n}: {what}"), effect.enabled, effect.why));
        }
    }

    let bake = scene.needs_baked_volume();
    let lazy: Vec<&str> = scene
        .images
        .iter()
        .filter(|i| i.source == RenderSource::Lazy)
        .map(|i| i.name.as_str())
        .collect();
    let voxelize = if bake {
        Decision::new(
            "voxelize",
            true,
            "an image renders the baked volume, or a volume output writes it",
        )
    } else {
        Decision::new(
            "voxelize",
            false,
            format!(
                "no volume output, and every image samples the nodes lazily ({})",
                lazy.join(", ")
            ),
        )
    };
    let memory = estimate(scene, colour_channel, bake);
    let limit = memory_limit.or_else(memory::available_bytes).unwrap_or(u64::MAX);
    if memory.total_bytes > limit {
        let d = scene.grid.dims();
        return Err(SceneError::TooLarge {
            path: scene.source.clone(),
            needed: Bytes(memory.total_bytes as u128),
            limit: Bytes(limit as u128),
            detail: format!(
                "grid {}×{}×{} = {} voxels, up to {} bricks of 8³ voxels; the nodes' own data (meshes, ADF builds) {}",
                d.x,
                d.y,
                d.z,
                scene.grid.voxel_count(),
                memory.bricks_upper_bound,
                Bytes(u128::from(memory.nodes_bytes))
            ),
        });
    }
    let work = work_estimate(scene);
    if work.samples_upper_bound > MAX_SAMPLES {
        return Err(SceneError::TooMuchWork {
            path: scene.source.clone(),
            detail: format!(
                "its images may take up to {:.3e} field samples ({} rays over {} image files), more than the {:.3e} a build may take: lower the image sizes, supersampling, frames or shadow-casting lights, or raise the steps",
                work.samples_upper_bound as f64,
                work.rays,
                work.image_files,
                MAX_SAMPLES as f64
            ),
        });
    }
    let mut procedural: Vec<Decision> = crate::nodes::all_procedural_plans(&scene.root)
        .into_iter()
        .map(|(node, why)| Decision::new(format!("procedural: {node}"), true, why))
        .collect();
    if procedural.is_empty() {
        procedural.push(Decision::new(
            "procedural",
            false,
            "no texture or hypertexture node: noise is never evaluated",
        ));
    }
    Ok(Plan {
        voxelize,
        channels,
        effects,
        procedural,
        memory,
        work,
        memory_limit_bytes: limit,
        colour_channel,
    })
}

fn work_estimate(scene: &Scene) -> WorkEstimate {
    let diagonal_voxels = scene.grid.sampled_bounds().size().length() / scene.grid.transform.spacing().min_element();
    let mut w = WorkEstimate {
        image_files: 0,
        rays: 0,
        samples_upper_bound: 0,
        image_disk_bytes: 0,
    };
    for im in &scene.images {
        let s = &im.settings;
        let frames = im.turntable.as_ref().map_or(1, |t| t.frames as u64);
        let pixels = s.image.width as u64 * s.image.height as u64;
        let rays = pixels * (s.image.supersampling as u64).pow(2) * frames;
        let per_ray = (diagonal_voxels / s.sampling.step_voxels).ceil() + 1.0;
        let shadow =
            s.lighting.shadows.casters.len() as f64 * ((diagonal_voxels / s.lighting.shadows.step_voxels).ceil() + 1.0);
        let samples = rays as f64 * per_ray * (1.0 + shadow);
        w.image_files += frames;
        w.rays = w.rays.saturating_add(rays);
        w.samples_upper_bound = w.samples_upper_bound.saturating_add(if samples >= u64::MAX as f64 {
            u64::MAX
        } else {
            samples as u64
        });
        let bytes_per_pixel = if im.bit_depth == 16 { 8 } else { 4 };
        let png = pixels * bytes_per_pixel + s.image.height as u64 * 6 + 4096;
        w.image_disk_bytes = w.image_disk_bytes.saturating_add(png.saturating_mul(frames));
    }
    w
}

fn estimate(scene: &Scene, colour: bool, bake: bool) -> MemoryEstimate {
    let nodes = scene.root.estimate(&scene.grid);
    // Baking holds every node's bricks; lazy images hold only the nodes' own data
    // (meshes' BVHs), which baking needs too.
    let bricks = if bake { nodes.bricks } else { 0 };
    let per_brick = BRICK_VOXELS as u64 * (4 + if colour { 12 } else { 0 }) + BRICK_OVERHEAD_BYTES + 12; // the voxelizer's list of candidate brick coordinates
    let volume_bytes = bricks.saturating_mul(per_brick).saturating_add(nodes.extra_bytes);
    let image_bytes = scene
        .images
        .iter()
        // Per pixel: the tiles' float pixels and the assembled image (16 + 16 bytes,
        // both alive while tiles are copied), the 8-bit copy (4) and the PNG
        // encoder's filtered rows and output (≤ 4).
        .map(|i| i.settings.image.width as u64 * i.settings.image.height as u64 * (16 + 16 + 4 + 4))
        .max()
        .unwrap_or(0);
    let d = scene.grid.dims().as_u64vec3();
    let output_slab_bytes = if scene.volumes.is_empty() { 0 } else { d.x * d.y * 4 * 3 };
    MemoryEstimate {
        bricks_upper_bound: bricks,
        volume_bytes,
        image_bytes,
        output_slab_bytes,
        nodes_bytes: nodes.extra_bytes,
        total_bytes: volume_bytes
            .saturating_add(image_bytes)
            .saturating_add(output_slab_bytes),
    }
}

/// The scene's baked volume (the node tree voxelized on its grid: density, and colour
/// with `colour`) over `region` (voxel indices of the grid) only, as a volume on
/// [`Grid::window`](volga_core::Grid::window)`(region)`: **bit for bit** the same voxels
/// as the whole bake ([`Node::bake`]), without baking the rest of the grid. `scene` must
/// be resolved ([`Scene::resolve`]).
///
/// Memory is checked for the region before anything is allocated, against `memory_limit`
/// (default: the machine's available memory): at most every node's bricks within the
/// region (each node holds at most the region's bricks, and a union holds its children's
/// one after another), the region's copy, and the nodes' own data (meshes, ADF builds).
/// Errors: [`SceneError::TooLarge`] over the limit, [`SceneError::Invalid`] for a region
/// that is empty or not inside the grid, and whatever a node's bake reports.
pub fn bake_region(
    scene: &Scene,
    region: &volga_core::IndexBox,
    colour: bool,
    memory_limit: Option<u64>,
    progress: &dyn volga_core::Progress,
) -> Result<volga_core::SparseVolume, SceneError> {
    let bad_region = |e: volga_core::CoreError| SceneError::Invalid {
        path: scene.source.clone(),
        field: "region".into(),
        message: e.to_string(),
    };
    scene.grid.window(region).map_err(bad_region)?;
    let nodes = scene.root.estimate(&scene.grid);
    let region_bricks = volga_core::bricks_meeting(region).volume();
    let node_count = count_nodes(&scene.root);
    let bricks = nodes
        .bricks
        .min(region_bricks.saturating_mul(node_count))
        .saturating_add(region_bricks);
    let per_brick = BRICK_VOXELS as u64 * (4 + if colour { 12 } else { 0 }) + BRICK_OVERHEAD_BYTES + 12;
    let needed = bricks.saturating_mul(per_brick).saturating_add(nodes.extra_bytes);
    let limit = memory_limit.or_else(memory::available_bytes).unwrap_or(u64::MAX);
    if needed > limit {
        let s = region.max - region.min;
        return Err(SceneError::TooLarge {
            path: scene.source.clone(),
            needed: Bytes(needed as u128),
            limit: Bytes(limit as u128),
            detail: format!(
                "a region of {}×{}×{} voxels, up to {bricks} bricks of 8³ voxels; the nodes' own data (meshes, ADF builds) {}",
                s.x,
                s.y,
                s.z,
                Bytes(u128::from(nodes.extra_bytes))
            ),
        });
    }
    let volume = scene.root.bake_in(&scene.grid, colour, region, progress)?;
    volume.window(region).map_err(bad_region)
}

/// Nodes in the tree under `node`, itself included.
fn count_nodes(node: &dyn Node) -> u64 {
    1 + node.children().iter().map(|c| count_nodes(c.as_ref())).sum::<u64>()
}
