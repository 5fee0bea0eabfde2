//! The command line's grammar (clap): [`Cli`] and its subcommands.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Examples shown at the end of `kinema --help`.
const EXAMPLES: &str = "\
Examples:
  kinema check models/slider_crank.kin
  kinema run models/slider_crank.kin --t-end 2 --steps 200 --out results.csv --plot motion.svg
  kinema derive models/four_bar.kin
  kinema run sliderCrankKIN.adm --acf kinematics.acf --out results.csv
  kinema import sliderCrankKIN.adm > slider_crank.kin

Exit status: 0 success; 1 the analysis failed (no convergence, lock-up) or its results could
not be written once it had started; 2 bad arguments (an output that cannot be created or is an
input or another output included), or a model that cannot be read.";

/// Planar kinematic analysis of mechanisms in absolute coordinates.
///
/// MODEL is a `.kin` file in kinema's model language, or a simEngine2D `.adm`
/// file (JSON), which is imported on the fly.
#[derive(Debug, Parser)]
#[command(name = "kinema", version, about, long_about = None, after_help = EXAMPLES)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Parse and validate a model, report its degrees of freedom, assemble it
    /// at t = 0 from the guess and report the rank of Φ_q there.
    #[command(after_help = "Example:\n  kinema check models/four_bar.kin")]
    Check(ModelArg),
    /// Kinematic analysis over time: positions, velocities and accelerations
    /// as CSV, a summary, and optionally an SVG plot.
    #[command(after_help = RUN_EXAMPLES)]
    Run(RunArgs),
    /// Run a `.kin` model over every row of a parameter table, on every
    /// core, into one CSV (columns `row`, the swept parameters, then those of
    /// `run`).
    #[command(after_help = SWEEP_EXAMPLES)]
    Sweep(SweepArgs),
    /// Dimensional synthesis: fit the model's params so that its results meet
    /// a target table (a coupler path, a rocker's angles), with exact
    /// Jacobians, many starts on every core, and only defect-free designs.
    #[command(after_help = FIT_EXAMPLES)]
    Fit(FitArgs),
    /// Print the symbolic derivation: Φ, Φ_q, Φ_t, Φ_qt, Φ_tt, (Φ_q q̇)_q q̇, ν, γ
    /// (with --sensitivity, the parameter sensitivities' Φ_p and right-hand
    /// sides too).
    #[command(
        after_help = "Examples:\n  kinema derive models/pendulum.kin\n  kinema derive models/four_bar.kin --sensitivity l1,l2"
    )]
    Derive(DeriveArgs),
    /// Print the generated Rust source of the model's solver.
    #[command(
        after_help = "Example:\n  kinema codegen models/slider_crank.kin > src/slider_crank.rs"
    )]
    Codegen(ModelArg),
    /// Print a simEngine2D model (`.adm`) as kinema model text (`.kin`).
    #[command(after_help = "Example:\n  kinema import sliderCrankKIN.adm > slider_crank.kin")]
    Import(ImportArgs),
}

const RUN_EXAMPLES: &str = "\
Examples:
  kinema run models/slider_crank.kin --plot slider_crank.svg
  kinema run models/four_bar.kin --t-end 2 --steps 400 --out four_bar.csv
  kinema run models/pendulum.kin --out - | head
  kinema run models/four_bar.kin --animate four_bar.html
  kinema run rack_pinion.adm --acf kinematics.acf --plot rack.svg

The CSV has the columns t; every body's B.x, B.y, B.phi in declaration order; the same
names suffixed _dot (velocities); then suffixed _ddot (accelerations). With
--positions-only, only t and the position columns.";

const SWEEP_EXAMPLES: &str = "\
Examples:
  kinema sweep models/slider_crank.kin --params lengths.csv --out sweep.csv
  kinema sweep models/slider_crank.kin --params lengths.csv --shard 3/8 --out part3.csv

lengths.csv names some of the model's params in its header, then holds one variant per row:
  l1, l2
  0.30, 1.0
  0.25, 1.1
Lines starting with # and blank lines are skipped. A variant that fails keeps its rows up to
the failure and is named in a warning; the exit status is then 1.";

