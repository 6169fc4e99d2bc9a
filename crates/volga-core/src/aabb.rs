use glam::DVec3;

/// An axis-aligned box in **world space**; `min ≤ max` on every axis for a non-empty box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lowest corner (world units); `+∞` on every axis for [`Aabb::EMPTY`].
    pub min: DVec3,
    /// Highest corner (world units); `−∞` on every axis for [`Aabb::EMPTY`].
    pub max: DVec3,
}

impl Aabb {
    /// The box with no points; the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    /// The box from `min` to `max` as given: not reordered or validated (`min > max` on
    /// an axis gives an empty box).
    pub fn new(min: DVec3, max: DVec3) -> Self {
        Aabb { min, max }
    }

    /// Whether the box holds no point: `min > max` on some axis. A flat box (equal `min`
    /// and `max` on an axis) is not empty.
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// The smallest box containing both (per-axis min of the mins, max of the maxes).
    /// [`Aabb::EMPTY`] is its identity; another empty box with finite corners is not,
    /// and can widen the result.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb::new(self.min.min(other.min), self.max.max(other.max))
    }

    /// The points in both boxes; empty (by [`Aabb::is_empty`], not equal to
    /// [`Aabb::EMPTY`]) if they are disjoint, flat if they only touch.
    pub fn intersection(&self, other: &Aabb) -> Aabb {
        Aabb::new(self.min.max(other.min), self.max.min(other.max))
    }

    /// Grow the box by `margin` (world units) on every side.
    pub fn expanded(&self, margin: DVec3) -> Aabb {
        Aabb::new(self.min - margin, self.max + margin)
    }

    /// Whether `world_pos` lies in the closed box (faces included). Always false for an
    /// empty box or a NaN position.
    pub fn contains(&self, world_pos: DVec3) -> bool {
        world_pos.cmpge(self.min).all() && world_pos.cmple(self.max).all()
    }

    /// Edge lengths `max − min` (world units), clamped to 0 on axes where the box is
    /// empty.
    pub fn size(&self) -> DVec3 {
        (self.max - self.min).max(DVec3::ZERO)
    }

    /// The midpoint `(min + max) / 2` (world units); NaN for [`Aabb::EMPTY`].
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// Parametric entry and exit of the ray `origin + t·dir` (slab method), clipped to
    /// `t ≥ 0`; `None` if the ray misses. Axis-parallel rays (a zero direction
    /// component) are handled without dividing by zero: such a ray either lies inside
    /// the slab for all `t` or misses.
    #[inline]
    pub fn ray_interval(&self, origin: DVec3, dir: DVec3) -> Option<(f64, f64)> {
        let mut t0 = 0.0f64;
        let mut t1 = f64::INFINITY;
        for a in 0..3 {
            let (o, d, lo, hi) = (origin[a], dir[a], self.min[a], self.max[a]);
            if d == 0.0 {
                if o < lo || o > hi {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d;
            let (mut ta, mut tb) = ((lo - o) * inv, (hi - o) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_interval_axis_parallel_and_grazing() {
        let b = Aabb::new(DVec3::ZERO, DVec3::ONE);
        assert_eq!(b.ray_interval(DVec3::new(0.5, 0.5, -1.0), DVec3::Z), Some((1.0, 2.0)));
        // Grazing along a face: inside the closed slab, so it hits.
        assert_eq!(b.ray_interval(DVec3::new(1.0, 0.5, -1.0), DVec3::Z), Some((1.0, 2.0)));
        assert_eq!(b.ray_interval(DVec3::new(1.5, 0.5, -1.0), DVec3::Z), None);
        assert_eq!(b.ray_interval(DVec3::new(0.5, 0.5, 3.0), DVec3::Z), None);
    }
}
