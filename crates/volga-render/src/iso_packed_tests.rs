//! Accuracy of the packed iso path's hits against exact references: the exact root of
//! the same trilinear reconstruction (found independently by dense sampling and
//! bisection of `Sampled::value` in `f64`), an analytic plane (which trilinear
//! interpolation reproduces exactly) and the analytic sphere (within the reconstruction's
//! own error), for densities and signed distances, near the origin and at 10⁶.

use glam::{DVec3, UVec3};
use volga_core::{ChannelKind, Field, Filter, Grid, Sampled, SparseVolume, Transform};

use crate::packed::PackedVolume;

use super::{march_iso_packed, IsoCellMask, IsoStarts};
use crate::{Ray, RenderStats};

/// A 40³ volume with voxel (0, 0, 0) at `origin`, unit spacing, filled with `f(ijk)`.
fn volume(origin: DVec3, kind: ChannelKind, background: f32, f: impl Fn(DVec3) -> f64) -> SparseVolume {
    let grid = Grid::new(Transform::new(origin, DVec3::ONE).unwrap(), UVec3::splat(40)).unwrap();
    let mut v = SparseVolume::new(grid, background, false).with_density_kind(kind);
    for ijk in grid.index_box().iter() {
        v.density.set(ijk, f(ijk.as_dvec3()) as f32);
    }
    v
}

/// One packed iso walk with the renderer's tolerance (1e-9 voxel): the hit and the
/// counters.
#[allow(clippy::too_many_arguments)]
fn walk(
    packed: &PackedVolume,
    ray: &Ray,
    inward: f64,
    iso: f64,
    interval: (f64, f64),
    mask: Option<&IsoCellMask>,
    start: f64,
    below: Option<bool>,
) -> (Option<f64>, RenderStats) {
    let mut stats = RenderStats::default();
    let hit = march_iso_packed(packed, ray, inward, iso, interval, 1e-9, mask, start, below, &mut stats);
    (hit, stats)
}

/// The packed path's first crossing along `ray` (the renderer's clip and tolerance).
/// `inward` is the sign of the inside (`−1`: a signed distance; sampled volumes are
/// densities to `Field::kind`, so the orientation is passed as the renderer would).
fn packed_hit(field: &dyn Field, inward: f64, ray: &Ray, iso: f64) -> Option<f64> {
    let packed = PackedVolume::of_field(field).expect("packs");
    let (t0, t1) = field.bounds().ray_interval(ray.origin, ray.dir)?;
    let t0 = t0.max(0.0);
    let bg = field.background();
    let below = (t0 > 0.0).then_some(inward * bg < inward * iso);
    let (hit, stats) = walk(&packed, ray, inward, iso, (t0, t1), None, f64::NEG_INFINITY, below);
    // The cell mask only spares reads: the same hit, bit for bit, with fewer cells read.
    let mask = IsoCellMask::build(&packed, inward, iso);
    let (with_mask, masked) = walk(
        &packed,
        ray,
        inward,
        iso,
        (t0, t1),
        Some(&mask),
        f64::NEG_INFINITY,
        below,
    );
    assert_eq!(hit.map(f64::to_bits), with_mask.map(f64::to_bits));
    assert!(masked.samples <= stats.samples);
    hit
}

