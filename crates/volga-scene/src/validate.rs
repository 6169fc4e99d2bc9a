//! Raw scene → validated kernel types. Each check names the field path
//! (`objects[1].shape.radius`) of the value it refuses.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use glam::{DVec3, UVec3, Vec4};
use volga_core::{Aabb, Filter, GradientMethod, Grid, Transform};
use volga_render::{
    Attenuation, Camera, ImageSettings, Iso, Light, LightId, Lighting, Material, Mip, Mode, PointLight, Projection,
    RenderError, RenderSettings, Sampling, ShadowSettings, SurfaceColour, TransferFunction, Volume, XRay,
};

use crate::ctx::Ctx;
use crate::model::*;
use crate::nodes::union::Union;
use crate::nodes::{Node, Resolve};
use crate::SceneError;

/// A scene whose every value has been checked: what the planner and builder run.
///
/// Validation does no I/O: nodes that name files (meshes) load them in the resolve
/// stage ([`Scene::resolve`]).
#[derive(Debug)]
pub struct Scene {
    /// The scene file; relative paths in the scene (meshes, volumes) are read from its
    /// folder.
    pub source: PathBuf,
    /// The voxel grid, from `grid`: world box, voxel size and voxels per axis.
    pub grid: Grid,
    /// The node tree; its root is a union (the implicit union of `objects`, or `root`).
    pub root: Union,
    /// The image outputs, in file order.
    pub images: Vec<ImageJob>,
    /// The volume outputs, as written in the file (names checked).
    pub volumes: Vec<VolumeOutputSpec>,
    /// The mesh outputs, as written in the file (names checked).
    pub meshes: Vec<crate::model::MeshOutputSpec>,
    /// Whether the resolve stage may read files outside the scene's folder (absolute
    /// paths, `..` above it); `false` after validation. See
    /// [`BuildOptions::allow_outside_paths`](crate::BuildOptions::allow_outside_paths).
    pub allow_outside_paths: bool,
}

impl Scene {
    /// The resolve stage: loads every file the nodes name (paths relative to the scene
    /// file's folder). Before parsing a file, an upper bound on what parsing it takes
    /// (from its size) is checked against `memory_limit` (default: the machine's
    /// available memory).
    pub fn resolve(&mut self, memory_limit: Option<u64>) -> Result<(), SceneError> {
        let dir = self.source.parent().unwrap_or(Path::new(".")).to_owned();
        let cx = Resolve {
            scene: &self.source,
            dir: &dir,
            memory_limit: memory_limit
                .or_else(volga_core::memory::available_bytes)
                .unwrap_or(u64::MAX),
            allow_outside: self.allow_outside_paths,
        };
        self.root.resolve(&cx)
    }

    /// Whether the volume is voxelized: some image renders it, or a volume output
    /// writes it.
    pub fn needs_baked_volume(&self) -> bool {
        !self.volumes.is_empty() || self.images.iter().any(|i| i.source == RenderSource::Baked)
    }
}

/// What an image samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RenderSource {
    /// The voxelized volume, reconstructed with the image's filter.
    Baked,
    /// The node tree evaluated where rays sample it, without voxels.
    Lazy,
}

/// One image output: a camera, a mode and the render settings for it.
#[derive(Debug, Clone)]
pub struct ImageJob {
    /// File stem of the PNG (`{out}/{name}.png`; turntable frames append `_0000`, …).
    pub name: String,
    /// The `name` of the camera it is seen by.
    pub camera_name: String,
    /// The validated camera (world space).
    pub camera: Camera,
    /// The render mode, with its transfer function for `Volume` images.
    pub mode: Mode,
    /// Image size, ray sampling and lighting; lights are dropped when the mode does not
    /// shade.
    pub settings: RenderSettings,
    /// How the baked volume is reconstructed (unused by `Lazy` images).
    pub filter: Filter,
    /// How the baked volume's gradients are taken.
    pub gradient: GradientMethod,
    /// PNG bits per channel: 8 or 16.
    pub bit_depth: u8,
    /// Whether it samples the baked volume or the node tree.
    pub source: RenderSource,
    /// The image reads the volume's colour channel.
    pub reads_colour: bool,
    /// A turntable: the image is rendered once per frame with the camera turned.
    pub turntable: Option<crate::turntable::Turntable>,
}

