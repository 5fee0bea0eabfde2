//! HHT-α on the index-3 DAE (Negrut, Rampalli, Ottarsson, Sandu 2007):
//!
//! ```text
//! q₊ = q + h q̇ + h²/2 [(1 − 2β) q̈ + 2β q̈₊]
//! q̇₊ = q̇ + h [(1 − γ) q̈ + γ q̈₊]
//! M q̈₊ + (1 + α)(Φ_qᵀλ − Q_A)₊ − α (Φ_qᵀλ − Q_A) = 0
//! Φ(q₊, t₊) / (β h²) = 0
//! ```
//!
//! with α ∈ [−1/3, 0], β = (1 − α)²/4, γ = ½ − α: second order, with
//! numerical damping of the high frequencies growing as α goes to −1/3
//! (α = 0 is the trapezoidal rule). The unknowns are q̈₊ and λ₊; Newton's
//! Jacobian is exact, from the symbolic derivatives:
//!
//! ```text
//! [ M + (1+α)[(∂(Φ_qᵀλ)/∂q − ∂Q_A/∂q) β h² − ∂Q_A/∂q̇ γ h]   (1+α) Φ_qᵀ ]
//! [ Φ_q                                                      0          ]
//! ```
//!
//! (modified Newton by default: factored once per step while the
//! corrections halve; full Newton on request, [`HhtOptions::modified`]). The start is made consistent:
//! q is projected onto Φ = 0 and q̇ onto Φ_q q̇ = ν by minimum-norm
//! corrections, and q̈, λ come from the index-1 system
//! [M Φ_qᵀ; Φ_q 0][q̈; λ] = [Q_A; γ].

use super::dense::Lu;
use super::kkt::{Scratch, SparseKkt};
use super::monitor::Monitor;
use super::saddle::{self, Saddle};
use super::{ForwardSystem, IntegrateError};
use crate::linalg::{LinalgError, LinearSolver};

mod start;

/// HHT-α's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HhtOptions {
    /// α ∈ [−1/3, 0] (default −0.1: β = 0.3025, γ = 0.6, simEngine2D's).
    pub alpha: f64,
    /// Newton stops when the position change it makes, β h² ‖Δq̈‖∞, is at
    /// most `tolerance` (1 + ‖q‖∞) and the change of the constraint forces
    /// it makes, ‖Φ_qᵀΔλ‖∞, is at most √tolerance (1 + ‖Φ_qᵀλ − Q_A‖∞)
    /// (λ enters the next step only through the α-weighted forces, and at
    /// a singular configuration or with redundant constraints λ itself is
    /// not determined: only Φ_qᵀλ is).
    pub tolerance: f64,
    /// Newton iterations per step before the step fails.
    pub max_iterations: usize,
    /// Modified Newton (the default): the Jacobian factored once per step
    /// (at the predictor) and reused, refactored only when an iteration
    /// does not halve the correction. Full Newton (`false`) factors every
    /// iteration. Measured on the slider-crank from rest, 1000 steps of
    /// 1 ms: the same 2101 iterations, 1000 factorizations instead of 2101,
    /// a third less time.
    pub modified: bool,
    /// Report q̇ projected onto Φ_q q̇ = ν at the end of every step
    /// (minimum norm; HHT on the index-3 form meets Φ = 0 but the velocity
    /// constraint only to its truncation error). Only the reported q̇
    /// ([`Hht::qd`], and the kinetic energy) is projected: HHT's own state
    /// keeps its unprojected q̇, so the method and its second order are
    /// unchanged, and the projection of a second-order q̇ at a second-order
    /// q onto the velocity constraint is second order too (it moves q̇ by
    /// at most a constant times the constraint's residual, itself of the
    /// size of the errors in q and q̇). Projecting the state instead would
    /// break HHT's recurrence between q̇ and q̈ and make it first order.
    /// Off by default (one more solve per step).
    pub project_velocity: bool,
    /// Factor Newton's matrix with the sparse LU on its fixed pattern
    /// (the runtime's [`SparseLu`](crate::SparseLu): COLAMD ordering,
    /// partial pivoting, the elimination recorded and replayed), assembled
    /// from the system's `*_values` methods, when the system gives its
    /// [`structure`](ForwardSystem::structure) and n + m is at least this;
    /// below it (default 32: the course's models, the slider-crank) or
    /// without a structure, the dense LU. `usize::MAX` always dense, 0
    /// always sparse. Measured (fd_profile example, 1000 steps of 1 ms):
    /// the chain N = 10 (n + m = 50) steps 4.5× faster sparse, with no
    /// allocation; the slider-crank (17) 2× faster, but its pivots move
    /// along the motion and each new pivot order records a new elimination
    /// (allocating), so it stays dense.
    pub sparse_from: usize,
}

