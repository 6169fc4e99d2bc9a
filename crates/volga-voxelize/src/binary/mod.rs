//! Binary surface voxelization of triangles with a chosen separability (survey §17.2–17.3).
//!
//! ## The rule
//! Work in **index space** (voxel `ijk` is the unit cube centred on the integer point).
//! For separability `N`, let `K_N` be the convex hull of the half-steps `±o/2` of the
//! `N`-neighbourhood: the octahedron `|x|+|y|+|z| ≤ ½` for 6, the cuboctahedron for 18,
//! the cube `[−½, ½]³` for 26. A voxel `v` is black when the triangle `T` meets `v + K_N`.
//!
//! *Why it separates.* If two white `N`-adjacent voxels `v`, `v + o` had a connecting
//! segment crossing `T` at `q = v + λo`, then `q ∈ v + K_N` (λ ≤ ½) or `q ∈ v + o + K_N`
//! (λ ≥ ½), since `K_N` contains `±o/2`; so one of them would be black. Hence no
//! `N`-path of white voxels crosses the triangle, and a closed mesh voxelized this way is
//! `N`-separating (checked by flood fill in the tests).
//!
//! *The plane thresholds.* Inside the triangle, `T ∩ (v + K_N) ≠ ∅` reduces to
//! `|n̂·(v − a)| ≤ h_N(n̂)` with `h_N` the support function of `K_N`: `½‖n‖∞` (6),
//! half the sum of the two largest `|nᵢ|` (18), `½‖n‖₁` (26) — half the largest change
//! of `n̂·v` along one `N`-step, which is the largest step an `N`-path can take across the
//! plane. Near edges and vertices the same test is the exact Minkowski sum `T ⊕ K_N`,
//! which Huang, Yagel, Filippov & Kurzion (1998) approximate by edge cylinders and
//! vertex spheres of radius `max |K_N|` (the circumscribed ball); the exact sum is
//! contained in theirs, so it is never thicker and equally separating.
//!
//! *Rounding.* The arguments above assume exact arithmetic. Every closed interval is
//! widened by a relative ε (64 ulps of the coordinates' magnitude) and the half-open window
//! is shifted by −ε, so rounded near-ties err towards separating and covering; inputs on a
//! dyadic lattice never come within ε of a threshold and are decided exactly.
//!
//! *Ties.* A plane lying exactly on voxel faces touches two layers of closed
//! neighbourhoods. We use one half-open rule: orient the normal so its largest component
//! (lowest axis among equals) is positive, and keep `−h ≤ n·(v − a) < h`. An axis-aligned
//! plane through voxel centres or exactly on voxel faces then gives one layer. No tie rule
//! is invariant under reflections (the face plane `z = ½` must pick `z = 0` or `z = 1`), so
//! exact ties follow this orientation, except that a triangle lying exactly in the grid's
//! lower boundary face plane `x_k = −½` takes the layer `x_k = 0` inside the grid instead
//! of `x_k = −1` outside it; everything else is symmetric under the grid's
//! symmetries, and all comparisons use the unnormalized normal so inputs on a dyadic
//! lattice are decided in exact arithmetic.
//!
//! *Minimality.* For a plane the slab `−h ≤ n·(v − a) < h` has width exactly the largest
//! `N`-step, so every voxel has white `N`-neighbours on both sides: removing any one opens
//! a tunnel, the slab is `N`-minimal. Where triangles meet at an angle the union of their
//! neighbourhoods can hold `N`-simple voxels, so a mesh is minimal only where it is flat;
//! the topology validator reports the simple voxels.
//!
//! Degenerate triangles (zero area) are handled by the same separating-axis test with the
//! normal axis dropped: a segment or a point is voxelized as the voxels whose
//! neighbourhood it meets.
//!
//! ## Layout
//! * `separating`: the reference test of the rule, a separating-axis test of the
//!   triangle against `v + K_N` for any `N` ([`triangle_covers_voxel`]).
//! * `box26`: the same decisions specialised to 26-separability (the conservative box
//!   test), the path most meshes take.
//! * `raster`: the driver ([`voxelize_triangles`], [`voxelize_mesh_surface`]): triangles
//!   in coarse spatial order, rasterized in chunks into brick masks and merged.
//! * Here: the numeric helpers they share (voxel ranges, the canonical normal and its
//!   dominant axis).

