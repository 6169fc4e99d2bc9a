//! Surface errors of a voxelized solid against its exact signed distance.
//!
//! The reconstructed surface is the ½ level set of the trilinear reconstruction,
//! triangulated by marching tetrahedra (six tetrahedra per cell of eight voxel
//! centres, split along the cell's main diagonal; exact for a field linear in the
//! cell). On that surface we measure:
//!
//! * **position**: the exact distance `|d(p)|` from the reconstructed surface to the
//!   true one, area-weighted RMS at triangle centroids and the maximum at vertices
//!   (world units);
//! * **normal**: the angle between the renderer's normal (central differences of the
//!   trilinear reconstruction, one voxel apart: `Field::gradient` of
//!   [`volga_core::Sampled`]) and the exact normal `∇d`, area-weighted RMS in degrees,
//!   in about [`NORMAL_SAMPLES`] / 2 cells (an evenly spread subset chosen by a hash
//!   of the cell);
//! * **area**: the triangulated surface's area against the exact area.
//!
//! Cells are visited brick by brick in sorted order and each brick's sums are added in
//! that order, so every figure is the same for any thread count.

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use rustc_hash::FxHashSet;
use volga_core::{Brick, Field, Filter, Sampled, SparseVolume, VoxelSource, BRICK_DIM};
use volga_shapes::SignedDistance;

/// About twice the number of cells whose triangles' normal error is evaluated (six
/// trilinear samples per triangle).
pub const NORMAL_SAMPLES: usize = 200_000;

/// The errors of one reconstructed surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceErrors {
    /// Area-weighted RMS of `|d|` at triangle centroids (world units).
    pub position_rms: f64,
    /// Largest distance between the two surfaces, both ways (a Hausdorff estimate,
    /// world units): the larger of `|d|` at the triangle vertices and
    /// [`SurfaceErrors::from_exact_max`].
    pub position_max: f64,
    /// Largest distance from the true surface to the reconstructed one, searched along
    /// the exact normal from projected sample points (world units; capped at
    /// [`SEARCH_VOXELS`] voxels where no crossing is found). It sees what the other
    /// direction cannot: a cone's tip cut off, a thin part missing.
    pub from_exact_max: f64,
    /// Area-weighted RMS angle between reconstructed and exact normals (degrees).
    pub normal_rms_deg: f64,
    /// Area of the triangulated level set (world units²).
    pub area: f64,
    /// Triangles of the level set's triangulation.
    pub triangles: u64,
}

/// The six tetrahedra of a cell (corner `c` is at offset `(c & 1, c >> 1 & 1, c >> 2 & 1)`),
/// sharing the diagonal 0–7.
const TETRAHEDRA: [[usize; 4]; 6] = [
    [0, 1, 3, 7],
    [0, 3, 2, 7],
    [0, 2, 6, 7],
    [0, 6, 4, 7],
    [0, 4, 5, 7],
    [0, 5, 1, 7],
];

