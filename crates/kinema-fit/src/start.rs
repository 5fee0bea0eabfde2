//! One start: Levenberg–Marquardt from a starting design to a local
//! optimum, then the optimum's defect checks.

use std::f64::consts::TAU;

use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use lm_nalgebra::{DMatrix, DVector, Dyn, Owned};

use crate::bounds::Map;
use crate::eval::{Failure, Worker};
use crate::plan::Plan;
use crate::{Design, Fitted, Reason, Rejection};

/// A start's outcome: a design that passed the checks, or why not.
pub(crate) type StartResult = Result<Design, Rejection>;

/// The problem MINPACK's LM sees: internal unknowns u (bounded ones through
/// their [`Map`]), residuals and Jacobian from the worker.
struct Problem<'a> {
    worker: &'a mut Worker,
    plan: &'a Plan,
    maps: Vec<Map>,
    u: DVector<f64>,
    /// The outer values of u: params, then (unknown times) the first time
    /// and the gaps between consecutive ones.
    x: Vec<f64>,
    /// The target times those give (their running sums).
    times: Vec<f64>,
    /// The last evaluation's failure, if it failed.
    failed: Option<Failure>,
    /// The residuals of the last design that evaluated: a failed trial
    /// design is answered with ten times these, so LM shrinks its step
    /// (a failed evaluation must not end the fit).
    last_good: Option<Vec<f64>>,
    /// The varied params of the design LM last accepted (its Jacobian was
    /// asked for) and its q at the run's first time: later designs
    /// assemble on its branch.
    accepted: std::cell::RefCell<(Vec<f64>, Vec<f64>)>,
    evaluations: usize,
    /// Whether a singular configuration where the check looks fails a
    /// design ([`fit`]).
    walls: bool,
}

impl Problem<'_> {
    fn evaluate(&mut self) {
        for (x, (u, map)) in self.x.iter_mut().zip(self.u.iter().zip(&self.maps)) {
            *x = map.outer(*u);
        }
        let k = self.plan.vary.len();
        let (params, gaps) = self.x.split_at(k);
        let times = if self.plan.times_unknown() {
            running_sums(gaps, &mut self.times);
            &self.times[..]
        } else {
            self.plan.targets.times().unwrap_or(&[])
        };
        // Unknown times: within [−t_end, 3 t_end], and the targets visited
        // within one cycle (as the check asks).
        let cycle = self.plan.t_end;
        let span_of_visits =
            times.last().copied().unwrap_or(0.0) - times.first().copied().unwrap_or(0.0);
        let wild = self.plan.times_unknown()
            && (times.iter().any(|&t| !(-cycle..=3.0 * cycle).contains(&t))
                || (self.walls && span_of_visits > cycle * (1.0 + 1e-9)));
        if wild {
            self.failed = Some(Failure::NotFinite { t: times[0] });
            return;
        }
        let span = self.plan.fit_span(times);
        // Assembly from the accepted design's start keeps its branch.
        {
            let (p0, q0) = &*self.accepted.borrow();
            self.worker.start_at(p0, q0);
        }
        self.evaluations += 1;
        let window = self.walls.then(|| self.plan.singular_window(times, span));
        match self
            .worker
            .evaluate(self.plan, params, times, span, true, window)
        {
            Ok(()) => {
                self.failed = None;
                let good = self.last_good.get_or_insert_with(Vec::new);
                good.clear();
                good.extend_from_slice(&self.worker.residuals);
            }
            Err(f) => self.failed = Some(f),
        }
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, u: &DVector<f64>) {
        self.u.copy_from(u);
        self.evaluate();
    }

    fn params(&self) -> DVector<f64> {
        self.u.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        if self.failed.is_none() {
            return Some(DVector::from_column_slice(&self.worker.residuals));
        }
        let good = self.last_good.as_ref()?;
        Some(DVector::from_iterator(
            good.len(),
            good.iter().map(|r| 10.0 * r + 1.0),
        ))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        if self.failed.is_some() {
            return None;
        }
        // LM asks for the Jacobian of the design it accepted: later designs
        // assemble from its start.
        {
            let (p0, q0) = &mut *self.accepted.borrow_mut();
            q0.clear();
            q0.extend_from_slice(&self.worker.first_q);
            p0.clear();
            p0.extend_from_slice(&self.x[..self.plan.vary.len()]);
        }
        let n = self.maps.len();
        let k = self.plan.vary.len();
        let m = self.worker.residuals.len();
        let j = &self.worker.jacobian;
        // With respect to the times, then to the first time and the gaps:
        // t_i is the sum of the first i of those, so the column of the
        // c-th is the sum of the times' columns from c on.
        let mut jacobian = DMatrix::from_fn(m, n, |r, c| j[r * n + c]);
        for c in (k..n.saturating_sub(1)).rev() {
            let later = jacobian.column(c + 1).clone_owned();
            let mut column = jacobian.column_mut(c);
            column += &later;
        }
        for (c, mut column) in jacobian.column_iter_mut().enumerate() {
            column *= self.maps[c].slope(self.u[c]);
        }
        Some(jacobian)
    }
}

