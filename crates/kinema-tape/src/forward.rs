//! The tape back end's forward dynamics: a [`ForwardSystem`] whose every
//! matrix comes from the symbolic derivation (Φ, Φ_q, ν, γ, M, Q_A,
//! ∂Q_A/∂q, ∂Q_A/∂q̇ and the second derivatives of Φ for ∂(Φ_qᵀλ)/∂q),
//! compiled to tapes once. The sparse matrices' tapes write their values
//! straight into the `*_values` outputs HHT's sparse Newton matrix reads
//! (in the order of [`ForwardSystem::structure`]).

use kinema_expr::{ExprId, SymId, Tape, TapeInputs};
use kinema_model::Derivation;
use kinema_runtime::{DenseScratch, ForwardStructure, ForwardSystem};

use crate::Model;

/// One tape and the dense positions of its outputs.
#[derive(Clone, Debug)]
struct Part {
    tape: Tape,
    /// Output k goes to `slots[k]` of the dense result (row-major); for the
    /// constraint Hessian, (row of Φ, dense slot).
    slots: Vec<(usize, usize)>,
}

/// Forward dynamics of a [`Model`] by tapes.
#[derive(Clone, Debug)]
pub struct TapeForward {
    n: usize,
    m: usize,
    coordinate_names: Vec<String>,
    equation_names: Vec<String>,
    params: Vec<f64>,
    /// The stated start (q⁰, q̇⁰) at `params`.
    start: (Vec<f64>, Vec<f64>),
    phi: Tape,
    jac: Part,
    nu: Tape,
    gamma: Tape,
    mass: Tape,
    applied: Tape,
    applied_q: Part,
    applied_qd: Part,
    hessian: Part,
    gravity: Tape,
    registers: Vec<f64>,
    values: Vec<f64>,
    zeros: Vec<f64>,
    masses: Vec<f64>,
}

impl TapeForward {
    /// The tapes of a derivation with inertia, or `None` for a kinematic one.
    #[must_use]
    pub fn new(d: &Derivation, params: &[f64]) -> Option<TapeForward> {
        let dy = d.dynamics.as_ref()?;
        let n = d.nc();
        let m = d.rows.len();
        let mut arena = d.arena.clone();
        let q_syms: Vec<SymId> = d.coordinates.iter().map(|c| c.sym).collect();
        // Second derivatives of Φ: ∂(Φ_q)_{ij}/∂q_k, nonzeros only.
        let mut hess_exprs: Vec<ExprId> = Vec::new();
        let mut hess_slots = Vec::new();
        for e in &d.phi_q.entries {
            for (k, &s) in q_syms.iter().enumerate() {
                let x = arena.diff(e.expr, s);
                if !arena.is_zero(x) {
                    hess_exprs.push(x);
                    hess_slots.push((e.row as usize, e.col as usize * n + k));
                }
            }
        }
        let sparse =
            |s: &kinema_expr::SparseMatrix, cols: usize| -> (Vec<ExprId>, Vec<(usize, usize)>) {
                s.entries
                    .iter()
                    .map(|e| (e.expr, (0, e.row as usize * cols + e.col as usize)))
                    .unzip()
            };
        let (jac_e, jac_s) = sparse(&d.phi_q, n);
        let (aq_e, aq_s) = sparse(&dy.applied_q, n);
        let (aqd_e, aqd_s) = sparse(&dy.applied_qd, n);
        let a = &arena;
        let part = |e: &[ExprId], slots: Vec<(usize, usize)>| Part {
            tape: Tape::compile(a, e),
            slots,
        };
        let f = TapeForward {
            n,
            m,
            coordinate_names: d.coordinates.iter().map(|c| c.name.clone()).collect(),
            equation_names: d.rows.iter().map(|r| r.name.clone()).collect(),
            params: params.to_vec(),
            start: d.start_at(params),
            phi: Tape::compile(a, &d.phi),
            jac: part(&jac_e, jac_s),
            nu: Tape::compile(a, &d.nu),
            gamma: Tape::compile(a, &d.gamma),
            mass: Tape::compile(a, &dy.mass),
            applied: Tape::compile(a, &dy.applied),
            applied_q: part(&aq_e, aq_s),
            applied_qd: part(&aqd_e, aqd_s),
            hessian: part(&hess_exprs, hess_slots),
            gravity: Tape::compile(a, &dy.gravity),
            registers: Vec::new(),
            values: Vec::new(),
            zeros: vec![0.0; n],
            masses: vec![0.0; n],
        };
        let tapes = [
            &f.phi,
            &f.jac.tape,
            &f.nu,
            &f.gamma,
            &f.mass,
            &f.applied,
            &f.applied_q.tape,
            &f.applied_qd.tape,
            &f.hessian.tape,
            &f.gravity,
        ];
        let registers = tapes.iter().map(|t| t.registers()).max().unwrap_or(0);
        let values = tapes.iter().map(|t| t.outputs()).max().unwrap_or(0);
        Some(TapeForward {
            registers: vec![0.0; registers],
            values: vec![0.0; values],
            ..f
        })
    }

