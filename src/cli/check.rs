//! `kinema check MODEL`: validation, the DOF report, assembly at t = 0 from
//! the guess, and the rank of Φ_q there with any redundant equations named.

use std::fmt::Write as _;
use std::path::Path;

use kinema::{Auto, Error, Options, Solver, System, TapeSystem};
use nalgebra::DMatrix;

use super::load::{Loaded, load};
use super::{Failure, print_stdout};

/// Largest n for which the dense SVD of Φ_q is computed (a few hundred
/// milliseconds there); larger systems report the LU's verdict only.
const MAX_SVD: usize = 600;

/// Relative singular-value cut-off of the numerical rank.
const RANK_TOLERANCE: f64 = 1e-10;

/// Runs `kinema check`.
///
/// # Errors
/// [`Failure::Input`] for a model that does not read or validate;
/// [`Failure::Analysis`] when assembly fails (no convergence, singular Φ_q:
/// the report, with the dependent and redundant equations, is printed first).
pub fn check(path: &Path) -> Result<(), Failure> {
    let loaded = load(path, None)?;
    loaded.print_warnings();
    let mut report = header(&loaded);
    let mut solver =
        Solver::<TapeSystem, Auto>::with_options(loaded.model.system(), Options::default())
            .map_err(|e| Failure::analysis(format_args!("cannot set up the solver: {e}")))?;
    let n = solver.dim();

    // Φ_q at the guess, for the record.
    let mut guess = vec![0.0; n];
    solver.system().initial_guess(&mut guess);
    if let Some(rank) = rank_at(solver.system_mut(), &guess, 0.0) {
        let _ = writeln!(report, "  rank of Φ_q at the guess: {}", rank.describe(n));
    }

    let assembled = solver.assemble(0.0).map(|s| (s.q().to_vec(), *s.stats()));
    match assembled {
        Ok((q, stats)) => {
            let _ = writeln!(
                report,
                "  assembly at t = 0 from the guess: converged after {} Newton update{}, ‖Φ‖∞ = {:.1e}",
                stats.iterations,
                if stats.iterations == 1 { "" } else { "s" },
                stats.residual
            );
            let rank = rank_at(solver.system_mut(), &q, 0.0);
            let described = rank.map_or_else(
                || format!("{n} of {n} (full: the LU's pivots pass; n is too large for the SVD)"),
                |r| r.describe(n),
            );
            let _ = writeln!(
                report,
                "  rank of Φ_q at the assembled configuration: {described}"
            );
            let _ = writeln!(report, "  redundant equations: none");
            let _ = write!(
                report,
                "ok: `{}` assembles and is ready to run",
                loaded.name()
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
    let c = &loaded.checked;
    let bodies: Vec<&str> = c.bodies.iter().map(|b| b.name.as_str()).collect();
    let s = if bodies.len() == 1 { "y" } else { "ies" };
    let mut out = format!(
        "{}: mechanism `{}`, {} bod{s} ({})\n",
        loaded.file,
        c.name,
        bodies.len(),
        abbreviate(&bodies, 8)
    );
    let _ = writeln!(out, "  DOF: {}", c.dof());
    out
}

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

/// Numerical rank and condition number of a square Φ_q.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rank {
    rank: usize,
    condition: f64,
}

impl Rank {
    fn describe(self, n: usize) -> String {
        let verdict = if self.rank == n {
            "full"
        } else {
            "rank-deficient"
        };
        format!(
            "{} of {n} ({verdict}; condition number {:.1e})",
            self.rank, self.condition
        )
    }
}

/// Rank of Φ_q(q, t) by SVD: singular values above 1e-10 σ_max; `None`
/// when n is above [`MAX_SVD`] or Φ_q is not finite.
fn rank_at<S: System>(system: &mut S, q: &[f64], t: f64) -> Option<Rank> {
    let n = system.len();
    if n == 0 || n > MAX_SVD {
        return None;
    }
    let mut values = vec![0.0; system.jacobian_pattern().len()];
    system.jacobian(q, t, &mut values);
    if values.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let mut a = DMatrix::<f64>::zeros(n, n);
    for (&(r, c), &v) in system.jacobian_pattern().iter().zip(&values) {
        if let Some(slot) = a.get_mut((r as usize, c as usize)) {
            *slot = v;
        }
    }
    let sigma = a.singular_values();
    let max = sigma.max();
    let min = sigma.min();
    let rank = sigma.iter().filter(|&&s| s > RANK_TOLERANCE * max).count();
    Some(Rank {
        rank,
        condition: if min > 0.0 { max / min } else { f64::INFINITY },
    })
}