/// The exact first crossing of the trilinear reconstruction, independently: samples
/// every 1/256 voxel from the bounds entry, then 100 bisections of the first bracket.
fn brute_hit(field: &dyn Field, s: f64, ray: &Ray, iso: f64) -> Option<f64> {
    let (t0, t1) = field.bounds().ray_interval(ray.origin, ray.dir)?;
    let t0 = t0.max(0.0);
    let g = |t: f64| s * (field.value(ray.at(t)) - iso);
    let dt = 1.0 / 256.0;
    // (parameter, below) of the previous sample; from outside the bounds the background.
    let mut prev = (t0, t0 > 0.0 && s * (field.background() - iso) < 0.0);
    let n = ((t1 - t0) / dt).ceil() as u64;
    for i in 0..=n {
        let t = (t0 + i as f64 * dt).min(t1);
        let inside = g(t) >= 0.0;
        if prev.1 && inside {
            let (mut lo, mut hi) = (prev.0, t);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if g(mid) >= 0.0 {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return Some(0.5 * (lo + hi));
        }
        prev = (t, !inside);
    }
    None
}

/// Oblique, axis-parallel and nearly grazing rays at a sphere of radius `r` centred at
/// `c`: the origin, direction and offset across the disk of ray `k`.
fn sphere_ray(c: DVec3, r: f64, k: usize) -> Ray {
    let dir = match k % 25 {
        0 => DVec3::X,
        1 => -DVec3::Z,
        _ => DVec3::new(
            (k as f64 * 0.7).sin(),
            (k as f64 * 1.3).cos(),
            0.4 + (k as f64 * 0.37).sin(),
        )
        .normalize(),
    };
    let offset = dir.any_orthogonal_vector().normalize() * (r * 0.97 * ((k % 20) as f64 / 19.0));
    Ray {
        origin: c - dir * 40.0 + offset,
        dir,
    }
}

/// Sampled spheres (a density with a smooth logistic profile, ½ on the sphere, and a
/// signed distance): every packed hit is within 10⁻³ voxel of the exact root of the
/// same reconstruction, and within 0.05 voxel of the analytic sphere (the trilinear
/// reconstruction's own error for a radius of 12 voxels, measured ≈ 0.02).
#[test]
fn sphere_hits_are_the_exact_roots_of_the_reconstruction() {
    for origin in [DVec3::ZERO, DVec3::splat(1e6)] {
        let centre_index = DVec3::new(19.3, 20.1, 19.7);
        let r = 12.0;
        let sdf = |p: DVec3| (p - centre_index).length() - r;
        for (kind, iso, bg) in [
            (ChannelKind::Density, 0.5, 0.0f32),
            (ChannelKind::SignedDistance, 0.0, 100.0),
        ] {
            let v = volume(origin, kind, bg, |p| match kind {
                ChannelKind::SignedDistance => sdf(p),
                _ => 1.0 / (1.0 + (sdf(p) / 1.5).exp()),
            });
            let field = Sampled::new(&v, Filter::Trilinear);
            let s = if kind == ChannelKind::SignedDistance { -1.0 } else { 1.0 };
            let c = origin + centre_index;
            let mut worst = (0.0f64, 0.0f64);
            for k in 0..150 {
                let ray = sphere_ray(c, r, k);
                let hit = packed_hit(&field, s, &ray, iso).unwrap_or_else(|| panic!("{kind:?} ray {k}: no hit"));
                let brute = brute_hit(&field, s, &ray, iso).expect("the reference hits");
                let oc = ray.origin - c;
                let b = -oc.dot(ray.dir);
                let exact = b - (b * b - (oc.length_squared() - r * r)).sqrt();
                let _ = exact;
                // Radial error: along the ray it grows as 1/cos at grazing incidence.
                let (e_rec, e_sphere) = ((hit - brute).abs(), ((ray.at(hit) - c).length() - r).abs());
                assert!(
                    e_rec < 1e-3,
                    "{kind:?} at {origin}: ray {k} {e_rec} voxel from the root"
                );
                assert!(
                    e_sphere < 0.05,
                    "{kind:?} at {origin}: ray {k} {e_sphere} voxel from the sphere"
                );
                worst = (worst.0.max(e_rec), worst.1.max(e_sphere));
            }
            eprintln!(
                "{kind:?} at {origin}: worst {:.2e} voxel from the root, {:.3} from the sphere",
                worst.0, worst.1
            );
        }
    }
}

/// A plane `n·p = d` as a signed distance and as a linear density ramp: trilinear
/// interpolation reproduces it exactly, so hits are within 10⁻⁶ voxel of the analytic
/// intersection, for rays in every octant and along the axes.
#[test]
fn plane_hits_are_exact() {
    let n = DVec3::new(0.3, -0.5, 0.81).normalize();
    for origin in [DVec3::ZERO, DVec3::splat(1e6)] {
        for kind in [ChannelKind::SignedDistance, ChannelKind::Density] {
            // Density increases along −n (inside where ≥ 0.5), distance along +n.
            let v = volume(origin, kind, 0.0, |p| match kind {
                ChannelKind::SignedDistance => n.dot(p) - 5.0,
                _ => 0.5 - 0.05 * (n.dot(p) - 5.0),
            });
            let field = Sampled::new(&v, Filter::Trilinear);
            let mut tested = 0;
            let (iso, s) = if kind == ChannelKind::SignedDistance {
                (0.0, -1.0)
            } else {
                (0.5, 1.0)
            };
            for k in 0..60 {
                let target = origin
                    + DVec3::new(
                        5.0 + (k % 7) as f64 * 4.1,
                        4.0 + (k % 5) as f64 * 5.3,
                        6.0 + (k % 3) as f64 * 9.0,
                    );
                // Project the target onto the plane, then shoot at it from the outside (+n side).
                let on = target - n * (n.dot(target - origin) - 5.0);
                let dir = match k % 6 {
                    0 => -DVec3::Y,
                    1 => DVec3::Z,
                    _ => (-n + 0.6 * DVec3::new((k as f64).sin(), (k as f64 * 2.1).cos(), (k as f64 * 0.3).sin()))
                        .normalize(),
                };
                if dir.dot(n) >= -1e-3 {
                    continue;
                }
                // Start inside the bounds on the outside of the plane.
                let ray = Ray {
                    origin: on - dir * 3.0,
                    dir,
                };
                let bounds = field.bounds();
                if !bounds.contains(ray.origin) || !bounds.contains(on) {
                    continue;
                }
                let hit = packed_hit(&field, s, &ray, iso).unwrap_or_else(|| panic!("{kind:?} ray {k}: no hit"));
                assert!((hit - 3.0).abs() < 1e-6, "{kind:?} at {origin}, ray {k}: {hit}");
                tested += 1;
            }
            assert!(tested >= 30, "{tested} rays tested");
        }
    }
}

/// The cube jumps, the active-box clip and the per-view start map never drop or move a
/// hit, ray by ray: over every pixel of random views of scattered blobs (orthographic and
/// perspective, eyes outside and inside the volume and inside a blob's solid interior, the
/// grid at the origin and at 1e6, an inside background meeting a blob cut by the bounds), the
/// masked walk started at the map's bound returns the same hit bits as the walk with
/// neither; the bound is never past the exact first crossing (`brute_hit`); and a tile the
/// map declares missed has no hit in any of its pixels.
#[test]
fn starts_jumps_and_clip_never_drop_a_hit() {
    use crate::{Camera, Projection};
    let blobs = [
        DVec3::new(9.0, 11.0, 8.0),
        DVec3::new(30.0, 28.0, 14.0),
        DVec3::new(21.0, 8.0, 31.0),
    ];
    // A large blob cut by the grid's face x = 39: a solid inside (blocks of inside
    // cells only) that reaches the bounds, where clipped rays start their walks.
    let (big, big_radius) = (DVec3::new(35.0, 22.0, 24.0), 9.0);
    let (width, height) = (48u32, 40u32);
    let tile = 8u32;
    // An inside background (1.0) makes the big blob's cut cells inside-only blocks at
    // the bounds, where clipped rays start.
    for (origin, background) in [(DVec3::ZERO, 0.0), (DVec3::splat(1e6), 0.0), (DVec3::ZERO, 1.0)] {
        let v = volume(origin, ChannelKind::Density, background, |p| {
            let d = blobs
                .iter()
                .map(|b| (p - *b).length() - 4.5)
                .fold(f64::INFINITY, f64::min);
            let d = d.min((p - big).length() - big_radius);
            1.0 / (1.0 + (d / 1.2).exp())
        });
        let field = Sampled::new(&v, Filter::Trilinear);
        let packed = PackedVolume::of_field(&field).expect("packs");
        let (iso, inward) = (0.5, 1.0);
        let mask = IsoCellMask::build(&packed, inward, iso);
        // The blobs' solid interiors: blocks the map projects only where a walk starts.
        assert!(!mask.inside_blocks().is_empty() && !mask.front_blocks().is_empty());
        let bounds = field.bounds();
        let centre = bounds.center();
        let (mut hits, mut tiles_missed, mut bounded) = (0u64, 0u64, 0u64);
        for k in 0..10 {
            let a = 0.9 * k as f64 + 0.3;
            let (eye, projection) = match k {
                // Eyes inside a blob's solid interior (cells all inside, in blocks the
                // map projects only where a walk can start): perspective, then an
                // orthographic eye plane cutting the blob.
                8 => (origin + blobs[1], Projection::Perspective { fov_y_deg: 60.0 }),
                9 => (origin + big, Projection::Orthographic { height_world: 40.0 }),
                _ => match k % 4 {
                    0 => (
                        centre + DVec3::new(a.cos(), 0.6, a.sin()) * 90.0,
                        Projection::Orthographic { height_world: 60.0 },
                    ),
                    1 => (
                        centre + DVec3::new(a.cos(), -0.4, a.sin()) * 80.0,
                        Projection::Perspective { fov_y_deg: 40.0 },
                    ),
                    // Eyes inside the volume: the map may know nothing, and must not lie.
                    2 => (
                        origin + DVec3::new(20.0, 20.0, 20.0),
                        Projection::Perspective { fov_y_deg: 70.0 },
                    ),
                    _ => (
                        centre + DVec3::new(0.0, 1.0, 1e-3) * 70.0,
                        Projection::Orthographic { height_world: 45.0 },
                    ),
                },
            };
            let target = centre + DVec3::new(0.3 * a.sin(), 0.2, -0.1) * 10.0;
            let camera = Camera::look_at(eye, target, DVec3::Y, projection).expect("camera");
            let starts = IsoStarts::build(&mask, &packed.grid().transform, &bounds, &camera, width, height);
            let mut hit_in_tile = vec![false; ((width / tile) * (height / tile)) as usize];
            for py in 0..height {
                for px in 0..width {
                    let ray = camera.ray(px as f64, py as f64, width, height);
                    let Some((t0, t1)) = bounds.ray_interval(ray.origin, ray.dir) else {
                        continue;
                    };
                    let t0 = t0.max(0.0);
                    let below = (t0 > 0.0).then_some((background as f64) < iso);
                    let start = starts.as_ref().map_or(f64::NEG_INFINITY, |s| s.start(&ray));
                    let (plain, _) = walk(&packed, &ray, inward, iso, (t0, t1), None, f64::NEG_INFINITY, below);
                    let (skipped, _) = walk(&packed, &ray, inward, iso, (t0, t1), Some(&mask), start, below);
                    assert_eq!(
                        plain.map(f64::to_bits),
                        skipped.map(f64::to_bits),
                        "view {k}, pixel ({px}, {py}), start {start}"
                    );
                    if let Some(t) = plain {
                        hits += 1;
                        hit_in_tile[((py / tile) * (width / tile) + px / tile) as usize] = true;
                        // The bound against an independent crossing (1/256-voxel steps).
                        if px % 2 == 0 && py % 2 == 0 && start.is_finite() {
                            let exact = brute_hit(&field, inward, &ray, iso).expect("the reference hits too");
                            assert!(
                                start <= exact,
                                "view {k}, pixel ({px}, {py}): start {start} after {exact}"
                            );
                            assert!((exact - t).abs() < 1e-3, "view {k}, pixel ({px}, {py}): {t} vs {exact}");
                            bounded += 1;
                        }
                    }
                }
            }
            if let Some(s) = &starts {
                for ty in 0..height / tile {
                    for tx in 0..width / tile {
                        let rect = (tx * tile, ty * tile, (tx + 1) * tile, (ty + 1) * tile);
                        if s.misses_pixels(&camera, rect, (width, height)) {
                            tiles_missed += 1;
                            assert!(
                                !hit_in_tile[(ty * (width / tile) + tx) as usize],
                                "view {k}, tile ({tx}, {ty})"
                            );
                        }
                    }
                }
            }
        }
        assert!(
            // (An inside background surrounds everything: no tile misses.)
            hits > 500 && (tiles_missed > 0 || background > 0.0) && bounded > 100,
            "{hits} {tiles_missed} {bounded}"
        );
    }
}