    /// The gravity vector (gx, gy) at the parameters' values.
    pub fn gravity(&mut self) -> [f64; 2] {
        let mut g = [f64::NAN; 2];
        let inputs = TapeInputs {
            q: &self.zeros,
            qd: &self.zeros,
            params: &self.params,
            t: 0.0,
        };
        if self
            .gravity
            .eval(&inputs, &mut self.registers, &mut g)
            .is_err()
        {
            g = [f64::NAN; 2];
        }
        g
    }

    /// The gravitational potential −Σ m (g · r) of the bodies at q (no
    /// allocation).
    pub fn gravity_potential(&mut self, q: &[f64]) -> f64 {
        let g = self.gravity();
        let mut mass = std::mem::take(&mut self.masses);
        self.mass(q, &mut mass);
        let v = mass
            .chunks_exact(3)
            .zip(q.chunks_exact(3))
            .map(|(m, r)| -(m[0] * g[0] * r[0] + m[1] * g[1] * r[1]))
            .sum();
        self.masses = mass;
        v
    }
}

/// `from` into `to`, or NaN in `to` when the lengths differ.
fn copy_or_nan(from: &[f64], to: &mut [f64]) {
    if from.len() == to.len() {
        to.copy_from_slice(from);
    } else {
        to.fill(f64::NAN);
    }
}

/// Evaluates `tape` into `out` (NaN on a failed evaluation).
fn run(tape: &Tape, inputs: &TapeInputs<'_>, registers: &mut [f64], out: &mut [f64]) {
    if tape.eval(inputs, registers, out).is_err() {
        out.fill(f64::NAN);
    }
}

impl TapeForward {
    fn dense(&mut self, which: u8, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
        let part = match which {
            0 => &self.jac,
            1 => &self.applied_q,
            _ => &self.applied_qd,
        };
        let inputs = TapeInputs {
            q,
            qd,
            params: &self.params,
            t,
        };
        let k = part.tape.outputs();
        let values = &mut self.values[..k];
        out.fill(0.0);
        if part
            .tape
            .eval(&inputs, &mut self.registers, values)
            .is_err()
        {
            out.fill(f64::NAN);
            return;
        }
        for (&v, &(_, slot)) in values.iter().zip(&part.slots) {
            if let Some(o) = out.get_mut(slot) {
                *o = v;
            }
        }
    }
}