/// The fractions of the way from a start that does not run to the model's
/// design at which it is tried again ([`fit`]), nearest the start first.
const TOWARDS_MODEL: [f64; 4] = [0.125, 0.25, 0.5, 0.75];

/// Fits from the start `x0` (params, then times when unknown) and checks
/// the optimum's defects; with it, whether the start was moved.
///
/// A start whose design does not run through the targets (it does not
/// assemble, locks up before the last target, meets a singular
/// configuration at one) has no residuals for LM to start from. Rather
/// than rejected, it is moved along the straight line to the model's
/// design — which must run, being the first start — to the first of
/// [`TOWARDS_MODEL`]'s fractions of the way where it runs: the feasible
/// part of the space-filling design, kept as near its point as that
/// allows. (The bounds are convex: the point stays within them.) Only
/// when none runs is it rejected, for its own failure.
///
/// Unknown times are fitted as the first time and the gaps between
/// consecutive ones, each positive (p = exp u): the targets are visited in
/// their order by construction (an order defect is then only a visit
/// spanning more than one cycle, which the check rejects). A design whose
/// times leave [−t_end, 3 t_end] — or, with the walls up, span more than a
/// cycle — is answered as a failed one (LM shrinks its step).
pub(crate) fn fit(
    worker: &mut Worker,
    plan: &Plan,
    index: usize,
    x0: &[f64],
) -> (StartResult, bool) {
    let (moved, x0) = match runnable(worker, plan, x0) {
        Ok(None) => (false, x0.to_vec()),
        Ok(Some(x)) => (true, x),
        Err(f) => return (Err(rejection(index, &f)), false),
    };
    (fit_walls(worker, plan, index, &x0), moved)
}

/// `None` if the start `x0` runs through the targets; else the first point
/// towards the model's design that does ([`fit`]), or the start's failure.
fn runnable(worker: &mut Worker, plan: &Plan, x0: &[f64]) -> Result<Option<Vec<f64>>, Failure> {
    let k = plan.vary.len();
    let times = if plan.times_unknown() {
        &x0[k..]
    } else {
        plan.targets.times().unwrap_or(&[])
    };
    let span = plan.fit_span(times);
    let runs = |worker: &mut Worker, params: &[f64]| {
        worker.start_at(&[], &[]);
        worker.evaluate(plan, params, times, span, false, None)
    };
    let failure = match runs(worker, &x0[..k]) {
        Ok(()) => return Ok(None),
        Err(f) => f,
    };
    let model: Vec<f64> = plan.vary.iter().map(|v| v.value).collect();
    if x0[..k] == model[..] {
        return Err(failure);
    }
    let mut x = x0.to_vec();
    for s in TOWARDS_MODEL {
        for ((xj, &aj), &bj) in x.iter_mut().zip(&x0[..k]).zip(&model) {
            *xj = aj + s * (bj - aj);
        }
        if runs(worker, &x[..k]).is_ok() {
            return Ok(Some(x));
        }
    }
    Err(failure)
}

/// [`fit`] from a start that runs: first free of walls, then, if the
/// optimum has a defect, with them.
fn fit_walls(worker: &mut Worker, plan: &Plan, index: usize, x0: &[f64]) -> StartResult {
    // First free of walls: LM's path may cross designs with a singular
    // configuration or targets spread over more than a cycle (the optimum
    // is checked; an optimum on the edge, as a closed path's last point
    // one turn after its first, is reached). If the optimum has a branch
    // or order defect, again from the same start with the walls up: every
    // design tried must be clear of them, so the optimum is by
    // construction.
    match fit_once(worker, plan, index, x0, false) {
        Err(r)
            if matches!(
                r.reason,
                Reason::Branch | Reason::FullTurn | Reason::Singular | Reason::Order
            ) =>
        {
            fit_once(worker, plan, index, x0, true).map_err(|_| r)
        }
        result => result,
    }
}

