//! Noise against the `noise` crate, row form against point form, Worley against brute
//! force, the distance transform against brute force, bias/gain end values, thread
//! counts and far-from-origin behaviour.

use glam::DVec3;
use noise::{MultiFractal, NoiseFn};
use proptest::prelude::*;
use volga_core::{Aabb, Field, Grid, Transform};
use volga_shapes::Sphere;
use volga_texture::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn perlin_equals_noise_crate(seed in 0u32..50, x in -300.0f64..300.0, y in -300.0f64..300.0, z in -300.0f64..300.0) {
        let ours = Perlin::new(seed).value(DVec3::new(x, y, z));
        let theirs = noise::Perlin::new(seed).get([x, y, z]);
        prop_assert!((ours - theirs).abs() <= 1e-12, "{ours} vs {theirs}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn fbm_rows_equal_noise_crate(seed in 0u32..20, x0 in -50.0f64..50.0, dx in 0.001f64..0.7, y in -50.0f64..50.0, z in -50.0f64..50.0, n in 1usize..200) {
        let reference = noise::Fbm::<noise::Perlin>::new(seed).set_octaves(4).set_lacunarity(2.0).set_frequency(0.75);
        let ours = Fbm::new(seed, 4, 0.75, 2.0, 0.5);
        let mut row = vec![0.0; n];
        ours.row(x0, dx, y, z, &mut row);
        for (k, v) in row.iter().enumerate() {
            let p = [x0 + k as f64 * dx, y, z];
            let r = reference.get(p);
            prop_assert!((v - r).abs() <= 1e-9, "row {k}: {v} vs {r}");
            prop_assert!((ours.value(DVec3::from(p)) - r).abs() <= 1e-12);
        }
    }

    #[test]
    fn turbulence_row_equals_points(x0 in -20.0f64..20.0, dx in 0.01f64..0.5, y in -20.0f64..20.0, z in -20.0f64..20.0) {
        let t = Turbulence::new(3, 4, 1.3);
        let mut row = vec![0.0; 64];
        t.row(x0, dx, y, z, &mut row);
        for (k, v) in row.iter().enumerate() {
            let p = DVec3::new(x0 + k as f64 * dx, y, z);
            // Σ|noise(2ⁱx)|/2ⁱ straight from the definition.
            let direct: f64 = (0..4).map(|i| Perlin::new(3).value(p * 1.3 * 2f64.powi(i)).abs() / 2f64.powi(i)).sum();
            prop_assert!((v - direct).abs() <= 1e-9);
        }
    }
}

/// Noise is 0 on the lattice, including at 0 exactly and at negative integers, where the
/// `noise` crate's corner rule (trunc − 1 for x ≤ 0) applies.
#[test]
fn perlin_lattice_and_corner_rule() {
    let n = noise::Perlin::new(7);
    let p = Perlin::new(7);
    for c in [-3.0, -1.0, 0.0, 1.0, 2.0] {
        for q in [DVec3::new(c, 0.5, 0.25), DVec3::new(c, c, c), DVec3::new(0.3, c, -c)] {
            assert!((p.value(q) - n.get(q.to_array())).abs() <= 1e-12, "{q}");
        }
    }
    let mut row = vec![0.0; 9];
    p.add_row(-2.0, 0.5, 0.0, -1.0, 1.0, false, &mut row);
    for (k, v) in row.iter().enumerate() {
        let q = [-2.0 + 0.5 * k as f64, 0.0, -1.0];
        assert!((v - n.get(q)).abs() <= 1e-12);
    }
}

#[test]
fn far_from_origin_finite_and_equal() {
    let p = Perlin::new(1);
    let n = noise::Perlin::new(1);
    let t = Turbulence::new(1, 6, 1.0);
    let w = Worley::new(1, 1.0);
    for q in [
        DVec3::splat(1e6),
        DVec3::new(-1e6, 1e6 + 0.3, 2.5e6),
        DVec3::new(1e9, -1e9, 0.7),
    ] {
        let v = p.value(q);
        assert!(v.is_finite() && v.abs() <= 1.0);
        assert!((v - n.get(q.to_array())).abs() <= 1e-9);
        assert!(t.value(q).is_finite());
        let (f1, f2) = w.f1_f2(q);
        assert!(f1.is_finite() && f2.is_finite() && f1 <= f2);
    }
    let mut row = vec![0.0; 100];
    Fbm::new(0, 4, 1.0, 2.0, 0.5).row(1e6, 0.01, 1e6, -1e6, &mut row);
    assert!(row.iter().all(|v| v.is_finite()));
    // Beyond the integer range of cells the row form still ends (point fallback).
    Fbm::new(0, 4, 1.0, 2.0, 0.5).row(1e19, 1e17, 0.5, 0.5, &mut row);
    assert!(row.iter().all(|v| v.is_finite()));
}

