//! The scene file as users write it (RON or JSON). These serde types are the raw
//! input: [`crate::validate`] turns them into checked kernel types, so the kernel never
//! sees unvalidated user input. Every struct denies unknown fields.

use serde::{Deserialize, Serialize};

pub type V3 = [f64; 3];

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
/// RON files may name the top-level struct `Scene(...)`.
#[serde(deny_unknown_fields, rename = "Scene")]
pub struct SceneFile {
    pub grid: GridSpec,
    /// The objects, merged with the fuzzy union (max) in this order. Either this or
    /// `root`.
    #[serde(default)]
    pub objects: Option<Vec<ObjectSpec>>,
    /// The scene as a tree of nodes (operators over objects). Either this or `objects`.
    #[serde(default)]
    pub root: Option<NodeSpec>,
    #[serde(default)]
    pub transfer_function: Option<Vec<TransferPoint>>,
    #[serde(default)]
    pub lights: Vec<LightSpec>,
    #[serde(default)]
    pub material: Option<MaterialSpec>,
    pub cameras: Vec<CameraSpec>,
    pub outputs: OutputsSpec,
}

/// The voxel grid: a world box tiled by voxel cells, sized either by `resolution`
/// (voxels along the box's longest side, cubic voxels) or by `voxel_size`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    pub bounds: BoundsSpec,
    #[serde(default)]
    pub resolution: Option<u64>,
    #[serde(default)]
    pub voxel_size: Option<VoxelSize>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundsSpec {
    pub min: V3,
    pub max: V3,
}

/// One edge length for cubic voxels, or three for anisotropic ones.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum VoxelSize {
    Cubic(f64),
    PerAxis(V3),
}

/// A node of the scene tree: an operator over nodes, or an object (a leaf).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum NodeSpec {
    /// Fuzzy union (max, survey eq. 17) of the operands, in order; colour from the
    /// operand that is strictly densest (the first on ties).
    Union(Vec<NodeSpec>),
    /// A leaf: one object (RON: `Object(name: "ball", shape: Sphere(...), colour: ...)`),
    /// the fields of [`ObjectSpec`].
    Object {
        #[serde(default)]
        name: Option<String>,
        shape: ShapeSpec,
        #[serde(default)]
        colour: Option<V3>,
    },
    /// A CVG operator (survey §17.5, eqs. 17–18) over nodes (`nodes/cvg.rs`).
    Cvg(crate::nodes::cvg::CvgSpec),
    /// A fuzzy primitive, density `1 − r/R` (`nodes/fuzzy.rs`).
    Fuzzy(crate::nodes::fuzzy::FuzzySpec),
    /// A sampled volume from a `.binvox` / `.nrrd` file (`nodes/volume.rs`).
    Volume(crate::nodes::volume::VolumeSpec),
    /// A solid texture painting a node (`nodes/textured.rs`).
    Textured(crate::nodes::textured::TexturedSpec),
    /// A Perlin–Hoffert hypertexture (`nodes/hypertexture.rs`).
    Hypertexture(crate::nodes::hypertexture::HypertextureSpec),
    /// The operand sampled into a sculpt (Bærentzen's octree on the scene grid), then
    /// edited by `strokes` (stroke files' syntax: carve, add, spray, paint, smooth, saws).
    Sculpt {
        operand: Box<NodeSpec>,
        strokes: Vec<crate::strokes::StrokeSpec>,
    },
    /// An adaptively sampled distance field built from a mesh or a shape (`nodes/adf.rs`).
    Adf(crate::nodes::adf::AdfSpec),
}

