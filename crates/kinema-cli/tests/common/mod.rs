//! Helpers shared by the command-line tests (`tests/cli.rs`,
//! `tests/cli_hostile.rs`, …): running the binary, its streams and status,
//! temporary directories, and reading the CSV of the contract.

// Each test file uses a different subset of the helpers.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

pub type TestResult = Result<(), Box<dyn std::error::Error>>;

/// The repository root: `models/`, the other crates' test data, `benches/`;
/// the binary runs there.
pub const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// This package's directory: the command line's own fixtures (`tests/cli/`).
pub const HERE: &str = env!("CARGO_MANIFEST_DIR");

/// Runs the binary in the repository root with `args`.
pub fn kinema(args: &[&str]) -> Output {
    kinema_in(Path::new(ROOT), args)
}

pub fn kinema_in(dir: &Path, args: &[&str]) -> Output {
    match Command::new(env!("CARGO_BIN_EXE_kinema"))
        .args(args)
        .current_dir(dir)
        .output()
    {
        Ok(output) => output,
        Err(e) => panic!("cannot run kinema: {e}"),
    }
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts the exit status, showing both streams on failure.
pub fn assert_status(o: &Output, code: i32) {
    assert_eq!(
        o.status.code(),
        Some(code),
        "stdout:\n{}\nstderr:\n{}",
        stdout(o),
        stderr(o)
    );
}

/// A fresh directory under the system's temporary directory, removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(name: &str) -> TempDir {
        static COUNT: AtomicUsize = AtomicUsize::new(0);
        let k = COUNT.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("kinema-cli-{}-{k}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        if let Err(e) = std::fs::create_dir_all(&dir) {
            panic!("cannot create {}: {e}", dir.display());
        }
        TempDir(dir)
    }

    pub fn path(&self, file: &str) -> String {
        self.0.join(file).display().to_string()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A CSV of the contract: header and rows of numbers.
pub struct Csv {
    pub header: Vec<String>,
    pub rows: Vec<Vec<f64>>,
}

impl Csv {
    pub fn read(path: &str) -> Result<Csv, Box<dyn std::error::Error>> {
        Csv::parse(&std::fs::read_to_string(path)?)
    }

    pub fn parse(text: &str) -> Result<Csv, Box<dyn std::error::Error>> {
        let mut lines = text.lines();
        let header: Vec<String> = lines
            .next()
            .ok_or("empty CSV")?
            .split(',')
            .map(String::from)
            .collect();
        let mut rows = Vec::new();
        for line in lines {
            let row: Vec<f64> = line.split(',').map(str::parse).collect::<Result<_, _>>()?;
            assert_eq!(row.len(), header.len(), "row length: {line}");
            assert!(
                row.iter().all(|v| v.is_finite()),
                "non-finite number: {line}"
            );
            rows.push(row);
        }
        Ok(Csv { header, rows })
    }

    pub fn column(&self, name: &str) -> Result<usize, String> {
        self.header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| format!("no column {name} in {:?}", self.header))
    }
}
