//! Raw scene → validated kernel types. Each check names the field path
//! (`objects[1].shape.radius`) of the value it refuses.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3, EulerRot, UVec3, Vec3, Vec4};
use volga_core::{Aabb, Filter, Grid, Transform};
use volga_render::{
    Camera, ImageSettings, Iso, Light, Lighting, Material, Mip, Mode, Projection, RenderError, RenderSettings,
    Sampling, SurfaceColour, TransferFunction, Volume, XRay,
};
use volga_voxelize::shapes::{AxisBox, Capsule, Cone, Cylinder, Ellipsoid, OrientedBox, Quadric, Sphere};
use volga_voxelize::{Shape, Solid};

use crate::model::*;
use crate::SceneError;

/// A scene whose every value has been checked: what the planner and builder run.
#[derive(Debug, Clone)]
pub struct Scene {
    pub source: PathBuf,
    pub grid: Grid,
    /// Analytic solids (shapes and quadrics).
    pub solids: Vec<Solid>,
    /// Mesh solids, merged after the analytic ones.
    pub meshes: Vec<MeshObject>,
    pub object_names: Vec<String>,
    pub images: Vec<ImageJob>,
    pub volumes: Vec<VolumeOutputSpec>,
}

/// A mesh object of the scene, loaded and placed in world space.
#[derive(Debug, Clone)]
pub struct MeshObject {
    pub name: String,
    pub mesh: volga_mesh::TriMesh,
    pub colour: volga_core::Rgb,
}

/// One image output: a camera, a mode and the render settings for it.
#[derive(Debug, Clone)]
pub struct ImageJob {
    pub name: String,
    pub camera_name: String,
    pub camera: Camera,
    pub mode: Mode,
    pub settings: RenderSettings,
    pub filter: Filter,
    /// The image reads the volume's colour channel.
    pub reads_colour: bool,
}

struct Ctx<'a> {
    path: &'a Path,
}

impl Ctx<'_> {
    fn err(&self, field: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            path: self.path.to_owned(),
            field: field.into(),
            message: message.into(),
        }
    }

    fn finite3(&self, field: &str, v: V3) -> Result<DVec3, SceneError> {
        let d = DVec3::from_array(v);
        if d.is_finite() {
            Ok(d)
        } else {
            Err(self.err(field, format!("must be finite, got {v:?}")))
        }
    }

    fn positive(&self, field: &str, v: f64) -> Result<f64, SceneError> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(field, format!("must be finite and > 0, got {v}")))
        }
    }

    fn unit_interval(&self, field: &str, v: &[f64]) -> Result<(), SceneError> {
        if v.iter().all(|x| (0.0..=1.0).contains(x)) {
            Ok(())
        } else {
            Err(self.err(field, format!("components must lie in [0, 1], got {v:?}")))
        }
    }

    fn file_stem(&self, field: &str, name: &str) -> Result<(), SceneError> {
        let ok = !name.is_empty()
            && name.len() <= 100
            && !name.starts_with('.')
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
        if ok {
            Ok(())
        } else {
            Err(self.err(
                field,
                format!("`{name}` is not a valid file name (letters, digits, `_`, `-`, `.`; not starting with `.`)"),
            ))
        }
    }
}

/// Largest voxel count per axis a scene may ask for (the grid type's own limit).
const MAX_DIM: f64 = (i32::MAX / 2) as f64;

