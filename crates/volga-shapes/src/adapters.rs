//! Adapters from signed distances to [`Field`]s, and between fields.
//!
//! They are generic (monomorphised per shape), so sampling one is a direct call, not a
//! virtual call per sample.

use glam::DVec3;
use volga_core::{Aabb, Field, FieldKind};

use crate::{OrientedBoxFilter, SignedDistance};

/// Conservative `(min, max)` of a signed distance over a world box: the value at the
/// centre ± the half-diagonal for exact (1-Lipschitz) distances, unbounded otherwise.
pub(crate) fn distance_range<S: SignedDistance>(shape: &S, world_box: &Aabb) -> (f64, f64) {
    if !shape.is_exact() {
        return (f64::NEG_INFINITY, f64::INFINITY);
    }
    let d = shape.signed_distance(world_box.center());
    let r = world_box.size().length() * 0.5;
    (d - r, d + r)
}

/// A shape seen through the oriented box filter: value = `filter.density(d)`, 1 deep
/// inside, ½ on the surface, 0 beyond the half-width outside (survey §17.4). This is the
/// lazy counterpart of voxelizing the shape anti-aliased: a voxelized sample equals this
/// field's value at the voxel centre, rounded to `f32`.
#[derive(Debug, Clone)]
pub struct FilteredDensity<S> {
    shape: S,
    filter: OrientedBoxFilter,
    bounds: Aabb,
}

impl<S: SignedDistance> FilteredDensity<S> {
    /// The density of `shape`; its bounds are the shape's grown by the filter's
    /// half-width (infinite for unbounded quadrics: clip with [`Self::clipped`]).
    pub fn new(shape: S, filter: OrientedBoxFilter) -> Self {
        let bounds = shape.bounds().expanded(DVec3::splat(filter.half_width()));
        FilteredDensity { shape, filter, bounds }
    }

    /// The same field with its bounds intersected with `world_box` (outside it the
    /// value is the background 0).
    pub fn clipped(mut self, world_box: &Aabb) -> Self {
        self.bounds = self.bounds.intersection(world_box);
        self
    }

    /// The shape whose density this is.
    pub fn shape(&self) -> &S {
        &self.shape
    }
}

impl<S: SignedDistance + Sync> Field for FilteredDensity<S> {
    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn value(&self, world_pos: DVec3) -> f64 {
        self.filter.density(self.shape.signed_distance(world_pos))
    }

    /// The ramp is `2·half_width` wide: central differences a third of the half-width
    /// apart (one voxel of the grid the filter was made for) read it linearly.
    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.filter.half_width() / 3f64.sqrt())
    }

    /// The profile is monotone decreasing in the distance.
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        let (lo, hi) = distance_range(&self.shape, world_box);
        (self.filter.density(hi), self.filter.density(lo))
    }
}

/// A shape's signed distance as a field (world units, negative inside). Its bounds are
/// the shape's grown by `margin`; outside them the value is the background `margin`
/// (a lower bound of the true distance there).
#[derive(Debug, Clone)]
pub struct DistanceField<S> {
    shape: S,
    margin: f64,
    sample_spacing: f64,
    bounds: Aabb,
}

impl<S: SignedDistance> DistanceField<S> {
    /// `margin` (world units, > 0) grows the bounds so rays see the surface from outside;
    /// `sample_spacing` is the feature size rays and gradients are sampled at.
    pub fn new(shape: S, margin: f64, sample_spacing: f64) -> Self {
        let bounds = shape.bounds().expanded(DVec3::splat(margin));
        DistanceField {
            shape,
            margin,
            sample_spacing,
            bounds,
        }
    }

    /// The shape whose distance this is.
    pub fn shape(&self) -> &S {
        &self.shape
    }
}

impl<S: SignedDistance + Sync> Field for DistanceField<S> {
    fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// A signed distance (negative inside), so the renderer finds the inside where the
    /// value is ≤ the iso value and orients normals along `+∇`.
    fn kind(&self) -> FieldKind {
        FieldKind::SignedDistance
    }

