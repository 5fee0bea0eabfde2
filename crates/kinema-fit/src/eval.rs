//! One design evaluated: the mechanism run through the target times (and
//! the objectives' grid), the residuals, and their exact Jacobian from the
//! parameter sensitivities and the results' rates.

use kinema_runtime::{Motion, Options, Outputs, SingularEvent, System};
use kinema_tape::sensitivity::Sensitivity;
use kinema_tape::{Model, ModelSolver};

use crate::plan::{Column, Plan};

/// What a design's run came to, when it has no residuals.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Failure {
    /// No solution at `t` from the last one (or, at the start, from the
    /// guess): the design does not assemble there on the branch followed.
    Assembly { t: f64, why: String },
    /// A target (or an objective's sample) at a configuration that is
    /// singular or nearly so: its results' sensitivities are not
    /// determined there.
    Singular { t: f64 },
    /// A result, a rate or a sensitivity that is not finite.
    NotFinite { t: f64 },
}

/// What a run samples at one time.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Tag {
    /// A step on the way (keeps the branch; not sampled).
    Step,
    /// Target row `i`.
    Target(usize),
    /// Objective sample `k` of the cycle.
    Sample(usize),
}

/// A worker's solver, sensitivities and buffers: a design evaluated with no
/// allocation but the time list's first growth.
pub(crate) struct Worker {
    pub(crate) solver: ModelSolver,
    sens: Sensitivity,
    scratch: <kinema_tape::TapeSystem as System>::Scratch,
    /// y, ẏ, ÿ of every result column at the current state.
    outputs: [Vec<f64>; 3],
    schedule: Vec<(f64, Tag)>,
    /// The sampled columns' (y, ẏ) at the current time.
    values: Vec<(f64, f64)>,
    /// Residuals (m) and their Jacobian, row-major m × unknowns, with
    /// respect to the params' values and the times (not the bounded
    /// internal variables).
    pub(crate) residuals: Vec<f64>,
    pub(crate) jacobian: Vec<f64>,
    /// Per objective sample and column, the value (for the peaks' norms)
    /// and its sensitivities (k per value).
    samples: Vec<f64>,
    sample_sens: Vec<f64>,
    /// q at the run's first time, of the last design that assembled: the
    /// next design's assembly starts there (its branch).
    pub(crate) start_q: Vec<f64>,
    /// The varied params of that design.
    start_params: Vec<f64>,
    /// Singular configurations met on the last run.
    pub(crate) events: Vec<SingularEvent>,
    /// q at the last run's first and last times.
    pub(crate) first_q: Vec<f64>,
    pub(crate) last_q: Vec<f64>,
    /// The model's own design assembled at a time: where cold starts are
    /// continued from.
    nominal_q: Option<(f64, Vec<f64>)>,
}

impl Worker {
    pub(crate) fn new(model: &Model, plan: &Plan) -> Result<Worker, String> {
        let options = Options::default();
        let solver = model.solver(options).map_err(|e| e.to_string())?;
        let sens = plan.sensitivity.clone();
        let system = solver.system();
        let m = system.output_len();
        let scratch = system.scratch();
        let unknowns = plan.unknowns();
        let residuals = plan.residuals();
        let samples = plan.objective_samples() * plan.objectives.len();
        Ok(Worker {
            solver,
            sens,
            scratch,
            outputs: [vec![0.0; m], vec![0.0; m], vec![0.0; m]],
            schedule: Vec::new(),
            values: Vec::with_capacity(plan.columns.len().max(plan.objectives.len())),
            residuals: vec![0.0; residuals],
            jacobian: vec![0.0; residuals * unknowns],
            samples: vec![0.0; samples],
            sample_sens: vec![0.0; samples * plan.vary.len()],
            start_q: Vec::new(),
            start_params: Vec::new(),
            events: Vec::new(),
            first_q: Vec::new(),
            last_q: Vec::new(),
            nominal_q: None,
        })
    }

