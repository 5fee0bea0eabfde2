//! The `.kin` target: model text through the front door's phases, a run
//! on the tape (and, for a sample, the JIT, compared bit for bit), and the
//! derivatives against finite differences at the assembled states.

use std::fmt;

use kinema::{Auto, Backend, Solver, State, System, TapeSystem};

use crate::{Finding, Reach, check_error_size, finding, text};

/// Times at which the `.kin` target steps a model: a regular grid to 1,
/// then long strides (drivers that overflow later, Newton from far away).
pub(crate) const KIN_TIMES: [f64; 8] = [0.0, 0.1, 0.25, 0.5, 0.75, 1.0, 10.0, 1000.0];

/// One model text in this many is run again on the JIT: the compilation
/// it waits for (a debug build of Cranelift in CI) would otherwise take
/// most of the budget (measured: the `fun` target ran 58 inputs a second
/// with every one compared, 900 without).
pub(crate) const JIT_SAMPLE: u64 = 8;

/// Whether `source` is one of the texts run again on the JIT: a hash of
/// the text, so that a replay does what the run did.
pub(crate) fn compared_on_jit(source: &str) -> bool {
    let fnv = source.bytes().fold(0xcbf2_9ce4_8422_2325_u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    });
    fnv % JIT_SAMPLE == 0
}

/// Largest derivation (expression nodes) run again on the JIT: its
/// compilation is waited for, and a debug build of Cranelift (CI's) takes
/// seconds on the largest models the generators make, which would count
/// against the input's time budget.
pub(crate) const JIT_COMPARED_NODES: usize = 4_000;

/// The `.kin` target.
///
/// # Errors
/// A [`Finding`] when an oracle is violated.
pub fn kin(data: &[u8]) -> Result<Reach, Finding> {
    let Some(source) = text(data) else {
        return Ok(Reach::Parse);
    };
    kin_text(
        source,
        "fuzz.kin",
        &KIN_TIMES,
        true,
        moderate_literals(source),
    )
    .map(|(reach, _)| reach)
}

/// Checks every number of a state reported as a success.
pub(crate) fn check_state(state: &State, t: f64, system: &TapeSystem) -> Result<(), Finding> {
    let parts = [("q", state.q()), ("q̇", state.qd()), ("q̈", state.qdd())];
    for (what, values) in parts {
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(finding(
                "non-finite-success",
                format!(
                    "step at t = {t} succeeded with {what}[{}] ({}) = {}",
                    i,
                    system.coordinate_name(i),
                    values[i]
                ),
            ));
        }
    }
    Ok(())
}

/// The `.kin` pipeline on text: parse, check, derive, run at `times` (from
/// the guess at the first, stepping after). Returns how far it got and the
/// first coordinate at each time that succeeded. `codegen`: generate the
/// Rust source too (the slowest phase; the `.kin` target only).
/// `derivatives`: check Φ_q, ν and γ against finite differences at the
/// assembled state (for models whose numbers differences can resolve).
pub(crate) fn kin_text(
    source: &str,
    file: &str,
    times: &[f64],
    codegen: bool,
    derivatives: bool,
) -> Result<(Reach, Vec<(f64, f64)>), Finding> {
    // The front door's phases one at a time: how far the text gets.
    let parsed = match kinema_model::Parsed::from_source(kinema_model::Source::new(file, source)) {
        Ok(m) => m,
        Err(report) => {
            check_error_size(&report.render(), source.len())?;
            return Ok((Reach::Parse, Vec::new()));
        }
    };
    let checked = match parsed.check() {
        Ok(c) => c,
        Err(report) => {
            check_error_size(&report.render(), source.len())?;
            return Ok((Reach::Check, Vec::new()));
        }
    };
    let derived = match checked.derive() {
        Ok(d) => d,
        Err(report) => {
            // The derivation's budget: an error at the equation.
            check_error_size(&report.render(), source.len())?;
            return Ok((Reach::Check, Vec::new()));
        }
    };
    for w in derived.warnings().render_each() {
        check_error_size(&w, source.len())?;
    }
    // `kinema derive`: the text must render (its size is the model's).
    let _ = derived.derivation().render();
    let model = kinema::Model::from_derived(derived).with_backend(Backend::Tape);
    if codegen {
        // `kinema codegen`: generated Rust for the same derivation.
        let _ = model.rust_source();
    }
    let plan = Plan::new(times, !model.derivation().params.is_empty());
    let mut outcomes = Vec::with_capacity(plan.steps.len());
    let reach = run_tape(&model, &plan, derivatives, &mut outcomes)?;
    if (reach != Reach::Analysis || !outcomes.is_empty()) && compared_on_jit(source) {
        same_on_jit(&model, &plan, &outcomes)?;
    }
    let first = outcomes
        .iter()
        .zip(&plan.steps)
        .filter(|(_, step)| !step.changed)
        .filter_map(|(o, step)| match o {
            Outcome::Step(q, _, _) => q.first().map(|&x| (step.t, x)),
            Outcome::Error(_) => None,
        })
        .collect();
    Ok((reach, first))
}

