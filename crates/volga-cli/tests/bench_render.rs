//! `volga bench render --json`: the stable keys, the baseline drawing the DVR image,
//! and bad arguments refused with exit code 2.

mod common;
use common::{stderr, volga};

#[test]
fn prints_the_stable_keys_and_the_baseline_draws_the_same_image() {
    let mesh = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/assets/spot.obj");
    let out = volga(&[
        "bench", "render", "--json", "--size", "24", "--width", "24", "--height", "20", "--warmup", "0", "--repeat",
        "1", "--mesh", mesh,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    for key in ["iso_fps", "dvr_fps", "baseline_fps", "samples_per_s"] {
        let v = report[key].as_f64().unwrap_or_else(|| panic!("{key} missing"));
        assert!(v.is_finite() && v > 0.0, "{key} = {v}");
    }
    let volumes = report["volumes"].as_array().unwrap();
    assert_eq!(volumes.len(), 2);
    for v in volumes {
        let rays = v["dvr"]["rays"].as_u64().unwrap();
        assert_eq!(rays, 24 * 20);
        // The DVR really ran without early termination and sampled something.
        assert_eq!(v["dvr"]["rays_terminated_early"].as_u64(), Some(0));
        assert!(v["dvr"]["samples"].as_u64().unwrap() > 0);
        // The plain raycaster computes the same image (up to rounding).
        let diff = v["dvr_baseline_max_abs_diff"].as_f64().unwrap();
        assert!(diff < 1e-4, "{}: baseline differs by {diff}", v["name"]);
    }
}

#[test]
fn bad_arguments_exit_2() {
    for (args, needle) in [
        (vec!["bench", "render"], "--json"),
        (vec!["bench", "render", "--json", "--volumes", "teapot"], "teapot"),
        (vec!["bench", "render", "--json", "--step-voxels", "0"], "--step-voxels"),
        (
            vec![
                "bench",
                "render",
                "--json",
                "--volumes",
                "bunny",
                "--mesh",
                "/nonexistent.obj",
            ],
            "--mesh",
        ),
    ] {
        let out = volga(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(stderr(&out).contains(needle), "{args:?}: {}", stderr(&out));
    }
}