    /// Runs the design `params` (the varied params' values) with the
    /// target times `times` (the prescribed ones, or the unknowns'
    /// values) over `span`, and fills the residuals and, with
    /// `jacobian`, their Jacobian. A singular configuration met within
    /// `singular_window` fails the design: a fit's designs stay clear of
    /// branch defects, LM stepping back from them as from any failure. Assembly starts from
    /// [`start_q`](Self::start_q) when set (then from the model's guess if
    /// that fails), so a fit stays on its branch.
    pub(crate) fn evaluate(
        &mut self,
        plan: &Plan,
        params: &[f64],
        times: &[f64],
        span: [f64; 2],
        jacobian: bool,
        singular_window: Option<[f64; 2]>,
    ) -> Result<(), Failure> {
        self.set_params(plan, params);
        self.schedule(plan, times, span)
            .map_err(|why| Failure::Assembly { t: span[0], why })?;
        self.events.clear();
        self.residuals.fill(0.0);
        self.jacobian.fill(0.0);
        let start = self.schedule.first().map_or(span[0], |s| s.0);
        self.assemble(plan, params, start)?;
        if let Some(state) = self.solver.state() {
            self.first_q.clear();
            self.first_q.extend_from_slice(state.q());
        }
        let k = plan.vary.len();
        let unknowns = plan.unknowns();
        let width = plan.columns.len();
        let mut last = start;
        for s in 0..self.schedule.len() {
            let (t, tag) = self.schedule[s];
            if t > last {
                self.step(last, t)?;
                last = t;
            }
            if tag == Tag::Step {
                continue;
            }
            let Some(state) = self.solver.state() else {
                return Err(Failure::Assembly {
                    t,
                    why: "no state".to_owned(),
                });
            };
            if state.near_singular() {
                return Err(Failure::Singular { t });
            }
            let system = self.solver.system();
            {
                let [y, yd, ydd] = &mut self.outputs;
                system.outputs(&mut self.scratch, Motion::of(state), [y, yd, ydd]);
            }
            {
                let (q, qd) = (state.q(), state.qd());
                let outputs = &self.outputs;
                let value = |c: &Column| match *c {
                    Column::Coordinate(i) => (q[i], qd[i]),
                    Column::Output(i) => (outputs[0][i], outputs[1][i]),
                };
                self.values.clear();
                match tag {
                    Tag::Step => {}
                    Tag::Target(_) => self.values.extend(plan.columns.iter().map(value)),
                    Tag::Sample(_) => self
                        .values
                        .extend(plan.objectives.iter().map(|o| value(&o.column))),
                }
            }
            // Targets and objectives are positions: their sensitivities
            // at the position level (an unknown time's column is the
            // result's own rate, from the state).
            if jacobian && let Err(e) = self.sens.compute_positions(&mut self.solver) {
                return Err(Failure::Assembly {
                    t,
                    why: format!("the sensitivities: {e}"),
                });
            }
            match tag {
                Tag::Step => {}
                Tag::Target(i) => {
                    for (c, column) in plan.columns.iter().enumerate() {
                        let row = i * width + c;
                        let (y, yd) = self.values[c];
                        self.residuals[row] = y - plan.target(i, c);
                        if !jacobian {
                            continue;
                        }
                        let jrow = &mut self.jacobian[row * unknowns..(row + 1) * unknowns];
                        for (j, dj) in jrow.iter_mut().take(k).enumerate() {
                            *dj = sensitivity(&self.sens, j, column);
                        }
                        if plan.times_unknown() {
                            jrow[k + i] = yd;
                        }
                    }
                }
                Tag::Sample(n) => {
                    for (o, objective) in plan.objectives.iter().enumerate() {
                        let at = o * plan.objective_samples() + n;
                        let (y, _) = self.values[o];
                        self.samples[at] = y;
                        if jacobian {
                            for j in 0..k {
                                self.sample_sens[at * k + j] =
                                    sensitivity(&self.sens, j, &objective.column);
                            }
                        }
                    }
                }
            }
        }
        self.events.extend_from_slice(self.solver.close_events());
        if let Some([a, b]) = singular_window {
            let slack = 1e-9 * (b - a).abs().max(1.0);
            if let Some(e) = self
                .events
                .iter()
                .find(|e| e.t >= a - slack && e.t <= b + slack)
            {
                return Err(Failure::Singular { t: e.t });
            }
        }
        self.objectives(plan, jacobian);
        let finite = self.residuals.iter().all(|r| r.is_finite())
            && (!jacobian || self.jacobian.iter().all(|d| d.is_finite()));
        if !finite {
            return Err(Failure::NotFinite { t: last });
        }
        if let Some(state) = self.solver.state() {
            self.last_q.clear();
            self.last_q.extend_from_slice(state.q());
        }
        Ok(())
    }

