//! Messages more than one subcommand gives: a run-time error with the ADM
//! constraints behind it, warnings about an assembly far from the guess,
//! and the report on a model with inertia whose equations are redundant.

use std::fmt::Write as _;

use kinema::integrate::Monitor;
use kinema::{Error, ForwardSystem, System, TapeSystem};

use crate::cli::load::Loaded;

/// A run-time error as a message: the runtime's sentence, and for an ADM
/// model the ADM constraints behind the equations it names.
pub fn run_error(loaded: &Loaded, e: &Error) -> String {
    let mut message = e.to_string();
    if let Some(adm) = &loaded.adm {
        let names: Vec<&str> = match e {
            Error::Singular { dependency, .. } => {
                dependency.equations.iter().map(String::as_str).collect()
            }
            Error::NoConvergence { worst_equation, .. } => vec![worst_equation.as_str()],
            Error::NonFinite { name, .. } => vec![name.split(" / ").next().unwrap_or(name)],
            _ => Vec::new(),
        };
        message.push_str(&adm.explain(&names));
    }
    message
}

/// Warnings about an assembly that converged far from the guess: an angle
/// that moved by more than half a turn usually means another assembly
/// mode (or the mirror image) of the mechanism meant.
pub fn assembly_warnings(loaded: &Loaded, system: &TapeSystem, q: &[f64]) -> Vec<String> {
    let mut guess = vec![0.0; q.len()];
    system.initial_guess(&mut guess);
    let names = &loaded.model.derivation().coordinates;
    let mut out = Vec::new();
    for ((c, &g), &x) in names.iter().zip(&guess).zip(q) {
        let moved = (x - g).abs();
        if c.name.ends_with(".phi") && moved > std::f64::consts::PI {
            out.push(format!(
                "warning: assembly at t = 0 moved `{}` from its guess {g} to {x} (by {moved:.3} rad, \
                 more than half a turn): the configuration found may be another assembly mode or \
                 the mirror image of the one meant; give a guess closer to it",
                c.name
            ));
        }
    }
    out
}

/// `kinema check`'s report on a model with inertia whose equations are
/// redundant at its assembled configuration (with what `kinema run` does
/// with it), or `None` for any other model.
pub fn redundancy_report(loaded: &Loaded) -> Option<String> {
    loaded.model.derivation().dynamics.as_ref()?;
    let dof = loaded.checked().dof();
    if dof.ndof() > 0 || (dof.ndof() == 0 && dof.driving > 0) {
        return None;
    }
    let mut fwd = loaded.model.forward_system()?;
    let mut q = loaded.model.initial_configuration();
    let assembled = kinema::integrate::assemble(&mut fwd, &mut q, 0.0);
    let monitor = Monitor::new(&mut fwd, &q, 0.0, 0.0);
    let (rank, redundancy) = match (assembled, monitor.rank(), monitor.redundancy()) {
        (Ok(()), Some(rank), Some(redundancy)) => (rank, redundancy),
        _ => return None,
    };
    let free = q.len() - rank;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "  assembly at t = 0 from the guess: converged (minimum-norm Newton steps); rank of Φ_q \
         there {rank} of {} rows",
        fwd.rows()
    );
    let _ = writeln!(
        out,
        "  redundant equations: {}",
        redundancy.redundant.join(", ")
    );
    let _ = write!(
        out,
        "ok: `{}` is valid; its {} equations hold {} independent ones, leaving {free} degree{} of \
         freedom: `kinema run` {}",
        loaded.name(),
        fwd.rows(),
        rank,
        if free == 1 { "" } else { "s" },
        if free > 0 {
            "integrates its forward dynamics"
        } else {
            "solves its prescribed motion and inverse dynamics (minimum-norm multipliers)"
        }
    );
    Some(out)
}
