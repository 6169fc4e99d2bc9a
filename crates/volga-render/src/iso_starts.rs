//! Per view, where each ray of the packed iso path can first meet a cell that is not
//! outside: per front block of the cell mask (`iso_skip.rs`: a block holding a cell
//! with corners on both sides of the iso value, a **mixed** cell) the box of its mixed
//! cells, projected onto the image plane, keeping per image cell the least depth of
//! the boxes that cover it. The front faces of a volume's non-empty bricks rasterized
//! to give each ray its start (Krüger and Westermann, "Acceleration techniques for
//! GPU-based volume rendering", 2003), here in software and as a bound: a ray starts
//! its walk just before that depth, and a ray no box covers ends at once.
//!
//! **Why the first cell that is not outside is mixed.** The walk steps between cells
//! that share a face. If a cell is outside (all eight corners below the iso value) the
//! next one shares four corners below it, so it is not inside (all corners at or
//! above): the first cell that is not outside, after an outside one, is mixed (or has a
//! NaN corner, which counts as mixed). Only the walk's first cell has no predecessor;
//! it holds the ray's start, a point of the field's bounds or the ray's origin, so the
//! blocks of inside cells only that come within a cell of the bounds' faces or reach
//! the eye's plane are projected too (whole). The solid interior of a volume (most of
//! its non-empty blocks) is never projected, and a front block projects only the box of
//! its mixed cells, which is what brings a ray's start close to its first mixed cell.
//!
//! **Why the bound holds.** A ray `o + t·d` (unit `d`, `d·f > 0` for the camera's
//! forward `f`) that meets a box at `t` meets it at a point of depth
//! `z = (o + t·d − eye)·f`, so `t = (z − (o − eye)·f) / (d·f)`, and `z` is at least the
//! least depth of the box's corners (depth is linear, the box convex). Its image-plane
//! point `(u, v)` (`(x/z, y/z)` in the camera frame for a perspective camera, `(x, y)`
//! for an orthographic one) lies in the convex hull of the corners' points, so in their
//! bounding rectangle, which is grown by a thousandth of an image cell against
//! rounding. So every cell the walk passes before the least such `t` over the boxes is
//! outside, which is what the walk would find by reading it. The depth is rounded down
//! to `f32` and the start moved [`START_MARGIN_VOXELS`] plus [`START_MARGIN_RELATIVE`]
//! of the view's scale earlier (f64 rounding of the depths and parameters is ~1e-15 of
//! that scale), so rounding can only make the walk read more.
//!
//! Built once per [`Renderer::render`](crate::Renderer::render) call (the view is part
//! of the frame, so a benchmark frame pays for it), in parallel by bands of image rows;
//! the same map for any thread count (a minimum per image cell).

use glam::{DVec3, IVec3};
use rayon::prelude::*;
use volga_core::{Aabb, Transform};

use super::IsoCellMask;
use crate::{Camera, Projection, Ray};

/// How far before the bound a ray's walk starts, in voxels (of the largest spacing),
/// besides [`START_MARGIN_RELATIVE`] of the view's scale.
const START_MARGIN_VOXELS: f64 = 0.05;

/// The start margin's part relative to the view's scale (the largest distance of the
/// active box's corners from the eye): about 10⁶ times the f64 rounding of the
/// depths and ray parameters the bound is computed from.
const START_MARGIN_RELATIVE: f64 = 1e-9;

/// Image cells per side at most (larger images share cells between pixels).
const MAX_CELLS_PER_SIDE: u32 = 2048;

/// How far (in image cells) a box's rectangle is grown on every side.
const CELL_SLACK: f64 = 1e-3;

/// Rows of image cells per parallel band.
const BAND_ROWS: usize = 8;

/// The start map of one view (see the [module docs](self)).
pub(crate) struct IsoStarts {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    perspective: bool,
    /// Image-plane coordinates of the map's corner and image cells per unit.
    u0: f64,
    v0: f64,
    cells_per_u: f64,
    cells_per_v: f64,
    width: usize,
    height: usize,
    /// Per image cell (row-major), the least depth of the active boxes covering it,
    /// rounded down; `+∞` where none does.
    depth: Vec<f32>,
    margin: f64,
}

/// One projected box: image-cell rectangle (inclusive) and least corner depth.
#[derive(Clone, Copy)]
struct Footprint {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
    depth: f32,
}

