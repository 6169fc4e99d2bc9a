//! Tool geometry: what a tool occupies, as a signed distance in world space.
//!
//! A tool is a shape (any analytic shape of volga-shapes, a torus, or a closed mesh) at a
//! rigid [`Pose`], or such a shape swept along a polyline ([`Sweep`], the saw). Tools are
//! volume-sampled by the oriented box filter of the sculpt's grid (survey §17.4), so every
//! edit is anti-aliased; this module only answers distances and their bounds.

use std::sync::Arc;

use glam::{DQuat, DVec3};
use volga_core::Aabb;
use volga_mesh::{signed_distance, Bvh, TriMesh};
use volga_shapes::{Shape, SignedDistance, Torus};

/// Why a tool was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ToolError {
    /// The pose is not finite or its rotation is zero.
    #[error("tool pose must be finite with a non-zero rotation")]
    Pose,
    /// The mesh has holes or no triangles.
    #[error("tool mesh must be closed (it has {boundary_edges} boundary edges) and have triangles")]
    OpenMesh {
        /// Edges used by one triangle only.
        boundary_edges: usize,
    },
    /// The saw path is empty, has a non-finite point, or its step is not finite and positive.
    #[error("saw path needs at least one point, all finite")]
    Path,
    /// The saw path needs more tool copies than [`MAX_SWEEP_SAMPLES`].
    #[error("saw path is too long for the sculpt: {samples} tool positions (at most {max})")]
    PathTooLong {
        /// Tool positions the path needs, counted up to the segment where it passed `max`.
        samples: u64,
        /// The most allowed.
        max: u64,
    },
    /// One segment of the saw path alone needs more tool copies than [`MAX_SWEEP_SAMPLES`].
    #[error("saw path segment {segment} is {length:e} world units long: at one tool position every {step:e} it needs more than {max} tool positions")]
    SegmentTooLong {
        /// Index of the segment's first point in the path.
        segment: usize,
        /// Its length (world units; may be infinite when the coordinates are huge).
        length: f64,
        /// The step between tool positions (half a voxel).
        step: f64,
        /// The most tool positions allowed.
        max: u64,
    },
    /// The shape was refused (the message says why).
    #[error("tool shape: {0}")]
    Shape(String),
}

/// A rigid placement: `world = rotation·local + translation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    rotation: DQuat,
    translation: DVec3,
    /// `rotation⁻¹`, and whether it is the identity (then points are only translated).
    inverse: DQuat,
    rotated: bool,
}

impl Default for Pose {
    fn default() -> Self {
        Pose::IDENTITY
    }
}

impl Pose {
    /// No rotation, no translation.
    pub const IDENTITY: Pose = Pose {
        rotation: DQuat::IDENTITY,
        translation: DVec3::ZERO,
        inverse: DQuat::IDENTITY,
        rotated: false,
    };

    /// A pose from a rotation (normalized here; must be finite and non-zero) and a translation.
    pub fn new(rotation: DQuat, translation: DVec3) -> Result<Pose, ToolError> {
        let len = rotation.length();
        if !(rotation.is_finite() && translation.is_finite() && len > 1e-12) {
            return Err(ToolError::Pose);
        }
        let rotation = rotation / len;
        Ok(Pose {
            rotation,
            translation,
            inverse: rotation.inverse(),
            rotated: rotation != DQuat::IDENTITY,
        })
    }

    /// A translation only (refused if not finite).
    pub fn translation(translation: DVec3) -> Result<Pose, ToolError> {
        Pose::new(DQuat::IDENTITY, translation)
    }

    #[inline]
    fn local_of(&self, world_pos: DVec3) -> DVec3 {
        let p = world_pos - self.translation;
        if self.rotated {
            self.inverse * p
        } else {
            p
        }
    }

    /// World box of a local box under this pose (its eight corners' box).
    fn world_box(&self, local: &Aabb) -> Aabb {
        if local.is_empty() {
            return Aabb::EMPTY;
        }
        (0..8).fold(Aabb::EMPTY, |b, k| {
            let c = DVec3::new(
                if k & 1 == 0 { local.min.x } else { local.max.x },
                if k & 2 == 0 { local.min.y } else { local.max.y },
                if k & 4 == 0 { local.min.z } else { local.max.z },
            );
            let w = self.rotation * c + self.translation;
            b.union(&Aabb::new(w, w))
        })
    }
}

/// A closed mesh used as a tool: exact distance (volga-mesh's BVH) with the winding-number sign.
#[derive(Debug)]
pub struct MeshTool {
    bvh: Bvh,
    bounds: Aabb,
}

