//! Point and box queries of the reconstruction: the leaf at a point, distance, gradient,
//! closest point, inside, and conservative ranges over boxes.

use glam::DVec3;
use volga_core::Aabb;

use super::{octant, overlaps, trilinear, trilinear_gradient, LeafInfo};
use crate::Adf;

impl Adf {
    /// Leaves as `(world min, size, depth)`, in tree order.
    pub fn leaves(&self) -> Vec<(DVec3, f64, u8)> {
        let mut out = Vec::new();
        let mut stack = vec![(0u32, self.root_min, self.root_size, 0u8)];
        while let Some((i, min, size, depth)) = stack.pop() {
            let c = &self.cells[i as usize];
            if c.is_leaf() {
                out.push((min, size, depth));
            } else {
                let half = size * 0.5;
                for o in (0..8).rev() {
                    stack.push((c.children + o as u32, min + octant(o) * half, half, depth + 1));
                }
            }
        }
        out
    }

    /// The leaf containing `world_pos` (clamped into the root cube): its index, world
    /// minimum, size and depth.
    #[inline]
    pub(crate) fn locate(&self, world_pos: DVec3) -> (usize, DVec3, f64, u8) {
        let mut index = 0usize;
        let mut min = self.root_min;
        let mut size = self.root_size;
        let mut depth = 0u8;
        loop {
            let c = &self.cells[index];
            if c.is_leaf() {
                return (index, min, size, depth);
            }
            size *= 0.5;
            index = c.children as usize + crate::tree::child_octant(world_pos, &mut min, size);
            depth += 1;
        }
    }

    /// The leaf containing `world_pos` (clamped into the root cube).
    pub fn leaf_at(&self, world_pos: DVec3) -> LeafInfo {
        let (i, min, size, depth) = self.locate(self.clamp(world_pos));
        let c = &self.cells[i];
        let diagonal = size * 3f64.sqrt();
        let far = c
            .corners
            .iter()
            .all(|&v| (v as f64).abs() > diagonal + self.options.band);
        let positive = c.corners.iter().filter(|&&v| v > 0.0).count();
        LeafInfo {
            world_min: min,
            size,
            depth,
            jump: c.jump().is_some(),
            pruned: far && (positive == 0 || positive == 8) && depth < self.options.max_depth,
        }
    }

    fn clamp(&self, p: DVec3) -> DVec3 {
        p.clamp(self.root_min, self.root_min + DVec3::splat(self.root_size))
    }

    /// Reconstructed signed distance at `world_pos` (world units, negative inside). Outside
    /// the root cube: the value at the nearest point of the cube plus the distance to it
    /// (an upper bound of the true distance there, by the 1-Lipschitz property).
    pub fn distance(&self, world_pos: DVec3) -> f64 {
        let q = self.clamp(world_pos);
        let (i, min, size, _) = self.locate(q);
        let t = ((q - min) / size).clamp(DVec3::ZERO, DVec3::ONE);
        self.leaf_value(i, t) + (world_pos - q).length()
    }

    /// The reconstruction in leaf `i` at unit-cube coordinates `t`: trilinear, or, in a
    /// jump leaf, the trilinear magnitude with the sign of the trilinear sign field.
    #[inline]
    pub(crate) fn leaf_value(&self, i: usize, t: DVec3) -> f64 {
        let c = &self.cells[i];
        match c.jump() {
            None => trilinear(&c.corners, t),
            Some(k) => {
                let u = trilinear(&c.corners.map(f32::abs), t);
                if trilinear(&self.jumps[k], t) > 0.0 {
                    u
                } else {
                    -u
                }
            }
        }
    }

    /// Gradient (unit-cube coordinates) of [`Adf::leaf_value`].
    #[inline]
    fn leaf_gradient(&self, i: usize, t: DVec3) -> DVec3 {
        let c = &self.cells[i];
        match c.jump() {
            None => trilinear_gradient(&c.corners, t),
            Some(k) => {
                let g = trilinear_gradient(&c.corners.map(f32::abs), t);
                if trilinear(&self.jumps[k], t) > 0.0 {
                    g
                } else {
                    -g
                }
            }
        }
    }

    /// Gradient of the reconstruction (world units), the analytic derivative of the
    /// trilinear cell; outside the root cube, the gradient at the nearest cube point plus
    /// the direction away from the cube.
    pub fn gradient(&self, world_pos: DVec3) -> DVec3 {
        let q = self.clamp(world_pos);
        // The same leaf either way; the walk index (once a ray has built it) finds it faster.
        let (i, min, size) = match self.walk.0.get() {
            Some(ix) => self.locate_indexed(ix, q),
            None => {
                let (i, min, size, _) = self.locate(q);
                (i, min, size)
            }
        };
        let t = ((q - min) / size).clamp(DVec3::ZERO, DVec3::ONE);
        let g = self.leaf_gradient(i, t) / size;
        let away = world_pos - q;
        if away == DVec3::ZERO {
            g
        } else {
            g + away.normalize()
        }
    }

    /// The nearest surface point as the reconstruction sees it: `p − d·∇d/|∇d|` (exact for
    /// an exact distance field; `p` itself where the gradient vanishes).
    pub fn closest_point(&self, world_pos: DVec3) -> DVec3 {
        let d = self.distance(world_pos);
        let g = self.gradient(world_pos);
        let n = g.length();
        if n > 0.0 && n.is_finite() {
            world_pos - g * (d / n)
        } else {
            world_pos
        }
    }

    /// Whether `world_pos` is inside (reconstructed distance ≤ 0).
    pub fn inside(&self, world_pos: DVec3) -> bool {
        self.distance(world_pos) <= 0.0
    }

    /// `(min, max)` of the reconstruction over a world box (conservative: the true range
    /// lies inside). Leaves bound their reconstruction by their corner values; a box
    /// reaching outside the root cube gets `+∞` as its maximum.
    pub fn range(&self, world_box: &Aabb) -> (f64, f64) {
        let root = self.root_box();
        let clipped = world_box.intersection(&root);
        if clipped.is_empty() {
            // Entirely outside: at least the distance from the box to the cube's values.
            let gap = (world_box.min - root.max)
                .max(root.min - world_box.max)
                .max(DVec3::ZERO)
                .length();
            let (lo, _) = self.range(&Aabb::new(self.clamp(world_box.min), self.clamp(world_box.max)));
            return (lo + gap, f64::INFINITY);
        }
        let mut lo = f64::INFINITY;
        let mut hi = f64::NEG_INFINITY;
        let mut stack = vec![(0u32, self.root_min, self.root_size)];
        while let Some((i, min, size)) = stack.pop() {
            let cell_box = Aabb::new(min, min + DVec3::splat(size));
            if !overlaps(&cell_box, &clipped) {
                continue;
            }
            let c = &self.cells[i as usize];
            if c.is_leaf() {
                let (a, b) = c.corner_range();
                let (a, b) = if c.jump().is_some() {
                    (-a.abs().max(b.abs()), a.abs().max(b.abs()))
                } else {
                    (a, b)
                };
                lo = lo.min(a);
                hi = hi.max(b);
            } else {
                let half = size * 0.5;
                for o in 0..8 {
                    stack.push((c.children + o as u32, min + octant(o) * half, half));
                }
            }
        }
        let outside = world_box.min.cmplt(root.min).any() || world_box.max.cmpgt(root.max).any();
        (lo, if outside { f64::INFINITY } else { hi })
    }
}
