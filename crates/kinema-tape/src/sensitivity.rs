//! Parameter sensitivities on the tape back end (issue 40): the derivation's
//! symbolic sensitivity systems ([`kinema_model::sensitivity`]) compiled to
//! tapes, and solved after a solver step with that step's factorization of
//! Φ_q — one extra solve per parameter and level, no allocation per step.
//!
//! ```
//! let model = kinema::Model::from_source(
//!     "mechanism Pendulum {
//!         param l = 1.0;
//!         body bar { guess: (0.5, 0.8, 1.0) }
//!         joint pin: revolute(ground(0, 0), bar(-l, 0));
//!         driver swing: bar.phi == t;
//!     }",
//!     "pendulum.kin",
//! )?;
//! let mut sens = model.sensitivity(&["l"]).map_err(|e| e.to_string()).unwrap();
//! let mut solver = model.solver(kinema::Options::default())?;
//! solver.step(0.5)?;
//! sens.compute(&mut solver)?;
//! // bar.x = l cos t: ∂x/∂l = cos t.
//! let [dq, _, _] = sens.coordinates(0);
//! assert!((dq[0] - 0.5f64.cos()).abs() < 1e-12);
//! # Ok::<(), kinema::Error>(())
//! ```

use kinema_expr::{ExprId, Tape, TapeInputs};
use kinema_model::{Derivation, ParamSensitivity, SensitivityError};
use kinema_runtime::linalg::LinearSolver;
use kinema_runtime::sensitivity::{Augmented, Sensitivities, SensitivitySystem};
use kinema_runtime::{Error, Solver};

use crate::model::{Model, TapeSystem};

/// The compiled sensitivity systems of some params of a model, and the
/// buffers their values are computed in ([`Sensitivity::compute`]): the
/// runtime's one algorithm ([`Solver::sensitivities_of`]) over the tapes
/// ([`Tapes`], its [`SensitivitySystem`]).
#[derive(Clone, Debug)]
pub struct Sensitivity {
    tapes: Tapes,
    values: Sensitivities<Tapes>,
}

/// The tapes of every param, and the system's parameter values they read:
/// the tape back end's [`SensitivitySystem`].
#[derive(Clone, Debug)]
struct Tapes {
    names: Vec<String>,
    params: Vec<Level>,
    /// Coordinates, rows of Φ, result columns.
    nc: usize,
    n: usize,
    m: usize,
    param_values: Vec<f64>,
}

/// One param's three tapes, one per level: each reads the solutions of the
/// levels before it.
#[derive(Clone, Debug)]
struct Level {
    /// Φ_p (rows). Reads q, p, t.
    position: Tape,
    /// The velocity right-hand side (rows), y_p (m), W's values, (y_p)_q's
    /// values, y_q's values. Reads q, q̇, s, p, t.
    velocity: Tape,
    /// The acceleration right-hand side without q̈ (rows), ẏ_p (m), ÿ_p's
    /// terms without q̈ and s̈ (m). Reads q, q̇, s, ṡ, p, t.
    acceleration: Tape,
    /// W's entries: (row, coordinate), values at `velocity`'s outputs
    /// from `w_base` on.
    w: Vec<(usize, usize)>,
    w_base: usize,
    /// Per result column, (coordinate, output of `velocity`) of the q̈
    /// coefficients (y_p)_q, then of y_q (the s̈ coefficients).
    qdd: Vec<Vec<(usize, usize)>>,
    sdd: Vec<Vec<(usize, usize)>>,
}