impl MeshTool {
    /// Refuses meshes with holes (their inside is not defined as a tool volume).
    pub fn new(mesh: &TriMesh) -> Result<MeshTool, ToolError> {
        let stats = mesh.edge_stats();
        if mesh.triangles.is_empty() || stats.boundary_edges > 0 {
            return Err(ToolError::OpenMesh {
                boundary_edges: stats.boundary_edges,
            });
        }
        Ok(MeshTool {
            bvh: Bvh::build(mesh),
            bounds: mesh.bounds(),
        })
    }
}

/// The shape of a tool in its own (local) space.
#[derive(Debug, Clone)]
pub enum ToolShape {
    /// Any analytic shape of the geometry layer (sphere, boxes, ellipsoid, cylinder, cone, capsule, quadric).
    Shape(Shape),
    /// A torus (exact distance).
    Torus(Torus),
    /// A closed triangle mesh (exact distance, winding-number sign).
    Mesh(Arc<MeshTool>),
}

impl ToolShape {
    #[inline]
    fn distance(&self, local: DVec3) -> f64 {
        match self {
            ToolShape::Shape(s) => s.signed_distance(local),
            ToolShape::Torus(t) => t.signed_distance(local),
            ToolShape::Mesh(m) => signed_distance(&m.bvh, local),
        }
    }
    fn bounds(&self) -> Aabb {
        match self {
            ToolShape::Shape(s) => s.bounds(),
            ToolShape::Torus(t) => t.bounds(),
            ToolShape::Mesh(m) => m.bounds,
        }
    }
    /// Whether the distance is 1-Lipschitz (so boxes can be classified by their centre).
    fn is_exact(&self) -> bool {
        match self {
            ToolShape::Shape(s) => s.is_exact(),
            ToolShape::Torus(_) | ToolShape::Mesh(_) => true,
        }
    }
}

/// A tool: a shape at a pose, or swept along a path.
#[derive(Debug, Clone)]
pub struct Tool {
    shape: ToolShape,
    pose: Pose,
    /// Offsets of the swept copies (world units, applied after the pose); `[0]` for a plain tool.
    sweep: Arc<[DVec3]>,
    bounds: Aabb,
}

/// At most this many swept tool positions in one saw stroke.
pub const MAX_SWEEP_SAMPLES: u64 = 1 << 20;

impl Tool {
    /// `shape` placed by `pose`. Refuses a shape whose bounds are not finite (an unbounded
    /// quadric: clip it first).
    pub fn new(shape: ToolShape, pose: Pose) -> Result<Tool, ToolError> {
        let local = shape.bounds();
        if !(local.min.is_finite() && local.max.is_finite()) {
            return Err(ToolError::Shape("tool bounds must be finite".into()));
        }
        let bounds = pose.world_box(&local);
        Ok(Tool {
            shape,
            pose,
            sweep: Arc::from(vec![DVec3::ZERO]),
            bounds,
        })
    }

    /// A sphere tool (the common case), centre in world space.
    pub fn sphere(center: DVec3, radius: f64) -> Result<Tool, ToolError> {
        let s = volga_shapes::Sphere::new(center, radius).map_err(|e| ToolError::Shape(e.to_string()))?;
        Tool::new(ToolShape::Shape(Shape::Sphere(s)), Pose::IDENTITY)
    }

    /// The saw: `self` swept along the polyline `path` (world offsets added to the tool's
    /// placement, so a tool centred at the origin is swept through the path's points).
    /// Copies are placed every `max_step` along each segment, at least at every path
    /// point; repeated points and zero-length paths are fine (one copy per distinct spot).
    /// With `max_step = h/2` on a grid of spacing `h` the union of copies differs from the
    /// true swept volume of a sphere of radius `r` by less than `h²/(32r)`.
    pub fn swept(self, path: &[DVec3], max_step: f64) -> Result<Tool, ToolError> {
        if path.is_empty() || path.iter().any(|p| !p.is_finite()) || !(max_step.is_finite() && max_step > 0.0) {
            return Err(ToolError::Path);
        }
        let mut samples: Vec<DVec3> = vec![path[0]];
        let mut count = 1u64;
        for (segment, pair) in path.windows(2).enumerate() {
            let (a, b) = (pair[0], pair[1]);
            let length = (b - a).length();
            let n = (length / max_step).ceil();
            if n.is_nan() || n > MAX_SWEEP_SAMPLES as f64 {
                return Err(ToolError::SegmentTooLong {
                    segment,
                    length,
                    step: max_step,
                    max: MAX_SWEEP_SAMPLES,
                });
            }
            count += n as u64;
            if count > MAX_SWEEP_SAMPLES {
                return Err(ToolError::PathTooLong {
                    samples: count,
                    max: MAX_SWEEP_SAMPLES,
                });
            }
            for k in 1..=n as u64 {
                samples.push(a + (b - a) * (k as f64 / n));
            }
        }
        samples.dedup();
        let local_box = self.pose.world_box(&self.shape.bounds());
        let bounds = samples.iter().fold(Aabb::EMPTY, |acc, o| {
            acc.union(&Aabb::new(local_box.min + *o, local_box.max + *o))
        });
        Ok(Tool {
            sweep: Arc::from(samples),
            bounds,
            ..self
        })
    }

