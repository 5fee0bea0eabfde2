//! Parameter sweeps: one mechanism, many parameter sets, on every core.
//!
//! A designer exploring link lengths runs the same mechanism thousands of
//! times with different parameters. [`Sweep`] does that with one
//! derivation (the tapes of a [`Model`](crate::Model) are compiled once and
//! cloned per worker, a generated system is cloned as it is) and one solver
//! per worker thread, reused from row to row: each row sets the parameters,
//! resets the solver (the next step assembles from the initial guess) and
//! hands it to a closure that steps it as it likes.
//!
//! Rows are independent, so the work spreads over a rayon thread pool, and
//! results come back in row order whatever the schedule. For a batch
//! scheduler, [`shard`] splits the row range into contiguous parts: run
//! part i of n on each machine and concatenate the outputs in part order.
//!
//! ```
//! # #[cfg(feature = "model")] {
//! let model = kinema::Model::from_source(
//!     "mechanism Pendulum {
//!         param l = 1.0;
//!         body bar { guess: (0.5, 0.8, 1.0) }
//!         joint pin: revolute(ground(0, 0), bar(-l, 0));
//!         driver swing: bar.phi == 4 * t * t;
//!     }",
//!     "pendulum.kin",
//! )?;
//! let sweep = model.sweep(&["l"])?;
//! let rows = [[0.5], [1.0], [2.0]];
//! // The x of the bar's centre at t = 0.5 for each length.
//! let x = sweep.map(&rows, |_, solver| solver.step(0.5).map(|s| s.q()[0]));
//! for (row, x) in rows.iter().zip(x) {
//!     assert!((x? - row[0] * 1f64.cos()).abs() < 1e-12);
//! }
//! # }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::ops::Range;

use kinema_runtime::{
    Auto, Error, LinalgError, LinearSolverFor, Options, Solver, System, Trajectory,
};
use rayon::prelude::*;

use crate::TapeSystem;

/// Writes one row of parameter values into a system. Closures
/// `Fn(&mut S, &[f64])` are setters; [`crate::Model::sweep`] uses
/// [`TapeParams`].
pub trait SetParams<S>: Sync {
    /// Writes `row` into `system`.
    fn set(&self, system: &mut S, row: &[f64]);
}

impl<S, F: Fn(&mut S, &[f64]) + Sync> SetParams<S> for F {
    fn set(&self, system: &mut S, row: &[f64]) {
        self(system, row);
    }
}

/// The setter of a [`Model`](crate::Model)'s sweep: row value k goes to
/// the parameter at `indices[k]` (declaration order).
#[derive(Debug, Clone)]
pub struct TapeParams {
    pub(crate) indices: Vec<usize>,
}

impl SetParams<TapeSystem> for TapeParams {
    fn set(&self, system: &mut TapeSystem, row: &[f64]) {
        for (&i, &value) in self.indices.iter().zip(row) {
            let set = system.set_param_at(i, value);
            debug_assert!(set.is_ok(), "indices come from the model's parameter names");
        }
    }
}

/// The sweep of a [`Model`](crate::Model): its tapes, parameters set by
/// name.
pub type ModelSweep = Sweep<TapeSystem, TapeParams>;

/// Runs one system over many parameter sets in parallel.
///
/// `S` is the system (cloned once per worker), `F` writes one row of
/// parameter values into it, `L` is the linear solver.
#[derive(Debug, Clone)]
pub struct Sweep<S, F, L = Auto> {
    prototype: S,
    set: F,
    options: Options,
    threads: Option<usize>,
    /// Number of values every row must have, if known.
    width: Option<usize>,
    _lu: std::marker::PhantomData<fn() -> L>,
}

impl<S, F> Sweep<S, F, Auto>
where
    S: System + Clone + Send + Sync,
    F: SetParams<S>,
{
    /// A sweep of `prototype`, each row written into a clone of it by
    /// `set`, solved with [`Options::default`] and the automatic linear
    /// solver, on rayon's global pool (one thread per core unless
    /// `RAYON_NUM_THREADS` says otherwise).
    pub fn new(prototype: S, set: F) -> Self {
        Sweep {
            prototype,
            set,
            options: Options::default(),
            threads: None,
            width: None,
            _lu: std::marker::PhantomData,
        }
    }
}