impl Default for HhtOptions {
    fn default() -> Self {
        HhtOptions {
            alpha: -0.1,
            tolerance: 1e-13,
            max_iterations: 25,
            modified: true,
            project_velocity: false,
            sparse_from: 32,
        }
    }
}

/// How far the initial conditions were from consistent.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Consistency {
    /// ‖Φ(q₀)‖∞ as given.
    pub phi: f64,
    /// ‖Φ_q q̇₀ − ν‖∞ as given (after the position projection).
    pub velocity: f64,
    /// ‖Δq‖∞ of the position projection.
    pub dq: f64,
    /// ‖Δq̇‖∞ of the velocity projection.
    pub dqd: f64,
}

/// Counters of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HhtStats {
    /// Steps taken.
    pub steps: usize,
    /// Newton iterations (factorizations) in all.
    pub iterations: usize,
    /// Most iterations in one step.
    pub max_iterations: usize,
    /// Factorizations of the Newton matrix in all.
    pub factorizations: usize,
}

/// Fixed-step HHT-α integrator and its state.
#[derive(Debug)]
pub struct Hht<S> {
    system: S,
    n: usize,
    m: usize,
    alpha: f64,
    beta: f64,
    gamma: f64,
    options: HhtOptions,
    t: f64,
    q: Vec<f64>,
    qd: Vec<f64>,
    /// q̇ as reported with [`HhtOptions::project_velocity`]: `qd` projected.
    qd_out: Vec<f64>,
    qdd: Vec<f64>,
    lambda: Vec<f64>,
    /// (Φ_qᵀλ − Q_A) at the current state.
    f: Vec<f64>,
    /// Work of Q_A and of the constraint forces since the start.
    work: f64,
    /// Qᵀq̇ − λᵀν at the current state.
    power: f64,
    stats: HhtStats,
    // Buffers.
    qn: Vec<f64>,
    qdn: Vec<f64>,
    qddn: Vec<f64>,
    lambdan: Vec<f64>,
    mass: Vec<f64>,
    qa: Vec<f64>,
    jac: Vec<f64>,
    phi: Vec<f64>,
    nu: Vec<f64>,
    kq: Vec<f64>,
    cqd: Vec<f64>,
    hess: Vec<f64>,
    rhs: Vec<f64>,
    lu: Lu,
    /// Newton's matrix on its sparse pattern, when used.
    kkt: Option<SparseKkt>,
    /// Whether the last factorization of Newton's matrix is the dense one.
    dense_active: bool,
    /// The start's index-1 system and the projections (regularized).
    saddle: Saddle,
    /// Ones: the Euclidean metric of the minimum-norm projections.
    ones: Vec<f64>,
    /// The regularization of the rows in Newton's matrix (dense path).
    eps: Vec<f64>,
    /// The largest |Φ_q| entry of each row at the iterate.
    row_max: Vec<f64>,

    /// Φ_qᵀ Δλ of the last Newton correction (its convergence test).
    force: Vec<f64>,
    ys: Vec<f64>,
    /// Redundant rows at the start, singular configurations passed.
    monitor: Monitor,
}

/// The scaled singular value at or below which a located minimum along
/// the motion is a singular configuration ([`Monitor::new`]).
const MONITOR_THRESHOLD: f64 = 1e-5;

/// |Φᵣ| ≤ this · ε · (1 + ‖q‖∞) · maxⱼ |∂Φᵣ/∂qⱼ| is Φ's roundoff: the row
/// counts as met.
const ROUNDOFF_ROWS: f64 = 64.0;

