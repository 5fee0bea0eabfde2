//! The accurate mode: the index-1 form of the equations of motion,
//!
//! ```text
//! [M Φ_qᵀ; Φ_q 0] [q̈; λ] = [Q_A; γ]
//! ```
//!
//! integrated as the ODE y = (q, q̇, W)′ = (q̇, q̈, Q_Aᵀq̇ − λᵀν) by the
//! Dormand–Prince 5(4) pair (Dormand & Prince 1980; the coefficients of
//! Hairer, Nørsett & Wanner, *Solving ODEs I*, table II.5.2) with error
//! control on (q, q̇) and step-size adaptation, and after every accepted
//! step a projection of q onto Φ = 0 and of q̇ onto Φ_q q̇ = ν
//! (minimum-norm), so the constraint drift of the index-1 form does not
//! accumulate. W is the work of the applied forces and of the drivers,
//! integrated to the same tolerance (the energy balance in the summary).
//!
//! Why written here and not taken from a crate: `ode_solvers`' `Dopri5` /
//! `Dop853` evaluate through `&self` (a tape's registers need `&mut`),
//! offer no hook to change the state after a step (the projection), and
//! keep every step's output; diffsol targets stiff problems (BDF, SDIRK) on
//! its own matrix types. The pair is seven stages and a dozen lines.

use super::monitor::Monitor;
use super::saddle::Saddle;
use super::{ForwardSystem, IntegrateError};

const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
/// Fifth-order weights (the last row of A).
const B: [f64; 7] = [
    35.0 / 384.0,
    0.0,
    500.0 / 1113.0,
    125.0 / 192.0,
    -2187.0 / 6784.0,
    11.0 / 84.0,
    0.0,
];
/// B minus the fourth-order weights: the error estimate's.
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// Most step attempts between two output times before the run is
/// declared too stiff (a hang otherwise).
const MAX_ATTEMPTS: usize = 1_000_000;

/// Counters of an accurate run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AccurateStats {
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected steps.
    pub rejected: usize,
    /// Evaluations of the index-1 system.
    pub evaluations: usize,
}

/// The error-controlled integrator and its state.
#[derive(Debug)]
pub struct Accurate<S> {
    system: S,
    n: usize,
    m: usize,
    rtol: f64,
    atol: f64,
    t: f64,
    /// (q, q̇, W).
    y: Vec<f64>,
    qdd: Vec<f64>,
    lambda: Vec<f64>,
    h: f64,
    stats: AccurateStats,
    k: [Vec<f64>; 7],
    ys: Vec<f64>,
    ynew: Vec<f64>,
    mass: Vec<f64>,
    qa: Vec<f64>,
    jac: Vec<f64>,
    gam: Vec<f64>,
    nu: Vec<f64>,
    phi: Vec<f64>,
    rhs: Vec<f64>,
    saddle: Saddle,
    /// Redundant rows at the start, singular configurations passed.
    monitor: Monitor,
}

fn amax(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
}

