//! Parameter sensitivities of inverse dynamics on the tape back end
//! (issue 40): ∂λ/∂p and the sensitivities of every reaction and driver
//! effort of a kinematic run of a model with inertia, in the order and
//! naming of [`DynamicsColumns`](crate::dynamics::DynamicsColumns).
//!
//! Differentiating Φ_qᵀλ = Q_A − M q̈ totally with respect to a param p,
//! with s = ∂q/∂p, ṡ, s̈ from [`Sensitivity`]:
//!
//! ```text
//! Φ_qᵀ λ_p = D Q_A − M_p q̈ − M s̈ − Wᵀ λ
//! ```
//!
//! with D the directional derivative along {q → s, q̇ → ṡ, p → 1} and
//! W = (Φ_q s + Φ_p)_q = dΦ_q/dp, all derived symbolically
//! ([`kinema_model::DynamicsSensitivity`]); one transposed solve per param
//! with the step's factorization of Φ_q
//! ([`Solver::solve_transposed_at_state`]). A reaction
//! [F; T_O] = −Φ_q,bᵀ λ_c (its torque then moved from the body's origin to
//! the element's point by the arm a: T = T_O − (−a_y F_x + a_x F_y)) has
//!
//! ```text
//! [F_p; T_O,p] = −Φ_q,bᵀ (λ_p)_c − W_bᵀ λ_c,
//! T_p = T_O,p − (−a_y,p F_x − a_y F_x,p + a_x,p F_y + a_x F_y,p)
//! ```
//!
//! and a driver's effort −λ has −λ_p. Nothing is differenced.
//!
//! ```
//! let model = kinema::Model::from_source(
//!     "mechanism Pendulum {
//!         param l = 1.0;
//!         gravity = (0, -9.81);
//!         body bar { guess: (0.5, 0.0, 0.0), mass: 2, inertia: 0.1 }
//!         joint pin: revolute(ground(0, 0), bar(-l / 2, 0));
//!         driver hold: bar.phi == 0;
//!     }",
//!     "pendulum.kin",
//! )?;
//! let mut sens = model.sensitivity(&["l"]).map_err(|e| e.to_string()).unwrap();
//! let mut dyn_sens = model
//!     .dynamics_sensitivity(&sens)
//!     .map_err(|e| e.to_string())
//!     .unwrap()
//!     .expect("a model with inertia");
//! let mut solver = model.solver(kinema::Options::default())?;
//! solver.step(0.0)?;
//! sens.compute(&mut solver)?;
//! dyn_sens.compute(&mut solver, &sens)?;
//! // Held horizontal, the driver's effort is m g l/2: its ∂/∂l is m g/2.
//! let effort = *dyn_sens.columns(0).last().unwrap();
//! assert!((effort - 2.0 * 9.81 / 2.0).abs() < 1e-9);
//! # Ok::<(), kinema::Error>(())
//! ```

use kinema_expr::{ExprId, Tape, TapeInputs};
use kinema_index::{Body, Coord};
use kinema_model::{Derivation, ParamSensitivity, SensitivityError};
use kinema_runtime::linalg::LinearSolver;
use kinema_runtime::{Dynamics, Error, InverseDynamics, LinalgError, Quantity, Solver, System};

use crate::model::{Model, TapeSystem};
use crate::sensitivity::Sensitivity;

/// The compiled p-derivatives of inverse dynamics for some params of a
/// model with inertia, and the buffers their values are computed in
/// ([`DynamicsSensitivity::compute`]).
#[derive(Clone, Debug)]
pub struct DynamicsSensitivity {
    names: Vec<String>,
    params: Vec<Level>,
    /// Coordinates (= rows of Φ: a kinematic run), reactions, driving
    /// rows' first row.
    nc: usize,
    reactions: usize,
    driving_start: usize,
    /// Every reaction's terms −Φ_q[k] λ[row] (pattern order), as inverse
    /// dynamics sums them.
    entries: Vec<Term>,
    /// λ, the reactions, M, Q_A and the arms at the state.
    id: InverseDynamics,
    /// The augmented inputs [q; s] and [q̇; ṡ], q̈, the params' values.
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    param_values: Vec<f64>,
    /// Per param, the row [λ_p; reactions_p (Fx, Fy, T each); efforts_p].
    values: Vec<f64>,
}

