//! Distance-driven voxelization of anything with a [`SignedDistance`]: analytic shapes
//! and quadrics now, meshes through the same trait. One band sampler serves four modes
//! ([`SurfaceMode`]); several inputs combine as a union (max density, min distance,
//! OR for binary).
//!
//! Only bricks within the mode's band of a surface are sampled voxel by voxel. For
//! inputs with exact distances a brick is classified from its centre with the
//! 1-Lipschitz bound; inexact ones (first-order quadric distance) are sampled over their
//! whole bounds. Bricks are processed in parallel and stored in sorted order: results do
//! not depend on the thread count.

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use volga_core::{Brick, ChannelKind, Grid, IndexBox, Progress, SparseVolume, BRICK_DIM, BRICK_VOXELS};

use crate::binary::{dominant_axis, Separability};
use crate::{OrientedBoxFilter, SignedDistance};

/// What each voxel of the band receives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SurfaceMode {
    /// Anti-aliased solid: oriented box filter of the signed distance (survey §17.4).
    Solid,
    /// Anti-aliased thin surface of `thickness` (world units): the filter applied to
    /// `|d| − thickness/2`.
    Shell {
        /// Thickness of the shell (world units).
        thickness: f64,
    },
    /// Narrow-band distance field in world units, clamped to ±`half_width_voxels` voxels
    /// (voxel = the largest spacing, [`volga_core::Transform::max_spacing`]); background
    /// `+half_width`, interior `−half_width` when signed.
    Distance {
        /// Half-width of the band in voxels of the largest spacing.
        half_width_voxels: f64,
        /// Negative inside.
        signed: bool,
    },
    /// Binary surface with the given separability: the plane thresholds of
    /// [`crate::binary`] applied to the surface's local tangent plane (distance and
    /// normal at the voxel, in index space), with the same half-open tie rule — a slab
    /// centred on the surface, minimal for planes. On a curved surface a minimal slab
    /// leaves gaps, so a repair pass adds every inside voxel (`d ≤ 0`) that has an
    /// outside `N`-neighbour (`d > 0`) when neither is in the slab. Then no white
    /// `N`-adjacent pair straddles the surface: the result is `N`-separating by
    /// construction, and equals the slab wherever the slab already separates.
    Binary(Separability),
    /// Binary solid: 1 where the signed distance is ≤ 0 (the closed solid; a voxel centre
    /// exactly on the surface is inside).
    Inside,
}

impl SurfaceMode {
    /// Background value of the result.
    pub fn background(&self, grid: &Grid) -> f32 {
        match *self {
            SurfaceMode::Distance { half_width_voxels, .. } => (half_width_voxels * grid.max_spacing()) as f32,
            _ => 0.0,
        }
    }

    /// What the result's scalar channel holds: densities for the anti-aliased modes,
    /// (signed or unsigned) distances for `Distance`, 0/1 for `Binary` and `Inside`.
    pub fn channel_kind(&self) -> ChannelKind {
        match self {
            SurfaceMode::Solid | SurfaceMode::Shell { .. } => ChannelKind::Density,
            SurfaceMode::Distance { .. } => ChannelKind::SignedDistance,
            SurfaceMode::Binary(_) | SurfaceMode::Inside => ChannelKind::Binary,
        }
    }
}

/// Voxelizes the union of `inputs` on `grid` in the given mode.
pub fn voxelize_shapes<S: SignedDistance + Sync>(
    grid: &Grid,
    inputs: &[S],
    mode: SurfaceMode,
    progress: &dyn Progress,
) -> SparseVolume {
    voxelize_shapes_in(grid, inputs, mode, &grid.index_box(), progress)
}

