//! Writing results: output files that never replace a good file with a
//! bad one ([`Outputs`], [`OutputFile`]), the CSV of the command-line
//! contract, to a file or to standard output, and small formatting helpers
//! for the summary.
//!
//! Every output file goes through [`Outputs::create`]: it is refused
//! (exit 2) when it is the same file as an input or as another output
//! (same inode, or the same canonical path for files that do not exist yet:
//! `./a.csv`, `a.csv`, hard and symbolic links are all caught), and it is
//! written to a temporary file in the same directory that is renamed over
//! the target only by [`OutputFile::commit`]. A run that fails before the
//! commit leaves the earlier file as it was.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use kinema::State;

use super::Failure;
use kinema::CsvLine;

/// Where the CSV goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Destination {
    /// Standard output (`--out -`).
    Stdout,
    /// A file.
    File(PathBuf),
}

impl Destination {
    /// `-` is standard output, anything else a file.
    pub fn of(path: &Path) -> Destination {
        if path.as_os_str() == "-" {
            Destination::Stdout
        } else {
            Destination::File(path.to_path_buf())
        }
    }
}

/// What a path names, to tell whether two paths are the same file.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Identity {
    /// An existing regular file: its device and inode (Unix), or its
    /// canonical path.
    Existing(FileKey),
    /// A file that does not exist yet: the canonical path of its directory
    /// joined with its name.
    New(PathBuf),
}

#[cfg(unix)]
type FileKey = (u64, u64);
#[cfg(not(unix))]
type FileKey = PathBuf;

#[cfg(unix)]
fn file_key(_path: &Path, meta: &fs::Metadata) -> Option<FileKey> {
    use std::os::unix::fs::MetadataExt;
    Some((meta.dev(), meta.ino()))
}

#[cfg(not(unix))]
fn file_key(path: &Path, _meta: &fs::Metadata) -> Option<FileKey> {
    fs::canonicalize(path).ok()
}

/// The identity of `path` (symbolic links followed). `None` for things that
/// are not regular files — `/dev/null`, a terminal, a pipe — which may be
/// named by several outputs, and for paths whose directory cannot be
/// resolved (creating them fails with its own message).
fn identity(path: &Path) -> Option<Identity> {
    match fs::metadata(path) {
        Ok(meta) if meta.is_file() => file_key(path, &meta).map(Identity::Existing),
        Ok(_) => None,
        Err(_) => {
            let name = path.file_name()?;
            let dir = match path.parent() {
                Some(d) if !d.as_os_str().is_empty() => d,
                _ => Path::new("."),
            };
            fs::canonicalize(dir)
                .ok()
                .map(|d| Identity::New(d.join(name)))
        }
    }
}

/// The files of one command: its inputs, and the outputs created so far.
/// Every output of a command is created through [`Outputs::create`] (the CSV,
/// the plot, any later one), which refuses a path that is an input or an
/// earlier output.
#[derive(Debug, Default)]
pub struct Outputs {
    /// What each file is for (`the model`, `--out`), its path as given,
    /// and its identity.
    files: Vec<(String, PathBuf, Option<Identity>, bool)>,
}

impl Outputs {
    /// No files yet.
    pub fn new() -> Outputs {
        Outputs::default()
    }

    /// Records an input file (`what`: `the model`, `the analysis file`),
    /// which no output may overwrite.
    pub fn input(&mut self, what: &str, path: &Path) {
        self.files
            .push((what.to_string(), path.to_path_buf(), identity(path), false));
    }

    /// Checks that `path`, the value of `option`, is neither an input nor an
    /// earlier output, and creates it ([`OutputFile::create`]).
    ///
    /// # Errors
    /// [`Failure::Input`] (exit 2) for the same file as an input or another
    /// output, or a file that cannot be created.
    pub fn create(&mut self, option: &str, path: &Path) -> Result<OutputFile, Failure> {
        let id = identity(path);
        if let Some(id) = &id
            && let Some((what, other, _, is_output)) = self
                .files
                .iter()
                .find(|(_, _, o, _)| o.as_ref() == Some(id))
        {
            let (p, o) = (path.display(), other.display());
            return Err(Failure::usage(if *is_output {
                format!(
                    "{option} `{p}` and {what} `{o}` are the same file: each output needs a file of its own"
                )
            } else {
                format!(
                    "{option} `{p}` is {what} (`{o}`): writing it would overwrite {what}; choose another file"
                )
            }));
        }
        let file = OutputFile::create(path)?;
        self.files
            .push((option.to_string(), path.to_path_buf(), id, true));
        Ok(file)
    }
}

