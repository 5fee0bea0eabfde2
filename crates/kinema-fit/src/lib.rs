//! Dimensional synthesis: which params make a mechanism do what it should.
//!
//! A fit takes a model, the params it may change (`vary`, with bounds), and
//! a [`Targets`] table of result columns to meet — a coupler point's path,
//! a rocker's angle — with or without their timing. It minimizes the sum of
//! squared differences (plus, optionally, weighted [`Objective`]s: the RMS
//! or peak of any result column over the cycle) by Levenberg–Marquardt
//! (MINPACK's, the `levenberg-marquardt` crate) with the *exact* Jacobian:
//! the symbolic parameter sensitivities solved with each step's
//! factorization ([`kinema_tape::sensitivity`]) and, for unknown times, the
//! results' own rates. It starts from the model's own design and from a
//! space-filling (Owen-scrambled Sobol) set of designs within the bounds,
//! on every core — a start that does not run through the targets moved
//! towards the model's design until it does ([`Outcome::moved`]) — and
//! keeps only defect-free optima:
//!
//! * **no circuit defect** — the design assembles at every target time,
//!   run by continuation on the branch it assembles on;
//! * **no branch defect** — no singular configuration between the first
//!   and the last target (the solver's monitor);
//! * **no order defect** — with unknown times, the targets are reached in
//!   their rows' order within one cycle;
//! * with `full_turn`, that body turns fully over the cycle without a
//!   singular configuration (checked over the turn, not by a formula).
//!
//! Near-duplicate optima are merged, the rest ranked by cost; rejected
//! starts are counted by reason ([`Outcome::rejections`]).
//!
//! ```
//! use kinema_fit::{Fitter, Spec, Targets};
//! let model = kinema::Model::from_source(
//!     "mechanism Arm {
//!         param l = 1.3;
//!         body bar { guess: (0.5, 0.5, 0.8) }
//!         joint pin: revolute(ground(0, 0), bar(-l / 2, 0));
//!         point bar.tip = (l / 2, 0);
//!         driver swing: bar.phi == t;
//!     }",
//!     "arm.kin",
//! )?;
//! // Where the tip of a bar of length 1 is at three times.
//! let rows: Vec<Vec<f64>> = [0.2f64, 0.6, 1.0]
//!     .iter()
//!     .map(|t| vec![t.cos(), t.sin()])
//!     .collect();
//! let targets = Targets::new(&["bar.tip.x", "bar.tip.y"], &rows, Some(&[0.2, 0.6, 1.0]))?;
//! let spec = Spec::new(&["l"], targets).with_starts(4);
//! let outcome = Fitter::new(&model, spec)?.run()?;
//! let best = &outcome.designs()[0];
//! assert!((best.params()[0].1 - 1.0).abs() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod bounds;
mod eval;
mod kin;
mod plan;
mod start;
mod targets;

use std::fmt;
use std::str::FromStr;

use kinema_tape::Model;
use rayon::prelude::*;

pub use bounds::Bound;
pub use kin::{FittedKinError, fitted_kin};
pub use targets::{TargetError, Targets};

use plan::Plan;

/// How an objective measures a result column over the cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Measure {
    /// The root mean square over the cycle's samples.
    Rms,
    /// The largest magnitude over the cycle's samples (fitted as their
    /// 16-norm, a smooth stand-in; [`Design::objectives`] reports the
    /// true peak).
    Peak,
}

/// A design objective beside the targets: `weight × measure(column)` is
/// added, squared, to the targets' sum of squares — e.g. the RMS of a
/// transmission-angle output's deviation, traded against path accuracy.
/// Written `rms(COLUMN)`, `peak(COLUMN)`, with `*WEIGHT` (default 1).
#[derive(Clone, Debug, PartialEq)]
pub struct Objective {
    /// RMS or peak.
    pub measure: Measure,
    /// A result column (coordinate, point component, output).
    pub column: String,
    /// Its weight (> 0).
    pub weight: f64,
}

impl FromStr for Objective {
    type Err = String;