#[test]
fn fill_identical_for_one_and_two_threads() {
    let t = Turbulence::new(5, 4, 0.1);
    let run = |threads: usize| {
        let mut out = vec![0.0f32; 33 * 17 * 9];
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                fill(
                    &t,
                    DVec3::new(-3.0, 1e6, 2.0),
                    DVec3::new(0.37, 0.5, 0.61),
                    [33, 17, 9],
                    &mut out,
                )
            });
        out
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(
        a.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        b.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    assert!(a.iter().all(|v| v.is_finite()));
}

#[test]
fn worley_equals_brute_force() {
    // Feature points of a wide block of cells, then the two nearest by brute force.
    let w = Worley::new(9, 1.0);
    let mut state = 12345u64;
    let mut rnd = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..200 {
        let q = DVec3::new(rnd() * 6.0 - 3.0, rnd() * 6.0 - 3.0, rnd() * 6.0 - 3.0);
        let (f1, f2) = w.f1_f2(q);
        // A point at q: its own cell's point is within √3, so F1, F2 ≤ 3 and cells
        // within 4 hold every candidate.
        let mut d: Vec<f64> = Vec::new();
        let c = q.floor().as_ivec3();
        for z in -4..=4 {
            for y in -4..=4 {
                for x in -4..=4 {
                    d.push(w.feature_point(c + glam::IVec3::new(x, y, z)).distance(q));
                }
            }
        }
        d.sort_by(f64::total_cmp);
        assert!(
            (f1 - d[0]).abs() < 1e-12 && (f2 - d[1]).abs() < 1e-12,
            "{q}: {f1} {f2} vs {} {}",
            d[0],
            d[1]
        );
    }
}

#[test]
fn bias_gain_documented_values() {
    for b in [0.0, 0.2, 0.5, 0.8, 1.0] {
        assert_eq!(bias(b, 0.0), 0.0);
        assert_eq!(bias(b, 1.0), 1.0);
        assert_eq!(gain(b, 0.0), 0.0);
        assert_eq!(gain(b, 0.5), 0.5);
        assert_eq!(gain(b, 1.0), 1.0);
    }
    for b in [0.2, 0.5, 0.8] {
        assert!((bias(b, 0.5) - b).abs() < 1e-15);
    }
    assert_eq!(bias(0.0, 0.5), 0.0);
    assert_eq!(bias(1.0, 0.5), 1.0);
    assert_eq!(gain(0.0, 0.25), 0.5);
    assert_eq!(gain(1.0, 0.25), 0.0);
    assert_eq!(gain(0.0, 0.75), 0.5);
    assert_eq!(gain(1.0, 0.75), 1.0);
    for t in [0.1, 0.3, 0.7] {
        assert!((gain(0.5, t) - t).abs() < 1e-15);
    }
    for v in [f64::NAN, -1.0, 2.0, f64::INFINITY] {
        assert!(bias(v, 0.3).is_finite() && bias(0.3, v).is_finite());
        assert!(gain(v, 0.3).is_finite() && gain(0.3, v).is_finite());
    }
}

