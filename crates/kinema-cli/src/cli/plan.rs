//! `kinema run`'s arguments resolved once into a [`RunPlan`]: the model
//! loaded, what motion to compute ([`Motion`]: kinematics over a grid,
//! forward dynamics, or a static equilibrium) with its options, and where
//! the results go ([`OutputPlan`]).
//!
//! Every refusal of an argument, alone or in combination with others or
//! with the model, is made here, in the order the user meets them: usage
//! errors found from the arguments alone before the model is read, those
//! that depend on the model after. The executors (`run`, `forward`,
//! `equilibrium`) take the plan and never see the arguments; only the
//! errors of creating the output files (first thing an executor does) and
//! of the analysis itself remain theirs.

use std::path::PathBuf;
use std::time::Instant;

use kinema::forward::DynamicsRun;
use kinema::{Format, Options};
use kinema_adm::{Analysis, Simulation};

use super::Failure;
use super::adm;
use super::args::{Backend, Integrator, RunArgs};
use super::load::{Loaded, format_of, load, load_with};
use super::output::{Destination, time};
use super::shared::grid::{DEFAULT_STEPS, DEFAULT_T_END, Grid, MAX_TIMES, check_grid_args};

/// Default step of a `.kin` model's forward dynamics.
pub const DEFAULT_STEP: f64 = 1e-3;
/// Default tolerance of `--integrator accurate`.
pub const DEFAULT_RTOL: f64 = 1e-8;

/// A `kinema run`, resolved and checked: what to compute on which model,
/// and where to write it.
pub struct RunPlan {
    /// The model, read, checked and derived (its warnings printed).
    pub loaded: Loaded,
    /// What to compute.
    pub motion: Motion,
    /// Where the results go.
    pub outputs: OutputPlan,
}

/// What a run computes.
pub enum Motion {
    /// Kinematic analysis (and inverse dynamics for a model with inertia)
    /// over a time grid: NDOF = 0.
    Kinematic(KinematicPlan),
    /// Forward dynamics (or a prescribed motion with redundant rows) of a
    /// model with inertia.
    Forward(ForwardPlan),
    /// The stable static equilibrium at t = 0 (`--equilibrium`).
    Equilibrium,
}

/// A kinematic run.
pub struct KinematicPlan {
    /// The times to solve at.
    pub grid: Grid,
    /// The back end asked for (the summary says which one ran).
    pub backend: Backend,
    /// The solver's options: `--stop-at-singular`, `--positions-only`.
    pub options: Options,
    /// When the command started (the summary's total time includes
    /// reading the model).
    pub start: Instant,
    /// `--sensitivity`: the params' sensitivity systems, compiled (boxed:
    /// the plan stays small without them).
    pub sensitivity: Option<Box<kinema::sensitivity::Sensitivity>>,
}

/// A forward-dynamics run.
pub struct ForwardPlan {
    /// Integrated, or prescribed with redundant rows.
    pub kind: DynamicsRun,
    /// The output times, increasing, from t₀ = `times[0]`.
    pub times: Vec<f64>,
    /// The grid's description for the summary.
    pub description: String,
    /// `--integrator`.
    pub integrator: Integrator,
    /// The step: `--step`, the ACF's `stepSize` or [`DEFAULT_STEP`].
    pub step: f64,
    /// `--rtol` or [`DEFAULT_RTOL`].
    pub rtol: f64,
    /// `--project-velocity`.
    pub project_velocity: bool,
    /// `--energy`: the energy columns.
    pub energy: bool,
}

/// Where a run's results go, and which columns the CSV holds; the files
/// are created by the executor, before its analysis.
pub struct OutputPlan {
    /// The model file (no output may be it).
    pub model: PathBuf,
    /// The analysis file, if any (no output may be it).
    pub acf: Option<PathBuf>,
    /// `--out`.
    pub csv: Destination,
    /// `--columns`, checked against the model when the CSV is created.
    pub columns: Option<String>,
    /// `--positions-only`: no rate columns.
    pub positions_only: bool,
    /// `--plot`.
    pub plot: Option<PathBuf>,
    /// `--animate`.
    pub animate: Option<PathBuf>,
}

impl OutputPlan {
    fn of(args: &RunArgs) -> OutputPlan {
        OutputPlan {
            model: args.model.clone(),
            acf: args.acf.clone(),
            csv: Destination::of(&args.out),
            columns: args.columns.clone(),
            positions_only: args.positions_only,
            plot: args.plot.clone(),
            animate: args.animate.clone(),
        }
    }
}

