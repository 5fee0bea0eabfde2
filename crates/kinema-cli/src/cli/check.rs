//! `kinema check MODEL`: validation, the DOF report, assembly at t = 0 from
//! the guess, and the rank of Φ_q there with any redundant equations named.

use std::fmt::Write as _;
use std::path::Path;

use kinema::{Error, Options, Rank, System, diagnose};

use super::load::Loaded;
use super::shared::report::{assembly_warnings, redundancy_report, run_error};
use super::{Failure, print_stdout};

/// Runs `kinema check`.
///
/// # Errors
/// [`Failure::Input`] for a model that does not read or validate;
/// [`Failure::Analysis`] when assembly fails (no convergence, singular Φ_q:
/// the report, with the dependent and redundant equations, is printed first).
pub fn check(path: &Path) -> Result<(), Failure> {
    let loaded = super::load::load_with(path, None, false)?;
    loaded.print_warnings();
    let mut report = header(&loaded);
    if let Some(redundant) = redundancy_report(&loaded) {
        report.push_str(&redundant);
        return print_stdout(&report);
    }
    if loaded.checked().dof().ndof() != 0 {
        // A model with inertia and free degrees of freedom (the checker
        // allows no other): no motion to assemble.
        let _ = write!(
            report,
            "ok: `{}` is valid; with NDOF = {} it has no kinematic motion: `kinema run {} \
             --equilibrium` finds its stable static equilibrium",
            loaded.name(),
            loaded.checked().dof().ndof(),
            loaded.file
        );
        return print_stdout(&report);
    }
    let mut solver = loaded
        .model
        .solver(Options::default())
        .map_err(|e| Failure::analysis(format_args!("cannot set up the solver: {e}")))?;
    let n = solver.dim();

    // Φ_q at the guess, for the record.
    let mut guess = vec![0.0; n];
    solver.system().initial_guess(&mut guess);
    if let Some(rank) = rank_at(solver.system(), &guess, 0.0) {
        let _ = writeln!(report, "  rank of Φ_q at the guess: {}", describe(&rank));
    }

    let assembled = solver
        .assemble(0.0)
        .map(|s| (s.q().to_vec(), *s.stats(), s.kink()));
    match assembled {
        Ok((q, stats, kink)) => {
            for w in assembly_warnings(&loaded, solver.system(), &q) {
                eprintln!("{w}");
            }
            let _ = writeln!(
                report,
                "  assembly at t = 0 from the guess: converged after {} Newton update{}, ‖Φ‖∞ = {:.1e}",
                stats.iterations,
                if stats.iterations == 1 { "" } else { "s" },
                stats.residual
            );
            let rank = rank_at(solver.system(), &q, 0.0);
            let described = rank.map_or_else(
                || format!("{n} of {n} (full: the LU's pivots pass; n is too large for the SVD)"),
                |r| describe(&r),
            );
            let _ = writeln!(
                report,
                "  rank of Φ_q at the assembled configuration: {described}"
            );
            let tolerance = Options::default().singular_tolerance;
            let near = stats.near_singular || rank.is_some_and(|r| r.near_singular(tolerance));
            if !near {
                let _ = writeln!(report, "  redundant equations: none");
                if let Some(kink) = kink {
                    // q̇ and q̈ at the start would be roundoff: a warning,
                    // not "ok".
                    let equation = super::warnings::equation_of(solver.system(), kink);
                    let _ = write!(
                        report,
                        "warning: `{}` assembles with {equation} at a kink of its `{}`; \
                         `kinema run` will flag the rows there",
                        loaded.name(),
                        kink.function
                    );
                    eprintln!(
                        "warning: the assembled configuration (t = 0) puts {equation}'s `{}` \
                         where it is not differentiable, within roundoff: q̇ and q̈ there are \
                         not determined by the model",
                        kink.function
                    );
                    return print_stdout(&report);
                }
                if let Some(state) = solver.state()
                    && let Some(imprecision) = solver.system().imprecision(
                        &mut solver.system().scratch(),
                        state,
                        solver.model_size(),
                        kinema::PrecisionScope::All,
                    )
                {
                    let system = solver.system();
                    let _ = write!(
                        report,
                        "warning: `{}` assembles with equation `{}` not determined by its own \
                         arithmetic; `kinema run` will flag the rows there",
                        loaded.name(),
                        system.equation_name(imprecision.equation),
                    );
                    eprintln!(
                        "warning: at the assembled configuration (t = 0), {}: q, q̇ and q̈ \
                         there are the rounding errors' as much as the model's",
                        super::warnings::imprecision_clause(system, &imprecision)
                    );
                    return print_stdout(&report);
                }
                let _ = write!(
                    report,
                    "ok: `{}` assembles and is ready to run",
                    loaded.name()
                );
                return print_stdout(&report);
            }
            // At or near a singular configuration: a warning, never "ok".
            let mut values = vec![0.0; solver.system().jacobian_pattern().len()];
            solver
                .system()
                .jacobian(&mut solver.system().scratch(), &q, 0.0, &mut values);
            let dependency = diagnose::dependency(solver.system(), &values, tolerance);
            let _ = writeln!(
                report,
                "  dependent equations: {}",
                list(&dependency.equations)
            );
            let _ = write!(
                report,
                "warning: `{}` assembles at or near a singular configuration; `kinema run` \
                 will report it and flag the rows there",
                loaded.name()
            );
            eprintln!(
                "warning: the assembled configuration is at or near a singular configuration \
                 (t = 0): {dependency}"
            );
            print_stdout(&report)
        }
        Err(e) => {
            let _ = writeln!(report, "  assembly at t = 0 from the guess: failed");
            if let Error::Singular { dependency, .. } = &e {
                if let Some(rank) = dependency.rank {
                    let _ = writeln!(report, "  rank of Φ_q where Newton stopped: {rank} of {n}");
                }
                let _ = writeln!(
                    report,
                    "  dependent equations: {}",
                    list(&dependency.equations)
                );
                let _ = writeln!(
                    report,
                    "  redundant equations: {}",
                    list(&dependency.redundant)
                );
            }
            print_stdout(report.trim_end())?;
            Err(Failure::analysis(run_error(&loaded, &e)))
        }
    }
}

