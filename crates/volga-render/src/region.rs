//! Localized re-rendering: after an edit that changed the field only inside a world box,
//! re-render just the pixels whose rays pass through that box (survey §17.9: "a localized
//! rendering can be employed to reproject only those pixels that are affected").
//!
//! A pixel is a pure function of the field values its ray reads: samples on the ray,
//! refinement points on the ray and, for shading, central differences one
//! [`Field::gradient_step`] around them. So a ray that misses the changed box grown by the
//! gradient step reads only unchanged values, and its pixel is bit-identical to a full
//! render of the edited field; every other pixel is recomputed exactly as
//! [`Renderer::render`] computes it.

use glam::Vec3;
use volga_core::{Aabb, Field};

use super::{Image, RenderStats, Renderer};
use crate::integrators::{clip, over_background};
use crate::{Camera, Integrator, Ray};

impl<F: Field + ?Sized, I: Integrator> Renderer<'_, F, I> {
    /// Re-renders in `image` (a full render of this view before the edit, same size as the
    /// settings) the pixels whose rays pass through `changed` grown by the field's gradient
    /// step; returns how many pixels were re-rendered and their statistics. This renderer
    /// must be prepared for the edited field. Rows in parallel; pixel values are those
    /// [`Renderer::render`] gives, bit for bit.
    ///
    /// Panics if `image` is not the settings' size.
    pub fn rerender_box(&self, camera: &Camera, changed: &Aabb, image: &mut Image) -> (u64, RenderStats) {
        use rayon::prelude::*;
        let (w, h) = (self.settings.image.width, self.settings.image.height);
        assert!(
            image.width == w && image.height == h,
            "image size differs from the settings"
        );
        if changed.is_empty() {
            return (0, RenderStats::default());
        }
        let grown = changed.expanded(self.march.field.gradient_step());
        let results: Vec<(u64, RenderStats)> = image
            .pixels
            .par_chunks_mut(w as usize)
            .enumerate()
            .map(|(y, row)| {
                let mut stats = RenderStats::default();
                let mut count = 0;
                for (x, px) in row.iter_mut().enumerate() {
                    let ray = camera.ray(x as f64, y as f64, w, h);
                    if grown.ray_interval(ray.origin, ray.dir).is_some() {
                        *px = self.trace_ray(&ray, &mut stats);
                        count += 1;
                    }
                }
                (count, stats)
            })
            .collect();
        let mut total = (0, RenderStats::default());
        for (c, s) in results {
            total.0 += c;
            total.1 += s;
        }
        total
    }

    /// One pixel, as [`Renderer::render`] computes it.
    fn trace_ray(&self, ray: &Ray, stats: &mut RenderStats) -> glam::Vec4 {
        stats.rays += 1;
        let (c, a) = match clip(&self.bounds, ray) {
            None => (Vec3::ZERO, 0.0),
            Some(interval) => self.integrator.integrate(&self.march, ray, interval, stats),
        };
        over_background(self.settings.image.background, c, a)
    }
}
