//! Narrow-band half-width of a mesh's signed distance field: distance error near and
//! far from the surface against time and memory.
//!
//! Inside the band the stored distance is exact at voxel centres and trilinear
//! between them; beyond it the field reads the clamp value `±w`, so a query
//! `|d|` voxels away is off by `|d| − w`. The sweep shows what each extra voxel of
//! band costs and where it stops paying for queries up to 10 voxels out.

use glam::DVec3;
use rayon::prelude::*;
use volga_core::{Field, Filter, NoProgress, Sampled};
use volga_shapes::SignedDistance;
use volga_voxelize::{MeshVoxelizer, SurfaceMode};

use super::{scene_grid, Context, Experiment};
use crate::references::{mesh_signed_distance, r3_point, torus_mesh, ReferenceShape};
use crate::{timed, KnobResult, Metric, Series, Setting};

pub const EXPERIMENT: Experiment = Experiment { id: "narrow_band", run };

/// Queries lie within this many voxels of the surface.
const QUERY_VOXELS: f64 = 10.0;
/// "Far" queries: at least this many voxels from the surface.
const FAR_VOXELS: f64 = 4.0;

/// `count` query points within `QUERY_VOXELS · voxel` of the mesh (selected with the
/// analytic torus the mesh approximates, whose distance is within 0.02 of the mesh's),
/// with their exact mesh distances by brute force.
fn queries(mesh: &volga_mesh::TriMesh, voxel: f64, count: usize) -> Vec<(DVec3, f64)> {
    let torus = ReferenceShape::torus();
    let reach = QUERY_VOXELS * voxel;
    let points: Vec<DVec3> = (0u64..)
        .map(|i| r3_point(i) * 2.0 - 1.0)
        .filter(|&p| torus.signed_distance(p).abs() <= reach + 0.02)
        .take(count * 2)
        .collect();
    let exact: Vec<(DVec3, f64)> = points.par_iter().map(|&p| (p, mesh_signed_distance(mesh, p))).collect();
    exact
        .into_iter()
        .filter(|(_, d)| d.abs() <= reach)
        .take(count)
        .collect()
}

fn run(ctx: &Context) -> KnobResult {
    let n = ctx.size.pick(32, 128);
    let (major, minor) = ctx.size.pick((24, 12), (96, 48));
    let count = ctx.size.pick(300, 4000);
    let half_widths: &[f64] = ctx
        .size
        .pick(&[1.0, 3.0, 10.0], &[1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0]);
    let grid = scene_grid(n);
    let voxel = grid.max_spacing();
    let mesh = torus_mesh(major, minor);
    let voxelizer = MeshVoxelizer::new(&mesh);
    let queries = queries(&mesh, voxel, count);
    ctx.start("narrow band", half_widths.len());
    let settings = half_widths
        .iter()
        .map(|&w| {
            let mode = SurfaceMode::Distance {
                half_width_voxels: w,
                signed: true,
            };
            let (volume, timing) = timed(|| voxelizer.voxelize(&grid, mode, &NoProgress));
            let field = Sampled::new(&volume, Filter::Trilinear);
            let errors: Vec<(f64, f64)> = queries
                .iter()
                .map(|&(p, d)| ((field.value(p) - d).abs() / voxel, d.abs() / voxel))
                .collect();
            let rms = |keep: &dyn Fn(f64) -> bool| {
                let picked: Vec<f64> = errors.iter().filter(|(_, at)| keep(*at)).map(|(e, _)| *e).collect();
                (picked.iter().map(|e| e * e).sum::<f64>() / picked.len().max(1) as f64).sqrt()
            };
            let max = errors.iter().map(|(e, _)| *e).fold(0.0, f64::max);
            ctx.setting_done();
            Setting::new(
                format!("{w}"),
                &[("half_width_voxels", w), ("resolution", n as f64)],
                timing,
                volume.memory_bytes(),
            )
            .error("distance_rms_voxels", rms(&|_| true))
            .error("distance_rms_far_voxels", rms(&|at| at >= FAR_VOXELS))
            .error("distance_rms_near_voxels", rms(&|at| at <= 1.0))
            .error("distance_max_voxels", max)
        })
        .collect();
    ctx.finish();
    KnobResult {
        id: "narrow_band",
        title: "Narrow-band half-width of a mesh distance field",
        knob: "band half-width w in voxels (labels), torus mesh at a fixed resolution",
        reference: "brute-force signed distance to every triangle of a torus mesh (sign: generalized winding number over every triangle) at query points up to 10 voxels from the surface",
        timed: "MeshVoxelizer::voxelize in SurfaceMode::Distance (signed), all threads; the mesh's BVH is built once beforehand",
        metrics: vec![
            Metric {
                id: "distance_rms_voxels",
                label: "distance error, RMS over queries ≤ 10 voxels out (voxels)",
            },
            Metric {
                id: "distance_rms_far_voxels",
                label: "distance error, RMS over queries 4–10 voxels out (voxels)",
            },
            Metric {
                id: "distance_rms_near_voxels",
                label: "distance error, RMS over queries ≤ 1 voxel out (voxels)",
            },
            Metric {
                id: "distance_max_voxels",
                label: "distance error, max (voxels)",
            },
        ],
        series: vec![Series {
            name: format!("torus mesh, {} triangles, N = {n}", mesh.triangle_count()),
            settings,
        }],
    }
}
