//! Forward dynamics and static equilibrium from Python, as `kinema run`
//! does them (crates/kinema-cli/src/cli/forward.rs and equilibrium.rs):
//! the same facade calls in the same order, so the rows are the CLI's CSV
//! rows bit for bit.
//!
//! What is still repeated from the CLI (each marked "as the CLI's …"
//! below): the integrator's start, the option checks and the failure
//! message. The rest is the facade's: which motion a model runs
//! (`kinema::forward::dynamics_run`), the integrators, the passage monitor,
//! the equilibrium search, a row's λ, reactions and efforts
//! (`kinema::dynamics::DynamicsRow`), the search for an equation undefined
//! in a step (`kinema::undefined_between`), column selection and names.

use kinema::equilibrium::{Equilibrium, EquilibriumError};
use kinema::forward::TapeForward;
use kinema::integrate::{Consistency, Integrator as MotionEngine, Monitor, Prescribed};
use kinema::{Accurate, Hht, HhtOptions, IntegrateError, PrecisionScope, System, TapeSystem};

/// Default step of a `.kin` model's forward dynamics (as `kinema run`).
pub const DEFAULT_STEP: f64 = 1e-3;
/// Default tolerance of the accurate integrator (as `kinema run`).
pub const DEFAULT_RTOL: f64 = 1e-8;
/// The columns `energy=True` adds after the dynamics columns.
pub const ENERGY_COLUMNS: [&str; 3] = ["energy.kinetic", "energy.potential", "energy.work"];

pub use kinema::forward::DynamicsRun;

/// The start of a motion: q₀ and q̇₀ as the model declares them at the
/// system's parameter values. At the declared values these are the
/// derivation's own numbers (what `kinema run` starts from); with other
/// values the guess and `velocity` expressions are evaluated at them.
/// `adm_qd0`: a simEngine2D body's `qd0`, which overrides.
pub fn start_state(
    model: &kinema::Model,
    system: &TapeSystem,
    adm_qd0: &[Option<[f64; 3]>],
) -> (Vec<f64>, Vec<f64>) {
    let d = model.derivation();
    let params = system.params();
    let (q0, mut qd0) = if params == d.param_values().as_slice() {
        (model.initial_configuration(), model.initial_velocities())
    } else {
        let q0 = d
            .coordinates
            .iter()
            .map(|c| d.eval(c.guess, &[], &[], 0.0, params))
            .collect();
        let qd0 = d
            .coordinates
            .iter()
            .map(|c| {
                c.initial_velocity
                    .map_or(0.0, |e| d.eval(e, &[], &[], 0.0, params))
            })
            .collect();
        (q0, qd0)
    };
    qd0.resize(d.nc(), 0.0);
    for (k, v) in adm_qd0.iter().enumerate() {
        if let (Some(v), Some(slot)) = (v, qd0.get_mut(3 * k..3 * k + 3)) {
            slot.copy_from_slice(v);
        }
    }
    (q0, qd0)
}

/// How a model with inertia runs, or `None` (kinematics and inverse
/// dynamics), at the system's params from `q0` (the facade's
/// [`kinema::forward::dynamics_run`], which `kinema run` calls too).
pub fn dynamics_run(model: &kinema::Model, system: &TapeSystem, q0: &[f64]) -> Option<DynamicsRun> {
    kinema::forward::dynamics_run(model.derivation(), system.params(), q0)
}

/// The integrator of a forward run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integrator {
    /// HHT-α at a fixed step.
    Hht,
    /// Dormand–Prince 5(4) on the index-1 form, projected.
    Accurate,
}

/// The options of a forward run, checked.
pub struct ForwardOptions {
    pub integrator: Integrator,
    /// The largest step (HHT).
    pub step: f64,
    pub rtol: f64,
    pub project_velocity: bool,
    pub energy: bool,
    /// A simEngine2D model: reactions name their bodies `body1`/`body2`.
    pub adm: bool,
}

/// A singular configuration passed, as data.
pub struct PassageOut {
    pub t: f64,
    pub sigma: f64,
    pub equations: Vec<String>,
    pub message: String,
}