/// Arguments of `kinema sweep`.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// The model: a `.kin` file.
    #[arg(value_name = "MODEL")]
    pub model: PathBuf,
    /// The parameter table (CSV): a header naming params of the model, then
    /// one row of values per variant.
    #[arg(long, value_name = "TABLE.csv")]
    pub params: PathBuf,
    /// Final time [s]; each variant runs from t = 0. Default 1.
    #[arg(long, value_name = "T", allow_hyphen_values = true)]
    pub t_end: Option<f64>,
    /// Number of equal time steps from 0 to the final time: N + 1 rows per
    /// variant. Default 100.
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub steps: Option<i64>,
    /// Where to write the CSV; `-` for standard output (the summary then
    /// goes to standard error).
    #[arg(long, value_name = "FILE", default_value = "sweep.csv")]
    pub out: PathBuf,
    /// Run only part I of N of the table (contiguous rows, 1 ≤ I ≤ N), for
    /// spreading a sweep over machines: the parts' outputs, concatenated in
    /// order without their headers, are the whole sweep's.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// Worker threads (default: one per core).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub jobs: Option<u16>,
    /// Positions only: no velocity or acceleration solve; the CSV has no
    /// `_dot` and `_ddot` columns.
    #[arg(long)]
    pub positions_only: bool,
}

const FIT_EXAMPLES: &str = "\
Examples:
  kinema fit models/path_generation.kin --target models/path_generation.csv \\
      --vary l1,l2,l3,l0,px,py --t-end 1 --full-turn crank --out fitted.kin --plot fit.svg
  kinema fit models/function_generation.kin --target models/function_generation.csv \\
      --vary l1,l2,l3 --bounds l1=0.1:1,l2=0.2:3,l3=0.2:3

The target table's header names result columns of `kinema run` (coordinates such as
rocker.phi, named points' components such as coupler.p.x, outputs), one target per row.
With a `t` column the timing is prescribed; without one each row's time is an unknown,
the rows visited in their order within one cycle of --t-end. The summary lists the best
defect-free designs (no circuit, branch or order defect) and counts the rejected starts
by reason. Exit status: 0 a design was found; 1 every start was rejected; 2 bad input.";

/// Arguments of `kinema fit`.
#[derive(Debug, Args)]
pub struct FitArgs {
    /// The model: a `.kin` file whose params' values are the first start.
    #[arg(value_name = "MODEL")]
    pub model: PathBuf,
    /// The target table (CSV): a header naming result columns (and `t` to
    /// prescribe the timing), one row per target.
    #[arg(long, value_name = "TARGET.csv")]
    pub target: PathBuf,
    /// The params to fit, comma-separated.
    #[arg(long, value_name = "P1,P2,…", value_delimiter = ',', required = true)]
    pub vary: Vec<String>,
    /// Bounds on varied params, comma-separated `NAME=LO:HI` (either side
    /// may be left out). Starts are drawn within them.
    #[arg(
        long,
        value_name = "P=LO:HI,…",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub bounds: Vec<String>,
    /// Number of starts: the model's design and N − 1 space-filling designs
    /// within the bounds (unbounded params: ±50 % of the model's value).
    #[arg(long, value_name = "N", default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub starts: u32,
    /// The cycle's length [s]: unknown times lie in it, objectives are
    /// measured and --full-turn checked over it. Required without a `t`
    /// column; else the last target's time.
    #[arg(long, value_name = "T", allow_hyphen_values = true)]
    pub t_end: Option<f64>,
    /// A body (the crank) that must turn fully over the cycle, with no
    /// singular configuration on the way.
    #[arg(long, value_name = "BODY")]
    pub full_turn: Option<String>,
    /// An objective beside the targets, `rms(COLUMN)` or `peak(COLUMN)`,
    /// with `*WEIGHT` (repeatable): e.g. `rms(mu)*0.1`.
    #[arg(long, value_name = "MEASURE(COLUMN)*W")]
    pub objective: Vec<String>,
    /// Steps per cycle of each run (the largest step between targets; the
    /// objectives' samples).
    #[arg(long, value_name = "N", default_value_t = 360, value_parser = clap::value_parser!(u32).range(4..=100_000))]
    pub steps: u32,
    /// How many of the best designs the summary lists.
    #[arg(long, value_name = "K", default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
    pub designs: u32,
    /// The scrambling seed of the space-filling starts.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub seed: u32,
    /// Worker threads (default: one per core).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..))]
    pub jobs: Option<u16>,
    /// Write the model with the best design's param values (`.kin`).
    #[arg(long, value_name = "FITTED.kin")]
    pub out: Option<PathBuf>,
    /// Write the summary of the best designs as CSV (rank, errors,
    /// objectives, params, how many starts ended there, the target rows'
    /// times t1, t2, …).
    #[arg(long, value_name = "FILE.csv")]
    pub summary: Option<PathBuf>,
    /// Draw the best design's path (or columns against time) over the
    /// targets (SVG).
    #[arg(long, value_name = "FIT.svg")]
    pub plot: Option<PathBuf>,
}