    fn from_str(s: &str) -> Result<Objective, String> {
        let bad = || {
            format!(
                "`{s}` is not an objective: write rms(COLUMN) or peak(COLUMN), with *WEIGHT to weight it (e.g. rms(crank.phi)*0.1)"
            )
        };
        let (call, weight) = match s.rsplit_once('*') {
            Some((call, w)) => {
                let w = w.trim();
                let weight = w
                    .parse::<f64>()
                    .ok()
                    .filter(|w| w.is_finite() && *w > 0.0)
                    .ok_or_else(|| {
                        format!("the weight of `{s}`, `{w}`, is not a positive number")
                    })?;
                (call.trim(), weight)
            }
            None => (s.trim(), 1.0),
        };
        let (measure, rest) = if let Some(r) = call.strip_prefix("rms(") {
            (Measure::Rms, r)
        } else if let Some(r) = call.strip_prefix("peak(") {
            (Measure::Peak, r)
        } else {
            return Err(bad());
        };
        let column = rest.strip_suffix(')').ok_or_else(bad)?.trim();
        if column.is_empty() {
            return Err(bad());
        }
        Ok(Objective {
            measure,
            column: column.to_owned(),
            weight,
        })
    }
}

impl fmt::Display for Objective {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = match self.measure {
            Measure::Rms => "rms",
            Measure::Peak => "peak",
        };
        write!(f, "{m}({})", self.column)?;
        if self.weight != 1.0 {
            write!(f, "*{}", self.weight)?;
        }
        Ok(())
    }
}

/// What to fit.
#[derive(Clone, Debug)]
pub struct Spec {
    /// The params to vary.
    pub vary: Vec<String>,
    /// Their bounds (params without are free).
    pub bounds: Vec<Bound>,
    /// The targets.
    pub targets: Targets,
    /// The cycle's length: required when the targets have no `t` (their
    /// times are fitted within it); else the last target's time by
    /// default.
    pub t_end: Option<f64>,
    /// A body that must turn fully over the cycle (a crank).
    pub full_turn: Option<String>,
    /// Objectives beside the targets.
    pub objectives: Vec<Objective>,
    /// Starts: the model's design and `starts − 1` space-filling ones.
    pub starts: usize,
    /// The scrambling seed of the space-filling starts.
    pub seed: u32,
    /// Steps per cycle of the runs (the largest step between two targets,
    /// and the objectives' samples).
    pub steps: usize,
    /// Worker threads (0: every core).
    pub threads: usize,
}

impl Spec {
    /// Fits `vary` to `targets`, with 32 starts, 360 steps per cycle and
    /// no bounds, objectives or full turn.
    #[must_use]
    pub fn new(vary: &[&str], targets: Targets) -> Spec {
        Spec {
            vary: vary.iter().map(|s| (*s).to_owned()).collect(),
            bounds: Vec::new(),
            targets,
            t_end: None,
            full_turn: None,
            objectives: Vec::new(),
            starts: 32,
            seed: 0,
            steps: 360,
            threads: 0,
        }
    }

    /// With bounds.
    #[must_use]
    pub fn with_bounds(mut self, bounds: Vec<Bound>) -> Spec {
        self.bounds = bounds;
        self
    }

    /// With `n` starts (at least 1).
    #[must_use]
    pub fn with_starts(mut self, n: usize) -> Spec {
        self.starts = n.max(1);
        self
    }

    /// With the cycle's length.
    #[must_use]
    pub fn with_t_end(mut self, t_end: f64) -> Spec {
        self.t_end = Some(t_end);
        self
    }

    /// With a body that must turn fully over the cycle.
    #[must_use]
    pub fn with_full_turn(mut self, body: &str) -> Spec {
        self.full_turn = Some(body.to_owned());
        self
    }

    /// With objectives.
    #[must_use]
    pub fn with_objectives(mut self, objectives: Vec<Objective>) -> Spec {
        self.objectives = objectives;
        self
    }
}

/// Why a fit cannot be run or found nothing.
#[derive(Debug, thiserror::Error)]
pub enum FitError {
    /// The request does not fit the model (a name, a bound, a column, too
    /// few targets): the message says which.
    #[error("{0}")]
    Usage(String),
    /// A target table that cannot be used.
    #[error(transparent)]
    Targets(#[from] TargetError),
    /// The model cannot be fitted at all (free degrees of freedom, …).
    #[error("{0}")]
    Model(String),
    /// Every start was rejected: the counts by reason, and an example of
    /// each.
    #[error("no defect-free design: {0}")]
    NoDesign(Rejections),
}

/// Why a start's design was not kept.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Reason {
    /// It does not assemble at a target time, or the run from one target
    /// to the next has no solution (a circuit defect).
    Assembly,
    /// While fitted, a design met a singular configuration between (or
    /// at) its targets — or, with `full_turn`, anywhere in the cycle —
    /// from which LM could not step back.
    Singular,
    /// A singular configuration between the first and last targets (a
    /// branch defect).
    Branch,
    /// The targets reached out of order, or over more than one cycle (an
    /// order defect).
    Order,
    /// The `full_turn` body does not turn fully.
    FullTurn,
    /// A value that is not finite.
    NotFinite,
}

