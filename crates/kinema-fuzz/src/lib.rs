//! Fuzz targets for kinema's entry points, input generators, and the
//! oracles that judge a run.
//!
//! Four targets, each a plain function of the input bytes
//! ([`run`], or [`fuzz_kin`], [`fuzz_adm`], [`fuzz_fun`] for a libFuzzer or
//! AFL harness: one line each):
//!
//! - [`Target::Kin`]: `.kin` text → parse → check (diagnostics rendered) →
//!   derive (the derivation text) → tapes → assembly and a few steps.
//! - [`Target::Adm`]: ADM JSON, optionally a NUL byte and an ACF analysis →
//!   read → kinematic check → `.kin` emission → the `.kin` pipeline at the
//!   analysis' first solve times.
//! - [`Target::Fun`]: a simEngine2D `fun` string → parse → evaluate →
//!   `.kin` emission as the driver of a one-body model → run; the run must
//!   agree with the `fun` evaluation (a differential oracle).
//! - [`Target::Cli`]: the `kinema` program on a model file ([`cli`]).
//!
//! Oracles here: no NaN or ±∞ in any state reported as a success, emitted
//! `.kin` text that reads back, error output of bounded size, agreement of
//! the two `fun` evaluators, agreement of the tape and the JIT bit for bit
//! (one `.kin` run in eight is run on both). Panics, hangs, aborts and
//! memory are judged by the driver (`kinema-fuzz` binary), which runs
//! inputs in a child process.

pub mod cli;
mod fun_oracle;
pub mod generate;
mod kin;

pub use kin::kin;
use kin::{kin_text, moderate_literals};
pub mod rng;
pub mod verdict;

use std::fmt;

use kinema_adm::fun::{Expr, Fun};

/// An entry point under test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// `.kin` model text.
    Kin,
    /// simEngine2D ADM model, optionally followed by `\0` and an ACF.
    Adm,
    /// A simEngine2D `fun` string.
    Fun,
    /// The `kinema` program on a `.kin` model, or an ADM model (input
    /// starting with `{`) optionally followed by `\0` and an ACF.
    Cli,
}

impl Target {
    /// Every target, in the order the driver runs them.
    pub const ALL: [Target; 4] = [Target::Kin, Target::Adm, Target::Fun, Target::Cli];

    /// The target's name (`kin`, `adm`, `fun`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Target::Kin => "kin",
            Target::Adm => "adm",
            Target::Fun => "fun",
            Target::Cli => "cli",
        }
    }

    /// The target of a name.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }
}

/// How far an input got: for the driver's statistics.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Reach {
    /// Refused by a reader or parser (syntax).
    Parse,
    /// Refused by a checker (names, types, counts).
    Check,
    /// Derived, but the analysis failed with an error.
    Analysis,
    /// Ran every step it was given.
    Ran,
}

impl Reach {
    /// Short name for the statistics.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Reach::Parse => "parse-error",
            Reach::Check => "check-error",
            Reach::Analysis => "analysis-error",
            Reach::Ran => "ran",
        }
    }
}

/// An oracle violation: what the input did that it must not.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Finding {
    /// A short, stable category: the first part of the signature.
    pub kind: &'static str,
    /// What happened, for the report.
    pub detail: String,
    /// Where it happened, when known (`file:line` of a panic in a `kinema`
    /// process): the second part of the signature.
    pub site: Option<String>,
}

impl Finding {
    /// The signature: the kind, and the site when there is one.
    #[must_use]
    pub fn signature(&self) -> String {
        match &self.site {
            Some(site) => format!("{} at {site}", self.kind),
            None => self.kind.to_string(),
        }
    }
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.kind, self.detail)
    }
}

impl std::error::Error for Finding {}

pub(crate) fn finding(kind: &'static str, detail: impl Into<String>) -> Finding {
    Finding {
        kind,
        detail: detail.into(),
        site: None,
    }
}

/// Most ADM solve times the `adm` target steps through.
const ADM_STEPS: usize = 25;

/// Error output may not be much larger than its input.
fn check_error_size(rendered: &str, input_len: usize) -> Result<(), Finding> {
    let limit = (input_len * 64).max(64 * 1024);
    if rendered.len() > limit {
        return Err(finding(
            "error-output-blowup",
            format!(
                "{} bytes of error text for {input_len} bytes of input",
                rendered.len()
            ),
        ));
    }
    if rendered.trim().is_empty() {
        return Err(finding("empty-error", "an error without any message"));
    }
    Ok(())
}

