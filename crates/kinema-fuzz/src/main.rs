//! `kinema-fuzz`: the fuzz driver (stable Rust). Generates inputs for each
//! target from a fixed seed, runs them in batches in a child process (itself,
//! with `--child`) under a memory limit, and judges: a panic (caught in the
//! child), an abort, a stack overflow or an allocation failure (the child
//! dies), a hang (no answer within the time limit: the parent kills it), or
//! an oracle violation. Each finding is saved in the output directory with
//! what happened, minimised when that is cheap.
//!
//! ```text
//! kinema-fuzz [--target kin|adm|fun|all] [--seconds N] [--seed S] [--out DIR]
//!             [--seeds DIR]... [--known FILE] [--timeout SECS] [--mem-mb MB]
//!             [--batch N] [--replay PATH] [--dump N]
//! ```
//!
//! Exit status: 0 no new finding, 1 a finding not in the known list, 2 bad
//! arguments or a failure of the driver itself.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use kinema_fuzz::Target;
use kinema_fuzz::generate::{self, Seeds};
use kinema_fuzz::rng::Rng;
use kinema_fuzz::verdict::{Known, Verdict, minimize, run_caught};

/// Field separator inside a protocol line; newlines inside a field.
const SEP: char = '\u{1e}';
const NL: char = '\u{1f}';

struct Args {
    targets: Vec<Target>,
    seconds: f64,
    seed: u64,
    out: PathBuf,
    seed_dirs: Vec<PathBuf>,
    known: Known,
    timeout: Duration,
    mem_mb: u64,
    batch: usize,
    replay: Option<PathBuf>,
    dump: usize,
}

fn usage() -> &'static str {
    "usage: kinema-fuzz [--target kin|adm|fun|all] [--seconds N] [--seed S] [--out DIR] \
     [--seeds DIR]... [--known FILE] [--timeout SECS] [--mem-mb MB] [--batch N] [--replay PATH] [--dump N]"
}

fn parse_args(mut it: impl Iterator<Item = String>) -> Result<Args, String> {
    let mut a = Args {
        targets: Target::ALL.to_vec(),
        seconds: 60.0,
        seed: 1,
        out: PathBuf::from("fuzz-findings"),
        seed_dirs: Vec::new(),
        known: Known::committed(),
        timeout: Duration::from_secs(10),
        mem_mb: 2048,
        batch: 200,
        replay: None,
        dump: 0,
    };
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{flag} needs a value"));
        match flag.as_str() {
            "--target" => {
                let v = value()?;
                a.targets = if v == "all" {
                    Target::ALL.to_vec()
                } else {
                    v.split(',')
                        .map(|n| {
                            Target::from_name(n).ok_or_else(|| format!("unknown target `{n}`"))
                        })
                        .collect::<Result<_, _>>()?
                };
            }
            "--seconds" => a.seconds = number(&flag, &value()?)?,
            "--seed" => {
                let v = value()?;
                a.seed = v
                    .parse()
                    .map_err(|_| format!("--seed: `{v}` is not an integer"))?;
            }
            "--out" => a.out = PathBuf::from(value()?),
            "--seeds" => a.seed_dirs.push(PathBuf::from(value()?)),
            "--known" => {
                let p = value()?;
                let text = std::fs::read_to_string(&p).map_err(|e| format!("--known {p}: {e}"))?;
                a.known = Known::parse(&text);
            }
            "--timeout" => a.timeout = Duration::from_secs_f64(number(&flag, &value()?)?),
            "--mem-mb" => a.mem_mb = number(&flag, &value()?)? as u64,
            "--batch" => a.batch = (number(&flag, &value()?)? as usize).max(1),
            "--replay" => a.replay = Some(PathBuf::from(value()?)),
            "--dump" => a.dump = number(&flag, &value()?)? as usize,
            "-h" | "--help" => return Err(usage().to_string()),
            other => return Err(format!("unknown argument `{other}`\n{}", usage())),
        }
    }
    Ok(a)
}

fn number(flag: &str, v: &str) -> Result<f64, String> {
    match v.parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!("{flag}: `{v}` is not a positive number")),
    }
}