use glam::{DVec3, IVec3};
use volga_core::Adjacency;

use crate::tri_distance::{ceil_i32, floor_i32};

mod box26;
mod raster;
mod separating;

pub use raster::{voxelize_mesh_surface, voxelize_mesh_surface_in, voxelize_triangles, voxelize_triangles_in};
use separating::PreparedTriangle;

/// Which white paths a voxelized surface must block (survey §17.2): the one
/// [`Adjacency`] type of `volga-core`, under the name the binary voxelizer has always
/// used (the CLI and tests name it so). The plane thresholds are
/// [`Adjacency::support`].
pub type Separability = Adjacency;

/// Is voxel `ijk` black for this single triangle (index-space coordinates)? The
/// reference predicate behind [`voxelize_triangles`], exposed for validators and tests.
pub fn triangle_covers_voxel(tri_index: [DVec3; 3], separability: Separability, ijk: IVec3) -> bool {
    PreparedTriangle::new(tri_index, separability).contains(ijk.as_dvec3())
}

/// Inclusive voxel range a triangle's neighbourhood test can pass: its bounding box grown
/// by ½ (every `K_N` fits in the cube `[−½, ½]³`) and by the rounding guard ε of the
/// face axes ([`separating::PreparedTriangle::new`]), computed as they compute it
/// (`fl(fl(lo − ½) − ε)`, `fl(fl(hi + ½) + ε)`), so the range holds exactly the voxels
/// that pass the cube's face axes. Without ε, a triangle in an axis plane a few ulp past
/// a voxel face (a flat mesh laid out on a grid whose faces it should lie on) passed the
/// normal window on one layer and the range on the other, and got no voxel at all.
fn voxel_range(a: DVec3, b: DVec3, c: DVec3) -> (IVec3, IVec3) {
    let m = upper(upper(a.abs(), b.abs()), c.abs());
    let eps = 64.0 * f64::EPSILON * (upper_f(upper_f(m.x, m.y), m.z) + 1.0);
    (
        round_clamped(lower(lower(a, b), c) - 0.5 - eps, ceil_i32),
        round_clamped(upper(upper(a, b), c) + 0.5 + eps, floor_i32),
    )
}

/// Lane-wise minimum and maximum of finite vectors by plain comparisons (the same
/// values as `DVec3::min`/`max`, without their NaN handling, which costs more than
/// the rest of a small triangle's preparation).
#[inline(always)]
fn lower(p: DVec3, q: DVec3) -> DVec3 {
    DVec3::select(p.cmplt(q), p, q)
}

#[inline(always)]
fn upper(p: DVec3, q: DVec3) -> DVec3 {
    DVec3::select(p.cmpgt(q), p, q)
}

#[inline(always)]
fn upper_f(p: f64, q: f64) -> f64 {
    if p > q {
        p
    } else {
        q
    }
}

/// The axis of the largest-magnitude component, the lowest axis among equals.
pub(crate) fn dominant_axis(n: DVec3) -> usize {
    let a = n.abs();
    if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    }
}

/// The half-open plane window `lo ≤ n·v < hi` for a triangle with canonical normal `n`,
/// plane threshold `h` and rounding guard `eps`: `d − h − ε ≤ n·v < d + h − ε` with
/// `d = n·a`. One exception to the tie rule: a triangle lying exactly in the plane
/// `x_k = −½` (index space) lies on the grid's lower boundary face, and the rule would
/// put its one layer at `x_k = −1`, outside every grid, leaving it uncovered. It takes
/// the layer `x_k = 0` instead: its window moves up by `2h`, one layer (its normal is
/// `|n_k| e_k`, so `2h = |n_k|` for every `N`). The upper boundary face `x_k = dims − ½`
/// already takes the layer inside.
fn plane_window(tri: [DVec3; 3], n: DVec3, h: f64, eps: f64) -> (f64, f64) {
    let d = n.dot(tri[0]);
    let on_lower_face = (0..3).any(|k| tri.iter().all(|p| p[k] == -0.5));
    let shift = if on_lower_face { 2.0 * h } else { 0.0 };
    (d - h - eps + shift, d + h - eps + shift)
}