/// One term of a reaction's sum: component `axis` of reaction `reaction`
/// gets −v[k] λ[row], v being Φ_q's values (pattern order) or W's.
#[derive(Clone, Copy, Debug)]
struct Term {
    k: usize,
    row: usize,
    reaction: usize,
    axis: usize,
}

/// One param's tape and where its outputs go.
#[derive(Clone, Debug)]
struct Level {
    /// ∂(diag M)/∂p (nc), D Q_A (nc), W's entries, D a (2 per reaction).
    /// Reads q, q̇, s, ṡ, p, t.
    tape: Tape,
    registers: Vec<f64>,
    /// W's entries (row, coordinate), values from output 2 nc on.
    w: Vec<(usize, usize)>,
    /// The reactions' terms −W[k] λ[row] (`k` indexes `w`).
    w_terms: Vec<Term>,
}

impl Level {
    fn new(d: &Derivation, p: &ParamSensitivity) -> Option<Level> {
        let (dy, dp) = (d.dynamics.as_ref()?, p.dynamics.as_ref()?);
        let mut outputs: Vec<ExprId> = dp.mass.iter().chain(&dp.applied).copied().collect();
        let w: Vec<(usize, usize)> = p
            .acceleration_qdd
            .entries
            .iter()
            .map(|e| {
                outputs.push(e.expr);
                (e.row as usize, e.col as usize)
            })
            .collect();
        outputs.extend(dp.arms.iter().flatten());
        let specs: Vec<(std::ops::Range<usize>, Body)> = dy
            .reactions
            .iter()
            .map(|r| (r.rows.clone(), Body::new(r.body)))
            .collect();
        let w_terms = terms(&specs, &w);
        let tape = Tape::compile(&d.arena, &outputs);
        let registers = vec![0.0; tape.registers()];
        Some(Level {
            tape,
            registers,
            w,
            w_terms,
        })
    }
}

/// The terms of each reaction (rows × body) among the entries `pattern`
/// (row, coordinate): those in its rows and its body's columns.
fn terms(specs: &[(std::ops::Range<usize>, Body)], pattern: &[(usize, usize)]) -> Vec<Term> {
    let mut out = Vec::new();
    for (reaction, (rows, body)) in specs.iter().enumerate() {
        for (k, &(row, col)) in pattern.iter().enumerate() {
            let c = Coord::of_index(col);
            if rows.contains(&row) && c.body == *body {
                out.push(Term {
                    k,
                    row,
                    reaction,
                    axis: c.axis.index(),
                });
            }
        }
    }
    out
}

impl Model {
    /// The sensitivities of inverse dynamics (λ, reactions, efforts) with
    /// respect to the params of `sensitivity` (in its order), derived
    /// symbolically and compiled to tapes; `None` for a model without
    /// inertia, gravity or forces (no dynamics columns). Compute them after
    /// each step and [`Sensitivity::compute`] with
    /// [`DynamicsSensitivity::compute`].
    ///
    /// # Errors
    /// As [`Model::sensitivity`] (derivatives too large).
    pub fn dynamics_sensitivity(
        &self,
        sensitivity: &Sensitivity,
    ) -> Result<Option<DynamicsSensitivity>, SensitivityError> {
        let system = self.system();
        if !system.has_dynamics() {
            return Ok(None);
        }
        let mut d = self.derivation().clone();
        let names: Vec<&str> = sensitivity.params().iter().map(String::as_str).collect();
        let s = d.sensitivities(&names)?;
        let Some(params) = s
            .params
            .iter()
            .map(|p| Level::new(&d, p))
            .collect::<Option<Vec<Level>>>()
        else {
            return Ok(None);
        };
        let nc = d.nc();
        let specs: Vec<(std::ops::Range<usize>, Body)> = system
            .reactions()
            .iter()
            .map(|r| (r.rows.start as usize..r.rows.end as usize, r.body))
            .collect();
        let pattern: Vec<(usize, usize)> = system
            .jacobian_pattern()
            .iter()
            .map(|&(r, c)| (r as usize, c as usize))
            .collect();
        let entries = terms(&specs, &pattern);
        let id = InverseDynamics::new(&system);
        let width = id.lambda().len() + 3 * id.reactions().len() + id.efforts().len();
        Ok(Some(DynamicsSensitivity {
            names: sensitivity.params().to_vec(),
            nc,
            reactions: specs.len(),
            driving_start: system.driving_start().min(d.rows.len()),
            entries,
            id,
            q: vec![0.0; 2 * nc],
            qd: vec![0.0; 2 * nc],
            qdd: vec![0.0; nc],
            param_values: d.param_values(),
            values: vec![0.0; params.len() * width],
            params,
        }))
    }
}