/// The steps both back ends run, in order.
pub(crate) struct Plan {
    steps: Vec<PlannedStep>,
}

/// A step of a [`Plan`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlannedStep {
    t: f64,
    /// The model's first parameter is changed and the model assembled
    /// again at `t` (else: a step to `t`).
    changed: bool,
}

impl Plan {
    /// A step at each of `times`; with `parameters`, halfway, the model
    /// assembled again at the same time after the first parameter is
    /// changed, as a design tool re-solves when a dimension moves. The
    /// compiled code keeps values that read t and the parameters: at the
    /// same t, the solver's new scratch (the system was lent out mutably)
    /// and the parameters' bits in the kept values' key must each leave
    /// none stale (the test below fails with both removed).
    fn new(times: &[f64], parameters: bool) -> Plan {
        let mut steps: Vec<PlannedStep> = times
            .iter()
            .map(|&t| PlannedStep { t, changed: false })
            .collect();
        let half = times.len().div_ceil(2);
        if parameters && half > 0 {
            steps.insert(
                half,
                PlannedStep {
                    t: times[half - 1],
                    changed: true,
                },
            );
        }
        Plan { steps }
    }
}

/// What one step gave: the state's q, q̇, q̈, or the error's message.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Outcome {
    Step(Vec<f64>, Vec<f64>, Vec<f64>),
    Error(String),
}

impl Outcome {
    fn of<E: fmt::Display>(result: &Result<&State, E>) -> Outcome {
        match result {
            Ok(s) => Outcome::Step(s.q().to_vec(), s.qd().to_vec(), s.qdd().to_vec()),
            Err(e) => Outcome::Error(e.to_string()),
        }
    }
}

/// The model on the tape interpreter through `plan`, each step's outcome
/// pushed to `outcomes` (up to and with the first error), with the
/// state oracles; how far it got.
pub(crate) fn run_tape(
    model: &kinema::Model,
    plan: &Plan,
    derivatives: bool,
    outcomes: &mut Vec<Outcome>,
) -> Result<Reach, Finding> {
    let mut solver = match Solver::<TapeSystem, Auto>::new(model.system()) {
        Ok(s) => s,
        Err(e) => {
            let _ = e.to_string();
            return Ok(Reach::Analysis);
        }
    };
    for (k, step) in plan.steps.iter().enumerate() {
        let t = step.t;
        let result = step.run(&mut solver);
        outcomes.push(Outcome::of(&result));
        match result {
            Ok(state) => {
                let state = state.clone();
                check_state(&state, t, solver.system())?;
                if k == 0 && derivatives {
                    check_derivatives(solver.system(), &state, solver.model_size())?;
                }
            }
            Err(e) => {
                if e.to_string().trim().is_empty() {
                    return Err(finding("empty-error", "a run-time error without a message"));
                }
                return Ok(Reach::Analysis);
            }
        }
    }
    Ok(Reach::Ran)
}

