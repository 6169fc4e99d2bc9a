//! `volga bench noise`: 4-octave fBm on an N³ lattice (default 256³), one thread and
//! two, for volga's Perlin (`volga_texture::Fbm`, row form), the `noise` crate 0.9's
//! `Fbm<Perlin>` with the same parameters (the values volga must equal) and `simdnoise`
//! 3.1's fBm (a different noise: throughput only); then the 256³ bake of 4-octave
//! turbulence, dense by rows and sparse through `volga_cvg::bake`. One JSON object.
//!
//! Lattice: `p = ijk · (span / N)` with `span` = 16 noise periods, frequency 1,
//! lacunarity 2, persistence (gain) ½, seed 0. Times are the fastest of `--repeat`.

use std::time::Instant;

use clap::Args;
use glam::DVec3;
use noise::{MultiFractal, NoiseFn};
use rayon::prelude::*;
use serde_json::json;
use volga_texture::{Fbm, SolidNoise, Turbulence};

use crate::failure::{failed, Failure};

#[derive(Args)]
pub struct NoiseBenchArgs {
    /// Lattice side N (N³ samples).
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(8..=1024))]
    size: u32,
    /// Timed runs per measurement; the fastest is reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeat: u32,
    /// Print JSON (the only format).
    #[arg(long)]
    json: bool,
}

const SPAN: f64 = 16.0;
const OCTAVES: usize = 4;

fn best(repeat: u32, mut f: impl FnMut()) -> f64 {
    (0..repeat)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn pool(threads: usize) -> Result<rayon::ThreadPool, Failure> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| failed(format!("thread pool: {e}")))
}

pub fn run(args: NoiseBenchArgs) -> Result<(), Failure> {
    let _ = args.json;
    let n = args.size as usize;
    let h = SPAN / n as f64;
    let samples = (n * n * n) as f64;
    let ours = Fbm::new(0, OCTAVES, 1.0, 2.0, 0.5);
    let theirs = noise::Fbm::<noise::Perlin>::new(0)
        .set_octaves(OCTAVES)
        .set_frequency(1.0)
        .set_lacunarity(2.0)
        .set_persistence(0.5);
    let mut out = vec![0.0f32; n * n * n];

    let volga_fill = |out: &mut [f32]| volga_texture::fill(&ours, DVec3::ZERO, DVec3::splat(h), [n; 3], out);
    let crate_fill = |out: &mut [f32]| {
        out.par_chunks_mut(n * n).enumerate().for_each(|(k, slab)| {
            for (i, v) in slab.iter_mut().enumerate() {
                let (x, y) = (i % n, i / n);
                *v = theirs.get([x as f64 * h, y as f64 * h, k as f64 * h]) as f32;
            }
        })
    };
    let simd_fill = |out: &mut [f32]| {
        // One call per z slab, so both threads have work; simdnoise steps 1 per voxel
        // times its frequency.
        out.par_chunks_mut(n * n).enumerate().for_each(|(k, slab)| {
            let mut s = simdnoise::NoiseBuilder::fbm_3d_offset(0.0, n, 0.0, n, k as f32, 1);
            s.with_freq(h as f32)
                .with_octaves(OCTAVES as u8)
                .with_gain(0.5)
                .with_lacunarity(2.0)
                .with_seed(0);
            let (v, _, _) = s.generate();
            slab.copy_from_slice(&v[..n * n]);
        })
    };

    let mut figures = serde_json::Map::new();
    for threads in [1usize, 2] {
        let p = pool(threads)?;
        let t_volga = p.install(|| best(args.repeat, || volga_fill(&mut out)));
        let t_crate = p.install(|| best(args.repeat, || crate_fill(&mut out)));
        let t_simd = p.install(|| best(args.repeat, || simd_fill(&mut out)));
        let suffix = format!("{threads}t");
        figures.insert(format!("volga_msps_{suffix}"), json!(samples / t_volga / 1e6));
        figures.insert(format!("noise_crate_msps_{suffix}"), json!(samples / t_crate / 1e6));
        figures.insert(format!("simdnoise_msps_{suffix}"), json!(samples / t_simd / 1e6));
        figures.insert(format!("speedup_vs_noise_crate_{suffix}"), json!(t_crate / t_volga));
    }

    // Values: every row of every 8th slab, volga's f64 row form against the crate.
    let mut max_diff = 0.0f64;
    let mut compared = 0u64;
    let mut row = vec![0.0; n];
    for k in (0..n).step_by(8) {
        for j in 0..n {
            ours.row(0.0, h, j as f64 * h, k as f64 * h, &mut row);
            for (i, v) in row.iter().enumerate() {
                let r = theirs.get([i as f64 * h, j as f64 * h, k as f64 * h]);
                max_diff = max_diff.max((v - r).abs());
                compared += 1;
            }
        }
    }

    // 256³ (N³) turbulence, 4 octaves, one period per 32 voxels.
    let turbulence = Turbulence::new(0, 4, 1.0 / 32.0);
    let t_turb_fill = pool(2)?.install(|| {
        best(args.repeat, || {
            volga_texture::fill(&turbulence, DVec3::ZERO, DVec3::ONE, [n; 3], &mut out)
        })
    });
    drop(out);
    let grid = volga_core::Grid::new(
        volga_core::Transform::new(DVec3::ZERO, DVec3::ONE).map_err(|e| failed(e.to_string()))?,
        glam::UVec3::splat(n as u32),
    )
    .map_err(|e| failed(e.to_string()))?;
    let field = volga_texture::NoiseField::new(
        Box::new(Turbulence::new(0, 4, 1.0 / 32.0)),
        0.0,
        0.5,
        grid.world_bounds(),
        1.0,
    );
    let mut bake_bytes = 0;
    let t_turb_bake = pool(2)?.install(|| {
        best(1, || {
            let (v, _) = volga_cvg::bake(&field, &grid, false);
            bake_bytes = v.memory_bytes();
        })
    });

    figures.insert("size".into(), json!(n));
    figures.insert("samples".into(), json!(samples as u64));
    figures.insert("octaves".into(), json!(OCTAVES));
    figures.insert(
        "lattice".into(),
        json!(format!(
            "p = ijk * {h} (span {SPAN}), frequency 1, lacunarity 2, persistence 0.5, seed 0"
        )),
    );
    figures.insert("max_abs_diff_vs_noise_crate".into(), json!(max_diff));
    figures.insert("values_compared".into(), json!(compared));
    figures.insert("turbulence_fill_2t_s".into(), json!(t_turb_fill));
    figures.insert("turbulence_bake_sparse_2t_s".into(), json!(t_turb_bake));
    figures.insert("turbulence_bake_bytes".into(), json!(bake_bytes));
    figures.insert("repeat".into(), json!(args.repeat));
    println!("{}", serde_json::Value::Object(figures));
    Ok(())
}