impl<S, F, L> Sweep<S, F, L>
where
    S: System + Clone + Send + Sync,
    F: SetParams<S>,
    L: LinearSolverFor<S> + Send,
{
    /// The same sweep with other solver options.
    #[must_use]
    pub fn with_options(mut self, options: Options) -> Self {
        self.options = options;
        self
    }

    /// The same sweep on a pool of its own with `threads` threads (1: no
    /// parallelism, for measurements and reproducible timing).
    #[must_use]
    pub fn with_threads(mut self, threads: usize) -> Self {
        self.threads = Some(threads.max(1));
        self
    }

    /// The same sweep with another linear solver (e.g. a generated LU).
    #[must_use]
    pub fn with_linear_solver<M: LinearSolverFor<S> + Send>(self) -> Sweep<S, F, M> {
        Sweep {
            prototype: self.prototype,
            set: self.set,
            options: self.options,
            threads: self.threads,
            width: self.width,
            _lu: std::marker::PhantomData,
        }
    }

    /// The same sweep, requiring every row to hold exactly `width` values
    /// (a row of another length fails with [`LinalgError::Dimension`]
    /// instead of reaching `set`).
    #[must_use]
    pub fn with_row_width(mut self, width: usize) -> Self {
        self.width = Some(width);
        self
    }

    /// The solver options.
    #[must_use]
    pub fn options(&self) -> &Options {
        &self.options
    }

    /// For each row (in parallel): writes the row into the system, resets
    /// the solver and calls `visit(index, solver)`; returns what `visit`
    /// returned, in row order. A failure to build a solver (a system whose
    /// Jacobian pattern the linear solver rejects) is returned for every
    /// row, since no row can run.
    pub fn map<T, R, V>(&self, rows: &[T], visit: V) -> Vec<Result<R, Error>>
    where
        T: AsRef<[f64]> + Sync,
        R: Send,
        V: Fn(usize, &mut Solver<S, L>) -> Result<R, Error> + Sync,
    {
        let work = || {
            rows.par_iter()
                .enumerate()
                .map_init(
                    || Solver::<S, L>::with_options(self.prototype.clone(), self.options),
                    |solver, (index, row)| {
                        let solver = solver.as_mut().map_err(|e| e.clone())?;
                        let row = row.as_ref();
                        match self.width {
                            Some(expected) if row.len() != expected => {
                                return Err(LinalgError::Dimension {
                                    what: "parameter row",
                                    expected,
                                    found: row.len(),
                                }
                                .into());
                            }
                            _ => {}
                        }
                        self.set.set(solver.system_mut(), row);
                        solver.reset();
                        visit(index, solver)
                    },
                )
                .collect()
        };
        match self.threads {
            None => work(),
            Some(threads) => match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
                Ok(pool) => pool.install(work),
                // No thread could be spawned: run on the global pool.
                Err(_) => work(),
            },
        }
    }

    /// The analysis over `times` for every row: one trajectory per row, or
    /// the error that stopped it.
    pub fn run(
        &self,
        rows: &[impl AsRef<[f64]> + Sync],
        times: &[f64],
    ) -> Vec<Result<Trajectory, Error>> {
        self.map(rows, |_, solver| solver.run(times))
    }
}

/// A parameter name a sweep was asked for that the model does not have,
/// or asked for twice.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ParamError {
    /// No parameter of that name.
    #[error("unknown parameter `{name}`; the model's parameters are: {}", known.join(", "))]
    Unknown {
        /// The name asked for.
        name: String,
        /// The model's parameters, in declaration order.
        known: Vec<String>,
    },
    /// The same parameter named twice.
    #[error("parameter `{name}` is named twice")]
    Duplicate {
        /// The repeated name.
        name: String,
    },
}

/// Part `part` (1-based) of `parts` of the rows `0..rows`: contiguous, in
/// order, sizes differing by at most one, so that concatenating the
/// outputs of parts 1, 2, …, n gives the whole sweep's output. `None` unless
/// 1 ≤ part ≤ parts.
#[must_use]
pub fn shard(rows: usize, part: usize, parts: usize) -> Option<Range<usize>> {
    if part == 0 || part > parts {
        return None;
    }
    // (part · rows) / parts without overflow: rows, parts < 2⁶⁴ so the
    // product fits in u128.
    let bound = |k: usize| -> usize {
        let b = (k as u128 * rows as u128) / parts as u128;
        usize::try_from(b).expect("a bound of a shard never exceeds the row count")
    };
    Some(bound(part - 1)..bound(part))
}

#[cfg(test)]
mod tests {
    use super::shard;

    #[test]
    fn shards_cover_the_rows_in_order_without_overlap() {
        for rows in [0, 1, 2, 7, 10, 1000, 1001] {
            for parts in 1..=9 {
                let mut next = 0;
                for part in 1..=parts {
                    let r = shard(rows, part, parts).expect("valid part");
                    assert_eq!(r.start, next, "rows {rows}, part {part}/{parts}");
                    assert!(r.len() <= rows / parts + 1);
                    assert!(r.len() >= rows / parts);
                    next = r.end;
                }
                assert_eq!(next, rows);
            }
        }
        assert_eq!(shard(10, 0, 3), None);
        assert_eq!(shard(10, 4, 3), None);
        assert_eq!(shard(usize::MAX, 2, 2).map(|r| r.end), Some(usize::MAX));
    }
}