    fn background(&self) -> f64 {
        self.margin
    }

    fn value(&self, world_pos: DVec3) -> f64 {
        self.shape.signed_distance(world_pos)
    }

    /// The shape's own gradient (analytic where the shape knows it), unit length.
    fn gradient(&self, world_pos: DVec3) -> DVec3 {
        self.shape.gradient(world_pos).normalize_or_zero()
    }

    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.sample_spacing)
    }

    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        distance_range(&self.shape, world_box)
    }
}

/// A field with its value negated: `−f(p)`, gradient `−∇f`, range `(−max, −min)`.
#[derive(Debug, Clone)]
pub struct Negated<F>(pub F);

impl<F: Field> Field for Negated<F> {
    fn bounds(&self) -> Aabb {
        self.0.bounds()
    }
    fn background(&self) -> f64 {
        -self.0.background()
    }
    fn value(&self, world_pos: DVec3) -> f64 {
        -self.0.value(world_pos)
    }
    fn gradient(&self, world_pos: DVec3) -> DVec3 {
        -self.0.gradient(world_pos)
    }
    fn gradient_step(&self) -> DVec3 {
        self.0.gradient_step()
    }
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        let (lo, hi) = self.0.value_range(world_box);
        (-hi, -lo)
    }
    fn has_colour(&self) -> bool {
        self.0.has_colour()
    }
    fn colour(&self, world_pos: DVec3) -> Option<glam::Vec3> {
        self.0.colour(world_pos)
    }
    fn sample_spacing(&self) -> f64 {
        self.0.sample_spacing()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Shape, Sphere};

    fn boxes() -> impl Iterator<Item = Aabb> {
        (0..60).map(|k| {
            let c = DVec3::new(k as f64 * 0.21 - 6.0, (k % 7) as f64 * 0.5 - 1.5, 0.3);
            Aabb::new(c - 0.4, c + 0.4)
        })
    }

    fn corners(b: &Aabb) -> impl Iterator<Item = DVec3> + '_ {
        (0..27).map(move |i| {
            let t = DVec3::new((i % 3) as f64, ((i / 3) % 3) as f64, (i / 9) as f64) * 0.5;
            b.min + t * b.size()
        })
    }

    #[test]
    fn ranges_are_conservative() {
        let s = Shape::Sphere(Sphere::new(DVec3::ZERO, 3.0).unwrap());
        let fd = FilteredDensity::new(s, OrientedBoxFilter::for_spacing(DVec3::splat(0.5)));
        let df = DistanceField::new(s, 1.0, 0.5);
        let neg = Negated(df.clone());
        for b in boxes() {
            for f in [&fd as &dyn Field, &df, &neg] {
                let (lo, hi) = f.value_range(&b);
                for p in corners(&b) {
                    let v = f.value(p);
                    assert!(lo <= v && v <= hi, "{v} outside [{lo}, {hi}]");
                }
            }
        }
    }

    #[test]
    fn density_is_half_on_the_surface_and_negation_flips() {
        let s = Sphere::new(DVec3::new(1e6, 0.0, 0.0), 2.0).unwrap();
        let fd = FilteredDensity::new(s, OrientedBoxFilter::for_spacing(DVec3::ONE));
        assert_eq!(fd.value(DVec3::new(1e6 + 2.0, 0.0, 0.0)), 0.5);
        assert_eq!(fd.value(DVec3::new(1e6, 0.0, 0.0)), 1.0);
        let df = DistanceField::new(s, 1.0, 0.5);
        let p = DVec3::new(1e6 + 3.0, 0.5, 0.0);
        assert_eq!(Negated(&df).value(p), -df.value(p));
        assert!((df.gradient(p) - (p - s.center()).normalize()).length() < 1e-12);
        assert_eq!(Negated(&df).gradient(p), -df.gradient(p));
    }
}
