use glam::{DVec3, Vec3};

use crate::{Aabb, SampledVoxels};

/// What a [`Field`]'s value means, so consumers (the renderer, planners, exporters)
/// know which side of an iso value is the inside and which way the outward normal
/// points. Decided once per field, never per sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum FieldKind {
    /// A density that rises inwards (e.g. the oriented box filter's `clamp(½ − d/W)`):
    /// inside is `value ≥ iso`, the outward normal is `−∇value`.
    #[default]
    Density,
    /// A signed distance in world units, negative inside: inside is `value ≤ iso`,
    /// the outward normal is `+∇value`.
    SignedDistance,
    /// A 0/1 occupancy (1 inside); oriented like [`FieldKind::Density`].
    Binary,
}

impl FieldKind {
    /// `+1` if the value rises inwards (density, binary), `−1` if it falls inwards
    /// (signed distance). Multiplying values and iso values by it (an exact
    /// operation) turns every kind into "inside is `≥ iso`".
    #[inline]
    pub fn inward_sign(self) -> f64 {
        match self {
            FieldKind::Density | FieldKind::Binary => 1.0,
            FieldKind::SignedDistance => -1.0,
        }
    }

    /// The (unnormalized) outward direction of a level set given the value's
    /// gradient: `−∇` for values rising inwards, `+∇` for signed distances. Exact
    /// (a negation or the identity).
    #[inline]
    pub fn outward(self, gradient: DVec3) -> DVec3 {
        match self {
            FieldKind::Density | FieldKind::Binary => -gradient,
            FieldKind::SignedDistance => gradient,
        }
    }
}

/// Equally spaced world points `origin + i·step`, `i = 0, 1, …`: the sample lattice of
/// a ray, read in batches by [`Field::values_along`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// World position of point 0.
    pub origin: DVec3,
    /// World offset from one point to the next.
    pub step: DVec3,
}

impl Line {
    /// World position of point `i`.
    #[inline]
    pub fn at(&self, i: u64) -> DVec3 {
        self.origin + self.step * i as f64
    }
}

/// What [`Field::first_crossing`] found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Crossing {
    /// The field does not find crossings itself: march it (the default).
    NotProvided,
    /// No crossing in the interval.
    Miss,
    /// The first crossing, at this ray parameter.
    At(f64),
}

/// One ray of [`Field::first_crossings`]: `world_origin + t·world_dir`, `t ∈ [t0, t1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrossingRay {
    /// World position at `t = 0`.
    pub world_origin: DVec3,
    /// World direction; `t` is measured in multiples of it (need not be unit length).
    pub world_dir: DVec3,
    /// Start of the searched interval (ray parameter).
    pub t0: f64,
    /// End of the searched interval (ray parameter), `≥ t0` for a non-empty search.
    pub t1: f64,
}

/// The one sampling interface: everything the raycaster can render is a `Field`.
///
/// Positions are **world space** (`f64`). Values are densities, distances or
/// occupancies as `f64` ([`Field::kind`] says which), reconstructed from `f32`
/// payloads by the implementor. A new representation
/// (octree, ADF, CVG tree) joins the renderer by implementing this trait.
pub trait Field: Sync {
    /// World box outside which the field equals [`Field::background`].
    fn bounds(&self) -> Aabb;

    /// What the value means (which side is inside); default [`FieldKind::Density`].
    fn kind(&self) -> FieldKind {
        FieldKind::Density
    }

    /// Value far from the content (outside `bounds`).
    fn background(&self) -> f64 {
        0.0
    }

    /// Value at a world position.
    fn value(&self, world_pos: DVec3) -> f64;

    /// Values at the points `first + k` of `line`, `k < out.len()`: `out[k]` is the value
    /// at `line.at(first + k)`.
    ///
    /// The batch form of [`Field::value`], for runs of samples along a ray: a sampled
    /// field reads voxels brick by brick instead of looking each sample up. An
    /// implementation may compute the points its own way (e.g. in index space), so values
    /// may differ from `value(line.at(i))` by the rounding of the position, but each value
    /// must be a function of `line` and the point's index `i = first + k` alone — never of
    /// `first` or of the batch length — so a ray read in one batch or in many pieces gives
    /// the same bits (what lets the renderer skip empty space without changing the
    /// image). The default calls `value` at each point.
    fn values_along(&self, line: &Line, first: u64, out: &mut [f64]) {
        for (k, v) in out.iter_mut().enumerate() {
            *v = self.value(line.at(first + k as u64));
        }
    }

