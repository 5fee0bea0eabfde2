//! Helpers shared by the integration tests.

use std::path::PathBuf;

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
