//! `volga bench render --effects`: what each effect a scene may ask for costs, as the
//! ratio of its frame's CPU seconds to the plain shaded frame's, on the same volume,
//! view and image (survey eq. 10 shadows, pre-integrated classification, the
//! Catmull–Rom cubic filter). Every configuration is prepared once
//! ([`Renderer::new`], timed apart: the pre-integration table is built there) and
//! rendered `--effects-repeat` times; medians are reported.
//!
//! * plain DVR: shaded semi-transparent volume rendering, trilinear, early ray
//!   termination on (the image a user renders), one directional light;
//! * plain iso: the shaded iso-surface at 0.5, trilinear;
//! * `shadow_*`: the same with the light casting shadows, shadow step 1 voxel;
//! * `shadow_light_space`: DVR shadows from the light-space pre-pass (step 1 voxel;
//!   the pre-pass is part of the preparation, `prepare_s`);
//! * `preint`: DVR with the pre-integrated transfer function;
//! * `cubic_*`: the same with Catmull–Rom reconstruction (and its gradients).

use serde_json::{json, Value};
use volga_core::{Field, Filter, NoProgress, Sampled, SparseVolume};
use volga_render::{
    Camera, Integrator, Iso, LightId, RenderSettings, Renderer, SurfaceColour, TransferFunction, Volume,
};

use super::{median, timed, timed_cpu};
use crate::failure::{failed, Failure};

/// Median wall and CPU seconds per frame, and the preparation's wall seconds.
fn frame_cost<F: Field, I: Integrator>(
    field: &F,
    integrator: &I,
    settings: &RenderSettings,
    camera: &Camera,
    repeat: usize,
) -> Result<(f64, f64, f64), Failure> {
    let (prepare_s, renderer) = timed(|| Renderer::new(field, integrator, settings));
    let renderer = renderer.map_err(|e| failed(e.to_string()))?;
    let (mut wall, mut cpu) = (Vec::new(), Vec::new());
    for _ in 0..repeat.max(1) {
        let (t, c, _) = timed_cpu(|| renderer.render(camera, &NoProgress));
        wall.push(t);
        cpu.push(c);
    }
    Ok((median(&wall), median(&cpu), prepare_s))
}

/// The effects' costs on `volume` seen by `camera` with `lit` (one light) settings.
pub(super) fn effects(
    volume: &SparseVolume,
    transfer: &TransferFunction,
    camera: &Camera,
    lit: &RenderSettings,
    repeat: usize,
) -> Result<Value, Failure> {
    let trilinear = Sampled::new(volume, Filter::Trilinear);
    let cubic = Sampled::new(volume, Filter::CatmullRom);
    let dvr = Volume::new(transfer.clone(), false);
    let iso = Iso {
        value: 0.5,
        colour: SurfaceColour::Constant(glam::Vec3::new(0.85, 0.8, 0.7)),
    };
    let mut shadowed = lit.clone();
    shadowed.lighting.shadows.casters = vec![LightId::Directional(0)];
    shadowed.lighting.shadows.step_voxels = 1.0;
    let mut light_space = shadowed.clone();
    light_space.lighting.shadows.light_space = true;
    let mut preint = lit.clone();
    preint.sampling.pre_integration = true;

    let plain_dvr = frame_cost(&trilinear, &dvr, lit, camera, repeat)?;
    let shadow_dvr = frame_cost(&trilinear, &dvr, &shadowed, camera, repeat)?;
    let light_space_dvr = frame_cost(&trilinear, &dvr, &light_space, camera, repeat)?;
    let preint_dvr = frame_cost(&trilinear, &dvr, &preint, camera, repeat)?;
    let cubic_dvr = frame_cost(&cubic, &dvr, lit, camera, repeat)?;
    let plain_iso = frame_cost(&trilinear, &iso, lit, camera, repeat)?;
    let shadow_iso = frame_cost(&trilinear, &iso, &shadowed, camera, repeat)?;
    let cubic_iso = frame_cost(&cubic, &iso, lit, camera, repeat)?;
    let ratio = |a: (f64, f64, f64), b: (f64, f64, f64)| a.1 / b.1;
    let entry = |c: (f64, f64, f64)| json!({ "wall_s": c.0, "cpu_s": c.1, "prepare_s": c.2 });
    Ok(json!({
        "shadow_cost_ratio": ratio(shadow_dvr, plain_dvr),
        "shadow_light_space_cost_ratio": ratio(light_space_dvr, plain_dvr),
        "preint_cost_ratio": ratio(preint_dvr, plain_dvr),
        "cubic_cost_ratio": ratio(cubic_dvr, plain_dvr),
        "iso_shadow_cost_ratio": ratio(shadow_iso, plain_iso),
        "iso_cubic_cost_ratio": ratio(cubic_iso, plain_iso),
        "ratios_of": "median CPU seconds per frame (all threads), effect / plain shaded; DVR unless prefixed iso_",
        "shadow_step_voxels": 1.0,
        "repeat": repeat.max(1),
        "plain_dvr": entry(plain_dvr),
        "shadow_dvr": entry(shadow_dvr),
        "shadow_light_space_dvr": entry(light_space_dvr),
        "preint_dvr": entry(preint_dvr),
        "cubic_dvr": entry(cubic_dvr),
        "plain_iso": entry(plain_iso),
        "shadow_iso": entry(shadow_iso),
        "cubic_iso": entry(cubic_iso),
    }))
}