/// Index-space offset of cell corner `c`.
fn corner(c: usize) -> DVec3 {
    DVec3::new((c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64)
}

/// Calls `emit` with each triangle (index-space corners relative to the cell's base voxel) of the
/// `iso` level set of the linear interpolant on the cell's tetrahedra.
fn cell_triangles(values: &[f64; 8], iso: f64, mut emit: impl FnMut([DVec3; 3])) {
    for tet in TETRAHEDRA {
        let inside: Vec<usize> = tet.iter().copied().filter(|&c| values[c] >= iso).collect();
        let outside: Vec<usize> = tet.iter().copied().filter(|&c| values[c] < iso).collect();
        let cut = |a: usize, b: usize| {
            let t = (iso - values[a]) / (values[b] - values[a]);
            corner(a) + (corner(b) - corner(a)) * t
        };
        match (inside.len(), outside.len()) {
            (1, 3) | (3, 1) => {
                let (lone, rest) = if inside.len() == 1 {
                    (inside[0], outside)
                } else {
                    (outside[0], inside)
                };
                emit([cut(lone, rest[0]), cut(lone, rest[1]), cut(lone, rest[2])]);
            }
            (2, 2) => {
                let (a, b, c, d) = (inside[0], inside[1], outside[0], outside[1]);
                let quad = [cut(a, c), cut(a, d), cut(b, d), cut(b, c)];
                emit([quad[0], quad[1], quad[2]]);
                emit([quad[0], quad[2], quad[3]]);
            }
            _ => {}
        }
    }
}

/// Per-brick sums, added in brick order.
#[derive(Debug, Default, Clone, Copy)]
struct Sums {
    area: f64,
    weighted_d2: f64,
    max_d: f64,
    triangles: u64,
    normal_weighted_a2: f64,
    normal_area: f64,
}

/// Bricks whose cells may cross the level set: a cell based in brick `b` reads bricks
/// `b + {0,1}³`; unless those are all absent or all the same uniform value, its cells
/// are visited.
fn candidate_bricks(volume: &SparseVolume) -> Vec<IVec3> {
    let stored = volume.density.sorted_bricks();
    let uniform_value = |b: IVec3| match volume.density.brick(b) {
        None => Some(volume.density.background()),
        Some(Brick::Uniform(v)) => Some(*v),
        Some(Brick::Dense(_)) => None,
    };
    let mut set = FxHashSet::default();
    for &b in &stored {
        for o in 0..8 {
            let base = b - corner(o).as_ivec3();
            if set.contains(&base) {
                continue;
            }
            let first = uniform_value(base);
            let same = first.is_some() && (1..8).all(|k| uniform_value(base + corner(k).as_ivec3()) == first);
            if !same {
                set.insert(base);
            }
        }
    }
    let mut out: Vec<IVec3> = set.into_iter().collect();
    out.sort_unstable_by_key(|b| (b.z, b.y, b.x));
    out
}

/// Whether cell (or voxel) `base` is in an evenly spread subset of about one in
/// `stride`, chosen by a hash of its coordinates (not by visiting order), so no
/// plane or row of the grid is favoured.
fn sampled_cell(base: IVec3, stride: u32) -> bool {
    let h = (base.x as u32).wrapping_mul(73_856_093)
        ^ (base.y as u32).wrapping_mul(19_349_663)
        ^ (base.z as u32).wrapping_mul(83_492_791);
    h.wrapping_mul(2_654_435_761) % stride == 0
}

/// Triangulates the `iso` level set of `volume`'s trilinear reconstruction and
/// measures it against `shape`'s exact signed distance.
pub fn surface_errors<S: SignedDistance + Sync>(volume: &SparseVolume, iso: f64, shape: &S) -> SurfaceErrors {
    let t = volume.grid.transform;
    let dims = volume.grid.dims().as_ivec3();
    let bricks = candidate_bricks(volume);
    // About 100 crossed cells per candidate brick; sample normals in ~NORMAL_SAMPLES / 2 cells.
    let stride = (bricks.len() * 200 / NORMAL_SAMPLES).max(1) as u32;
    let field = Sampled::new(volume, Filter::Trilinear);
    let per_brick: Vec<Sums> = bricks
        .par_iter()
        .map(|&b| {
            let mut sums = Sums::default();
            let lo = (b * BRICK_DIM).max(IVec3::ZERO);
            let hi = ((b + 1) * BRICK_DIM).min(dims - 1);
            for z in lo.z..hi.z {
                for y in lo.y..hi.y {
                    for x in lo.x..hi.x {
                        let ijk = IVec3::new(x, y, z);
                        let v = volume.density_cube(ijk).map(|v| v as f64);
                        let (mn, mx) = v
                            .iter()
                            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &c| (a.min(c), b.max(c)));
                        if !(mn < iso && mx >= iso) {
                            continue;
                        }
                        let with_normal = sampled_cell(ijk, stride);
                        cell_triangles(&v, iso, |index_tri| {
                            let w = index_tri.map(|c| t.index_to_world(ijk.as_dvec3() + c));
                            let area = 0.5 * (w[1] - w[0]).cross(w[2] - w[0]).length();
                            let world_centroid = (w[0] + w[1] + w[2]) / 3.0;
                            let d = shape.signed_distance(world_centroid);
                            sums.area += area;
                            sums.weighted_d2 += area * d * d;
                            for world_pos in w {
                                sums.max_d = sums.max_d.max(shape.signed_distance(world_pos).abs());
                            }
                            sums.triangles += 1;
                            if with_normal {
                                // Density rises inwards: the outward normal is −∇ρ.
                                let angle = angle_deg(-field.gradient(world_centroid), shape.gradient(world_centroid));
                                sums.normal_weighted_a2 += area * angle * angle;
                                sums.normal_area += area;
                            }
                        });
                    }
                }
            }
            sums
        })
        .collect();
    let mut total = Sums::default();
    for s in &per_brick {
        total.area += s.area;
        total.weighted_d2 += s.weighted_d2;
        total.max_d = total.max_d.max(s.max_d);
        total.triangles += s.triangles;
        total.normal_weighted_a2 += s.normal_weighted_a2;
        total.normal_area += s.normal_area;
    }
    let rms = |num: f64, den: f64| if den > 0.0 { (num / den).sqrt() } else { f64::NAN };
    let from_exact_max = from_exact_max(volume, iso, shape);
    SurfaceErrors {
        position_rms: rms(total.weighted_d2, total.area),
        position_max: total.max_d.max(from_exact_max),
        from_exact_max,
        normal_rms_deg: rms(total.normal_weighted_a2, total.normal_area),
        area: total.area,
        triangles: total.triangles,
    }
}

