//! ACF analysis files: what to simulate, until when, and where to output.
//!
//! Two forms are read. JSON (the usual one):
//!
//! ```text
//! { "simulation": "Kinematics", "tend": 5.0, "stepSize": 0.01, "outputSteps": 500 }
//! ```
//!
//! and the older plain text, one `key: value` per line, `%` starting a
//! comment:
//!
//! ```text
//! % analysis
//! simulation: kinematics
//! tend: 5
//! stepSize: 0.01
//! outputSteps: 500
//! ```
//!
//! `simulation` is compared case-insensitively; keys are matched exactly in
//! JSON and case-insensitively in the plain form. Numbers may be written as
//! arithmetic (`1/100`). Outputs are at t_k = k·tend/outputSteps,
//! k = 0..=outputSteps.

use kinema_index::u32_of;

use std::sync::Arc;

use kinema_model::{Diagnostics, Report, Source};

use crate::fun::Expr;
use crate::json::{self, Value};
use crate::pos::Pos;

/// The kind of simulation an ACF asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Simulation {
    /// Kinematic analysis: position, velocity, acceleration from the drivers.
    Kinematics,
    /// Forward dynamics (not supported by kinema yet).
    Dynamics,
}

/// An analysis read from an ACF file.
#[derive(Clone, Debug, PartialEq)]
pub struct Analysis {
    /// `simulation`.
    pub simulation: Simulation,
    /// `tend`: the final time (time starts at 0).
    pub tend: f64,
    /// `stepSize`: the largest time step between solves.
    pub step_size: f64,
    /// `outputSteps`: the number of output intervals.
    pub output_steps: usize,
}

impl Default for Analysis {
    /// The analysis of simEngine2D's `kinematics.acf`, used for kinematic
    /// models that come without an ACF: Kinematics, tend 5, stepSize 0.01,
    /// 500 output steps.
    fn default() -> Self {
        Analysis {
            simulation: Simulation::Kinematics,
            tend: 5.0,
            step_size: 0.01,
            output_steps: 500,
        }
    }
}

impl Analysis {
    /// Reads the ACF text of `source` (JSON if it starts with `{`, else the
    /// plain form).
    ///
    /// # Errors
    /// Syntax errors, missing or malformed fields, non-positive `tend`,
    /// `stepSize` or `outputSteps`, an unknown `simulation`, each at its
    /// place in the text (render them with a [`Report`] of `source`).
    pub fn parse(source: &Source) -> Result<Analysis, Diagnostics> {
        let text = source.text();
        let fields = if text
            .trim_start_matches('\u{feff}')
            .trim_start()
            .starts_with('{')
        {
            json_fields(text)?
        } else {
            plain_fields(text)?
        };
        let mut diags = Diagnostics::new();
        let analysis = build(&fields, &mut diags);
        match analysis {
            Some(a) if diags.is_empty() => Ok(a),
            _ => Err(diags),
        }
    }

    /// Reads the ACF file at `path` ([`Source::read`]: the one size cap and
    /// UTF-8 rule), then [`Analysis::parse`]s it.
    ///
    /// # Errors
    /// The file cannot be read, or [`Analysis::parse`]'s errors, as a
    /// report against the file.
    pub fn read(path: &std::path::Path) -> Result<Analysis, Report> {
        let source = Source::read(path)?;
        Analysis::parse(&source).map_err(|d| d.report(Arc::new(source)))
    }

    /// The output times t_k = k·tend/outputSteps, k = 0..=outputSteps
    /// (both ends included; the last is exactly `tend`). When k·tend would
    /// overflow (tend near `f64::MAX`), (k/outputSteps)·tend instead.
    #[must_use]
    pub fn output_times(&self) -> Vec<f64> {
        let n = self.output_steps;
        (0..=n)
            .map(|k| {
                if k == n {
                    self.tend // k·tend/n may round away from tend
                } else {
                    let p = k as f64 * self.tend;
                    if p.is_finite() {
                        p / n as f64
                    } else {
                        (k as f64 / n as f64) * self.tend
                    }
                }
            })
            .collect()
    }