    /// World box outside which the tool's distance is positive (tight for an unswept shape up to the pose).
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Signed distance (world units, negative inside): the minimum over swept copies.
    #[inline]
    pub fn distance(&self, world_pos: DVec3) -> f64 {
        if let [o] = *self.sweep {
            return self.shape.distance(self.pose.local_of(world_pos - o));
        }
        let mut d = f64::INFINITY;
        for o in self.sweep.iter() {
            d = d.min(self.shape.distance(self.pose.local_of(world_pos - *o)));
        }
        d
    }

    /// A conservative `(min, max)` of the distance over a world box, `(−∞, ∞)` if unknown.
    pub fn distance_range(&self, world_box: &Aabb) -> (f64, f64) {
        if !self.shape.is_exact() {
            return (f64::NEG_INFINITY, f64::INFINITY);
        }
        let d = self.distance(world_box.center());
        let r = world_box.size().length() * 0.5;
        (d - r, d + r)
    }

    /// The same tool keeping only the swept copies whose box comes within `margin` of
    /// `world_box` (the others cannot be nearest there within `margin`): what an edit
    /// evaluates per voxel in one brick. Returns `None` if no copy is that close.
    pub(crate) fn localized(&self, world_box: &Aabb, margin: f64) -> Option<Tool> {
        if self.sweep.len() == 1 {
            return Some(self.clone());
        }
        let local_box = self.pose.world_box(&self.shape.bounds());
        let near = world_box.expanded(DVec3::splat(margin));
        let kept: Vec<DVec3> = self
            .sweep
            .iter()
            .copied()
            .filter(|o| {
                let b = Aabb::new(local_box.min + *o, local_box.max + *o);
                !b.intersection(&near).is_empty()
            })
            .collect();
        if kept.is_empty() {
            return None;
        }
        Some(Tool {
            shape: self.shape.clone(),
            pose: self.pose,
            sweep: Arc::from(kept),
            bounds: self.bounds,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn posed_box_and_sweep_distances() {
        let cube = volga_shapes::AxisBox::new(DVec3::splat(-1.0), DVec3::ONE).unwrap();
        let rot = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_4);
        let tool = Tool::new(
            ToolShape::Shape(Shape::AxisBox(cube)),
            Pose::new(rot, DVec3::X * 10.0).unwrap(),
        )
        .unwrap();
        // The rotated cube's corner points along +x: at distance √2 from its centre.
        assert!((tool.distance(DVec3::new(10.0 + 2f64.sqrt() + 0.5, 0.0, 0.0)) - 0.5).abs() < 1e-12);
        assert!((tool.bounds().max.x - (10.0 + 2f64.sqrt())).abs() < 1e-12);
        let saw = Tool::sphere(DVec3::ZERO, 1.0)
            .unwrap()
            .swept(&[DVec3::ZERO, DVec3::ZERO, DVec3::X * 4.0, DVec3::X * 4.0], 0.25)
            .unwrap();
        assert!((saw.distance(DVec3::new(2.0, 3.0, 0.0)) - 2.0).abs() < 1e-12);
        assert_eq!(
            saw.bounds(),
            Aabb::new(DVec3::new(-1.0, -1.0, -1.0), DVec3::new(5.0, 1.0, 1.0))
        );
        // Zero length: one copy.
        let dot = Tool::sphere(DVec3::ZERO, 1.0)
            .unwrap()
            .swept(&[DVec3::Y; 3], 0.25)
            .unwrap();
        assert_eq!(dot.sweep.len(), 1);
        assert!(Tool::sphere(DVec3::ZERO, 1.0).unwrap().swept(&[], 0.25).is_err());
        assert!(Tool::sphere(DVec3::ZERO, 1.0)
            .unwrap()
            .swept(&[DVec3::ZERO, DVec3::X * 1e12], 0.25)
            .is_err());
    }
}