impl Reason {
    const ALL: [Reason; 6] = [
        Reason::Assembly,
        Reason::Singular,
        Reason::Branch,
        Reason::Order,
        Reason::FullTurn,
        Reason::NotFinite,
    ];

    /// A short phrase for summaries.
    #[must_use]
    pub fn phrase(self) -> &'static str {
        match self {
            Reason::Assembly => "do not assemble (circuit defect)",
            Reason::Singular => "meet a singular configuration while fitted (branch defect)",
            Reason::Branch => "pass a singular configuration between targets (branch defect)",
            Reason::Order => "reach the targets out of order (order defect)",
            Reason::FullTurn => "do not turn the crank fully",
            Reason::NotFinite => "give values that are not finite",
        }
    }
}

/// A rejected start.
#[derive(Clone, Debug, PartialEq)]
pub struct Rejection {
    /// Which start (0 is the model's design).
    pub start: usize,
    /// Why.
    pub reason: Reason,
    /// What was found.
    pub detail: String,
}

/// The rejected starts, counted by reason.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rejections {
    all: Vec<Rejection>,
}

impl Rejections {
    /// Every rejection, by start.
    #[must_use]
    pub fn all(&self) -> &[Rejection] {
        &self.all
    }

    /// How many were rejected for `reason`.
    #[must_use]
    pub fn count(&self, reason: Reason) -> usize {
        self.all.iter().filter(|r| r.reason == reason).count()
    }
}

impl fmt::Display for Rejections {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.all.is_empty() {
            return f.write_str("no start rejected");
        }
        let mut first = true;
        for reason in Reason::ALL {
            let n = self.count(reason);
            if n == 0 {
                continue;
            }
            if !first {
                f.write_str("; ")?;
            }
            first = false;
            let example = self.all.iter().find(|r| r.reason == reason);
            write!(f, "{n} {}", reason.phrase())?;
            if let Some(e) = example {
                write!(f, " (e.g. start {}: {})", e.start, e.detail)?;
            }
        }
        Ok(())
    }
}

/// A fitted, defect-free design.
#[derive(Clone, Debug, PartialEq)]
pub struct Design {
    params: Vec<(String, f64)>,
    times: Vec<f64>,
    rms: f64,
    max: f64,
    errors: Vec<f64>,
    cost: f64,
    objectives: Vec<(String, f64)>,
    start: usize,
    merged: usize,
    evaluations: usize,
    termination: String,
    /// q at the first time of its runs (`start_t`): its branch.
    start_q: Vec<f64>,
    start_t: f64,
}

/// What a start's fit ended at, for [`Design::new`].
pub(crate) struct Fitted<'a> {
    /// The start's index.
    pub(crate) start: usize,
    pub(crate) params: &'a [f64],
    pub(crate) times: &'a [f64],
    /// The fit's residuals (targets, then objectives).
    pub(crate) residuals: &'a [f64],
    /// Each objective's value over the cycle.
    pub(crate) objective_values: &'a [f64],
    /// q at the first time of its runs.
    pub(crate) start_q: &'a [f64],
    pub(crate) evaluations: usize,
    pub(crate) termination: &'a str,
}

impl Design {
    fn new(plan: &Plan, fitted: &Fitted<'_>) -> Design {
        let Fitted {
            start,
            params,
            times,
            residuals,
            objective_values,
            start_q,
            evaluations,
            termination,
        } = *fitted;
        let n = plan.target_residuals();
        let targets = &residuals[..n];
        let rms = (targets.iter().map(|r| r * r).sum::<f64>() / n.max(1) as f64).sqrt();
        let max = targets.iter().fold(0.0f64, |m, r| m.max(r.abs()));
        let cost = residuals.iter().map(|r| r * r).sum();
        let objectives = plan
            .objectives
            .iter()
            .zip(objective_values)
            .map(|(o, &value)| {
                let label = match o.measure {
                    Measure::Rms => format!("rms({})", o.name),
                    Measure::Peak => format!("peak({})", o.name),
                };
                (label, value)
            })
            .collect();
        Design {
            params: plan
                .vary
                .iter()
                .zip(params)
                .map(|(v, &p)| (v.name.clone(), p))
                .collect(),
            times: times.to_vec(),
            rms,
            max,
            errors: targets.to_vec(),
            cost,
            objectives,
            start,
            merged: 1,
            evaluations,
            termination: termination.to_owned(),
            start_q: start_q.to_vec(),
            start_t: plan.fit_span(times)[0],
        }
    }

