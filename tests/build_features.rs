//! One build for both README commands: `cargo run --release` (normal dependencies) and
//! `cargo test --release` (normal + dev-dependencies) must resolve every shared dependency
//! with the same features, or the second command recompiles them (faer, nalgebra, rayon,
//! ...). A dev-dependency that switches on a new feature of a shared crate fails this test;
//! name that feature under "Feature unification" in `Cargo.toml`.

use std::collections::BTreeMap;
use std::process::Command;

/// `name@version -> features` of every crate `cargo tree` resolves over the given edges.
fn resolved_features(edges: &str) -> BTreeMap<String, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let output = Command::new(cargo)
        .args(["tree", "--offline", "--locked", "--prefix", "none"])
        .args(["-e", edges, "-f", "{p}|{f}"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo runs");
    assert!(
        output.status.success(),
        "cargo tree -e {edges}: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let mut crates = BTreeMap::new();
    for line in String::from_utf8_lossy(&output.stdout).lines() {
        let line = line.trim_end_matches(" (*)");
        let Some((package, features)) = line.split_once('|') else {
            continue;
        };
        // `{p}` is "name vX.Y.Z" or "name vX.Y.Z (path)".
        let mut words = package.split_whitespace();
        let (Some(name), Some(version)) = (words.next(), words.next()) else {
            continue;
        };
        crates.insert(format!("{name}@{version}"), features.trim().to_string());
    }
    crates
}

#[test]
fn run_and_test_builds_resolve_shared_dependencies_with_the_same_features() {
    let normal = resolved_features("normal,build");
    let with_dev = resolved_features("normal,build,dev");
    assert!(
        normal.keys().any(|name| name.starts_with("faer@")) && normal.len() > 50,
        "cargo tree listed only {} crates",
        normal.len()
    );
    let differing: Vec<String> = normal
        .iter()
        .filter_map(|(name, features)| {
            let dev = with_dev.get(name)?;
            (dev != features).then(|| format!("{name}: run [{features}] test [{dev}]"))
        })
        .collect();
    assert!(
        differing.is_empty(),
        "dependencies built twice (once per command):\n{}",
        differing.join("\n")
    );
}