/// A solid of the scene: a leaf whose shape decides its node kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    #[serde(default)]
    pub name: Option<String>,
    pub shape: ShapeSpec,
    /// Linear RGB in \[0, 1\]; white when absent.
    #[serde(default)]
    pub colour: Option<V3>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ShapeSpec {
    Sphere {
        center: V3,
        radius: f64,
    },
    Box {
        min: V3,
        max: V3,
    },
    /// Rotation as intrinsic X-then-Y-then-Z Euler angles in degrees.
    OrientedBox {
        center: V3,
        half_extents: V3,
        rotation_deg: V3,
    },
    Ellipsoid {
        center: V3,
        radii: V3,
        #[serde(default)]
        rotation_deg: V3,
    },
    /// Circular cylinder around `axis` through `center`; infinite without `half_length`
    /// (then clipped by the grid).
    Cylinder {
        center: V3,
        axis: V3,
        radius: f64,
        #[serde(default)]
        half_length: Option<f64>,
    },
    /// Solid cone with its apex at `apex`, opening along `axis`; capped at `height` or
    /// infinite.
    Cone {
        apex: V3,
        axis: V3,
        half_angle_deg: f64,
        #[serde(default)]
        height: Option<f64>,
    },
    /// The general quadric solid xᵀAx + bᵀx + c ≤ 0, clipped by `clip`; `a` lists the
    /// rows of A.
    Quadric {
        a: [V3; 3],
        b: V3,
        c: f64,
        clip: BoundsSpec,
    },
    /// A line segment drawn as a tube of `radius` (an anti-aliased 3D line).
    Capsule {
        a: V3,
        b: V3,
        radius: f64,
    },
    /// A ring torus: the solid within `minor_radius` of the circle of `major_radius`
    /// around `axis` through `center` (`0 < minor_radius < major_radius`).
    Torus {
        center: V3,
        axis: V3,
        major_radius: f64,
        minor_radius: f64,
    },
    /// A triangle mesh given inline: corner positions and index triples (0-based), as a
    /// solid like `Mesh`.
    Triangles {
        vertices: Vec<V3>,
        triangles: Vec<[u32; 3]>,
    },
    /// A triangle mesh (.obj, .gltf, .glb; path relative to the scene file), as a solid:
    /// inside where its generalized winding number is ≥ ½.
    Mesh {
        path: String,
        #[serde(default)]
        translate: V3,
        #[serde(default = "unit_scale")]
        scale: f64,
    },
}