impl Level {
    fn new(d: &Derivation, p: &ParamSensitivity) -> Level {
        let a = &d.arena;
        let n = d.phi.len();
        let m = d.outputs.len();
        let mut velocity: Vec<ExprId> = Vec::with_capacity(2 * n + 2 * m);
        velocity.extend(&p.velocity_rhs);
        velocity.extend(p.outputs.iter().map(|o| o.value));
        let w_base = velocity.len();
        let w = p
            .acceleration_qdd
            .entries
            .iter()
            .map(|e| {
                velocity.push(e.expr);
                (e.row as usize, e.col as usize)
            })
            .collect();
        let mut qdd = Vec::with_capacity(m);
        for o in &p.outputs {
            let row = o
                .qdd
                .iter()
                .map(|&(k, e)| {
                    velocity.push(e);
                    (k as usize, velocity.len() - 1)
                })
                .collect();
            qdd.push(row);
        }
        let mut sdd = Vec::with_capacity(m);
        for o in &d.outputs {
            let row = o
                .jacobian
                .iter()
                .map(|&(k, e)| {
                    velocity.push(e);
                    (k as usize, velocity.len() - 1)
                })
                .collect();
            sdd.push(row);
        }
        let mut acceleration: Vec<ExprId> = Vec::with_capacity(n + 2 * m);
        acceleration.extend(&p.acceleration_rhs);
        acceleration.extend(p.outputs.iter().map(|o| o.velocity));
        acceleration.extend(p.outputs.iter().map(|o| o.acceleration));
        let tapes = [
            Tape::compile(a, &p.phi_p),
            Tape::compile(a, &velocity),
            Tape::compile(a, &acceleration),
        ];
        let [position, velocity, acceleration] = tapes;
        Level {
            position,
            velocity,
            acceleration,
            w,
            w_base,
            qdd,
            sdd,
        }
    }
}

impl Model {
    /// [`sensitivity`](Self::sensitivity) with respect to every param of
    /// the model, in declaration order.
    ///
    /// # Errors
    /// As [`sensitivity`](Self::sensitivity) (a model without params).
    pub fn sensitivity_to_every_param(&self) -> Result<Sensitivity, SensitivityError> {
        let d = self.derivation();
        let names: Vec<&str> = d.params.iter().map(|p| p.name.as_str()).collect();
        self.sensitivity(&names)
    }

    /// The sensitivities of this model's solution and result columns with
    /// respect to the params `params` (in that order), derived
    /// symbolically and compiled to tapes; compute them after each solver
    /// step with [`Sensitivity::compute`]. For λ, reactions and efforts
    /// (a model with inertia), see [`Model::dynamics_sensitivity`].
    ///
    /// # Errors
    /// A name that is not a param of the model or is named twice (the
    /// message names the model's params), or derivatives too large (see
    /// [`Derivation::sensitivities`]).
    pub fn sensitivity(&self, params: &[&str]) -> Result<Sensitivity, SensitivityError> {
        let mut d = self.derivation().clone();
        let s = d.sensitivities(params)?;
        let tapes = Tapes {
            names: s.params.iter().map(|p| p.name.clone()).collect(),
            params: s.params.iter().map(|p| Level::new(&d, p)).collect(),
            nc: d.nc(),
            n: d.phi.len(),
            m: d.outputs.len(),
            param_values: d.param_values(),
        };
        let values = Sensitivities::new(&tapes);
        Ok(Sensitivity { tapes, values })
    }
}

impl Sensitivity {
    /// The params, in the order asked for.
    #[must_use]
    pub fn params(&self) -> &[String] {
        &self.tapes.names
    }

    /// Computes every param's sensitivities at the solver's current state
    /// (after a successful [`Solver::step`]), with its parameter values,
    /// reusing the step's factorization of Φ_q
    /// ([`Solver::solve_at_state`]): three solves per param. Does not
    /// allocate.
    ///
    /// # Errors
    /// No state; Φ_q singular when the state's factorization had to be
    /// made again (an interpolated near-singular row); a system with
    /// another number of coordinates or params than the model this was
    /// built from ([`kinema_runtime::LinalgError::Dimension`]). A value
    /// that is not finite is written as it is (as the solver's rates
    /// would not be: check them where they are written).
    pub fn compute<L: LinearSolver>(
        &mut self,
        solver: &mut Solver<TapeSystem, L>,
    ) -> Result<(), Error> {
        self.compute_levels(solver, false)
    }

    /// [`compute`](Self::compute) at the position level only: ∂q/∂p and
    /// ∂y/∂p (the first of [`coordinates`](Self::coordinates)' and
    /// [`outputs`](Self::outputs)' three), one solve per param; the rates'
    /// levels are set to NaN
    /// ([`Solver::position_sensitivities_of`]).
    ///
    /// # Errors
    /// As [`compute`](Self::compute).
    pub fn compute_positions<L: LinearSolver>(
        &mut self,
        solver: &mut Solver<TapeSystem, L>,
    ) -> Result<(), Error> {
        self.compute_levels(solver, true)
    }

