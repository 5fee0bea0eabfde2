//! Writing results: the CSV of the command-line contract, to a file or to
//! standard output, and small formatting helpers for the summary.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

use kinema::State;

use super::Failure;
use super::number::push_e;

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

/// Streams states as CSV rows: columns `t`, the coordinate names, the
/// names suffixed `_dot`, then `_ddot`; numbers in `{:e}`, shortest
/// round-trip (the text of the runtime's `CsvWriter`, written faster: see
/// [`super::number`]).
pub struct CsvSink {
    out: Box<dyn Write>,
    line: Vec<u8>,
    buffer: ryu::Buffer,
    destination: Destination,
    rows: usize,
    columns: usize,
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
    /// Creates the destination and writes the header. Called before the
    /// analysis, so that a bad path fails at once.
    ///
    /// # Errors
    /// [`Failure::Input`] if the file cannot be created.
    pub fn create<N: AsRef<str>>(
        destination: Destination,
        names: &[N],
    ) -> Result<CsvSink, Failure> {
        let out: Box<dyn Write> = match &destination {
            Destination::Stdout => Box::new(BufWriter::new(io::stdout())),
            Destination::File(path) => {
                let file = File::create(path).map_err(|e| {
                    Failure::usage(format_args!("cannot create `{}`: {e}", path.display()))
                })?;
                Box::new(BufWriter::with_capacity(1 << 16, file))
            }
        };
        let mut header = String::from("t");
        for suffix in ["", "_dot", "_ddot"] {
            for name in names {
                header.push(',');
                header.push_str(name.as_ref());
                header.push_str(suffix);
            }
        }
        header.push('\n');
        let mut sink = CsvSink {
            out,
            line: Vec::new(),
            buffer: ryu::Buffer::new(),
            destination,
            rows: 0,
            columns: 1 + 3 * names.len(),
        };
        let result = sink.out.write_all(header.as_bytes());
        result.map_err(|e| write_failure(&sink.destination, &e))?;
        Ok(sink)
    }

    /// Writes one row.
    ///
    /// # Errors
    /// [`Failure::Analysis`] on a write error.
    pub fn write(&mut self, state: &State) -> Result<(), Failure> {
        self.line.clear();
        push_e(&mut self.line, &mut self.buffer, state.t());
        for &v in state.q().iter().chain(state.qd()).chain(state.qdd()) {
            self.line.push(b',');
            push_e(&mut self.line, &mut self.buffer, v);
        }
        self.line.push(b'\n');
        self.out
            .write_all(&self.line)
            .map_err(|e| write_failure(&self.destination, &e))?;
        self.rows += 1;
        Ok(())
    }

    /// Flushes everything.
    ///
    /// # Errors
    /// [`Failure::Analysis`] on a write error.
    pub fn finish(&mut self) -> Result<(), Failure> {
        self.out
            .flush()
            .map_err(|e| write_failure(&self.destination, &e))
    }

    /// Rows written so far (the header not counted).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Columns per row.
    pub fn columns(&self) -> usize {
        self.columns
    }

    /// Where the rows go.
    pub fn destination(&self) -> &Destination {
        &self.destination
    }
}

fn write_failure(destination: &Destination, e: &io::Error) -> Failure {
    match destination {
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

/// A time value, short: `0`, `0.25`, `1.5e-7`.
pub fn time(t: f64) -> String {
    let short = format!("{t:.6}");
    let short = short.trim_end_matches('0').trim_end_matches('.');
    if short.parse::<f64>().ok() == Some(t) || (t.abs() >= 1e-3 && t.abs() < 1e6) {
        short.to_string()
    } else {
        format!("{t:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
    }
}