/// [`voxelize_shapes`] on the bricks of `grid` that meet `clip` (voxel indices) only, each
/// the whole run's brick bit for bit (every voxel is a function of its own position and
/// its neighbours' distances, evaluated directly).
pub fn voxelize_shapes_in<S: SignedDistance + Sync>(
    grid: &Grid,
    inputs: &[S],
    mode: SurfaceMode,
    clip: &IndexBox,
    progress: &dyn Progress,
) -> SparseVolume {
    let wanted = volga_core::bricks_meeting(clip);
    let filter = OrientedBoxFilter::for_spacing(grid.transform.spacing());
    // World distance beyond which a voxel takes the mode's far value.
    let band = match mode {
        SurfaceMode::Solid => filter.half_width(),
        SurfaceMode::Shell { thickness } => 0.5 * thickness + filter.half_width(),
        SurfaceMode::Distance { half_width_voxels, .. } => half_width_voxels * grid.max_spacing(),
        SurfaceMode::Inside => 0.0,
        // Slab voxels lie within half a voxel diagonal; repair voxels within one
        // N-step (a voxel diagonal) of the surface.
        SurfaceMode::Binary(_) => grid.voxel_diagonal(),
    };
    let background = mode.background(grid);

    let grid_box = grid.index_box();
    let mut bricks: Vec<IVec3> = inputs
        .iter()
        .flat_map(|s| {
            // Solids fill their inside; everything else lives near the surface, but the
            // bounds are what we know without sampling.
            let world = s.bounds().expanded(DVec3::splat(band));
            let t = &grid.transform;
            let clip = |v: DVec3| v.clamp(DVec3::splat(-1.0), grid.dims().as_dvec3() + 1.0).as_ivec3();
            let lo = clip(t.world_to_index(world.min).ceil());
            let hi = clip(t.world_to_index(world.max).floor() + 1.0);
            let vox = IndexBox::new(lo, hi).intersection(&grid_box);
            let b = if vox.is_empty() {
                IndexBox::new(IVec3::ZERO, IVec3::ZERO)
            } else {
                IndexBox::new(
                    vox.min.div_euclid(IVec3::splat(BRICK_DIM)),
                    (vox.max - 1).div_euclid(IVec3::splat(BRICK_DIM)) + 1,
                )
            };
            b.intersection(&wanted).iter().collect::<Vec<_>>()
        })
        .collect();
    bricks.sort_unstable_by_key(|b| (b.z, b.y, b.x));
    bricks.dedup();

    progress.start("voxelize", bricks.len() as u64);
    let sampled: Vec<(IVec3, Brick<f32>)> = bricks
        .par_chunks(32)
        .flat_map_iter(|chunk| {
            let out: Vec<_> = chunk
                .iter()
                .filter_map(|&b| {
                    let brick = sample_brick(grid, inputs, mode, &filter, band, background, b);
                    brick.map(|br| (b, br))
                })
                .collect();
            progress.inc(chunk.len() as u64);
            out
        })
        .collect();
    progress.finish();

    let mut volume = SparseVolume::new(*grid, background, false).with_density_kind(mode.channel_kind());
    for (b, brick) in sampled {
        volume.density.insert_brick(b, brick);
    }
    volume
}

/// The value of one input at a voxel, before the union.
#[inline]
fn voxel_value<S: SignedDistance>(
    s: &S,
    mode: SurfaceMode,
    filter: &OrientedBoxFilter,
    band: f64,
    p: DVec3,
    spacing: DVec3,
) -> f64 {
    let d = s.signed_distance(p);
    match mode {
        SurfaceMode::Solid => filter.density(d),
        SurfaceMode::Shell { thickness } => filter.density(d.abs() - 0.5 * thickness),
        SurfaceMode::Distance { signed, .. } => {
            let d = if signed { d } else { d.abs() };
            d.clamp(-band, band)
        }
        SurfaceMode::Binary(sep) => in_slab(s, sep, band, p, d, spacing) as u8 as f64,
        SurfaceMode::Inside => (d <= 0.0) as u8 as f64,
    }
}

/// Is the voxel at `p` (signed distance `d`) inside the tangent-plane slab?
fn in_slab<S: SignedDistance>(s: &S, sep: Separability, band: f64, p: DVec3, d: f64, spacing: DVec3) -> bool {
    if !d.is_finite() || d.abs() > band {
        return false;
    }
    // Index-space normal and first-order index-space distance.
    let g_world = s.gradient(p);
    let n = g_world * spacing;
    let (gw, gi) = (g_world.length(), n.length());
    if !(gi > 0.0 && gw.is_finite()) {
        return false;
    }
    let s_index = d * gw / gi; // along the unit normal, in voxels
                               // n_c·(v − foot) for the canonically oriented normal (largest component positive).
    let along = if n[dominant_axis(n)] < 0.0 {
        -s_index * gi
    } else {
        s_index * gi
    };
    let h = sep.support(n);
    -h <= along && along < h
}