/// Runs one input through a target.
///
/// # Errors
/// A [`Finding`] when an oracle is violated. Panics propagate: the caller
/// catches them.
pub fn run(target: Target, data: &[u8]) -> Result<Reach, Finding> {
    match target {
        Target::Kin => kin(data),
        Target::Adm => adm(data),
        Target::Fun => fun(data),
        Target::Cli => cli::cli(data),
    }
}

/// libFuzzer/AFL entry for `.kin` text: panics on a finding.
///
/// # Panics
/// On any [`Finding`] (and wherever kinema panics).
pub fn fuzz_kin(data: &[u8]) {
    if let Err(f) = kin(data) {
        panic!("finding: {f}");
    }
}

/// libFuzzer/AFL entry for simEngine2D ADM (+ `\0` + ACF): panics on a
/// finding.
///
/// # Panics
/// On any [`Finding`] (and wherever kinema panics).
pub fn fuzz_adm(data: &[u8]) {
    if let Err(f) = adm(data) {
        panic!("finding: {f}");
    }
}

/// libFuzzer/AFL entry for `fun` strings: panics on a finding.
///
/// # Panics
/// On any [`Finding`] (and wherever kinema panics).
pub fn fuzz_fun(data: &[u8]) {
    if let Err(f) = fun(data) {
        panic!("finding: {f}");
    }
}

/// Text as the CLI reads it: invalid UTF-8 is refused (as `read_to_string`
/// does), so such inputs stop here.
fn text(data: &[u8]) -> Option<&str> {
    std::str::from_utf8(data).ok()
}

/// The simEngine2D target: ADM text, optionally `\0` and ACF text.
///
/// # Errors
/// A [`Finding`] when an oracle is violated.
pub fn adm(data: &[u8]) -> Result<Reach, Finding> {
    let (adm_bytes, acf_bytes) = match data.iter().position(|&b| b == 0) {
        Some(k) => (&data[..k], Some(&data[k + 1..])),
        None => (data, None),
    };
    let Some(adm_text) = text(adm_bytes) else {
        return Ok(Reach::Parse);
    };
    let analysis = match acf_bytes {
        None => kinema_adm::Analysis::default(),
        Some(bytes) => {
            let Some(acf_text) = text(bytes) else {
                return Ok(Reach::Parse);
            };
            let source = kinema_model::Source::new("fuzz.acf", acf_text);
            match kinema_adm::Analysis::parse(&source) {
                Ok(a) => a,
                Err(e) => {
                    let rendered = e.report(source.into()).render();
                    check_error_size(&rendered, bytes.len())?;
                    return Ok(Reach::Parse);
                }
            }
        }
    };
    let source = kinema_model::Source::new("fuzz.adm", adm_text);
    let model = match kinema_adm::Model::parse(&source) {
        Ok(m) => m,
        Err(e) => {
            let rendered = e.report(source.into()).render();
            check_error_size(&rendered, adm_bytes.len())?;
            return Ok(Reach::Parse);
        }
    };
    let _ = model.warnings.report(source.into()).render();
    let _ = kinema_adm::ignored_by_kinematics(&model);
    let _ = model.q0();
    if let Err(refusal) = kinema_adm::check_kinematic(&model, &analysis) {
        let _ = refusal.to_string();
        return Ok(Reach::Check);
    }
    let names = kinema_adm::Names::of(&model);
    let _ = names.rows(&model);
    let emitted = kinema_adm::to_kin(&model);
    // `kinema run` builds the model straight from the ADM data; `kinema
    // import` prints it. Both must check alike and derive the same rows.
    let built = kinema_adm::build(&model).check();
    let printed = kinema_model::check_str(&emitted);
    let verdict = |r: &Result<kinema_model::CheckedModel, _>| match r {
        Ok(m) => format!("checks with {} equations", m.equations.len()),
        Err(_) => "is refused".to_string(),
    };
    let (b, p) = (verdict(&built), verdict(&printed));
    if b != p {
        return Err(finding(
            "adm-built-differs",
            format!("the built model {b} and the printed one {p}"),
        ));
    }
    // What the CLI computes before it runs: the output and solve grids.
    let outputs = analysis.output_times();
    let solves = analysis.solve_times();
    if let Some(bad) = outputs.iter().chain(&solves).find(|t| !t.is_finite()) {
        return Err(finding(
            "adm-nonfinite-time",
            format!("the analysis grid contains t = {bad}"),
        ));
    }
    let times: Vec<f64> = solves.iter().take(ADM_STEPS).copied().collect();
    let times = if times.is_empty() { vec![0.0] } else { times };
    let (reach, _) = kin_text(
        &emitted,
        "fuzz.adm (imported as .kin)",
        &times,
        false,
        moderate_literals(&emitted),
    )?;
    match reach {
        Reach::Parse | Reach::Check => {
            // A kinematic ADM model the reader accepted must import as a
            // model that reads back: anything else is a message about text
            // the user never wrote.
            let d = kinema_model::check_str(&emitted)
                .err()
                .map(|d| d.render(&emitted, "imported.kin"))
                .unwrap_or_default();
            let message = first_line(&d).to_string();
            Err(Finding {
                kind: "adm-emitted-kin-rejected",
                site: Some(without_names(&message)),
                detail: message,
            })
        }
        r => Ok(r),
    }
}

