//! Chunked grids: every region (sub-box) of a mesh job computed on its own equals the same
//! region of the whole-grid result **bit for bit**, in every mode (binary 6/26 surface and
//! solid, anti-aliased shell and solid, signed and unsigned distance), on the unclean
//! corpus (self-intersecting, overlapping, nested, flipped, open, flat, stacked, far from
//! the origin) and the open bunny. The grid is tiled by chunks of several shapes, aligned
//! to the 8³ bricks and not, so chunk borders run through the surface, through the band
//! and through the far field whose signs are proven by region queries.

use glam::IVec3;
use volga_core::{Grid, IndexBox, NoProgress, SparseVolume};
use volga_mesh::{unclean, TriMesh};
use volga_voxelize::{MeshJob, MeshJobMode, Separability};

fn modes() -> Vec<MeshJobMode> {
    vec![
        MeshJobMode::Binary {
            separability: Separability::Six,
            solid: false,
        },
        MeshJobMode::Binary {
            separability: Separability::TwentySix,
            solid: true,
        },
        MeshJobMode::AntiAliased {
            thickness_voxels: 1.5,
            solid: false,
        },
        MeshJobMode::AntiAliased {
            thickness_voxels: 1.0,
            solid: true,
        },
        MeshJobMode::Distance {
            half_width_voxels: 2.5,
            signed: true,
        },
        MeshJobMode::Distance {
            half_width_voxels: 1.0,
            signed: false,
        },
    ]
}

/// The regions of `grid` tiled by chunks of `shape` voxels (the last ones cut by the grid).
fn tiles(grid: &Grid, shape: IVec3) -> Vec<IndexBox> {
    let dims = grid.dims().as_ivec3();
    let counts = (dims + shape - 1) / shape;
    IndexBox::new(IVec3::ZERO, counts)
        .iter()
        .map(|c| IndexBox::new(c * shape, ((c + 1) * shape).min(dims)))
        .collect()
}

/// The values of a volume's grid, as bits (`-0.0` and `0.0` differ, so do NaN payloads).
fn bits(volume: &SparseVolume) -> Vec<u32> {
    volume
        .grid
        .index_box()
        .iter()
        .map(|ijk| volume.density.get(ijk).to_bits())
        .collect()
}

fn assert_chunks_equal_whole(name: &str, mesh: &TriMesh, resolution: u32, shapes: &[IVec3]) {
    for mode in modes() {
        let job = MeshJob { resolution, mode };
        let grid = job.layout(&mesh.bounds()).unwrap();
        let whole = job.run(mesh, &grid, &NoProgress);
        let voxelizer = job.voxelizer(mesh);
        let mut nonempty = 0;
        for &shape in shapes {
            for region in tiles(&grid, shape) {
                let chunk = job
                    .run_region(mesh, voxelizer.as_ref(), &grid, &region, &NoProgress)
                    .unwrap()
                    .volume;
                let expected = whole.volume.window(&region).unwrap();
                assert_eq!(chunk.grid, expected.grid, "{name}, {mode:?}, {region:?}");
                assert_eq!(chunk.density_kind, expected.density_kind);
                assert_eq!(
                    chunk.density.background().to_bits(),
                    expected.density.background().to_bits()
                );
                let (got, want) = (bits(&chunk), bits(&expected));
                if let Some(k) = (0..got.len()).find(|&k| got[k] != want[k]) {
                    let ijk = region.iter().nth(k).unwrap();
                    panic!(
                        "{name}, {mode:?}, chunk {shape} at {:?}..{:?}: voxel {ijk} is {} in the chunk, {} in the whole grid",
                        region.min,
                        region.max,
                        f32::from_bits(got[k]),
                        f32::from_bits(want[k])
                    );
                }
                nonempty += (chunk.active_voxel_count() > 0) as usize;
            }
        }
        assert!(
            nonempty > shapes.len(),
            "{name}, {mode:?}: the chunks hold almost nothing"
        );
    }
}

