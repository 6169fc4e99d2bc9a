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

use volga_core::{Aabb, Field};

use super::{sub_pixel, Image, RenderStats, Renderer};
use crate::integrators::March;
use crate::{Camera, Integrator};

impl<'a, F: Field + ?Sized, I: Integrator> Renderer<'a, F, I> {
    /// This renderer for `field`, an edited version of the field it was prepared for
    /// that differs from it only inside the world box `changed` (what a sculpting edit
    /// reports): the skipping grid is updated only where `changed` reaches instead of
    /// rebuilt. When the bounds, sample spacing or kind differ, or the field prepares a
    /// faster equivalent of itself, it is prepared afresh ([`Renderer::new`]). Renders
    /// equal those of a fresh renderer bit for bit (skipping never changes an image).
    pub fn after_edit<'b>(self, field: &'b F, changed: &Aabb) -> Result<Renderer<'b, F, I>, crate::RenderError>
    where
        'a: 'b,
    {
        let same = field.bounds() == self.bounds
            && field.sample_spacing() == self.field.sample_spacing()
            && field.kind() == self.constants.kind
            && self.prepared.is_none()
            && self.packed.is_none()
            // A pre-integration table spans the old field's value range: build afresh.
            && self.preint.is_none()
            && self.light_volumes.iter().all(Option::is_none);
        if !same {
            return Renderer::new(field, self.integrator, self.settings);
        }
        let prepared = if self.settings.sampling.prepare_field {
            field.prepare()
        } else {
            None
        };
        if prepared.is_some() {
            return Renderer::new(field, self.integrator, self.settings);
        }
        let mut grid = self.grid;
        if let Some(g) = grid.as_mut() {
            let (integrator, kind, preint) = (self.integrator, self.constants.kind, self.preint.as_ref());
            g.update(field, field.sample_spacing(), changed, |lo, hi| {
                super::classify_cell(integrator, preint, lo, hi, kind)
            });
        }
        Ok(Renderer {
            integrator: self.integrator,
            settings: self.settings,
            bounds: self.bounds,
            field,
            prepared: None,
            packed: None,
            constants: self.constants,
            shader: self.shader,
            grid,
            shadow: self.shadow,
            preint: self.preint,
            light_volumes: self.light_volumes,
            iso_mask: None, // only with a packed copy, which is never kept here
        })
    }

    /// Re-renders in `image` (a full render of this view before the edit, same size as the
    /// settings) the pixels whose rays pass through `changed` grown by the field's gradient
    /// step; returns how many pixels were re-rendered and their statistics. This renderer
    /// must be prepared for the edited field. Rows in parallel; pixel values are those
    /// [`Renderer::render`] gives, bit for bit.
    ///
    /// Panics if `image` is not the settings' size.
    pub fn rerender_box(&self, camera: &Camera, changed: &Aabb, image: &mut Image) -> (u64, RenderStats) {
        let (w, h) = (self.settings.image.width, self.settings.image.height);
        assert!(
            image.width == w && image.height == h,
            "image size differs from the settings"
        );
        if changed.is_empty() {
            return (0, RenderStats::default());
        }
        // Gradients and cubic filters read up to two voxels (gradient steps) around a sample.
        let grown = changed.expanded(self.field.gradient_step() * 2.0);
        if let Some(packed) = &self.packed {
            let field = crate::packet::PackedField {
                field: self.field,
                packed,
            };
            return self.rerender_march(&self.march_packed(&field, Some(packed)), camera, &grown, image);
        }
        match &self.prepared {
            Some(p) => self.rerender_march(&self.march(&**p), camera, &grown, image),
            None => self.rerender_march(&self.march(self.field), camera, &grown, image),
        }
    }

    fn rerender_march<G: Field + ?Sized>(
        &self,
        march: &March<'_, G>,
        camera: &Camera,
        grown: &Aabb,
        image: &mut Image,
    ) -> (u64, RenderStats) {
        use rayon::prelude::*;
        let (w, h) = (self.settings.image.width, self.settings.image.height);
        let k = self.settings.image.supersampling.max(1);
        let touches = |x: u32, y: u32| {
            (0..k).any(|j| {
                (0..k).any(|i| {
                    let (sx, sy) = if k == 1 {
                        (x as f64, y as f64)
                    } else {
                        sub_pixel(x, y, i, j, k)
                    };
                    let ray = camera.ray(sx, sy, w, h);
                    grown.ray_interval(ray.origin, ray.dir).is_some()
                })
            })
        };
        let results: Vec<(u64, RenderStats)> = image
            .pixels
            .par_chunks_mut(w as usize)
            .enumerate()
            .map(|(y, row)| {
                let mut stats = RenderStats::default();
                let pixels: Vec<(u32, u32)> = (0..w)
                    .filter(|&x| touches(x, y as u32))
                    .map(|x| (x, y as u32))
                    .collect();
                let mut traced = Vec::with_capacity(pixels.len());
                self.trace_pixels(march, camera, &pixels, &mut stats, &mut traced);
                for (&(x, _), colour) in pixels.iter().zip(traced) {
                    row[x as usize] = colour;
                }
                (pixels.len() as u64, stats)
            })
            .collect();
        let mut total = (0, RenderStats::default());
        for (c, s) in results {
            total.0 += c;
            total.1 += s;
        }
        total
    }
}
