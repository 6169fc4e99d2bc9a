//! Stroke files: a sculpt's starting object and a list of strokes, as users write them
//! (RON or JSON), validated into `volga-sculpt` types with errors naming the field path.
//!
//! ```ron
//! Strokes(
//!     start: Some(Start(bounds: (min: (-1, -1, -1), max: (1, 1, 1)), voxel_size: 0.02,
//!         object: (shape: Box(min: (-0.6, -0.8, -0.5), max: (0.6, 0.8, 0.5)), colour: Some((0.8, 0.7, 0.6))))),
//!     strokes: [
//!         (op: Carve, tool: Sphere(center: (0, 0.3, 0.5), radius: 0.2)),
//!         (op: Carve, tool: Sphere(center: (0, 0, 0), radius: 0.04), path: Some([(-0.5, -0.5, 0.5), (0.5, -0.5, 0.5)])),
//!         (op: Paint(colour: (0.2, 0.3, 0.9)), tool: Sphere(center: (0.3, 0.3, 0.5), radius: 0.1)),
//!     ],
//! )
//! ```
//!
//! A tool is any shape of a scene object (`Sphere`, `Box`, `OrientedBox`, `Ellipsoid`,
//! `Cylinder` with a `half_length`, `Cone` with a `height`, `Capsule`, `Torus`, inline
//! `Triangles` or a `Mesh` file, both closed), optionally rotated (`rotation_deg`, XYZ
//! Euler, about the world origin) and moved (`translate`); with a `path` it is swept along
//! that polyline (the saw: the tool's placement is offset by each path point), sampled every
//! half voxel.

use std::path::Path;
use std::sync::Arc;

use glam::{DQuat, DVec3, EulerRot, UVec3};
use serde::{Deserialize, Serialize};
use volga_core::{Grid, Transform};
use volga_sculpt::{MeshTool, Operation, Pose, Sculpt, SculptGrid, Stroke, Tool, ToolShape};
use volga_shapes::Torus;

use crate::ctx::Ctx;
use crate::model::{BoundsSpec, ObjectSpec, ShapeSpec, V3};
use crate::nodes::{self, Resolve};
use crate::SceneError;

/// A stroke file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Strokes")]
pub struct StrokeFile {
    /// A new sculpt (needed unless the strokes apply to a saved one).
    #[serde(default)]
    pub start: Option<StartSpec>,
    /// The strokes, applied in order.
    pub strokes: Vec<StrokeSpec>,
}

/// The object a new sculpt starts from, voxelized on a grid covering `bounds`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Start")]
pub struct StartSpec {
    /// World box the sculpt must cover (`min < max` on every axis); the grid is centred on
    /// it with a margin of a few voxels.
    pub bounds: BoundsSpec,
    /// Voxel edge length (cubic voxels; the grid is `8·2^L` voxels per axis).
    pub voxel_size: f64,
    /// The object the sculpt starts from, voxelized through the same node as in a scene
    /// (`objects[N]`'s fields: `name`, `shape`, `colour`).
    pub object: ObjectSpec,
}

/// One stroke: an operation applied within a tool, placed by `rotation_deg` then
/// `translate`, optionally swept along `path`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StrokeSpec {
    /// What the stroke does to the voxels within the tool.
    pub op: OpSpec,
    /// The tool's shape (world units before `rotation_deg` and `translate`): any bounded
    /// shape, i.e. not a `Quadric`, a `Cylinder` without `half_length` or a `Cone` without
    /// `height`; `Triangles` and `Mesh` tools must be closed (a mesh path is relative to
    /// the file).
    pub tool: ShapeSpec,
    /// Rotation of the tool about the world origin as X-then-Y-then-Z Euler angles in
    /// degrees, finite; default `(0, 0, 0)`.
    #[serde(default)]
    pub rotation_deg: V3,
    /// Offset of the tool after the rotation (world units), finite; default `(0, 0, 0)`.
    #[serde(default)]
    pub translate: V3,
    /// Sweep the tool along this polyline (the saw).
    #[serde(default)]
    pub path: Option<Vec<V3>>,
}