pub fn validate(path: &Path, file: &SceneFile) -> Result<Scene, SceneError> {
    let cx = Ctx { path };
    let grid = validate_grid(&cx, &file.grid)?;

    if file.objects.is_empty() {
        return Err(cx.err("objects", "the scene has no objects"));
    }
    let mut solids = Vec::new();
    let mut meshes = Vec::new();
    let mut object_names = Vec::new();
    for (i, o) in file.objects.iter().enumerate() {
        let f = format!("objects[{i}]");
        let colour = match o.colour {
            Some(c) => {
                cx.unit_interval(&format!("{f}.colour"), &c)?;
                c.map(|x| x as f32)
            }
            None => [1.0; 3],
        };
        let name = o.name.clone().unwrap_or_else(|| format!("object{i}"));
        if let ShapeSpec::Mesh {
            path: mesh_path,
            translate,
            scale,
        } = &o.shape
        {
            let f = format!("{f}.shape");
            let offset = cx.finite3(&format!("{f}.translate"), *translate)?;
            let scale = cx.positive(&format!("{f}.scale"), *scale)?;
            let resolved = path.parent().unwrap_or(Path::new(".")).join(mesh_path);
            let mesh = volga_mesh::load_mesh(&resolved).map_err(|e| cx.err(format!("{f}.path"), e.to_string()))?;
            let placed = mesh.transformed(&glam::DAffine3::from_scale_rotation_translation(
                DVec3::splat(scale),
                DQuat::IDENTITY,
                offset,
            ));
            meshes.push(MeshObject {
                name: name.clone(),
                mesh: placed,
                colour,
            });
        } else if let ShapeSpec::Triangles { vertices, triangles } = &o.shape {
            let f = format!("{f}.shape");
            let positions = vertices
                .iter()
                .enumerate()
                .map(|(k, v)| cx.finite3(&format!("{f}.vertices[{k}]"), *v))
                .collect::<Result<Vec<_>, _>>()?;
            if triangles.is_empty() {
                return Err(cx.err(format!("{f}.triangles"), "needs at least one triangle"));
            }
            let mesh = volga_mesh::TriMesh::new(positions, triangles.clone())
                .map_err(|e| cx.err(format!("{f}.triangles"), e.to_string()))?;
            meshes.push(MeshObject {
                name: name.clone(),
                mesh,
                colour,
            });
        } else {
            let shape = validate_shape(&cx, &format!("{f}.shape"), &o.shape)?;
            solids.push(Solid::new(shape, colour));
        }
        object_names.push(name);
    }

    let transfer = validate_transfer(&cx, file.transfer_function.as_deref())?;
    let mut lights = Vec::new();
    for (i, l) in file.lights.iter().enumerate() {
        let f = format!("lights[{i}]");
        let dir = cx.finite3(&format!("{f}.direction"), l.direction)?;
        if dir.length_squared() == 0.0 {
            return Err(cx.err(format!("{f}.direction"), "must not be the zero vector"));
        }
        cx.unit_interval(&format!("{f}.colour"), &l.colour)?;
        lights.push(Light {
            direction: dir,
            colour: DVec3::from_array(l.colour).as_vec3(),
        });
    }
    let material = match &file.material {
        None => Material::default(),
        Some(m) => {
            for (name, v) in [("ambient", m.ambient), ("diffuse", m.diffuse), ("specular", m.specular)] {
                if !(0.0..=1.0).contains(&v) {
                    return Err(cx.err(format!("material.{name}"), format!("must lie in [0, 1], got {v}")));
                }
            }
            if !(m.shininess.is_finite() && m.shininess >= 1.0) {
                return Err(cx.err(
                    "material.shininess",
                    format!("must be finite and ≥ 1, got {}", m.shininess),
                ));
            }
            Material {
                ambient: m.ambient as f32,
                diffuse: m.diffuse as f32,
                specular: m.specular as f32,
                shininess: m.shininess as f32,
            }
        }
    };

    let mut cameras = Vec::new();
    for (i, c) in file.cameras.iter().enumerate() {
        let f = format!("cameras[{i}]");
        let eye = cx.finite3(&format!("{f}.eye"), c.eye)?;
        let target = cx.finite3(&format!("{f}.target"), c.target)?;
        let up = cx.finite3(&format!("{f}.up"), c.up)?;
        let projection = match c.projection {
            ProjectionSpec::Perspective { fov_deg } => {
                if !(fov_deg.is_finite() && fov_deg > 0.0 && fov_deg < 180.0) {
                    return Err(cx.err(
                        format!("{f}.projection.fov_deg"),
                        format!("must lie in (0, 180), got {fov_deg}"),
                    ));
                }
                Projection::Perspective { fov_y_deg: fov_deg }
            }
            ProjectionSpec::Orthographic { height } => Projection::Orthographic {
                height_world: cx.positive(&format!("{f}.projection.height"), height)?,
            },
        };
        let camera = Camera::look_at(eye, target, up, projection).map_err(|e| cx.err(f.clone(), e.to_string()))?;
        if cameras.iter().any(|(n, _): &(String, Camera)| *n == c.name) {
            return Err(cx.err(format!("{f}.name"), format!("camera `{}` is defined twice", c.name)));
        }
        cameras.push((c.name.clone(), camera));
    }

    let mut stems = HashSet::new();
    stems.insert("report".to_string());
    let mut images = Vec::new();
    for (i, im) in file.outputs.images.iter().enumerate() {
        let f = format!("outputs.images[{i}]");
        images.push(validate_image(
            &cx, &f, im, &grid, &cameras, &transfer, &lights, material,
        )?);
        if !stems.insert(im.name.clone()) {
            return Err(cx.err(
                format!("{f}.name"),
                format!("output name `{}` is used twice (or is reserved)", im.name),
            ));
        }
    }
    for (i, v) in file.outputs.volumes.iter().enumerate() {
        let f = format!("outputs.volumes[{i}].name");
        cx.file_stem(&f, &v.name)?;
        let colour_stem = format!("{}_colour", v.name);
        if !stems.insert(v.name.clone()) || (v.colour && !stems.insert(colour_stem)) {
            return Err(cx.err(f, format!("output name `{}` is used twice (or is reserved)", v.name)));
        }
    }
    if images.is_empty() && file.outputs.volumes.is_empty() {
        return Err(cx.err("outputs", "the scene asks for no output (no images, no volumes)"));
    }

    Ok(Scene {
        source: path.to_owned(),
        grid,
        solids,
        meshes,
        object_names,
        images,
        volumes: file.outputs.volumes.clone(),
    })
}