/// Which vector a minimum-norm correction changes.
#[derive(Clone, Copy, Debug)]
enum Correct {
    /// q (the start's projection onto Φ = 0).
    Positions,
    /// HHT's q̇ (the start's projection onto Φ_q q̇ = ν).
    Velocities,
    /// The reported q̇ (the per-step projection).
    Reported,
}

fn amax(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
}

/// Whether every entry is finite: 0 · x is 0 for a finite x and NaN
/// otherwise, and a sum of those has no branch to take per entry.
fn finite(v: &[f64]) -> bool {
    let mut lanes = [0.0_f64; 4];
    let chunks = v.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for (l, &x) in lanes.iter_mut().zip(c) {
            *l += 0.0 * x;
        }
    }
    let tail: f64 = rest.iter().map(|&x| 0.0 * x).sum();
    lanes.iter().sum::<f64>() + tail == 0.0
}

impl<S: ForwardSystem> Hht<S> {
    /// An integrator at t₀ from q₀, q̇₀, made consistent (see the module
    /// documentation); the [`Consistency`] says how much was corrected.
    /// Allocates every buffer of the run.
    ///
    /// # Errors
    /// α outside [−1/3, 0], wrong lengths, an initial configuration that
    /// cannot be projected, a singular or non-finite index-1 system.
    pub fn new(
        system: S,
        q0: &[f64],
        qd0: &[f64],
        t0: f64,
        options: HhtOptions,
    ) -> Result<(Hht<S>, Consistency), IntegrateError> {
        let alpha = options.alpha;
        if !(-1.0 / 3.0..=0.0).contains(&alpha) {
            return Err(IntegrateError::Setup(format!(
                "HHT's α must be in [−1/3, 0], not {alpha}"
            )));
        }
        let (n, m) = (system.coords(), system.rows());
        if q0.len() != n || qd0.len() != n {
            return Err(IntegrateError::Setup(format!(
                "{n} coordinates and {m} equations, given {} positions and {} velocities",
                q0.len(),
                qd0.len()
            )));
        }
        let mut hht = Hht {
            system,
            n,
            m,
            alpha,
            beta: (1.0 - alpha) * (1.0 - alpha) / 4.0,
            gamma: 0.5 - alpha,
            options,
            t: t0,
            q: q0.to_vec(),
            qd: qd0.to_vec(),
            qd_out: vec![0.0; n],
            qdd: vec![0.0; n],
            lambda: vec![0.0; m],
            f: vec![0.0; n],
            work: 0.0,
            power: 0.0,
            stats: HhtStats::default(),
            qn: vec![0.0; n],
            qdn: vec![0.0; n],
            qddn: vec![0.0; n],
            lambdan: vec![0.0; m],
            mass: vec![0.0; n],
            qa: vec![0.0; n],
            jac: vec![0.0; m * n],
            phi: vec![0.0; m],
            nu: vec![0.0; m],
            kq: vec![0.0; n * n],
            cqd: vec![0.0; n * n],
            hess: vec![0.0; n * n],
            rhs: vec![0.0; n + m],
            lu: Lu::new(n + m),
            kkt: None,
            dense_active: true,
            saddle: Saddle::new(n, m),
            ones: vec![1.0; n],
            eps: vec![0.0; m],
            row_max: vec![0.0; m],

            force: vec![0.0; n],
            ys: vec![0.0; n + m],
            monitor: Monitor::inactive(),
        };
        if n + m >= options.sparse_from {
            hht.kkt = hht.system.structure().and_then(|s| SparseKkt::new(s, n, m));
        }
        let consistency = hht.make_consistent()?;
        hht.monitor = Monitor::new(&mut hht.system, &hht.q, t0, MONITOR_THRESHOLD);
        hht.monitor.pace(true);
        hht.qd_out.copy_from_slice(&hht.qd);
        hht.index1()?;
        hht.prepare_sparse();
        Ok((hht, consistency))
    }

    fn non_finite(&self, what: &str) -> IntegrateError {
        IntegrateError::NonFinite {
            t: self.t,
            what: what.to_owned(),
        }
    }

