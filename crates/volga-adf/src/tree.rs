//! The ADF octree: cells with 8 corner distances (Frisken et al. 2000), the options and
//! statistics of a build, and the cell arithmetic the builder, the queries and the walks
//! share. The builder is the submodule `build`, the point and box queries `query`.

use glam::DVec3;
use volga_core::Aabb;

use crate::AdfError;

pub use estimate::{BuildEstimate, BUILD_BYTES_PER_CELL};

pub(crate) mod build;
mod estimate;
mod lattice;
mod query;

/// `children` of a leaf.
pub(crate) const LEAF: u32 = u32::MAX;

/// `children` of a jump leaf: this flag or'ed with the index of its sign-field corners in
/// [`Adf::jumps`]. Internal cells have `children < JUMP_FLAG`.
pub(crate) const JUMP_FLAG: u32 = 1 << 31;

/// The test points must meet this fraction of the tolerance. Frisken's criterion checks
/// only 19 points per cell; the reconstruction between them can miss by more (measured:
/// up to 1.1× the tolerance on a box's edges with a margin of 1). Half the tolerance at
/// the test points keeps every random point of the accuracy tests within the tolerance
/// (docs/ADF.md measures it), at about 1.4× the cells on curved surfaces.
pub const TEST_MARGIN: f64 = 0.5;

/// The deepest tree the cell arithmetic supports (cell sizes `root / 2^depth` stay exact
/// powers of two of the root size).
pub const MAX_SUPPORTED_DEPTH: u8 = 24;

/// One octree cell: the signed distances at its 8 corners (corner `b` is at
/// `min + size·(b&1, b>>1&1, b>>2&1)`), stored as `f32` payloads, and the index of its
/// first child (the 8 children are contiguous, in the same octant order) or [`LEAF`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Cell {
    pub corners: [f32; 8],
    pub children: u32,
}

impl Cell {
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.children >= JUMP_FLAG
    }

    /// The index of a jump leaf's sign-field corners.
    #[inline]
    pub fn jump(&self) -> Option<usize> {
        (self.children != LEAF && self.children >= JUMP_FLAG).then_some((self.children & !JUMP_FLAG) as usize)
    }

    /// `(min, max)` of the corner values: bounds the trilinear reconstruction anywhere in
    /// the cell (a convex combination of the corners).
    #[inline]
    pub fn corner_range(&self) -> (f64, f64) {
        let mut lo = f32::INFINITY;
        let mut hi = f32::NEG_INFINITY;
        for &c in &self.corners {
            lo = lo.min(c);
            hi = hi.max(c);
        }
        (lo as f64, hi as f64)
    }
}

/// How to build an ADF.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdfOptions {
    /// Largest accepted difference (world units) between the trilinear reconstruction and
    /// the source: a cell is split while it misses by more than `tolerance ·`
    /// [`TEST_MARGIN`] at any of its 19 test points (centre, 6 face centres, 12 edge
    /// midpoints).
    /// Must be finite and > 0 (0 would ask for exactness, which a trilinear cell reaches
    /// only on linear fields: the build would stop only at `max_depth` everywhere the
    /// surface is curved, so it is refused rather than silently bounded).
    pub tolerance: f64,
    /// Deepest level (the root is level 0); cells there are leaves whatever their error.
    pub max_depth: u8,
    /// Stop the build ([`AdfError::TooManyCells`]) once it would hold more cells than
    /// this: the guard behind [`Adf::estimate`], which is a model and can be low.
    /// [`crate::BuildEstimate::cells_within`] turns a memory budget into cells.
    pub max_cells: usize,
    /// Empty margin (world units) between the source's bounds and the root cube, so the
    /// reconstruction is defined around the whole surface. `None`: 5 % of the bounds'
    /// diagonal.
    pub margin: Option<f64>,
    /// Distance from the surface (world units) within which the tolerance must hold: a
    /// cell is pruned only if all its corners are of one sign and farther than its
    /// diagonal **plus** `band`, so every point within `band` of the surface lies in a
    /// tested leaf. 0 is Frisken's rule (accuracy at the surface only).
    pub band: f64,
}