impl ForwardSystem for TapeForward {
    fn coords(&self) -> usize {
        self.n
    }
    fn rows(&self) -> usize {
        self.m
    }
    fn coordinate_name(&self, i: usize) -> &str {
        self.coordinate_names.get(i).map_or("?", String::as_str)
    }
    fn equation_name(&self, i: usize) -> &str {
        self.equation_names.get(i).map_or("?", String::as_str)
    }
    fn initial_state(&mut self, q: &mut [f64], qd: &mut [f64]) {
        copy_or_nan(&self.start.0, q);
        copy_or_nan(&self.start.1, qd);
    }
    fn phi(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
        let inputs = TapeInputs {
            q,
            qd: &self.zeros,
            params: &self.params,
            t,
        };
        run(&self.phi, &inputs, &mut self.registers, out);
    }
    fn jacobian(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
        let z = std::mem::take(&mut self.zeros);
        self.dense(0, q, &z, t, out);
        self.zeros = z;
    }
    fn nu(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
        let inputs = TapeInputs {
            q,
            qd: &self.zeros,
            params: &self.params,
            t,
        };
        run(&self.nu, &inputs, &mut self.registers, out);
    }
    fn gamma(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
        let inputs = TapeInputs {
            q,
            qd,
            params: &self.params,
            t,
        };
        run(&self.gamma, &inputs, &mut self.registers, out);
    }
    fn mass(&mut self, q: &[f64], out: &mut [f64]) {
        let inputs = TapeInputs {
            q,
            qd: &self.zeros,
            params: &self.params,
            t: 0.0,
        };
        run(&self.mass, &inputs, &mut self.registers, out);
    }
    fn applied(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
        let inputs = TapeInputs {
            q,
            qd,
            params: &self.params,
            t,
        };
        run(&self.applied, &inputs, &mut self.registers, out);
    }
    fn applied_q(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
        self.dense(1, q, qd, t, out);
    }
    fn applied_qd(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
        self.dense(2, q, qd, t, out);
    }
    fn constraint_hessian(&mut self, q: &[f64], lambda: &[f64], t: f64, out: &mut [f64]) {
        let inputs = TapeInputs {
            q,
            qd: &self.zeros,
            params: &self.params,
            t,
        };
        let k = self.hessian.tape.outputs();
        let values = &mut self.values[..k];
        out.fill(0.0);
        if self
            .hessian
            .tape
            .eval(&inputs, &mut self.registers, values)
            .is_err()
        {
            out.fill(f64::NAN);
            return;
        }
        for (&v, &(row, slot)) in values.iter().zip(&self.hessian.slots) {
            if let (Some(o), Some(&l)) = (out.get_mut(slot), lambda.get(row)) {
                *o += l * v;
            }
        }
    }
    fn structure(&self) -> Option<ForwardStructure> {
        let n = self.n;
        if n == 0 {
            return None;
        }
        let entries = |part: &Part| -> Option<Vec<(u32, u32)>> {
            part.slots
                .iter()
                .map(|&(_, slot)| {
                    Some((u32::try_from(slot / n).ok()?, u32::try_from(slot % n).ok()?))
                })
                .collect()
        };
        Some(ForwardStructure {
            jacobian: entries(&self.jac)?,
            applied_q: entries(&self.applied_q)?,
            applied_qd: entries(&self.applied_qd)?,
            hessian: entries(&self.hessian)?,
        })
    }
    fn jacobian_values(&mut self, q: &[f64], t: f64, _: DenseScratch<'_>, out: &mut [f64]) {
        let inputs = TapeInputs {
            q,
            qd: &self.zeros,
            params: &self.params,
            t,
        };
        run(&self.jac.tape, &inputs, &mut self.registers, out);
    }
    fn applied_q_values(
        &mut self,
        q: &[f64],
        qd: &[f64],
        t: f64,
        _: DenseScratch<'_>,
        out: &mut [f64],
    ) {
        let inputs = TapeInputs {
            q,
            qd,
            params: &self.params,
            t,
        };
        run(&self.applied_q.tape, &inputs, &mut self.registers, out);
    }
    fn applied_qd_values(
        &mut self,
        q: &[f64],
        qd: &[f64],
        t: f64,
        _: DenseScratch<'_>,
        out: &mut [f64],
    ) {
        let inputs = TapeInputs {
            q,
            qd,
            params: &self.params,
            t,
        };
        run(&self.applied_qd.tape, &inputs, &mut self.registers, out);
    }
    fn constraint_hessian_values(
        &mut self,
        q: &[f64],
        lambda: &[f64],
        t: f64,
        _: DenseScratch<'_>,
        out: &mut [f64],
    ) {
        let inputs = TapeInputs {
            q,
            qd: &self.zeros,
            params: &self.params,
            t,
        };
        run(&self.hessian.tape, &inputs, &mut self.registers, out);
        for (o, &(row, _)) in out.iter_mut().zip(&self.hessian.slots) {
            *o *= lambda.get(row).copied().unwrap_or(f64::NAN);
        }
    }
}