/// Largest voxel count per axis a scene may ask for (the grid type's own limit).
const MAX_DIM: f64 = (i32::MAX / 2) as f64;

/// Validates a parsed scene file: every value's range, the grid, the node tree, cameras,
/// lights and output names. `path` names the file in errors and is where relative paths
/// start. Reads no file (see [`Scene::resolve`]).
///
/// # Errors
/// [`SceneError::Invalid`] naming the field path of the first value refused, e.g.
/// `objects[1].shape.radius`, `outputs.images[0].width` or `grid` (give either `resolution`
/// or `voxel_size`).
pub fn validate(path: &Path, file: &SceneFile) -> Result<Scene, SceneError> {
    let cx = Ctx { path };
    let grid = validate_grid(&cx, &file.grid)?;

    let root = match (&file.objects, &file.root) {
        (Some(_), Some(_)) => {
            return Err(cx.err(
                "root",
                "give either `root` (a node tree) or `objects` (a list merged by union), not both",
            ))
        }
        (None, None) => {
            return Err(cx.err(
                "objects",
                "the scene has no objects: give `objects` (a list merged by union) or `root` (a node tree)",
            ))
        }
        (Some(objects), None) => Union::from_objects(&cx, "objects", objects)?,
        (None, Some(node)) => Union::from_root(&cx, "root", node)?,
    };

    let transfer = validate_transfer(&cx, file.transfer_function.as_deref())?;
    let lights = validate_lights(&cx, &file.lights)?;
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
        if let (Some(t), Some(job)) = (&im.turntable, images.last_mut()) {
            // The default centre is the camera's target (validated with the camera).
            let target = file.cameras.iter().find(|c| c.name == im.camera).map(|c| c.target);
            let center = target.map(DVec3::from_array);
            let f = format!("{f}.turntable");
            job.turntable = Some(crate::turntable::validate(&cx, &f, t, &job.camera, center)?);
        }
        let frame_stems = match &im.turntable {
            None => vec![im.name.clone()],
            Some(t) => (0..t.frames)
                .map(|k| crate::turntable::frame_stem(&im.name, k))
                .collect(),
        };
        if !frame_stems.into_iter().all(|stem| stems.insert(stem)) {
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
        if v.half && v.format != crate::model::VolumeFormatSpec::Vdb {
            return Err(cx.err(
                format!("outputs.volumes[{i}].half"),
                "16-bit values are a .vdb option: set `format: Vdb`",
            ));
        }
    }
    for (i, m) in file.outputs.meshes.iter().enumerate() {
        let f = format!("outputs.meshes[{i}].name");
        cx.file_stem(&f, &m.name)?;
        if !stems.insert(m.name.clone()) {
            return Err(cx.err(f, format!("output name `{}` is used twice (or is reserved)", m.name)));
        }
        if let Some(a) = m.adaptivity {
            if !(0.0..=10.0).contains(&a) {
                return Err(cx.err(
                    format!("outputs.meshes[{i}].adaptivity"),
                    format!("must be between 0 and 10 voxels, got {a}"),
                ));
            }
        }
    }
    if images.is_empty() && file.outputs.volumes.is_empty() && file.outputs.meshes.is_empty() {
        return Err(cx.err("outputs", "the scene asks for no output (no images, no volumes)"));
    }

    Ok(Scene {
        source: path.to_owned(),
        grid,
        root,
        images,
        volumes: file.outputs.volumes.clone(),
        meshes: file.outputs.meshes.clone(),
        allow_outside_paths: false,
    })
}