/// What a forward run produced (made with the GIL released).
pub struct ForwardOutput {
    pub values: Vec<f64>,
    pub rows: usize,
    pub passages: Vec<PassageOut>,
    /// The redundancy at the start: (message, redundant equations).
    pub redundancy: Option<(String, Vec<String>)>,
    pub consistency: Consistency,
    /// Whether the consistency corrections exceed rounding at the start.
    pub corrected: bool,
    /// (t, equation, message) of rows an equation's arithmetic does not
    /// determine.
    pub imprecise: Vec<(f64, String, String)>,
    /// The integrator and its counters, as the CLI's summary line.
    pub integrator: String,
    /// [kinetic, potential, work of the other forces] at the end and
    /// [kinetic, potential] at the start.
    pub energies: [f64; 5],
    pub error: Option<String>,
    pub prescribed: bool,
}

/// The integrator of a run (as the CLI's `Engine`).
struct Engine {
    motion: Box<dyn MotionEngine<TapeForward>>,
    head: String,
    prescribed: bool,
}

/// Starts the motion as the CLI's `Motion::start`: HHT from (q₀, q̇₀) made
/// consistent; the accurate mode from HHT's consistent state; the
/// prescribed motion by minimum-norm solves.
fn start(
    fwd: TapeForward,
    kind: DynamicsRun,
    [q0, qd0]: [&[f64]; 2],
    t0: f64,
    o: &ForwardOptions,
) -> Result<(Engine, Consistency), String> {
    let start_failure = |e: IntegrateError| format!("forward dynamics cannot start: {e}");
    if kind == DynamicsRun::Prescribed {
        let p = Prescribed::new(fwd, q0, t0)
            .map_err(|e| format!("the prescribed motion cannot start: {e}"))?;
        return Ok((
            Engine {
                motion: Box::new(p),
                head: "prescribed motion with redundant rows (minimum-norm solves at each output \
                       time)"
                    .to_owned(),
                prescribed: true,
            },
            Consistency::default(),
        ));
    }
    let accurate_system = (o.integrator == Integrator::Accurate).then(|| fwd.clone());
    let options = HhtOptions {
        project_velocity: o.project_velocity,
        ..HhtOptions::default()
    };
    let (hht, consistency) = Hht::new(fwd, q0, qd0, t0, options).map_err(start_failure)?;
    let engine = match accurate_system {
        None => Engine {
            head: format!(
                "HHT-α (α = -0.1, β = 0.3025, γ = 0.6){}, step ≤ {:e}",
                if o.project_velocity {
                    " with velocity projection"
                } else {
                    ""
                },
                o.step
            ),
            motion: Box::new(hht),
            prescribed: false,
        },
        Some(system) => Engine {
            motion: Box::new(
                Accurate::new(system, hht.q(), hht.qd(), t0, o.rtol).map_err(start_failure)?,
            ),
            head: format!(
                "accurate (Dormand–Prince 5(4), index-1 with projection), rtol {:e}",
                o.rtol
            ),
            prescribed: false,
        },
    };
    Ok((engine, consistency))
}

/// The error message of a run that stopped (as the CLI's `step_failure`,
/// without the CSV's note).
fn failure_message(
    file: &str,
    e: Option<&IntegrateError>,
    undefined: Option<&kinema::Error>,
    monitor: &Monitor,
) -> String {
    let mut message = format!("forward dynamics of `{file}`: ");
    match (undefined, e) {
        (Some(u), Some(e)) => {
            message.push_str(&format!("{u}\n  = note: the integrator stopped: {e}"));
        }
        (Some(u), None) => message.push_str(&format!("{u}: no step can be taken through it")),
        (None, Some(e)) => message.push_str(&e.to_string()),
        (None, None) => message.push_str("the run stopped"),
    }
    if monitor.near_singular() {
        message.push_str(&format!(
            "\n  = note: the last state computed is at a singular configuration or next to one \
             (smallest scaled singular value of Φ_q {:.1e}): the step failed there",
            monitor.last_s()
        ));
    }
    message
}

/// What a forward run takes: the model and the system it runs on, how and
/// from where it moves, and what it writes when.
pub struct ForwardRun<'a> {
    pub model: &'a kinema::Model,
    /// The system at the run's parameters, on the run's back end (points,
    /// outputs, reactions).
    pub system: &'a TapeSystem,
    /// The model's file, named in messages.
    pub file: &'a str,
    /// Forward dynamics or the prescribed motion.
    pub kind: DynamicsRun,
    /// q₀ and q̇₀ as declared ([`start_state`]), made consistent by the
    /// integrator's start.
    pub start: [&'a [f64]; 2],
    /// The output times, increasing; the motion starts at the first.
    pub times: &'a [f64],
    /// The columns of each row before the dynamics columns.
    pub selection: &'a kinema::columns::Selection,
    pub options: &'a ForwardOptions,
}

