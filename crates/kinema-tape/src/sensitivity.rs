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
use kinema_runtime::{Error, Solver};

use crate::model::{Model, TapeSystem};

/// The compiled sensitivity systems of some params of a model, and the
/// buffers their values are computed in ([`Sensitivity::compute`]).
#[derive(Clone, Debug)]
pub struct Sensitivity {
    names: Vec<String>,
    params: Vec<Level>,
    /// Coordinates and result columns.
    nc: usize,
    m: usize,
    /// The augmented inputs [q; s] and [q̇; ṡ] (module docs of
    /// [`kinema_model::sensitivity`]), and the system's parameter values.
    q: Vec<f64>,
    qd: Vec<f64>,
    param_values: Vec<f64>,
    /// Per param, ∂q/∂p, ∂q̇/∂p, ∂q̈/∂p (nc each) then ∂y/∂p, ∂ẏ/∂p,
    /// ∂ÿ/∂p (m each).
    values: Vec<f64>,
    /// Φ_q s̈'s right-hand side, then solution.
    rhs: Vec<f64>,
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
    /// Registers of each tape (kept apart: `velocity`'s outputs are read
    /// after `acceleration` ran).
    registers: [Vec<f64>; 3],
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
        let registers = [0, 1, 2].map(|i| vec![0.0; tapes[i].registers()]);
        let [position, velocity, acceleration] = tapes;
        Level {
            position,
            velocity,
            acceleration,
            w,
            w_base,
            qdd,
            sdd,
            registers,
        }
    }
}

impl Model {
    /// The sensitivities of this model's solution and result columns with
    /// respect to the params `params` (in that order), derived
    /// symbolically and compiled to tapes; compute them after each solver
    /// step with [`Sensitivity::compute`]. Kinematic only: λ, reactions
    /// and efforts have none yet.
    ///
    /// # Errors
    /// A name that is not a param of the model or is named twice (the
    /// message names the model's params), or derivatives too large (see
    /// [`Derivation::sensitivities`]).
    pub fn sensitivity(&self, params: &[&str]) -> Result<Sensitivity, SensitivityError> {
        let mut d = self.derivation().clone();
        let s = d.sensitivities(params)?;
        let nc = d.nc();
        let m = d.outputs.len();
        let n = d.phi.len();
        Ok(Sensitivity {
            names: s.params.iter().map(|p| p.name.clone()).collect(),
            params: s.params.iter().map(|p| Level::new(&d, p)).collect(),
            nc,
            m,
            q: vec![0.0; 2 * nc],
            qd: vec![0.0; 2 * nc],
            param_values: d.param_values(),
            values: vec![0.0; s.params.len() * 3 * (nc + m)],
            rhs: vec![0.0; n],
        })
    }
}

