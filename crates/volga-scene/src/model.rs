//! The scene file as users write it (RON or JSON). These serde types are the raw
//! input: [`crate::validate`] turns them into checked kernel types, so the kernel never
//! sees unvalidated user input. Every struct denies unknown fields.

use serde::{Deserialize, Serialize};

/// A 3-vector `(x, y, z)` (JSON: `[x, y, z]`): a world position, offset or direction, or a
/// linear RGB colour, as each field says.
pub type V3 = [f64; 3];

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
/// RON files may name the top-level struct `Scene(...)`.
#[serde(deny_unknown_fields, rename = "Scene")]
pub struct SceneFile {
    /// The voxel grid every node is sampled on and the baked volume is stored on; required.
    pub grid: GridSpec,
    /// The objects, merged with the fuzzy union (max) in this order. Either this or
    /// `root`.
    #[serde(default)]
    pub objects: Option<Vec<ObjectSpec>>,
    /// The scene as a tree of nodes (operators over objects). Either this or `objects`.
    #[serde(default)]
    pub root: Option<NodeSpec>,
    /// Density → colour and opacity for `Volume` images: `(value, rgba)` points, linear in
    /// between and sorted by `value` on load (values finite and distinct, `rgba` in
    /// \[0, 1\], at least one point). An opacity holds for a ray step of one voxel and is
    /// corrected for other steps. Absent: transparent up to density 0.3, translucent white
    /// at 0.5 (α 0.15), α 0.3 at 1.
    #[serde(default)]
    pub transfer_function: Option<Vec<TransferPoint>>,
    /// Directional and point lights shading `Iso` and `Volume` images (those with
    /// `shading`, the default); default none, and an image without lights is unlit.
    #[serde(default)]
    pub lights: Vec<LightSpec>,
    /// Phong coefficients of every shaded image; absent:
    /// `(ambient: 0.15, diffuse: 0.75, specular: 0.3, shininess: 32)`.
    #[serde(default)]
    pub material: Option<MaterialSpec>,
    /// The named cameras images refer to (`outputs.images[i].camera`); required, names
    /// unique.
    pub cameras: Vec<CameraSpec>,
    /// What the build writes: images, volumes and meshes; at least one output in all.
    pub outputs: OutputsSpec,
}

/// The voxel grid: a world box tiled by voxel cells, sized either by `resolution`
/// (voxels along the box's longest side, cubic voxels) or by `voxel_size`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// World box the voxel cells tile; `min < max` on every axis. Voxel `ijk`'s centre is
    /// `bounds.min + (ijk + ½)·h` for voxel size `h`.
    pub bounds: BoundsSpec,
    /// Voxels along the longest side of `bounds`, ≥ 1; cubic voxels, the other sides get as
    /// many as they need (rounded up, so the grid may reach a little beyond `bounds.max`).
    /// At most 2³⁰ − 1 voxels per axis. Either this or `voxel_size`.
    #[serde(default)]
    pub resolution: Option<u64>,
    /// Voxel edge length in world units, finite and > 0: one number (cubic voxels) or
    /// `(hx, hy, hz)` (anisotropic). A side of `bounds` that is not a whole number of
    /// voxels is rounded up; at most 2³⁰ − 1 voxels per axis. Either this or `resolution`.
    #[serde(default)]
    pub voxel_size: Option<VoxelSize>,
}

/// An axis-aligned world box given by two corners.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundsSpec {
    /// Lowest corner (world units); below `max` on every axis.
    pub min: V3,
    /// Highest corner (world units); above `min` on every axis.
    pub max: V3,
}