impl RunPlan {
    /// Resolves `kinema run`'s arguments: checks them, reads the model
    /// (printing its warnings) and decides what to compute.
    ///
    /// # Errors
    /// [`Failure::Input`] for bad arguments, a combination of options the
    /// model's run does not take, or a model that cannot be read.
    pub fn resolve(args: &RunArgs) -> Result<RunPlan, Failure> {
        refuse_positions_only(args, false)?;
        refuse_sensitivity(args, None)?;
        let outputs = OutputPlan::of(args);
        if args.equilibrium {
            let loaded = equilibrium_model(args)?;
            return Ok(RunPlan {
                loaded,
                motion: Motion::Equilibrium,
                outputs,
            });
        }
        let start = Instant::now();
        let steps = check_grid_args(args.t_end, args.steps)?;
        let (grid, analysis) = match format_of(&args.model)? {
            Format::Kin => (kin_grid(args, steps)?, None),
            Format::Adm => {
                let analysis = adm_analysis(args, steps)?;
                if analysis.simulation == Simulation::Dynamics {
                    if !args.sensitivity.is_empty() {
                        return Err(Failure::usage(
                            "--sensitivity cannot be used with a Dynamics analysis: \
                             sensitivities are computed for kinematic runs only",
                        ));
                    }
                    return adm_dynamics(args, &analysis, outputs);
                }
                let source = || analysis_source(args, &analysis);
                (Grid::simengine(&analysis, &source)?, Some(analysis))
            }
        };
        let mut loaded = load(&args.model, analysis.as_ref())?;
        loaded.model.set_backend(match args.backend {
            Backend::Jit => kinema::Backend::Jit,
            Backend::Tape => kinema::Backend::Tape,
        });
        loaded.print_warnings();
        if let Some(kind) = dynamics_run(&loaded) {
            refuse_positions_only(args, true)?;
            refuse_sensitivity(args, Some(&loaded))?;
            let forward = ForwardPlan::of(args, kind, grid.times, grid.description, None)?;
            return Ok(RunPlan {
                loaded,
                motion: Motion::Forward(forward),
                outputs,
            });
        }
        refuse_forward_options(args)?;
        refuse_free_dof(&loaded)?;
        let options = Options::default()
            .with_stop_at_singular(args.stop_at_singular)
            .with_positions_only(args.positions_only);
        let sensitivity = sensitivity(args, &loaded)?;
        Ok(RunPlan {
            loaded,
            motion: Motion::Kinematic(KinematicPlan {
                grid,
                backend: args.backend,
                options,
                start,
                sensitivity,
            }),
            outputs,
        })
    }
}

impl ForwardPlan {
    /// The forward run of `kind` to the output `times`: the integrator's
    /// options checked against each other; the step `--step`, or the
    /// ACF's (`acf_step`), or [`DEFAULT_STEP`].
    fn of(
        args: &RunArgs,
        kind: DynamicsRun,
        times: Vec<f64>,
        description: String,
        acf_step: Option<f64>,
    ) -> Result<ForwardPlan, Failure> {
        let rtol = args.rtol.unwrap_or(DEFAULT_RTOL);
        match args.integrator {
            Integrator::Hht if args.rtol.is_some() => {
                return Err(Failure::usage(
                    "--rtol is the tolerance of --integrator accurate; HHT takes --step",
                ));
            }
            Integrator::Accurate if args.project_velocity => {
                return Err(Failure::usage(
                    "--project-velocity is for --integrator hht: the accurate mode projects \
                     positions and velocities after every step already",
                ));
            }
            Integrator::Accurate if args.step.is_some() => {
                return Err(Failure::usage(
                    "--step is HHT's; --integrator accurate chooses its steps to meet --rtol",
                ));
            }
            Integrator::Accurate if !(rtol > 1e-14 && rtol < 1.0) => {
                return Err(Failure::usage(format_args!(
                    "--rtol must be in (1e-14, 1), not {rtol}"
                )));
            }
            _ => {}
        }
        if args.stop_at_singular {
            return Err(Failure::usage(
                "--stop-at-singular is for kinematic runs: forward dynamics stops at a step that \
                 fails",
            ));
        }
        let step = args.step.or(acf_step).unwrap_or(DEFAULT_STEP);
        if !(step.is_finite() && step > 0.0) {
            return Err(Failure::usage(format_args!(
                "the step must be positive and finite, not {step}"
            )));
        }
        Ok(ForwardPlan {
            kind,
            times,
            description,
            integrator: args.integrator,
            step,
            rtol,
            project_velocity: args.project_velocity,
            energy: args.energy,
        })
    }
}

/// How `loaded` runs when it has inertia and is not the kinematic case
/// ([`kinema::forward::dynamics_run`] at the model's own params and start):
/// `None` for a kinematic run.
fn dynamics_run(loaded: &Loaded) -> Option<DynamicsRun> {
    let d = loaded.model.derivation();
    kinema::forward::dynamics_run(d, &d.param_values(), &loaded.model.initial_configuration())
}