fn unit_scale() -> f64 {
    1.0
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransferPoint {
    pub value: f64,
    pub rgba: [f64; 4],
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Direction towards the light (world space): a directional light. Give either
    /// this or `position`.
    #[serde(default)]
    pub direction: Option<V3>,
    /// World position of a point light. Give either this or `direction`.
    #[serde(default)]
    pub position: Option<V3>,
    #[serde(default = "white")]
    pub colour: V3,
    /// Point lights only: the colour is divided by `c + l·d + q·d²` at world
    /// distance `d`, given as `(c, l, q)`; default `(1, 0, 0)` (no attenuation).
    #[serde(default)]
    pub attenuation: Option<V3>,
    /// The light casts volumetric shadows (survey eq. 10) in shaded iso and volume
    /// images; default false.
    #[serde(default)]
    pub shadows: bool,
}

fn white() -> V3 {
    [1.0; 3]
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    pub ambient: f64,
    pub diffuse: f64,
    pub specular: f64,
    pub shininess: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub name: String,
    pub eye: V3,
    pub target: V3,
    #[serde(default = "y_up")]
    pub up: V3,
    pub projection: ProjectionSpec,
}

fn y_up() -> V3 {
    [0.0, 1.0, 0.0]
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ProjectionSpec {
    Perspective { fov_deg: f64 },
    Orthographic { height: f64 },
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputsSpec {
    #[serde(default)]
    pub images: Vec<ImageSpec>,
    #[serde(default)]
    pub volumes: Vec<VolumeOutputSpec>,
    /// Meshes of the scene's ½ iso-surface (`volga-mesh`'s shared extractor).
    #[serde(default)]
    pub meshes: Vec<MeshOutputSpec>,
}

/// A mesh output: the ½ iso-surface of the node tree (its lazy field) on the grid's
/// lattice, closed and manifold where the surface lies inside the grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshOutputSpec {
    /// File stem: `{out}/{name}.obj` or `.ply`.
    pub name: String,
    pub format: MeshFormatSpec,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MeshFormatSpec {
    Obj,
    Ply,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageSpec {
    /// File stem: the image is written to `{out}/{name}.png`.
    pub name: String,
    pub camera: String,
    pub mode: ModeSpec,
    pub width: u32,
    pub height: u32,
    /// Ray step in voxels (default 0.5).
    #[serde(default)]
    pub step_voxels: Option<f64>,
    #[serde(default)]
    pub filter: Option<FilterSpec>,
    /// How shading normals are taken from the baked volume: `CentralDifference`
    /// (default) or `Analytic` (the filter's own derivative).
    #[serde(default)]
    pub gradient: Option<GradientSpec>,
    /// PNG bits per channel: 8 (default) or 16.
    #[serde(default)]
    pub bit_depth: Option<u8>,
    /// Rays per pixel along each axis (`k × k` per pixel, averaged; default 1).
    #[serde(default)]
    pub supersampling: Option<u32>,
    /// Phong shading from the scene's lights (default true; needs lights).
    #[serde(default)]
    pub shading: Option<bool>,
    #[serde(default)]
    pub early_ray_termination: Option<bool>,
    #[serde(default)]
    pub empty_space_skipping: Option<bool>,
    #[serde(default)]
    pub background: Option<[f64; 4]>,
    /// What rays sample: the voxelized volume (`Baked`, default) or the node tree
    /// itself (`Lazy`, no voxels; `filter` does not apply).
    #[serde(default)]
    pub source: Option<SourceSpec>,
    /// Shadow ray step in voxels for the lights with `shadows: true` (default 1).
    #[serde(default)]
    pub shadow_step_voxels: Option<f64>,
    /// `Volume` images: directional lights' shadows from a light-space pre-pass
    /// (one transmittance grid per light) instead of a shadow ray per sample (default false).
    #[serde(default)]
    pub light_space_shadows: Option<bool>,
    /// Pre-integrated transfer function for `Volume` images (default false).
    #[serde(default)]
    pub pre_integration: Option<bool>,
    /// Render a turntable: `frames` images `{name}_0000.png`… with the camera
    /// turned about an axis instead of one `{name}.png`.
    #[serde(default)]
    pub turntable: Option<TurntableSpec>,
}

/// A turntable sequence: the camera (eye, target and up) turned about the line
/// through `center` along `axis` by `360°·k/frames` for frame `k`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TurntableSpec {
    /// Number of frames, 1 to 3600.
    pub frames: u32,
    /// Rotation axis (default +y).
    #[serde(default = "y_up")]
    pub axis: V3,
    /// A point on the axis (default: the camera's target).
    #[serde(default)]
    pub center: Option<V3>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SourceSpec {
    Baked,
    Lazy,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FilterSpec {
    Nearest,
    Trilinear,
    CatmullRom,
    BSpline,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum GradientSpec {
    CentralDifference,
    Analytic,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ModeSpec {
    /// Shaded iso-surface at `value`; colour from the objects (`FromVolume`) or fixed.
    Iso {
        value: f64,
        #[serde(default)]
        colour: Option<ColourSpec>,
    },
    /// Full volume rendering with the scene's transfer function; RGB from the objects'
    /// colours when `colour_from_volume` is true.
    Volume {
        #[serde(default)]
        colour_from_volume: bool,
    },
    Mip,
    XRay,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ColourSpec {
    FromVolume,
    Constant(V3),
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeOutputSpec {
    /// File stem: `{out}/{name}.nrrd` + `{out}/{name}.raw`.
    pub name: String,
    /// Also write the colour channel (`{name}_colour.nrrd`).
    #[serde(default)]
    pub colour: bool,
}