impl<S: ForwardSystem> Accurate<S> {
    /// An integrator at t₀ from q₀, q̇₀, which must be consistent (see
    /// [`super::Hht::new`], whose projection can make them so), to the
    /// relative tolerance `rtol` (absolute `rtol` too: coordinates of
    /// order one).
    ///
    /// # Errors
    /// A tolerance outside (1e-14, 1), wrong lengths, a singular or
    /// non-finite index-1 system at the start.
    pub fn new(
        system: S,
        q0: &[f64],
        qd0: &[f64],
        t0: f64,
        rtol: f64,
    ) -> Result<Accurate<S>, IntegrateError> {
        if !(rtol > 1e-14 && rtol < 1.0) {
            return Err(IntegrateError::Setup(format!(
                "the tolerance must be in (1e-14, 1), not {rtol}"
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
        let len = 2 * n + 1;
        let mut y = Vec::with_capacity(len);
        y.extend_from_slice(q0);
        y.extend_from_slice(qd0);
        y.push(0.0);
        let mut a = Accurate {
            system,
            n,
            m,
            rtol,
            atol: rtol,
            t: t0,
            y,
            qdd: vec![0.0; n],
            lambda: vec![0.0; m],
            h: 0.0,
            stats: AccurateStats::default(),
            k: std::array::from_fn(|_| vec![0.0; len]),
            ys: vec![0.0; len],
            ynew: vec![0.0; len],
            mass: vec![0.0; n],
            qa: vec![0.0; n],
            jac: vec![0.0; m * n],
            gam: vec![0.0; m],
            nu: vec![0.0; m],
            phi: vec![0.0; m],
            rhs: vec![0.0; n + m],
            saddle: Saddle::new(n, m),
            monitor: Monitor::inactive(),
        };
        a.monitor = Monitor::new(&mut a.system, q0, t0, (10.0 * rtol).max(1e-5));
        // First derivative, and a first step from its size (Hairer's
        // starting-step heuristic, simplified).
        let y0 = std::mem::take(&mut a.y);
        let mut k0 = std::mem::take(&mut a.k[0]);
        let r = a.derivative(t0, &y0, &mut k0);
        a.y = y0;
        a.k[0] = k0;
        r?;
        let d0 = amax(&a.y[..2 * n]).max(1e-5);
        let d1 = amax(&a.k[0][..2 * n]).max(1e-5);
        a.h = (0.01 * d0 / d1 * rtol.powf(0.2)).clamp(1e-10, 0.1);
        a.qdd.copy_from_slice(&a.k[0][n..2 * n]);
        Ok(a)
    }

    /// dy/dt at (t, y) into `out`; λ into `self.lambda`.
    fn derivative(&mut self, t: f64, y: &[f64], out: &mut [f64]) -> Result<(), IntegrateError> {
        let n = self.n;
        let (q, qd) = (&y[..n], &y[n..2 * n]);
        self.stats.evaluations += 1;
        let s = &mut self.system;
        s.mass(q, &mut self.mass);
        s.applied(q, qd, t, &mut self.qa);
        s.jacobian(q, t, &mut self.jac);
        s.gamma(q, qd, t, &mut self.gam);
        s.nu(q, t, &mut self.nu);
        let finite = [&self.mass, &self.qa, &self.jac, &self.gam, &self.nu]
            .iter()
            .all(|v| v.iter().all(|x| x.is_finite()));
        if !finite {
            return Err(IntegrateError::NonFinite {
                t,
                what: "M, Q_A, Φ_q, γ or ν".to_owned(),
            });
        }
        if let Err(k) = self.saddle.factor(&self.mass, &self.jac) {
            let at = if k < n {
                format!("q̈ of {}", self.system.coordinate_name(k))
            } else {
                format!("λ of {}", self.system.equation_name(k - n))
            };
            return Err(IntegrateError::Singular {
                t,
                what: "the index-1 matrix [M Φ_qᵀ; Φ_q 0]",
                at,
            });
        }
        self.rhs[..n].copy_from_slice(&self.qa);
        self.rhs[n..].copy_from_slice(&self.gam);
        self.saddle.solve(&self.jac, &mut self.rhs);
        if !self.rhs.iter().all(|x| x.is_finite()) {
            return Err(IntegrateError::NonFinite {
                t,
                what: "q̈ or λ".to_owned(),
            });
        }
        out[..n].copy_from_slice(qd);
        out[n..2 * n].copy_from_slice(&self.rhs[..n]);
        self.lambda.copy_from_slice(&self.rhs[n..]);
        let pq: f64 = self.qa.iter().zip(qd).map(|(a, b)| a * b).sum();
        let pc: f64 = self.lambda.iter().zip(&self.nu).map(|(a, b)| a * b).sum();
        out[2 * n] = pq - pc;
        Ok(())
    }

    /// Projects `ynew`'s q onto Φ = 0 and q̇ onto Φ_q q̇ = ν at `t`,
    /// mass-orthogonally (the corrections minimize ΔqᵀMΔq and Δq̇ᵀMΔq̇:
    /// what constraint impulses would do), through the regularized
    /// saddle-point matrix [M Φ_qᵀ; Φ_q −E] ([`Saddle`]), so a singular
    /// configuration or a redundant constraint does not stop it.
    fn project(&mut self, t: f64) -> Result<(), IntegrateError> {
        let (n, m) = (self.n, self.m);
        if m == 0 {
            return Ok(());
        }
        let scale = amax(&self.ynew[..n]).max(1.0);
        self.system.mass(&self.ynew[..n], &mut self.mass);
        for pass in 0..=10 {
            let q = &self.ynew[..n];
            self.system.phi(q, t, &mut self.phi);
            let err = amax(&self.phi);
            if !err.is_finite() {
                return Err(IntegrateError::NonFinite {
                    t,
                    what: "Φ in the projection".to_owned(),
                });
            }
            self.system.jacobian(q, t, &mut self.jac);
            self.factor_projection(t)?;
            if err <= 1e-15 * scale || pass == 10 {
                break;
            }
            self.rhs[..n].fill(0.0);
            for (r, &p) in self.rhs[n..].iter_mut().zip(&self.phi) {
                *r = -p;
            }
            self.correct(0);
        }
        self.system.nu(&self.ynew[..n], t, &mut self.nu);
        self.rhs[..n].fill(0.0);
        for i in 0..m {
            let r: f64 = self.jac[i * n..(i + 1) * n]
                .iter()
                .zip(&self.ynew[n..2 * n])
                .map(|(a, v)| a * v)
                .sum();
            self.rhs[n + i] = self.nu[i] - r;
        }
        self.correct(n);
        Ok(())
    }

    /// Factors the projection's matrix at the state in `jac`, `mass`.
    fn factor_projection(&mut self, t: f64) -> Result<(), IntegrateError> {
        let n = self.n;
        self.saddle
            .factor(&self.mass, &self.jac)
            .map_err(|k| IntegrateError::Singular {
                t,
                what: "the projection's matrix [M Φ_qᵀ; Φ_q 0]",
                at: if k < n {
                    format!("q̇ of {}", self.system.coordinate_name(k))
                } else {
                    format!("λ of {}", self.system.equation_name(k - n))
                },
            })
    }

    /// ynew[offset..offset + n] += Δ, the x part of the saddle-point
    /// solution for the right-hand side in `rhs`.
    fn correct(&mut self, offset: usize) {
        let n = self.n;
        self.saddle.solve(&self.jac, &mut self.rhs);
        for (x, d) in self.ynew[offset..offset + n].iter_mut().zip(&self.rhs[..n]) {
            *x += d;
        }
    }

    /// Integrates to `t_end` exactly (the last step is shortened onto it).
    ///
    /// # Errors
    /// A step size below roundoff (naming the time), non-finite values, a
    /// singular system.
    pub fn advance_to(&mut self, t_end: f64) -> Result<(), IntegrateError> {
        let n = self.n;
        let len = 2 * n + 1;
        if !(t_end.is_finite() && t_end > self.t) {
            return Err(IntegrateError::Setup(format!(
                "cannot integrate from t = {} to t = {t_end}",
                self.t
            )));
        }
        let mut attempts = 0usize;
        let (start, rejected) = (self.t, self.stats.rejected);
        while self.t < t_end {
            attempts += 1;
            if attempts > MAX_ATTEMPTS {
                let stiff = 2 * (self.stats.rejected - rejected) >= MAX_ATTEMPTS;
                let cause = if stiff {
                    format!(
                        "the motion is too stiff for the explicit accurate mode at rtol {:e}; \
                         try --integrator hht",
                        self.rtol
                    )
                } else {
                    // Mostly accepted steps: the interval, not the motion.
                    format!(
                        "the interval between these output times is too long for steps of \
                         this size (about {:.1e} more of them to go): ask for output times \
                         closer together",
                        ((t_end - self.t) / self.h).ceil()
                    )
                };
                return Err(IntegrateError::Setup(format!(
                    "{MAX_ATTEMPTS} steps from t = {start} did not reach t = {t_end} (they reached \
                     t = {}, the step is {:e}): {cause}",
                    self.t, self.h
                )));
            }
            let last = self.h >= t_end - self.t;
            let h = if last { t_end - self.t } else { self.h };
            // Only the step the error control chose can fall too low: the
            // last one is shortened onto t_end, as short as output times
            // are close (an ulp apart, where a schedule computes one time
            // two ways).
            if !last && h <= 1e-14 * self.t.abs().max(1.0) {
                return Err(IntegrateError::Setup(format!(
                    "the step fell to {h:e} at t = {}: the tolerance {:e} cannot be met \
                     (a singularity or a stiff force?)",
                    self.t, self.rtol
                )));
            }
            let t = self.t;
            // k₀ at (t, y).
            let y = std::mem::take(&mut self.y);
            let mut k = std::mem::take(&mut self.k);
            let mut result = self.derivative(t, &y, &mut k[0]);
            for s in 1..7 {
                if result.is_err() {
                    break;
                }
                for i in 0..len {
                    let mut v = y[i];
                    for (j, kj) in k.iter().enumerate().take(s) {
                        v += h * A[s][j] * kj[i];
                    }
                    self.ys[i] = v;
                }
                let ys = std::mem::take(&mut self.ys);
                result = self.derivative(t + C[s] * h, &ys, &mut k[s]);
                self.ys = ys;
            }
            // The new state and the error estimate.
            let mut err: f64 = 0.0;
            if result.is_ok() {
                for i in 0..len {
                    let mut v = y[i];
                    let mut e = 0.0;
                    for (s, ks) in k.iter().enumerate() {
                        v += h * B[s] * ks[i];
                        e += h * E[s] * ks[i];
                    }
                    self.ynew[i] = v;
                    if i < 2 * n {
                        let sc = self.atol + self.rtol * y[i].abs().max(v.abs());
                        err = err.max((e / sc).abs());
                    }
                }
            }
            self.y = y;
            self.k = k;
            // The step's own drift off Φ = 0 counts in its error: the
            // index-1 form keeps Φ̈ = 0, so a step that meets the tolerance
            // leaves Φ at the tolerance's size; one that does not has
            // stepped across a singular configuration too coarsely (and
            // the projection could put it on another branch).
            if result.is_ok() && self.m > 0 {
                let t1 = if last { t_end } else { t + h };
                self.system.phi(&self.ynew[..n], t1, &mut self.phi);
                let scale = self.atol + self.rtol * amax(&self.ynew[..n]);
                let drift = amax(&self.phi) / scale;
                err = if drift.is_nan() {
                    f64::INFINITY
                } else {
                    err.max(drift)
                };
            }
            if let Err(e) = result {
                // A failed evaluation inside the step: retry smaller once
                // the step allows, else report.
                if self.h > 1e-10 {
                    self.h /= 4.0;
                    self.stats.rejected += 1;
                    continue;
                }
                return Err(e);
            }
            if !err.is_finite() {
                err = 1e10;
            }
            let factor = (0.9 * err.max(1e-10).powf(-0.2)).clamp(0.2, 5.0);
            if err <= 1.0 {
                let t1 = if last { t_end } else { t + h };
                self.project(t1)?;
                std::mem::swap(&mut self.y, &mut self.ynew);
                self.t = t1;
                self.watch();
                self.stats.accepted += 1;
                // A last step much shorter than the chosen one says little
                // of it (its error may be the drift off Φ = 0 alone, which
                // no step size lowers): the chosen one is kept.
                if !last || (factor < 1.0 && h >= 0.5 * self.h) {
                    self.h = h * factor;
                }
            } else {
                self.stats.rejected += 1;
                self.h = h * factor.min(1.0);
            }
        }
        // q̈ and λ at the end.
        let y = std::mem::take(&mut self.y);
        let mut k0 = std::mem::take(&mut self.k[0]);
        let r = self.derivative(self.t, &y, &mut k0);
        self.y = y;
        self.qdd.copy_from_slice(&k0[n..2 * n]);
        self.k[0] = k0;
        r
    }

    /// The monitor's step at the accepted (projected) state, with the
    /// projection's factors (at that state).
    fn watch(&mut self) {
        let n = self.n;
        if self.m == 0 || !self.monitor.due(self.t) {
            return;
        }
        let saddle = &self.saddle;
        let mut solve = |v: &mut [f64]| saddle.solve_regularized(v);
        let state = (self.t, &self.y[..n], &self.y[n..2 * n]);
        self.monitor
            .step(&mut self.system, state, saddle.eps(), 1.0, &mut solve);
    }

    /// Redundant constraints found at the start and the singular
    /// configurations passed so far (see [`Monitor`]).
    #[must_use]
    pub fn monitor(&self) -> &Monitor {
        &self.monitor
    }

    /// Current time.
    #[must_use]
    pub fn t(&self) -> f64 {
        self.t
    }
    /// Positions.
    #[must_use]
    pub fn q(&self) -> &[f64] {
        &self.y[..self.n]
    }
    /// Velocities.
    #[must_use]
    pub fn qd(&self) -> &[f64] {
        &self.y[self.n..2 * self.n]
    }
    /// Accelerations (index-1 solution at the state).
    #[must_use]
    pub fn qdd(&self) -> &[f64] {
        &self.qdd
    }
    /// Lagrange multipliers at the state.
    #[must_use]
    pub fn lambda(&self) -> &[f64] {
        &self.lambda
    }
    /// Work of Q_A and of the drivers since the start (integrated to the
    /// tolerance).
    #[must_use]
    pub fn work(&self) -> f64 {
        self.y[2 * self.n]
    }
    /// Kinetic energy ½ q̇ᵀ M q̇.
    pub fn kinetic_energy(&mut self) -> f64 {
        let n = self.n;
        self.system.mass(&self.y[..n], &mut self.mass);
        super::kinetic_energy(&self.mass, &self.y[n..2 * n])
    }
    /// Counters.
    #[must_use]
    pub fn stats(&self) -> AccurateStats {
        self.stats
    }
    /// The system.
    pub fn system_mut(&mut self) -> &mut S {
        &mut self.system
    }
}