/// A model file.
#[derive(Debug, Args)]
pub struct ModelArg {
    /// The model: a `.kin` file, or a simEngine2D `.adm` file.
    #[arg(value_name = "MODEL")]
    pub model: PathBuf,
}

/// Arguments of `kinema derive`.
#[derive(Debug, Args)]
pub struct DeriveArgs {
    /// The model: a `.kin` file, or a simEngine2D `.adm` file.
    #[arg(value_name = "MODEL")]
    pub model: PathBuf,
    /// Params whose sensitivities to derive: after the derivation, Φ_p and
    /// the velocity and acceleration right-hand sides (Φ_q ∂q/∂p = −Φ_p, …)
    /// and the results' ∂/∂p, for each.
    #[arg(long, value_name = "P1,P2,…", value_delimiter = ',')]
    pub sensitivity: Vec<String>,
}

/// Arguments of `kinema run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The model: a `.kin` file, or a simEngine2D `.adm` file.
    #[arg(value_name = "MODEL")]
    pub model: PathBuf,
    /// Final time [s]; the analysis runs from t = 0. Default 1 for `.kin`
    /// models; for `.adm` models the ACF's `tend`.
    // Values that start with `-` are taken (and refused with the valid
    // range by `run`), not mistaken for options.
    #[arg(long, value_name = "T", allow_hyphen_values = true)]
    pub t_end: Option<f64>,
    /// Number of equal time steps from 0 to the final time: N + 1 rows.
    /// Default 100 for `.kin` models; for `.adm` models the ACF's
    /// `outputSteps`.
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub steps: Option<i64>,
    /// simEngine2D analysis file for an `.adm` model (default: the engine's
    /// kinematics.acf — Kinematics, tend 5, stepSize 0.01, 500 output steps).
    #[arg(long, value_name = "ANALYSIS.acf")]
    pub acf: Option<PathBuf>,
    /// Where to write the CSV results; `-` for standard output (the summary
    /// then goes to standard error).
    #[arg(long, value_name = "FILE", default_value = "results.csv")]
    pub out: PathBuf,
    /// Which quantities the CSV holds, comma-separated: `bodies`, `points`,
    /// `outputs`, `all`, a body, a point (`crank.pin`), an output, or one
    /// column (`slider.x`). Each gives its value, `_dot` and `_ddot`
    /// columns. Default: all.
    #[arg(long, value_name = "LIST")]
    pub columns: Option<String>,
    /// Write an SVG figure: the mechanism at several instants, the paths of
    /// its joint points, and position, velocity and acceleration against time
    /// (with inertia: reactions and driver efforts; forward dynamics: the
    /// energies and their balance).
    #[arg(long, value_name = "FILE.svg")]
    pub plot: Option<PathBuf>,
    /// Write a self-contained HTML page that plays the motion in any
    /// browser, offline: play/pause, time slider, speed, loop, paths of
    /// points, body frames; run failures marked on the slider.
    #[arg(long, value_name = "FILE.html")]
    pub animate: Option<PathBuf>,
    /// How the equations are evaluated.
    #[arg(long, value_enum, default_value_t = Backend::DEFAULT)]
    pub backend: Backend,
    /// Stop at the first singular configuration (bifurcation or toggle)
    /// instead of passing it on the branch where q̇ is continuous; the rows
    /// before it are kept and the exit status is 1.
    #[arg(long)]
    pub stop_at_singular: bool,
    /// Instead of a motion, the stable static equilibrium of a model with
    /// inertia at t = 0, reached from the guess by descending the potential:
    /// one CSV row (same columns), its stability in the summary.
    #[arg(long)]
    pub equilibrium: bool,
    /// Forward dynamics (a `.kin` model with NDOF > 0 and inertia, or a
    /// simEngine2D Dynamics ACF): the integrator.
    #[arg(long, value_enum, default_value_t = Integrator::Hht)]
    pub integrator: Integrator,
    /// Forward dynamics: the step (default: the ACF's `stepSize`; 1e-3 for
    /// a `.kin` model), shortened to land on every output time.
    #[arg(long, value_name = "H")]
    pub step: Option<f64>,
    /// Forward dynamics with `--integrator accurate`: the relative (and
    /// absolute) tolerance of the error control [default: 1e-8].
    #[arg(long, value_name = "X")]
    pub rtol: Option<f64>,
    /// Positions only, for synthesis loops: no velocity or acceleration
    /// solve, so each step costs Newton's updates alone. The CSV has only
    /// the position columns (t, B.x, B.y, B.phi, points and outputs; no
    /// `_dot`, `_ddot` or dynamics columns). Not with forward dynamics,
    /// `--equilibrium` or `--plot` (which draws velocities).
    #[arg(long)]
    pub positions_only: bool,
    /// Forward dynamics: three more CSV columns, `energy.kinetic`,
    /// `energy.potential` (gravity) and `energy.work` (the work of the
    /// other forces and the drivers since the start): kinetic + potential −
    /// work is constant when the integration is exact.
    #[arg(long)]
    pub energy: bool,
    /// Forward dynamics with HHT: report q̇ projected onto the velocity
    /// constraint Φ_q q̇ = ν (minimum-norm change) at every step. HHT on the
    /// index-3 form meets Φ = 0 at every step but Φ_q q̇ = ν only to its
    /// truncation error; the reported q̇ then meets it to roundoff. HHT's own
    /// state keeps its unprojected q̇, so positions are those of a plain run
    /// and the projected q̇ converges at second order too. One more solve
    /// per step. `--integrator accurate` always projects and refuses it.
    #[arg(long)]
    pub project_velocity: bool,
    /// Parameter sensitivities of a kinematic run, for the params named:
    /// after the other columns, `d(COLUMN)/d(PARAM)` for every coordinate
    /// and result column written (values, `_dot`, `_ddot`) and, with
    /// inertia, every inverse-dynamics column (λ, reactions, efforts),
    /// param by param — derived symbolically, solved with each step's
    /// factorization. Not
    /// with forward dynamics, `--equilibrium` or `--positions-only`.
    #[arg(long, value_name = "P1,P2,…", value_delimiter = ',')]
    pub sensitivity: Vec<String>,
}