impl IsoStarts {
    /// The map of `mask`'s front blocks (a grid with `transform`, rays clipped to
    /// `bounds`) for `camera`'s `width × height` image; `None` when it cannot bound
    /// anything (a box straddling the eye's plane of a perspective camera, a
    /// degenerate image plane).
    pub(crate) fn build(
        mask: &IsoCellMask,
        transform: &Transform,
        bounds: &Aabb,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> Option<IsoStarts> {
        let perspective = matches!(camera.projection(), Projection::Perspective { .. });
        let (w, h) = (width.clamp(1, MAX_CELLS_PER_SIDE), height.clamp(1, MAX_CELLS_PER_SIDE));
        let mut map = IsoStarts {
            eye: camera.eye(),
            forward: camera.forward(),
            right: camera.right(),
            up: camera.up(),
            perspective,
            u0: 0.0,
            v0: 0.0,
            cells_per_u: 0.0,
            cells_per_v: 0.0,
            width: w as usize,
            height: h as usize,
            depth: Vec::new(),
            margin: START_MARGIN_VOXELS * transform.spacing().max_element(),
        };
        // The image's extent on the plane, from the rays through its corners (pixel
        // edges: every pixel's and sub-pixel's ray lies within).
        let (fw, fh) = (width.max(1) as f64, height.max(1) as f64);
        let corners = [(-0.5, -0.5), (fw - 0.5, -0.5), (-0.5, fh - 0.5), (fw - 0.5, fh - 0.5)];
        let (mut u_lo, mut u_hi, mut v_lo, mut v_hi) =
            (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for (px, py) in corners {
            let (u, v) = map.ray_uv(&camera.ray(px, py, width, height))?;
            (u_lo, u_hi, v_lo, v_hi) = (u_lo.min(u), u_hi.max(u), v_lo.min(v), v_hi.max(v));
        }
        if !(u_hi > u_lo && v_hi > v_lo && (u_hi - u_lo).is_finite() && (v_hi - v_lo).is_finite()) {
            return None;
        }
        (map.u0, map.v0) = (u_lo, v_lo);
        map.cells_per_u = map.width as f64 / (u_hi - u_lo);
        map.cells_per_v = map.height as f64 / (v_hi - v_lo);

        map.margin += START_MARGIN_RELATIVE * map.view_scale(mask, transform)?;

        let starts_in = map.walk_start_region(transform, bounds);
        // Index boxes: the front blocks' mixed cells, the whole inside-only blocks.
        let whole = |b: IVec3| (b * 4 - IVec3::ONE, b * 4 + IVec3::splat(3));
        let prints: Vec<Option<Option<Footprint>>> = mask
            .front_blocks()
            .par_iter()
            .map(|&(lo, hi)| (lo, hi + IVec3::ONE))
            .chain(
                mask.inside_blocks()
                    .par_iter()
                    .map(|&b| whole(b))
                    .filter(|&b| starts_in(b)),
            )
            .map(|(lo, hi)| map.footprint(transform, lo, hi))
            .collect();
        let mut bands: Vec<Vec<Footprint>> = vec![Vec::new(); map.height.div_ceil(BAND_ROWS)];
        for p in prints {
            // `None`: a box straddles the eye's plane; no bound for this view.
            let Some(p) = p? else { continue };
            for band in bands.iter_mut().take(p.y1 / BAND_ROWS + 1).skip(p.y0 / BAND_ROWS) {
                band.push(p);
            }
        }
        let mut depth = vec![f32::INFINITY; map.width * map.height];
        depth
            .par_chunks_mut(map.width * BAND_ROWS)
            .zip(&bands)
            .enumerate()
            .for_each(|(band, (rows, prints))| {
                let y_first = band * BAND_ROWS;
                for p in prints {
                    for y in p.y0.max(y_first)..=p.y1.min(y_first + BAND_ROWS - 1) {
                        let row = &mut rows[(y - y_first) * map.width..][..map.width];
                        for d in &mut row[p.x0..=p.x1] {
                            *d = d.min(p.depth);
                        }
                    }
                }
            });
        map.depth = depth;
        Some(map)
    }

    /// The largest distance (any axis of the camera frame) of the active box's corners
    /// and of the image's corner rays' origins from the eye: what the rounding of this
    /// view's depths and ray parameters is relative to. `None` when not finite.
    fn view_scale(&self, mask: &IsoCellMask, transform: &Transform) -> Option<f64> {
        let (lo, hi) = mask.active_index_box()?;
        let (lo, hi) = (transform.index_to_world(lo), transform.index_to_world(hi));
        let mut scale = self.u0.abs().max(self.v0.abs());
        if !self.perspective {
            scale = scale
                .max((self.u0 + self.width as f64 / self.cells_per_u).abs())
                .max((self.v0 + self.height as f64 / self.cells_per_v).abs());
        }
        for corner in 0..8 {
            let p = DVec3::new(
                if corner & 1 == 0 { lo.x } else { hi.x },
                if corner & 2 == 0 { lo.y } else { hi.y },
                if corner & 4 == 0 { lo.z } else { hi.z },
            );
            scale = scale.max((p - self.eye).abs().max_element());
        }
        scale.is_finite().then_some(scale)
    }

    /// Whether a walk can start in an inside-only block's index box: the box (grown by a cell)
    /// reaches a face of `bounds` (where clipped rays start) or the eye's plane (where
    /// orthographic rays start; a perspective camera's eye is on it).
    fn walk_start_region<'t>(
        &self,
        transform: &'t Transform,
        bounds: &Aabb,
    ) -> impl Fn((IVec3, IVec3)) -> bool + Sync + 't {
        let (eye, forward, margin) = (self.eye, self.forward, self.margin);
        let (a, b) = (
            transform.world_to_index(bounds.min),
            transform.world_to_index(bounds.max),
        );
        // Index planes of the bounds, one cell inwards; a box wholly between them
        // holds no point of the faces.
        let (inner_lo, inner_hi) = (a.min(b) + 1.0, a.max(b) - 1.0);
        move |(lo, hi): (IVec3, IVec3)| {
            let (lo, hi) = (lo.as_dvec3() - 1.0, hi.as_dvec3() + 1.0);
            if !(lo.cmpgt(inner_lo).all() && hi.cmplt(inner_hi).all()) {
                return true;
            }
            // The box's least depth: at its centre less the half extents along the view.
            let (w_lo, w_hi) = (transform.index_to_world(lo), transform.index_to_world(hi));
            let centre = (w_lo + w_hi) * 0.5 - eye;
            let half = (w_hi - w_lo).abs() * 0.5;
            let z_lo = centre.dot(forward) - half.dot(forward.abs());
            z_lo.is_nan() || z_lo <= margin
        }
    }