impl DynamicsSensitivity {
    /// The params, in the order asked for.
    #[must_use]
    pub fn params(&self) -> &[String] {
        &self.names
    }

    /// How many columns each param has: λ (one per row), the reactions
    /// (Fx, Fy, T each), the efforts — as
    /// [`DynamicsColumns::names`](crate::dynamics::DynamicsColumns::names).
    #[must_use]
    pub fn width(&self) -> usize {
        self.nc + 3 * self.reactions + (self.nc - self.driving_start)
    }

    /// Computes every param's sensitivities of λ, the reactions and the
    /// efforts at the solver's current state, which `sensitivity` was
    /// last [computed](Sensitivity::compute) at (s, ṡ, s̈ are read from
    /// it). Inverse dynamics is solved again at the state (its λ and
    /// reactions enter the derivatives), then one transposed solve per
    /// param with the step's factorization of Φ_q. Does not allocate.
    ///
    /// # Errors
    /// As [`Solver::inverse_dynamics`] (no state; a non-finite M, Q_A or
    /// λ); Φ_q singular where the state's factorization had to be made
    /// again; a `sensitivity` of other params or a system of another size
    /// than this was built for ([`LinalgError::Dimension`]); a
    /// sensitivity that is not finite ([`Error::NonFinite`], naming the
    /// column and param).
    pub fn compute<L: LinearSolver>(
        &mut self,
        solver: &mut Solver<TapeSystem, L>,
        sensitivity: &Sensitivity,
    ) -> Result<(), Error> {
        let nc = self.nc;
        let same_params = sensitivity.params().len() == self.names.len()
            && sensitivity
                .params()
                .iter()
                .zip(&self.names)
                .all(|(a, b)| a == b);
        if !same_params {
            return Err(dimension(
                "params of the sensitivity (those this was built for, in order)",
                self.names.len(),
                sensitivity.params().len(),
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
        let Some(state) = solver.state() else {
            return Err(Error::Setup(LinalgError::NotFactored));
        };
        if state.q().len() != nc {
            return Err(dimension("coordinates of the system", nc, state.q().len()));
        }
        let t = state.t();
        self.q[..nc].copy_from_slice(state.q());
        self.qd[..nc].copy_from_slice(state.qd());
        self.qdd.copy_from_slice(state.qdd());
        solver.inverse_dynamics(&mut self.id)?;
        let width = self.width();
        let (m, rest) = self.id.values().split_at(nc);
        let arms = rest.get(nc..).unwrap_or(&[]);
        let lambda = self.id.lambda();
        let forces = self.id.reactions();
        for (k, level) in self.params.iter_mut().enumerate() {
            let [s, sd, sdd] = sensitivity.coordinates(k);
            self.q[nc..].copy_from_slice(s);
            self.qd[nc..].copy_from_slice(sd);
            let inputs = TapeInputs {
                q: &self.q,
                qd: &self.qd,
                params: &self.param_values,
                t,
            };
            let v = level
                .tape
                .eval_in_registers(&inputs, &mut level.registers)
                .unwrap_or(&[]);
            let out = &mut self.values[k * width..(k + 1) * width];
            let (dlambda, rest) = out.split_at_mut(nc);
            let (dreactions, d_efforts) = rest.split_at_mut(3 * self.reactions);
            if v.len() < 2 * nc + level.w.len() + 2 * self.reactions {
                // A tape that could not run (an input of the wrong length):
                // NaN, reported below.
                out.fill(f64::NAN);
                return Err(not_finite(solver.system(), t, &self.names[k], 0));
            }
            let (dm, rest) = v.split_at(nc);
            let (dqa, rest) = rest.split_at(nc);
            let (w, darms) = rest.split_at(level.w.len());
            // Φ_qᵀ λ_p = D Q_A − M_p q̈ − M s̈ − Wᵀ λ.
            for i in 0..nc {
                dlambda[i] = dqa[i] - dm[i] * self.qdd[i] - m[i] * sdd[i];
            }
            for (&wv, &(row, col)) in w.iter().zip(&level.w) {
                dlambda[col] -= wv * lambda[row];
            }
            let (_, jac) = solver.solve_transposed_at_state(dlambda)?;
            // [F_p; T_O,p] = −Φ_q,bᵀ (λ_p)_c − W_bᵀ λ_c, then the torque
            // about the element's point.
            dreactions.fill(0.0);
            for e in &self.entries {
                dreactions[3 * e.reaction + e.axis] -= jac[e.k] * dlambda[e.row];
            }
            for e in &level.w_terms {
                dreactions[3 * e.reaction + e.axis] -= w[e.k] * lambda[e.row];
            }
            for (r, (dr, f)) in dreactions.chunks_exact_mut(3).zip(forces).enumerate() {
                let (ax, ay) = (arms[2 * r], arms[2 * r + 1]);
                let (dax, day) = (darms[2 * r], darms[2 * r + 1]);
                dr[2] -= -day * f[0] - ay * dr[0] + dax * f[1] + ax * dr[1];
            }
            for (e, &l) in d_efforts.iter_mut().zip(&dlambda[self.driving_start..]) {
                *e = -l;
            }
            // A finite sum: every value is finite (the exact test only on
            // the error path).
            if !out.iter().sum::<f64>().is_finite() {
                let j = out.iter().position(|x| !x.is_finite()).unwrap_or(0);
                return Err(not_finite(solver.system(), t, &self.names[k], j));
            }
        }
        Ok(())
    }

    /// The `k`-th param's sensitivities at the state of the last
    /// [`compute`](Self::compute): ∂λ/∂p (one per row of Φ), the
    /// reactions' (Fx, Fy, T each, in [`Dynamics::reactions`] order), the
    /// driving efforts' — the order of
    /// [`DynamicsColumns::names`](crate::dynamics::DynamicsColumns::names).
    ///
    /// # Panics
    /// If `k` is not below the number of params asked for.
    #[must_use]
    pub fn columns(&self, k: usize) -> &[f64] {
        let width = self.width();
        &self.values[k * width..(k + 1) * width]
    }

    /// λ, the reactions and the efforts at the state of the last
    /// [`compute`](Self::compute) (what the sensitivities are of).
    #[must_use]
    pub fn inverse_dynamics(&self) -> &InverseDynamics {
        &self.id
    }
}

fn dimension(what: &'static str, expected: usize, found: usize) -> Error {
    Error::Setup(LinalgError::Dimension {
        what,
        expected,
        found,
    })
}

/// The error for a non-finite sensitivity: column `j` of param `param`'s
/// row, named as its dynamics column (error path only).
#[cold]
fn not_finite(system: &TapeSystem, t: f64, param: &str, j: usize) -> Error {
    let rows = system.len();
    let names = system.dynamics_column_names(rows, false);
    let column = names.get(j).map_or("?", String::as_str);
    Error::NonFinite {
        t,
        quantity: Quantity::Multiplier,
        name: format!("d({column})/d({param})"),
    }
}