/// An output file under construction. A regular file (or a new one) is
/// written to a temporary file in its directory and renamed over its target
/// by [`OutputFile::commit`]; dropped without a commit (a failed run, a
/// write error, a panic), the temporary file is removed and the target is
/// left as it was. Other targets (`/dev/null`, `/dev/stdout`, a pipe) are
/// written in place.
#[derive(Debug)]
pub struct OutputFile {
    /// The path as given, for messages.
    shown: PathBuf,
    /// Where the result goes (symbolic links resolved).
    target: PathBuf,
    /// The temporary file, until the commit; `None` when writing in place.
    temp: Option<PathBuf>,
    file: File,
}

impl OutputFile {
    /// Opens `path` for writing: checks that an existing file is writable,
    /// then creates the temporary file beside it.
    ///
    /// # Errors
    /// [`Failure::Input`] (exit 2): a missing directory, a directory, a
    /// read-only file or directory.
    pub fn create(path: &Path) -> Result<OutputFile, Failure> {
        let cannot = |e: &dyn std::fmt::Display| {
            Failure::usage(format_args!("cannot create `{}`: {e}", path.display()))
        };
        // `""`, `/`, `dir/..`, `dir/`: no file name to create.
        let trailing = path
            .as_os_str()
            .to_string_lossy()
            .ends_with(std::path::is_separator);
        if path.file_name().is_none() || trailing {
            return Err(match fs::metadata(path) {
                Ok(m) if m.is_dir() => cannot(&"it is a directory"),
                _ => cannot(&"not a file name"),
            });
        }
        let meta = fs::metadata(path);
        let target = match &meta {
            // Follow a symbolic link to the file it names.
            Ok(_) => fs::canonicalize(path).map_err(|e| cannot(&e))?,
            // A link to a file not yet created: the file it names.
            Err(_) => match fs::read_link(path) {
                Ok(dest) => path.parent().map_or(dest.clone(), |dir| dir.join(&dest)),
                Err(_) => path.to_path_buf(),
            },
        };
        match meta {
            Ok(m) if m.is_dir() => Err(cannot(&"it is a directory")),
            Ok(m) if !m.is_file() => {
                // A device or a pipe: written in place.
                let file = OpenOptions::new()
                    .write(true)
                    .truncate(true)
                    .open(&target)
                    .map_err(|e| cannot(&e))?;
                Ok(OutputFile {
                    shown: path.to_path_buf(),
                    target,
                    temp: None,
                    file,
                })
            }
            existing => {
                if existing.is_ok() {
                    // Writable now, or the rename would replace a file the
                    // user may not write (rename needs the directory only).
                    OpenOptions::new()
                        .append(true)
                        .open(&target)
                        .map_err(|e| cannot(&e))?;
                }
                let (temp, file) = temp_beside(&target).map_err(|e| cannot(&e))?;
                if let Ok(m) = &existing {
                    // The result keeps the permissions of the file it replaces.
                    let _ = fs::set_permissions(&temp, m.permissions());
                }
                Ok(OutputFile {
                    shown: path.to_path_buf(),
                    target,
                    temp: Some(temp),
                    file,
                })
            }
        }
    }

    /// The path as given.
    pub fn path(&self) -> &Path {
        &self.shown
    }

    /// Flushes and moves the file into place.
    ///
    /// # Errors
    /// [`Failure::Analysis`] (exit 1): the results could not be written.
    pub fn commit(mut self) -> Result<(), Failure> {
        let fail = |e: &io::Error| {
            Failure::analysis(format_args!("cannot write `{}`: {e}", self.shown.display()))
        };
        self.file.flush().map_err(|e| fail(&e))?;
        if let Some(temp) = self.temp.take()
            && let Err(e) = fs::rename(&temp, &self.target)
        {
            let _ = fs::remove_file(&temp);
            return Err(fail(&e));
        }
        Ok(())
    }
}