fn brute_edt(mask: &[bool], dims: [usize; 3], h: [f64; 3]) -> Vec<f64> {
    let idx = |x: usize, y: usize, z: usize| x + dims[0] * (y + dims[1] * z);
    let mut out = vec![f64::INFINITY; mask.len()];
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                for zz in 0..dims[2] {
                    for yy in 0..dims[1] {
                        for xx in 0..dims[0] {
                            if mask[idx(xx, yy, zz)] {
                                let d = [
                                    (x as f64 - xx as f64) * h[0],
                                    (y as f64 - yy as f64) * h[1],
                                    (z as f64 - zz as f64) * h[2],
                                ];
                                let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                                let o = &mut out[idx(x, y, z)];
                                *o = o.min(d2);
                            }
                        }
                    }
                }
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(60))]

    #[test]
    fn edt_equals_brute_force(nx in 1usize..9, ny in 1usize..9, nz in 1usize..9,
                              hx in 0.3f64..2.0, hy in 0.3f64..2.0, hz in 0.3f64..2.0,
                              density in 0.0f64..0.4, seed in any::<u64>()) {
        let dims = [nx, ny, nz];
        let mut s = seed | 1;
        let mask: Vec<bool> = (0..nx * ny * nz).map(|_| {
            s ^= s << 13; s ^= s >> 7; s ^= s << 17;
            (s % 1000) as f64 / 1000.0 < density
        }).collect();
        let h = [hx, hy, hz];
        let fast = edt::squared_edt(&mask, dims, h);
        let slow = brute_edt(&mask, dims, h);
        for (a, b) in fast.iter().zip(&slow) {
            prop_assert!(a == b || (a - b).abs() <= 1e-9 * (1.0 + b), "{a} vs {b}");
        }
    }
}

#[test]
fn hypertexture_regions_and_noise_only_in_soft_band() {
    let sphere = Sphere::new(DVec3::ZERO, 1.0).unwrap();
    let chain = vec![Modulation::Displace {
        noise: Box::new(Turbulence::new(0, 3, 4.0)),
        amplitude: 0.1,
        stretch: DVec3::ONE,
    }];
    let h = HyperTexture::new(Box::new(ShapeSource(sphere)), 0.1, chain, 0.02).unwrap();
    assert_eq!(h.value(DVec3::ZERO), 1.0);
    assert_eq!(h.value(DVec3::new(3.0, 0.0, 0.0)), 0.0);
    assert_eq!(h.noise_evaluations(), 0, "inside and outside cost no noise");
    let v = h.value(DVec3::new(1.0, 0.0, 0.0));
    assert!((0.0..=1.0).contains(&v));
    assert_eq!(h.noise_evaluations(), 3);
    // Interval bounds contain sampled values.
    let b = Aabb::new(DVec3::new(0.9, -0.1, -0.1), DVec3::new(1.1, 0.1, 0.1));
    let (lo, hi) = h.value_range(&b);
    for i in 0..100 {
        let p = b.min + b.size() * DVec3::new((i % 5) as f64 / 4.0, ((i / 5) % 5) as f64 / 4.0, (i / 25) as f64 / 3.0);
        let v = h.value(p);
        assert!(lo <= v && v <= hi);
    }
    assert_eq!(
        h.value_range(&Aabb::new(DVec3::splat(-0.3), DVec3::splat(0.3))),
        (1.0, 1.0)
    );
}

#[test]
fn sampled_distance_of_a_voxel_ball() {
    let grid = Grid::new(
        Transform::new(DVec3::splat(-1.0), DVec3::splat(0.1)).unwrap(),
        glam::UVec3::splat(21),
    )
    .unwrap();
    let mut inside = vec![false; 21 * 21 * 21];
    for z in 0..21 {
        for y in 0..21 {
            for x in 0..21 {
                let c = grid.transform.voxel_center(glam::IVec3::new(x, y, z));
                inside[(x + 21 * (y + 21 * z)) as usize] = c.length() <= 0.6;
            }
        }
    }
    let sd = edt::signed_distance(&inside, [21; 3], [0.1; 3]);
    let s = SampledDistance::new(grid, sd).unwrap();
    // Within a voxel of the true distance.
    for p in [DVec3::ZERO, DVec3::new(0.8, 0.0, 0.0), DVec3::new(0.3, 0.3, 0.1)] {
        assert!(
            (s.distance(p) - (p.length() - 0.6)).abs() <= 0.1,
            "{p}: {}",
            s.distance(p)
        );
    }
    let b = Aabb::new(DVec3::new(0.4, 0.0, 0.0), DVec3::new(0.55, 0.15, 0.1));
    let (lo, hi) = s.range(&b);
    for i in 0..64 {
        let p = b.min + b.size() * DVec3::new((i % 4) as f64 / 3.0, ((i / 4) % 4) as f64 / 3.0, (i / 16) as f64 / 3.0);
        let d = s.distance(p);
        assert!(lo <= d && d <= hi);
    }
}

