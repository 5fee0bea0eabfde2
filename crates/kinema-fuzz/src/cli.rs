//! The `cli` target: the `kinema` program itself on a model file — `kinema
//! check` (assembly, rank by SVD) and `kinema run` with a CSV and an SVG
//! figure — the paths the library targets cannot reach (the CLI's own rank
//! diagnosis, plotting, output files). Each run is a grandchild process with
//! its own CPU-time limit.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::{Finding, Reach, finding};

/// CPU seconds a `kinema` run may take.
const CPU_LIMIT: f64 = 10.0;

/// The `kinema` binary: `$KINEMA_BIN`, or `kinema` beside the running
/// executable (both are built into the same `target/` directory).
#[must_use]
pub fn kinema_binary() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("KINEMA_BIN") {
        return Some(PathBuf::from(p));
    }
    let exe = std::env::current_exe().ok()?;
    let dir = exe.parent()?;
    // Test executables live one level deeper, in `deps/`.
    [dir.join("kinema"), dir.join("../kinema")]
        .into_iter()
        .find(|p| p.is_file())
}

/// CPU seconds used by a running process (Linux `/proc`; 0 elsewhere).
fn cpu_of(pid: u32) -> f64 {
    let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return 0.0;
    };
    let Some((_, rest)) = stat.rsplit_once(')') else {
        return 0.0;
    };
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |k: usize| f.get(k).and_then(|x| x.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

/// Runs `kinema` with `args` in `dir`: its exit code (`None` when killed by
/// a signal), its standard error.
fn kinema(bin: &Path, dir: &Path, args: &[&str]) -> Result<(Option<i32>, String), Finding> {
    let err_path = dir.join("stderr.txt");
    let err_file = std::fs::File::create(&err_path)
        .map_err(|e| finding("cli-setup", format!("cannot create a file: {e}")))?;
    let mut child = Command::new(bin)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::from(err_file))
        .spawn()
        .map_err(|e| finding("cli-setup", format!("cannot start {}: {e}", bin.display())))?;
    let started = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break status,
            Ok(None) => {
                let cpu = cpu_of(child.id());
                if cpu > CPU_LIMIT || started.elapsed() > Duration::from_secs_f64(CPU_LIMIT * 10.0)
                {
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(finding(
                        "cli-hang",
                        format!(
                            "`kinema {}` still running after {cpu:.1} s of CPU time",
                            args.join(" ")
                        ),
                    ));
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) => return Err(finding("cli-setup", format!("cannot wait: {e}"))),
        }
    };
    let stderr = std::fs::read(&err_path).unwrap_or_default();
    let stderr = String::from_utf8_lossy(&stderr).into_owned();
    Ok((status.code(), stderr))
}

/// Judges one `kinema` run: exit 0, 1 or 2, no panic, bounded error text.
fn judge(args: &[&str], code: Option<i32>, stderr: &str, input_len: usize) -> Result<(), Finding> {
    if let Some(at) = stderr.find("panicked at ") {
        let location: String = stderr[at + 12..]
            .chars()
            .take_while(|c| !c.is_whitespace())
            .collect();
        let location = location.trim_end_matches(':');
        let short = crate::verdict::strip_column(location);
        return Err(Finding {
            kind: "cli-panic",
            detail: format!(
                "`kinema {}` panicked at {location}\n{stderr}",
                args.join(" ")
            ),
            site: Some(short.to_string()),
        });
    }
    match code {
        Some(0..=2) => {}
        Some(c) => {
            return Err(finding(
                "cli-exit-status",
                format!("`kinema {}` exited with {c}\n{stderr}", args.join(" ")),
            ));
        }
        None => {
            let kind = if stderr.contains("memory allocation of") {
                "cli-oom"
            } else if stderr.contains("overflowed its stack") {
                "cli-stack-overflow"
            } else {
                "cli-crash"
            };
            return Err(finding(
                kind,
                format!("`kinema {}` killed by a signal\n{stderr}", args.join(" ")),
            ));
        }
    }
    if stderr.len() > (input_len * 64).max(64 * 1024) {
        return Err(finding(
            "error-output-blowup",
            format!(
                "`kinema {}`: {} bytes on stderr",
                args.join(" "),
                stderr.len()
            ),
        ));
    }
    Ok(())
}

/// The `cli` target: a `.kin` model, or (input starting with `{`) an ADM
/// model optionally followed by `\0` and an ACF.
///
/// # Errors
/// A [`Finding`]: a panic, a signal, an unknown exit status, a hang, a
/// non-finite number in a CSV written with exit status 0.
pub fn cli(data: &[u8]) -> Result<Reach, Finding> {
    let Some(bin) = kinema_binary() else {
        return Err(finding(
            "cli-setup",
            "no `kinema` binary: build it (`cargo build -p kinema-cli`) or set KINEMA_BIN",
        ));
    };
    let dir = std::env::temp_dir().join(format!("kinema-fuzz-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)
        .map_err(|e| finding("cli-setup", format!("cannot create {}: {e}", dir.display())))?;
    let is_adm = data.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{');
    let (model, acf) = if is_adm {
        match data.iter().position(|&b| b == 0) {
            Some(k) => (&data[..k], Some(&data[k + 1..])),
            None => (data, None),
        }
    } else {
        (data, None)
    };
    let name = if is_adm { "model.adm" } else { "model.kin" };
    let write = |file: &str, bytes: &[u8]| {
        std::fs::write(dir.join(file), bytes)
            .map_err(|e| finding("cli-setup", format!("cannot write {file}: {e}")))
    };
    write(name, model)?;
    let mut run: Vec<&str> = vec![
        "run", name, "--steps", "20", "--out", "out.csv", "--plot", "out.svg",
    ];
    if let Some(acf) = acf {
        write("analysis.acf", acf)?;
        run.extend(["--acf", "analysis.acf"]);
    }
    let check = ["check", name];
    let (code, stderr) = kinema(&bin, &dir, &check)?;
    judge(&check, code, &stderr, data.len())?;
    let (code, stderr) = kinema(&bin, &dir, &run)?;
    judge(&run, code, &stderr, data.len())?;
    let reach = match code {
        Some(0) => {
            let csv = std::fs::read_to_string(dir.join("out.csv")).unwrap_or_default();
            let non_finite = csv.lines().skip(1).any(|row| {
                row.split(',')
                    .any(|cell| cell.trim().parse::<f64>().is_ok_and(|v| !v.is_finite()))
            });
            if non_finite {
                return Err(finding(
                    "cli-nonfinite-csv",
                    "`kinema run` succeeded and wrote a non-finite number to the CSV",
                ));
            }
            Reach::Ran
        }
        Some(1) => Reach::Analysis,
        _ => Reach::Check,
    };
    let _ = std::fs::remove_dir_all(&dir);
    Ok(reach)
}
