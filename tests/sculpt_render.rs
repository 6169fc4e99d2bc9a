//! Localized re-render after a sculpt edit equals a full re-render bit for bit (iso and
//! volume modes, perspective and orthographic), and re-renders only part of the image.

use glam::{DVec3, Vec3, Vec4};
use volga::core::{Field, NoProgress};
use volga::render::{
    Camera, Image, Integrator, Iso, Projection, RenderSettings, Renderer, SurfaceColour, TransferFunction, Volume,
};
use volga::sculpt::{Operation, Sculpt, SculptGrid, Stroke, Tool};
use volga::shapes::{AxisBox, FilteredDensity, OrientedBoxFilter};

fn sculpt() -> Sculpt {
    let grid = SculptGrid::new(DVec3::new(-16.0, -16.0, -16.0), 1.0, 2).unwrap(); // 32³
    let block = FilteredDensity::new(
        AxisBox::new(DVec3::splat(-9.0), DVec3::splat(9.0)).unwrap(),
        OrientedBoxFilter::for_spacing(DVec3::ONE),
    );
    Sculpt::from_field(grid, &block, [0.8, 0.7, 0.6])
}

fn full<I: Integrator>(s: &Sculpt, integrator: &I, settings: &RenderSettings, camera: &Camera) -> Image {
    Renderer::new(s, integrator, settings)
        .unwrap()
        .render(camera, &NoProgress)
        .0
}

fn check<I: Integrator>(integrator: &I, camera: &Camera) {
    let settings = RenderSettings::new(72, 56);
    let mut s = sculpt();
    let mut image = full(&s, integrator, &settings, camera);
    let strokes = [
        Stroke::new(Tool::sphere(DVec3::new(3.0, 9.0, 2.0), 3.5).unwrap(), Operation::Carve).unwrap(),
        Stroke::new(
            Tool::sphere(DVec3::new(-9.0, -2.0, 4.0), 2.5).unwrap(),
            Operation::Paint {
                colour: [0.9, 0.1, 0.1],
                strength: 1.0,
            },
        )
        .unwrap(),
        Stroke::new(
            Tool::sphere(DVec3::new(9.0, 9.0, 9.0), 2.0).unwrap(),
            Operation::Smooth { strength: 1.0 },
        )
        .unwrap(),
    ];
    for stroke in &strokes {
        let changed = s.apply(stroke).changed_world.expect("the stroke changes the block");
        let renderer = Renderer::new(&s, integrator, &settings).unwrap();
        let (count, _) = renderer.rerender_box(camera, &changed, &mut image);
        let reference = full(&s, integrator, &settings, camera);
        assert!(count > 0 && count < (72 * 56) / 2, "re-rendered {count} pixels");
        let same = image
            .pixels
            .iter()
            .zip(&reference.pixels)
            .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits));
        assert!(same, "localized re-render differs from a full render");
    }
}

#[test]
fn localized_rerender_equals_full_render_bit_for_bit() {
    let persp = Camera::look_at(
        DVec3::new(30.0, 40.0, 35.0),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Perspective { fov_y_deg: 40.0 },
    )
    .unwrap();
    let ortho = Camera::look_at(
        DVec3::new(-30.0, 25.0, 20.0),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Orthographic { height_world: 36.0 },
    )
    .unwrap();
    let iso = Iso {
        value: 0.5,
        colour: SurfaceColour::FromField,
    };
    for camera in [&persp, &ortho] {
        check(&iso, camera);
    }
    let volume = Volume::new(
        TransferFunction::new(vec![
            (0.0, Vec4::ZERO),
            (0.5, Vec4::new(0.9, 0.8, 0.6, 0.3)),
            (1.0, Vec4::new(0.7, 0.5, 0.3, 0.05)),
        ])
        .unwrap(),
        true,
    );
    check(&volume, &persp);
    let _ = Vec3::ZERO;
    assert!(sculpt().has_colour());
}

/// A renderer carried across edits (`Renderer::after_edit`: the skipping grid updated only
/// where each edit reached) renders every version exactly as a fresh renderer does.
#[test]
fn a_renderer_updated_after_edits_equals_a_fresh_one() {
    let camera = Camera::look_at(
        DVec3::new(30.0, 40.0, 35.0),
        DVec3::ZERO,
        DVec3::Z,
        Projection::Perspective { fov_y_deg: 40.0 },
    )
    .unwrap();
    let iso = Iso {
        value: 0.5,
        colour: SurfaceColour::FromField,
    };
    let settings = RenderSettings::new(64, 48);
    let mut s = sculpt();
    let mut versions = vec![s.clone()];
    let mut changes = Vec::new();
    for (centre, radius) in [
        (DVec3::new(3.0, 9.0, 2.0), 3.5),
        (DVec3::new(-9.0, -9.0, 9.0), 4.0),
        (DVec3::new(0.0, 0.0, 9.0), 2.0),
    ] {
        let stroke = Stroke::new(Tool::sphere(centre, radius).unwrap(), Operation::Carve).unwrap();
        changes.push(s.apply(&stroke).changed_world.expect("a carve into the block"));
        versions.push(s.clone());
    }
    let mut renderer = Renderer::new(&versions[0], &iso, &settings).unwrap();
    for (k, changed) in changes.iter().enumerate() {
        renderer = renderer.after_edit(&versions[k + 1], changed).unwrap();
        let updated = renderer.render(&camera, &NoProgress).0;
        let fresh = full(&versions[k + 1], &iso, &settings, &camera);
        assert!(
            updated
                .pixels
                .iter()
                .zip(&fresh.pixels)
                .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)),
            "edit {k}: the updated renderer's image differs"
        );
    }
}
