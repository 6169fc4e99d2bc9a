//! Accuracy of the packed iso path's hits against exact references: the exact root of
//! the same trilinear reconstruction (found independently by dense sampling and
//! bisection of `Sampled::value` in `f64`), an analytic plane (which trilinear
//! interpolation reproduces exactly) and the analytic sphere (within the reconstruction's
//! own error), for densities and signed distances, near the origin and at 10⁶.

use glam::{DVec3, UVec3};
use volga_core::{ChannelKind, Field, Filter, Grid, Sampled, SparseVolume, Transform};

use super::{march_iso_packed, IsoCellMask};
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

/// The packed path's first crossing along `ray` (the renderer's clip and tolerance).
/// `inward` is the sign of the inside (`−1`: a signed distance; sampled volumes are
/// densities to `Field::kind`, so the orientation is passed as the renderer would).
fn packed_hit(field: &dyn Field, inward: f64, ray: &Ray, iso: f64) -> Option<f64> {
    let packed = field.pack().expect("packs");
    let (t0, t1) = field.bounds().ray_interval(ray.origin, ray.dir)?;
    let t0 = t0.max(0.0);
    let bg = field.background();
    let below = (t0 > 0.0).then_some(inward * bg < inward * iso);
    let mut stats = RenderStats::default();
    let hit = march_iso_packed(
        &packed,
        ray,
        inward,
        iso,
        (t0, t1),
        1e-9,
        None,
        f64::NEG_INFINITY,
        below,
        &mut stats,
    );
    // The cell mask only spares reads: the same hit, bit for bit, with fewer cells read.
    let mask = IsoCellMask::build(&packed, inward, iso);
    let mut masked = RenderStats::default();
    let with_mask = march_iso_packed(
        &packed,
        ray,
        inward,
        iso,
        (t0, t1),
        1e-9,
        Some(&mask),
        f64::NEG_INFINITY,
        below,
        &mut masked,
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
