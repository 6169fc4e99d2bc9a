//! Resolution (32³ … 1024³) for binary and anti-aliased voxelization of the four
//! analytic shapes.

use volga_core::NoProgress;
use volga_voxelize::{measure, voxelize_shapes, SurfaceMode};

use super::{scene_grid, solid_errors, solid_metrics, Context, Experiment};
use crate::references::ReferenceShape;
use crate::{timed, KnobResult, Series, Setting};

pub const EXPERIMENT: Experiment = Experiment { id: "resolution", run };

/// Binary (`SurfaceMode::Inside`: 1 where `d ≤ 0`) or anti-aliased (oriented box
/// filter, `SurfaceMode::Solid`).
#[derive(Clone, Copy)]
pub(crate) enum Method {
    Binary,
    AntiAliased,
}

impl Method {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Method::Binary => "binary",
            Method::AntiAliased => "anti-aliased",
        }
    }

    /// Voxelizes `shape` on an `n³` grid of the scene box, timed, and measures it.
    pub(crate) fn measure(self, shape: &ReferenceShape, n: u32) -> Setting {
        let grid = scene_grid(n);
        let mode = match self {
            Method::Binary => SurfaceMode::Inside,
            Method::AntiAliased => SurfaceMode::Solid,
        };
        let (volume, timing) = timed(|| voxelize_shapes(&grid, &[*shape], mode, &NoProgress));
        // The library's volume estimate for each kind: voxel count, or the
        // partial-volume fractions recovered from the filtered densities.
        let measured_volume = match self {
            Method::Binary => measure::density_integral(&volume),
            Method::AntiAliased => measure::occupied_volume(&volume),
        };
        let setting = Setting::new(
            format!("{n}"),
            &[("resolution", n as f64)],
            timing,
            volume.memory_bytes(),
        );
        solid_errors(setting, &volume, measured_volume, shape)
    }
}

fn run(ctx: &Context) -> KnobResult {
    let sizes: &[u32] = ctx.size.pick(&[16, 32], &[32, 64, 128, 256, 512, 1024]);
    let shapes = ReferenceShape::all();
    let methods = [Method::Binary, Method::AntiAliased];
    ctx.start("resolution", shapes.len() * methods.len() * sizes.len());
    let mut series = Vec::new();
    for shape in &shapes {
        for method in methods {
            let settings = sizes
                .iter()
                .map(|&n| {
                    let s = method.measure(shape, n);
                    ctx.setting_done();
                    s
                })
                .collect();
            series.push(Series {
                name: format!("{} {}", shape.name(), method.name()),
                settings,
            });
        }
    }
    ctx.finish();
    KnobResult {
        id: "resolution",
        title: "Resolution, binary and anti-aliased voxelization",
        knob: "grid resolution N (N³ voxels over the scene box [−1, 1]³; labels give N)",
        reference: "analytic sphere (r 0.75), torus (R 0.55, r 0.22, tilted axis), rounded box (1.0×0.7×0.5 + 0.15) and cone with apex (30°, height 1.3): exact signed distances, normals, volumes and areas",
        timed: "voxelize_shapes (Inside for binary, Solid for anti-aliased), all threads",
        metrics: solid_metrics(),
        series,
    }
}