/// `--sensitivity` where there is none yet: with `--equilibrium`, with
/// `--positions-only` (no rates, no factorization at each row), and with
/// forward dynamics (`loaded`, the model of a forward run).
fn refuse_sensitivity(args: &RunArgs, forward: Option<&Loaded>) -> Result<(), Failure> {
    if args.sensitivity.is_empty() {
        return Ok(());
    }
    let why = if let Some(loaded) = forward {
        format!(
            "`{}` runs forward dynamics: sensitivities are computed for kinematic runs only \
             (NDOF = 0)",
            loaded.file
        )
    } else if args.equilibrium {
        "--equilibrium: sensitivities are computed for kinematic runs only".to_owned()
    } else if args.positions_only {
        "--positions-only: the sensitivities' rate columns need the rates' solves; run \
         without --positions-only"
            .to_owned()
    } else {
        return Ok(());
    };
    Err(Failure::usage(format_args!(
        "--sensitivity cannot be used with {why}"
    )))
}

/// `--sensitivity`'s params' sensitivity systems, derived and compiled;
/// none without the option.
///
/// # Errors
/// A usage error naming the model's params for a name that is not one (or
/// one named twice), or derivatives too large.
fn sensitivity(
    args: &RunArgs,
    loaded: &Loaded,
) -> Result<Option<Box<kinema::sensitivity::Sensitivity>>, Failure> {
    if args.sensitivity.is_empty() {
        return Ok(None);
    }
    let names: Vec<&str> = args.sensitivity.iter().map(|s| s.trim()).collect();
    loaded
        .model
        .sensitivity(&names)
        .map(|s| Some(Box::new(s)))
        .map_err(|e| Failure::usage(format_args!("--sensitivity: {e}")))
}

/// `--positions-only` where it makes no sense: with `--equilibrium` (one
/// static state, whose rates are zero anyway), `--plot` (which draws
/// velocities and accelerations), and forward dynamics (`dynamics`: its
/// positions come from integrating the accelerations).
fn refuse_positions_only(args: &RunArgs, dynamics: bool) -> Result<(), Failure> {
    if !args.positions_only {
        return Ok(());
    }
    let conflict = if dynamics {
        "forward dynamics: its positions are integrated from the accelerations, which it must solve"
    } else if args.equilibrium {
        "--equilibrium: a static equilibrium is one state, its rates zero"
    } else if args.plot.is_some() {
        "--plot: the figure draws velocities and accelerations (--animate needs positions only)"
    } else {
        return Ok(());
    };
    Err(Failure::usage(format_args!(
        "--positions-only cannot be used with {conflict}"
    )))
}

/// The model of `--equilibrium`: the options that describe a motion
/// refused first, then the model read; it must have dynamics.
fn equilibrium_model(args: &RunArgs) -> Result<Loaded, Failure> {
    refuse_motion_options(args)?;
    let loaded = load_with(&args.model, None, false)?;
    loaded.print_warnings();
    if loaded.model.derivation().dynamics.is_none() {
        return Err(Failure::usage(format_args!(
            "`{}` has no inertia, gravity or forces: --equilibrium needs a model with dynamics \
             (`mass`, `inertia`, `gravity`, `force`)",
            loaded.file
        )));
    }
    Ok(loaded)
}

/// Rule: `--equilibrium` is one configuration; options that describe a
/// motion are refused.
fn refuse_motion_options(args: &RunArgs) -> Result<(), Failure> {
    for (given, option) in [
        (args.t_end.is_some(), "--t-end"),
        (args.steps.is_some(), "--steps"),
        (args.plot.is_some(), "--plot"),
        (args.animate.is_some(), "--animate"),
        (args.stop_at_singular, "--stop-at-singular"),
    ] {
        if given {
            return Err(Failure::usage(format_args!(
                "{option} describes a motion; --equilibrium computes one configuration at t = 0"
            )));
        }
    }
    Ok(())
}

/// Refuses the forward-dynamics options in a kinematic run.
///
/// # Errors
/// [`Failure::Input`] naming the option.
fn refuse_forward_options(args: &RunArgs) -> Result<(), Failure> {
    if args.rtol.is_some()
        || args.integrator != Integrator::Hht
        || args.energy
        || args.project_velocity
    {
        return Err(Failure::usage(
            "--integrator, --rtol, --project-velocity and --energy are for forward dynamics (a \
             model with inertia and NDOF > 0, or a Dynamics ACF)",
        ));
    }
    if args.step.is_some() {
        return Err(Failure::usage(
            "--step is for forward dynamics (a model with inertia and NDOF > 0, or a Dynamics ACF); \
             a kinematic run takes --t-end and --steps",
        ));
    }
    Ok(())
}