fn validate_grid(cx: &Ctx, g: &GridSpec) -> Result<Grid, SceneError> {
    let min = cx.finite3("grid.bounds.min", g.bounds.min)?;
    let max = cx.finite3("grid.bounds.max", g.bounds.max)?;
    if min.cmpge(max).any() {
        return Err(cx.err("grid.bounds", "min must be < max on every axis"));
    }
    for (name, v) in [("grid.bounds.min", min), ("grid.bounds.max", max)] {
        if v.abs().max_element() > volga_core::MAX_WORLD {
            return Err(cx.err(
                name,
                format!("must lie within ±1e100 world units on every axis, got {v}"),
            ));
        }
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
    // The field that set the voxel size.
    let size_field = if g.resolution.is_some() {
        "grid.resolution"
    } else {
        "grid.voxel_size"
    };
    if voxel.min_element() < volga_core::MIN_SPACING {
        return Err(cx.err(
            size_field,
            format!("makes voxels of {voxel}: voxels must be at least 1e-100 world units (scale the scene up)"),
        ));
    }
    // Cells tile the bounds; a side that is not a whole number of voxels is rounded up
    // (the tolerance absorbs the rounding of size / voxel).
    let dims_f = (size / voxel - 1e-9).ceil().max(DVec3::ONE);
    if dims_f.max_element() > MAX_DIM {
        return Err(cx.err(
            size_field,
            format!("asks for {dims_f:?} voxels per axis; at most {MAX_DIM} are supported"),
        ));
    }
    let dims = UVec3::new(dims_f.x as u32, dims_f.y as u32, dims_f.z as u32);
    let transform = Transform::new(min + voxel * 0.5, voxel).map_err(|e| cx.err("grid", e.to_string()))?;
    Grid::new(transform, dims).map_err(|e| cx.err("grid", e.to_string()))
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
    lights: &Lighting,
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
            supersampling: im.supersampling.unwrap_or(1),
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
        lighting: if im.shading.unwrap_or(true) {
            Lighting {
                material,
                ..lights.clone()
            }
        } else {
            Lighting {
                material,
                ..Lighting::unlit()
            }
        },
    };
    if let Some(step) = im.shadow_step_voxels {
        if !(step.is_finite() && step > 0.0 && step <= 16.0) {
            return Err(cx.err(
                format!("{f}.shadow_step_voxels"),
                format!("must lie in (0, 16] voxels, got {step}"),
            ));
        }
        settings.lighting.shadows.step_voxels = step;
    }
    if im.light_space_shadows.unwrap_or(false) {
        if !matches!(mode, Mode::Volume(_)) {
            return Err(cx.err(
                format!("{f}.light_space_shadows"),
                "the light-space pre-pass shadows volume rendering: it needs `mode: Volume`",
            ));
        }
        settings.lighting.shadows.light_space = true;
    }
    if im.pre_integration.unwrap_or(false) {
        if !matches!(mode, Mode::Volume(_)) {
            return Err(cx.err(
                format!("{f}.pre_integration"),
                "pre-integration classifies volume rendering: it needs `mode: Volume`",
            ));
        }
        settings.sampling.pre_integration = true;
    }
    // The mode says what it needs: lights only where it shades, colour where it reads it.
    let effects = mode.integrator().effects(&settings);
    if !effects.gradients.enabled {
        settings.lighting.lights.clear();
        settings.lighting.point_lights.clear();
        settings.lighting.shadows.casters.clear();
    }
    let reads_colour = effects.colour.enabled;
    // Samples per ray over the grid the image renders, primary and shadow rays, with
    // what they depend on named (the step, and the grid's voxels along its diagonal).
    let diagonal_voxels = grid.sampled_bounds().size().length() / grid.transform.spacing().min_element();
    let mut steps = vec![("step_voxels", settings.sampling.step_voxels)];
    if !settings.lighting.shadows.casters.is_empty() {
        steps.push(("shadow_step_voxels", settings.lighting.shadows.step_voxels));
    }
    for (name, step) in steps {
        let samples = diagonal_voxels / step;
        if step > 0.0 && (samples.is_nan() || samples > volga_render::MAX_SAMPLES_PER_RAY as f64) {
            let d = grid.dims();
            return Err(cx.err(
                format!("{f}.{name}"),
                format!(
                    "a ray may cross {diagonal_voxels:.0} voxels (the diagonal of the {}×{}×{} grid): at {name} {step} that is {samples:.3e} samples, more than the {} one ray may take; raise {name} or lower the grid's resolution",
                    d.x,
                    d.y,
                    d.z,
                    volga_render::MAX_SAMPLES_PER_RAY
                ),
            ));
        }
    }
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
        FilterSpec::CatmullRom => Filter::CatmullRom,
        FilterSpec::BSpline => Filter::BSpline,
    };
    let bit_depth = im.bit_depth.unwrap_or(8);
    if bit_depth != 8 && bit_depth != 16 {
        return Err(cx.err(format!("{f}.bit_depth"), format!("must be 8 or 16, got {bit_depth}")));
    }
    let gradient = match im.gradient.unwrap_or(GradientSpec::CentralDifference) {
        GradientSpec::CentralDifference => GradientMethod::CentralDifference,
        GradientSpec::Analytic => GradientMethod::Analytic,
    };
    let source = match im.source.unwrap_or(SourceSpec::Baked) {
        SourceSpec::Baked => RenderSource::Baked,
        SourceSpec::Lazy if im.filter.is_some() => {
            return Err(cx.err(
                format!("{f}.filter"),
                "`filter` reconstructs the baked volume; a `Lazy` image samples the nodes directly (remove one)",
            ))
        }
        SourceSpec::Lazy if im.gradient.is_some() => {
            return Err(cx.err(
                format!("{f}.gradient"),
                "`gradient` differentiates the baked volume's reconstruction; a `Lazy` image samples the nodes directly (remove one)",
            ))
        }
        SourceSpec::Lazy => RenderSource::Lazy,
    };
    Ok(ImageJob {
        name: im.name.clone(),
        camera_name: im.camera.clone(),
        camera,
        mode,
        settings,
        filter,
        gradient,
        bit_depth,
        source,
        reads_colour,
        turntable: None,
    })
}