    /// The first non-finite value among the Newton iteration's
    /// evaluations, named (`Q_A at bar.y`), or `None`.
    fn first_non_finite(&self) -> Option<String> {
        let n = self.n;
        let coord = |i: usize| self.system.coordinate_name(i).to_owned();
        let first = |v: &[f64]| v.iter().position(|x| !x.is_finite());
        if let Some(i) = first(&self.mass) {
            return Some(format!("M at {}", coord(i)));
        }
        if let Some(i) = first(&self.qa) {
            return Some(format!("Q_A at {}", coord(i)));
        }
        if let Some(i) = first(&self.phi) {
            return Some(format!("Φ of `{}`", self.system.equation_name(i)));
        }
        if let Some(kkt) = &self.kkt {
            let equation = |i: usize| self.system.equation_name(i).to_owned();
            return kkt.first_non_finite(&equation, &coord);
        }
        if let Some(k) = first(&self.jac) {
            return Some(format!(
                "Φ_q of `{}` by {}",
                self.system.equation_name(k / n.max(1)),
                coord(k % n.max(1))
            ));
        }
        for (v, name) in [
            (&self.kq, "∂Q_A/∂q"),
            (&self.cqd, "∂Q_A/∂q̇"),
            (&self.hess, "∂(Φ_qᵀλ)/∂q"),
        ] {
            if let Some(k) = first(v) {
                return Some(format!(
                    "{name} at ({}, {})",
                    coord(k / n.max(1)),
                    coord(k % n.max(1))
                ));
            }
        }
        None
    }

    fn unknown_name(&self, k: usize) -> String {
        if k < self.n {
            format!("q̈ of {}", self.system.coordinate_name(k))
        } else {
            format!("λ of {}", self.system.equation_name(k - self.n))
        }
    }

    /// f = Φ_qᵀλ − Q_A and the power at the current state, from Φ_q (`jac`,
    /// or the sparse values) and `qa` evaluated there.
    fn store_force_and_power(&mut self) {
        let n = self.n;
        self.f.copy_from_slice(&self.qa);
        for v in &mut self.f {
            *v = -*v;
        }
        match &self.kkt {
            Some(kkt) => kkt.add_transposed_product(&self.lambda, 1.0, &mut self.f),
            None => {
                for (r, &l) in self.lambda.iter().enumerate() {
                    for (fc, &a) in self.f.iter_mut().zip(&self.jac[r * n..(r + 1) * n]) {
                        *fc += a * l;
                    }
                }
            }
        }
        self.system.nu(&self.q, self.t, &mut self.nu);
        let pq: f64 = self.qa.iter().zip(&self.qd).map(|(a, b)| a * b).sum();
        let pc: f64 = self.lambda.iter().zip(&self.nu).map(|(a, b)| a * b).sum();
        self.power = pq - pc;
    }

