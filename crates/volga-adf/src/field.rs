//! An ADF is a [`Field`] of signed-distance kind: the raycaster renders it directly.

use glam::DVec3;
use volga_core::{Aabb, Crossing, CrossingRay, Field, FieldKind, Line};

use crate::Adf;

impl Field for Adf {
    /// The root cube.
    fn bounds(&self) -> Aabb {
        self.root_box()
    }

    fn kind(&self) -> FieldKind {
        FieldKind::SignedDistance
    }

    /// Outside the root cube the surface is at least this far (the cube's side).
    fn background(&self) -> f64 {
        self.root_size
    }

    fn value(&self, world_pos: DVec3) -> f64 {
        self.distance(world_pos)
    }

    /// Walks the run leaf by leaf: a point inside the leaf of the previous one reuses it
    /// instead of descending from the root (the value is the same function of the point).
    fn values_along(&self, line: &Line, first: u64, out: &mut [f64]) {
        let root = self.root_box();
        let mut leaf: Option<(usize, DVec3, f64)> = None;
        for (k, v) in out.iter_mut().enumerate() {
            let p = line.at(first + k as u64);
            if !root.contains(p) {
                *v = self.distance(p);
                continue;
            }
            let (i, min, size) = match leaf {
                Some((i, min, size)) if p.cmpge(min).all() && p.cmplt(min + DVec3::splat(size)).all() => (i, min, size),
                _ => {
                    let (i, min, size, _) = self.locate(p);
                    leaf = Some((i, min, size));
                    (i, min, size)
                }
            };
            *v = self.leaf_value(i, ((p - min) / size).clamp(DVec3::ZERO, DVec3::ONE));
        }
    }

    /// The trilinear cell's analytic derivative.
    fn gradient(&self, world_pos: DVec3) -> DVec3 {
        Adf::gradient(self, world_pos)
    }

    fn gradient_step(&self) -> DVec3 {
        DVec3::splat(self.cell_size(self.stats.depth_reached))
    }

    /// The leaf walk with exact cubic roots ([`Adf::first_crossing_between`]): a few
    /// leaves per ray instead of a sample every [`Field::sample_spacing`].
    fn first_crossing(&self, world_origin: DVec3, world_dir: DVec3, t0: f64, t1: f64, iso: f64) -> Crossing {
        let ray = CrossingRay {
            world_origin,
            world_dir,
            t0,
            t1,
        };
        crossing(&ray, || {
            self.first_crossing_between(world_origin, world_dir, t0, t1, iso).0
        })
    }

    /// The batched leaf walk ([`Adf::first_crossings_between`]): the same answers as
    /// [`Field::first_crossing`] ray by ray, with the rays' memory reads overlapped.
    fn first_crossings(&self, rays: &[CrossingRay], iso: f64, out: &mut [Crossing]) {
        let walked: Vec<CrossingRay> = rays.iter().filter(|r| walkable(r)).copied().collect();
        let mut answers = vec![(None, 0u32); walked.len()];
        self.first_crossings_between(&walked, iso, &mut answers);
        let mut answers = answers.into_iter();
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = crossing(r, || answers.next().expect("one answer per walked ray").0);
        }
    }

    /// Per-leaf corner ranges (conservative), so iso rendering skips every macro cell the
    /// surface does not reach.
    fn value_range(&self, world_box: &Aabb) -> (f64, f64) {
        self.range(world_box)
    }

    /// The size of a cell at depth 9 (or the deepest cell, if shallower): 512 samples
    /// across the root cube. Iso rays refine their crossing exactly between samples, so
    /// the step only has to resolve features, not the surface position.
    fn sample_spacing(&self) -> f64 {
        self.cell_size(self.stats.depth_reached.min(9))
    }
}

/// What `Field::first_crossing` answers for `ray`: `NotProvided` for a ray the walk does
/// not take ([`walkable`]), else the walk's crossing (`walk` runs only then).
pub(crate) fn crossing(ray: &CrossingRay, walk: impl FnOnce() -> Option<f64>) -> Crossing {
    if !walkable(ray) {
        return Crossing::NotProvided;
    }
    match walk() {
        Some(t) => Crossing::At(t),
        None => Crossing::Miss,
    }
}

/// A ray the walk answers: finite, with a direction (others are marched by the renderer).
fn walkable(r: &CrossingRay) -> bool {
    r.world_origin.is_finite()
        && r.world_dir.is_finite()
        && r.t0.is_finite()
        && r.t1.is_finite()
        && r.world_dir != DVec3::ZERO
}

/// Another ADF as a source (its reconstruction; not an exact distance).
impl crate::DistanceSource for Adf {
    fn distance(&self, world_pos: DVec3) -> f64 {
        Adf::distance(self, world_pos)
    }
    /// [`Adf::range`]: the leaves' corner ranges.
    fn range(&self, world_box: &Aabb) -> (f64, f64) {
        Adf::range(self, world_box)
    }
    fn bounds(&self) -> Aabb {
        self.root_box()
    }
    fn is_exact(&self) -> bool {
        false
    }
}

/// The build's defaults (its reconstruction has no shortcuts).
impl crate::AdfSource for Adf {}