/// One edge length for cubic voxels, or three for anisotropic ones.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum VoxelSize {
    /// One edge length for all three axes (world units, > 0).
    Cubic(f64),
    /// Edge lengths along x, y and z (world units, each > 0).
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
        /// A label for reports; default `objectN`, N counting the tree's leaf nodes
        /// (objects, `Fuzzy`, `Volume`, `Hypertexture`, `Adf`) in file order from 0.
        #[serde(default)]
        name: Option<String>,
        /// What the object is (required); the shape's kind decides the node kind.
        shape: ShapeSpec,
        /// Linear RGB in \[0, 1\]; white when absent.
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
        /// The node sampled into the sculpt (any node). The grid must have cubic voxels.
        operand: Box<NodeSpec>,
        /// The edits, applied in order: `(op, tool, rotation_deg, translate, path)` as in
        /// stroke files (`volga sculpt --strokes`); checked in the resolve stage, since
        /// mesh tools are files.
        strokes: Vec<crate::strokes::StrokeSpec>,
    },
    /// An adaptively sampled distance field built from a mesh or a shape (`nodes/adf.rs`).
    Adf(crate::nodes::adf::AdfSpec),
}

/// A solid of the scene: a leaf whose shape decides its node kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    /// A label for reports; default `objectN` for `objects[N]`.
    #[serde(default)]
    pub name: Option<String>,
    /// What the object is (required); the shape's kind decides the node kind (analytic
    /// shape, torus or mesh).
    pub shape: ShapeSpec,
    /// Linear RGB in \[0, 1\]; white when absent.
    #[serde(default)]
    pub colour: Option<V3>,
}

/// The geometry of an object, an `Adf` source or a sculpting tool, in world units. Every
/// shape is a solid, anti-aliased by the grid's oriented box filter (density
/// `clamp(½ − d/W, 0, 1)` of the signed distance `d`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ShapeSpec {
    /// A ball.
    Sphere {
        /// World position of the centre.
        center: V3,
        /// Radius in world units, finite and > 0.
        radius: f64,
    },
    /// An axis-aligned box.
    Box {
        /// Lowest corner (world units); below `max` on every axis.
        min: V3,
        /// Highest corner (world units); above `min` on every axis.
        max: V3,
    },
    /// Rotation as intrinsic X-then-Y-then-Z Euler angles in degrees.
    OrientedBox {
        /// World position of the centre.
        center: V3,
        /// Half the edge lengths along the box's own x, y and z axes (world units,
        /// each > 0).
        half_extents: V3,
        /// Rotation about the centre (required; `(0, 0, 0)` for none).
        rotation_deg: V3,
    },
    /// An ellipsoid with exact distance (Eberly).
    Ellipsoid {
        /// World position of the centre.
        center: V3,
        /// Semi-axis lengths along the ellipsoid's own x, y and z axes (world units,
        /// each > 0).
        radii: V3,
        /// Rotation about the centre as intrinsic X-then-Y-then-Z Euler angles in degrees;
        /// default `(0, 0, 0)`.
        #[serde(default)]
        rotation_deg: V3,
    },
    /// Circular cylinder around `axis` through `center`; infinite without `half_length`
    /// (then clipped by the grid).
    Cylinder {
        /// A world point on the axis; the middle of the cylinder when it has a
        /// `half_length`.
        center: V3,
        /// Direction of the axis (any length, not zero).
        axis: V3,
        /// Radius in world units, finite and > 0.
        radius: f64,
        /// Half the length along `axis`, on each side of `center` (world units, > 0).
        /// Absent: infinite, clipped by the grid (sculpting tools need it).
        #[serde(default)]
        half_length: Option<f64>,
    },
    /// Solid cone with its apex at `apex`, opening along `axis`; capped at `height` or
    /// infinite.
    Cone {
        /// World position of the tip.
        apex: V3,
        /// Direction the cone opens along from the apex (any length, not zero).
        axis: V3,
        /// Angle between the axis and the side in degrees, in (0, 90).
        half_angle_deg: f64,
        /// Distance from the apex to the flat cap along the axis (world units, > 0).
        /// Absent: infinite, clipped by the grid (sculpting tools need it).
        #[serde(default)]
        height: Option<f64>,
    },
    /// The general quadric solid xᵀAx + bᵀx + c ≤ 0, clipped by `clip`; `a` lists the
    /// rows of A.
    Quadric {
        /// The three rows of the 3×3 matrix A, finite; only its symmetric part matters. A
        /// and `b` must not both be zero.
        a: [V3; 3],
        /// The linear coefficients b, finite.
        b: V3,
        /// The constant term c, finite.
        c: f64,
        /// The world box the solid is restricted to (`min < max` on every axis); it bounds
        /// quadrics that are unbounded (cylinders, cones, paraboloids, half-spaces). The
        /// distance is first order, `F/‖∇F‖`.
        clip: BoundsSpec,
    },
    /// A line segment drawn as a tube of `radius` (an anti-aliased 3D line).
    Capsule {
        /// World position of one end of the segment.
        a: V3,
        /// World position of the other end (may equal `a`: a ball).
        b: V3,
        /// Tube radius in world units, finite and > 0.
        radius: f64,
    },
    /// A ring torus: the solid within `minor_radius` of the circle of `major_radius`
    /// around `axis` through `center` (`0 < minor_radius < major_radius`).
    Torus {
        /// World position of the centre.
        center: V3,
        /// Axis of symmetry through `center` (any length, not zero).
        axis: V3,
        /// Radius of the circle the tube follows (world units); greater than
        /// `minor_radius`.
        major_radius: f64,
        /// Radius of the tube (world units), finite and > 0.
        minor_radius: f64,
    },
    /// A triangle mesh given inline: corner positions and index triples (0-based), as a
    /// solid like `Mesh`.
    Triangles {
        /// Corner positions (world units), finite.
        vertices: Vec<V3>,
        /// Index triples into `vertices`, 0-based and in range; at least one triangle,
        /// wound counter-clockwise seen from outside (inside is where the winding number is
        /// ≥ ½).
        triangles: Vec<[u32; 3]>,
    },
    /// A triangle mesh (.obj, .gltf, .glb; path relative to the scene file), as a solid:
    /// inside where its generalized winding number is ≥ ½.
    Mesh {
        /// The `.obj`, `.gltf` or `.glb` file, relative to the scene file's folder; read in
        /// the resolve stage, and refused beforehand when parsing it may need more than the
        /// memory limit.
        path: String,
        /// Offset added after scaling (world units); default `(0, 0, 0)`.
        #[serde(default)]
        translate: V3,
        /// Uniform factor applied to the file's coordinates before `translate`, finite
        /// and > 0; default 1.
        #[serde(default = "unit_scale")]
        scale: f64,
    },
}

