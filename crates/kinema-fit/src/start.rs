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

/// Fits from the start `x0` (params, then times when unknown) and checks
/// the optimum's defects.
///
/// Unknown times are fitted as the first time and the gaps between
/// consecutive ones, each positive (p = exp u): the targets are visited in
/// their order by construction (an order defect is then only a visit
/// spanning more than one cycle, which the check rejects). A design whose
/// times leave [−t_end, 3 t_end] — or, with the walls up, span more than a
/// cycle — is answered as a failed one (LM shrinks its step).
pub(crate) fn fit(worker: &mut Worker, plan: &Plan, index: usize, x0: &[f64]) -> StartResult {
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

    /// LM's Jacobian — through the bounds' maps and, for unknown times,
    /// the first time and the gaps — against central differences of the
    /// residuals in LM's own unknowns.
    #[test]
    fn the_internal_jacobian_is_exact() {
        let model = Model::from_source(
            "mechanism FourBar {
                param l1 = 0.3;
                param l2 = 1.0;
                param l3 = 0.8;
                body crank   { guess: (0.1, 0.1, 0.8) }
                body coupler { guess: (0.6, 0.5, 0.6) }
                body rocker  { guess: (1.0, 0.4, 1.5) }
                point coupler.p = (0.2, 0.3);
                joint o: revolute(crank(-l1 / 2, 0), ground(0, 0));
                joint a: revolute(crank(l1 / 2, 0), coupler(-l2 / 2, 0));
                joint b: revolute(coupler(l2 / 2, 0), rocker(l3 / 2, 0));
                joint d: revolute(rocker(-l3 / 2, 0), ground(1, 0));
                driver crank_angle: abs_angle(crank, pi / 4 + 2 * pi * t);
            }",
            "four_bar.kin",
        )
        .unwrap();
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