    /// The varied params' fitted values, in `vary`'s order.
    #[must_use]
    pub fn params(&self) -> &[(String, f64)] {
        &self.params
    }

    /// The target rows' times: fitted, or the prescribed ones.
    #[must_use]
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// The RMS of the differences from the targets (all rows and columns).
    #[must_use]
    pub fn rms(&self) -> f64 {
        self.rms
    }

    /// The largest difference from a target.
    #[must_use]
    pub fn max_error(&self) -> f64 {
        self.max
    }

    /// The differences achieved − target, row by row in the targets'
    /// column order.
    #[must_use]
    pub fn errors(&self) -> &[f64] {
        &self.errors
    }

    /// The minimized sum of squares (targets and weighted objectives).
    #[must_use]
    pub fn cost(&self) -> f64 {
        self.cost
    }

    /// Each objective's value over the cycle (unweighted), labelled
    /// `rms(column)` / `peak(column)`.
    #[must_use]
    pub fn objectives(&self) -> &[(String, f64)] {
        &self.objectives
    }

    /// The start it came from (0: the model's design).
    #[must_use]
    pub fn start(&self) -> usize {
        self.start
    }

    /// How many starts ended at this design (near-duplicates merged).
    #[must_use]
    pub fn merged(&self) -> usize {
        self.merged
    }

    /// Designs evaluated by its start's fit.
    #[must_use]
    pub fn evaluations(&self) -> usize {
        self.evaluations
    }

    /// Why its fit stopped (MINPACK's termination).
    #[must_use]
    pub fn termination(&self) -> &str {
        &self.termination
    }
}

/// A fit's result: the defect-free designs, best first, and the rejected
/// starts.
#[derive(Clone, Debug)]
pub struct Outcome {
    designs: Vec<Design>,
    rejections: Rejections,
    starts: usize,
    moved: usize,
}

impl Outcome {
    /// The defect-free designs, best (lowest cost) first, near-duplicates
    /// merged. Never empty ([`FitError::NoDesign`] otherwise).
    #[must_use]
    pub fn designs(&self) -> &[Design] {
        &self.designs
    }

    /// The rejected starts.
    #[must_use]
    pub fn rejections(&self) -> &Rejections {
        &self.rejections
    }

    /// How many starts were run.
    #[must_use]
    pub fn starts(&self) -> usize {
        self.starts
    }

    /// How many starts did not run through the targets and were moved
    /// towards the model's design until they did (then fitted from there,
    /// and kept or rejected as any other).
    #[must_use]
    pub fn moved(&self) -> usize {
        self.moved
    }
}

/// A checked fit, ready to run.
#[derive(Debug)]
pub struct Fitter {
    model: Model,
    plan: Plan,
    starts: usize,
    seed: u32,
    threads: usize,
}

impl Fitter {
    /// Checks `spec` against `model`.
    ///
    /// # Errors
    /// [`FitError::Usage`] for a name in `vary` that is not a param, a
    /// bound on a param not varied or excluding the model's value, a
    /// target or objective column that is not a result, a missing cycle
    /// length, an unknown `full_turn` body; [`FitError::Model`] for a model that is not driven (NDOF
    /// ≠ 0).
    pub fn new(model: &Model, spec: Spec) -> Result<Fitter, FitError> {
        let plan = Plan::new(model, &spec)?;
        model
            .solver(kinema_runtime::Options::default())
            .map_err(|e| FitError::Model(format!("the model cannot be run: {e}")))?;
        Ok(Fitter {
            model: model.clone(),
            plan,
            starts: spec.starts.max(1),
            seed: spec.seed,
            threads: spec.threads,
        })
    }