impl AdfOptions {
    /// A tolerance given as a fraction of the bounds' diagonal (how the docs and the
    /// benchmarks state it), with the default depth 12 and a cell limit from the memory
    /// available.
    pub fn relative(tolerance_fraction: f64, bounds: &Aabb) -> Self {
        AdfOptions {
            tolerance: tolerance_fraction * bounds.size().length(),
            ..AdfOptions::default()
        }
    }

    pub(crate) fn check(&self) -> Result<(), AdfError> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(AdfError::Tolerance(self.tolerance));
        }
        if self.max_depth > MAX_SUPPORTED_DEPTH {
            return Err(AdfError::Depth(self.max_depth));
        }
        if !(self.band.is_finite() && self.band >= 0.0) {
            return Err(AdfError::Band(self.band));
        }
        if let Some(m) = self.margin {
            if !(m.is_finite() && m >= 0.0) {
                return Err(AdfError::Margin(m));
            }
        }
        Ok(())
    }
}

impl Default for AdfOptions {
    fn default() -> Self {
        AdfOptions {
            tolerance: 1e-3,
            max_depth: 12,
            max_cells: default_max_cells(),
            margin: None,
            band: 0.0,
        }
    }
}

/// Cells whose build fits in the memory available now ([`BUILD_BYTES_PER_CELL`] each;
/// at least 1 M).
fn default_max_cells() -> usize {
    let bytes = volga_core::memory::available_bytes().unwrap_or(8 << 30);
    BuildEstimate::cells_within(bytes).max(1 << 20)
}

/// What a build did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BuildStats {
    /// Cells in the tree (internal and leaves).
    pub cells: usize,
    /// Leaves among them (plain, pruned and jump leaves).
    pub leaves: usize,
    /// Leaves pruned as far from the surface (all corners of one sign, farther than the
    /// cell's diagonal): no test points were evaluated for them.
    pub pruned_leaves: usize,
    /// Leaves at `max_depth` (their error was not checked: the resolution limit).
    pub max_depth_leaves: usize,
    /// Leaves where the signed distance jumps away from any surface (an open mesh's
    /// inside changing across a hole): they store the source's sign field too.
    pub jump_leaves: usize,
    /// Deepest level reached.
    pub depth_reached: u8,
    /// Source distance evaluations.
    pub evaluations: u64,
}

/// Where a point falls in the tree ([`Adf::leaf_at`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafInfo {
    /// The leaf's minimum corner (world space).
    pub world_min: DVec3,
    /// Its edge length (world units): the root's size / 2^depth.
    pub size: f64,
    /// Its level (the root is level 0).
    pub depth: u8,
    /// A jump leaf (it stores the source's sign field).
    pub jump: bool,
    /// Pruned as far from the surface (no test points: the tolerance does not hold).
    pub pruned: bool,
}

/// An adaptively sampled distance field: an octree over a cube (the root), each cell
/// storing the signed distances at its corners; the distance anywhere is the trilinear
/// reconstruction in the leaf containing the point.
///
/// Geometry is `f64` world space (`world_*`); the root cube is `root_min + [0, root_size]³`
/// and a cell at depth `k` has size `root_size / 2^k` (exact). Stored distances are `f32`
/// payloads: their rounding (≤ 6e-8 of the value) is 100× below the smallest tolerance the
/// benchmarks use (1e-5 of the diagonal) and is included in every tolerance check, because
/// the build checks the reconstruction from the rounded corners.
#[derive(Clone, Debug, PartialEq)]
pub struct Adf {
    pub(crate) root_min: DVec3,
    pub(crate) root_size: f64,
    pub(crate) cells: Vec<Cell>,
    /// Sign-field corners of the jump leaves (see [`crate::AdfSource::sign_field`]).
    pub(crate) jumps: Vec<[f32; 8]>,
    pub(crate) options: AdfOptions,
    pub(crate) stats: BuildStats,
    /// The ray walk's index, built on the first ray ([`crate::walk`]).
    pub(crate) walk: crate::walk::WalkCache,
}