/// A message with every `quoted` name replaced by `…`, so that one cause
/// has one signature.
fn without_names(message: &str) -> String {
    let mut out = String::new();
    for (k, part) in message.split('`').enumerate() {
        if k % 2 == 1 {
            out.push_str("`…`");
        } else {
            out.push_str(part);
        }
    }
    out
}

fn first_line(s: &str) -> &str {
    s.lines().next().unwrap_or("")
}

/// Times at which the `fun` target compares the two evaluators.
pub(crate) const FUN_TIMES: [f64; 6] = [0.0, 0.1, 0.25, 0.5, 1.0, 2.0];

/// The `fun` target.
///
/// # Errors
/// A [`Finding`] when an oracle is violated.
pub fn fun(data: &[u8]) -> Result<Reach, Finding> {
    let Some(source) = text(data) else {
        return Ok(Reach::Parse);
    };
    if let Ok(v) = Expr::parse_constant(source)
        && !v.is_finite()
    {
        return Err(finding(
            "fun-nonfinite-constant",
            format!("parse_constant accepted `{source}` as {v}"),
        ));
    }
    let expr = match Fun::parse(source) {
        Ok(Fun::None) => return Ok(Reach::Ran),
        Ok(Fun::Expr(e)) => e,
        Err(e) => {
            let _ = e.to_string();
            return Ok(Reach::Parse);
        }
    };
    let kin_expr = expr.to_kin();
    // Finite differences resolve the derivatives only where no intermediate
    // value is large (1e15 + t does not move with t).
    let resolvable = fun_oracle::resolvable(&expr, &FUN_TIMES);
    let model = generate::kin::driver_model(&kin_expr);
    let (reach, values) = kin_text(&model, "fun.kin", &FUN_TIMES, false, resolvable)?;
    if reach == Reach::Parse {
        return Err(finding(
            "fun-emitted-kin-unparsable",
            format!("`{source}` printed as `{kin_expr}`"),
        ));
    }
    if reach == Reach::Check {
        let rendered = kinema_model::check_str(&model)
            .err()
            .map(|d| d.render(&model, "fun.kin"))
            .unwrap_or_default();
        if rendered.contains("unknown") {
            return Err(finding(
                "fun-emitted-kin-unknown-name",
                format!(
                    "`{source}` printed as `{kin_expr}`: {}",
                    first_line(&rendered)
                ),
            ));
        }
    }
    // An expression undefined at isolated times (t/t at 0) may be
    // simplified into a defined one, as any computer algebra does; one that
    // is undefined at every sample time by a part that does not vary with t
    // (0/0 + t) must not run. See `fun_oracle` for where the reference
    // stands aside.
    let traces: Vec<fun_oracle::Trace> = values
        .iter()
        .map(|&(t, _)| fun_oracle::trace(&expr, t, 0.0))
        .collect();
    if values.len() == FUN_TIMES.len() && fun_oracle::undefined_whatever_t(&expr, &traces) {
        return Err(finding(
            "fun-undefined-value-vanished",
            format!(
                "`{source}` is {} at every t but kinema ran it, giving {} at t = 0",
                traces[0].value(),
                values[0].1
            ),
        ));
    }
    for (&(t, x), tr) in values.iter().zip(&traces) {
        let Some(tolerance) = fun_oracle::tolerance(&expr, t) else {
            continue;
        };
        let v = tr.value();
        if v.is_finite() && (v - x).abs() > tolerance {
            return Err(finding(
                "fun-value-mismatch",
                format!("`{source}` at t = {t}: fun evaluates {v}, kinema {x}"),
            ));
        }
    }
    Ok(reach)
}