/// Rule: kinematic analysis (and inverse dynamics) needs NDOF = 0; a model
/// with inertia and free degrees of freedom has an equilibrium only.
///
/// # Errors
/// [`Failure::Input`] naming the NDOF and `--equilibrium`.
fn refuse_free_dof(loaded: &Loaded) -> Result<(), Failure> {
    let dof = loaded.checked().dof();
    if dof.ndof() == 0 {
        return Ok(());
    }
    Err(Failure::usage(format_args!(
        "mechanism `{}` has NDOF = {} ({dof}): a kinematic motion needs NDOF = 0 (forward \
         dynamics needs inertia: `mass` and `inertia` on every body)\n  = help: `kinema run {} \
         --equilibrium` finds the stable static equilibrium of a model with inertia",
        loaded.checked().name,
        dof.ndof(),
        loaded.file
    )))
}

/// The grid of a `.kin` model: `--t-end` and `--steps` (no ACF).
fn kin_grid(args: &RunArgs, steps: Option<usize>) -> Result<Grid, Failure> {
    if args.acf.is_some() {
        return Err(Failure::usage(
            "--acf is for simEngine2D models (.adm); a .kin model takes --t-end and --steps",
        ));
    }
    Grid::uniform(
        args.t_end.unwrap_or(DEFAULT_T_END),
        steps.unwrap_or(DEFAULT_STEPS),
    )
}

/// The analysis of an `.adm` model: its ACF (or the default), with
/// `--t-end` and `--steps` overriding `tend` and `outputSteps`, checked.
fn adm_analysis(args: &RunArgs, steps: Option<usize>) -> Result<Analysis, Failure> {
    let mut analysis = adm::read_analysis(args.acf.as_deref())?;
    if let Some(t) = args.t_end {
        analysis.tend = t;
    }
    if let Some(n) = steps {
        analysis.output_steps = n;
    }
    check_analysis_size(&analysis)?;
    if let Err(e) = analysis.check_times() {
        return Err(Failure::usage(format_args!(
            "{}: {e}",
            analysis_source(args, &analysis)
        )));
    }
    Ok(analysis)
}

/// A simEngine2D Dynamics analysis: forward dynamics at the ACF's
/// `stepSize`, output every `outputSteps`.
fn adm_dynamics(
    args: &RunArgs,
    analysis: &Analysis,
    outputs: OutputPlan,
) -> Result<RunPlan, Failure> {
    refuse_positions_only(args, true)?;
    let loaded = load_with(&args.model, None, false)?;
    loaded.print_warnings();
    if loaded.model.derivation().dynamics.is_none() {
        return Err(Failure::usage(format_args!(
            "`{}` cannot run a Dynamics analysis: it has no inertia (every body needs `mass` and \
             `jbar`)",
            loaded.file
        )));
    }
    let description = format!(
        "{} outputs from t = 0 to {} (outputSteps {}, stepSize {})",
        analysis.output_steps + 1,
        time(analysis.tend),
        analysis.output_steps,
        analysis.step_size
    );
    let kind = dynamics_run(&loaded).unwrap_or(DynamicsRun::Forward);
    let times = analysis.output_times();
    let forward = ForwardPlan::of(args, kind, times, description, Some(analysis.step_size))?;
    Ok(RunPlan {
        loaded,
        motion: Motion::Forward(forward),
        outputs,
    })
}

/// Where a simEngine2D analysis's `tend` and `outputSteps` came from, for
/// messages: `--t-end 5e-324 with outputSteps 500 of kinematics.acf`.
fn analysis_source(args: &RunArgs, analysis: &Analysis) -> String {
    let acf = args.acf.as_ref().map_or_else(
        || "the default kinematics.acf".to_string(),
        |p| format!("`{}`", p.display()),
    );
    let tend = match args.t_end {
        Some(t) => format!("--t-end {t:e}"),
        None => format!("tend {:e} of {acf}", analysis.tend),
    };
    let steps = match args.steps {
        Some(n) => format!("--steps {n}"),
        None => format!("outputSteps {} of {acf}", analysis.output_steps),
    };
    format!("{tend} with {steps} (stepSize {:e})", analysis.step_size)
}

/// Refuses a simEngine2D analysis with more solve times than [`MAX_TIMES`].
fn check_analysis_size(analysis: &Analysis) -> Result<(), Failure> {
    let solves = analysis.tend / analysis.step_size + analysis.output_steps as f64;
    if solves.is_finite() && solves < MAX_TIMES as f64 {
        Ok(())
    } else {
        Err(Failure::usage(format_args!(
            "the analysis asks for about {solves:.3e} solves (tend {} / stepSize {} + outputSteps {}); \
             one run takes fewer than {MAX_TIMES}",
            analysis.tend, analysis.step_size, analysis.output_steps
        )))
    }
}

#[cfg(test)]
mod tests;