    /// The starting designs: the model's (start 0), then Sobol points
    /// within the bounds (params without bounds: ±50 % of their value, or
    /// ±0.5 if it is 0); unknown times spread evenly over one cycle from a
    /// phase drawn with them.
    fn starts(&self) -> Vec<Vec<f64>> {
        let plan = &self.plan;
        let k = plan.vary.len();
        let rows = plan.targets.rows();
        let times_at = |phase: f64| -> Vec<f64> {
            (0..rows)
                .map(|i| phase + (i as f64 + 0.5) * plan.t_end / rows as f64)
                .collect()
        };
        (0..self.starts)
            .map(|s| {
                let mut x: Vec<f64> = if s == 0 {
                    plan.vary.iter().map(|v| v.value).collect()
                } else {
                    plan.vary
                        .iter()
                        .enumerate()
                        .map(|(j, v)| {
                            let r = f64::from(sobol_burley::sample(
                                (s - 1) as u32,
                                j as u32,
                                self.seed,
                            ));
                            v.range[0] + r * (v.range[1] - v.range[0])
                        })
                        .collect()
                };
                if plan.times_unknown() {
                    let phase = if s == 0 {
                        0.0
                    } else {
                        f64::from(sobol_burley::sample((s - 1) as u32, k as u32, self.seed))
                            * plan.t_end
                    };
                    x.extend(times_at(phase));
                }
                x
            })
            .collect()
    }

    /// Runs every start (on every core, or `threads`), checks each optimum
    /// for defects, merges near-duplicates and ranks the rest.
    ///
    /// # Errors
    /// [`FitError::NoDesign`] when every start was rejected (with the
    /// counts by reason); [`FitError::Model`] when a worker cannot be set
    /// up.
    pub fn run(&self) -> Result<Outcome, FitError> {
        let starts = self.starts();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(self.threads)
            .build()
            .map_err(|e| FitError::Model(format!("cannot start the worker threads: {e}")))?;
        let model = &self.model;
        let plan = &self.plan;
        let results: Vec<Result<(start::StartResult, bool), String>> = pool.install(|| {
            starts
                .par_iter()
                .enumerate()
                .map_init(
                    || eval::Worker::new(model, plan),
                    |worker, (i, x0)| match worker {
                        Ok(w) => Ok(start::fit(w, plan, i, x0)),
                        Err(e) => Err(e.clone()),
                    },
                )
                .collect()
        });
        let mut designs: Vec<Design> = Vec::new();
        let mut rejections = Rejections::default();
        let mut moved = 0;
        for r in results {
            let (result, was_moved) = r.map_err(FitError::Model)?;
            moved += usize::from(was_moved);
            match result {
                Ok(d) => designs.push(d),
                Err(rejection) => rejections.all.push(rejection),
            }
        }
        if designs.is_empty() {
            return Err(FitError::NoDesign(rejections));
        }
        designs.sort_by(|a, b| a.cost.total_cmp(&b.cost).then(a.start.cmp(&b.start)));
        let mut kept: Vec<Design> = Vec::with_capacity(designs.len());
        for d in designs {
            let same = kept.iter_mut().find(|k| {
                k.params
                    .iter()
                    .zip(&d.params)
                    .zip(&plan.vary)
                    .all(|((a, b), v)| (a.1 - b.1).abs() <= 1e-6 * v.scale)
            });
            match same {
                Some(k) => k.merged += 1,
                None => kept.push(d),
            }
        }
        Ok(Outcome {
            designs: kept,
            rejections,
            starts: starts.len(),
            moved,
        })
    }

