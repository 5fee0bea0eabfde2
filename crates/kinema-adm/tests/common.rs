//! Helpers shared by the integration tests.

use std::path::PathBuf;

use kinema_adm::Source;

/// The crate's own test files.
pub fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// Reads a test file; the name (not the full path) names it in messages,
/// so snapshots do not depend on where the repository is.
pub fn read(name: &str) -> String {
    std::fs::read_to_string(data(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// A test file as a source named by its name.
#[allow(dead_code, reason = "not every test parses the crate's files")]
pub fn source(name: &str) -> Source {
    Source::new(name, read(name))
}

/// `diagnostics` rendered against `source`, as the command line shows them.
#[allow(dead_code, reason = "not every test renders diagnostics")]
pub fn render(source: &Source, diagnostics: kinema_adm::Diagnostics) -> String {
    diagnostics
        .report(std::sync::Arc::new(source.clone()))
        .render()
}

/// The `.adm` files of `shared/simengine2d` (beside the repository, or
/// above a worktree of it), sorted; `None`, with a notice, where there is
/// no such folder.
#[allow(dead_code, reason = "not every test reads the shared models")]
pub fn shared_models() -> Option<Vec<PathBuf>> {
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let Some(dir) = manifest
        .ancestors()
        .map(|a| a.join("shared/simengine2d"))
        .find(|d| d.is_dir())
    else {
        println!(
            "NOTICE: no shared/simengine2d above {}; skipping",
            manifest.display()
        );
        return None;
    };
    let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let mut paths: Vec<PathBuf> = entries
        .map(|e| {
            e.unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
                .path()
        })
        .filter(|p| p.extension().is_some_and(|e| e == "adm"))
        .collect();
    paths.sort();
    Some(paths)
}