/// What a stroke does within its tool (strengths in (0, 1]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum OpSpec {
    /// Remove the tool's volume (with a `path`: sawing).
    Carve,
    /// Add the tool's volume (fuzzy union).
    Add,
    /// Add density little by little, like an airbrush.
    Spray {
        /// Density added per stroke where the tool is solid (less in its soft edge), in
        /// (0, 1]; densities stop at 1.
        strength: f64,
        /// Extra soft-edge width (world units), finite and ≥ 0; default 0.
        #[serde(default)]
        falloff: f64,
    },
    /// Recolour the voxels within the tool; the shape is unchanged.
    Paint {
        /// Linear RGB, each component in \[0, 1\].
        colour: V3,
        /// How far the colour moves towards `colour`, in (0, 1]; default 1 (replace).
        #[serde(default = "one")]
        strength: f64,
    },
    /// Blend densities within the tool towards their 27-neighbour mean.
    Smooth {
        /// How far each voxel moves towards the mean, in (0, 1]; default 1.
        #[serde(default = "one")]
        strength: f64,
    },
}

fn one() -> f64 {
    1.0
}

/// Parses a stroke file (`.ron` or `.json`); errors name the file, line and column.
pub fn parse_stroke_file(path: &Path) -> Result<StrokeFile, SceneError> {
    let text = volga_core::input::read_input_text(path).map_err(|source| SceneError::Read {
        path: path.to_owned(),
        source,
    })?;
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("ron") => ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
            .from_str(&text)
            .map_err(|e| SceneError::Parse {
                path: path.to_owned(),
                line: e.position.line,
                column: e.position.col,
                message: e.code.to_string(),
            }),
        Some("json") => serde_json::from_str(&text).map_err(|e| SceneError::Parse {
            path: path.to_owned(),
            line: e.line(),
            column: e.column(),
            message: e.to_string(),
        }),
        _ => Err(SceneError::Extension { path: path.to_owned() }),
    }
}

/// The sculpt a `start` describes: the object's lazy field (the same node as in a scene)
/// sampled on a [`SculptGrid`] covering `bounds`.
pub fn start_sculpt(
    path: &Path,
    start: &StartSpec,
    memory_limit: u64,
    allow_outside: bool,
) -> Result<Sculpt, SceneError> {
    let cx = Ctx { path };
    let min = cx.finite3("start.bounds.min", start.bounds.min)?;
    let max = cx.finite3("start.bounds.max", start.bounds.max)?;
    if min.cmpge(max).any() {
        return Err(cx.err("start.bounds", "min must be below max on every axis"));
    }
    let h = cx.positive("start.voxel_size", start.voxel_size)?;
    let grid = SculptGrid::covering(&volga_core::Aabb::new(min, max), h)
        .map_err(|e| cx.err("start.voxel_size", e.to_string()))?;
    if grid.levels() > 11 {
        return Err(cx.err(
            "start.voxel_size",
            format!(
                "{} voxels per axis is more than the 16384 a stroke file may ask for",
                grid.dims()
            ),
        ));
    }
    let mut node = nodes::leaf(&cx, "start.object", 0, &start.object)?;
    let dir = path.parent().unwrap_or(Path::new("."));
    node.resolve(&Resolve {
        scene: path,
        dir,
        memory_limit,
        allow_outside,
    })?;
    let transform = Transform::new(grid.origin(), DVec3::splat(h)).map_err(|e| cx.err("start", e.to_string()))?;
    let core_grid =
        Grid::new(transform, UVec3::splat(grid.dims() as u32)).map_err(|e| cx.err("start", e.to_string()))?;
    let needed = grid.sample_bytes_bound(&node.bounds());
    if needed > memory_limit as u128 {
        return Err(cx.err(
            "start.voxel_size",
            format!(
                "sampling the start object on a {}³ sculpt needs up to {} ({needed} bytes), more than the memory limit of {} ({memory_limit} bytes); use a larger voxel_size or raise --memory-limit",
                grid.dims(),
                volga_core::memory::Bytes(needed),
                volga_core::memory::Bytes(memory_limit as u128)
            ),
        ));
    }
    let field = node.lazy_field(&core_grid)?;
    let colour = node.colour();
    Ok(Sculpt::from_field(grid, &*field, colour))
}