    /// A step from `last` to `t` ([`step_refined`]).
    fn step(&mut self, last: f64, t: f64) -> Result<(), Failure> {
        step_refined(&mut self.solver, last, t).map_err(|e| Failure::Assembly {
            t,
            why: e.to_string(),
        })
    }

    /// Assembly at `t` of the design whose varied params are `params`
    /// (already set). With an anchor ([`start_at`](Self::start_at): the
    /// design a fit last accepted), on its branch: from its configuration,
    /// else continued in the params from it. Without one (a start), from
    /// the model's guesses — they select the branch, as in a run; a model
    /// can write them as functions of its params (the closed-form
    /// assembly) — else continued in the params from the model's own
    /// design. A design that cannot be reached so does not assemble.
    fn assemble(&mut self, plan: &Plan, params: &[f64], t: f64) -> Result<(), Failure> {
        let q = std::mem::take(&mut self.start_q);
        let direct = self.assemble_from((!q.is_empty()).then_some(&q[..]), t);
        self.start_q = q;
        if direct.is_ok() {
            return Ok(());
        }
        self.continue_to(plan, params, t)
    }

    /// Sets the varied params to `params`.
    fn set_params(&mut self, plan: &Plan, params: &[f64]) {
        let system = self.solver.system_mut();
        for (v, &value) in plan.vary.iter().zip(params) {
            // The index is the param's own (checked by the plan).
            let _ = system.set_param_at(v.index, value);
        }
    }

    /// Assembly at `t` with the guess `q` (the model's when `None`).
    fn assemble_from(&mut self, q: Option<&[f64]>, t: f64) -> Result<(), String> {
        self.solver.system_mut().set_guess(q);
        self.solver.reset();
        let result = self
            .solver
            .assemble(t)
            .map(|_| ())
            .map_err(|e| e.to_string());
        self.solver.system_mut().set_guess(None);
        result
    }

    /// See [`assemble`](Self::assemble): steps of at most a quarter of the
    /// way, halved where assembly fails, each from the last solution.
    fn continue_to(&mut self, plan: &Plan, params: &[f64], t: f64) -> Result<(), Failure> {
        let fail = |why: String| Failure::Assembly { t, why };
        let anchored = !self.start_q.is_empty() && self.start_params.len() == params.len();
        let (from, mut q) = if anchored {
            (self.start_params.clone(), self.start_q.clone())
        } else {
            let nominal: Vec<f64> = plan.vary.iter().map(|v| v.value).collect();
            let cached = matches!(&self.nominal_q, Some((at, _)) if *at == t);
            if !cached {
                self.set_params(plan, &nominal);
                let assembled = self.assemble_from(None, t);
                self.set_params(plan, params);
                match assembled {
                    Ok(()) => {
                        let q = self
                            .solver
                            .state()
                            .map_or_else(Vec::new, |s| s.q().to_vec());
                        self.nominal_q = Some((t, q));
                    }
                    // The model's own design does not assemble: this one
                    // from the guesses, then.
                    Err(_) => return self.assemble_from(None, t).map_err(fail),
                }
            }
            let q = self
                .nominal_q
                .as_ref()
                .map_or_else(Vec::new, |(_, q)| q.clone());
            (nominal, q)
        };
        let nominal = from;
        let (mut done, mut step) = (0.0f64, 0.25f64);
        let mut along = vec![0.0; params.len()];
        while done < 1.0 {
            let next = (done + step).min(1.0);
            for ((a, &p), &p0) in along.iter_mut().zip(params).zip(&nominal) {
                *a = if next == 1.0 { p } else { p0 + next * (p - p0) };
            }
            self.set_params(plan, &along);
            match self.assemble_from(Some(&q), t) {
                Ok(()) => {
                    q.clear();
                    q.extend_from_slice(self.solver.state().map_or(&[][..], |s| s.q()));
                    done = next;
                    step = (2.0 * step).min(0.25);
                }
                Err(why) => {
                    step *= 0.5;
                    if step < 1.0 / 1024.0 {
                        self.set_params(plan, params);
                        return Err(fail(format!(
                            "not on the branch of the {}: continued from it, assembly fails {:.1} % of the way: {why}",
                            if anchored {
                                "fit's last design"
                            } else {
                                "model's design"
                            },
                            100.0 * done
                        )));
                    }
                }
            }
        }
        Ok(())
    }