fn main() -> ExitCode {
    let mut argv = std::env::args().skip(1);
    let first = argv.next();
    if first.as_deref() == Some("--child") {
        return child(argv);
    }
    let args = match parse_args(first.into_iter().chain(argv)) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            return ExitCode::from(2);
        }
    };
    match parent(&args) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("kinema-fuzz: {e}");
            ExitCode::from(2)
        }
    }
}

// ---------------------------------------------------------------- child --

/// Child mode: `--child run TARGET BATCHFILE` runs each input of the batch
/// file and reports on stdout; `--child min TARGET INPUT SIGNATURE OUTPUT`
/// minimises one input in process.
fn child(mut argv: impl Iterator<Item = String>) -> ExitCode {
    let mode = argv.next().unwrap_or_default();
    let target = argv.next().as_deref().and_then(Target::from_name);
    let Some(target) = target else {
        eprintln!("--child: bad target");
        return ExitCode::from(2);
    };
    let file = argv.next().unwrap_or_default();
    let Ok(bytes) = std::fs::read(&file) else {
        eprintln!("--child: cannot read {file}");
        return ExitCode::from(2);
    };
    kinema_fuzz::verdict::install_panic_hook();
    if mode == "min" {
        let signature = argv.next().unwrap_or_default();
        let output = argv.next().unwrap_or_default();
        let small = minimize(&bytes, 400, &mut |d| {
            run_caught(target, d).signature().as_deref() == Some(signature.as_str())
        });
        return match std::fs::write(&output, small) {
            Ok(()) => ExitCode::SUCCESS,
            Err(_) => ExitCode::from(2),
        };
    }
    let inputs = decode_batch(&bytes);
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    for (i, data) in inputs.iter().enumerate() {
        let _ = writeln!(out, "S{SEP}{i}");
        let _ = out.flush();
        let line = match run_caught(target, data) {
            Verdict::Clean(r) => format!("C{SEP}{i}{SEP}{}", r.name()),
            v => {
                let sig = v.signature().unwrap_or_default();
                format!("F{SEP}{i}{SEP}{}{SEP}{}", flat(&sig), flat(&v.describe()))
            }
        };
        let _ = writeln!(out, "{line}");
        let _ = out.flush();
    }
    ExitCode::SUCCESS
}

fn flat(s: &str) -> String {
    s.replace(['\n', SEP], &NL.to_string())
}

fn encode_batch(inputs: &[Vec<u8>]) -> Vec<u8> {
    let mut out = Vec::new();
    for d in inputs {
        out.extend_from_slice(&(d.len() as u64).to_le_bytes());
        out.extend_from_slice(d);
    }
    out
}

fn decode_batch(mut bytes: &[u8]) -> Vec<&[u8]> {
    let mut out = Vec::new();
    while bytes.len() >= 8 {
        let (len, rest) = bytes.split_at(8);
        let mut n = [0u8; 8];
        n.copy_from_slice(len);
        let n = (u64::from_le_bytes(n) as usize).min(rest.len());
        out.push(&rest[..n]);
        bytes = &rest[n..];
    }
    out
}

// --------------------------------------------------------------- parent --

/// The outcome of one input as the parent saw it.
#[derive(Clone, Debug)]
enum Seen {
    Clean(String),
    Finding { signature: String, detail: String },
}

/// A running child: its process, its stdout lines, the file with its stderr.
struct Worker {
    child: Child,
    lines: Receiver<String>,
    stderr: PathBuf,
}