/// Validates the strokes for a sculpt of voxel size `spacing` (saws are sampled every half voxel).
/// Mesh tools are read from the stroke file's folder; with `allow_outside` also from
/// elsewhere (absolute paths, `..` above it).
pub fn validate_strokes(
    path: &Path,
    file: &StrokeFile,
    spacing: f64,
    allow_outside: bool,
) -> Result<Vec<Stroke>, SceneError> {
    validate_stroke_list(path, "strokes", &file.strokes, spacing, allow_outside)
}

/// Validates `strokes` found at the field path `field` of the file `path` (mesh tools are
/// read relative to its folder, and only from inside it unless `allow_outside`). A mesh
/// file named by several strokes is read once.
pub fn validate_stroke_list(
    path: &Path,
    field: &str,
    strokes: &[StrokeSpec],
    spacing: f64,
    allow_outside: bool,
) -> Result<Vec<Stroke>, SceneError> {
    let cx = Ctx { path };
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut tools = ToolFiles {
        allow_outside,
        loaded: Vec::new(),
    };
    strokes
        .iter()
        .enumerate()
        .map(|(i, s)| validate_stroke(&cx, dir, &format!("{field}[{i}]"), s, spacing, &mut tools))
        .collect()
}

/// Mesh tools already built, by file, scale and offset: a scene naming one tool file
/// in many strokes holds one copy of it.
struct ToolFiles {
    allow_outside: bool,
    #[allow(clippy::type_complexity)]
    loaded: Vec<((std::path::PathBuf, u64, [u64; 3]), Arc<MeshTool>)>,
}

fn validate_stroke(
    cx: &Ctx,
    dir: &Path,
    f: &str,
    s: &StrokeSpec,
    spacing: f64,
    tools: &mut ToolFiles,
) -> Result<Stroke, SceneError> {
    let operation = match &s.op {
        OpSpec::Carve => Operation::Carve,
        OpSpec::Add => Operation::Add,
        OpSpec::Spray { strength, falloff } => Operation::Spray {
            strength: *strength,
            falloff_world: *falloff,
        },
        OpSpec::Paint { colour, strength } => Operation::Paint {
            colour: cx.colour(&format!("{f}.op.colour"), Some(*colour))?,
            strength: *strength,
        },
        OpSpec::Smooth { strength } => Operation::Smooth { strength: *strength },
    };
    let r = cx.finite3(&format!("{f}.rotation_deg"), s.rotation_deg)?;
    let t = cx.finite3(&format!("{f}.translate"), s.translate)?;
    let rotation = DQuat::from_euler(EulerRot::XYZ, r.x.to_radians(), r.y.to_radians(), r.z.to_radians());
    let pose = Pose::new(rotation, t).map_err(|e| cx.err(format!("{f}.rotation_deg"), e.to_string()))?;
    let shape = tool_shape(cx, dir, &format!("{f}.tool"), &s.tool, tools)?;
    let mut tool = Tool::new(shape, pose).map_err(|e| cx.err(format!("{f}.tool"), e.to_string()))?;
    if let Some(path) = &s.path {
        let points = path
            .iter()
            .enumerate()
            .map(|(k, p)| cx.finite3(&format!("{f}.path[{k}]"), *p))
            .collect::<Result<Vec<_>, _>>()?;
        tool = tool
            .swept(&points, spacing * 0.5)
            .map_err(|e| cx.err(format!("{f}.path"), e.to_string()))?;
    }
    Stroke::new(tool, operation).map_err(|e| cx.err(format!("{f}.op"), e.to_string()))
}