fn unit_scale() -> f64 {
    1.0
}

/// One control point of the transfer function.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransferPoint {
    /// Density at which `rgba` holds; finite and distinct from the other points' values.
    pub value: f64,
    /// Linear RGB and opacity at `value`, each in \[0, 1\]; the opacity holds for a ray
    /// step of one voxel.
    pub rgba: [f64; 4],
}

/// A light: directional (`direction`) or point (`position`); give exactly one of the two.
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
    /// Linear RGB intensity, each component in \[0, 1\]; default white `(1, 1, 1)`.
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

/// Phong coefficients (survey eq. 9) of every shaded image; all four are required when
/// `material` is given.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Ambient coefficient, in \[0, 1\] (0.15 without `material`).
    pub ambient: f64,
    /// Diffuse coefficient, in \[0, 1\] (0.75 without `material`).
    pub diffuse: f64,
    /// Specular coefficient, in \[0, 1\] (0.3 without `material`).
    pub specular: f64,
    /// Specular exponent, finite and ≥ 1 (32 without `material`).
    pub shininess: f64,
}

/// A named camera looking from `eye` at `target`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Unique name; images refer to it (`outputs.images[i].camera`).
    pub name: String,
    /// World position of the viewpoint.
    pub eye: V3,
    /// World point the camera looks at, different from `eye`; also the default centre of a
    /// turntable.
    pub target: V3,
    /// World direction that is up in the image (any length; not zero, not parallel to
    /// `target − eye`); default `(0, 1, 0)`.
    #[serde(default = "y_up")]
    pub up: V3,
    /// `Perspective(fov_deg)` or `Orthographic(height)`.
    pub projection: ProjectionSpec,
}