/// How far (voxels) [`from_exact_max`] searches along the normal for the reconstructed surface.
pub const SEARCH_VOXELS: f64 = 3.0;

/// Most true-surface samples [`from_exact_max`] takes (an evenly spaced subset).
const EXACT_SAMPLES: usize = 100_000;

/// Largest distance from the true surface to the reconstructed `iso` level set.
///
/// Sample points: the voxel centres of the volume's dense bricks within half a voxel
/// diagonal of the surface, projected onto it along the exact gradient (exact for an
/// exact signed distance). From each, the reconstruction is scanned along the exact
/// normal in quarter-voxel steps alternately outwards and inwards for the nearest
/// crossing of `iso` (refined by bisection). Where that finds none (at an apex or an
/// edge the normal can point away from the reconstruction), the exact distance to
/// the nearest reconstructed triangle nearby counts; none within [`SEARCH_VOXELS`]
/// voxels counts as that distance. Samples are taken in sorted brick order:
/// deterministic.
pub fn from_exact_max<S: SignedDistance + Sync>(volume: &SparseVolume, iso: f64, shape: &S) -> f64 {
    let t = volume.grid.transform;
    let voxel = t.spacing().max_element();
    let half_diagonal = 0.5 * t.spacing().length();
    let field = Sampled::new(volume, Filter::Trilinear);
    let grid_box = volume.grid.index_box();
    let dense: Vec<IVec3> = volume
        .density
        .sorted_bricks()
        .into_iter()
        .filter(|&b| matches!(volume.density.brick(b), Some(Brick::Dense(_))))
        .collect();
    // Roughly a quarter of a dense brick's voxels lie this close to the surface.
    let stride = (dense.len() * 128 / EXACT_SAMPLES).max(1) as u32;
    let maxima: Vec<f64> = dense
        .par_iter()
        .map(|&b| {
            let mut worst = 0.0f64;
            let cells = volga_core::brick_index_box(b).intersection(&grid_box);
            for ijk in cells.iter() {
                if !sampled_cell(ijk, stride) {
                    continue;
                }
                let world_voxel = t.voxel_center(ijk);
                let d = shape.signed_distance(world_voxel);
                let g = shape.gradient(world_voxel);
                let length = g.length();
                if d.abs() > half_diagonal || length.is_nan() || length <= 0.0 {
                    continue;
                }
                let normal = g.normalize();
                let world_surface = world_voxel - normal * d;
                let distance = distance_along(&field, iso, world_surface, normal, voxel)
                    .or_else(|| nearest_triangle(volume, iso, world_surface))
                    .unwrap_or(SEARCH_VOXELS * voxel);
                worst = worst.max(distance);
            }
            worst
        })
        .collect();
    maxima.into_iter().fold(0.0, f64::max)
}