    /// One step of length `h`.
    ///
    /// # Errors
    /// No convergence (naming the equation with the largest residual), a
    /// singular Newton matrix, non-finite values; the state is unchanged.
    pub fn step(&mut self, h: f64) -> Result<(), IntegrateError> {
        if !(h.is_finite() && h > 0.0) {
            return Err(IntegrateError::Setup(format!(
                "the step must be positive and finite, not {h}"
            )));
        }
        let n = self.n;
        let t1 = self.t + h;
        let bh2 = self.beta * h * h;
        self.qddn.copy_from_slice(&self.qdd);
        self.lambdan.copy_from_slice(&self.lambda);
        let mut iterations = 0;
        let mut worst = (0usize, f64::INFINITY);
        let mut factorizations = 0;
        let mut refactor = true;
        let mut last_correction = f64::INFINITY;
        loop {
            if iterations == self.options.max_iterations {
                return Err(self.no_convergence(worst, iterations));
            }
            iterations += 1;
            self.predict(h);
            self.evaluate(t1, refactor)?;
            if refactor {
                // Φ's roundoff scale moves with the factors: between
                // refactorizations the iterates differ by less than it.
                self.row_scale();
            }
            worst = self.residual(bh2);
            if refactor {
                self.factor_newton(h)?;
                factorizations += 1;
            }
            match &mut self.kkt {
                Some(kkt) if !self.dense_active => {
                    if kkt.lu.solve_in_place(&mut self.rhs).is_err() {
                        self.rhs.fill(f64::NAN);
                    }
                }
                _ => self.lu.solve(&mut self.rhs),
            }
            let (dq, dl) = self.rhs.split_at(n);
            for (x, d) in self.qddn.iter_mut().zip(dq) {
                *x -= d;
            }
            for (x, d) in self.lambdan.iter_mut().zip(dl) {
                *x -= d;
            }
            let tol = self.options.tolerance;
            if !finite(&self.rhs) {
                // A matrix value the sparse path did not scan, or the
                // correction itself.
                return Err(match self.first_non_finite() {
                    Some(what) => IntegrateError::NonFinite { t: t1, what },
                    None => self.non_finite("a Newton correction"),
                });
            }
            let correction = amax(&self.rhs[..n]);
            // Modified Newton keeps the factors while they halve the
            // correction; full Newton refactors every iteration.
            refactor = !self.options.modified || correction > 0.5 * last_correction;
            last_correction = correction;
            // The multipliers' convergence, by their force, only once the
            // accelerations' has (a pass over Φ_q saved per iteration).
            if bh2 * correction <= tol * (1.0 + amax(&self.q))
                && self.multiplier_force() <= tol.sqrt() * (1.0 + amax(&self.f))
            {
                break;
            }
        }
        self.accept(h, t1)?;
        self.stats.steps += 1;
        self.stats.iterations += iterations;
        self.stats.factorizations += factorizations;
        self.stats.max_iterations = self.stats.max_iterations.max(iterations);
        Ok(())
    }

    /// ‖Φ_qᵀ Δλ‖∞ of the Newton correction in `rhs`: the change of the
    /// constraint forces, which is what λ contributes to the motion (at a
    /// singular configuration or with redundant constraints Δλ itself
    /// has a component in the null space of Φ_qᵀ that moves nothing).
    fn multiplier_force(&mut self) -> f64 {
        let n = self.n;
        self.force.fill(0.0);
        let dl = &self.rhs[n..];
        match &self.kkt {
            Some(kkt) => kkt.add_transposed_product(dl, 1.0, &mut self.force),
            None => {
                for (r, &l) in dl.iter().enumerate() {
                    for (fc, &a) in self.force.iter_mut().zip(&self.jac[r * n..(r + 1) * n]) {
                        *fc += a * l;
                    }
                }
            }
        }
        amax(&self.force)
    }

    /// q₊ and q̇₊ (in `qn`, `qdn`) from the state and the iterate q̈₊.
    fn predict(&mut self, h: f64) {
        let (beta, gamma) = (self.beta, self.gamma);
        for i in 0..self.n {
            let (q, v, a, an) = (self.q[i], self.qd[i], self.qdd[i], self.qddn[i]);
            self.qn[i] = q + h * v + 0.5 * h * h * ((1.0 - 2.0 * beta) * a + 2.0 * beta * an);
            self.qdn[i] = v + h * ((1.0 - gamma) * a + gamma * an);
        }
    }