/// The first lines of the report: file, mechanism, bodies, DOF.
fn header(loaded: &Loaded) -> String {
    let c = &loaded.checked();
    let bodies: Vec<&str> = c.bodies.iter().map(|b| b.name.as_str()).collect();
    let s = if bodies.len() == 1 { "y" } else { "ies" };
    let mut out = format!(
        "{}: mechanism `{}`, {} bod{s} ({})\n",
        loaded.file,
        c.name,
        bodies.len(),
        abbreviate(&bodies, 8)
    );
    if !c.coords.is_empty() {
        let own: Vec<&str> = c.coords.iter().map(|k| k.name.as_str()).collect();
        let s = if own.len() == 1 { "" } else { "s" };
        let _ = writeln!(
            out,
            "  {} coordinate{s} of {}, after the bodies' in q: {}",
            own.len(),
            if own.len() == 1 {
                "its own"
            } else {
                "their own"
            },
            abbreviate(&own, 8)
        );
    }
    let _ = writeln!(out, "  DOF: {}", c.dof());
    out
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none found".to_string()
    } else {
        names.join(", ")
    }
}

/// `a, b, c, … (n in all)` past `max` names.
pub fn abbreviate(names: &[&str], max: usize) -> String {
    if names.len() <= max {
        names.join(", ")
    } else {
        format!("{}, … ({} in all)", names[..max].join(", "), names.len())
    }
}

/// "r of n (full|rank-deficient; condition number c)".
fn describe(rank: &Rank) -> String {
    let n = rank.dim;
    let verdict = if rank.rank == n {
        "full"
    } else {
        "rank-deficient"
    };
    format!(
        "{} of {n} ({verdict}; condition number {:.1e})",
        rank.rank, rank.condition
    )
}

/// Rank of Φ_q(q, t) under the runtime's rule (equilibrated SVD, see
/// [`diagnose::rank`]); `None` when the diagnosis cannot run (n above
/// [`diagnose::MAX_DENSE_DIAGNOSIS`], a non-finite entry, a failed SVD).
fn rank_at<S: System>(system: &S, q: &[f64], t: f64) -> Option<Rank> {
    let n = system.len();
    let mut values = vec![0.0; system.jacobian_pattern().len()];
    system.jacobian(&mut system.scratch(), q, t, &mut values);
    diagnose::rank(
        n,
        system.jacobian_pattern(),
        &values,
        Options::default().singular_tolerance,
    )
    .ok()
}
