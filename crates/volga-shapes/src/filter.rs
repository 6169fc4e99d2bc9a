use glam::DVec3;

/// The oriented box filter of Sramek & Kaufman (survey §17.4, Fig. 39): a 1D box of
/// width `W = 2·half_width` oriented along the surface normal. Convolved with a solid's
/// indicator it gives a density linear in the signed distance `d` (positive outside):
///
/// `density(d) = clamp(½ − d / W, 0, 1)`, so 1 at `d = −W/2`, ½ on the surface, 0 at `d = W/2`.
///
/// Sramek & Kaufman show `W = 2√3` voxels is the narrowest width for which central
/// differences over the 3×3×3 neighbourhood of a voxel near the surface all see the
/// linear ramp. On an anisotropic grid we keep that property by taking the half-width
/// as the voxel diagonal `‖spacing‖₂` (which is `√3·h` on a cubic grid).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedBoxFilter {
    half_width_world: f64,
}

impl OrientedBoxFilter {
    /// The filter for a grid with this spacing (half-width = voxel diagonal).
    pub fn for_spacing(spacing: DVec3) -> Self {
        OrientedBoxFilter {
            half_width_world: spacing.length(),
        }
    }

    /// A filter of explicit half-width (world units, must be > 0 and finite).
    pub fn with_half_width(half_width_world: f64) -> Option<Self> {
        (half_width_world.is_finite() && half_width_world > 0.0).then_some(OrientedBoxFilter { half_width_world })
    }

    /// The half-width `W/2` (world units): density is 1 at `d ≤ −W/2`, 0 at `d ≥ W/2`.
    pub fn half_width(&self) -> f64 {
        self.half_width_world
    }

    /// Density for a signed distance (world units, negative inside). NaN maps to 0.
    #[inline]
    pub fn density(&self, signed_distance: f64) -> f64 {
        let v = 0.5 - signed_distance / (2.0 * self.half_width_world);
        if v >= 1.0 {
            1.0
        } else if v > 0.0 {
            v
        } else {
            0.0 // also NaN
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profile_is_linear_with_half_on_surface() {
        let f = OrientedBoxFilter::for_spacing(DVec3::ONE);
        let w = 3f64.sqrt();
        assert_eq!(f.density(0.0), 0.5);
        assert_eq!(f.density(-w), 1.0);
        assert_eq!(f.density(w), 0.0);
        assert!((f.density(w / 2.0) - 0.25).abs() < 1e-15);
        assert_eq!(f.density(-10.0), 1.0);
        assert_eq!(f.density(f64::NAN), 0.0);
        assert!(OrientedBoxFilter::with_half_width(0.0).is_none());
    }
}
