//! `volga.render`: any grid, sculpt or ADF through the embedded raycaster, as an
//! `(H, W, 4)` uint8 RGBA array (row 0 at the top).

use glam::{DVec3, Vec3};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use volga_core::{Aabb, Field, Filter, NoProgress, Sampled};
use volga_render::{Camera, Iso, Mip, Mode, Projection, RenderSettings, SurfaceColour, XRay};

use crate::adf::Adf;
use crate::arrays;
use crate::errors::{check_memory, value_error};
use crate::grid::{Kind, VoxelGrid};
use crate::sculpt::Sculpt;
use crate::threads;

/// Largest image side.
pub const MAX_SIDE: u32 = 16384;

/// A perspective camera looking at `bounds` from the front, above and right (the view
/// `volga adf` renders), unless `eye`/`target`/`up` are given.
fn camera(
    bounds: &Aabb,
    eye: Option<DVec3>,
    target: Option<DVec3>,
    up: Option<DVec3>,
    fov_deg: f64,
) -> PyResult<Camera> {
    if !(fov_deg.is_finite() && fov_deg > 0.0 && fov_deg < 180.0) {
        return Err(value_error(format!("fov_deg must lie in (0, 180), got {fov_deg}")));
    }
    let centre = target.unwrap_or(bounds.center());
    let eye = eye.unwrap_or_else(|| {
        let radius = 0.5 * bounds.size().length();
        let dir = DVec3::new(0.35, 0.45, 1.0).normalize();
        centre + dir * radius / (fov_deg.to_radians() * 0.5).sin()
    });
    Camera::look_at(
        eye,
        centre,
        up.unwrap_or(DVec3::Y),
        Projection::Perspective { fov_y_deg: fov_deg },
    )
    .map_err(|e| value_error(format!("camera: {e}")))
}

#[allow(clippy::too_many_arguments)]
fn render_field<F: Field + ?Sized>(
    py: Python<'_>,
    field: &F,
    bounds: Aabb,
    default_iso: f64,
    field_colour: bool,
    size: (u32, u32),
    mode: &str,
    view: (Option<DVec3>, Option<DVec3>, Option<DVec3>, f64),
    iso: Option<f64>,
    colour: Option<DVec3>,
    threads: Option<usize>,
) -> PyResult<Vec<u8>> {
    let mode = match mode {
        "iso" => {
            let value = iso.unwrap_or(default_iso);
            if !value.is_finite() {
                return Err(value_error(format!("iso must be finite, got {value}")));
            }
            Mode::Iso(Iso {
                value,
                colour: match colour {
                    Some(c) => SurfaceColour::Constant(c.as_vec3()),
                    None if field_colour => SurfaceColour::FromField,
                    None => SurfaceColour::Constant(Vec3::new(0.85, 0.8, 0.7)),
                },
            })
        }
        "mip" => Mode::Mip(Mip),
        "xray" => Mode::XRay(XRay),
        other => {
            return Err(value_error(format!(
                "mode must be \"iso\", \"mip\" or \"xray\", got \"{other}\""
            )))
        }
    };
    let camera = camera(&bounds, view.0, view.1, view.2, view.3)?;
    let settings = RenderSettings::new(size.0, size.1);
    let image = threads::run(py, threads, || {
        volga_render::render(field, &camera, &mode, &settings, &NoProgress).map(|(image, _)| image.to_rgba8())
    })?
    .map_err(|e| value_error(e.to_string()))?;
    Ok(image)
}

/// Renders a grid, sculpt or ADF (see the Python docstring in `volga/__init__.py`).
#[pyfunction]
#[pyo3(signature = (obj, width=512, height=512, mode="iso", eye=None, target=None, up=None, fov_deg=30.0, iso=None, colour=None, threads=None))]
#[allow(clippy::too_many_arguments)]
pub fn render<'py>(
    py: Python<'py>,
    obj: &Bound<'py, PyAny>,
    width: u32,
    height: u32,
    mode: &str,
    eye: Option<&Bound<'py, PyAny>>,
    target: Option<&Bound<'py, PyAny>>,
    up: Option<&Bound<'py, PyAny>>,
    fov_deg: f64,
    iso: Option<f64>,
    colour: Option<&Bound<'py, PyAny>>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyAny>> {
    if !(1..=MAX_SIDE).contains(&width) || !(1..=MAX_SIDE).contains(&height) {
        return Err(value_error(format!(
            "width and height must lie in 1..={MAX_SIDE}, got {width}×{height}"
        )));
    }
    check_memory(
        &format!("a {width}×{height} image"),
        width as u64 * height as u64 * 20,
        None,
    )?;
    threads::check(threads)?;
    let v3 = |name: &str, o: Option<&Bound<'py, PyAny>>| o.map(|o| arrays::vec3(name, o)).transpose();
    let view = (v3("eye", eye)?, v3("target", target)?, v3("up", up)?, fov_deg);
    let colour = v3("colour", colour)?;
    let size = (width, height);
    let rgba = if let Ok(g) = obj.cast::<VoxelGrid>() {
        let g = g.get();
        let field = Sampled::new(&*g.volume, Filter::Trilinear);
        let iso0 = if g.kind == Kind::Distance { 0.0 } else { 0.5 };
        render_field(
            py,
            &field,
            g.volume.grid.world_bounds(),
            iso0,
            false,
            size,
            mode,
            view,
            iso,
            colour,
            threads,
        )?
    } else if let Ok(s) = obj.cast::<Sculpt>() {
        let s = s.try_borrow()?;
        let bounds = s.bounds();
        render_field(py, &s.inner, bounds, 0.5, true, size, mode, view, iso, colour, threads)?
    } else if let Ok(a) = obj.cast::<Adf>() {
        let a = a.get();
        let adf = &*a.inner;
        render_field(
            py,
            adf,
            a.surface_bounds(),
            0.0,
            false,
            size,
            mode,
            view,
            iso,
            colour,
            threads,
        )?
    } else {
        return Err(value_error(
            "render: expected a volga.VoxelGrid, volga.Sculpt or volga.Adf",
        ));
    };
    let array = PyArray1::from_vec(py, rgba).reshape([height as usize, width as usize, 4])?;
    Ok(array.into_any())
}