fn validate_grid(cx: &Ctx, g: &GridSpec) -> Result<Grid, SceneError> {
    let min = cx.finite3("grid.bounds.min", g.bounds.min)?;
    let max = cx.finite3("grid.bounds.max", g.bounds.max)?;
    if min.cmpge(max).any() {
        return Err(cx.err("grid.bounds", "min must be < max on every axis"));
    }
    let size = max - min;
    let voxel = match (g.resolution, &g.voxel_size) {
        (Some(_), Some(_)) => return Err(cx.err("grid", "give either `resolution` or `voxel_size`, not both")),
        (None, None) => {
            return Err(cx.err(
                "grid",
                "give `resolution` (voxels along the longest side) or `voxel_size`",
            ))
        }
        (Some(0), None) => return Err(cx.err("grid.resolution", "must be ≥ 1, got 0")),
        (Some(n), None) => DVec3::splat(size.max_element() / n as f64),
        (None, Some(VoxelSize::Cubic(h))) => DVec3::splat(cx.positive("grid.voxel_size", *h)?),
        (None, Some(VoxelSize::PerAxis(h))) => {
            for (a, v) in h.iter().enumerate() {
                cx.positive(&format!("grid.voxel_size[{a}]"), *v)?;
            }
            DVec3::from_array(*h)
        }
    };
    // Cells tile the bounds; a side that is not a whole number of voxels is rounded up
    // (the tolerance absorbs the rounding of size / voxel).
    let dims_f = (size / voxel - 1e-9).ceil().max(DVec3::ONE);
    if dims_f.max_element() > MAX_DIM {
        let field = if g.resolution.is_some() {
            "grid.resolution"
        } else {
            "grid.voxel_size"
        };
        return Err(cx.err(
            field,
            format!("asks for {dims_f:?} voxels per axis; at most {MAX_DIM} are supported"),
        ));
    }
    let dims = UVec3::new(dims_f.x as u32, dims_f.y as u32, dims_f.z as u32);
    let transform = Transform::new(min + voxel * 0.5, voxel).map_err(|e| cx.err("grid", e.to_string()))?;
    Grid::new(transform, dims).map_err(|e| cx.err("grid", e.to_string()))
}

fn nonzero(cx: &Ctx, field: &str, v: V3) -> Result<DVec3, SceneError> {
    let d = cx.finite3(field, v)?;
    if d == DVec3::ZERO {
        return Err(cx.err(field, "must not be the zero vector"));
    }
    Ok(d)
}