/// Forward-dynamics integrators.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Integrator {
    /// HHT-α (α = −0.1) at a fixed step: second order, index-3, Newton on
    /// [q̈; λ] with the symbolic Jacobian.
    Hht,
    /// Error-controlled adaptive steps to `--rtol` (Dormand–Prince 5(4) on
    /// the index-1 form, projected onto the constraints after each step).
    Accurate,
}

/// Evaluation back ends available at run time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// The tapes compiled to native code when the model is loaded
    /// (Cranelift): the default. Falls back to the tape, with a note, where
    /// that is not possible.
    Jit,
    /// The derivation compiled to flat instruction tapes, interpreted: no
    /// code generation. (Generated Rust is the other back end: `kinema
    /// codegen`, or the `mechanism!` macro.)
    Tape,
}

impl Backend {
    /// `jit` when the program has it (its `jit` feature), else `tape`.
    #[cfg(feature = "jit")]
    pub const DEFAULT: Backend = Backend::Jit;
    /// `jit` when the program has it (its `jit` feature), else `tape`.
    #[cfg(not(feature = "jit"))]
    pub const DEFAULT: Backend = Backend::Tape;
}

/// Arguments of `kinema import`.
#[derive(Debug, Args)]
pub struct ImportArgs {
    /// The simEngine2D model file (`.adm`, JSON).
    #[arg(value_name = "MODEL.adm")]
    pub model: PathBuf,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn grammar_is_consistent() {
        Cli::command().debug_assert();
    }
}