    /// M, Q_A, Φ, Φ_q at the iterate, and (to refactor) the derivatives
    /// the Newton matrix needs; a non-finite value is an error naming it.
    fn evaluate(&mut self, t1: f64, refactor: bool) -> Result<(), IntegrateError> {
        let s = &mut self.system;
        s.mass(&self.qn, &mut self.mass);
        s.applied(&self.qn, &self.qdn, t1, &mut self.qa);
        s.phi(&self.qn, t1, &mut self.phi);
        match &mut self.kkt {
            Some(kkt) => {
                kkt.eval_jacobian(s, &self.qn, t1, &mut self.jac);
                if refactor {
                    let dense = Scratch {
                        applied_q: &mut self.kq,
                        applied_qd: &mut self.cqd,
                        hessian: &mut self.hess,
                    };
                    let at = (&self.qn[..], &self.qdn[..], &self.lambdan[..], t1);
                    kkt.eval_block(s, at, dense);
                }
            }
            None => {
                s.jacobian(&self.qn, t1, &mut self.jac);
                if refactor {
                    s.applied_q(&self.qn, &self.qdn, t1, &mut self.kq);
                    s.applied_qd(&self.qn, &self.qdn, t1, &mut self.cqd);
                    s.constraint_hessian(&self.qn, &self.lambdan, t1, &mut self.hess);
                }
            }
        }
        // With the sparse Newton matrix, the sparse values are checked
        // where they are read: the assembled matrix (factor_newton) and
        // the residual and correction (step).
        let checked = !(finite(&self.mass) && finite(&self.qa) && finite(&self.phi))
            || (self.kkt.is_none()
                && !(finite(&self.jac)
                    && (!refactor
                        || (finite(&self.kq) && finite(&self.cqd) && finite(&self.hess)))));
        match checked.then(|| self.first_non_finite()).flatten() {
            Some(what) => Err(IntegrateError::NonFinite { t: t1, what }),
            None => Ok(()),
        }
    }

    /// The residual r = [M q̈ + (1+α)(Φ_qᵀλ − Q) − α f; Φ/(βh²)] into
    /// `rhs`; returns its largest entry (index, |value|).
    fn residual(&mut self, bh2: f64) -> (usize, f64) {
        let (n, alpha) = (self.n, self.alpha);
        for i in 0..n {
            self.rhs[i] =
                self.mass[i] * self.qddn[i] - (1.0 + alpha) * self.qa[i] - alpha * self.f[i];
        }
        match &self.kkt {
            Some(kkt) => kkt.add_transposed_product(&self.lambdan, 1.0 + alpha, &mut self.rhs[..n]),
            None => {
                for (r, &l) in self.lambdan.iter().enumerate() {
                    let row = &self.jac[r * n..(r + 1) * n];
                    for (x, &a) in self.rhs[..n].iter_mut().zip(row) {
                        *x += (1.0 + alpha) * a * l;
                    }
                }
            }
        }
        // A row of Φ within its own roundoff is zero: near a singular
        // configuration Newton's matrix turns that noise into corrections
        // of ε/σ_min along the weakly constrained direction, step after
        // step, and the iteration could never meet its tolerance. (The
        // rows' scales are those of the last factorization's iterate.)
        let q_scale = 1.0 + amax(&self.qn);
        for ((x, &p), &g) in self.rhs[n..].iter_mut().zip(&self.phi).zip(&self.row_max) {
            let floor = ROUNDOFF_ROWS * f64::EPSILON * q_scale * g;
            *x = if p.abs() <= floor { 0.0 } else { p / bh2 };
        }
        self.rhs.iter().enumerate().fold(
            (0, 0.0),
            |b, (i, v)| {
                if v.abs() > b.1 { (i, v.abs()) } else { b }
            },
        )
    }

    /// `row_max` ← the largest |Φ_q| entry of each row at the iterate
    /// (the scale of Φ's roundoff); on the sparse path, in the same pass,
    /// the regularization of the Newton matrix about to be factored.
    fn row_scale(&mut self) {
        let n = self.n;
        match &mut self.kkt {
            Some(kkt) => kkt.regularize(&self.mass, 1.0 + self.alpha, &mut self.row_max),
            None => {
                for (r, e) in self.row_max.iter_mut().enumerate() {
                    *e = amax(&self.jac[r * n..(r + 1) * n]);
                }
            }
        }
    }

