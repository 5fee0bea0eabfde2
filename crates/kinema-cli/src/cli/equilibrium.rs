//! `kinema run MODEL --equilibrium`: the stable static equilibrium of a
//! model with inertia at t = 0 (see `kinema::equilibrium`), written as one
//! CSV row with the columns of a dynamics run (q̇ = q̈ = 0), its stability
//! in the summary.

use std::fmt::Write as _;

use kinema::equilibrium::{Equilibrium, Stability};

use super::files::RunFiles;
use super::load::Loaded;
use super::output::Destination;
use super::plan::OutputPlan;
use super::{Failure, print_stderr, print_stdout};

/// Runs `kinema run --equilibrium` on `loaded` (a model with dynamics:
/// see [`super::plan`]).
///
/// # Errors
/// [`Failure::Input`] for an output that cannot be created or a bad
/// `--columns`; [`Failure::Analysis`] when no equilibrium is found.
pub fn run(loaded: &Loaded, outputs: &OutputPlan) -> Result<(), Failure> {
    let d = loaded.model.derivation();
    let system = loaded.model.system();
    let dynamics = system.dynamics_column_names(d.rows.len(), loaded.adm.is_some());
    let mut sink = RunFiles::create(outputs, d, &dynamics)?.csv;

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
    let summary = summary(loaded, &eq, &destination);
    if destination == Destination::Stdout {
        print_stderr(&summary);
        Ok(())
    } else {
        print_stdout(&summary)
    }
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
