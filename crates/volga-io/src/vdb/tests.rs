use glam::{DVec3, IVec3, UVec3};
use volga_core::{Brick, ChannelKind, Grid, SparseVolume, Transform};

use super::*;

/// A narrow-band level set of a sphere (radius `r` world units) as volga stores one:
/// band voxels exact, voxels outside the band clamped to ±band, interior bricks uniform
/// at −band, background +band.
fn sphere_level_set(dims: UVec3, origin: DVec3, spacing: DVec3, centre: DVec3, r: f64, band: f32) -> SparseVolume {
    let grid = Grid::new(Transform::new(origin, spacing).unwrap(), dims).unwrap();
    let mut v = SparseVolume::new(grid, band, false).with_density_kind(ChannelKind::SignedDistance);
    let ext = volga_core::brick_extent(dims);
    for bz in 0..ext.z {
        for by in 0..ext.y {
            for bx in 0..ext.x {
                let b = IVec3::new(bx, by, bz);
                let brick = volga_core::gather_brick(b, |ijk| {
                    let d = (grid.transform.voxel_center(ijk) - centre).length() - r;
                    (d as f32).clamp(-band, band)
                });
                if brick != Brick::Uniform(band) {
                    v.density.insert_brick(b, brick);
                }
            }
        }
    }
    v
}

fn fog(dims: UVec3, origin: DVec3, spacing: DVec3) -> SparseVolume {
    let grid = Grid::new(Transform::new(origin, spacing).unwrap(), dims).unwrap();
    let mut v = SparseVolume::new(grid, 0.0, true);
    let c = dims.as_dvec3() * 0.5;
    for ijk in grid.index_box().iter() {
        let d = (ijk.as_dvec3() - c).length() / c.min_element();
        if d < 1.0 {
            v.density.set(ijk, (1.0 - d) as f32);
            v.colour.as_mut().unwrap().set(ijk, [d as f32, 0.5, 1.0 - d as f32]);
        }
    }
    v.density.prune();
    v
}

const ALL: [VdbCompression; 3] = [VdbCompression::None, VdbCompression::Zip, VdbCompression::Blosc];

/// Every voxel of the grid read back equals the written one (after the writer's
/// level-set clamping and half rounding).
fn assert_round_trip(v: &SparseVolume, options: VdbOptions) -> Vec<u8> {
    let bytes = encode_vdb(v, &options);
    let back = decode_vdb(&bytes, 1 << 30).unwrap_or_else(|e| panic!("{options:?}: {e}"));
    let r = &back.volume;
    assert_eq!(r.grid.dims(), v.grid.dims(), "{options:?}");
    assert_eq!(r.grid.transform.origin(), v.grid.transform.origin());
    assert_eq!(r.grid.transform.spacing(), v.grid.transform.spacing());
    let kind = VdbGridKind::of(v);
    assert_eq!(back.class, kind.class);
    assert_eq!(back.name, kind.name);
    let bg = v.density.background();
    assert_eq!(
        r.density.background(),
        if options.half { bg.truncated_half() } else { bg }
    );
    let mut active = 0u64;
    for ijk in v.grid.index_box().iter() {
        let mut want = v.density.get(ijk);
        let is_active = match kind.class {
            VdbClass::LevelSet => want.abs() < bg,
            _ => want != bg,
        };
        active += is_active as u64;
        if kind.class == VdbClass::LevelSet && !is_active {
            want = bg.copysign(want);
        }
        if options.half {
            want = want.truncated_half();
        }
        let got = r.density.get(ijk);
        assert_eq!(
            got.to_bits(),
            want.to_bits(),
            "{options:?} voxel {ijk}: {got} vs {want}"
        );
    }
    assert_eq!(back.active_voxels, active);
    bytes
}

trait Half {
    fn truncated_half(self) -> Self;
}
impl Half for f32 {
    fn truncated_half(self) -> f32 {
        half::f16::from_f32(self).to_f32()
    }
}

#[test]
fn level_sets_round_trip_in_every_compression() {
    // Odd dims (bricks cut by the grid border), anisotropic voxels far from the origin,
    // and a sphere large enough for uniform interior bricks and whole interior nodes.
    let v = sphere_level_set(
        UVec3::new(45, 38, 41),
        DVec3::new(1e6, -2.5e5, 3.25),
        DVec3::new(0.5, 0.5, 0.75),
        DVec3::new(1e6 + 11.0, -2.5e5 + 9.0, 3.25 + 15.0),
        8.0,
        1.5,
    );
    for compression in ALL {
        for half in [false, true] {
            assert_round_trip(&v, VdbOptions { compression, half });
        }
    }
}

