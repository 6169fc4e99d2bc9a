//! The sculpt as a [`Field`]: trilinear reconstruction of the voxel densities (background 0
//! outside the grid), density-weighted trilinear colour, and a conservative value range per
//! node, so the raycaster skips homogeneous regions.

use glam::{DVec3, IVec3, Vec3};
use volga_core::{Aabb, Field, FieldKind, IndexBox};

use crate::octree::{child_of, child_offset, Brick, Node, BRICK};
use crate::Sculpt;

impl Sculpt {
    /// Densities of the 2×2×2 voxels from `i0` (x fastest), background 0 outside the grid.
    /// Descends once while the whole stencil lies in one child; a uniform node answers all
    /// eight at once.
    fn stencil(&self, i0: IVec3) -> [f32; 8] {
        let dims = self.grid.dims();
        let inside = i0.cmpge(IVec3::ZERO).all() && (i0 + 1).cmplt(IVec3::splat(dims)).all();
        if !inside {
            return std::array::from_fn(|c| {
                let ijk = i0 + corner(c);
                if self.grid.index_box().contains(ijk) {
                    self.root.voxel(ijk, IVec3::ZERO, self.grid.levels()).density
                } else {
                    0.0
                }
            });
        }
        let (mut node, mut origin, mut level) = (&self.root, IVec3::ZERO, self.grid.levels());
        loop {
            match node {
                Node::Uniform(v) => return [v.density; 8],
                Node::Brick(b) => {
                    let local = i0 - origin;
                    if (local + 1).cmplt(IVec3::splat(BRICK)).all() {
                        return std::array::from_fn(|c| b.density[Brick::offset(local + corner(c))]);
                    }
                    break;
                }
                Node::Branch(children) => {
                    let k = child_of(i0, origin, level);
                    if child_of(i0 + 1, origin, level) != k {
                        break;
                    }
                    origin += child_offset(k, level);
                    node = &children[k];
                    level -= 1;
                }
            }
        }
        std::array::from_fn(|c| node.voxel(i0 + corner(c), origin, level).density)
    }
}

#[inline]
fn corner(c: usize) -> IVec3 {
    IVec3::new((c & 1) as i32, (c >> 1 & 1) as i32, (c >> 2 & 1) as i32)
}

/// Trilinear weights of the eight corners for fractional offsets `f`.
#[inline]
fn weights(f: DVec3) -> [f64; 8] {
    std::array::from_fn(|c| {
        let wx = if c & 1 == 0 { 1.0 - f.x } else { f.x };
        let wy = if c & 2 == 0 { 1.0 - f.y } else { f.y };
        let wz = if c & 4 == 0 { 1.0 - f.z } else { f.z };
        wx * wy * wz
    })
}

impl Field for Sculpt {
    /// From voxel −1's centre to voxel `dims`'s: beyond, every stencil is background.
    fn bounds(&self) -> Aabb {
        let h = self.grid.spacing();
        Aabb::new(
            self.grid.origin() - h,
            self.grid.origin() + DVec3::splat(self.grid.dims() as f64 * h),
        )
    }

    fn kind(&self) -> FieldKind {
        FieldKind::Density
    }

    fn value(&self, world_pos: DVec3) -> f64 {
        let index = self.grid.world_to_index(world_pos);
        if !index.is_finite() {
            return 0.0;
        }
        let lo = index.floor();
        let dims = self.grid.dims() as f64;
        if lo.cmplt(DVec3::splat(-1.0)).any() || lo.cmpge(DVec3::splat(dims)).any() {
            return 0.0;
        }
        let d = self.stencil(lo.as_ivec3());
        let (min, max) = d.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        if min == max {
            return min as f64; // homogeneous stencil: exact, no rounding of the weights
        }
        let w = weights(index - lo);
        // Clamped to the stencil's range (the weights' sum may round above 1), so
        // `value_range`'s voxel bounds hold exactly.
        (0..8)
            .map(|c| w[c] * d[c] as f64)
            .sum::<f64>()
            .clamp(min as f64, max as f64)
    }

    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.grid.spacing())
    }

    /// Min and max stored density over the voxels whose stencils reach the box (plus the
    /// background 0 if the box reaches outside the grid): trilinear values lie between them.
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        let lo = self.grid.world_to_index(world_box.min).floor();
        let hi = self.grid.world_to_index(world_box.max).floor() + 1.0;
        if !(lo.is_finite() && hi.is_finite()) {
            return (0.0, 1.0);
        }
        let dims = self.grid.dims() as f64;
        let clamp = |v: DVec3| v.clamp(DVec3::splat(-1.0), DVec3::splat(dims + 1.0)).as_ivec3();
        let query = IndexBox::new(clamp(lo), clamp(hi) + 1);
        let grid = self.grid.index_box();
        let inner = query.intersection(&grid);
        let outside = inner != query;
        let mut range = if outside { Some((0.0f32, 0.0f32)) } else { None };
        if let Some((a, b)) = self.root.density_range(&inner, IVec3::ZERO, self.grid.levels()) {
            range = Some(range.map_or((a, b), |(x, y)| (x.min(a), y.max(b))));
        }
        range.map_or((0.0, 0.0), |(a, b)| (a as f64, b as f64))
    }

    fn has_colour(&self) -> bool {
        true
    }

    /// Density-weighted trilinear colour (empty voxels do not darken a surface).
    fn colour(&self, world_pos: DVec3) -> Option<Vec3> {
        let index = self.grid.world_to_index(world_pos);
        if !index.is_finite() {
            return None;
        }
        let lo = index.floor();
        let w = weights(index - lo);
        let i0 = lo.as_ivec3();
        let (mut sum, mut weight) = (DVec3::ZERO, 0.0);
        for (c, wc) in w.iter().enumerate() {
            let ijk = i0 + corner(c);
            if !self.grid.index_box().contains(ijk) {
                continue;
            }
            let v = self.root.voxel(ijk, IVec3::ZERO, self.grid.levels());
            let k = wc * v.density as f64;
            sum += DVec3::from(v.colour.map(f64::from)) * k;
            weight += k;
        }
        (weight > 0.0).then(|| (sum / weight).as_vec3())
    }
}
