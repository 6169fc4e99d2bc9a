//! The crate graph against docs/ARCHITECTURE.md: every dependency between workspace
//! crates (from `cargo metadata`) must be an edge the document's "Allowed dependencies"
//! table allows, and every workspace crate must have a row there. Adding a dependency
//! the table does not list (say `volga-render` on `volga-scene`) fails this test; the
//! fix is either to drop the edge or to change the documented layering on purpose.

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// `crate → (normal, dev)` allowed workspace dependencies, from the document's table:
/// rows `| crate | normal dependencies | dev-only dependencies |` with crate names in
/// backticks and `—` for none.
fn documented_edges() -> BTreeMap<String, (BTreeSet<String>, BTreeSet<String>)> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/ARCHITECTURE.md");
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let section = text
        .split("## Allowed dependencies")
        .nth(1)
        .unwrap_or_else(|| panic!("{path}: no \"## Allowed dependencies\" section"));
    let names = |cell: &str| -> BTreeSet<String> { cell.split('`').skip(1).step_by(2).map(str::to_string).collect() };
    let mut rows = BTreeMap::new();
    for line in section.lines().take_while(|l| !l.starts_with("## ")) {
        let cells: Vec<&str> = line.trim().trim_matches('|').split('|').map(str::trim).collect();
        if cells.len() != 3 || !cells[0].starts_with('`') {
            continue;
        }
        let krate = names(cells[0]).into_iter().next().expect("a crate name");
        rows.insert(krate, (names(cells[1]), names(cells[2])));
    }
    assert!(rows.len() > 5, "{path}: the table has {} rows", rows.len());
    rows
}

/// `crate → (normal, dev)` workspace dependencies as Cargo sees them.
fn actual_edges() -> BTreeMap<String, (BTreeSet<String>, BTreeSet<String>)> {
    let out = Command::new(env!("CARGO"))
        .args(["metadata", "--format-version", "1", "--no-deps", "--offline"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout).expect("cargo metadata JSON");
    let members: BTreeSet<String> = meta["packages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    let mut edges = BTreeMap::new();
    for p in meta["packages"].as_array().unwrap() {
        let mut normal = BTreeSet::new();
        let mut dev = BTreeSet::new();
        for d in p["dependencies"].as_array().unwrap() {
            let name = d["name"].as_str().unwrap().to_string();
            if !members.contains(&name) {
                continue;
            }
            match d["kind"].as_str() {
                Some("dev") => dev.insert(name),
                _ => normal.insert(name),
            };
        }
        // A crate's dev-dependency on itself (to turn on a test feature) is no edge.
        dev.remove(p["name"].as_str().unwrap());
        edges.insert(p["name"].as_str().unwrap().to_string(), (normal, dev));
    }
    edges
}

#[test]
fn crate_graph_follows_the_documented_layers() {
    let allowed = documented_edges();
    let actual = actual_edges();
    let mut wrong = Vec::new();
    for (krate, (normal, dev)) in &actual {
        let Some((ok_normal, ok_dev)) = allowed.get(krate) else {
            wrong.push(format!("{krate}: no row in docs/ARCHITECTURE.md's table"));
            continue;
        };
        for d in normal.difference(ok_normal) {
            wrong.push(format!("{krate} → {d}: not an allowed dependency"));
        }
        for d in dev.difference(&ok_normal.union(ok_dev).cloned().collect()) {
            wrong.push(format!("{krate} → {d} (dev): not an allowed dependency"));
        }
    }
    for krate in allowed.keys() {
        if !actual.contains_key(krate) {
            wrong.push(format!("{krate}: in the table but not in the workspace"));
        }
    }
    assert!(
        wrong.is_empty(),
        "the crate graph breaks docs/ARCHITECTURE.md:\n{}",
        wrong.join("\n")
    );
}

/// The table itself is layered: no cycle among the allowed normal edges.
#[test]
fn documented_layers_have_no_cycle() {
    let allowed = documented_edges();
    let mut done: BTreeSet<&str> = BTreeSet::new();
    while done.len() < allowed.len() {
        let next: Vec<&str> = allowed
            .iter()
            .filter(|(k, (n, _))| !done.contains(k.as_str()) && n.iter().all(|d| done.contains(d.as_str())))
            .map(|(k, _)| k.as_str())
            .collect();
        assert!(
            !next.is_empty(),
            "a cycle among {:?}",
            allowed
                .keys()
                .filter(|k| !done.contains(k.as_str()))
                .collect::<Vec<_>>()
        );
        done.extend(next);
    }
}
