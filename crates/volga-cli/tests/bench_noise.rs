//! `volga bench noise --json`: the keys docs/BENCHMARKS.md names, and values equal to the
//! `noise` crate's.

mod common;
use common::{stderr, volga};

#[test]
fn prints_the_keys_and_matches_the_noise_crate() {
    let out = volga(&["bench", "noise", "--json", "--size", "16", "--repeat", "1"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    for key in [
        "volga_msps_1t",
        "noise_crate_msps_1t",
        "simdnoise_msps_1t",
        "volga_msps_2t",
        "noise_crate_msps_2t",
        "simdnoise_msps_2t",
        "turbulence_fill_2t_s",
        "turbulence_bake_sparse_2t_s",
    ] {
        let v = report[key].as_f64().unwrap_or_else(|| panic!("{key} missing"));
        assert!(v.is_finite() && v > 0.0, "{key} = {v}");
    }
    let diff = report["max_abs_diff_vs_noise_crate"].as_f64().unwrap();
    assert!(diff <= 1e-6, "{diff}");
    assert_eq!(report["samples"].as_u64(), Some(16 * 16 * 16));
}

#[test]
fn bad_size_exits_2() {
    let out = volga(&["bench", "noise", "--json", "--size", "4"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
}
