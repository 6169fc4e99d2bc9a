use glam::DVec3;

/// An axis-aligned box in **world space**; `min ≤ max` on every axis for a non-empty box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

impl Aabb {
    /// The box with no points; the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };

    pub fn new(min: DVec3, max: DVec3) -> Self {
        Aabb { min, max }
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb::new(self.min.min(other.min), self.max.max(other.max))
    }

    pub fn intersection(&self, other: &Aabb) -> Aabb {
        Aabb::new(self.min.max(other.min), self.max.min(other.max))
    }

    /// Grow the box by `margin` (world units) on every side.
    pub fn expanded(&self, margin: DVec3) -> Aabb {
        Aabb::new(self.min - margin, self.max + margin)
    }

    pub fn contains(&self, world_pos: DVec3) -> bool {
        world_pos.cmpge(self.min).all() && world_pos.cmple(self.max).all()
    }

    pub fn size(&self) -> DVec3 {
        (self.max - self.min).max(DVec3::ZERO)
    }

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