    /// Image-plane coordinates of a camera ray (`None` if it does not look forward).
    #[inline(always)]
    fn ray_uv(&self, ray: &Ray) -> Option<(f64, f64)> {
        if self.perspective {
            let z = ray.dir.dot(self.forward);
            (z > 0.0).then(|| (ray.dir.dot(self.right) / z, ray.dir.dot(self.up) / z))
        } else {
            let rel = ray.origin - self.eye;
            Some((rel.dot(self.right), rel.dot(self.up)))
        }
    }

    /// The image-cell rectangle and least depth of the index box `[lo, hi]`;
    /// `Some(None)` when it covers no image cell or lies wholly behind the eye, `None`
    /// when it straddles the eye's plane (perspective).
    fn footprint(&self, transform: &Transform, lo: IVec3, hi: IVec3) -> Option<Option<Footprint>> {
        let lo = transform.index_to_world(lo.as_dvec3());
        let hi = transform.index_to_world(hi.as_dvec3());
        let (mut u_lo, mut u_hi, mut v_lo, mut v_hi) =
            (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        let (mut z_lo, mut z_hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for corner in 0..8 {
            let p = DVec3::new(
                if corner & 1 == 0 { lo.x } else { hi.x },
                if corner & 2 == 0 { lo.y } else { hi.y },
                if corner & 4 == 0 { lo.z } else { hi.z },
            );
            let rel = p - self.eye;
            let (x, y, z) = (rel.dot(self.right), rel.dot(self.up), rel.dot(self.forward));
            (z_lo, z_hi) = (z_lo.min(z), z_hi.max(z));
            let (u, v) = if self.perspective { (x / z, y / z) } else { (x, y) };
            (u_lo, u_hi, v_lo, v_hi) = (u_lo.min(u), u_hi.max(u), v_lo.min(v), v_hi.max(v));
        }
        if self.perspective && (z_lo.is_nan() || z_lo <= 0.0) {
            // Wholly behind the eye: no forward ray meets it at t ≥ 0.
            return if z_hi < 0.0 { Some(None) } else { None };
        }
        // The image cells the rectangle touches, grown by `CELL_SLACK` of a cell: far
        // more than the rounding of these coordinates and of a ray's (relative 1e-15
        // of at most `MAX_CELLS_PER_SIDE` cells).
        let cell = |value: f64, origin: f64, per: f64, n: usize, slack: f64| {
            // Clamped before the conversion (NaN, ±∞ and far values included).
            let c = ((value - origin) * per + slack).floor();
            c.clamp(-1.0, n as f64) as i64
        };
        let (x0, x1) = (
            cell(u_lo, self.u0, self.cells_per_u, self.width, -CELL_SLACK),
            cell(u_hi, self.u0, self.cells_per_u, self.width, CELL_SLACK),
        );
        let (y0, y1) = (
            cell(v_lo, self.v0, self.cells_per_v, self.height, -CELL_SLACK),
            cell(v_hi, self.v0, self.cells_per_v, self.height, CELL_SLACK),
        );
        let (w, h) = (self.width as i64, self.height as i64);
        if x1 < 0 || y1 < 0 || x0 >= w || y0 >= h || !(u_lo <= u_hi && v_lo <= v_hi) {
            return Some(None);
        }
        Some(Some(Footprint {
            x0: x0.max(0) as usize,
            x1: x1.min(w - 1) as usize,
            y0: y0.max(0) as usize,
            y1: y1.min(h - 1) as usize,
            depth: round_down_f32(z_lo),
        }))
    }

    /// A lower bound on the ray parameter where `ray` (a ray of this view's camera)
    /// first meets a cell that is not outside: `+∞` where no active box is met,
    /// `−∞` where the map knows nothing (outside its image, a ray not looking forward).
    #[inline]
    pub(crate) fn start(&self, ray: &Ray) -> f64 {
        let Some((u, v)) = self.ray_uv(ray) else {
            return f64::NEG_INFINITY;
        };
        let (x, y) = ((u - self.u0) * self.cells_per_u, (v - self.v0) * self.cells_per_v);
        if !(x >= 0.0 && y >= 0.0 && x < self.width as f64 && y < self.height as f64) {
            return f64::NEG_INFINITY;
        }
        let z = self.depth[y as usize * self.width + x as usize];
        if z == f32::INFINITY {
            return f64::INFINITY;
        }
        let along = ray.dir.dot(self.forward);
        if along.is_nan() || along <= 0.0 {
            return f64::NEG_INFINITY;
        }
        (z as f64 - (ray.origin - self.eye).dot(self.forward)) / along - self.margin
    }
}

impl IsoStarts {
    /// Whether every ray through the pixels `x0..x1 × y0..y1` (and their sub-pixels)
    /// of `camera`'s `width × height` image meets no active box: every image cell their
    /// image-plane points can fall in (the rectangle of the tile's corner rays, which
    /// bounds them: image-plane coordinates are affine in the pixel coordinates) holds
    /// `+∞`. False where the tile reaches beyond the map.
    pub(crate) fn misses_pixels(
        &self,
        camera: &Camera,
        (x0, y0, x1, y1): (u32, u32, u32, u32),
        (width, height): (u32, u32),
    ) -> bool {
        let (mut u_lo, mut u_hi, mut v_lo, mut v_hi) =
            (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
        for (px, py) in [(x0, y0), (x1, y0), (x0, y1), (x1, y1)] {
            let ray = camera.ray(px as f64 - 0.5, py as f64 - 0.5, width, height);
            let Some((u, v)) = self.ray_uv(&ray) else {
                return false;
            };
            (u_lo, u_hi, v_lo, v_hi) = (u_lo.min(u), u_hi.max(u), v_lo.min(v), v_hi.max(v));
        }
        let (cx0, cx1) = (
            ((u_lo - self.u0) * self.cells_per_u - CELL_SLACK).floor(),
            ((u_hi - self.u0) * self.cells_per_u + CELL_SLACK).floor(),
        );
        let (cy0, cy1) = (
            ((v_lo - self.v0) * self.cells_per_v - CELL_SLACK).floor(),
            ((v_hi - self.v0) * self.cells_per_v + CELL_SLACK).floor(),
        );
        if !(cx0 >= 0.0 && cy0 >= 0.0 && cx1 < self.width as f64 && cy1 < self.height as f64) {
            return false;
        }
        let (cx0, cx1, cy0, cy1) = (cx0 as usize, cx1 as usize, cy0 as usize, cy1 as usize);
        (cy0..=cy1).all(|y| {
            self.depth[y * self.width + cx0..=y * self.width + cx1]
                .iter()
                .all(|z| *z == f32::INFINITY)
        })
    }
}

/// The largest `f32` at most `x` (`−∞` for NaN).
fn round_down_f32(x: f64) -> f32 {
    if x.is_nan() {
        return f32::NEG_INFINITY;
    }
    let f = x as f32;
    if (f as f64) > x {
        // One step towards −∞ (x is finite here: ±∞ convert exactly).
        if f > 0.0 {
            f32::from_bits(f.to_bits() - 1)
        } else if f == 0.0 {
            -f32::from_bits(1)
        } else {
            f32::from_bits(f.to_bits() + 1)
        }
    } else {
        f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_down_never_rounds_up() {
        for x in [0.1f64, -0.1, 1e-50, -1e-50, 3.0, 1e39, -1e39, 16_777_217.0, 0.0] {
            let f = round_down_f32(x);
            assert!((f as f64) <= x, "{x} → {f}");
            assert!(f.is_finite() || x.abs() > f32::MAX as f64, "{x} → {f}");
        }
        assert_eq!(round_down_f32(f64::NAN), f32::NEG_INFINITY);
    }
}
