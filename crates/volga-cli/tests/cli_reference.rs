//! docs/CLI.md is the binary's own help, as `scripts/cli-reference.sh` renders it: a flag
//! added, renamed or re-documented without regenerating the reference fails here.
//! Regenerate with `scripts/cli-reference.sh target/release/volga > docs/CLI.md`.

use std::path::Path;
use std::process::Command;

#[test]
fn docs_cli_md_is_the_binarys_help() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let out = Command::new("sh")
        .arg(repo.join("scripts/cli-reference.sh"))
        .arg(env!("CARGO_BIN_EXE_volga"))
        .output()
        .expect("sh runs");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let generated = String::from_utf8(out.stdout).expect("UTF-8 help");
    let committed = std::fs::read_to_string(repo.join("docs/CLI.md")).expect("docs/CLI.md");
    if generated != committed {
        let line = generated
            .lines()
            .zip(committed.lines())
            .position(|(a, b)| a != b)
            .unwrap_or_else(|| generated.lines().count().min(committed.lines().count()));
        panic!(
            "docs/CLI.md differs from the binary's help from line {} on:\n  generated: {:?}\n  committed: {:?}\n\
             regenerate: scripts/cli-reference.sh target/release/volga > docs/CLI.md",
            line + 1,
            generated.lines().nth(line),
            committed.lines().nth(line)
        );
    }
}