impl Write for OutputFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

impl Drop for OutputFile {
    fn drop(&mut self) {
        if let Some(temp) = self.temp.take() {
            let _ = fs::remove_file(temp);
        }
    }
}

/// Creates a new temporary file in the directory of `target`, named after
/// it (`.results.csv.1234.0.tmp`).
fn temp_beside(target: &Path) -> io::Result<(PathBuf, File)> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = target
        .file_name()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy());
    let mut last = None;
    for k in 0..100 {
        let temp = dir.join(format!(".{name}.{}.{k}.tmp", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&temp) {
            Ok(file) => return Ok((temp, file)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.unwrap_or_else(|| io::Error::other("no free temporary name")))
}

/// Where the CSV bytes go: standard output or an [`OutputFile`].
pub enum Sink {
    Stdout(io::Stdout),
    File(OutputFile),
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Sink::Stdout(s) => s.write(buf),
            Sink::File(f) => f.write(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match self {
            Sink::Stdout(s) => s.flush(),
            Sink::File(f) => f.flush(),
        }
    }
}

impl Sink {
    /// Opens `destination` (a file through `outputs`, as option `option`),
    /// buffered.
    ///
    /// # Errors
    /// [`Failure::Input`] if the file cannot be created or is an input or
    /// another output.
    pub fn open(
        outputs: &mut Outputs,
        option: &str,
        destination: &Destination,
    ) -> Result<BufWriter<Sink>, Failure> {
        Ok(match destination {
            Destination::Stdout => BufWriter::new(Sink::Stdout(io::stdout())),
            Destination::File(path) => {
                BufWriter::with_capacity(1 << 16, Sink::File(outputs.create(option, path)?))
            }
        })
    }

    /// Flushes `out` and puts a file in place (see [`OutputFile::commit`]).
    ///
    /// # Errors
    /// [`Failure::Analysis`] on a write error; [`Failure::Closed`] when
    /// standard output's reader has gone.
    pub fn finish(out: BufWriter<Sink>, destination: &Destination) -> Result<(), Failure> {
        match out.into_inner() {
            Ok(Sink::File(file)) => file.commit(),
            Ok(Sink::Stdout(mut s)) => s.flush().map_err(|e| write_failure(destination, &e)),
            Err(e) => Err(write_failure(destination, e.error())),
        }
    }
}

/// Streams states as CSV rows: columns `t`, the selected coordinate names,
/// suffixed `_dot`, then `_ddot`; then the selected results (named points,
/// measures) in the same three blocks; numbers in `{:e}`, shortest
/// round-trip, as the runtime's [`CsvLine`] writes every CSV of kinema.
pub struct CsvSink {
    out: BufWriter<Sink>,
    line: CsvLine,
    destination: Destination,
    rows: usize,
    /// The header's names after `t`.
    names: Vec<String>,
    /// The row's values after `t`, reused.
    row: Vec<f64>,
    selection: super::columns::Selection,
}

impl std::fmt::Debug for CsvSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CsvSink")
            .field("destination", &self.destination)
            .field("rows", &self.rows)
            .finish_non_exhaustive()
    }
}

impl CsvSink {
    /// Creates the destination (through `outputs`, as option `--out`) and
    /// writes the header (`header_names`: the selected columns, then any
    /// extra ones [`CsvSink::write_with`] fills, such as inverse dynamics).
    /// Called before the analysis, so that a bad path fails at once.
    ///
    /// # Errors
    /// [`Failure::Input`] if the file cannot be created or is an input or
    /// another output.
    pub fn create(
        outputs: &mut Outputs,
        destination: Destination,
        header_names: &[String],
        selection: super::columns::Selection,
    ) -> Result<CsvSink, Failure> {
        let out = Sink::open(outputs, "--out", &destination)?;
        let mut header = String::from("t");
        for name in header_names {
            header.push(',');
            header.push_str(name);
        }
        header.push('\n');
        let mut sink = CsvSink {
            out,
            line: CsvLine::new(),
            destination,
            rows: 0,
            names: header_names.to_vec(),
            row: Vec::with_capacity(header_names.len()),
            selection,
        };
        let result = sink.out.write_all(header.as_bytes());
        result.map_err(|e| write_failure(&sink.destination, &e))?;
        Ok(sink)
    }

