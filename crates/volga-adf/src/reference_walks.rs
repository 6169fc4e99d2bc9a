//! Views of an ADF that render through its reference walks (feature `reference-walks`):
//! the walk without the index ([`DescentWalk`]) and the indexed walk one ray at a time
//! ([`OneRayWalk`]). For same-run comparisons (`volga bench adf`) and tests; a renderer
//! uses the `Adf` itself.

use glam::DVec3;
use volga_core::CrossingRay;

use crate::Adf;

/// A view of an ADF for same-run comparisons (`volga bench adf`) and tests: every
/// [`Field`](volga_core::Field) method is the ADF's except `first_crossing`, answered by
/// `$walk`, and `first_crossings`, left at its default (ray by ray).
macro_rules! walk_view {
    ($(#[$doc:meta])* $name:ident, $walk:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug)]
        pub struct $name<'a>(pub &'a Adf);

        impl volga_core::Field for $name<'_> {
            fn bounds(&self) -> volga_core::Aabb {
                volga_core::Field::bounds(self.0)
            }
            fn kind(&self) -> volga_core::FieldKind {
                volga_core::Field::kind(self.0)
            }
            fn background(&self) -> f64 {
                volga_core::Field::background(self.0)
            }
            fn value(&self, world_pos: DVec3) -> f64 {
                volga_core::Field::value(self.0, world_pos)
            }
            fn values_along(&self, line: &volga_core::Line, first: u64, out: &mut [f64]) {
                volga_core::Field::values_along(self.0, line, first, out)
            }
            fn gradient(&self, world_pos: DVec3) -> DVec3 {
                volga_core::Field::gradient(self.0, world_pos)
            }
            fn gradient_step(&self) -> DVec3 {
                volga_core::Field::gradient_step(self.0)
            }
            fn first_crossing(
                &self,
                world_origin: DVec3,
                world_dir: DVec3,
                t0: f64,
                t1: f64,
                iso: f64,
            ) -> volga_core::Crossing {
                let ray = CrossingRay {
                    world_origin,
                    world_dir,
                    t0,
                    t1,
                };
                crate::field::crossing(&ray, || self.0.$walk(world_origin, world_dir, t0, t1, iso).0)
            }
            fn value_range(&self, world_box: &volga_core::Aabb) -> (f64, f64) {
                volga_core::Field::value_range(self.0, world_box)
            }
            fn sample_spacing(&self) -> f64 {
                volga_core::Field::sample_spacing(self.0)
            }
        }
    };
}

walk_view!(
    /// An ADF rendered through the reference walk ([`Adf::first_crossing_by_descent`]):
    /// iso crossings are found without the walk index, ray by ray.
    DescentWalk,
    first_crossing_by_descent
);

walk_view!(
    /// An ADF rendered through the indexed walk one ray at a time
    /// ([`Adf::first_crossing_between`]) instead of the batched walk
    /// ([`Adf::first_crossings_between`]) the ADF's own `Field` gives a tile's rays: the
    /// same image, for measuring what batching gains.
    OneRayWalk,
    first_crossing_between
);
