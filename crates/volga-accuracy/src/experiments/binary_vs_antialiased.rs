//! Binary vs anti-aliased vs supersampled binary (k³ samples per voxel) on the torus:
//! the same errors against time, so equal-time comparisons read across the plot.

use volga_voxelize::measure;

use super::resolution::Method;
use super::{scene_grid, solid_errors, solid_metrics, supersampled_binary, Context, Experiment};
use crate::references::ReferenceShape;
use crate::{timed, KnobResult, Series, Setting};

pub const EXPERIMENT: Experiment = Experiment {
    id: "binary_vs_antialiased",
    run,
};

fn supersampled(shape: &ReferenceShape, n: u32, k: u32) -> Setting {
    let grid = scene_grid(n);
    let (volume, timing) = timed(|| supersampled_binary(&grid, shape, k));
    let setting = Setting::new(
        format!("{n}"),
        &[("resolution", n as f64), ("samples_per_axis", k as f64)],
        timing,
        volume.memory_bytes(),
    );
    solid_errors(setting, &volume, measure::density_integral(&volume), shape)
}

fn run(ctx: &Context) -> KnobResult {
    let sizes: &[u32] = ctx.size.pick(&[16, 32], &[32, 64, 128, 256, 512]);
    let shape = ReferenceShape::torus();
    let ks = [2u32, 4];
    ctx.start("binary vs anti-aliased", sizes.len() * (2 + ks.len()));
    let mut series = Vec::new();
    for method in [Method::Binary, Method::AntiAliased] {
        let settings = sizes
            .iter()
            .map(|&n| {
                let s = method.measure(&shape, n);
                ctx.setting_done();
                s
            })
            .collect();
        series.push(Series {
            name: method.name().to_string(),
            settings,
        });
    }
    for k in ks {
        let settings = sizes
            .iter()
            .map(|&n| {
                let s = supersampled(&shape, n, k);
                ctx.setting_done();
                s
            })
            .collect();
        series.push(Series {
            name: format!("supersampled binary {}³", k),
            settings,
        });
    }
    ctx.finish();
    KnobResult {
        id: "binary_vs_antialiased",
        title: "Binary vs anti-aliased vs supersampled binary at equal time",
        knob: "method, each at resolutions N (labels give N); supersampled binary takes k³ point samples per voxel",
        reference:
            "analytic torus (R 0.55, r 0.22, tilted axis): exact signed distance, normal, volume 2π²Rr², area 4π²Rr",
        timed: "the voxelization (voxelize_shapes Inside / Solid; supersampled_binary), all threads",
        metrics: solid_metrics(),
        series,
    }
}
