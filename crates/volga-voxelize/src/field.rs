use glam::{DVec3, Vec3};
use volga_core::{Aabb, Field};

use crate::{OrientedBoxFilter, SignedDistance, Solid};

/// The fuzzy union of filtered solids evaluated directly, without voxels: an
/// unbounded-resolution procedural [`Field`] (the renderer can sample it like a volume).
///
/// `filter` sets the width of the density ramp (choose the voxel size the result
/// should be equivalent to); gradients are exact central differences of the profile.
#[derive(Debug, Clone)]
pub struct AnalyticField {
    solids: Vec<Solid>,
    filter: OrientedBoxFilter,
    bounds: Aabb,
}

impl AnalyticField {
    /// The union of `solids` filtered with `filter`; its bounds are the solids' grown
    /// by the filter's half-width.
    pub fn new(solids: Vec<Solid>, filter: OrientedBoxFilter) -> Self {
        let bounds = solids
            .iter()
            .fold(Aabb::EMPTY, |b, s| b.union(&s.shape.bounds()))
            .expanded(DVec3::splat(filter.half_width()));
        AnalyticField { solids, filter, bounds }
    }

    fn best(&self, p: DVec3) -> (f64, Option<&Solid>) {
        let mut best = (0.0, None);
        for s in &self.solids {
            let d = self.filter.density(s.shape.signed_distance(p));
            if d > best.0 {
                best = (d, Some(s));
            }
        }
        best
    }
}

impl Field for AnalyticField {
    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn value(&self, world_pos: DVec3) -> f64 {
        self.best(world_pos).0
    }

    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.filter.half_width() / 3f64.sqrt())
    }

    /// Each solid's signed distance varies by at most the box's half-diagonal around
    /// its centre (1-Lipschitz); the profile is monotone, and max preserves bounds.
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        let c = world_box.center();
        let r = world_box.size().length() * 0.5;
        let mut range = (0.0f64, 0.0f64);
        for s in &self.solids {
            if !s.shape.is_exact() {
                return (0.0, 1.0);
            }
            let d = s.shape.signed_distance(c);
            range.0 = range.0.max(self.filter.density(d + r));
            range.1 = range.1.max(self.filter.density(d - r));
        }
        range
    }

    fn has_colour(&self) -> bool {
        true
    }

    fn colour(&self, world_pos: DVec3) -> Option<Vec3> {
        let (_, s) = self.best(world_pos);
        Some(s.map_or(Vec3::ONE, |s| Vec3::from(s.colour)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::Sphere;
    use crate::Shape;

    #[test]
    fn value_range_is_conservative() {
        let f = AnalyticField::new(
            vec![Solid::new(
                Shape::Sphere(Sphere::new(DVec3::ZERO, 5.0).unwrap()),
                [1.0; 3],
            )],
            OrientedBoxFilter::for_spacing(DVec3::ONE),
        );
        for k in 0..50 {
            let c = DVec3::new(k as f64 * 0.3 - 7.0, 0.1 * k as f64 - 2.0, 0.5);
            let b = Aabb::new(c - 0.75, c + 0.75);
            let (lo, hi) = f.value_range(&b);
            for i in 0..27 {
                let o = DVec3::new((i % 3) as f64, ((i / 3) % 3) as f64, (i / 9) as f64) * 0.75 - 0.75;
                let v = f.value(c + o);
                assert!(lo <= v && v <= hi, "{v} not in [{lo}, {hi}]");
            }
        }
    }
}