    /// Whether the selection holds result columns (points, outputs): the
    /// caller evaluates them only then.
    pub fn wants_outputs(&self) -> bool {
        !self.selection.outputs.is_empty()
    }

    /// Writes one row: the state's selected coordinates, then the selected
    /// results from `y`, `yd`, `ydd` (all results, in declaration order;
    /// ignored when none is selected), then the values of the extra columns.
    ///
    /// # Errors
    /// [`Failure::Analysis`] on a write error; [`Failure::Closed`] when
    /// standard output's reader has gone (`--out - | head`).
    pub fn write_with(
        &mut self,
        state: &State,
        results: [&[f64]; 3],
        extra: &[f64],
    ) -> Result<(), Failure> {
        self.write_values(
            state.t(),
            [state.q(), state.qd(), state.qdd()],
            results,
            extra,
        )
    }

    /// One row from its parts: t, the selected coordinates of q, q̇, q̈, the
    /// selected results, the extra columns.
    ///
    /// # Errors
    /// As [`CsvSink::write_with`].
    pub fn write_values(
        &mut self,
        t: f64,
        states: [&[f64]; 3],
        results: [&[f64]; 3],
        extra: &[f64],
    ) -> Result<(), Failure> {
        self.line.clear();
        self.line.number(t);
        let row = &mut self.row;
        row.clear();
        let orders = self.selection.orders();
        for values in &states[..orders] {
            for &k in &self.selection.coordinates {
                row.push(values.get(k).copied().unwrap_or(f64::NAN));
            }
        }
        for values in &results[..orders] {
            for &k in &self.selection.outputs {
                row.push(values.get(k).copied().unwrap_or(f64::NAN));
            }
        }
        row.extend_from_slice(extra);
        // Never a silent NaN or ∞ in the results: the solver checks q, q̇
        // and q̈; a named point, an output or a dynamics column evaluated
        // from them can still overflow (a point 1e308 from its body).
        if let Some(j) = row.iter().position(|v| !v.is_finite()) {
            let name = self.names.get(j).map_or("?", String::as_str);
            return Err(Failure::Analysis(format!(
                "error: at t = {t}: column `{name}` is {} (it overflowed); the CSV holds the {} rows before it",
                row[j], self.rows
            )));
        }
        self.line.numbers(row.iter());
        self.line
            .write_to(&mut self.out)
            .map_err(|e| write_failure(&self.destination, &e))?;
        self.rows += 1;
        Ok(())
    }

    /// Flushes everything and puts the file in place: the rows written so
    /// far become the file (also after a failed analysis, whose rows are
    /// kept).
    ///
    /// # Errors
    /// [`Failure::Analysis`] on a write error; [`Failure::Closed`] when
    /// standard output's reader has gone.
    pub fn finish(self) -> Result<(), Failure> {
        let CsvSink {
            out, destination, ..
        } = self;
        Sink::finish(out, &destination)
    }

    /// After the analysis failed: closes the CSV, keeping the rows written
    /// before the failure; a note for the error message that says where
    /// they are (none when there are none, when they went to standard
    /// output, or when closing failed: the analysis error is the one to
    /// report then).
    pub fn finish_after_failure(self) -> String {
        let rows = self.rows;
        let destination = self.destination.clone();
        match (self.finish(), &destination) {
            (Ok(()), Destination::File(p)) if rows == 1 => format!(
                "\n  = note: the 1 row computed before the failure is in `{}`",
                p.display()
            ),
            (Ok(()), Destination::File(p)) if rows > 0 => format!(
                "\n  = note: the {rows} rows computed before the failure are in `{}`",
                p.display()
            ),
            _ => String::new(),
        }
    }

    /// Rows written so far (the header not counted).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Columns per row.
    pub fn columns(&self) -> usize {
        1 + self.names.len()
    }

    /// Where the rows go.
    pub fn destination(&self) -> &Destination {
        &self.destination
    }
}

