//! Binary voxelization of 3D segments and polylines (survey §17.3), in index space.
//!
//! * [`LineConnectivity::TWENTY_SIX`]: the thin digital line of 3D Bresenham between the
//!   voxels containing the two endpoints (half-open rule `floor(x + ½)`): integer DDA
//!   with exact rounding, one voxel per step along the dominant axis, so consecutive voxels
//!   differ by 1 along it and by at most 1 along the others — 26-connected, with
//!   `max |Δ| + 1` voxels. Being a line between voxel centres, it lies within half a voxel
//!   diagonal of the exact segment.
//! * [`LineConnectivity::SIX`]: the supercover, every voxel whose closed cell
//!   `[ijk − ½, ijk + ½]` the closed segment meets. It is 6-connected; where the segment
//!   passes exactly through a cell edge or corner, every cell sharing it is included
//!   (that is what keeps it 6-connected).
//!
//! A zero-length segment gives the voxel containing the point (26), or every voxel whose
//! closed cell contains it (6).
//!
//! There is no 18-connected line here: the connectivity is an [`Adjacency`] checked
//! once by [`LineConnectivity::new`], which refuses 18 with [`UnsupportedAdjacency`].

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use volga_core::{Adjacency, Brick, ChannelKind, Grid, Progress, SparseVolume, BRICK_DIM, BRICK_VOXELS};

use crate::binary::clamp_i;

/// The connectivity of a digital line: an [`Adjacency`] the line voxelizer supports
/// (6 or 26), validated once by [`LineConnectivity::new`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LineConnectivity(Adjacency);

/// The line voxelizer has no line for this adjacency (18: the thin 26-line is not
/// 18-connected and the 6-connected supercover is not thin, so neither is "the"
/// 18-line).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnsupportedAdjacency(pub Adjacency);

impl std::fmt::Display for UnsupportedAdjacency {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "lines are 6- or 26-connected, not {}-connected", self.0)
    }
}

impl std::error::Error for UnsupportedAdjacency {}

impl LineConnectivity {
    /// Thin, 26-connected (3D Bresenham).
    pub const TWENTY_SIX: LineConnectivity = LineConnectivity(Adjacency::TwentySix);
    /// Every voxel the segment passes through; 6-connected.
    pub const SIX: LineConnectivity = LineConnectivity(Adjacency::Six);

    /// The line connectivity for `adjacency`: 6 or 26; 18 is refused.
    pub fn new(adjacency: Adjacency) -> Result<Self, UnsupportedAdjacency> {
        match adjacency {
            Adjacency::Six | Adjacency::TwentySix => Ok(LineConnectivity(adjacency)),
            Adjacency::Eighteen => Err(UnsupportedAdjacency(adjacency)),
        }
    }

    /// The adjacency of consecutive voxels: 6 or 26.
    pub fn adjacency(self) -> Adjacency {
        self.0
    }
}

impl TryFrom<Adjacency> for LineConnectivity {
    type Error = UnsupportedAdjacency;

    fn try_from(adjacency: Adjacency) -> Result<Self, Self::Error> {
        LineConnectivity::new(adjacency)
    }
}

#[inline]
fn round_half_up(v: DVec3) -> IVec3 {
    clamp_i((v + 0.5).floor())
}

/// Voxels of the segment `p → q` (index-space endpoints), in order from `p`.
pub fn segment_voxels(p: DVec3, q: DVec3, connectivity: LineConnectivity) -> Vec<IVec3> {
    if !(p.is_finite() && q.is_finite()) {
        return Vec::new();
    }
    match connectivity.0 {
        Adjacency::TwentySix => thin_line(p, q),
        // `LineConnectivity::new` admits only 6 and 26.
        Adjacency::Six | Adjacency::Eighteen => supercover(p, q),
    }
}

fn thin_line(p: DVec3, q: DVec3) -> Vec<IVec3> {
    // Integer DDA between the voxels holding the endpoints: voxel k is
    // vp + round(Δ·k/n) with n the largest |Δ|, rounded half up in exact integer
    // arithmetic, so every step moves 1 along the dominant axis and at most 1 along the
    // others.
    let (vp, vq) = (round_half_up(p), round_half_up(q));
    let delta = (vq - vp).as_i64vec3();
    let n = delta.abs().max_element();
    if n == 0 {
        return vec![vp];
    }
    (0..=n)
        .map(|k| {
            let num = delta * (2 * k) + glam::I64Vec3::splat(n);
            vp + num.div_euclid(glam::I64Vec3::splat(2 * n)).as_ivec3()
        })
        .collect()
}

/// Does the closed segment `p + t·delta` (t ∈ [0, 1]) meet the closed cell of `ijk`?
/// Separating-axis test with the cell's three axes and the three cross products of the
/// segment with them: only products and sums of the inputs, so inputs on a dyadic
/// lattice are decided exactly (a segment touching a cell edge or corner counts).
fn meets_cell(p: DVec3, delta: DVec3, ijk: IVec3) -> bool {
    let c = ijk.as_dvec3();
    let (a, b) = (p - c, p + delta - c);
    for axis in 0..3 {
        if a[axis].min(b[axis]) > 0.5 || a[axis].max(b[axis]) < -0.5 {
            return false;
        }
    }
    for e in [DVec3::X, DVec3::Y, DVec3::Z] {
        let n = delta.cross(e);
        // Both endpoints project to the same value on n; the cell to ±½‖n‖₁.
        let s = n.dot(a);
        if s.abs() > 0.5 * (n.x.abs() + n.y.abs() + n.z.abs()) {
            return false;
        }
    }
    true
}