/// The differential oracle of the two back ends: the model compiled to
/// native code (waited for, so every step runs on it) must give the tape's
/// `outcomes` through `plan` bit for bit, errors word for word. A model
/// the JIT does not take (too large, no native code for the host) is not
/// compared.
pub(crate) fn same_on_jit(
    model: &kinema::Model,
    plan: &Plan,
    outcomes: &[Outcome],
) -> Result<(), Finding> {
    if model.derivation().arena.len() > JIT_COMPARED_NODES {
        return Ok(());
    }
    let model = model.clone().with_backend(Backend::Jit);
    let system = model.system();
    if system.wait_for_jit() != Backend::Jit {
        return Ok(());
    }
    let Ok(mut solver) = Solver::<TapeSystem, Auto>::new(system) else {
        return Err(finding(
            "jit-differs",
            "the solver's analysis failed on the JIT, not on the tape",
        ));
    };
    // The folded LU's compilation, queued when the solver was built.
    solver.system().wait_for_jit();
    for (step, tape) in plan.steps.iter().zip(outcomes) {
        let t = step.t;
        let jit = Outcome::of(&step.run(&mut solver));
        if !same_bits(tape, &jit) {
            let after = if step.changed {
                " (after the first parameter changed)"
            } else {
                ""
            };
            return Err(finding(
                "jit-differs",
                format!("at t = {t}{after} the tape gave {tape:?}, the JIT {jit:?}"),
            ));
        }
    }
    Ok(())
}

impl PlannedStep {
    /// Runs the step: the next time, or the first parameter changed a
    /// little and the model assembled again at the same time.
    fn run<'s>(
        &self,
        solver: &'s mut Solver<TapeSystem, Auto>,
    ) -> Result<&'s State, kinema::Error> {
        if !self.changed {
            return solver.step(self.t);
        }
        if let Some(&p) = solver.system().params().first() {
            let changed = p * 1.001 + 1e-3;
            if changed.is_finite() {
                // Parameter 0 exists: `params().first()` is `Some`.
                let _ = solver.system_mut().set_param_at(0, changed);
            }
        }
        solver.assemble(self.t)
    }
}

/// Equal outcomes, numbers compared bit for bit.
pub(crate) fn same_bits(a: &Outcome, b: &Outcome) -> bool {
    let bits = |x: &[f64], y: &[f64]| {
        x.len() == y.len() && x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits())
    };
    match (a, b) {
        (Outcome::Step(q, qd, qdd), Outcome::Step(r, rd, rdd)) => {
            bits(q, r) && bits(qd, rd) && bits(qdd, rdd)
        }
        (Outcome::Error(x), Outcome::Error(y)) => x == y,
        _ => false,
    }
}

/// Finite differences of Φ along a direction at step `h` (first or second
/// order): the central difference, and the gap between the forward and
/// backward one-sided ones (how much a corner could explain).
pub(crate) fn differences(
    system: &TapeSystem,
    state: &State,
    h: f64,
    second: bool,
    along: &dyn Fn(&mut [f64], &mut f64, f64),
) -> (Vec<f64>, Vec<f64>) {
    let n = system.len();
    let at = |s: f64| {
        let mut q = state.q().to_vec();
        let mut t = state.t();
        along(&mut q, &mut t, s);
        let mut out = vec![0.0; n];
        system.phi(&mut system.scratch(), &q, t, &mut out);
        out
    };
    let (plus, centre, minus) = (at(h), at(0.0), at(-h));
    if second {
        let (plus2, minus2) = (at(2.0 * h), at(-2.0 * h));
        let h2 = h * h;
        let central = (0..n)
            .map(|i| (plus[i] - 2.0 * centre[i] + minus[i]) / h2)
            .collect();
        let kink = (0..n)
            .map(|i| {
                let forward = (plus2[i] - 2.0 * plus[i] + centre[i]) / h2;
                let backward = (centre[i] - 2.0 * minus[i] + minus2[i]) / h2;
                (forward - backward).abs()
            })
            .collect();
        (central, kink)
    } else {
        let central = (0..n).map(|i| (plus[i] - minus[i]) / (2.0 * h)).collect();
        let kink = (0..n)
            .map(|i| ((plus[i] - centre[i]) / h - (centre[i] - minus[i]) / h).abs())
            .collect();
        (central, kink)
    }
}