/// [`fit`] once, with or without the walls.
fn fit_once(
    worker: &mut Worker,
    plan: &Plan,
    index: usize,
    x0: &[f64],
    walls: bool,
) -> StartResult {
    let k = plan.vary.len();
    let mut maps: Vec<Map> = plan.vary.iter().map(|v| v.map).collect();
    let mut start: Vec<f64> = x0[..k].to_vec();
    if plan.times_unknown() {
        // The first time free (a bound would hold it where its slope
        // vanishes), the gaps positive.
        maps.push(Map::Free);
        maps.extend(std::iter::repeat_n(Map::Positive, plan.targets.rows() - 1));
        let times = &x0[k..];
        start.push(times[0]);
        start.extend(times.windows(2).map(|w| w[1] - w[0]));
    }
    let u = DVector::from_iterator(
        maps.len(),
        start.iter().zip(&maps).map(|(&x, map)| map.inner(x)),
    );
    worker.start_at(&[], &[]);
    let mut problem = Problem {
        worker,
        plan,
        maps,
        u,
        x: vec![0.0; x0.len()],
        times: Vec::with_capacity(plan.targets.rows()),
        failed: None,
        last_good: None,
        accepted: std::cell::RefCell::new((Vec::new(), Vec::new())),
        evaluations: 0,
        walls,
    };
    problem.evaluate();
    if let Some(f) = problem.failed.take() {
        return Err(rejection(index, &f));
    }
    let lm = LevenbergMarquardt::new()
        .with_ftol(1e-14)
        .with_xtol(1e-14)
        .with_gtol(1e-15)
        .with_patience(100);
    let (mut problem, report) = lm.minimize(problem);
    // The minimizer leaves the problem at its best design; make sure the
    // worker's buffers are that design's.
    let u = problem.u.clone();
    problem.set_params(&u);
    if let Some(f) = problem.failed.take() {
        return Err(rejection(index, &f));
    }
    let evaluations = problem.evaluations;
    let p0 = problem.x[..k].to_vec();
    let times = if plan.times_unknown() {
        problem.times.clone()
    } else {
        plan.targets.times().unwrap_or(&[]).to_vec()
    };
    let q0 = problem.worker.first_q.clone();
    let worker = problem.worker;
    check(
        worker,
        plan,
        index,
        &times,
        (&p0, &q0),
        evaluations,
        &format!("{:?}", report.termination),
    )
}

/// A fitted design's defect checks, and the design: it must assemble at
/// every target time on the branch it starts on (it does, being run by
/// continuation), pass no singular configuration between its first and
/// last target (no branch defect), visit the targets in order within one
/// cycle (no order defect), and with `--full-turn` turn that body fully
/// over the cycle with no singular configuration.
fn check(
    worker: &mut Worker,
    plan: &Plan,
    index: usize,
    times: &[f64],
    (params, q0): (&[f64], &[f64]),
    evaluations: usize,
    termination: &str,
) -> StartResult {
    let reject = |reason: Reason, detail: String| Rejection {
        start: index,
        reason,
        detail,
    };
    if plan.times_unknown() {
        for (i, w) in times.windows(2).enumerate() {
            if w[1] <= w[0] {
                return Err(reject(
                    Reason::Order,
                    format!(
                        "target {} is reached at t = {:.6}, before target {} at t = {:.6}",
                        i + 2,
                        w[1],
                        i + 1,
                        w[0]
                    ),
                ));
            }
        }
        let (first, last) = (times[0], times[times.len() - 1]);
        // A whole cycle is allowed: a closed path's list may end with its
        // first point again, one turn later.
        if last - first > plan.t_end * (1.0 + 1e-9) {
            return Err(reject(
                Reason::Order,
                format!(
                    "the targets take t = {first:.6} to {last:.6}, more than one cycle ({})",
                    plan.t_end
                ),
            ));
        }
    }
    // The objectives' samples are already in the fitted design's
    // residuals; the check runs the whole cycle.
    let residuals = worker.residuals.clone();
    let span = plan.check_span(times);
    worker.start_at(params, q0);
    if let Err(f) = worker.evaluate(plan, params, times, span, false, None) {
        return Err(rejection(index, &f));
    }
    let first = times.iter().copied().fold(f64::INFINITY, f64::min);
    let last = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if let Some(e) = worker
        .events
        .iter()
        .find(|e| e.t >= first - 1e-9 && e.t <= last + 1e-9)
    {
        return Err(reject(Reason::Branch, format!("between the targets: {e}")));
    }
    if let Some((body, i)) = &plan.full_turn {
        if let Some(e) = worker.events.first() {
            return Err(reject(
                Reason::FullTurn,
                format!("{body} does not turn fully: {e}"),
            ));
        }
        let turned = (worker.last_q[*i] - worker.first_q[*i]).abs();
        if turned < TAU * (1.0 - 1e-9) {
            return Err(reject(
                Reason::FullTurn,
                format!(
                    "{body} turns {turned:.6} rad over t = {} to {}, less than a full turn (is --t-end one turn of its driver?)",
                    span[0], span[1]
                ),
            ));
        }
    }
    let objectives = worker.objective_values(plan);
    Ok(Design::new(
        plan,
        &Fitted {
            start: index,
            params,
            times,
            residuals: &residuals,
            objective_values: &objectives,
            start_q: q0,
            evaluations,
            termination,
        },
    ))
}