    /// Checks that the analysis's times increase and are not too many: the
    /// solves (`tend / stepSize`) at most [`MAX_SOLVES`]; the output spacing
    /// `tend / outputSteps` and `stepSize` must both be resolvable next to
    /// `tend` (a few units in the last place of it). Otherwise consecutive
    /// times would round to the same number (`tend` 5e-324 with 10 output
    /// steps), or `t + stepSize` back to `t`.
    ///
    /// # Errors
    /// A [`TimesError`] naming the field at fault.
    pub fn check_times(&self) -> Result<(), TimesError> {
        let (tend, n, step) = (self.tend, self.output_steps, self.step_size);
        if !(tend > 0.0 && tend.is_finite() && step > 0.0 && step.is_finite() && n > 0) {
            return Err(TimesError {
                field: "tend",
                message: format!(
                    "tend {}, stepSize {} and outputSteps {n} must be positive and finite",
                    crate::fun::format_number(tend),
                    crate::fun::format_number(step)
                ),
            });
        }
        // The spacing between representable times just below tend.
        let ulp = tend - tend.next_down();
        let spacing = tend / n as f64;
        if spacing < 4.0 * ulp {
            return Err(TimesError {
                field: "outputSteps",
                message: format!(
                    "the output times do not increase: tend / outputSteps = {} / {n} = {} is below \
                     the resolution of times near tend ({ulp:e}); use fewer output steps or a later tend",
                    crate::fun::format_number(tend),
                    crate::fun::format_number(spacing)
                ),
            });
        }
        if step < ulp {
            return Err(TimesError {
                field: "stepSize",
                message: format!(
                    "the solve times do not increase: stepSize {step:e} is below the resolution of times near tend {} ({ulp:e}), so t + stepSize would round back to t",
                    crate::fun::format_number(tend)
                ),
            });
        }
        let solves = tend / step;
        if solves > MAX_SOLVES as f64 {
            return Err(TimesError {
                field: "stepSize",
                message: format!(
                    "simEngine2D solves every stepSize: tend / stepSize = {} / {} = {solves:.3e} \
                     solves, more than the {MAX_SOLVES} a run may take; use a larger stepSize",
                    crate::fun::format_number(tend),
                    crate::fun::format_number(step)
                ),
            });
        }
        Ok(())
    }

    /// The times at which simEngine2D solved: every `stepSize` from 0 and
    /// additionally at every output time (a step that would pass an output
    /// time stops on it). Useful to follow the engine's branch choices; the
    /// results are reported at [`Analysis::output_times`] only.
    #[must_use]
    pub fn solve_times(&self) -> Vec<f64> {
        let outputs = self.output_times();
        let mut times = vec![0.0];
        let mut t = 0.0;
        let mut next = 1; // index of the next output time
        // Every step advances by stepSize or lands on an output time, so the
        // loop ends; the cap guards against a degenerate stepSize.
        let cap =
            outputs.len() + (self.tend / self.step_size).ceil().min(MAX_SOLVES as f64) as usize + 2;
        while next < outputs.len() && times.len() < cap {
            let target = outputs[next];
            if t + self.step_size >= target {
                t = target;
                next += 1;
            } else {
                t += self.step_size;
            }
            times.push(t);
        }
        times
    }