/// The normal with its largest-magnitude component (lowest axis among equals) positive.
fn canonical(n: DVec3) -> DVec3 {
    let d = dominant_axis(n);
    if n[d] < 0.0 {
        -n
    } else {
        n
    }
}

pub(crate) fn clamp_i(v: DVec3) -> IVec3 {
    let lim = DVec3::splat((i32::MAX / 4) as f64);
    let c = upper(lower(v, lim), -lim);
    IVec3::new(c.x as i32, c.y as i32, c.z as i32)
}

/// `v` clamped to ±2²⁹ and rounded per component with `round` (`ceil_i32` or
/// `floor_i32`; without SSE4.1 `f64::ceil` is a libm call, and this is per triangle).
fn round_clamped(v: DVec3, round: fn(f64) -> i32) -> IVec3 {
    let lim = DVec3::splat((i32::MAX / 4) as f64);
    let c = upper(lower(v, lim), -lim);
    IVec3::new(round(c.x), round(c.y), round(c.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn support_functions_match_polytope_vertices() {
        let n = DVec3::new(0.3, -0.9, 0.5);
        assert_eq!(Separability::Six.support(n), 0.45);
        assert!((Separability::Eighteen.support(n) - 0.7).abs() < 1e-15);
        assert!((Separability::TwentySix.support(n) - 0.85).abs() < 1e-15);
    }

    /// A triangle lying in a face plane takes one layer: the one below by the tie rule,
    /// except on the grid's lower boundary face `x_k = −½`, where it takes layer 0
    /// (the layer below is outside the grid). Every separability, every axis, both
    /// the specialised 26-path and the general one (a degenerate triangle's segment is
    /// not affected).
    #[test]
    fn face_plane_triangles_take_one_layer_inside_the_grid() {
        use volga_core::{Grid, Transform};
        let grid = Grid::new(Transform::new(DVec3::ZERO, DVec3::ONE).unwrap(), glam::UVec3::splat(8)).unwrap();
        for k in 0..3 {
            for (plane, layer) in [(-0.5, 0), (3.5, 3), (7.5, 7)] {
                let corner = |u: f64, w: f64| {
                    let mut p = DVec3::ZERO;
                    p[k] = plane;
                    p[(k + 1) % 3] = u;
                    p[(k + 2) % 3] = w;
                    p
                };
                let tri = [corner(1.0, 1.0), corner(5.0, 1.0), corner(1.0, 5.0)];
                for sep in [Separability::Six, Separability::Eighteen, Separability::TwentySix] {
                    let volume = voxelize_triangles(&grid, &[tri], sep, &volga_core::NoProgress);
                    let mut layers = std::collections::BTreeSet::new();
                    for ijk in grid.index_box().iter() {
                        if volume.density.get(ijk) > 0.5 {
                            layers.insert(ijk[k]);
                        }
                    }
                    let expected: std::collections::BTreeSet<i32> = [layer].into();
                    assert_eq!(layers, expected, "axis {k}, plane {plane}, {sep}");
                }
            }
        }
    }

    #[test]
    fn canonical_normal_orientation() {
        assert_eq!(canonical(DVec3::new(0.0, 0.0, -2.0)), DVec3::new(0.0, 0.0, 2.0));
        assert_eq!(canonical(DVec3::new(-1.0, 1.0, 0.0)), DVec3::new(1.0, -1.0, 0.0));
        assert_eq!(canonical(DVec3::new(0.5, -1.0, 0.2)), DVec3::new(-0.5, 1.0, -0.2));
    }
}