/// Compares `exact` with finite differences at steps `h` and `h / 4`: the
/// first entry where both differences disagree with `exact` by more than the
/// tolerance and agree with each other (rounding noise and truncation make
/// them differ), and where no corner explains it (`kink`: the gap between
/// the one-sided differences at `h`, as large as the mismatch when Φ has a
/// corner there, as t·atan2(t, t) has at 0).
pub(crate) fn disagreement(
    exact: &[f64],
    coarse: &[f64],
    fine: &[f64],
    kink: &[f64],
    relative: f64,
) -> Option<usize> {
    (0..exact.len()).find(|&i| {
        let (e, c, f) = (exact[i], coarse[i], fine[i]);
        let k = kink.get(i).copied().unwrap_or(f64::INFINITY);
        if !(e.is_finite() && c.is_finite() && f.is_finite() && k.is_finite()) {
            return false;
        }
        let tolerance = relative * (1.0 + e.abs().max(c.abs()));
        let off_f = (f - e).abs();
        // Whether the two differences resolve the derivative: judged on
        // their own scale, not the derived value's (a derived 1e15 against
        // differences of 1e5 and 3e7 — cos(3e7 t), which steps of 1e-3
        // cannot resolve — would otherwise pass under a tolerance of 1e11).
        let resolved = (c - f).abs() <= 0.01 * c.abs().max(f.abs()) + relative * (1.0 + c.abs());
        (c - e).abs() > tolerance
            && off_f > tolerance
            && (c - f).abs() < 0.01 * off_f
            && resolved
            && k < 0.1 * off_f
    })
}

/// The derivative check of one quantity, as a finding.
pub(crate) struct Check<'a> {
    kind: &'static str,
    what: &'a str,
    exact: &'a [f64],
    coarse: &'a [f64],
    fine: &'a [f64],
    kink: &'a [f64],
    relative: f64,
}

impl Check<'_> {
    fn run(&self, system: &TapeSystem, t: f64) -> Result<(), Finding> {
        match disagreement(self.exact, self.coarse, self.fine, self.kink, self.relative) {
            None => Ok(()),
            Some(i) => Err(finding(
                self.kind,
                format!(
                    "{} of equation {} at t = {t}: derived {:e}, finite differences {:e} and {:e}",
                    self.what,
                    system.equation_name(i),
                    self.exact[i],
                    self.coarse[i],
                    self.fine[i]
                ),
            )),
        }
    }
}