    fn compute_levels<L: LinearSolver>(
        &mut self,
        solver: &mut Solver<TapeSystem, L>,
        positions_only: bool,
    ) -> Result<(), Error> {
        let tapes = &mut self.tapes;
        let dimension = |what, expected, found| {
            Error::Setup(kinema_runtime::LinalgError::Dimension {
                what,
                expected,
                found,
            })
        };
        if tapes.n != tapes.nc {
            return Err(dimension(
                "equations of the model (sensitivities need NDOF = 0)",
                tapes.nc,
                tapes.n,
            ));
        }
        let params = solver.system().params();
        if params.len() != tapes.param_values.len() {
            return Err(dimension(
                "params of the system",
                tapes.param_values.len(),
                params.len(),
            ));
        }
        tapes.param_values.copy_from_slice(params);
        if positions_only {
            solver.position_sensitivities_of(&*tapes, &mut self.values)
        } else {
            solver.sensitivities_of(&*tapes, &mut self.values)
        }
    }

    /// ∂q/∂p, ∂q̇/∂p, ∂q̈/∂p for the `k`-th param asked for, at the state
    /// of the last [`compute`](Self::compute), in the order of q.
    ///
    /// # Panics
    /// If `k` is not below the number of params asked for.
    #[must_use]
    pub fn coordinates(&self, k: usize) -> [&[f64]; 3] {
        self.values.coordinates(k)
    }

    /// ∂y/∂p, ∂ẏ/∂p, ∂ÿ/∂p of every result column (named points'
    /// components and outputs, the order of
    /// [`Outputs::outputs`](kinema_runtime::Outputs::outputs)) for the
    /// `k`-th param asked for, at the state of the last
    /// [`compute`](Self::compute).
    ///
    /// # Panics
    /// If `k` is not below the number of params asked for.
    #[must_use]
    pub fn outputs(&self, k: usize) -> [&[f64]; 3] {
        self.values.outputs(k)
    }
}

impl Tapes {
    /// The tapes' inputs at `at`, with the system's parameter values.
    fn inputs<'a>(&'a self, at: &Augmented<'a>) -> TapeInputs<'a> {
        TapeInputs {
            q: at.q,
            qd: at.qd,
            params: &self.param_values,
            t: at.t,
        }
    }
}

/// Registers of each param's three tapes (kept apart: `velocity`'s outputs
/// — W, the q̈ and s̈ coefficients — are read after `acceleration` ran).
type Registers = Vec<[Vec<f64>; 3]>;

impl SensitivitySystem for Tapes {
    type SensitivityScratch = Registers;

    fn sensitivity_scratch(&self) -> Registers {
        self.params
            .iter()
            .map(|l| [&l.position, &l.velocity, &l.acceleration].map(|t| vec![0.0; t.registers()]))
            .collect()
    }

    fn param_count(&self) -> usize {
        self.params.len()
    }

    fn param_name(&self, k: usize) -> &str {
        self.names.get(k).map_or("", String::as_str)
    }

    fn coordinate_count(&self) -> usize {
        self.nc
    }

    fn result_count(&self) -> usize {
        self.m
    }

    fn position_rhs(&self, scratch: &mut Registers, k: usize, at: Augmented<'_>, rhs: &mut [f64]) {
        let (Some(level), Some(registers)) = (self.params.get(k), scratch.get_mut(k)) else {
            rhs.fill(f64::NAN);
            return;
        };
        let inputs = self.inputs(&at);
        eval_into(&level.position, &inputs, &mut registers[0], rhs, -1.0);
    }

    fn velocity_rhs(
        &self,
        scratch: &mut Registers,
        k: usize,
        at: Augmented<'_>,
        rhs: &mut [f64],
        dy: &mut [f64],
    ) {
        let (Some(level), Some(registers)) = (self.params.get(k), scratch.get_mut(k)) else {
            rhs.fill(f64::NAN);
            dy.fill(f64::NAN);
            return;
        };
        let inputs = self.inputs(&at);
        let v = run(&level.velocity, &inputs, &mut registers[1]);
        let n = self.n;
        for (i, r) in rhs.iter_mut().enumerate() {
            *r = if i < n { v.get(i) } else { None }
                .copied()
                .unwrap_or(f64::NAN);
        }
        for (i, y) in dy.iter_mut().enumerate() {
            *y = v.get(n + i).copied().unwrap_or(f64::NAN);
        }
    }