    /// Assembles and factors Newton's matrix (module documentation).
    fn factor_newton(&mut self, h: f64) -> Result<(), IntegrateError> {
        let (n, m, alpha) = (self.n, self.m, self.alpha);
        let (bh2, gh) = (self.beta * h * h, self.gamma * h);
        if let Some(kkt) = &mut self.kkt {
            // Regularized by `row_scale`, at this iterate.
            kkt.assemble(&self.mass, (1.0 + alpha, bh2, gh));
            if !finite(&kkt.values) {
                let what = self
                    .first_non_finite()
                    .unwrap_or_else(|| "HHT's Newton matrix".to_owned());
                return Err(IntegrateError::NonFinite { t: self.t, what });
            }
            match kkt.lu.factor(&kkt.values, 1e-14) {
                Ok(()) => {
                    self.dense_active = false;
                    return Ok(());
                }
                // The dense LU decides (and names the unknown without a
                // pivot), this iteration solving with it.
                Err(LinalgError::Singular { .. }) => {
                    kkt.to_dense(self.lu.matrix_mut());
                    self.dense_active = true;
                    return self.lu.factor().map_err(|k| IntegrateError::Singular {
                        t: self.t,
                        what: "HHT's Newton matrix",
                        at: self.unknown_name(k),
                    });
                }
                Err(e) => {
                    return Err(IntegrateError::Setup(format!("HHT's Newton matrix: {e}")));
                }
            }
        }
        self.dense_active = true;
        let w = n + m;
        let a = self.lu.matrix_mut();
        for i in 0..n {
            for j in 0..n {
                let k = i * n + j;
                let d = if i == j { self.mass[i] } else { 0.0 };
                a[i * w + j] =
                    d + (1.0 + alpha) * ((self.hess[k] - self.kq[k]) * bh2 - self.cqd[k] * gh);
            }
        }
        saddle::regularization(&self.jac, &self.mass, 1.0 + alpha, &mut self.eps);
        for r in 0..m {
            for c in 0..n {
                let v = self.jac[r * n + c];
                a[(n + r) * w + c] = v;
                a[c * w + n + r] = (1.0 + alpha) * v;
            }
            for c in 0..m {
                a[(n + r) * w + n + c] = 0.0;
            }
            a[(n + r) * w + n + r] = -self.eps[r];
        }
        self.lu.factor().map_err(|k| IntegrateError::Singular {
            t: self.t,
            what: "HHT's Newton matrix",
            at: self.unknown_name(k),
        })
    }

    /// The error for a step that did not converge, naming the equation
    /// with the largest residual.
    #[cold]
    fn no_convergence(&self, worst: (usize, f64), iterations: usize) -> IntegrateError {
        let n = self.n;
        let (i, residual) = worst;
        let equation = if i < n {
            format!(
                "the equation of motion of {}",
                self.system.coordinate_name(i)
            )
        } else {
            format!("constraint `{}`", self.system.equation_name(i - n))
        };
        IntegrateError::NoConvergence {
            t: self.t,
            iterations,
            equation,
            residual,
        }
    }

    /// Accepts the step: the state at t + h with the final q̈, λ; the
    /// optional velocity projection of the reported q̇; the forces and the
    /// work.
    fn accept(&mut self, h: f64, t1: f64) -> Result<(), IntegrateError> {
        let m = self.m;
        self.predict(h);
        std::mem::swap(&mut self.q, &mut self.qn);
        std::mem::swap(&mut self.qd, &mut self.qdn);
        std::mem::swap(&mut self.qdd, &mut self.qddn);
        std::mem::swap(&mut self.lambda, &mut self.lambdan);
        self.t = t1;
        let p0 = self.power;
        if let Some(kkt) = &mut self.kkt {
            kkt.eval_jacobian(&mut self.system, &self.q, t1, &mut self.jac);
        } else {
            self.system.jacobian(&self.q, t1, &mut self.jac);
        }
        if self.options.project_velocity && m > 0 {
            if self.kkt.is_some() {
                self.system.jacobian(&self.q, t1, &mut self.jac);
            }
            self.system.nu(&self.q, t1, &mut self.nu);
            self.velocity_residual();
            self.factor_projection("the velocity projection")?;
            self.qd_out.copy_from_slice(&self.qd);
            self.correct(Correct::Reported);
        }
        self.system.applied(&self.q, &self.qd, t1, &mut self.qa);
        self.store_force_and_power();
        self.work += 0.5 * h * (p0 + self.power);
        self.watch();
        Ok(())
    }