/// Where the segment enters the cell (for ordering the voxels along the segment).
fn entry_parameter(p: DVec3, delta: DVec3, ijk: IVec3) -> f64 {
    let (lo, hi) = (ijk.as_dvec3() - 0.5, ijk.as_dvec3() + 0.5);
    let mut t0 = 0.0f64;
    for a in 0..3 {
        if delta[a] != 0.0 {
            let (ta, tb) = ((lo[a] - p[a]) / delta[a], (hi[a] - p[a]) / delta[a]);
            t0 = t0.max(ta.min(tb));
        }
    }
    t0.min(1.0)
}

fn supercover(p: DVec3, q: DVec3) -> Vec<IVec3> {
    let delta = q - p;
    let lo = (p.min(q) - 0.5).ceil();
    let hi = (p.max(q) + 0.5).floor();
    let (lo, hi) = (clamp_i(lo), clamp_i(hi));
    // Walk the slabs of the dominant axis; in each, test the (few) cells of the other
    // two axes that the slab's piece of the segment can reach.
    let d = crate::binary::dominant_axis(delta);
    let (u, w) = ((d + 1) % 3, (d + 2) % 3);
    let mut out: Vec<(f64, IVec3)> = Vec::new();
    for k in lo[d]..=hi[d] {
        let (s0, s1) = if delta[d] == 0.0 {
            (0.0, 1.0)
        } else {
            let ta = ((k as f64 - 0.5) - p[d]) / delta[d];
            let tb = ((k as f64 + 0.5) - p[d]) / delta[d];
            (ta.min(tb).max(0.0), ta.max(tb).min(1.0))
        };
        if s0 > s1 {
            continue;
        }
        let (e0, e1) = (p + delta * s0, p + delta * s1);
        let (ulo, uhi) = (
            (e0[u].min(e1[u]) - 0.5).ceil() as i32 - 1,
            (e0[u].max(e1[u]) + 0.5).floor() as i32 + 1,
        );
        let (wlo, whi) = (
            (e0[w].min(e1[w]) - 0.5).ceil() as i32 - 1,
            (e0[w].max(e1[w]) + 0.5).floor() as i32 + 1,
        );
        for cu in ulo.max(lo[u])..=uhi.min(hi[u]) {
            for cw in wlo.max(lo[w])..=whi.min(hi[w]) {
                let mut ijk = IVec3::ZERO;
                ijk[d] = k;
                ijk[u] = cu;
                ijk[w] = cw;
                if meets_cell(p, delta, ijk) {
                    out.push((entry_parameter(p, delta, ijk), ijk));
                }
            }
        }
    }
    // Order along the segment (ties by coordinate) so callers get a path order.
    out.sort_by(|a, b| {
        a.0.total_cmp(&b.0)
            .then_with(|| (a.1.z, a.1.y, a.1.x).cmp(&(b.1.z, b.1.y, b.1.x)))
    });
    out.dedup_by_key(|e| e.1);
    out.into_iter().map(|e| e.1).collect()
}

/// Voxelizes world-space segments on `grid` (density 1 on the line voxels, clipped to
/// the grid). Polylines are consecutive segments. Deterministic for any thread count.
pub fn voxelize_segments(
    grid: &Grid,
    segments: &[[DVec3; 2]],
    connectivity: LineConnectivity,
    progress: &dyn Progress,
) -> SparseVolume {
    let t = &grid.transform;
    progress.start("voxelize", segments.len() as u64);
    let mut voxels: Vec<IVec3> = segments
        .par_iter()
        .flat_map_iter(|[a, b]| {
            progress.inc(1);
            segment_voxels(t.world_to_index(*a), t.world_to_index(*b), connectivity)
                .into_iter()
                .filter(|v| grid.contains(*v))
        })
        .collect();
    progress.finish();
    voxels.par_sort_unstable_by_key(|v| (v.z >> 3, v.y >> 3, v.x >> 3, v.z, v.y, v.x));
    voxels.dedup();
    let mut volume = SparseVolume::new(*grid, 0.0, false).with_density_kind(ChannelKind::Binary);
    for group in voxels.chunk_by(|a, b| (*a >> 3) == (*b >> 3)) {
        let mut data = [0.0f32; BRICK_VOXELS];
        for v in group {
            data[Brick::<f32>::local_offset(*v)] = 1.0;
        }
        volume.density.insert_brick(group[0] >> 3, Brick::from_voxels(&data));
    }
    debug_assert_eq!(BRICK_DIM, 8);
    volume
}

/// Segments of a polyline through `points`.
pub fn polyline_segments(points: &[DVec3]) -> Vec<[DVec3; 2]> {
    if points.len() == 1 {
        return vec![[points[0], points[0]]];
    }
    points.windows(2).map(|w| [w[0], w[1]]).collect()
}