fn validate_shape(cx: &Ctx, f: &str, s: &ShapeSpec) -> Result<Shape, SceneError> {
    Ok(match s {
        ShapeSpec::Sphere { center, radius } => {
            let c = cx.finite3(&format!("{f}.center"), *center)?;
            let r = cx.positive(&format!("{f}.radius"), *radius)?;
            Shape::Sphere(Sphere::new(c, r).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Box { min, max } => {
            let lo = cx.finite3(&format!("{f}.min"), *min)?;
            let hi = cx.finite3(&format!("{f}.max"), *max)?;
            Shape::AxisBox(AxisBox::new(lo, hi).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::OrientedBox {
            center,
            half_extents,
            rotation_deg,
        } => {
            let c = cx.finite3(&format!("{f}.center"), *center)?;
            let h = cx.finite3(&format!("{f}.half_extents"), *half_extents)?;
            for a in 0..3 {
                cx.positive(&format!("{f}.half_extents[{a}]"), h[a])?;
            }
            let r = cx.finite3(&format!("{f}.rotation_deg"), *rotation_deg)?;
            let q = DQuat::from_euler(EulerRot::XYZ, r.x.to_radians(), r.y.to_radians(), r.z.to_radians());
            Shape::OrientedBox(OrientedBox::new(c, h, q).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Ellipsoid {
            center,
            radii,
            rotation_deg,
        } => {
            let c = cx.finite3(&format!("{f}.center"), *center)?;
            let r = cx.finite3(&format!("{f}.radii"), *radii)?;
            for a in 0..3 {
                cx.positive(&format!("{f}.radii[{a}]"), r[a])?;
            }
            let e = cx.finite3(&format!("{f}.rotation_deg"), *rotation_deg)?;
            let q = DQuat::from_euler(EulerRot::XYZ, e.x.to_radians(), e.y.to_radians(), e.z.to_radians());
            Shape::Ellipsoid(Ellipsoid::new(c, r, q).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Cylinder {
            center,
            axis,
            radius,
            half_length,
        } => {
            let c = cx.finite3(&format!("{f}.center"), *center)?;
            let a = nonzero(cx, &format!("{f}.axis"), *axis)?;
            let r = cx.positive(&format!("{f}.radius"), *radius)?;
            let l = half_length
                .map(|l| cx.positive(&format!("{f}.half_length"), l))
                .transpose()?;
            Shape::Cylinder(Cylinder::new(c, a, r, l).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Cone {
            apex,
            axis,
            half_angle_deg,
            height,
        } => {
            let p = cx.finite3(&format!("{f}.apex"), *apex)?;
            let a = nonzero(cx, &format!("{f}.axis"), *axis)?;
            if !(half_angle_deg.is_finite() && *half_angle_deg > 0.0 && *half_angle_deg < 90.0) {
                return Err(cx.err(
                    format!("{f}.half_angle_deg"),
                    format!("must lie in (0, 90), got {half_angle_deg}"),
                ));
            }
            let h = height.map(|h| cx.positive(&format!("{f}.height"), h)).transpose()?;
            Shape::Cone(Cone::new(p, a, half_angle_deg.to_radians(), h).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Quadric { a, b, c, clip } => {
            let rows: Vec<DVec3> = (0..3)
                .map(|r| cx.finite3(&format!("{f}.a[{r}]"), a[r]))
                .collect::<Result<_, _>>()?;
            let bv = cx.finite3(&format!("{f}.b"), *b)?;
            if !c.is_finite() {
                return Err(cx.err(format!("{f}.c"), format!("must be finite, got {c}")));
            }
            let lo = cx.finite3(&format!("{f}.clip.min"), clip.min)?;
            let hi = cx.finite3(&format!("{f}.clip.max"), clip.max)?;
            let clip_box = AxisBox::new(lo, hi).map_err(|e| cx.err(format!("{f}.clip"), e.to_string()))?;
            let m = glam::DMat3::from_cols(rows[0], rows[1], rows[2]).transpose();
            Shape::Quadric(Quadric::new(m, bv, *c, clip_box).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Capsule { a, b, radius } => {
            let pa = cx.finite3(&format!("{f}.a"), *a)?;
            let pb = cx.finite3(&format!("{f}.b"), *b)?;
            let r = cx.positive(&format!("{f}.radius"), *radius)?;
            Shape::Capsule(Capsule::new(pa, pb, r).map_err(|e| cx.err(f, e.to_string()))?)
        }
        ShapeSpec::Mesh { .. } | ShapeSpec::Triangles { .. } => unreachable!("meshes are loaded by the caller"),
    })
}

/// The default transfer function: transparent below density 0.3, ramping to a
/// translucent white at the surface (0.5) and more opaque inside.
fn default_transfer() -> Vec<(f64, Vec4)> {
    vec![
        (0.0, Vec4::ZERO),
        (0.3, Vec4::new(1.0, 1.0, 1.0, 0.0)),
        (0.5, Vec4::new(1.0, 1.0, 1.0, 0.15)),
        (1.0, Vec4::new(1.0, 1.0, 1.0, 0.3)),
    ]
}

fn validate_transfer(cx: &Ctx, points: Option<&[TransferPoint]>) -> Result<TransferFunction, SceneError> {
    let pts = match points {
        None => default_transfer(),
        Some(p) => {
            let mut out = Vec::new();
            for (i, tp) in p.iter().enumerate() {
                let f = format!("transfer_function[{i}]");
                if !tp.value.is_finite() {
                    return Err(cx.err(format!("{f}.value"), format!("must be finite, got {}", tp.value)));
                }
                cx.unit_interval(&format!("{f}.rgba"), &tp.rgba)?;
                out.push((tp.value, Vec4::from_array(tp.rgba.map(|x| x as f32))));
            }
            out
        }
    };
    TransferFunction::new(pts).map_err(|e| cx.err("transfer_function", e.to_string()))
}

/// The scene field path of a render setting named by [`RenderError::BadSetting`]
/// (`sampling.step_voxels` → `outputs.images[i].step_voxels`, `lighting.lights[k]…`
/// → `lights[k]…`).
fn scene_path(f: &str, render_name: &str) -> String {
    if let Some(rest) = render_name.strip_prefix("lighting.") {
        if rest.starts_with("lights[") || rest.starts_with("material.") {
            return rest.to_string();
        }
        return f.to_string();
    }
    let rest = render_name
        .strip_prefix("image.")
        .or_else(|| render_name.strip_prefix("sampling."))
        .unwrap_or(render_name);
    format!("{f}.{rest}")
}

fn render_error(cx: &Ctx, f: &str, e: RenderError) -> SceneError {
    match e {
        RenderError::BadSetting { name, reason } => cx.err(scene_path(f, &name), reason),
        e => cx.err(f, e.to_string()),
    }
}

#[allow(clippy::too_many_arguments)]
fn validate_image(
    cx: &Ctx,
    f: &str,
    im: &ImageSpec,
    grid: &Grid,
    cameras: &[(String, Camera)],
    transfer: &TransferFunction,
    lights: &[Light],
    material: Material,
) -> Result<ImageJob, SceneError> {
    cx.file_stem(&format!("{f}.name"), &im.name)?;
    let camera = cameras
        .iter()
        .find(|(n, _)| *n == im.camera)
        .map(|(_, c)| *c)
        .ok_or_else(|| cx.err(format!("{f}.camera"), format!("no camera named `{}`", im.camera)))?;
    for (name, v) in [("width", im.width), ("height", im.height)] {
        if !(1..=16384).contains(&v) {
            return Err(cx.err(format!("{f}.{name}"), format!("must lie in 1..=16384, got {v}")));
        }
    }
    let mode = match &im.mode {
        ModeSpec::Iso { value, colour } => {
            if !value.is_finite() {
                return Err(cx.err(format!("{f}.mode.value"), format!("must be finite, got {value}")));
            }
            let colour = match colour {
                None | Some(ColourSpec::FromVolume) => SurfaceColour::FromField,
                Some(ColourSpec::Constant(c)) => {
                    cx.unit_interval(&format!("{f}.mode.colour"), c)?;
                    SurfaceColour::Constant(DVec3::from_array(*c).as_vec3())
                }
            };
            Mode::Iso(Iso { value: *value, colour })
        }
        ModeSpec::Volume { colour_from_volume } => Mode::Volume(Volume::new(transfer.clone(), *colour_from_volume)),
        ModeSpec::Mip => Mode::Mip(Mip),
        ModeSpec::XRay => Mode::XRay(XRay),
    };
    let defaults = RenderSettings::default();
    let step = im.step_voxels.unwrap_or(defaults.sampling.step_voxels);
    if step > 16.0 {
        return Err(cx.err(format!("{f}.step_voxels"), format!("must be ≤ 16 voxels, got {step}")));
    }
    let background = match im.background {
        Some(b) => {
            cx.unit_interval(&format!("{f}.background"), &b)?;
            Vec4::from_array(b.map(|x| x as f32))
        }
        None => defaults.image.background,
    };
    let mut settings = RenderSettings {
        image: ImageSettings {
            width: im.width,
            height: im.height,
            background,
            ..defaults.image
        },
        sampling: Sampling {
            step_voxels: step,
            early_termination_alpha: if im.early_ray_termination.unwrap_or(true) {
                defaults.sampling.early_termination_alpha
            } else {
                f32::INFINITY
            },
            empty_space_skipping: im.empty_space_skipping.unwrap_or(true),
            ..defaults.sampling
        },
        lighting: Lighting {
            lights: if im.shading.unwrap_or(true) {
                lights.to_vec()
            } else {
                Vec::new()
            },
            ambient_colour: Vec3::ONE,
            material,
        },
    };
    // The mode says what it needs: lights only where it shades, colour where it reads it.
    let effects = mode.integrator().effects(&settings);
    if !effects.gradients.enabled {
        settings.lighting.lights.clear();
    }
    let reads_colour = effects.colour.enabled;
    // The renderer's own checks, run now so bad settings are input errors (exit 2),
    // including the samples-per-ray budget over the sampled grid the image renders.
    settings.validate().map_err(|e| render_error(cx, f, e))?;
    mode.integrator().validate().map_err(|e| render_error(cx, f, e))?;
    settings
        .sampling
        .world_step(&grid.sampled_bounds(), grid.transform.spacing().min_element())
        .map_err(|e| render_error(cx, f, e))?;
    let filter = match im.filter.unwrap_or(FilterSpec::Trilinear) {
        FilterSpec::Nearest => Filter::Nearest,
        FilterSpec::Trilinear => Filter::Trilinear,
    };
    Ok(ImageJob {
        name: im.name.clone(),
        camera_name: im.camera.clone(),
        camera,
        mode,
        settings,
        filter,
        reads_colour,
    })
}

/// World bounds of all objects (for tools that frame a camera); unbounded quadrics
/// count as the grid's bounds.
pub fn content_bounds(scene: &Scene) -> Aabb {
    use volga_voxelize::SignedDistance;
    let grid = scene.grid.world_bounds();
    let solids = scene
        .solids
        .iter()
        .fold(Aabb::EMPTY, |b, s| b.union(&s.shape.bounds().intersection(&grid)));
    scene.meshes.iter().fold(solids, |b, m| b.union(&m.mesh.bounds()))
}

#[cfg(test)]
mod tests {
    use super::*;

    const HELLO: &str = include_str!("../../../scenes/hello.ron");

    fn load(text: &str) -> Result<Scene, SceneError> {
        let path = Path::new("test.ron");
        validate(path, &crate::load::parse_ron(path, text)?)
    }

    fn invalid_field(text: &str) -> (String, String) {
        match load(text) {
            Err(SceneError::Invalid { field, message, .. }) => (field, message),
            other => panic!("expected an invalid-field error, got {other:?}"),
        }
    }

    #[test]
    fn render_settings_are_checked_at_validation() {
        assert!(load(HELLO).is_ok());
        let with = |extra: &str| {
            HELLO.replace(
                "width: 512, height: 512),",
                &format!("width: 512, height: 512, {extra}),"),
            )
        };
        // Positive but so small a ray needs more than 2^24 samples: once a render-time
        // failure (exit 1), now a validation error naming the scene field (exit 2).
        let (field, message) = invalid_field(&with("step_voxels: 1e-9"));
        assert_eq!(field, "outputs.images[0].step_voxels");
        assert!(message.contains("samples"), "{message}");
        // The renderer's own range checks name the scene field too.
        for bad in ["0.0", "-1.0"] {
            let (field, message) = invalid_field(&with(&format!("step_voxels: {bad}")));
            assert_eq!(field, "outputs.images[0].step_voxels", "{bad}");
            assert!(message.contains("> 0"), "{message}");
        }
        // A step that fits the budget still loads.
        assert!(load(&with("step_voxels: 0.01")).is_ok());
    }

    #[test]
    fn modes_declare_lights_and_colour() {
        let text = HELLO.replace("mode: Volume(colour_from_volume: true)", "mode: Mip");
        let scene = load(&text).unwrap();
        let (iso, mip) = (&scene.images[0], &scene.images[1]);
        // Iso shades with the scene's light and reads the volume's colour.
        assert_eq!(iso.settings.lighting.lights.len(), 1);
        assert!(iso.reads_colour);
        // MIP neither shades nor reads colour: the mode says so, the scene asks it.
        assert!(mip.settings.lighting.lights.is_empty());
        assert!(!mip.reads_colour);
        let plan = crate::plan::plan(&scene, Some(u64::MAX)).unwrap();
        let enabled = |name: &str| plan.effects.iter().find(|d| d.name == name).unwrap().enabled;
        assert!(enabled("hello_iso: gradients"));
        assert!(!enabled("hello_volume: gradients"));
        assert!(enabled("hello_volume: empty-space skipping"));
        assert!(!enabled("hello_iso: early ray termination"));
    }
}
