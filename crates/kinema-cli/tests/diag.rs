//! The `kinema` binary on hostile model files: the error report stays short
//! and points at the cause (item 5 and the model-file part of item 11 of
//! the hostile-input issue).

use std::path::PathBuf;
use std::process::{Command, Output};

/// A model file in a fresh temporary directory, removed on drop.
struct TempModel(PathBuf);

impl TempModel {
    fn new(name: &str, bytes: &[u8]) -> TempModel {
        let dir = std::env::temp_dir().join(format!("kinema-diag-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        TempModel(path)
    }

    fn check(&self) -> Output {
        Command::new(env!("CARGO_BIN_EXE_kinema"))
            .arg("check")
            .arg(&self.0)
            .output()
            .unwrap_or_else(|e| panic!("cannot run kinema: {e}"))
    }
}

impl Drop for TempModel {
    fn drop(&mut self) {
        if let Some(dir) = self.0.parent() {
            let _ = std::fs::remove_dir_all(dir);
        }
    }
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A Latin-1 byte in a comment: status 2, and the message gives the line
/// and the column of the first byte that is not UTF-8.
#[test]
fn invalid_utf8_is_located() {
    let m = TempModel::new(
        "latin1.kin",
        b"mechanism M {\n    body bar;\n    driver d: bar.x == t; // caf\xE9\n}\n",
    );
    let o = m.check();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    // The CLI reads through kinema_model::Source::read (size cap); its message
    // gives the byte, line and column.
    assert!(err.to_lowercase().contains("byte 0xe9"), "{err}");
    assert!(err.contains("line 3, column 33"), "{err}");
}

/// 20 000 mistakes: status 2, every one counted, the first 100 shown, and a
/// report of a few tens of kilobytes (a 60 KB file used to give 900 MB).
#[test]
fn many_errors_give_a_short_report() {
    let n = 20_000;
    let mut src = String::from("mechanism M {\n    body bar;\n");
    for i in 0..n {
        src.push_str(&format!("    driver d{i}: bar.x == nobody * t;\n"));
    }
    src.push_str("}\n");
    let m = TempModel::new("many.kin", src.as_bytes());
    let o = m.check();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{}", &err[..err.len().min(2000)]);
    assert!(o.stderr.len() < 100_000, "{} bytes", o.stderr.len());
    assert_eq!(err.matches("error: unknown name `nobody`").count(), 100);
    assert!(err.contains("… and 19900 more errors not shown"), "{err}");
    assert!(err.contains("due to 20000 previous errors"), "{err}");
}

/// One line of 1 MB with a stray backtick at its end: the excerpt is cut
/// around the caret.
#[test]
fn megabyte_line_gives_a_short_excerpt() {
    let mut src = String::from("mechanism M { body bar; driver d: bar.x == t");
    while src.len() < 1_000_000 {
        src.push_str(" + 0 * t");
    }
    src.push_str(" + `t; }\n");
    let m = TempModel::new("long.kin", src.as_bytes());
    let o = m.check();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{}", &err[..err.len().min(2000)]);
    assert!(err.len() < 1000, "{err}");
    assert!(err.contains("unexpected character '`' (U+0060)"), "{err}");
    assert!(err.contains("+ 0 * t + `t; }"), "{err}");
}