    /// The target columns over the check span of a design (for plots): the
    /// times, then each column's values, on the cycle's grid refined
    /// `per_step` times, and the target rows' achieved values.
    ///
    /// # Errors
    /// The design does not run (it did when it was fitted).
    pub fn trace(&self, design: &Design, per_step: usize) -> Result<Trace, FitError> {
        let mut plan = self.plan.clone();
        let span = plan.check_span(&design.times);
        // Refined as asked while the whole span stays within a run's
        // bound (the fit's own grid, within it by the plan's check, is
        // never coarsened).
        let cycles = ((span[1] - span[0]) / plan.t_end).max(1.0);
        let most = (0.99 * plan::MAX_RUN_STEPS as f64 / cycles) as usize;
        plan.steps = (plan.steps * per_step.max(1))
            .min(1_000_000)
            .min(most)
            .max(plan.steps);
        plan.objectives.clear();
        let mut solver = self
            .model
            .solver(kinema_runtime::Options::default())
            .map_err(|e| FitError::Model(e.to_string()))?;
        for (v, (_, value)) in plan.vary.iter().zip(&design.params) {
            let _ = solver.system_mut().set_param_at(v.index, *value);
        }
        solver.system_mut().set_guess(Some(&design.start_q));
        let h = plan.t_end / plan.steps as f64;
        let mut times = Vec::new();
        plan::grid(span, h, |t| times.push(t)).map_err(FitError::Usage)?;
        let mut trace = Trace {
            columns: plan.targets.columns.clone(),
            t: Vec::with_capacity(times.len()),
            values: vec![Vec::with_capacity(times.len()); plan.columns.len()],
        };
        let system_outputs =
            |solver: &kinema_tape::ModelSolver, trace: &mut Trace| -> Result<(), FitError> {
                let state = solver
                    .state()
                    .ok_or_else(|| FitError::Model("no state".to_owned()))?;
                let [y, _, _] = kinema_runtime::Outputs::outputs_at(solver.system(), state);
                trace.t.push(state.t());
                for (c, column) in plan.columns.iter().enumerate() {
                    trace.values[c].push(match *column {
                        plan::Column::Coordinate(i) => state.q()[i],
                        plan::Column::Output(i) => y[i],
                    });
                }
                Ok(())
            };
        for (i, &t) in times.iter().enumerate() {
            let stepped = if i == 0 {
                solver.assemble(t).map(|_| ())
            } else {
                eval::step_refined(&mut solver, times[i - 1], t)
            };
            stepped.map_err(|e| FitError::Model(format!("the fitted design at t = {t}: {e}")))?;
            system_outputs(&solver, &mut trace)?;
        }
        Ok(trace)
    }

    /// The model's text `source` with `design`'s param values
    /// ([`fitted_kin`]) — and, when the model's guesses at those values
    /// would assemble it on another configuration than the one fitted (the
    /// fit continued it from elsewhere), its bodies' and coordinates'
    /// guesses written as the fitted configuration, so that the fitted
    /// model runs the motion that was fitted.
    ///
    /// # Errors
    /// As [`fitted_kin`].
    pub fn fitted_kin(&self, source: &str, design: &Design) -> Result<FittedKin, FittedKinError> {
        let same = self.guesses_assemble(design);
        let d = self.model.derivation();
        let q = &design.start_q;
        let value = |name: &str| -> Option<f64> {
            d.coordinates
                .iter()
                .position(|c| c.name == name)
                .and_then(|i| q.get(i).copied())
        };
        let text = kin::write(source, &design.params, (!same).then_some(&value))?;
        Ok(FittedKin {
            text,
            guesses_written: !same,
        })
    }

    /// Whether the model's own guesses, at `design`'s params, assemble the
    /// configuration the design was fitted on (to 1e-9 of the model's
    /// size; angles not taken modulo 2π — an output reading one would
    /// change).
    fn guesses_assemble(&self, design: &Design) -> bool {
        let Ok(mut solver) = self.model.solver(kinema_runtime::Options::default()) else {
            return false;
        };
        for (v, (_, value)) in self.plan.vary.iter().zip(&design.params) {
            let _ = solver.system_mut().set_param_at(v.index, *value);
        }
        let Ok(state) = solver.assemble(design.start_t) else {
            return false;
        };
        let size = design.start_q.iter().fold(1.0f64, |m, q| m.max(q.abs()));
        state
            .q()
            .iter()
            .zip(&design.start_q)
            .all(|(a, b)| (a - b).abs() <= 1e-9 * size)
    }

    /// The model being fitted.
    #[must_use]
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// `(target values, unknowns)` when there are fewer target values than
    /// unknowns: the exact fits, if any, form a family, and each start
    /// ends at one member of it (MINPACK's LM takes such problems).
    #[must_use]
    pub fn underdetermined(&self) -> Option<(usize, usize)> {
        let (m, n) = (self.plan.target_residuals(), self.plan.unknowns());
        (m < n).then_some((m, n))
    }
}

/// A fitted model's text ([`Fitter::fitted_kin`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FittedKin {
    /// The model's text with the fitted values.
    pub text: String,
    /// Whether its guesses were rewritten as the fitted configuration.
    pub guesses_written: bool,
}

/// A fitted design's target columns over time ([`Fitter::trace`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    /// The columns' names (the targets').
    pub columns: Vec<String>,
    /// The times.
    pub t: Vec<f64>,
    /// Per column, its values at those times.
    pub values: Vec<Vec<f64>>,
}
