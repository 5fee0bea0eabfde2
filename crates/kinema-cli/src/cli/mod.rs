//! The `kinema` command line: one module per job.
//!
//! | module | job |
//! |---|---|
//! | [`args`] | the grammar (clap) |
//! | [`load`] | reading a `.kin` or `.adm` model into a checked, derived model |
//! | [`adm`] | simEngine2D specifics: the analysis, ignored forces, ADM names in messages |
//! | [`check`] | `kinema check`: DOF report, assembly, rank of Φ_q |
//! | [`plan`] | `kinema run`'s arguments resolved once, and every refusal of them, into a plan the executors below take |
//! | [`run`] | `kinema run` of a kinematic plan: the time loop and its summary |
//! | [`forward`] | `kinema run` of a forward-dynamics plan |
//! | [`equilibrium`] | `kinema run --equilibrium` |
//! | [`sweep`] | `kinema sweep`: a model over a parameter table |
//! | [`fit`] | `kinema fit`: dimensional synthesis — params fitted to a target table |
//! | [`shared`] | what subcommands share (time grids, run errors, assembly and redundancy reports): no subcommand imports another's file |
//! | [`columns`] | `run --columns`: which quantities the CSV holds |
//! | [`sensitivity`] | `run --sensitivity`: the params' sensitivity columns after the others |
//! | [`files`] | a run's CSV (its header: the selected columns, then the run's own), figure and page, created before the analysis |
//! | [`output`] | output files (refused when an input or another output; temporary file renamed on success), the CSV sink; durations and times for people |
//! | [`progress`] | the progress bar on standard error |
//! | [`scene`] | what to draw: bodies, joint points, ground pivots, driven coordinates |
//! | [`plot`] | the SVG figure |
//! | [`animate`] | the animation page (HTML) |
//!
//! Exit status: 0 success (also when standard output's reader goes away:
//! `--out - | head`); 1 the analysis failed, or its results could not be
//! written once it had started (a full disk); 2 bad arguments — an output
//! that cannot be created, or is the same file as an input or another
//! output, included: all detected before the analysis — or a model that
//! cannot be read.

pub mod adm;
pub mod animate;
pub mod args;
pub mod check;
pub mod columns;
pub mod dynamics;
pub mod equilibrium;
pub mod files;
pub mod fit;
pub mod forward;
pub mod load;
pub mod output;
pub mod plan;
pub mod plot;
pub mod progress;
pub mod run;
pub mod scene;
pub mod sensitivity;
pub mod shared;
pub mod sweep;
pub mod warnings;

use std::fmt;
use std::io::Write;
use std::process::ExitCode;

use clap::Parser;

use args::{Cli, Command};

/// Why a command failed; decides the exit status.
#[derive(Debug)]
pub enum Failure {
    /// Bad arguments, an unreadable or invalid model, an output file that
    /// cannot be created: exit status 2. The message is complete (rendered
    /// diagnostics start with `error:` already).
    Input(String),
    /// The analysis failed, or its results could not be written: exit
    /// status 1.
    Analysis(String),
    /// Standard output's reader went away (`kinema run m --out - | head`):
    /// the command stops quietly with status 0, as Unix tools do.
    Closed,
}

impl Failure {
    /// A usage error with an `error: ` prefix.
    pub fn usage(message: impl fmt::Display) -> Failure {
        Failure::Input(format!("error: {message}"))
    }

    /// An analysis failure with an `error: ` prefix.
    pub fn analysis(message: impl fmt::Display) -> Failure {
        Failure::Analysis(format!("error: {message}"))
    }

    fn exit_code(&self) -> u8 {
        match self {
            Failure::Input(_) => 2,
            Failure::Analysis(_) => 1,
            Failure::Closed => 0,
        }
    }

    fn message(&self) -> &str {
        match self {
            Failure::Input(m) | Failure::Analysis(m) => m,
            Failure::Closed => "",
        }
    }
}

/// Parses the arguments, runs the command, prints any failure on standard
/// error and returns the exit status.
pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // Help and version go to stdout with status 0; usage errors to
            // stderr with status 2 (clap's convention, and ours).
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    let result = match &cli.command {
        Command::Check(a) => check::check(&a.model),
        Command::Run(a) => plan::RunPlan::resolve(a).and_then(execute),
        Command::Sweep(a) => sweep::sweep(a),
        Command::Fit(a) => fit::fit(a),
        Command::Derive(a) => load::load(&a.model, None).and_then(|m| {
            m.print_warnings();
            let mut text = m.model.derivation_text();
            if !a.sensitivity.is_empty() {
                let names: Vec<&str> = a.sensitivity.iter().map(String::as_str).collect();
                let mut derivation = m.model.derivation().clone();
                let s = derivation
                    .sensitivities(&names)
                    .map_err(|e| Failure::usage(format_args!("--sensitivity: {e}")))?;
                text.push('\n');
                text.push_str(&derivation.render_sensitivities(&s));
            }
            print_stdout(&text)
        }),
        Command::Codegen(a) => load::load(&a.model, None).and_then(|m| {
            m.print_warnings();
            print_stdout(&m.model.rust_source())
        }),
        Command::Import(a) => adm::import(&a.model),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failure) => {
            let message = failure.message().trim_end();
            if !message.is_empty() {
                print_stderr(message);
            }
            ExitCode::from(failure.exit_code())
        }
    }
}

/// Executes a resolved `kinema run`: each kind of motion has its executor,
/// which takes the plan, never the arguments.
fn execute(plan: plan::RunPlan) -> Result<(), Failure> {
    let plan::RunPlan {
        loaded,
        motion,
        outputs,
    } = plan;
    match &motion {
        plan::Motion::Kinematic(k) => run::kinematics(&loaded, k, &outputs),
        plan::Motion::Forward(f) => forward::run(&loaded, f, &outputs),
        plan::Motion::Equilibrium => equilibrium::run(&loaded, &outputs),
    }
}

/// Writes `text` to standard error, ending with a newline. Errors are
/// ignored: `eprintln!` would panic on a closed pipe (`2>&1 | head`), and
/// there is nowhere left to report them.
pub fn print_stderr(text: &str) {
    let mut err = std::io::stderr().lock();
    let _ = err.write_all(text.as_bytes());
    if !text.ends_with('\n') {
        let _ = err.write_all(b"\n");
    }
    let _ = err.flush();
}

/// Writes `text` to standard output, ending with a newline; a closed pipe
/// (`kinema derive m.kin | head`) is not an error.
pub fn print_stdout(text: &str) -> Result<(), Failure> {
    let mut out = std::io::stdout().lock();
    let result = out
        .write_all(text.as_bytes())
        .and_then(|()| {
            if text.ends_with('\n') {
                Ok(())
            } else {
                out.write_all(b"\n")
            }
        })
        .and_then(|()| out.flush());
    match result {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Failure::analysis(
            format_args!("cannot write to standard output: {e}"),
        )),
        _ => Ok(()),
    }
}