/// Distance from `world_surface` along `±normal` to the nearest crossing of `iso` in
/// `field` (world units), if there is one within `SEARCH_VOXELS · voxel`.
fn distance_along<F: Field>(field: &F, iso: f64, world_surface: DVec3, normal: DVec3, voxel: f64) -> Option<f64> {
    let f = |s: f64| field.value(world_surface + normal * s) - iso;
    let step = 0.25 * voxel;
    let limit = SEARCH_VOXELS * voxel;
    let at_zero = f(0.0);
    if at_zero == 0.0 {
        return Some(0.0);
    }
    let mut k = 1.0;
    while k * step <= limit + 1e-12 * voxel {
        for sign in [1.0, -1.0] {
            let (near, far) = (sign * (k - 1.0) * step, sign * k * step);
            let (f_near, f_far) = (f(near), f(far));
            if (f_near < 0.0) != (f_far < 0.0) {
                let (mut a, mut b, fa) = (near, far, f_near);
                for _ in 0..50 {
                    let m = 0.5 * (a + b);
                    if (f(m) < 0.0) == (fa < 0.0) {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                return Some((0.5 * (a + b)).abs());
            }
        }
        k += 1.0;
    }
    None
}

/// Exact distance from `world_pos` to the nearest triangle of the reconstructed
/// surface in the cells within `SEARCH_VOXELS` of it, if any: the fallback where the
/// normal is not the way to the surface (at a cone's apex or rim every direction of
/// the normal cone is a normal, and a search along one may never meet the surface).
fn nearest_triangle(volume: &SparseVolume, iso: f64, world_pos: DVec3) -> Option<f64> {
    let t = volume.grid.transform;
    let centre = t.world_to_index(world_pos).floor().as_ivec3();
    let reach = IVec3::splat(SEARCH_VOXELS.ceil() as i32);
    let mut best = f64::INFINITY;
    for ijk in volga_core::IndexBox::new(centre - reach, centre + reach + 1).iter() {
        let v = volume.density_cube(ijk).map(|v| v as f64);
        cell_triangles(&v, iso, |index_tri| {
            let world_tri = index_tri.map(|c| t.index_to_world(ijk.as_dvec3() + c));
            best = best.min(volga_mesh::point_triangle_distance_squared(world_pos, world_tri));
        });
    }
    let limit = SEARCH_VOXELS * t.spacing().max_element();
    (best.sqrt() <= limit).then(|| best.sqrt())
}

/// Angle between two directions in degrees; 90° if either vanishes (no normal at all).
pub fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    let (la, lb) = (a.length(), b.length());
    if !(la > 0.0 && lb > 0.0 && la.is_finite() && lb.is_finite()) {
        return 90.0;
    }
    (a.dot(b) / (la * lb)).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Sum of densities × voxel volume: the volume a 0/1 or partial-volume voxelization
/// stands for (world units³).
pub fn density_volume(volume: &SparseVolume) -> f64 {
    volga_voxelize::measure::density_integral(volume)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::UVec3;
    use volga_core::{Grid, NoProgress};
    use volga_voxelize::{voxelize_shapes, SurfaceMode};

    use crate::references::{scene_box, ReferenceShape};

    /// A half-space as a shape: `d = n·p − offset`.
    struct Plane(DVec3, f64);
    impl SignedDistance for Plane {
        fn signed_distance(&self, p: DVec3) -> f64 {
            self.0.dot(p) - self.1
        }
        fn bounds(&self) -> volga_core::Aabb {
            scene_box()
        }
        fn gradient(&self, _: DVec3) -> DVec3 {
            self.0
        }
    }

    /// An anti-aliased plane is linear across its band, so marching tetrahedra
    /// reproduce it exactly: zero position error, and the area of the plane's section
    /// of the box the cells span. (Its normals are off at the grid's border, where
    /// central differences read the background.)
    #[test]
    fn a_linear_field_is_reconstructed_exactly() {
        let grid = Grid::covering(&scene_box(), UVec3::splat(32)).unwrap();
        let plane = Plane(DVec3::Z, 0.0123);
        let volume = voxelize_shapes(&grid, &[plane], SurfaceMode::Solid, &NoProgress);
        let e = surface_errors(&volume, 0.5, &Plane(DVec3::Z, 0.0123));
        let side = grid.center_bounds().size().x;
        assert!(e.position_max < 1e-6, "{e:?}");
        assert!((e.area - side * side).abs() < 1e-9, "{e:?} vs {}", side * side);
    }

    /// The sphere's reconstructed area converges to 4πr² and its surface to the
    /// sphere; its normals are within half a degree.
    #[test]
    fn sphere_surface_converges() {
        let shape = ReferenceShape::sphere();
        let mut last = f64::INFINITY;
        for n in [32, 64] {
            let grid = Grid::covering(&scene_box(), UVec3::splat(n)).unwrap();
            let volume = voxelize_shapes(&grid, &[shape], SurfaceMode::Solid, &NoProgress);
            let e = surface_errors(&volume, 0.5, &shape);
            let rel = (e.area / shape.area() - 1.0).abs();
            assert!(rel < 0.01, "N={n}: {e:?}");
            assert!(e.position_rms < 0.1 * grid.transform.spacing().x, "N={n}: {e:?}");
            assert!(e.position_rms < last);
            assert!(e.normal_rms_deg < 0.5, "N={n}: {e:?}");
            last = e.position_rms;
        }
    }

    /// Sums per brick in brick order: the same bits with 1 and 3 threads.
    #[test]
    fn figures_do_not_depend_on_the_thread_count() {
        let shape = ReferenceShape::torus();
        let grid = Grid::covering(&scene_box(), UVec3::splat(40)).unwrap();
        let volume = voxelize_shapes(&grid, &[shape], SurfaceMode::Solid, &NoProgress);
        let with = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| surface_errors(&volume, 0.5, &shape))
        };
        assert_eq!(with(1), with(3));
    }

    /// Both directions see a plane exactly; the one-sided distance misses a cone's cut
    /// tip that the search from the true surface finds.
    #[test]
    fn the_search_from_the_true_surface_sees_a_cut_tip() {
        let grid = Grid::covering(&scene_box(), UVec3::splat(32)).unwrap();
        let cone = ReferenceShape::cone();
        let binary = voxelize_shapes(&grid, &[cone], SurfaceMode::Inside, &NoProgress);
        let e = surface_errors(&binary, 0.5, &cone);
        let h = grid.transform.spacing().x;
        // Binary voxels miss the apex by about a voxel or more; the reconstructed
        // surface's own vertices stay within about half a voxel diagonal of the cone.
        assert!(e.from_exact_max > e.position_rms, "{e:?}");
        assert!(e.from_exact_max > 0.8 * h, "{e:?}");
        assert!(e.position_max >= e.from_exact_max);
    }

    #[test]
    fn angles() {
        assert!((angle_deg(DVec3::X, DVec3::Y) - 90.0).abs() < 1e-12);
        assert_eq!(angle_deg(DVec3::X, DVec3::X * 3.0), 0.0);
        assert_eq!(angle_deg(DVec3::ZERO, DVec3::X), 90.0);
    }
}