    /// Anchors the next designs' assembly at the design `params` whose
    /// configuration at the run's first time is `q0` (its
    /// [`first_q`](Self::first_q)), to keep its branch; empty slices: the
    /// model's design.
    pub(crate) fn start_at(&mut self, params: &[f64], q0: &[f64]) {
        self.start_q.clear();
        self.start_q.extend_from_slice(q0);
        self.start_params.clear();
        self.start_params.extend_from_slice(params);
    }

    /// The times of a run: a uniform grid over `span` (the plan's steps
    /// per cycle), the targets' times and the objectives' samples, in time
    /// order; equal times share a step.
    ///
    /// # Errors
    /// As [`grid`](crate::plan::grid) (not met: a plan's times are checked
    /// to give a bounded grid).
    fn schedule(&mut self, plan: &Plan, times: &[f64], span: [f64; 2]) -> Result<(), String> {
        let s = &mut self.schedule;
        s.clear();
        let h = plan.cycle_length() / plan.steps as f64;
        crate::plan::grid(span, h, |t| s.push((t, Tag::Step)))?;
        s.extend(times.iter().enumerate().map(|(i, &t)| (t, Tag::Target(i))));
        for n in 0..plan.objective_samples() {
            s.push((plan.sample_time(n), Tag::Sample(n)));
        }
        // Targets and samples after the steps at the same time; a stable
        // sort keeps their order.
        s.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(())
    }

    /// Each objective's unweighted value over the last run's samples: the
    /// RMS, or the true peak (largest magnitude).
    pub(crate) fn objective_values(&self, plan: &Plan) -> Vec<f64> {
        let n = plan.objective_samples();
        plan.objectives
            .iter()
            .enumerate()
            .map(|(o, objective)| {
                let samples = &self.samples[o * n..(o + 1) * n];
                match objective.measure {
                    crate::Measure::Rms => {
                        (samples.iter().map(|y| y * y).sum::<f64>() / n.max(1) as f64).sqrt()
                    }
                    crate::Measure::Peak => samples.iter().fold(0.0f64, |m, y| m.max(y.abs())),
                }
            })
            .collect()
    }

    /// The objectives' residuals from their samples: an RMS as one
    /// residual per sample (w y/√N: their squares sum to w² RMS²), a peak
    /// as one residual, w times the samples' 16-norm (a smooth stand-in
    /// for the largest magnitude; the summary reports the true peak).
    fn objectives(&mut self, plan: &Plan, jacobian: bool) {
        let k = plan.vary.len();
        let unknowns = plan.unknowns();
        let n = plan.objective_samples();
        let mut row = plan.target_residuals();
        for (o, objective) in plan.objectives.iter().enumerate() {
            let samples = &self.samples[o * n..(o + 1) * n];
            let sens = &self.sample_sens[o * n * k..(o + 1) * n * k];
            let w = objective.weight;
            match objective.measure {
                crate::Measure::Rms => {
                    let scale = w / (n as f64).sqrt();
                    for (i, &y) in samples.iter().enumerate() {
                        self.residuals[row] = scale * y;
                        if jacobian {
                            for j in 0..k {
                                self.jacobian[row * unknowns + j] = scale * sens[i * k + j];
                            }
                        }
                        row += 1;
                    }
                }
                crate::Measure::Peak => {
                    let (norm, grad) = p_norm(samples, sens, k);
                    self.residuals[row] = w * norm;
                    if jacobian {
                        for (j, g) in grad.iter().take(k).enumerate() {
                            self.jacobian[row * unknowns + j] = w * g;
                        }
                    }
                    row += 1;
                }
            }
        }
    }
}