#[test]
fn fog_volumes_round_trip_and_carry_colour() {
    let v = fog(UVec3::new(30, 17, 9), DVec3::new(-3.0, 2.0, -1.0), DVec3::splat(0.125));
    for compression in ALL {
        let bytes = assert_round_trip(
            &v,
            VdbOptions {
                compression,
                half: false,
            },
        );
        let back = decode_vdb(&bytes, 1 << 30).unwrap();
        let names: Vec<_> = back
            .grids
            .iter()
            .map(|g| (g.name.as_str(), g.type_name.as_str()))
            .collect();
        // The density grid is read; the colour grid after it is listed.
        assert_eq!(
            names,
            vec![("density", "Tree_float_5_4_3"), ("color", "Tree_vec3s_5_4_3")]
        );
    }
}

#[test]
fn uniform_regions_become_tiles() {
    // A 160³ solid block of density 1 in a 256³ grid: 8000 uniform bricks, 1 whole
    // 128³ node. Written as tiles the file stays far below one leaf per brick.
    let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), UVec3::splat(256)).unwrap();
    let mut v = SparseVolume::new(grid, 0.0, false);
    for z in 0..20 {
        for y in 0..20 {
            for x in 0..20 {
                v.density.insert_brick(IVec3::new(x, y, z), Brick::Uniform(1.0));
            }
        }
    }
    for compression in ALL {
        let bytes = assert_round_trip(
            &v,
            VdbOptions {
                compression,
                half: false,
            },
        );
        assert!(bytes.len() < 40_000, "{compression:?}: {} bytes", bytes.len());
    }
}

#[test]
fn output_does_not_depend_on_threads() {
    let v = sphere_level_set(UVec3::splat(40), DVec3::ZERO, DVec3::ONE, DVec3::splat(20.0), 12.0, 3.0);
    let encode = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| encode_vdb(&v, &VdbOptions::default()))
    };
    assert_eq!(encode(1), encode(3));
}

#[test]
fn hostile_files_are_errors() {
    let v = sphere_level_set(UVec3::splat(20), DVec3::ZERO, DVec3::ONE, DVec3::splat(10.0), 6.0, 2.0);
    for compression in ALL {
        let bytes = encode_vdb(
            &v,
            &VdbOptions {
                compression,
                half: false,
            },
        );
        for cut in (0..bytes.len()).step_by(7) {
            assert!(decode_vdb(&bytes[..cut], 1 << 30).is_err(), "cut at {cut}");
        }
        let mut state = 7u64;
        for _ in 0..2000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let mut bad = bytes.clone();
            let i = (state >> 33) as usize % bad.len();
            bad[i] ^= 1 << ((state >> 20) % 8);
            let _ = decode_vdb(&bad, 1 << 26);
        }
    }
    let bytes = encode_vdb(&v, &VdbOptions::default());
    let e = decode_vdb(&bytes, 10_000).unwrap_err();
    assert!(e.contains("memory limit"), "{e}");
    assert!(decode_vdb(b"not a vdb file at all", 1 << 20)
        .unwrap_err()
        .contains("not an OpenVDB file"));
    let mut newer = bytes.clone();
    newer[8..12].copy_from_slice(&300u32.to_le_bytes());
    assert!(
        decode_vdb(&newer, 1 << 30).unwrap_err().contains("newer"),
        "newer versions are refused"
    );
}

#[test]
fn bytes_bound_holds() {
    let v = fog(UVec3::new(30, 17, 9), DVec3::ZERO, DVec3::ONE);
    let l = sphere_level_set(UVec3::splat(50), DVec3::ZERO, DVec3::ONE, DVec3::splat(25.0), 18.0, 3.0);
    for vol in [&v, &l] {
        for half in [false, true] {
            let n = encode_vdb(
                vol,
                &VdbOptions {
                    compression: VdbCompression::None,
                    half,
                },
            )
            .len() as u64;
            assert!(n <= vdb_bytes_bound(vol, half), "{n} > {}", vdb_bytes_bound(vol, half));
        }
    }
}
