use glam::{DVec3, Vec3};

use crate::Aabb;

/// The one sampling interface: everything the raycaster can render is a `Field`.
///
/// Positions are **world space** (`f64`). Values are densities (or distances) as
/// `f64`, reconstructed from `f32` payloads by the implementor. A new representation
/// (octree, ADF, CVG tree) joins the renderer by implementing this trait.
pub trait Field: Sync {
    /// World box outside which the field equals [`Field::background`].
    fn bounds(&self) -> Aabb;

    /// Value far from the content (outside `bounds`).
    fn background(&self) -> f64 {
        0.0
    }

    /// Value at a world position.
    fn value(&self, world_pos: DVec3) -> f64;

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
    fn background(&self) -> f64 {
        (**self).background()
    }
    fn value(&self, p: DVec3) -> f64 {
        (**self).value(p)
    }
    fn gradient(&self, p: DVec3) -> DVec3 {
        (**self).gradient(p)
    }
    fn gradient_step(&self) -> DVec3 {
        (**self).gradient_step()
    }
    fn value_range(&self, b: &Aabb) -> (f64, f64) {
        (**self).value_range(b)
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