/// A step of `solver` from `last` to `t`; where the motion changes too much
/// over it to be followed (Newton's failure or a branch the solver cannot
/// tell from another), eight sub-steps before giving up — the grid is a
/// user's choice, not the mechanism's limit. The error is the first step's.
pub(crate) fn step_refined(
    solver: &mut ModelSolver,
    last: f64,
    t: f64,
) -> Result<(), kinema_runtime::Error> {
    let first = match solver.step(t) {
        Ok(_) => return Ok(()),
        Err(e) => e,
    };
    let retry = matches!(
        first,
        kinema_runtime::Error::BranchJump { .. } | kinema_runtime::Error::NoConvergence { .. }
    );
    if retry {
        let h = (t - last) / 8.0;
        let stepped = (1..=8).try_for_each(|i| {
            let ti = if i == 8 { t } else { last + h * f64::from(i) };
            solver.step(ti).map(|_| ())
        });
        if stepped.is_ok() {
            return Ok(());
        }
    }
    Err(first)
}

/// The power of the smooth peak: ‖y‖₁₆ is within 16√N ≈ 1.2 (N = 360) of
/// the largest |y|, and smooth.
const PEAK_POWER: i32 = 16;

/// (mean |y|^P)^(1/P) and its gradient from the samples' sensitivities
/// (`k` per sample): allocation-free for k ≤ 64, as the plan allows.
fn p_norm(samples: &[f64], sens: &[f64], k: usize) -> (f64, [f64; 64]) {
    let n = samples.len().max(1) as f64;
    let big = samples.iter().fold(0.0f64, |m, y| m.max(y.abs()));
    let mut grad = [0.0; 64];
    if big == 0.0 {
        return (0.0, grad);
    }
    // Scaled by the largest magnitude so the powers do not overflow.
    let mean = samples
        .iter()
        .map(|y| (y.abs() / big).powi(PEAK_POWER))
        .sum::<f64>()
        / n;
    let norm = big * mean.powf(1.0 / f64::from(PEAK_POWER));
    // d‖y‖/dθ = ‖y‖^(1−P) mean(|y|^(P−1) sign(y) dy/dθ).
    for (i, &y) in samples.iter().enumerate() {
        let weight = (y.abs() / big).powi(PEAK_POWER - 1) * y.signum() / (n * mean);
        for j in 0..k.min(64) {
            grad[j] += weight * sens[i * k + j];
        }
    }
    (norm, grad.map(|g| g * norm / big))
}