/// The derivation against finite differences at a converged state: each
/// column of Φ_q, ν = −Φ_t, and γ = −d²Φ/ds² along (q + s q̇, t + s).
/// Only where every number is moderate, so that differences are accurate,
/// and not at a state the runtime flags at a kink (finding F16) or with an
/// equation its own arithmetic does not determine
/// (`TapeSystem::imprecision`, at the model's `size`): there the
/// derivatives are not defined, or differences of rounding, and the
/// runtime says so.
pub(crate) fn check_derivatives(
    system: &TapeSystem,
    state: &State,
    size: f64,
) -> Result<(), Finding> {
    let n = system.len();
    let moderate = |v: &[f64]| v.iter().all(|x| x.abs() < 1e3);
    if n == 0 || n > 60 || !moderate(state.q()) || !moderate(state.qd()) || state.t().abs() > 1e3 {
        return Ok(());
    }
    if state.kink().is_some()
        || system
            .imprecision(
                &mut system.scratch(),
                state,
                size,
                kinema::PrecisionScope::All,
            )
            .is_some()
    {
        return Ok(());
    }
    let t = state.t();
    let pattern = system.jacobian_pattern().to_vec();
    let mut values = vec![0.0; pattern.len()];
    system.jacobian(&mut system.scratch(), state.q(), t, &mut values);
    let mut phi = vec![0.0; n];
    system.phi(&mut system.scratch(), state.q(), t, &mut phi);
    if !moderate(&values) || !moderate(&phi) {
        return Ok(());
    }
    for j in 0..n {
        let mut column = vec![0.0; n];
        for (&(r, c), &v) in pattern.iter().zip(&values) {
            if c as usize == j
                && let Some(slot) = column.get_mut(r as usize)
            {
                *slot = v;
            }
        }
        let h = 1e-4 * (1.0 + state.q()[j].abs());
        let step = |q: &mut [f64], _: &mut f64, s: f64| q[j] += s;
        let (coarse, kink) = differences(system, state, h, false, &step);
        let (fine, _) = differences(system, state, h / 4.0, false, &step);
        let what = format!("Φ_q column {}", system.coordinate_name(j));
        Check {
            kind: "jacobian-mismatch",
            what: &what,
            exact: &column,
            coarse: &coarse,
            fine: &fine,
            kink: &kink,
            relative: 1e-5,
        }
        .run(system, t)?;
    }
    let mut nu = vec![0.0; n];
    system.nu(&mut system.scratch(), state.q(), t, &mut nu);
    let minus_nu: Vec<f64> = nu.iter().map(|v| -v).collect();
    let time = |_: &mut [f64], t: &mut f64, s: f64| *t += s;
    let h = 1e-4 * (1.0 + t.abs());
    let (coarse, kink) = differences(system, state, h, false, &time);
    let (fine, _) = differences(system, state, h / 4.0, false, &time);
    Check {
        kind: "nu-mismatch",
        what: "Φ_t (−ν)",
        exact: &minus_nu,
        coarse: &coarse,
        fine: &fine,
        kink: &kink,
        relative: 1e-5,
    }
    .run(system, t)?;
    let mut gamma = vec![0.0; n];
    system.gamma(&mut system.scratch(), state.q(), state.qd(), t, &mut gamma);
    let minus_gamma: Vec<f64> = gamma.iter().map(|v| -v).collect();
    let qd = state.qd().to_vec();
    let path = move |q: &mut [f64], t: &mut f64, s: f64| {
        for (x, v) in q.iter_mut().zip(&qd) {
            *x += s * v;
        }
        *t += s;
    };
    let h = 1e-3;
    let (coarse, kink) = differences(system, state, h, true, &path);
    let (fine, _) = differences(system, state, h / 4.0, true, &path);
    Check {
        kind: "gamma-mismatch",
        what: "d²Φ/ds² (−γ)",
        exact: &minus_gamma,
        coarse: &coarse,
        fine: &fine,
        kink: &kink,
        relative: 1e-4,
    }
    .run(system, t)
}

