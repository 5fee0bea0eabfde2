//! `kinema run MODEL --equilibrium`: the stable static equilibrium of a
//! model with inertia at t = 0 (see `kinema::equilibrium`), written as one
//! CSV row with the columns of a dynamics run (q̇ = q̈ = 0), its stability
//! in the summary.

use std::fmt::Write as _;

use kinema::equilibrium::{Equilibrium, Stability};

use super::args::RunArgs;
use super::files::RunFiles;
use super::load::{Loaded, load_with};
use super::output::Destination;
use super::{Failure, print_stderr, print_stdout};

/// Rule: kinematic analysis (and inverse dynamics) needs NDOF = 0; a model
/// with inertia and free degrees of freedom has an equilibrium only.
///
/// # Errors
/// [`Failure::Input`] naming the NDOF and `--equilibrium`.
pub fn refuse_free_dof(loaded: &Loaded) -> Result<(), Failure> {
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

/// Runs `kinema run --equilibrium`.
///
/// # Errors
/// Usage errors (options that describe a motion, a model without
/// dynamics), model errors, and [`Failure::Analysis`] when no equilibrium
/// is found.
pub fn run(args: &RunArgs) -> Result<(), Failure> {
    refuse_motion_options(args)?;
    let loaded = load_with(&args.model, None, false)?;
    loaded.print_warnings();
    let d = loaded.model.derivation();
    if d.dynamics.is_none() {
        return Err(Failure::usage(format_args!(
            "`{}` has no inertia, gravity or forces: --equilibrium needs a model with dynamics \
             (`mass`, `inertia`, `gravity`, `force`)",
            loaded.file
        )));
    }
    let system = loaded.model.system();
    let dynamics = system.dynamics_column_names(d.rows.len(), loaded.adm.is_some());
    let mut sink = RunFiles::create(args, d, &dynamics)?.csv;

    let eq = loaded
        .model
        .equilibrium(0.0)
        .map_err(|e| Failure::analysis(format_args!("error: no equilibrium: {e}")))?;
    // Named points and measures at rest, λ, reactions and efforts.
    let zeros = vec![0.0; d.nc()];
    let mut row = kinema::dynamics::DynamicsRow::new(&system, d.rows.len());
    let at = kinema::Motion {
        t: eq.t,
        q: &eq.q,
        qd: &zeros,
        qdd: &zeros,
    };
    row.fill(&system, at, &eq.lambda)
        .map_err(|e| Failure::analysis(format_args!("the reactions at the equilibrium: {e}")))?;
    let [y, yd, ydd] = row.outputs();
    sink.write_values(eq.t, [&eq.q, &zeros, &zeros], [y, yd, ydd], row.dynamics())?;
    let destination = sink.destination().clone();
    sink.finish()?;

    if eq.stability != Stability::Stable {
        print_stderr(&format!(
            "warning: the equilibrium found is {}: a small disturbance moves the mechanism away",
            eq.stability
        ));
    }
    let summary = summary(&loaded, &eq, &destination);
    if destination == Destination::Stdout {
        print_stderr(&summary);
        Ok(())
    } else {
        print_stdout(&summary)
    }
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

/// The summary: descent steps, stability with the reduced Hessian's
/// eigenvalues, residuals, where the row went.
fn summary(loaded: &Loaded, eq: &Equilibrium, destination: &Destination) -> String {
    let mut summary = format!(
        "{} ({}): equilibrium at t = 0 after {} descent step{}\n",
        loaded.checked().name,
        loaded.file,
        eq.iterations,
        if eq.iterations == 1 { "" } else { "s" }
    );
    let _ = writeln!(
        summary,
        "  stability: {} (reduced Hessian eigenvalues {})",
        eq.stability,
        if eq.eigenvalues.is_empty() {
            "none: NDOF = 0".to_owned()
        } else {
            eq.eigenvalues
                .iter()
                .map(|v| format!("{v:.6e}"))
                .collect::<Vec<_>>()
                .join(", ")
        }
    );
    let _ = writeln!(
        summary,
        "  ‖Φ‖∞ = {:.1e}, reduced gradient ‖Nᵀ Q_A‖∞ = {:.1e}",
        eq.residual, eq.gradient
    );
    let _ = write!(
        summary,
        "  wrote {}",
        match destination {
            Destination::Stdout => "standard output (1 row)".to_owned(),
            Destination::File(p) => format!("`{}` (1 row)", p.display()),
        }
    );
    summary
}