/// Most lights a scene may have.
pub const MAX_LIGHTS: usize = 64;
/// Most lights that may cast shadows.
pub const MAX_SHADOW_CASTERS: usize = 8;

/// The scene's `lights`: directional ones (`direction`) and point ones
/// (`position`, optional `attenuation`), and which cast shadows, as the lighting
/// every shaded image starts from.
fn validate_lights(cx: &Ctx, specs: &[LightSpec]) -> Result<Lighting, SceneError> {
    if specs.len() > MAX_LIGHTS {
        return Err(cx.err(
            "lights",
            format!(
                "{} lights: a scene may have at most {MAX_LIGHTS} (every shaded sample visits each one)",
                specs.len()
            ),
        ));
    }
    let casters = specs.iter().filter(|l| l.shadows).count();
    if casters > MAX_SHADOW_CASTERS {
        return Err(cx.err(
            "lights",
            format!(
                "{casters} lights cast shadows: at most {MAX_SHADOW_CASTERS} may (each casts a shadow ray from every shaded sample)"
            ),
        ));
    }
    let mut lighting = Lighting {
        lights: Vec::new(),
        point_lights: Vec::new(),
        shadows: ShadowSettings::default(),
        ..Lighting::default()
    };
    for (i, l) in specs.iter().enumerate() {
        let f = format!("lights[{i}]");
        cx.unit_interval(&format!("{f}.colour"), &l.colour)?;
        let colour = DVec3::from_array(l.colour).as_vec3();
        let id = match (l.direction, l.position) {
            (Some(d), None) => {
                let dir = cx.finite3(&format!("{f}.direction"), d)?;
                if dir.length_squared() == 0.0 {
                    return Err(cx.err(format!("{f}.direction"), "must not be the zero vector"));
                }
                if l.attenuation.is_some() {
                    return Err(cx.err(
                        format!("{f}.attenuation"),
                        "only point lights (`position`) are attenuated with distance",
                    ));
                }
                lighting.lights.push(Light { direction: dir, colour });
                LightId::Directional(lighting.lights.len() - 1)
            }
            (None, Some(p)) => {
                let position = cx.finite3(&format!("{f}.position"), p)?;
                let attenuation = match l.attenuation {
                    None => Attenuation::NONE,
                    Some(a) => {
                        let path = format!("{f}.attenuation");
                        if !a.iter().all(|c| c.is_finite() && *c >= 0.0) || a.iter().all(|c| *c == 0.0) {
                            return Err(cx.err(
                                path,
                                format!("(constant, linear, quadratic) must be finite and ≥ 0, not all 0, got {a:?}"),
                            ));
                        }
                        Attenuation {
                            constant: a[0],
                            linear: a[1],
                            quadratic: a[2],
                        }
                    }
                };
                lighting.point_lights.push(PointLight {
                    position,
                    colour,
                    attenuation,
                });
                LightId::Point(lighting.point_lights.len() - 1)
            }
            (Some(_), Some(_)) => {
                return Err(cx.err(
                    f,
                    "give either `direction` (a directional light) or `position` (a point light), not both",
                ))
            }
            (None, None) => {
                return Err(cx.err(
                    f,
                    "give `direction` (a directional light) or `position` (a point light)",
                ))
            }
        };
        if l.shadows {
            lighting.shadows.casters.push(id);
        }
    }
    Ok(lighting)
}