fn rejection(start: usize, f: &Failure) -> Rejection {
    match f {
        Failure::Assembly { t, why } => Rejection {
            start,
            reason: Reason::Assembly,
            detail: format!("no solution at t = {t}: {why}"),
        },
        Failure::Singular { t } => Rejection {
            start,
            reason: Reason::Singular,
            detail: format!("a singular configuration at t = {t}, between or at the targets"),
        },
        Failure::NotFinite { t } => Rejection {
            start,
            reason: Reason::NotFinite,
            detail: format!("a result that is not finite (by t = {t})"),
        },
    }
}

/// `out` = the running sums of `parts` (the first time, then the gaps).
fn running_sums(parts: &[f64], out: &mut Vec<f64>) {
    out.clear();
    let mut sum = 0.0;
    for &p in parts {
        sum += p;
        out.push(sum);
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests: a failure should stop the test
mod tests {
    use super::*;
    use crate::{Spec, Targets};
    use kinema_tape::Model;

    /// The test four-bar (ground pivots 1 apart, a coupler point), its
    /// crank turning from 45° at `rate` rad per unit time.
    fn four_bar(rate: &str) -> Model {
        let text = format!(
            "mechanism FourBar {{
                param l1 = 0.3;
                param l2 = 1.0;
                param l3 = 0.8;
                body crank   {{ guess: (0.1, 0.1, 0.8) }}
                body coupler {{ guess: (0.6, 0.5, 0.6) }}
                body rocker  {{ guess: (1.0, 0.4, 1.5) }}
                point coupler.p = (0.2, 0.3);
                joint o: revolute(crank(-l1 / 2, 0), ground(0, 0));
                joint a: revolute(crank(l1 / 2, 0), coupler(-l2 / 2, 0));
                joint b: revolute(coupler(l2 / 2, 0), rocker(l3 / 2, 0));
                joint d: revolute(rocker(-l3 / 2, 0), ground(1, 0));
                driver crank_angle: abs_angle(crank, pi / 4 + {rate} * t);
            }}"
        );
        Model::from_source(&text, "four_bar.kin").unwrap()
    }

    /// A four-bar (ground pivots 1 apart) whose crank turns a quarter
    /// turn from 45°, and the coupler point's path of its own design at
    /// four times.
    fn crank_rocker() -> (Model, Plan) {
        let model = four_bar("pi / 2");
        let times = [0.0, 0.3, 0.6, 1.0];
        let mut solver = model.solver(kinema_runtime::Options::default()).unwrap();
        let p = model.output_index("coupler.p.x").unwrap();
        let rows: Vec<Vec<f64>> = times
            .iter()
            .map(|&t| {
                if t == 0.0 {
                    solver.assemble(t).unwrap();
                } else {
                    solver.step(t).unwrap();
                }
                let state = solver.state().unwrap();
                let [y, _, _] = kinema_runtime::Outputs::outputs_at(solver.system(), state);
                vec![y[p], y[p + 1]]
            })
            .collect();
        let targets = Targets::new(&["coupler.p.x", "coupler.p.y"], &rows, Some(&times)).unwrap();
        let spec = Spec::new(&["l1", "l2", "l3"], targets).with_bounds(vec![
            "l1=0.05:2".parse().unwrap(),
            "l2=0.05:2".parse().unwrap(),
            "l3=0.05:2".parse().unwrap(),
        ]);
        let plan = Plan::new(&model, &spec).unwrap();
        (model, plan)
    }

    /// A start whose links cannot close (l2 + l3 shorter than the pivots'
    /// distance from the crank pin) is not rejected but moved towards the
    /// model's design until it runs, and fitted from there; one that runs
    /// is fitted where it is.
    #[test]
    fn a_start_that_does_not_run_is_moved_towards_the_models_design() {
        let (model, plan) = crank_rocker();
        let mut worker = Worker::new(&model, &plan).unwrap();
        let stuck = [0.9, 0.2, 0.2];
        let k = plan.vary.len();
        let span = plan.fit_span(plan.targets.times().unwrap());
        worker.start_at(&[], &[]);
        let failure = worker.evaluate(
            &plan,
            &stuck,
            plan.targets.times().unwrap(),
            span,
            false,
            None,
        );
        assert!(
            matches!(failure, Err(Failure::Assembly { .. })),
            "{failure:?}"
        );
        let moved = runnable(&mut worker, &plan, &stuck).unwrap().unwrap();
        // The first fraction that runs, on the line to the model's design.
        let s = (moved[0] - stuck[0]) / (0.3 - stuck[0]);
        assert!(TOWARDS_MODEL.contains(&((s * 1e6).round() / 1e6)), "{s}");
        for (j, v) in plan.vary.iter().enumerate().take(k) {
            assert!((moved[j] - (stuck[j] + s * (v.value - stuck[j]))).abs() < 1e-12);
        }
        let (result, was_moved) = fit(&mut worker, &plan, 7, &stuck);
        assert!(was_moved);
        let design = result.unwrap();
        assert_eq!(design.start(), 7);
        assert!(design.rms() < 1e-8, "{}", design.rms());
        // A start that runs is not moved.
        let (result, was_moved) = fit(&mut worker, &plan, 8, &[0.32, 0.95, 0.85]);
        assert!(!was_moved);
        assert!(result.unwrap().rms() < 1e-8);
    }

    /// A start none of whose points towards the model's design runs is
    /// rejected for its own failure, unmoved.
    #[test]
    fn a_start_with_no_running_point_towards_the_model_is_rejected() {
        let (model, plan) = crank_rocker();
        let mut worker = Worker::new(&model, &plan).unwrap();
        // Far out: three quarters of the way back is still too short.
        let stuck = [2.0, 0.05, 0.05];
        assert!(runnable(&mut worker, &plan, &stuck).is_err());
        let (result, was_moved) = fit(&mut worker, &plan, 3, &stuck);
        assert!(!was_moved);
        let rejection = result.unwrap_err();
        assert_eq!((rejection.start, rejection.reason), (3, Reason::Assembly));
        assert!(rejection.detail.contains("t = 0"), "{}", rejection.detail);
    }

    /// LM's Jacobian — through the bounds' maps and, for unknown times,
    /// the first time and the gaps — against central differences of the
    /// residuals in LM's own unknowns.
    #[test]
    fn the_internal_jacobian_is_exact() {
        let model = four_bar("2 * pi");
        let rows = vec![
            vec![0.5, 0.6],
            vec![0.4, 0.7],
            vec![0.3, 0.7],
            vec![0.2, 0.6],
        ];
        let targets = Targets::new(&["coupler.p.x", "coupler.p.y"], &rows, None).unwrap();
        let spec = Spec::new(&["l1", "l2", "l3"], targets)
            .with_t_end(1.0)
            .with_bounds(vec![
                "l1=0.1:0.5".parse().unwrap(),
                "l3=0.5:".parse().unwrap(),
            ]);
        let plan = Plan::new(&model, &spec).unwrap();
        let mut worker = Worker::new(&model, &plan).unwrap();
        let x0 = [0.31, 0.98, 0.83, 0.1, 0.3, 0.45, 0.6];
        let k = 3;
        let mut maps: Vec<Map> = plan.vary.iter().map(|v| v.map).collect();
        maps.push(Map::Free);
        maps.extend(std::iter::repeat_n(Map::Positive, 3));
        let mut start: Vec<f64> = x0[..k].to_vec();
        start.push(x0[k]);
        start.extend(x0[k..].windows(2).map(|w| w[1] - w[0]));
        let u = DVector::from_iterator(7, start.iter().zip(&maps).map(|(&x, m)| m.inner(x)));
        let mut problem = Problem {
            worker: &mut worker,
            plan: &plan,
            maps,
            u: u.clone(),
            x: vec![0.0; 7],
            times: Vec::new(),
            failed: None,
            last_good: None,
            accepted: std::cell::RefCell::new((Vec::new(), Vec::new())),
            evaluations: 0,
            walls: true,
        };
        problem.set_params(&u);
        let jacobian = problem.jacobian().unwrap();
        for j in 0..7 {
            let h = 1e-6;
            let mut up = u.clone();
            up[j] += h;
            problem.set_params(&up);
            let ru = problem.residuals().unwrap();
            let mut down = u.clone();
            down[j] -= h;
            problem.set_params(&down);
            let rd = problem.residuals().unwrap();
            for r in 0..ru.len() {
                let fd = (ru[r] - rd[r]) / (2.0 * h);
                assert!(
                    (fd - jacobian[(r, j)]).abs() < 1e-6,
                    "∂r{r}/∂u{j}: {} against {fd}",
                    jacobian[(r, j)]
                );
            }
        }
    }
}
