//! [`DistanceSource`]: what the tools that consume a signed distance (ADFs,
//! hypertextures) ask of it, and [`ShapeSource`], any [`SignedDistance`] as one.

use glam::DVec3;
use volga_core::Aabb;

use crate::SignedDistance;

/// A signed distance in world units, negative inside, queried at world points, with
/// conservative ranges over world boxes.
///
/// `distance` must be a function of the point alone (deterministic results). Sources whose
/// values are exact Euclidean distances ([`DistanceSource::is_exact`]) are 1-Lipschitz:
/// over a box the distance lies within the value at its centre ± its half-diagonal (the
/// default [`DistanceSource::range`]); approximate sources (CSG trees, first-order
/// distances, sampled volumes) say so and give their own ranges or none.
///
/// Tools add what they need on top: `volga_adf::AdfSource` (the build's shortcuts) extends
/// this trait; `volga_texture::HyperTexture` uses it as it is.
pub trait DistanceSource: Sync {
    /// Signed distance at `world_pos` (world units, negative inside).
    fn distance(&self, world_pos: DVec3) -> f64;

    /// `(lo, hi)` containing every value of [`DistanceSource::distance`] over
    /// `world_box` (conservative; `±∞` where nothing is known). The default: for an
    /// exact source, the value at the box's centre ± the box's half-diagonal (the
    /// 1-Lipschitz bound); otherwise `(−∞, +∞)`.
    fn range(&self, world_box: &Aabb) -> (f64, f64) {
        if !self.is_exact() {
            return (f64::NEG_INFINITY, f64::INFINITY);
        }
        let d = self.distance(world_box.center());
        let r = world_box.size().length() * 0.5;
        (d - r, d + r)
    }

    /// World box containing every point where the distance is negative or zero (the
    /// object and its surface).
    fn bounds(&self) -> Aabb;

    /// Whether `distance` is the exact Euclidean signed distance (1-Lipschitz). `true`
    /// unless a source says otherwise.
    fn is_exact(&self) -> bool {
        true
    }
}

/// Forwards every [`DistanceSource`] method through a pointer, so `&S` and `Box<S>` can
/// never silently fall back to a default a new method adds (one list, both impls).
macro_rules! forward_distance_source {
    ($($ptr:ty),*) => {$(
        impl<S: DistanceSource + ?Sized> DistanceSource for $ptr {
            fn distance(&self, world_pos: DVec3) -> f64 {
                (**self).distance(world_pos)
            }
            fn range(&self, world_box: &Aabb) -> (f64, f64) {
                (**self).range(world_box)
            }
            fn bounds(&self) -> Aabb {
                (**self).bounds()
            }
            fn is_exact(&self) -> bool {
                (**self).is_exact()
            }
        }
    )*};
}

forward_distance_source!(&S, Box<S>);

/// A shape of the geometry layer as a [`DistanceSource`]: its signed distance, bounds and
/// exactness; ranges by the 1-Lipschitz bound when the shape is exact (unbounded
/// otherwise, e.g. a quadric's first-order distance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapeSource<S>(pub S);

impl<S: SignedDistance + Sync> DistanceSource for ShapeSource<S> {
    fn distance(&self, world_pos: DVec3) -> f64 {
        self.0.signed_distance(world_pos)
    }
    fn range(&self, world_box: &Aabb) -> (f64, f64) {
        crate::adapters::distance_range(&self.0, world_box)
    }
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
    fn is_exact(&self) -> bool {
        self.0.is_exact()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AxisBox, Quadric, Sphere};
    use glam::DMat3;

    /// A source that keeps every default: the range of an exact distance by the ball.
    struct Plane;

    impl DistanceSource for Plane {
        fn distance(&self, world_pos: DVec3) -> f64 {
            world_pos.x
        }
        fn bounds(&self) -> Aabb {
            Aabb::new(DVec3::splat(-1.0), DVec3::new(0.0, 1.0, 1.0))
        }
    }

    /// Ranges contain the values at the box's 27 lattice points, and are the exact
    /// ball bound: its ends are reached by the plane along a box diagonal's direction
    /// only, so here (x-aligned plane) they are the centre ± the half-diagonal exactly.
    #[test]
    fn ranges_contain_the_values_and_follow_exactness() {
        let ball = ShapeSource(Sphere::new(DVec3::new(0.5, -0.25, 0.0), 1.0).unwrap());
        let boxes = [
            Aabb::new(DVec3::new(-2.0, -1.0, 0.5), DVec3::new(-1.0, 0.5, 1.0)),
            Aabb::new(DVec3::splat(-0.25), DVec3::splat(0.75)),
        ];
        for b in &boxes {
            for source in [&ball as &dyn DistanceSource, &Plane] {
                let (lo, hi) = source.range(b);
                for i in 0..27 {
                    let t = DVec3::new((i % 3) as f64, ((i / 3) % 3) as f64, (i / 9) as f64) * 0.5;
                    let v = source.distance(b.min + t * b.size());
                    assert!(lo <= v && v <= hi, "{v} outside [{lo}, {hi}]");
                }
            }
            let (lo, hi) = Plane.range(b);
            let r = b.size().length() * 0.5;
            assert_eq!((lo, hi), (b.center().x - r, b.center().x + r));
        }
        // A quadric's distance is first order: no range.
        let clip = AxisBox::new(DVec3::splat(-1.0), DVec3::splat(1.0)).unwrap();
        let q = ShapeSource(Quadric::new(DMat3::IDENTITY, DVec3::ZERO, -0.5, clip).unwrap());
        assert!(!q.is_exact());
        assert_eq!(q.range(&boxes[1]), (f64::NEG_INFINITY, f64::INFINITY));
        // Through a pointer: the same answers.
        let by_ref = &ball;
        assert_eq!(DistanceSource::range(&by_ref, &boxes[0]), ball.range(&boxes[0]));
        let boxed: Box<dyn DistanceSource> = Box::new(ball);
        assert_eq!(DistanceSource::range(&boxed, &boxes[1]), ball.range(&boxes[1]));
        assert_eq!(boxed.is_exact(), ball.is_exact());
    }
}