    /// The run's grid as the command line solves it: the solve times of
    /// [`Analysis::solve_times`] merged with the [`Analysis::output_times`]
    /// (strictly increasing), and for each whether it is an output. A solve
    /// within roundoff (1e-9 · stepSize) before the next output time is
    /// that output (the engine's `t + stepSize` drifts: 0.29 + 0.01 <
    /// 0.3). `kinema run model.adm` and the Python package step a solver
    /// through these times and report the outputs.
    #[must_use]
    pub fn grid(&self) -> (Vec<f64>, Vec<bool>) {
        let outputs = self.output_times();
        let solves = self.solve_times();
        let (mut times, mut output) = (Vec::new(), Vec::new());
        let (mut i, mut j) = (0, 0);
        while i < solves.len() || j < outputs.len() {
            let (s, o) = (solves.get(i).copied(), outputs.get(j).copied());
            let (t, is_output) = match (s, o) {
                (Some(s), Some(o)) if s == o => {
                    i += 1;
                    j += 1;
                    (s, true)
                }
                (Some(s), Some(o)) if s < o => {
                    i += 1;
                    (s, false)
                }
                (_, Some(o)) => {
                    j += 1;
                    (o, true)
                }
                (Some(s), None) => {
                    i += 1;
                    (s, false)
                }
                (None, None) => break,
            };
            let near_output = !is_output
                && outputs
                    .get(j)
                    .is_some_and(|&o| o - t <= 1e-9 * self.step_size.abs());
            if near_output {
                continue;
            }
            // Keep the grid strictly increasing whatever the inputs.
            if times.last().is_none_or(|&last| t > last) {
                times.push(t);
                output.push(is_output);
            } else if is_output && let Some(last) = output.last_mut() {
                *last = true;
            }
        }
        (times, output)
    }
}

/// Most solve times an analysis may ask for (`tend / stepSize`): the same
/// limit as the command line's on a run's times. A 10⁸-entry grid from a
/// subnormal stepSize would otherwise be built (800 MB) and solved.
pub const MAX_SOLVES: usize = 10_000_000;

/// Why an analysis's times do not increase ([`Analysis::check_times`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TimesError {
    /// The ACF field at fault: `tend`, `stepSize` or `outputSteps`.
    pub field: &'static str,
    /// What is wrong, with the values.
    pub message: String,
}

impl std::fmt::Display for TimesError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for TimesError {}

/// A field value with the position of its key and value.
struct Field {
    key: String,
    pos: Pos,
    value: FieldValue,
}