    fn acceleration_rhs(
        &self,
        scratch: &mut Registers,
        k: usize,
        at: Augmented<'_>,
        rhs: &mut [f64],
        dyd: &mut [f64],
        dydd: &mut [f64],
    ) {
        let (Some(level), Some(registers)) = (self.params.get(k), scratch.get_mut(k)) else {
            rhs.fill(f64::NAN);
            dyd.fill(f64::NAN);
            dydd.fill(f64::NAN);
            return;
        };
        let (n, m) = (self.n, self.m);
        let inputs = self.inputs(&at);
        let [_, velocity_registers, acceleration_registers] = registers;
        let v: &[f64] = velocity_registers;
        let v = v.get(..level.velocity.outputs()).unwrap_or(&[]);
        let a = run(&level.acceleration, &inputs, acceleration_registers);
        let qdd = at.qdd;
        let at_q = |col: usize| qdd.get(col).copied().unwrap_or(f64::NAN);
        for (i, r) in rhs.iter_mut().enumerate() {
            *r = if i < n { a.get(i) } else { None }
                .copied()
                .unwrap_or(f64::NAN);
        }
        for (j, &(row, col)) in level.w.iter().enumerate() {
            let w = v.get(level.w_base + j).copied().unwrap_or(f64::NAN);
            if let Some(r) = rhs.get_mut(row) {
                *r -= w * at_q(col);
            }
        }
        // ÿ_p = y_q s̈ + (y_p)_q q̈ + c: here c and the q̈ terms.
        for (i, (yd, ydd)) in dyd.iter_mut().zip(dydd.iter_mut()).enumerate() {
            *yd = a.get(n + i).copied().unwrap_or(f64::NAN);
            let c = a.get(n + m + i).copied().unwrap_or(f64::NAN);
            let q_terms = level.qdd.get(i).map_or(f64::NAN, |row| {
                row.iter().fold(0.0, |acc, &(col, j)| {
                    acc + v.get(j).copied().unwrap_or(f64::NAN) * at_q(col)
                })
            });
            *ydd = c + q_terms;
        }
    }

    fn acceleration_outputs(
        &self,
        scratch: &mut Registers,
        k: usize,
        _at: Augmented<'_>,
        sdd: &[f64],
        dydd: &mut [f64],
    ) {
        let (Some(level), Some(registers)) = (self.params.get(k), scratch.get(k)) else {
            dydd.fill(f64::NAN);
            return;
        };
        let v: &[f64] = &registers[1];
        let v = v.get(..level.velocity.outputs()).unwrap_or(&[]);
        for (i, ydd) in dydd.iter_mut().enumerate() {
            let s_terms = level.sdd.get(i).map_or(f64::NAN, |row| {
                row.iter().fold(0.0, |acc, &(col, j)| {
                    acc + v.get(j).copied().unwrap_or(f64::NAN)
                        * sdd.get(col).copied().unwrap_or(f64::NAN)
                })
            });
            *ydd += s_terms;
        }
    }
}

/// Runs `tape` in `registers`: its outputs, or none if an input is short
/// (then every value read from them is NaN, never a silent number).
fn run<'r>(tape: &Tape, inputs: &TapeInputs<'_>, registers: &'r mut [f64]) -> &'r [f64] {
    tape.eval_in_registers(inputs, registers).unwrap_or(&[])
}

/// `scale` times `tape`'s outputs into `out` (NaN if it cannot run).
fn eval_into(
    tape: &Tape,
    inputs: &TapeInputs<'_>,
    registers: &mut [f64],
    out: &mut [f64],
    scale: f64,
) {
    let v = run(tape, inputs, registers);
    if v.len() < out.len() {
        out.fill(f64::NAN);
        return;
    }
    for (o, &x) in out.iter_mut().zip(v) {
        *o = scale * x;
    }
}