/// Forward dynamics (or the prescribed motion) through `run.times`
/// (increasing, from t₀ = the first), a row at each, as `kinema run`:
/// `run.selection`'s columns, then λ, reactions, efforts (and the
/// energies). Setup failures are `Err`; a failed step is `Ok` with `error`
/// set and the rows before it.
pub fn run_forward(run: &ForwardRun<'_>) -> Result<ForwardOutput, String> {
    let &ForwardRun {
        model,
        system,
        file,
        kind,
        start: [q0, qd0],
        times: outputs_t,
        selection,
        options: o,
    } = run;
    let d = model.derivation();
    let Some(fwd) = TapeForward::new(d, system.params()) else {
        return Err(format!(
            "`{file}` has no inertia: forward dynamics needs `mass` and `inertia` on every body"
        ));
    };
    let mut gravity_of = fwd.clone();
    let t0 = outputs_t.first().copied().unwrap_or(0.0);
    let (mut engine, consistency) = start(fwd, kind, [q0, qd0], t0, o)?;
    // Corrections at the rounding of the start are not news (as the CLI).
    let roundoff = 1e-12 * (1.0 + q0.iter().chain(qd0).fold(0.0_f64, |m, x| m.max(x.abs())));
    let corrected = consistency.dq > roundoff || consistency.dqd > roundoff;
    let redundancy = engine.motion.monitor().redundancy().map(|dep| {
        (
            format!(
                "redundant constraints at the start: {dep}; the motion is determined, but the \
                 constraint forces of these equations are not: their λ, reactions and driver \
                 efforts are the minimum-norm values the solver gives"
            ),
            dep.redundant.clone(),
        )
    });
    let v0 = gravity_of.gravity_potential(engine.motion.q()) + 0.0;
    let ke0 = engine.motion.kinetic_energy();

    let mut row = kinema::dynamics::DynamicsRow::new(system, d.rows.len());
    let orders = selection.orders();
    let mut line: Vec<f64> = Vec::new();
    let mut values: Vec<f64> = Vec::new();
    let mut out = ForwardOutput {
        values: Vec::new(),
        rows: 0,
        passages: Vec::new(),
        redundancy,
        consistency,
        corrected,
        imprecise: Vec::new(),
        integrator: String::new(),
        energies: [0.0; 5],
        error: None,
        prescribed: engine.prescribed,
    };
    let mut names: Option<Vec<String>> = None;
    for (k, &t) in outputs_t.iter().enumerate() {
        if k > 0 {
            let interval = (engine.motion.t(), t, f64::NAN);
            let ahead =
                kinema::undefined_between(system, row.scratch(), engine.motion.q(), interval);
            let result = match ahead {
                Some(u) => Err((None, Some(u))),
                None => engine
                    .motion
                    .advance_to(t, o.step)
                    .map_err(|e| (Some(e), None)),
            };
            if let Err((e, undefined)) = result {
                let undefined = undefined.or_else(|| {
                    let failed_at = match &e {
                        Some(
                            IntegrateError::NoConvergence { t, .. }
                            | IntegrateError::Singular { t, .. }
                            | IntegrateError::NonFinite { t, .. },
                        ) => *t,
                        _ => f64::NAN,
                    };
                    let bracket = (engine.motion.t(), t, failed_at);
                    kinema::undefined_between(system, row.scratch(), engine.motion.q(), bracket)
                });
                out.error = Some(failure_message(
                    file,
                    e.as_ref(),
                    undefined.as_ref(),
                    engine.motion.monitor(),
                ));
                break;
            }
        }
        let motion = &engine.motion;
        let at = kinema::Motion {
            t: motion.t(),
            q: motion.q(),
            qd: motion.qd(),
            qdd: motion.qdd(),
        };
        if let Err(e) = row.fill(system, at, motion.lambda()) {
            out.error = Some(format!(
                "forward dynamics of `{file}`: the reactions at t = {}: {e}",
                at.t
            ));
            break;
        }
        let scope = if k == 0 {
            PrecisionScope::All
        } else {
            PrecisionScope::Timed
        };
        if let Some(i) = system.imprecision_at(row.scratch(), engine.motion.q(), t, 0.0, 1.0, scope)
        {
            let name = system.equation_name(i.equation).to_owned();
            let message = format!(
                "equation `{name}` is not determined by its own arithmetic: its rounding error, up \
                 to {:.1e}, moves the coordinates by up to {:.1e} against their scale {:.1e}",
                i.error, i.shift, i.scale
            );
            out.imprecise.push((t, name, message));
        }
        let motion = &mut engine.motion;
        line.clear();
        line.push(t);
        let states = [motion.q(), motion.qd(), motion.qdd()];
        for v in &states[..orders] {
            for &c in &selection.coordinates {
                line.push(v.get(c).copied().unwrap_or(f64::NAN));
            }
        }
        for v in &row.outputs()[..orders] {
            for &c in &selection.outputs {
                line.push(v.get(c).copied().unwrap_or(f64::NAN));
            }
        }
        line.extend_from_slice(row.dynamics());
        if o.energy {
            let v = gravity_of.gravity_potential(motion.q()) + 0.0;
            let work = motion.work() - (v0 - v);
            line.extend([motion.kinetic_energy(), v, work]);
        }
        // Never a silent NaN or ∞ (as the CLI's CSV).
        if let Some(j) = line.iter().position(|v| !v.is_finite()) {
            let names =
                names.get_or_insert_with(|| columns(model, system, selection, (o.adm, o.energy)));
            out.error = Some(format!(
                "at t = {t}: column `{}` is {} (it overflowed)",
                names.get(j).map_or("?", String::as_str),
                line[j]
            ));
            break;
        }
        values.extend_from_slice(&line);
        out.rows += 1;
    }
    let motion = &mut engine.motion;
    out.passages = motion
        .monitor()
        .passages()
        .iter()
        .map(|p| PassageOut {
            t: p.t,
            sigma: p.sigma,
            equations: p.dependency.equations.clone(),
            message: p.to_string(),
        })
        .collect();
    let v = gravity_of.gravity_potential(motion.q()) + 0.0;
    let work = motion.work() - (v0 - v);
    out.energies = [motion.kinetic_energy(), v, work, ke0, v0];
    out.integrator = format!("{}: {}", engine.head, engine.motion.counters());
    out.values = values;
    Ok(out)
}