/// Binary value of the union at voxel `ijk`: in some input's slab, or an inside voxel
/// with an outside neighbour where neither is in a slab (the separation repair).
fn binary_voxel<S: SignedDistance>(
    grid: &Grid,
    inputs: &[&S],
    sep: Separability,
    band: f64,
    ijk: IVec3,
    offsets: &[IVec3],
) -> bool {
    let t = &grid.transform;
    let spacing = t.spacing();
    let eval = |ijk: IVec3| -> (f64, bool) {
        let p = t.voxel_center(ijk);
        let mut d_union = f64::INFINITY;
        let mut slab = false;
        for s in inputs {
            let d = s.signed_distance(p);
            d_union = d_union.min(d);
            slab |= in_slab(*s, sep, band, p, d, spacing);
        }
        (d_union, slab)
    };
    let (d, slab) = eval(ijk);
    if slab {
        return true;
    }
    if d.is_nan() || d > 0.0 || d < -band {
        return false;
    }
    offsets.iter().any(|&o| {
        let (du, slab_u) = eval(ijk + o);
        du > 0.0 && !slab_u
    })
}

/// Union of two values in this mode.
#[inline]
fn union(mode: SurfaceMode, a: f64, b: f64) -> f64 {
    match mode {
        SurfaceMode::Distance { .. } => a.min(b),
        _ => a.max(b),
    }
}

fn sample_brick<S: SignedDistance>(
    grid: &Grid,
    inputs: &[S],
    mode: SurfaceMode,
    filter: &OrientedBoxFilter,
    band: f64,
    background: f32,
    brick: IVec3,
) -> Option<Brick<f32>> {
    let t = &grid.transform;
    let spacing = t.spacing();
    let base = brick * BRICK_DIM;
    let half = (BRICK_DIM - 1) as f64 * 0.5;
    let center = t.index_to_world(base.as_dvec3() + half);
    let radius = (spacing * half).length();
    let grid_box = grid.index_box();
    let whole = grid_box.contains(base) && grid_box.contains(base + IVec3::splat(BRICK_DIM - 1));

    // Keep the inputs whose band reaches this brick; note whether one of them fills it.
    let mut relevant: Vec<&S> = Vec::new();
    let mut filled = false;
    for s in inputs {
        if !s.is_exact() {
            relevant.push(s);
            continue;
        }
        let d = s.signed_distance(center);
        let inside_far = d + radius < -band;
        let outside_far = d.abs() - radius > band;
        match mode {
            SurfaceMode::Solid | SurfaceMode::Inside if inside_far => filled = true,
            SurfaceMode::Distance { signed: true, .. } if inside_far => filled = true,
            _ if outside_far => {}
            _ => relevant.push(s),
        }
    }
    let far_inside = match mode {
        SurfaceMode::Solid | SurfaceMode::Inside => 1.0,
        SurfaceMode::Distance { .. } => -(band as f32),
        _ => 0.0,
    };
    if filled && whole {
        return Some(Brick::Uniform(far_inside));
    }
    if relevant.is_empty() && !filled {
        return None;
    }
    let neutral = match mode {
        SurfaceMode::Distance { .. } => band,
        _ => 0.0,
    };
    let mut data = [background; BRICK_VOXELS];
    if let SurfaceMode::Binary(sep) = mode {
        let offsets = sep.offsets();
        for (n, ijk) in IndexBox::new(base, base + IVec3::splat(BRICK_DIM)).iter().enumerate() {
            if grid_box.contains(ijk) && binary_voxel(grid, &relevant, sep, band, ijk, offsets) {
                data[n] = 1.0;
            }
        }
        let brick = Brick::from_voxels(&data);
        return (brick != Brick::Uniform(background)).then_some(brick);
    }
    for (n, ijk) in IndexBox::new(base, base + IVec3::splat(BRICK_DIM)).iter().enumerate() {
        if !grid_box.contains(ijk) {
            continue;
        }
        let p = t.voxel_center(ijk);
        let mut v = if filled { far_inside as f64 } else { neutral };
        for s in &relevant {
            v = union(mode, v, voxel_value(*s, mode, filter, band, p, spacing));
        }
        data[n] = v as f32;
    }
    let brick = Brick::from_voxels(&data);
    (brick != Brick::Uniform(background)).then_some(brick)
}