    /// Gradients at a batch of world points: `out[k]` is [`Field::gradient`] at
    /// `world_pos[k]` (the default calls it; sampled fields share voxel look-ups across
    /// the batch). Both slices have the same length.
    fn gradients_at(&self, world_pos: &[DVec3], out: &mut [DVec3]) {
        debug_assert_eq!(world_pos.len(), out.len());
        for (g, p) in out.iter_mut().zip(world_pos) {
            *g = self.gradient(*p);
        }
    }

    /// Gradient of the value with respect to world position. The default takes
    /// central differences of [`Field::value`] with steps [`Field::gradient_step`].
    fn gradient(&self, world_pos: DVec3) -> DVec3 {
        let h = self.gradient_step();
        let d = |axis: DVec3| (self.value(world_pos + axis) - self.value(world_pos - axis)) / (2.0 * axis.length());
        DVec3::new(d(DVec3::X * h.x), d(DVec3::Y * h.y), d(DVec3::Z * h.z))
    }

    /// Per-axis step for central-difference gradients (world units): the voxel
    /// spacing for sampled fields.
    fn gradient_step(&self) -> DVec3;

    /// A field equal to this one **bit for bit** (every method returns the same
    /// bits) that samples faster, built once before many rays: a renderer calls it
    /// once per prepared image and samples the result instead. A sampled volume
    /// returns itself over a [`BrickAtlas`](crate::BrickAtlas) (padded tiles, one table
    /// read per sample instead of a hash look-up). The default, `None`, means there is
    /// nothing to prepare (analytic fields) or it would not fit; callers then sample
    /// `self`.
    fn prepare(&self) -> Option<Box<dyn Field + '_>> {
        None
    }

    /// The first crossing of the `iso` level set from outside to inside (as
    /// [`Field::kind`] orients it) along `world_origin + t·world_dir`, `t ∈ [t0, t1]`,
    /// found by the field's own structure (an ADF walks its leaves and solves each
    /// trilinear cell's cubic exactly) instead of by marching samples. A value at `t0`
    /// already inside gives `t0`. The default, [`Crossing::NotProvided`], makes the
    /// renderer march the sample lattice as for any field.
    fn first_crossing(&self, _world_origin: DVec3, _world_dir: DVec3, _t0: f64, _t1: f64, _iso: f64) -> Crossing {
        Crossing::NotProvided
    }

    /// [`Field::first_crossing`] of many rays with one `iso`: `out[i]` is
    /// `first_crossing(rays[i].world_origin, rays[i].world_dir, rays[i].t0, rays[i].t1,
    /// iso)`, bit for bit. The renderer asks a tile's rays at once, so a field whose walk
    /// waits on memory can overlap the reads of several rays (an ADF does). The default
    /// answers ray by ray.
    fn first_crossings(&self, rays: &[CrossingRay], iso: f64, out: &mut [Crossing]) {
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.first_crossing(r.world_origin, r.world_dir, r.t0, r.t1, iso);
        }
    }

    /// The voxels this field reconstructs and how ([`SampledVoxels`]: the densities,
    /// the filter and the gradient method), when the field is exactly such a
    /// reconstruction, as a [`Sampled`](crate::Sampled) volume is. A consumer may then
    /// read the voxels into a layout of its own (the renderer's packed fast path copies
    /// trilinear, central-difference volumes). The default, `None`: the field is not a
    /// plain reconstruction of voxels (analytic, composed, adaptive…).
    fn voxels(&self) -> Option<SampledVoxels<'_>> {
        None
    }

    /// A conservative `(min, max)` of the value over a world box: the true range lies
    /// inside it. Used for empty-space skipping; `(-∞, ∞)` is always correct.
    fn value_range(&self, world_box: &Aabb) -> (f64, f64);

    /// Whether [`Field::colour`] returns colours.
    fn has_colour(&self) -> bool {
        false
    }

    /// Linear RGB colour at a world position, if the field carries colour.
    fn colour(&self, _world_pos: DVec3) -> Option<Vec3> {
        None
    }

    /// A length scale for sampling along rays (world units): the voxel size for
    /// sampled fields, the feature size for analytic ones.
    fn sample_spacing(&self) -> f64 {
        self.gradient_step().min_element()
    }
}