impl Sensitivity {
    /// The params, in the order asked for.
    #[must_use]
    pub fn params(&self) -> &[String] {
        &self.names
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
        let (nc, m) = (self.nc, self.m);
        let Some(state) = solver.state() else {
            return Err(Error::Setup(kinema_runtime::LinalgError::NotFactored));
        };
        let dimension = |what, expected, found| {
            Error::Setup(kinema_runtime::LinalgError::Dimension {
                what,
                expected,
                found,
            })
        };
        if state.q().len() != nc {
            return Err(dimension("coordinates of the system", nc, state.q().len()));
        }
        if self.rhs.len() != nc {
            return Err(dimension(
                "equations of the model (sensitivities need NDOF = 0)",
                nc,
                self.rhs.len(),
            ));
        }
        let params = solver.system().params();
        if params.len() != self.param_values.len() {
            return Err(dimension(
                "params of the system",
                self.param_values.len(),
                params.len(),
            ));
        }
        self.param_values.copy_from_slice(params);
        let t = state.t();
        self.q[..nc].copy_from_slice(state.q());
        self.qd[..nc].copy_from_slice(state.qd());
        let stride = 3 * (nc + m);
        for (k, level) in self.params.iter_mut().enumerate() {
            let out = &mut self.values[k * stride..(k + 1) * stride];
            let (coords, results) = out.split_at_mut(3 * nc);
            let (ds, rest) = coords.split_at_mut(nc);
            let (dsd, dsdd) = rest.split_at_mut(nc);
            // The current state: a solve below may not move it, but its
            // q̈ is read after the solves borrowed the solver.
            let qdd = solver.state().map_or(&[][..], |s| s.qdd());
            if qdd.len() != nc {
                return Err(dimension("accelerations of the state", nc, qdd.len()));
            }
            dsdd.copy_from_slice(qdd);
            // Position: Φ_q s = −Φ_p.
            let inputs = TapeInputs {
                q: &self.q,
                qd: &self.qd,
                params: &self.param_values,
                t,
            };
            eval_into(&level.position, &inputs, &mut level.registers[0], ds, -1.0);
            solver.solve_at_state(ds)?;
            self.q[nc..].copy_from_slice(ds);
            // Velocity: Φ_q ṡ = rhs; with y_p, W, (y_p)_q and y_q.
            let inputs = TapeInputs {
                q: &self.q,
                qd: &self.qd,
                params: &self.param_values,
                t,
            };
            let v = run(&level.velocity, &inputs, &mut level.registers[1]);
            let n = self.rhs.len();
            dsd.copy_from_slice(v.get(..n).unwrap_or(&[]));
            if v.len() < n {
                dsd.fill(f64::NAN);
            }
            solver.solve_at_state(dsd)?;
            self.qd[nc..].copy_from_slice(dsd);
            let (dy, rest) = results.split_at_mut(m);
            let (dyd, dydd) = rest.split_at_mut(m);
            for (i, y) in dy.iter_mut().enumerate() {
                *y = v.get(n + i).copied().unwrap_or(f64::NAN);
            }
            // Acceleration: Φ_q s̈ = rhs − W q̈.
            let inputs = TapeInputs {
                q: &self.q,
                qd: &self.qd,
                params: &self.param_values,
                t,
            };
            let [_, velocity_registers, acceleration_registers] = &mut level.registers;
            let v: &[f64] = velocity_registers;
            let v = v.get(..level.velocity.outputs()).unwrap_or(&[]);
            let a = run(&level.acceleration, &inputs, acceleration_registers);
            let rhs = &mut self.rhs;
            for (i, r) in rhs.iter_mut().enumerate() {
                *r = a.get(i).copied().unwrap_or(f64::NAN);
            }
            for (j, &(row, col)) in level.w.iter().enumerate() {
                let w = v.get(level.w_base + j).copied().unwrap_or(f64::NAN);
                rhs[row] -= w * dsdd[col];
            }
            solver.solve_at_state(rhs)?;
            // ÿ_p = y_q s̈ + (y_p)_q q̈ + c, with dsdd still q̈ here.
            for i in 0..m {
                dyd[i] = a.get(n + i).copied().unwrap_or(f64::NAN);
                let c = a.get(n + m + i).copied().unwrap_or(f64::NAN);
                let q_terms = level.qdd[i].iter().fold(0.0, |acc, &(col, j)| {
                    acc + v.get(j).copied().unwrap_or(f64::NAN) * dsdd[col]
                });
                let s_terms = level.sdd[i].iter().fold(0.0, |acc, &(col, j)| {
                    acc + v.get(j).copied().unwrap_or(f64::NAN) * rhs[col]
                });
                dydd[i] = c + q_terms + s_terms;
            }
            dsdd.copy_from_slice(rhs);
        }
        Ok(())
    }

    /// ∂q/∂p, ∂q̇/∂p, ∂q̈/∂p for the `k`-th param asked for, at the state
    /// of the last [`compute`](Self::compute), in the order of q.
    ///
    /// # Panics
    /// If `k` is not below the number of params asked for.
    #[must_use]
    pub fn coordinates(&self, k: usize) -> [&[f64]; 3] {
        let nc = self.nc;
        let base = k * 3 * (nc + self.m);
        let c = &self.values[base..base + 3 * nc];
        [&c[..nc], &c[nc..2 * nc], &c[2 * nc..]]
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
        let (nc, m) = (self.nc, self.m);
        let base = k * 3 * (nc + m) + 3 * nc;
        let c = &self.values[base..base + 3 * m];
        [&c[..m], &c[m..2 * m], &c[2 * m..]]
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