impl Worker {
    fn spawn(args: &Args, target: Target, batch: &Path) -> Result<Worker, String> {
        let exe = std::env::current_exe().map_err(|e| format!("cannot find myself: {e}"))?;
        let stderr = args.out.join(format!(".stderr-{}", target.name()));
        let err_file = std::fs::File::create(&stderr)
            .map_err(|e| format!("cannot create {}: {e}", stderr.display()))?;
        // The memory limit through the shell's ulimit (address space, KiB):
        // an allocation beyond it fails, and Rust aborts with a message.
        let script = format!("ulimit -v {} && exec \"$@\"", args.mem_mb * 1024);
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(script)
            .arg("sh")
            .arg(exe)
            .arg("--child")
            .arg("run")
            .arg(target.name())
            .arg(batch)
            .env("RUST_BACKTRACE", "1")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::from(err_file))
            .spawn()
            .map_err(|e| format!("cannot start the child: {e}"))?;
        let stdout = child.stdout.take().ok_or("child without stdout")?;
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Ok(Worker {
            child,
            lines: rx,
            stderr,
        })
    }

    /// Kills the child and its own children (the `cli` target's `kinema`
    /// runs), so that none outlives the batch.
    fn kill(&mut self) {
        let pid = self.child.id();
        let grandchildren =
            std::fs::read_to_string(format!("/proc/{pid}/task/{pid}/children")).unwrap_or_default();
        let _ = self.child.kill();
        let _ = self.child.wait();
        for g in grandchildren.split_whitespace() {
            let _ = Command::new("kill").args(["-9", g]).status();
        }
    }

    /// Why the child died: from its exit status and the end of its stderr.
    fn death(&mut self) -> (String, String) {
        let status = self.child.wait().map(|s| s.to_string()).unwrap_or_default();
        let mut err = String::new();
        if let Ok(mut f) = std::fs::File::open(&self.stderr) {
            let _ = f.read_to_string(&mut err);
        }
        let tail: String = err
            .lines()
            .rev()
            .take(60)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect::<Vec<_>>()
            .join("\n");
        let kind = if err.contains("memory allocation of") || err.contains("capacity overflow") {
            "oom (allocation failure under the memory limit)"
        } else if err.contains("has overflowed its stack") {
            "stack overflow"
        } else {
            "crash"
        };
        (kind.to_string(), format!("child died: {status}\n{tail}"))
    }
}