impl Model {
    /// Forward dynamics by tapes at the parameters' declared values, or
    /// `None` for a model without inertia.
    #[must_use]
    pub fn forward_system(&self) -> Option<TapeForward> {
        let system = self.system();
        TapeForward::new(self.derivation(), system.params())
    }

    /// The initial configuration the model declares (its coordinates'
    /// guesses, at the default parameters), the start of forward dynamics;
    /// at other parameters, [`TapeForward::new`] with them states its own
    /// (`ForwardSystem::initial_state`).
    #[must_use]
    pub fn initial_configuration(&self) -> Vec<f64> {
        self.derivation()
            .coordinates
            .iter()
            .map(|c| c.guess_value)
            .collect()
    }

    /// The initial velocities the model declares (each body's `velocity`
    /// item, zero for a body without one; at the default parameters), the
    /// start of forward dynamics
    /// together with [`Model::initial_configuration`]. The integrators make
    /// the pair consistent (Φ_q q̇ = ν) by a minimum-norm correction and
    /// report its size.
    #[must_use]
    pub fn initial_velocities(&self) -> Vec<f64> {
        self.derivation().initial_velocity_values()
    }
}

/// How a model with inertia moves when it is not the kinematic case (the
/// answer of [`dynamics_run`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DynamicsRun {
    /// Forward dynamics: free degrees of freedom (by the count, or left by
    /// redundant constraints).
    Forward,
    /// A fully driven model whose rows outnumber its coordinates through
    /// redundant constraints: kinematics and inverse dynamics by
    /// minimum-norm solves ([`kinema_runtime::integrate::Prescribed`]).
    Prescribed,
}

impl DynamicsRun {
    /// Its name in messages and in the Python package (`"forward"`,
    /// `"prescribed"`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            DynamicsRun::Forward => "forward",
            DynamicsRun::Prescribed => "prescribed",
        }
    }
}

/// How the derivation `d` with inertia runs at the params `params` from
/// the start `q0`: NDOF > 0 is forward dynamics; NDOF = 0 with drivers is
/// the kinematic case (`None`: kinematics and inverse dynamics); otherwise
/// the rank of Φ_q at the assembled start decides — degrees of freedom
/// left free by redundant constraints are forward dynamics, a fully
/// determined motion with redundant rows is [`DynamicsRun::Prescribed`].
/// A start that does not assemble with more rows than coordinates is the
/// prescribed motion's error to report. `None` for a model without
/// inertia. Allocates (an assembly and an SVD); once per model.
#[must_use]
pub fn dynamics_run(d: &Derivation, params: &[f64], q0: &[f64]) -> Option<DynamicsRun> {
    d.dynamics.as_ref()?;
    let dof = d.dof;
    if dof.ndof() > 0 {
        return Some(DynamicsRun::Forward);
    }
    if dof.ndof() == 0 && dof.driving > 0 {
        return None;
    }
    let over = (dof.ndof() < 0).then_some(DynamicsRun::Prescribed);
    let mut fwd = TapeForward::new(d, params)?;
    let mut q = q0.to_vec();
    if kinema_runtime::integrate::assemble(&mut fwd, &mut q, 0.0).is_err() {
        return over;
    }
    let Some(rank) = kinema_runtime::integrate::Monitor::new(&mut fwd, &q, 0.0, 0.0).rank() else {
        return over;
    };
    if rank < q.len() {
        Some(DynamicsRun::Forward)
    } else if dof.ndof() < 0 {
        Some(DynamicsRun::Prescribed)
    } else {
        None
    }
}