fn y_up() -> V3 {
    [0.0, 1.0, 0.0]
}

/// How a camera projects the scene onto the image.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ProjectionSpec {
    /// A pinhole camera: rays fan out from `eye`.
    Perspective {
        /// Vertical field of view in degrees, in (0, 180); the horizontal one follows
        /// from the image's aspect ratio.
        fov_deg: f64,
    },
    /// Parallel rays along the view direction.
    Orthographic {
        /// World height the image spans, finite and > 0; its width follows from the
        /// image's aspect ratio.
        height: f64,
    },
}

/// What a build writes to the output folder; each list optional, at least one output in
/// all. Output names are file stems: letters, digits, `_`, `-` and `.`, not starting with
/// `.`, at most 100 characters, unique across all outputs (turntable frames and
/// `{name}_colour` included) and not `report`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputsSpec {
    /// PNG images, `{out}/{name}.png` (or a turntable's numbered frames); default none.
    #[serde(default)]
    pub images: Vec<ImageSpec>,
    /// Baked volumes written as NRRD (`{out}/{name}.nrrd` + `{name}.raw`) or OpenVDB
    /// (`{out}/{name}.vdb`); default none.
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
    /// The file's format and extension: `Obj` or `Ply`.
    pub format: MeshFormatSpec,
    /// How the surface is drawn: `Cubes` (default: marching cubes, topology-correct),
    /// `Dual` (dual contouring: sharp edges and corners kept) or `Tetrahedra`.
    #[serde(default)]
    pub method: Option<MeshMethodSpec>,
    /// Simplification bound in voxels, 0 to 10 (default 0: every triangle kept): vertices
    /// merge while each stays within this distance of the planes of the triangles it
    /// replaces, so flat regions get fewer, larger triangles.
    #[serde(default)]
    pub adaptivity: Option<f64>,
}

/// A mesh output's extraction method (`volga_mesh::ExtractMethod`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum MeshMethodSpec {
    /// Marching cubes with the asymptotic decider and interior tunnels.
    #[default]
    Cubes,
    /// Dual contouring on the marching-cubes loops (sharp features).
    Dual,
    /// Marching tetrahedra (three times the triangles).
    Tetrahedra,
}

impl From<MeshMethodSpec> for volga_mesh::ExtractMethod {
    fn from(m: MeshMethodSpec) -> Self {
        match m {
            MeshMethodSpec::Cubes => volga_mesh::ExtractMethod::Cubes,
            MeshMethodSpec::Dual => volga_mesh::ExtractMethod::Dual,
            MeshMethodSpec::Tetrahedra => volga_mesh::ExtractMethod::Tetrahedra,
        }
    }
}

/// The file format of a mesh output; both carry per-vertex normals (outward, from the
/// field's gradient).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MeshFormatSpec {
    /// Wavefront OBJ, `{name}.obj` (text).
    Obj,
    /// Binary little-endian PLY, `{name}.ply`.
    Ply,
}

/// One image output: the scene seen by a camera in a render mode, with its render settings
/// (`docs/RENDER.md`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageSpec {
    /// File stem: the image is written to `{out}/{name}.png`.
    pub name: String,
    /// The `name` of a camera in `cameras`.
    pub camera: String,
    /// What the rays compute: `Iso(value, colour)`, `Volume(colour_from_volume)`, `Mip` or
    /// `XRay`.
    pub mode: ModeSpec,
    /// Width in pixels, 1 to 16384.
    pub width: u32,
    /// Height in pixels, 1 to 16384.
    pub height: u32,
    /// Ray step in voxels (default 0.5).
    #[serde(default)]
    pub step_voxels: Option<f64>,
    /// How the baked volume is reconstructed between voxel centres: `Nearest`, `Trilinear`
    /// (default), `CatmullRom` or `BSpline`. Not allowed with `source: Lazy`.
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
    /// Stop a `Volume` image's ray once its opacity reaches 0.99 (default true); the
    /// other modes ignore it.
    #[serde(default)]
    pub early_ray_termination: Option<bool>,
    /// Skip macro cells that cannot contribute (default true); it never changes the image,
    /// only the time.
    #[serde(default)]
    pub empty_space_skipping: Option<bool>,
    /// Linear RGBA composited behind the scene, each component in \[0, 1\]; default
    /// `(0.05, 0.05, 0.08, 1)`.
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