fn tool_shape(cx: &Ctx, dir: &Path, f: &str, s: &ShapeSpec, tools: &mut ToolFiles) -> Result<ToolShape, SceneError> {
    let v = |name: &str, x: V3| cx.finite3(&format!("{f}.{name}"), x);
    match s {
        ShapeSpec::Torus {
            center,
            axis,
            major_radius,
            minor_radius,
        } => Ok(ToolShape::Torus(
            Torus::new(v("center", *center)?, v("axis", *axis)?, *major_radius, *minor_radius)
                .map_err(|e| cx.err(f, e.to_string()))?,
        )),
        ShapeSpec::Triangles { vertices, triangles } => {
            let mesh = volga_mesh::TriMesh::new(
                vertices.iter().map(|p| DVec3::from_array(*p)).collect(),
                triangles.clone(),
            )
            .map_err(|e| cx.err(f, e.to_string()))?;
            Ok(ToolShape::Mesh(Arc::new(
                MeshTool::new(&mesh).map_err(|e| cx.err(f, e.to_string()))?,
            )))
        }
        ShapeSpec::Mesh { path, translate, scale } => {
            let file = crate::nodes::scene_file(cx.path, dir, &format!("{f}.path"), path, tools.allow_outside)?;
            let scale = cx.positive(&format!("{f}.scale"), *scale)?;
            let offset = v("translate", *translate)?;
            let key = (file.clone(), scale.to_bits(), offset.to_array().map(f64::to_bits));
            if let Some((_, tool)) = tools.loaded.iter().find(|(k, _)| *k == key) {
                return Ok(ToolShape::Mesh(Arc::clone(tool)));
            }
            let mesh = volga_mesh::load_mesh(&file).map_err(|e| cx.err(format!("{f}.path"), e.to_string()))?;
            let mesh = volga_mesh::TriMesh {
                positions: mesh.positions.iter().map(|p| *p * scale + offset).collect(),
                triangles: mesh.triangles,
            };
            let tool = Arc::new(MeshTool::new(&mesh).map_err(|e| cx.err(f, e.to_string()))?);
            tools.loaded.push((key, Arc::clone(&tool)));
            Ok(ToolShape::Mesh(tool))
        }
        ShapeSpec::Cylinder { half_length: None, .. } | ShapeSpec::Cone { height: None, .. } => Err(cx.err(
            f,
            "a tool must be bounded: give the cylinder a half_length or the cone a height",
        )),
        ShapeSpec::Quadric { .. } => Err(cx.err(f, "a quadric is not a sculpting tool (its distance is not exact)")),
        // The analytic shapes: validated and built as scene objects are (field paths
        // name the parameter at fault).
        _ => Ok(ToolShape::Shape(nodes::shape::validate_shape(cx, f, s)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_name_the_field_path() {
        let p = Path::new("bust.ron");
        let file: StrokeFile = ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
            .from_str(
                "Strokes(strokes: [(op: Carve, tool: Sphere(center: (0, 0, 0), radius: 1)), \
                 (op: Spray(strength: 2.0), tool: Sphere(center: (0, 0, 0), radius: 1)), \
                 (op: Carve, tool: Sphere(center: (0, 0, 0), radius: -1))])",
            )
            .unwrap();
        let e = validate_strokes(p, &file, 0.1, false).unwrap_err().to_string();
        assert!(e.contains("strokes[1].op"), "{e}");
        let file = StrokeFile {
            start: None,
            strokes: vec![file.strokes[2].clone()],
        };
        let e = validate_strokes(p, &file, 0.1, false).unwrap_err().to_string();
        assert!(e.contains("strokes[0].tool"), "{e}");
        let saw = StrokeFile {
            start: None,
            strokes: vec![StrokeSpec {
                op: OpSpec::Carve,
                tool: ShapeSpec::Sphere {
                    center: [0.0; 3],
                    radius: 1.0,
                },
                rotation_deg: [0.0; 3],
                translate: [0.0; 3],
                path: Some(vec![[0.0; 3], [f64::NAN, 0.0, 0.0]]),
            }],
        };
        assert!(validate_strokes(p, &saw, 0.1, false)
            .unwrap_err()
            .to_string()
            .contains("strokes[0].path[1]"));
    }
}
