//! The oriented box filter's width below, at and above Sramek & Kaufman's 2√3 voxels
//! (survey §17.4): normal and position error against time and band memory.
//!
//! The library's anti-aliased voxelizer fixes the width at 2√3 voxels, so each width
//! `W` is voxelized as the narrow-band signed distance clamped at `W/2`
//! (`SurfaceMode::Distance`, the same band sampler) and mapped through the filter's
//! profile `clamp(½ − d/W, 0, 1)`: the filtered density the library would store for
//! that width, band for band.

use volga_core::{Brick, ChannelKind, NoProgress, SparseVolume};
use volga_shapes::OrientedBoxFilter;
use volga_voxelize::{voxelize_shapes, SurfaceMode};

use super::{scene_grid, Context, Experiment};
use crate::measure::surface_errors;
use crate::references::ReferenceShape;
use crate::{timed, KnobResult, Metric, Series, Setting};

pub const EXPERIMENT: Experiment = Experiment {
    id: "filter_width",
    run,
};

/// Anti-aliased voxelization of `shape` with a filter `width_voxels` wide.
pub(crate) fn filtered_volume(shape: &ReferenceShape, n: u32, width_voxels: f64) -> SparseVolume {
    let grid = scene_grid(n);
    let half_width_voxels = 0.5 * width_voxels;
    let mode = SurfaceMode::Distance {
        half_width_voxels,
        signed: true,
    };
    let distance = voxelize_shapes(&grid, &[*shape], mode, &NoProgress);
    let filter = OrientedBoxFilter::with_half_width(half_width_voxels * grid.max_spacing()).expect("positive width");
    let density = |d: f32| filter.density(d as f64) as f32;
    let mut out = SparseVolume::new(grid, 0.0, false).with_density_kind(ChannelKind::Density);
    for b in distance.density.sorted_bricks() {
        let brick = match distance.density.brick(b).expect("listed brick") {
            Brick::Uniform(d) => Brick::Uniform(density(*d)),
            Brick::Dense(d) => Brick::from_voxels(&std::array::from_fn(|i| density(d[i]))),
        };
        if brick != Brick::Uniform(0.0) {
            out.density.insert_brick(b, brick);
        }
    }
    out
}

fn run(ctx: &Context) -> KnobResult {
    let n = ctx.size.pick(32, 256);
    let standard = 2.0 * 3f64.sqrt();
    let widths = [1.0, 2.0, 3.0, standard, 4.5, 6.0, 8.0];
    let shape = ReferenceShape::torus();
    ctx.start("filter width", widths.len());
    let settings = widths
        .iter()
        .map(|&w| {
            let (volume, timing) = timed(|| filtered_volume(&shape, n, w));
            let e = surface_errors(&volume, 0.5, &shape);
            ctx.setting_done();
            let label = if w == standard {
                "2√3".to_string()
            } else {
                format!("{w}")
            };
            Setting::new(
                label,
                &[("width_voxels", w), ("resolution", n as f64)],
                timing,
                volume.memory_bytes(),
            )
            .error("position_rms", e.position_rms)
            .error("normal_rms_deg", e.normal_rms_deg)
            .error("position_max", e.position_max)
        })
        .collect();
    ctx.finish();
    KnobResult {
        id: "filter_width",
        title: "Oriented box filter width",
        knob:
            "filter width W in voxels (labels), the torus at a fixed resolution; Sramek & Kaufman's width is 2√3 ≈ 3.46",
        reference: "analytic torus (R 0.55, r 0.22, tilted axis): exact signed distance and normal",
        timed: "the narrow-band distance voxelization at half-width W/2 and its map through the filter profile",
        metrics: vec![
            Metric {
                id: "position_rms",
                label: "surface position error, RMS (world units)",
            },
            Metric {
                id: "normal_rms_deg",
                label: "normal error, RMS (degrees)",
            },
            Metric {
                id: "position_max",
                label: "surface position error, max both ways (world units)",
            },
        ],
        series: vec![Series {
            name: format!("torus, N = {n}"),
            settings,
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At the standard width the mapped distance band is the library's anti-aliased
    /// solid (up to the f32 rounding of the stored distance).
    #[test]
    fn standard_width_is_the_library_filter() {
        let shape = ReferenceShape::torus();
        let n = 32;
        let ours = filtered_volume(&shape, n, 2.0 * 3f64.sqrt());
        let grid = scene_grid(n);
        let library = voxelize_shapes(&grid, &[shape], SurfaceMode::Solid, &NoProgress);
        for ijk in grid.index_box().iter() {
            let (a, b) = (ours.density.get(ijk), library.density.get(ijk));
            assert!((a - b).abs() < 1e-5, "{ijk}: {a} vs {b}");
        }
    }
}