/// The failure for a write error on `destination`.
pub fn write_failure(destination: &Destination, e: &io::Error) -> Failure {
    match destination {
        Destination::Stdout if e.kind() == io::ErrorKind::BrokenPipe => Failure::Closed,
        Destination::Stdout => {
            Failure::analysis(format_args!("cannot write the CSV to standard output: {e}"))
        }
        Destination::File(p) => {
            Failure::analysis(format_args!("cannot write `{}`: {e}", p.display()))
        }
    }
}

/// A duration for people: `850 µs`, `12.3 ms`, `1.42 s`.
pub fn duration(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s < 1e-3 {
        format!("{:.0} µs", s * 1e6)
    } else if s < 1.0 {
        format!("{:.1} ms", s * 1e3)
    } else {
        format!("{s:.2} s")
    }
}

/// `1 row at t = a` or `N rows at t = a … b` for the rows at `times`;
/// `None` for none.
pub fn rows_at(times: &[f64]) -> Option<String> {
    let (first, last) = (times.first()?, times.last()?);
    Some(if times.len() == 1 {
        format!("1 row at t = {}", time(*first))
    } else {
        format!(
            "{} rows at t = {} … {}",
            times.len(),
            time(*first),
            time(*last)
        )
    })
}

/// A time value, short: `0`, `0.25`, `1.5e-7`, `1.7e308` (never the
/// hundreds of digits of a large number written out).
pub fn time(t: f64) -> String {
    if t.abs() >= 1e6 || !t.is_finite() {
        return format!("{t:e}");
    }
    let short = format!("{t:.6}");
    let short = short.trim_end_matches('0').trim_end_matches('.');
    if short.parse::<f64>().ok() == Some(t) || t.abs() >= 1e-3 {
        short.to_string()
    } else {
        format!("{t:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory for one test.
    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("kinema-output-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("a temporary directory");
        dir
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .expect("readable")
            .filter_map(Result::ok)
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn an_output_replaces_its_target_only_on_commit() {
        let dir = scratch("commit");
        let target = dir.join("r.csv");
        fs::write(&target, "old\n").expect("writable");
        // Dropped without a commit: the target is as it was, no temporary
        // file is left.
        let mut f = OutputFile::create(&target).expect("created");
        f.write_all(b"half").expect("written");
        drop(f);
        assert_eq!(fs::read_to_string(&target).expect("read"), "old\n");
        assert_eq!(names(&dir), ["r.csv"]);
        // Committed: replaced.
        let mut f = OutputFile::create(&target).expect("created");
        f.write_all(b"new\n").expect("written");
        f.commit().expect("committed");
        assert_eq!(fs::read_to_string(&target).expect("read"), "new\n");
        assert_eq!(names(&dir), ["r.csv"]);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn outputs_refuse_inputs_and_each_other() {
        let dir = scratch("same");
        let model = dir.join("m.kin");
        fs::write(&model, "mechanism M {}\n").expect("writable");
        let mut outputs = Outputs::new();
        outputs.input("the model", &model);
        let dotted = dir.join(".").join("m.kin");
        assert!(outputs.create("--out", &dotted).is_err());
        let _csv = outputs
            .create("--out", &dir.join("a.csv"))
            .expect("a new file");
        let again = dir.join("sub").join("..").join("a.csv");
        let _ = fs::create_dir_all(dir.join("sub"));
        match outputs.create("--plot", &again) {
            Err(Failure::Input(m)) => assert!(m.contains("are the same file"), "{m}"),
            other => panic!("{other:?}"),
        }
        assert!(outputs.create("--plot", &dir.join("b.svg")).is_ok());
        assert_eq!(
            fs::read_to_string(&model).expect("read"),
            "mechanism M {}\n"
        );
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn durations_and_times() {
        assert_eq!(duration(Duration::from_micros(850)), "850 µs");
        assert_eq!(duration(Duration::from_micros(12_345)), "12.3 ms");
        assert_eq!(duration(Duration::from_millis(1420)), "1.42 s");
        assert_eq!(time(0.0), "0");
        assert_eq!(time(0.25), "0.25");
        assert_eq!(time(5.0), "5");
        assert_eq!(time(1.5e-7), "1.5e-7");
        assert_eq!(time(-0.0), "-0");
        assert_eq!(time(1.7e308), "1.7e308");
        assert_eq!(time(-2.5e6), "-2.5e6");
        assert_eq!(time(123456.5), "123456.5");
    }
}