/// What an image's rays sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum SourceSpec {
    /// The voxelized volume, reconstructed with the image's `filter` (the default).
    Baked,
    /// The node tree itself, filtered as if voxelized on the grid, without voxels.
    Lazy,
}

/// A reconstruction filter for the baked volume (survey §5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FilterSpec {
    /// The value of the voxel whose cell holds the point (blocky; its analytic gradient is
    /// zero).
    Nearest,
    /// Trilinear interpolation of the 8 surrounding voxel centres (the default).
    Trilinear,
    /// Cubic Catmull–Rom over 4×4×4 voxels: passes through the voxel values, sharper, may
    /// overshoot them.
    CatmullRom,
    /// Cubic B-spline over 4×4×4 voxels: smooths the voxel values and never leaves their
    /// range.
    BSpline,
}

/// How shading normals are taken from the baked volume.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum GradientSpec {
    /// Central differences of the reconstruction one voxel apart (the default).
    CentralDifference,
    /// The reconstruction filter's own derivative (zero for `Nearest`).
    Analytic,
}

/// The render mode of an image: what each ray computes from its samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ModeSpec {
    /// Shaded iso-surface at `value`; colour from the objects (`FromVolume`) or fixed.
    Iso {
        /// The density of the surface, finite; 0.5 is the surface of the scene's solids.
        value: f64,
        /// `FromVolume` (the default): the objects' colours at the hit; or
        /// `Constant((r, g, b))`, each component in \[0, 1\].
        #[serde(default)]
        colour: Option<ColourSpec>,
    },
    /// Full volume rendering with the scene's transfer function; RGB from the objects'
    /// colours when `colour_from_volume` is true.
    Volume {
        /// Take RGB from the objects' colours (white where they have none) and only the
        /// opacity from the transfer function; default false: RGB from the transfer
        /// function too.
        #[serde(default)]
        colour_from_volume: bool,
    },
    /// Maximum intensity projection: the largest density along each ray, clamped to
    /// \[0, 1\], drawn as white with that opacity; unlit.
    Mip,
    /// The mean density along each ray inside the volume, clamped to \[0, 1\], drawn as
    /// white with that opacity; unlit.
    XRay,
}

/// The colour of an `Iso` surface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum ColourSpec {
    /// The objects' colour at the hit (white where they have none).
    FromVolume,
    /// One linear RGB colour, each component in \[0, 1\].
    Constant(V3),
}

/// A volume output: the baked density as NRRD (float32 voxels, detached header), optionally
/// with the colour channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeOutputSpec {
    /// File stem: `{out}/{name}.nrrd` + `{out}/{name}.raw`, or `{out}/{name}.vdb`.
    pub name: String,
    /// Also write the colour channel (`{name}_colour.nrrd`, or a Vec3f grid `color`
    /// inside the `.vdb`).
    #[serde(default)]
    pub colour: bool,
    /// `Nrrd` (the default: dense, with a `.raw` beside it) or `Vdb` (OpenVDB: a fog
    /// volume `density`, sparse, Blosc-compressed).
    #[serde(default)]
    pub format: VolumeFormatSpec,
    /// `.vdb` only: store values as 16-bit floats (default false).
    #[serde(default)]
    pub half: bool,
}

/// The file format of a volume output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum VolumeFormatSpec {
    /// NRRD header and raw data: every voxel of the grid, `f32`.
    #[default]
    Nrrd,
    /// OpenVDB: the voxels that differ from the background, in OpenVDB's sparse tree.
    Vdb,
}