impl<F: Field + ?Sized> Field for &F {
    fn bounds(&self) -> Aabb {
        (**self).bounds()
    }
    fn kind(&self) -> FieldKind {
        (**self).kind()
    }
    fn background(&self) -> f64 {
        (**self).background()
    }
    fn value(&self, p: DVec3) -> f64 {
        (**self).value(p)
    }
    fn values_along(&self, line: &Line, first: u64, out: &mut [f64]) {
        (**self).values_along(line, first, out)
    }
    fn gradients_at(&self, world_pos: &[DVec3], out: &mut [DVec3]) {
        (**self).gradients_at(world_pos, out)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        (**self).gradient(p)
    }
    fn gradient_step(&self) -> DVec3 {
        (**self).gradient_step()
    }
    fn prepare(&self) -> Option<Box<dyn Field + '_>> {
        (**self).prepare()
    }
    fn voxels(&self) -> Option<SampledVoxels<'_>> {
        (**self).voxels()
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        (**self).value_range(b)
    }
    fn first_crossing(&self, o: DVec3, d: DVec3, t0: f64, t1: f64, iso: f64) -> Crossing {
        (**self).first_crossing(o, d, t0, t1, iso)
    }
    fn first_crossings(&self, rays: &[CrossingRay], iso: f64, out: &mut [Crossing]) {
        (**self).first_crossings(rays, iso, out)
    }
    fn has_colour(&self) -> bool {
        (**self).has_colour()
    }
    fn colour(&self, p: DVec3) -> Option<Vec3> {
        (**self).colour(p)
    }
    fn sample_spacing(&self) -> f64 {
        (**self).sample_spacing()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Ball(FieldKind);
    impl Field for Ball {
        fn kind(&self) -> FieldKind {
            self.0
        }
        fn bounds(&self) -> Aabb {
            Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0))
        }
        fn value(&self, p: DVec3) -> f64 {
            p.length() - 1.0
        }
        fn gradient_step(&self) -> DVec3 {
            DVec3::splat(0.01)
        }
        fn value_range(&self, _: &Aabb) -> (f64, f64) {
            (f64::NEG_INFINITY, f64::INFINITY)
        }
    }

    #[test]
    fn kind_defaults_to_density_and_is_forwarded_by_references() {
        struct Plain;
        impl Field for Plain {
            fn bounds(&self) -> Aabb {
                Aabb::new(DVec3::ZERO, DVec3::ONE)
            }
            fn value(&self, _: DVec3) -> f64 {
                0.0
            }
            fn gradient_step(&self) -> DVec3 {
                DVec3::ONE
            }
            fn value_range(&self, _: &Aabb) -> (f64, f64) {
                (0.0, 0.0)
            }
        }
        assert_eq!(Plain.kind(), FieldKind::Density);
        let sdf = Ball(FieldKind::SignedDistance);
        // Through the `&F` impl (a by-value generic, so the reference is the field).
        fn kind_of<F: Field>(f: F) -> FieldKind {
            f.kind()
        }
        assert_eq!(kind_of(&sdf), FieldKind::SignedDistance);
        let by_ref = &sdf;
        let by_ref_ref: &&Ball = &by_ref;
        assert_eq!(kind_of(by_ref_ref), FieldKind::SignedDistance);
    }

    #[test]
    fn outward_points_away_from_the_inside() {
        // At (1, 0, 0) on the unit sphere: the signed distance rises outwards, so its
        // gradient is the outward normal; a density of the same surface falls outwards.
        let p = DVec3::X;
        let g = Ball(FieldKind::SignedDistance).gradient(p);
        assert!(FieldKind::SignedDistance.outward(g).dot(p) > 0.99);
        assert!(FieldKind::Density.outward(-g).dot(p) > 0.99);
        assert_eq!(FieldKind::Binary.outward(g), -g);
        // inside ⟺ inward_sign·value ≥ inward_sign·iso, for each kind's own iso value
        for (k, iso, inside, outside) in [
            (FieldKind::Density, 0.5, 0.9, 0.1),
            (FieldKind::Binary, 0.5, 1.0, 0.0),
            (FieldKind::SignedDistance, 0.0, -0.3, 0.3),
        ] {
            let s = k.inward_sign();
            assert!(s * inside >= s * iso, "{k:?}");
            assert!(s * outside < s * iso, "{k:?}");
        }
    }
}