/// Runs `inputs` in children, restarting after each death or hang; the
/// outcome of each input, `None` for those not run before `deadline`.
fn run_batch(
    args: &Args,
    target: Target,
    inputs: &[Vec<u8>],
    deadline: Instant,
) -> Result<Vec<Option<Seen>>, String> {
    let mut seen: Vec<Option<Seen>> = vec![None; inputs.len()];
    let mut start = 0;
    while start < inputs.len() && Instant::now() < deadline {
        let file = args.out.join(format!(".batch-{}", target.name()));
        std::fs::write(&file, encode_batch(&inputs[start..]))
            .map_err(|e| format!("cannot write {}: {e}", file.display()))?;
        let mut worker = Worker::spawn(args, target, &file)?;
        // The input being run: its index, when it started (wall clock) and
        // the child's CPU time then.
        let mut current: Option<(usize, Instant, f64)> = None;
        let mut next_start = inputs.len();
        loop {
            if Instant::now() >= deadline {
                // Out of time: the input under way gets no verdict.
                worker.kill();
                next_start = inputs.len();
                break;
            }
            let wait = match current {
                Some((_, since, _)) => args
                    .timeout
                    .saturating_sub(since.elapsed())
                    .max(Duration::from_millis(100)),
                None => args.timeout,
            }
            .min(deadline.saturating_duration_since(Instant::now()) + Duration::from_millis(1));
            match worker.lines.recv_timeout(wait) {
                Ok(line) => {
                    let fields: Vec<&str> = line.split(SEP).collect();
                    let index = fields.get(1).and_then(|s| s.parse::<usize>().ok());
                    let Some(i) = index.map(|i| i + start) else {
                        continue;
                    };
                    match fields[0] {
                        "S" => {
                            current = Some((i, Instant::now(), cpu_seconds(worker.child.id())));
                            if Instant::now() >= deadline {
                                worker.kill();
                                next_start = inputs.len();
                                break;
                            }
                        }
                        "C" => {
                            current = None;
                            seen[i] = Some(Seen::Clean(fields.get(2).unwrap_or(&"").to_string()));
                        }
                        _ => {
                            current = None;
                            seen[i] = Some(Seen::Finding {
                                signature: fields.get(2).unwrap_or(&"").to_string(),
                                detail: fields.get(3).unwrap_or(&"").replace(NL, "\n"),
                            });
                        }
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    if Instant::now() >= deadline {
                        continue;
                    }
                    if let Some((i, since, cpu0)) = current {
                        // The limit is on CPU time, so that a loaded machine
                        // does not turn slow inputs into hangs; the wall clock
                        // is allowed ten times as much.
                        let cpu = cpu_seconds(worker.child.id()) - cpu0;
                        if cpu < args.timeout.as_secs_f64() && since.elapsed() < args.timeout * 10 {
                            continue;
                        }
                        worker.kill();
                        seen[i] = Some(Seen::Finding {
                            signature: "hang".to_string(),
                            detail: format!(
                                "no answer after {cpu:.1} s of CPU time ({:.1} s wall clock; limit {:?})",
                                since.elapsed().as_secs_f64(),
                                args.timeout
                            ),
                        });
                        next_start = i + 1;
                        break;
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    if let Some((i, _, _)) = current {
                        let (kind, detail) = worker.death();
                        seen[i] = Some(Seen::Finding {
                            signature: kind,
                            detail,
                        });
                        next_start = i + 1;
                    } else {
                        // Between inputs: the batch is done, or the child
                        // failed before or between inputs (then go on from
                        // the first input without a verdict, unless it made
                        // no progress at all: that is the driver's failure).
                        let failed = worker.child.wait().map_or(true, |s| !s.success());
                        let first_open = (start..inputs.len()).find(|&k| seen[k].is_none());
                        if let (true, Some(k)) = (failed, first_open) {
                            if k == start {
                                let (_, detail) = worker.death();
                                return Err(format!("the child failed before any input: {detail}"));
                            }
                            next_start = k;
                        }
                    }
                    break;
                }
            }
        }
        start = next_start;
    }
    Ok(seen)
}

/// CPU time (user + system) a process has used, from `/proc` (Linux);
/// 0 where that cannot be read, which makes the time limit a wall-clock one.
fn cpu_seconds(pid: u32) -> f64 {
    stat_seconds(&format!("/proc/{pid}/stat"), 11)
}

/// CPU time of this process's children that have been waited for (all the
/// children's work, for the statistics), from `/proc/self/stat`.
fn children_cpu_seconds() -> f64 {
    stat_seconds("/proc/self/stat", 13)
}

/// The sum of two consecutive tick counts in a `/proc/…/stat` file, from
/// index `first` after the command name, in seconds.
fn stat_seconds(path: &str, first: usize) -> f64 {
    let Ok(stat) = std::fs::read_to_string(path) else {
        return 0.0;
    };
    // Fields after the command name (which may contain spaces) end with `)`.
    let Some((_, rest)) = stat.rsplit_once(')') else {
        return 0.0;
    };
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the whole line (11 and 12
    // here), cutime and cstime 16 and 17 (13 and 14).
    let ticks = |k: usize| {
        fields
            .get(k)
            .and_then(|f| f.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    // Clock ticks per second: 100 on every Linux configuration in use.
    (ticks(first) + ticks(first + 1)) / 100.0
}

/// Per-target statistics.
#[derive(Default)]
struct Stats {
    inputs: usize,
    reach: BTreeMap<String, usize>,
    findings: BTreeMap<String, usize>,
    elapsed: Duration,
    /// CPU seconds the children used.
    cpu: f64,
}

fn parent(args: &Args) -> Result<bool, String> {
    std::fs::create_dir_all(&args.out)
        .map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    if let Some(path) = &args.replay {
        return replay(args, path);
    }
    let mut seeds = Seeds::embedded();
    for dir in &args.seed_dirs {
        seeds = seeds.with_dir(dir);
    }
    if args.dump > 0 {
        for &target in &args.targets {
            let mut rng = target_rng(args.seed, target);
            for k in 0..args.dump {
                let data = generate::input(target, &mut rng, &seeds);
                let path = args
                    .out
                    .join(format!("{}-{k}.{}", target.name(), extension(target)));
                std::fs::write(&path, data).map_err(|e| format!("{}: {e}", path.display()))?;
            }
        }
        return Ok(true);
    }
    let per_target = args.seconds / args.targets.len() as f64;
    let mut clean = true;
    let mut report = String::new();
    for &target in &args.targets {
        let begin = Instant::now();
        let cpu_begin = children_cpu_seconds();
        let deadline = begin + Duration::from_secs_f64(per_target);
        let mut rng = target_rng(args.seed, target);
        let mut stats = Stats::default();
        let mut saved: BTreeMap<String, usize> = BTreeMap::new();
        let mut batch_no = 0;
        while Instant::now() < deadline {
            let inputs: Vec<Vec<u8>> = (0..args.batch)
                .map(|_| generate::input(target, &mut rng, &seeds))
                .collect();
            let seen = run_batch(args, target, &inputs, deadline)?;
            for (k, (input, outcome)) in inputs.iter().zip(&seen).enumerate() {
                match outcome {
                    None => {}
                    Some(Seen::Clean(r)) => {
                        stats.inputs += 1;
                        *stats.reach.entry(r.clone()).or_default() += 1;
                    }
                    Some(Seen::Finding { signature, detail }) => {
                        stats.inputs += 1;
                        *stats.reach.entry("finding".into()).or_default() += 1;
                        *stats.findings.entry(signature.clone()).or_default() += 1;
                        let known = args.known.contains(target, signature);
                        if !known {
                            clean = false;
                        }
                        let n = saved.entry(signature.clone()).or_default();
                        *n += 1;
                        if *n <= 3 {
                            let origin = format!("seed {} batch {batch_no} input {k}", args.seed);
                            let finding = Finding {
                                target,
                                signature,
                                detail,
                                input,
                                origin: &origin,
                                known,
                                n: *n,
                            };
                            save(args, &finding);
                        }
                    }
                }
            }
            batch_no += 1;
        }
        stats.elapsed = begin.elapsed();
        stats.cpu = children_cpu_seconds() - cpu_begin;
        let line = summary(target, &stats, &args.known);
        eprintln!("{line}");
        report.push_str(&line);
        report.push('\n');
    }
    let _ = std::fs::write(args.out.join("summary.txt"), &report);
    Ok(clean)
}

/// The generator of a target: independent of the other targets, so that
/// `--target kin` produces the same inputs as `--target all`.
fn target_rng(seed: u64, target: Target) -> Rng {
    Rng::new(seed ^ (target as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

fn summary(target: Target, s: &Stats, known: &Known) -> String {
    let secs = s.elapsed.as_secs_f64();
    let mut line = format!(
        "{}: {} inputs in {:.1} s ({:.1}/s; {:.1} s of CPU in the children, {:.1} per CPU second);",
        target.name(),
        s.inputs,
        secs,
        s.inputs as f64 / secs.max(1e-9),
        s.cpu,
        s.inputs as f64 / s.cpu.max(1e-9)
    );
    for (r, n) in &s.reach {
        let _ = write!(line, " {r} {n}");
    }
    if s.findings.is_empty() {
        line.push_str("; no findings");
    }
    for (sig, n) in &s.findings {
        let tag = if known.contains(target, sig) {
            "known"
        } else {
            "NEW"
        };
        let _ = write!(line, "\n  {tag} finding ×{n}: {sig}");
    }
    line
}

fn slug(s: &str) -> String {
    let mut out: String = s
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    out.truncate(60);
    out
}

fn extension(target: Target) -> &'static str {
    match target {
        Target::Kin => "kin",
        Target::Adm => "adm",
        Target::Fun => "fun",
        Target::Cli => "cli",
    }
}

/// A finding to save: what a target did with one input, and where it came
/// from.
struct Finding<'a> {
    target: Target,
    /// What went wrong, in the known-findings list's form.
    signature: &'a str,
    /// The child's message.
    detail: &'a str,
    input: &'a [u8],
    /// Seed, batch and input number.
    origin: &'a str,
    /// In the known-findings list.
    known: bool,
    /// How many times this signature was saved, this one included.
    n: usize,
}

/// Saves a finding: the input (minimised when the finding is reproducible
/// in process) and a text file saying what happened.
fn save(args: &Args, finding: &Finding<'_>) {
    let &Finding {
        target,
        signature,
        detail,
        input,
        origin,
        known,
        n,
    } = finding;
    let base = format!("{}-{}-{n}", target.name(), slug(signature));
    let input_path = args.out.join(format!("{base}.{}", extension(target)));
    let _ = std::fs::write(&input_path, input);
    let mut minimised = None;
    let in_process = !(signature == "hang"
        || signature.starts_with("oom")
        || signature.starts_with("crash")
        || signature.starts_with("stack"));
    if in_process && input.len() > 1 {
        let min_path = args.out.join(format!("{base}.min.{}", extension(target)));
        let exe = std::env::current_exe().ok();
        if let Some(exe) = exe {
            let script = format!("ulimit -v {} && exec \"$@\"", args.mem_mb * 1024);
            let mut child = Command::new("sh")
                .arg("-c")
                .arg(script)
                .arg("sh")
                .arg(exe)
                .args(["--child", "min", target.name()])
                .arg(&input_path)
                .arg(signature)
                .arg(&min_path)
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn();
            if let Ok(c) = child.as_mut() {
                let started = Instant::now();
                loop {
                    match c.try_wait() {
                        Ok(Some(_)) => break,
                        Ok(None) if started.elapsed() < Duration::from_secs(30) => {
                            std::thread::sleep(Duration::from_millis(20));
                        }
                        _ => {
                            let _ = c.kill();
                            let _ = c.wait();
                            break;
                        }
                    }
                }
            }
            if min_path.exists() {
                minimised = Some(min_path);
            }
        }
    }
    let mut text = format!(
        "target: {}\nsignature: {signature}\nknown: {known}\norigin: {origin}\ninput: {}\n",
        target.name(),
        input_path.display()
    );
    if let Some(m) = &minimised {
        let _ = writeln!(text, "minimised: {}", m.display());
    }
    let _ = write!(text, "\n{detail}\n");
    let _ = std::fs::write(args.out.join(format!("{base}.txt")), text);
    eprintln!(
        "{} {} finding: {signature} → {}",
        if known { "known" } else { "NEW" },
        target.name(),
        input_path.display()
    );
}

/// Replays saved inputs (a file, or a directory with `kin/`, `adm/`, `fun/`
/// or files named by extension) through children, as a fuzz run would.
fn replay(args: &Args, path: &Path) -> Result<bool, String> {
    let mut files = Vec::new();
    collect(path, &mut files);
    files.sort();
    let mut clean = true;
    for file in files {
        let Some(target) = target_of(&file) else {
            continue;
        };
        let data = std::fs::read(&file).map_err(|e| format!("{}: {e}", file.display()))?;
        let started = Instant::now();
        let seen = run_batch(args, target, &[data], started + Duration::from_secs(3600))?;
        let elapsed = started.elapsed();
        let verdict = match seen.into_iter().next().flatten() {
            Some(Seen::Clean(r)) => format!("clean ({r})"),
            Some(Seen::Finding { signature, detail }) => {
                let known = args.known.contains(target, &signature);
                if !known {
                    clean = false;
                }
                let tag = if known { "known" } else { "NEW" };
                format!("{tag} finding: {signature}\n{detail}")
            }
            None => "not run".to_string(),
        };
        println!(
            "{} ({:.2} s): {verdict}",
            file.display(),
            elapsed.as_secs_f64()
        );
    }
    Ok(clean)
}

fn collect(path: &Path, out: &mut Vec<PathBuf>) {
    let mut todo = vec![path.to_path_buf()];
    while let Some(p) = todo.pop() {
        if p.is_dir() {
            if let Ok(entries) = std::fs::read_dir(&p) {
                todo.extend(entries.flatten().map(|e| e.path()));
            }
        } else {
            out.push(p);
        }
    }
}

/// The target of a saved input: by extension (`.kin`, `.adm`, `.fun`).
fn target_of(path: &Path) -> Option<Target> {
    match path.extension()?.to_str()? {
        "kin" => Some(Target::Kin),
        "adm" => Some(Target::Adm),
        "fun" => Some(Target::Fun),
        "cli" => Some(Target::Cli),
        _ => None,
    }
}