/// Whether every number literal of a model is 0 or between 1e-3 and 1e4 in
/// magnitude and no `tan` meets a multiple of π/2 there: then finite
/// differences of its equations are accurate enough to judge derivatives.
pub(crate) fn moderate_literals(source: &str) -> bool {
    if source.contains("tan(pi") {
        return false;
    }
    let mut chars = source.char_indices().peekable();
    let bytes = source.as_bytes();
    while let Some((i, c)) = chars.next() {
        let starts_number = c.is_ascii_digit()
            && (i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_'));
        if !starts_number {
            continue;
        }
        let mut end = i + 1;
        while end < bytes.len()
            && (bytes[end].is_ascii_digit()
                || bytes[end] == b'.'
                || bytes[end] == b'e'
                || bytes[end] == b'E'
                || ((bytes[end] == b'-' || bytes[end] == b'+')
                    && matches!(bytes[end - 1], b'e' | b'E')))
        {
            end += 1;
        }
        while chars.peek().is_some_and(|&(k, _)| k < end) {
            chars.next();
        }
        let Ok(v) = source[i..end].parse::<f64>() else {
            return false;
        };
        if v != 0.0 && !(1e-3..=1e4).contains(&v.abs()) {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outcomes_compare_bit_for_bit() {
        let step = |x: f64| Outcome::Step(vec![1.0, x], vec![0.0], vec![2.0]);
        assert!(same_bits(&step(0.5), &step(0.5)));
        assert!(!same_bits(&step(0.5), &step(0.5f64.next_up())));
        assert!(!same_bits(&step(0.0), &step(-0.0)));
        assert!(!same_bits(
            &step(0.5),
            &Outcome::Step(vec![1.0], vec![0.0], vec![2.0])
        ));
        let error = |m: &str| Outcome::Error(m.to_owned());
        assert!(same_bits(&error("singular"), &error("singular")));
        assert!(!same_bits(&error("singular"), &error("branch")));
        assert!(!same_bits(&error("singular"), &step(0.5)));
    }

    /// A model run on the tape and on the JIT: the oracle finds them equal
    /// (and compares: the JIT's compilation is waited for).
    #[test]
    fn a_model_runs_the_same_on_both_back_ends() {
        // A parameter in a time term (kept by the compiled code, keyed by
        // t and the parameter), changed halfway through the run.
        let src = "mechanism P { param w = 4; body b { guess: (0.5, 0.8, 1.0) } \
                   joint pin: revolute(ground(0, 0), b(-1, 0)); \
                   driver d: b.phi == sin(w * t) + t * t; }";
        let model = match kinema::Model::from_source(src, "p.kin") {
            Ok(m) => m.with_backend(Backend::Tape),
            Err(e) => panic!("{e}"),
        };
        let plan = Plan::new(&[0.0, 0.1, 0.2, 0.3, 0.4, 0.5], true);
        let steps: Vec<(f64, bool)> = plan.steps.iter().map(|s| (s.t, s.changed)).collect();
        assert_eq!(steps[2..5], [(0.2, false), (0.2, true), (0.3, false)]);
        let mut outcomes = Vec::new();
        assert_eq!(run_tape(&model, &plan, true, &mut outcomes), Ok(Reach::Ran));
        assert_eq!(outcomes.len(), 7);
        // The change took: the same time gives another state.
        assert_ne!(outcomes[2], outcomes[3]);
        assert_eq!(same_on_jit(&model, &plan, &outcomes), Ok(()));
        // Outcomes the tape did not give: found different.
        let mut wrong = outcomes.clone();
        if let Some(Outcome::Step(q, _, _)) = wrong.last_mut() {
            q[0] = q[0].next_up();
        }
        assert!(matches!(
            same_on_jit(&model, &plan, &wrong),
            Err(Finding {
                kind: "jit-differs",
                ..
            })
        ));
    }

    fn pendulum() -> TapeSystem {
        let src = "mechanism P { body b { guess: (0.5, 0.8, 1.0) } \
                   joint pin: revolute(ground(0, 0), b(-1, 0)); \
                   driver d: b.phi == 4 * t * t; }";
        match kinema::Model::from_source(src, "p.kin") {
            Ok(m) => m.system(),
            Err(e) => panic!("{e}"),
        }
    }

    #[test]
    fn derivative_mismatch_is_reported_only_when_differences_agree() {
        // A consistent disagreement (a wrong derivative) is a finding…
        let smooth = [0.0, 0.0];
        let wrong = disagreement(&[0.0, 2.0], &[0.0, 1.0], &[0.0, 1.0], &smooth, 1e-5);
        assert_eq!(wrong, Some(1));
        // …differences that disagree with each other (noise) are not…
        assert_eq!(disagreement(&[2.0], &[1.0], &[1.5], &smooth, 1e-5), None);
        // …nor a corner, where the one-sided differences part…
        assert_eq!(
            disagreement(&[0.0], &[-0.785], &[-0.785], &[3.0], 1e-5),
            None
        );
        // …and agreement within the tolerance is fine.
        assert_eq!(
            disagreement(&[2.0], &[2.0 + 1e-7], &[2.0], &smooth, 1e-5),
            None
        );
    }

    #[test]
    fn derivatives_of_a_correct_model_pass() {
        let mut solver = match Solver::<TapeSystem, Auto>::new(pendulum()) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        };
        let state = match solver.step(0.3) {
            Ok(s) => s.clone(),
            Err(e) => panic!("{e}"),
        };
        assert_eq!(
            check_derivatives(solver.system(), &state, solver.model_size()),
            Ok(())
        );
    }

    #[test]
    fn moderate_literals_judges_every_number() {
        assert!(moderate_literals("b.x == 0.3 * t + 2e3; b1.y == 0"));
        assert!(!moderate_literals("b.x == 1e15 + t"));
        assert!(!moderate_literals("b.x == 0.00001 * t"));
        assert!(!moderate_literals("b.x == tan(pi / 2) + t"));
        // Digits inside names are not numbers.
        assert!(moderate_literals("b123456789.x == t"));
    }
}