enum FieldValue {
    Number(f64),
    Text(String),
    Other(&'static str),
}

fn json_fields(text: &str) -> Result<Vec<Field>, Diagnostics> {
    let root: Value = json::parse(text)?;
    let Some(members) = root.as_object() else {
        let mut one = Diagnostics::new();
        one.push(
            root.pos
                .error(format!("expected a JSON object, found {}", root.describe())),
        );
        return Err(one);
    };
    Ok(members
        .iter()
        .map(|m| Field {
            key: m.key.clone(),
            pos: m.value.pos,
            value: match (&m.value.as_f64(), m.value.as_str()) {
                (Some(x), _) => FieldValue::Number(*x),
                (None, Some(s)) => FieldValue::Text(s.text.clone()),
                _ => FieldValue::Other(m.value.describe()),
            },
        })
        .collect())
}

fn plain_fields(text: &str) -> Result<Vec<Field>, Diagnostics> {
    let mut fields = Vec::new();
    let mut diags = Diagnostics::new();
    for (i, raw) in text.split('\n').enumerate() {
        let line_no = u32_of(i + 1, "an ACF line");
        let line = raw.split('%').next().unwrap_or("");
        if line.trim().is_empty() {
            continue;
        }
        let at = |chars: usize| Pos {
            line: line_no,
            col: u32_of(chars + 1, "an ACF column"),
            offset: 0,
        };
        let indent = line.chars().take_while(|c| c.is_whitespace()).count();
        let Some((key, value)) = line.split_once(':') else {
            diags.push(at(indent).error("expected `key: value` (for example `tend: 5`)"));
            continue;
        };
        let key = key.trim().trim_matches('"').to_string();
        let value_col = key_len(line) + 1;
        let vindent = value_col
            + line
                .chars()
                .skip(value_col)
                .take_while(|c| c.is_whitespace())
                .count();
        let text = value.trim().trim_end_matches(',').trim();
        let text = text.trim_matches('"');
        let canonical = ["simulation", "tend", "stepSize", "outputSteps"]
            .iter()
            .find(|k| k.eq_ignore_ascii_case(&key))
            .map_or(key.clone(), |k| (*k).to_string());
        let value = if canonical == "simulation" {
            FieldValue::Text(text.to_string())
        } else {
            match Expr::parse_constant(text) {
                Ok(x) => FieldValue::Number(x),
                Err(e) => {
                    diags.push(at(vindent + e.offset).error(format!(
                        "field \"{canonical}\": cannot read `{text}`: {}",
                        e.message
                    )));
                    continue;
                }
            }
        };
        fields.push(Field {
            key: canonical,
            pos: at(vindent),
            value,
        });
    }
    if diags.is_empty() {
        Ok(fields)
    } else {
        Err(diags)
    }
}

/// The number of characters before the first `:` of a line.
fn key_len(line: &str) -> usize {
    line.chars().take_while(|&c| c != ':').count()
}

fn build(fields: &[Field], diags: &mut Diagnostics) -> Option<Analysis> {
    let mut err = |pos: Pos, msg: String| diags.push(pos.error(msg));
    let end = Pos::start();
    let get = |key: &str| fields.iter().find(|f| f.key == key);

    let simulation = match get("simulation") {
        None => {
            err(
                end,
                "missing field \"simulation\" (\"Kinematics\" or \"Dynamics\")".into(),
            );
            None
        }
        Some(f) => match &f.value {
            FieldValue::Text(s) if s.trim().eq_ignore_ascii_case("kinematics") => {
                Some(Simulation::Kinematics)
            }
            FieldValue::Text(s) if s.trim().eq_ignore_ascii_case("dynamics") => {
                Some(Simulation::Dynamics)
            }
            FieldValue::Text(s) => {
                err(
                    f.pos,
                    format!(
                        "field \"simulation\": unknown simulation \"{}\" (expected \"Kinematics\" or \"Dynamics\")",
                        s.escape_debug()
                    ),
                );
                None
            }
            FieldValue::Number(_) => {
                err(
                    f.pos,
                    "field \"simulation\": expected a string, found a number".into(),
                );
                None
            }
            FieldValue::Other(what) => {
                err(
                    f.pos,
                    format!("field \"simulation\": expected a string, found {what}"),
                );
                None
            }
        },
    };
    let mut positive = |key: &str, integer: bool| -> Option<f64> {
        let Some(f) = get(key) else {
            err(end, format!("missing field \"{key}\""));
            return None;
        };
        let x = match &f.value {
            FieldValue::Number(x) => *x,
            FieldValue::Text(_) => {
                err(
                    f.pos,
                    format!("field \"{key}\": expected a number, found a string"),
                );
                return None;
            }
            FieldValue::Other(what) => {
                err(
                    f.pos,
                    format!("field \"{key}\": expected a number, found {what}"),
                );
                return None;
            }
        };
        if !(x > 0.0 && x.is_finite()) || (integer && (x.fract() != 0.0 || x > 1e9)) {
            let what = if integer {
                "a positive integer"
            } else {
                "a positive number"
            };
            err(
                f.pos,
                format!(
                    "field \"{key}\": expected {what}, found {}",
                    crate::fun::format_number(x)
                ),
            );
            return None;
        }
        Some(x)
    };
    let tend = positive("tend", false);
    let step_size = positive("stepSize", false);
    let output_steps = positive("outputSteps", true);
    let analysis = Analysis {
        simulation: simulation?,
        tend: tend?,
        step_size: step_size?,
        output_steps: output_steps? as usize,
    };
    if let Err(e) = analysis.check_times() {
        let pos = get(e.field).map_or(end, |f| f.pos);
        err(pos, format!("field \"{}\": {}", e.field, e.message));
        return None;
    }
    Some(analysis)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Analysis, Diagnostics> {
        Analysis::parse(&Source::new("x.acf", text))
    }

    /// Line and 1-based column of the first diagnostic.
    fn place(e: &Diagnostics) -> (usize, usize) {
        let start = e.iter().next().expect("a diagnostic").span.start();
        (start.line, start.column + 1)
    }

    #[test]
    fn json_form() {
        let a = parse("{\n\t\"simulation\": \"kinematics\",\n \"tend\": 2.0, \"stepSize\": 0.01, \"outputSteps\": 4}")
        .expect("parses");
        assert_eq!(a.simulation, Simulation::Kinematics);
        assert_eq!(a.output_times(), vec![0.0, 0.5, 1.0, 1.5, 2.0]);
    }

    #[test]
    fn plain_form() {
        let text = "% my analysis\nsimulation: Dynamics\ntend: 1 % seconds\nstepSize: 1/1000\n\noutputSteps: 500\n";
        let a = parse(text).expect("parses");
        assert_eq!(a.simulation, Simulation::Dynamics);
        assert_eq!(a.tend, 1.0);
        assert_eq!(a.step_size, 0.001);
        assert_eq!(a.output_steps, 500);
    }

    #[test]
    fn output_times_are_k_tend_over_n() {
        let a = Analysis {
            simulation: Simulation::Kinematics,
            tend: 5.0,
            step_size: 0.01,
            output_steps: 300,
        };
        let t = a.output_times();
        assert_eq!(t.len(), 301);
        assert_eq!(t[7], 7.0 * 5.0 / 300.0);
        assert_eq!(t[300], 5.0);
    }

    #[test]
    fn solve_times_include_outputs() {
        let a = Analysis {
            simulation: Simulation::Kinematics,
            tend: 0.05,
            step_size: 0.01,
            output_steps: 3,
        };
        let s = a.solve_times();
        for t in a.output_times() {
            assert!(s.contains(&t), "{t} missing from {s:?}");
        }
        assert!(
            s.windows(2)
                .all(|w| w[1] > w[0] && w[1] - w[0] <= 0.01 + 1e-15)
        );
        assert_eq!(s.last().copied(), Some(0.05));
    }

    #[test]
    fn times_that_do_not_increase_are_refused_at_their_field() {
        let e = parse("{\"simulation\": \"Kinematics\", \"tend\": 5e-324,\n \"stepSize\": 1e-3, \"outputSteps\": 10}")
        .expect_err("5e-324 / 10 underflows");
        let d = e.iter().next().expect("a diagnostic");
        assert!(
            d.message
                .contains("\"outputSteps\": the output times do not increase"),
            "{e}"
        );
        assert_eq!(place(&e), (2, 35), "{e}");
        let e = parse("simulation: kinematics\ntend: 5\nstepSize: 1e-20\noutputSteps: 5\n")
            .expect_err("t + 1e-20 == t near 5");
        let d = e.iter().next().expect("a diagnostic");
        assert!(
            d.message
                .contains("\"stepSize\": the solve times do not increase"),
            "{e}"
        );
        assert_eq!(place(&e).0, 3, "{e}");
        // Resolvable but too many solves: refused at stepSize, not built.
        let e = parse("simulation: kinematics\ntend: 1e6\nstepSize: 1e-3\noutputSteps: 5\n")
            .expect_err("1e9 solves");
        let d = e.iter().next().expect("a diagnostic");
        assert!(
            d.message
                .contains("\"stepSize\": simEngine2D solves every stepSize"),
            "{e}"
        );
        assert!(d.message.contains("1.000e9 solves"), "{e}");
        assert_eq!(place(&e).0, 3, "{e}");
        // Tiny but resolvable times are fine, and so are huge ones.
        for (tend, n) in [(1e-310, 10), (1e-300, 1000), (f64::MAX, 1000)] {
            let a = Analysis {
                simulation: Simulation::Kinematics,
                tend,
                step_size: tend / 7.0,
                output_steps: n,
            };
            assert_eq!(a.check_times(), Ok(()));
            let t = a.output_times();
            assert!(t.iter().all(|x| x.is_finite()), "{tend}");
            assert!(t.windows(2).all(|w| w[1] > w[0]), "{tend}: {t:?}");
            let s = a.solve_times();
            assert!(s.windows(2).all(|w| w[1] > w[0]), "{tend}");
        }
    }

    #[test]
    fn errors() {
        let e = parse("{\"simulation\": \"Static\", \"tend\": -1, \"stepSize\": 0.1}")
            .expect_err("bad");
        let text = e.to_string();
        assert!(text.contains("unknown simulation \"Static\""), "{text}");
        assert!(
            text.contains("\"tend\": expected a positive number, found -1"),
            "{text}"
        );
        assert!(text.contains("missing field \"outputSteps\""), "{text}");
        assert!(parse("simulation kinematics").is_err());
        assert!(parse("{").is_err());
    }
}