/// World bounds of all objects (for tools that frame a camera); unbounded quadrics
/// count as the grid's bounds.
pub fn content_bounds(scene: &Scene) -> Aabb {
    scene.root.bounds().intersection(&scene.grid.world_bounds())
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
    fn filters_and_gradient_methods_are_chosen_per_image() {
        // The first image only.
        let with = |extra: &str| {
            HELLO.replacen(
                "width: 512, height: 512),",
                &format!("width: 512, height: 512, {extra}),"),
                1,
            )
        };
        let scene = load(&with("filter: Some(CatmullRom), gradient: Some(Analytic)")).unwrap();
        assert_eq!(scene.images[0].filter, Filter::CatmullRom);
        assert_eq!(scene.images[0].gradient, GradientMethod::Analytic);
        assert_eq!(scene.images[1].filter, Filter::Trilinear);
        assert_eq!(scene.images[1].gradient, GradientMethod::CentralDifference);
        let scene = load(&with("filter: Some(BSpline)")).unwrap();
        assert_eq!(scene.images[0].filter, Filter::BSpline);
        // Supersampling: per image, checked by the renderer's rule, named by field path.
        let scene = load(&with("supersampling: Some(3)")).unwrap();
        assert_eq!(scene.images[0].settings.image.supersampling, 3);
        assert_eq!(scene.images[1].settings.image.supersampling, 1);
        assert_eq!(scene.images[0].bit_depth, 8);
        assert_eq!(load(&with("bit_depth: Some(16)")).unwrap().images[0].bit_depth, 16);
        let (field, _) = invalid_field(&with("bit_depth: Some(12)"));
        assert_eq!(field, "outputs.images[0].bit_depth");
        let (field, message) = invalid_field(&with("supersampling: Some(0)"));
        assert_eq!(field, "outputs.images[0].supersampling");
        assert!(message.contains("1 to 16"), "{message}");
        // A lazy image has no reconstruction to differentiate.
        let (field, message) = invalid_field(&with("source: Some(Lazy), gradient: Some(Analytic)"));
        assert_eq!(field, "outputs.images[0].gradient");
        assert!(message.contains("Lazy"), "{message}");
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