/// ∂y/∂p_j of a column at the state of the last sensitivity computation.
fn sensitivity(sens: &Sensitivity, j: usize, column: &Column) -> f64 {
    match *column {
        Column::Coordinate(i) => sens.coordinates(j)[0][i],
        Column::Output(i) => sens.outputs(j)[0][i],
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests: a failure should stop the test
mod tests {
    use super::*;
    use crate::{Objective, Spec, Targets};

    const FOUR_BAR: &str = "mechanism FourBar {
        param l1 = 0.3;
        param l2 = 1.0;
        param l3 = 0.8;
        param px = 0.2;
        param py = 0.3;
        body crank   { guess: (0.1, 0.1, 0.8) }
        body coupler { guess: (0.6, 0.5, 0.6) }
        body rocker  { guess: (1.0, 0.4, 1.5) }
        point coupler.p = (px, py);
        joint o: revolute(crank(-l1 / 2, 0), ground(0, 0));
        joint a: revolute(crank(l1 / 2, 0), coupler(-l2 / 2, 0));
        joint b: revolute(coupler(l2 / 2, 0), rocker(l3 / 2, 0));
        joint d: revolute(rocker(-l3 / 2, 0), ground(1, 0));
        driver crank_angle: abs_angle(crank, pi / 4 + 2 * pi * t);
        output mu: acos(dot(rot(coupler.phi, (1, 0)), rot(rocker.phi, (1, 0))));
    }";

    /// The residuals' Jacobian — params through the symbolic sensitivities,
    /// unknown times through the results' rates, RMS and peak objectives
    /// through both — against central differences of whole evaluations.
    #[test]
    fn the_jacobian_is_the_residuals_derivative() {
        let model = Model::from_source(FOUR_BAR, "four_bar.kin").unwrap();
        let rows = vec![
            vec![0.5, 0.6, 1.0],
            vec![0.4, 0.7, 1.1],
            vec![0.3, 0.7, 1.2],
        ];
        for times in [None, Some(&[0.1, 0.35, 0.6][..])] {
            let targets =
                Targets::new(&["coupler.p.x", "coupler.p.y", "rocker.phi"], &rows, times).unwrap();
            let spec = Spec::new(&["l1", "l2", "l3", "px", "py"], targets)
                .with_t_end(1.0)
                .with_objectives(vec![
                    "rms(mu)*0.5".parse::<Objective>().unwrap(),
                    "peak(coupler.p.y)".parse().unwrap(),
                ]);
            let mut spec = spec;
            spec.steps = 40;
            let plan = Plan::new(&model, &spec).unwrap();
            let mut worker = Worker::new(&model, &plan).unwrap();
            let params = [0.31, 0.98, 0.83, 0.21, 0.28];
            let unknown_times = [0.12, 0.33, 0.61];
            let x: Vec<f64> = if times.is_some() {
                params.to_vec()
            } else {
                params.iter().chain(&unknown_times).copied().collect()
            };
            let n = x.len();
            let eval = |worker: &mut Worker, x: &[f64], jacobian: bool| -> Vec<f64> {
                let (p, t) = x.split_at(5);
                let t = times.unwrap_or(t);
                let span = plan.fit_span(t);
                worker.evaluate(&plan, p, t, span, jacobian, None).unwrap();
                worker.residuals.clone()
            };
            eval(&mut worker, &x, true);
            let jacobian = worker.jacobian.clone();
            let m = worker.residuals.len();
            assert_eq!(m, 9 + 40 + 1);
            for j in 0..n {
                let h = 1e-6 * x[j].abs().max(1.0);
                let mut up = x.clone();
                up[j] += h;
                let mut down = x.clone();
                down[j] -= h;
                let (ru, rd) = (
                    eval(&mut worker, &up, false),
                    eval(&mut worker, &down, false),
                );
                let scale = (0..m)
                    .map(|r| jacobian[r * n + j].abs())
                    .fold(1e-3, f64::max);
                for r in 0..m {
                    let fd = (ru[r] - rd[r]) / (2.0 * h);
                    let exact = jacobian[r * n + j];
                    assert!(
                        (fd - exact).abs() <= 1e-6 * scale,
                        "times {times:?}: ∂r{r}/∂x{j}: exact {exact}, differences {fd}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_smooth_peak_is_near_the_peak_and_its_gradient_exact() {
        let samples = [0.3, -1.2, 0.9, 1.1];
        let sens = [1.0, 0.0, 0.5, 2.0, -1.0, 0.3, 0.2, 0.1];
        let (norm, grad) = p_norm(&samples, &sens, 2);
        assert!(norm <= 1.2 && norm > 1.2 * 0.9, "{norm}");
        for j in 0..2 {
            let h = 1e-7;
            let shifted = |s: f64| -> f64 {
                let y: Vec<f64> = samples
                    .iter()
                    .enumerate()
                    .map(|(i, y)| y + s * sens[i * 2 + j])
                    .collect();
                p_norm(&y, &sens, 2).0
            };
            let fd = (shifted(h) - shifted(-h)) / (2.0 * h);
            assert!((fd - grad[j]).abs() < 1e-7, "{fd} {}", grad[j]);
        }
    }
}