    /// The monitor's step at the accepted state, with the step's last
    /// factorization of Newton's matrix.
    fn watch(&mut self) {
        if !self.monitor.due(self.t) {
            return;
        }
        let scale = 1.0 + self.alpha;
        let state = (self.t, &self.q[..], &self.qd[..]);
        match &mut self.kkt {
            Some(kkt) if !self.dense_active => {
                let (values, lu) = kkt.regularized_factors();
                let mut solve = |v: &mut [f64]| {
                    if lu.solve_in_place(v).is_err() {
                        v.fill(f64::NAN);
                    }
                };
                self.monitor
                    .step(&mut self.system, state, values, scale, &mut solve);
            }
            Some(kkt) => {
                // The sparse path fell back to the dense LU this step: its
                // E is the sparse assembly's.
                let (values, _) = kkt.regularized_factors();
                let lu = &self.lu;
                let mut solve = |v: &mut [f64]| lu.solve(v);
                self.monitor
                    .step(&mut self.system, state, values, scale, &mut solve);
            }
            None => {
                let lu = &self.lu;
                let mut solve = |v: &mut [f64]| lu.solve(v);
                self.monitor
                    .step(&mut self.system, state, &self.eps, scale, &mut solve);
            }
        }
    }

    /// Steps to `t_end` exactly in the fewest equal steps no longer than
    /// `h` (so output times are hit, not approached).
    ///
    /// # Errors
    /// As [`step`](Self::step); a `t_end` not after the current time.
    pub fn advance_to(&mut self, t_end: f64, h: f64) -> Result<(), IntegrateError> {
        let span = t_end - self.t;
        if !(span.is_finite() && span > 0.0 && h.is_finite() && h > 0.0) {
            return Err(IntegrateError::Setup(format!(
                "cannot step from t = {} to t = {t_end} with steps of {h:e}",
                self.t
            )));
        }
        let count = (span / h * (1.0 - 1e-12)).ceil().max(1.0);
        if count > 1e12 {
            return Err(IntegrateError::Setup(format!(
                "{count:e} steps of {h:e} from t = {} to t = {t_end}: too many",
                self.t
            )));
        }
        let sub = span / count;
        let steps = count as u64;
        for k in 1..=steps {
            if k == steps {
                self.step(t_end - self.t)?;
                self.t = t_end;
            } else {
                self.step(sub)?;
            }
        }
        Ok(())
    }

    /// Current time.
    #[must_use]
    pub fn t(&self) -> f64 {
        self.t
    }
    /// Positions.
    #[must_use]
    pub fn q(&self) -> &[f64] {
        &self.q
    }
    /// Velocities (projected onto Φ_q q̇ = ν with
    /// [`HhtOptions::project_velocity`]).
    #[must_use]
    pub fn qd(&self) -> &[f64] {
        if self.options.project_velocity {
            &self.qd_out
        } else {
            &self.qd
        }
    }
    /// Accelerations (HHT's q̈ at the step's end).
    #[must_use]
    pub fn qdd(&self) -> &[f64] {
        &self.qdd
    }
    /// Lagrange multipliers, one per row of Φ.
    #[must_use]
    pub fn lambda(&self) -> &[f64] {
        &self.lambda
    }
    /// Work done since the start by Q_A and by the constraints (through ν,
    /// i.e. by drivers), trapezoidal rule over the steps: with T the kinetic
    /// energy, T − work stays T(t₀) up to the integrator's error.
    #[must_use]
    pub fn work(&self) -> f64 {
        self.work
    }
    /// Kinetic energy ½ q̇ᵀ M q̇ at the current state.
    pub fn kinetic_energy(&mut self) -> f64 {
        self.system.mass(&self.q, &mut self.mass);
        let qd = if self.options.project_velocity {
            &self.qd_out
        } else {
            &self.qd
        };
        super::kinetic_energy(&self.mass, qd)
    }
    /// Redundant constraints found at the start and the singular
    /// configurations passed so far (see [`Monitor`]).
    #[must_use]
    pub fn monitor(&self) -> &Monitor {
        &self.monitor
    }
    /// Counters.
    #[must_use]
    pub fn stats(&self) -> HhtStats {
        self.stats
    }
    /// The system.
    pub fn system_mut(&mut self) -> &mut S {
        &mut self.system
    }
}