/// The lattice fill (rows sharing corner hashes through `RowHashes`) equals the
/// `noise` crate's fBm at every sample (to the `f32` payload).
#[test]
fn fill_equals_noise_crate() {
    let reference = noise::Fbm::<noise::Perlin>::new(3).set_octaves(4).set_lacunarity(2.0);
    let ours = Fbm::new(3, 4, 1.0, 2.0, 0.5);
    let (origin, h, n) = (DVec3::new(-2.3, -0.7, 5.1), 0.173, [29, 23, 11]);
    let mut out = vec![0.0f32; n[0] * n[1] * n[2]];
    fill(&ours, origin, DVec3::splat(h), n, &mut out);
    for z in 0..n[2] {
        for y in 0..n[1] {
            for x in 0..n[0] {
                let p = origin + DVec3::new(x as f64, y as f64, z as f64) * h;
                let v = out[x + n[0] * (y + n[1] * z)] as f64;
                assert!((v - reference.get(p.to_array())).abs() <= 1e-6, "{p}");
            }
        }
    }
}

/// Each documented requirement of a constructor is checked: the argument that breaks it
/// is refused with its name and value, and the arguments that meet it are accepted.
#[test]
fn constructors_refuse_what_their_docs_rule_out() {
    let sphere = || Box::new(ShapeSource(Sphere::new(DVec3::ZERO, 1.0).unwrap()));
    for bad in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        let err = HyperTexture::new(sphere(), bad, Vec::new(), 0.02).unwrap_err();
        assert_eq!(err.to_string(), TextureError::SoftWidth(bad).to_string());
        assert!(
            err.to_string().starts_with("soft_width must be finite and > 0, got "),
            "{err}"
        );
        let err = HyperTexture::new(sphere(), 0.1, Vec::new(), bad).unwrap_err();
        assert!(
            err.to_string()
                .starts_with("sample_spacing must be finite and > 0, got "),
            "{err}"
        );
        assert!(err.to_string().ends_with(&bad.to_string()), "{err}");
    }
    assert_eq!(
        HyperTexture::new(sphere(), -0.5, Vec::new(), 0.02).unwrap_err(),
        TextureError::SoftWidth(-0.5)
    );
    assert_eq!(
        HyperTexture::new(sphere(), 0.1, Vec::new(), 0.0).unwrap_err(),
        TextureError::SampleSpacing(0.0)
    );
    assert!(HyperTexture::new(sphere(), 1e-9, Vec::new(), 1e-9).is_ok());

    let grid = Grid::new(
        Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(),
        glam::UVec3::new(2, 3, 4),
    )
    .unwrap();
    let err = SampledDistance::new(grid, vec![1.0; 23]).unwrap_err();
    assert_eq!(err, TextureError::ValueCount { expected: 24, got: 23 });
    assert_eq!(
        err.to_string(),
        "values must hold one distance per voxel of the grid (24), got 23"
    );
    assert!(SampledDistance::new(grid, vec![1.0; 24]).is_ok());

    use glam::Vec3;
    assert_eq!(ColourSpline::new(Vec::new()).unwrap_err(), TextureError::NoKnots);
    let err = ColourSpline::new(vec![(0.0, Vec3::ONE), (f64::NAN, Vec3::ONE)]).unwrap_err();
    assert!(
        err.to_string().starts_with("knots[1] must be finite, got position NaN"),
        "{err}"
    );
    let err = ColourSpline::new(vec![(0.0, Vec3::new(1.0, f32::INFINITY, 0.0))]).unwrap_err();
    assert!(matches!(err, TextureError::KnotNotFinite { index: 0, .. }), "{err}");
    assert!(err.to_string().contains("inf"), "{err}");
    let err = ColourSpline::new(vec![(0.0, Vec3::ONE), (0.5, Vec3::ONE), (0.5, Vec3::ZERO)]).unwrap_err();
    assert_eq!(
        err,
        TextureError::KnotOrder {
            index: 2,
            position: 0.5,
            previous: 0.5
        }
    );
    assert_eq!(
        err.to_string(),
        "knots[2] must lie after knots[1] at 0.5, got position 0.5"
    );
    assert!(ColourSpline::new(vec![(0.0, Vec3::ONE), (0.5, Vec3::ONE)]).is_ok());
}