/// Trilinear reconstruction from 8 corners at unit-cube coordinates `t`.
#[inline]
pub(crate) fn trilinear(c: &[f32; 8], t: DVec3) -> f64 {
    let c = c.map(|v| v as f64);
    let x00 = c[0] + (c[1] - c[0]) * t.x;
    let x10 = c[2] + (c[3] - c[2]) * t.x;
    let x01 = c[4] + (c[5] - c[4]) * t.x;
    let x11 = c[6] + (c[7] - c[6]) * t.x;
    let y0 = x00 + (x10 - x00) * t.y;
    let y1 = x01 + (x11 - x01) * t.y;
    y0 + (y1 - y0) * t.z
}

/// Gradient of [`trilinear`] with respect to `t` (unit-cube coordinates).
#[inline]
pub(crate) fn trilinear_gradient(c: &[f32; 8], t: DVec3) -> DVec3 {
    let c = c.map(|v| v as f64);
    let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
    // d/dx: differences along x, interpolated in y and z
    let dx = lerp(
        lerp(c[1] - c[0], c[3] - c[2], t.y),
        lerp(c[5] - c[4], c[7] - c[6], t.y),
        t.z,
    );
    let dy = lerp(
        lerp(c[2] - c[0], c[3] - c[1], t.x),
        lerp(c[6] - c[4], c[7] - c[5], t.x),
        t.z,
    );
    let dz = lerp(
        lerp(c[4] - c[0], c[5] - c[1], t.x),
        lerp(c[6] - c[2], c[7] - c[3], t.x),
        t.y,
    );
    DVec3::new(dx, dy, dz)
}

impl Adf {
    /// The root cube (world space).
    pub fn root_box(&self) -> Aabb {
        Aabb::new(self.root_min, self.root_min + DVec3::splat(self.root_size))
    }

    /// The options it was built with.
    pub fn options(&self) -> &AdfOptions {
        &self.options
    }

    /// What the build (or the last edit) did.
    pub fn stats(&self) -> &BuildStats {
        &self.stats
    }

    /// Cells in the tree.
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }

    /// Bytes of the cell storage (8 `f32` corners and a child index per cell, and 8 `f32`
    /// sign-field corners per jump leaf).
    pub fn memory_bytes(&self) -> usize {
        self.cells.len() * std::mem::size_of::<Cell>() + self.jumps.len() * std::mem::size_of::<[f32; 8]>()
    }

    /// Size of a cell at `depth`.
    #[inline]
    pub fn cell_size(&self, depth: u8) -> f64 {
        // `root_size · 2^−depth`: the same real number as `root_size / 2^depth`, so the same
        // rounding and bits, by a multiplication (the walk asks it once per leaf).
        self.root_size * f64::from_bits((1023 - depth as u64) << 52)
    }
}

#[inline]
pub(crate) fn octant(o: usize) -> DVec3 {
    DVec3::new((o & 1) as f64, ((o >> 1) & 1) as f64, ((o >> 2) & 1) as f64)
}

#[inline]
pub(crate) fn corner_position(min: DVec3, size: f64, b: usize) -> DVec3 {
    min + octant(b) * size
}

/// Closed-box overlap (touching boxes overlap, so a query on a cell face sees both cells).
#[inline]
pub(crate) fn overlaps(a: &Aabb, b: &Aabb) -> bool {
    a.min.cmple(b.max).all() && b.min.cmple(a.max).all()
}

/// The octant (bit 0: x, bit 1: y, bit 2: z) of the child of the cell at `min` with
/// children of edge `child_size` that holds `world_pos`, moving `min` to that child's
/// minimum corner. Points on a mid-plane go to the upper child.
#[inline]
pub(crate) fn child_octant(world_pos: DVec3, min: &mut DVec3, child_size: f64) -> usize {
    let mid = *min + DVec3::splat(child_size);
    let mut o = 0;
    if world_pos.x >= mid.x {
        o |= 1;
        min.x = mid.x;
    }
    if world_pos.y >= mid.y {
        o |= 2;
        min.y = mid.y;
    }
    if world_pos.z >= mid.z {
        o |= 4;
        min.z = mid.z;
    }
    o
}