#[test]
fn chunks_of_the_unclean_corpus_equal_the_whole_grid() {
    let shapes = [IVec3::splat(8), IVec3::new(13, 7, 21)];
    for (name, mesh) in unclean::corpus() {
        assert_chunks_equal_whole(name, &mesh, 24, &shapes);
    }
}

#[test]
fn chunks_of_the_open_bunny_equal_the_whole_grid() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/stanford-bunny.obj");
    let mesh = volga_mesh::load_obj(&path).unwrap();
    assert_chunks_equal_whole("bunny", &mesh, 48, &[IVec3::new(24, 16, 32), IVec3::new(11, 50, 9)]);
}

#[test]
fn regions_outside_the_grid_or_empty_are_refused() {
    let (_, mesh) = unclean::corpus().remove(0);
    let job = MeshJob {
        resolution: 16,
        mode: MeshJobMode::Distance {
            half_width_voxels: 2.0,
            signed: true,
        },
    };
    let grid = job.layout(&mesh.bounds()).unwrap();
    let dims = grid.dims().as_ivec3();
    for region in [
        IndexBox::new(IVec3::ZERO, dims + IVec3::X),
        IndexBox::new(IVec3::NEG_ONE, dims),
        IndexBox::new(IVec3::splat(3), IVec3::new(3, 5, 5)),
    ] {
        let e = job
            .run_region(&mesh, None, &grid, &region, &NoProgress)
            .err()
            .unwrap_or_else(|| panic!("{region:?} accepted"));
        assert!(e.to_string().contains("region"), "{e}");
    }
    // The estimate of a region is no more than the whole grid's, and counts its bricks only.
    let whole = job.estimate(&mesh, &grid);
    let corner = job.estimate_region(&mesh, &grid, &IndexBox::new(IVec3::ZERO, IVec3::splat(8)));
    assert!(corner.band_bricks <= 1 && corner.inside_bricks <= 1, "{corner:?}");
    assert!(whole.band_bricks > 1);
    let all = job.estimate_region(&mesh, &grid, &grid.index_box());
    assert_eq!(
        (all.band_bricks, all.inside_bricks),
        (whole.band_bricks, whole.inside_bricks)
    );
    assert_eq!(grid.window(&grid.index_box()).unwrap().dims(), grid.dims());
}

/// `MeshJob::run_profiled` returns `run`'s volume and sign counts bit for bit, with the
/// stages each mode goes through, in order, none negative.
#[test]
fn profiled_runs_equal_plain_runs() {
    let corpus = unclean::corpus();
    let mesh = &corpus.iter().find(|(n, _)| *n == "open scan with two holes").unwrap().1;
    let band = [
        "bins",
        "slack",
        "distances",
        "band_signs",
        "flood_signs",
        "brick_output",
        "far_field",
    ];
    for mode in modes() {
        let job = MeshJob { resolution: 24, mode };
        let grid = job.layout(&mesh.bounds()).unwrap();
        let plain = job.run(mesh, &grid, &NoProgress);
        let (profiled, profile) = job.run_profiled(mesh, &grid, &NoProgress);
        assert_eq!(bits(&plain.volume), bits(&profiled.volume), "{mode:?}");
        assert_eq!(plain.sign, profiled.sign, "{mode:?}");
        let names: Vec<&str> = profile.stages.iter().map(|s| s.name).collect();
        let mut expected: Vec<&str> = Vec::new();
        if !matches!(mode, MeshJobMode::Binary { solid: false, .. }) {
            expected.extend(["tables_and_bvh", "sign_oracle"]);
        }
        if matches!(mode, MeshJobMode::Binary { .. }) {
            expected.push("binary_surface");
        }
        if !matches!(mode, MeshJobMode::Binary { solid: false, .. }) {
            expected.extend(band);
        }
        assert_eq!(names, expected, "{mode:?}");
        assert!(profile.stages.iter().all(|s| s.wall_s >= 0.0 && s.cpu_s >= 0.0));
        assert!(profile.wall_s() > 0.0);
    }
}
