//! `volga accuracy --quick`: every experiment runs, the same files as the full run are
//! written, within the test suite's budget; bad `--out` is refused before any work.

mod common;

use common::{arg, stderr, volga};

#[test]
fn quick_run_writes_every_table_plot_and_the_raw_figures() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("accuracy");
    let o = volga(&["accuracy", "--quick", "--out", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));

    // Exactly the files of the full run, and nothing else (no temporary files).
    let mut written: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    written.sort();
    let mut expected = volga_accuracy::output_names();
    expected.sort();
    assert_eq!(written, expected);

    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("accuracy.json")).unwrap()).unwrap();
    assert_eq!(json["size"], "quick");
    assert!(json["machine"]["cores"].as_u64().unwrap() >= 1);
    assert!(json["command"].as_str().unwrap().starts_with("volga accuracy --quick"));
    let experiments = json["experiments"].as_array().unwrap();
    assert_eq!(experiments.len(), volga_accuracy::EXPERIMENTS.len());
    for e in experiments {
        let id = e["id"].as_str().unwrap();
        let metrics: Vec<&str> = e["metrics"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m["id"].as_str().unwrap())
            .collect();
        let table = std::fs::read_to_string(out.join(format!("{id}.md"))).unwrap();
        let svg = std::fs::read_to_string(out.join(format!("{id}.svg"))).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("wall time (s)"), "{id}.svg");
        let mut rows = 0;
        for series in e["series"].as_array().unwrap() {
            for setting in series["settings"].as_array().unwrap() {
                rows += 1;
                assert!(setting["time_s"].as_f64().unwrap() > 0.0, "{id}: {setting}");
                assert!(setting["memory_bytes"].as_u64().unwrap() > 0, "{id}: {setting}");
                for m in &metrics {
                    let v = setting["errors"][m].as_f64();
                    assert!(v.is_some_and(|v| v.is_finite() && v >= 0.0), "{id} {m}: {setting}");
                }
            }
        }
        assert!(rows >= 2, "{id}: {rows} settings");
        // A header, its rule and one row per setting.
        let table_rows = table.lines().filter(|l| l.starts_with('|')).count();
        assert_eq!(table_rows, rows + 2, "{id}.md");
    }
}

#[test]
fn out_that_is_a_file_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("taken");
    std::fs::write(&file, b"keep me").unwrap();
    let o = volga(&["accuracy", "--quick", "--out", arg(&file)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--out"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&file).unwrap(), b"keep me");
}

/// Every error figure is a pure function of its setting: `--threads 1` and
/// `--threads 2` give the same figures (times and memory peaks may differ).
#[test]
fn error_figures_do_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let errors = |threads: &str| {
        let out = dir.path().join(threads);
        let o = volga(&["--threads", threads, "accuracy", "--quick", "--out", arg(&out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("accuracy.json")).unwrap()).unwrap();
        assert_eq!(json["machine"]["threads"].as_u64(), Some(threads.parse().unwrap()));
        json["experiments"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|e| e["series"].as_array().unwrap().clone())
            .flat_map(|s| s["settings"].as_array().unwrap().clone())
            .map(|p| p["errors"].clone())
            .collect::<Vec<_>>()
    };
    let (one, two) = (errors("1"), errors("2"));
    assert!(!one.is_empty());
    assert_eq!(one, two);
}