/// The columns of a forward run or an equilibrium: `t`, the selection,
/// λ, reactions, efforts (as the CLI's `dynamics::column_names`), the
/// energies with `energy`.
pub fn columns(
    model: &kinema::Model,
    system: &TapeSystem,
    selection: &kinema::columns::Selection,
    (adm, energy): (bool, bool),
) -> Vec<String> {
    let d = model.derivation();
    let mut names = vec!["t".to_owned()];
    names.extend(selection.header(d));
    names.extend(system.dynamics_column_names(d.rows.len(), adm));
    if energy {
        names.extend(ENERGY_COLUMNS.map(String::from));
    }
    names
}

/// The stable static equilibrium at t = 0 from the guess at the system's
/// parameters, as `kinema run --equilibrium`: its row (t, q, q̇ = q̈ = 0,
/// named points and outputs at rest, λ, reactions, efforts).
pub fn equilibrium(
    model: &kinema::Model,
    system: &TapeSystem,
    selection: &kinema::columns::Selection,
) -> Result<(Equilibrium, Vec<f64>), EquilibriumError> {
    let d = model.derivation();
    let params = system.params();
    let eq = if params == d.param_values().as_slice() {
        model.equilibrium(0.0)?
    } else {
        let mut guess = vec![0.0; d.nc()];
        System::initial_guess(system, &mut guess);
        kinema::equilibrium::equilibrium_from(d, params, &guess, 0.0)?
    };
    let zeros = vec![0.0; d.nc()];
    let mut dynamics = kinema::dynamics::DynamicsRow::new(system, d.rows.len());
    let at = kinema::Motion {
        t: eq.t,
        q: &eq.q,
        qd: &zeros,
        qdd: &zeros,
    };
    // M and Q_A were finite for the equilibrium's own test: only an arm
    // can fail here.
    dynamics
        .fill(system, at, &eq.lambda)
        .map_err(|_| EquilibriumError::NonFinite {
            what: "a reaction's arm",
        })?;
    let mut row = vec![eq.t];
    let (states, results) = ([&eq.q, &zeros, &zeros], dynamics.outputs());
    for v in &states[..selection.orders()] {
        row.extend(selection.coordinates.iter().map(|&c| v[c]));
    }
    for v in &results[..selection.orders()] {
        row.extend(selection.outputs.iter().map(|&c| v[c]));
    }
    row.extend_from_slice(dynamics.dynamics());
    Ok((eq, row))
}
