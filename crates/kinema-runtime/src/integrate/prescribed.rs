//! Prescribed motion with redundant constraints: kinematics and inverse
//! dynamics of a fully driven model whose rows outnumber its coordinates
//! because some of them are redundant (a parallelogram with a third crank,
//! a door on three hinges), so that Φ_q is m × n with m > n but rank n.
//!
//! The kinematic solver needs a square Φ_q; here every solve goes through
//! the regularized saddle-point matrix of saddle.rs, which holds for any
//! rank:
//!
//! ```text
//! position:      [I Φ_qᵀ; Φ_q 0] [Δq; ·] = [0; −Φ]      (Newton, minimum-norm steps)
//! velocity:      [I Φ_qᵀ; Φ_q 0] [q̇; ·]  = [0; ν]
//! acceleration:  [I Φ_qᵀ; Φ_q 0] [q̈; ·]  = [0; γ]
//! multipliers:   [I Φ_q; Φ_qᵀ 0] [λ; ·]  = [0; Q_A − M q̈]  (the minimum-norm λ)
//! ```
//!
//! The motion is unique (rank n); the multipliers are not: λ is the
//! minimum-norm solution of Φ_qᵀλ = Q_A − M q̈, and the rows it splits
//! among are reported as redundant ([`Monitor::redundancy`]).

use super::monitor::Monitor;
use super::saddle::Saddle;
use super::{ForwardSystem, IntegrateError};

/// Newton iterations of a position solve before it fails.
const MAX_ITERATIONS: usize = 50;

/// The buffers of [`newton`].
struct Work<'a> {
    phi: &'a mut [f64],
    jac: &'a mut [f64],
    rhs: &'a mut [f64],
    ones: &'a [f64],
    saddle: &'a mut Saddle,
}

/// Newton's method on Φ(q, t) = 0 with minimum-norm steps (any rank of
/// Φ_q, any number of rows); leaves Φ_q at the solution factored in
/// `work.saddle` and in `work.jac`. Returns the iterations.
fn newton<S: ForwardSystem>(
    system: &mut S,
    q: &mut [f64],
    t: f64,
    work: Work<'_>,
) -> Result<usize, IntegrateError> {
    let Work {
        phi,
        jac,
        rhs,
        ones,
        saddle,
    } = work;
    let n = q.len();
    let scale = amax(q).max(1.0);
    let mut residual = f64::INFINITY;
    for iteration in 0..=MAX_ITERATIONS {
        system.phi(q, t, phi);
        system.jacobian(q, t, jac);
        if !phi.iter().chain(jac.iter()).all(|v| v.is_finite()) {
            return Err(IntegrateError::NonFinite {
                t,
                what: "Φ or Φ_q".to_owned(),
            });
        }
        residual = amax(phi);
        saddle
            .factor(ones, jac)
            .map_err(|k| IntegrateError::Singular {
                t,
                what: "the position solve's matrix [I Φ_qᵀ; Φ_q 0]",
                at: if k < n {
                    system.coordinate_name(k).to_owned()
                } else {
                    system.equation_name(k - n).to_owned()
                },
            })?;
        if residual <= 1e-14 * scale || iteration == MAX_ITERATIONS {
            break;
        }
        rhs[..n].fill(0.0);
        for (r, &v) in rhs[n..].iter_mut().zip(phi.iter()) {
            *r = -v;
        }
        saddle.solve(jac, rhs);
        for (x, d) in q.iter_mut().zip(&rhs[..n]) {
            *x += d;
        }
        if amax(&rhs[..n]) <= 1e-15 * scale {
            system.phi(q, t, phi);
            system.jacobian(q, t, jac);
            saddle
                .factor(ones, jac)
                .map_err(|_| IntegrateError::NonFinite {
                    t,
                    what: "Φ_q".to_owned(),
                })?;
            return Ok(iteration + 1);
        }
    }
    if residual > 1e-10 * scale {
        return Err(IntegrateError::NoAssembly {
            residual,
            iterations: MAX_ITERATIONS,
        });
    }
    Ok(MAX_ITERATIONS)
}

/// Brings `q` onto Φ(q, t) = 0 by Newton's method with minimum-norm
/// steps, whatever the rank of Φ_q and the number of rows (allocates its
/// buffers): the assembly of a model with redundant constraints, before
/// its rank decides how it runs.
///
/// # Errors
/// No assembly (the residual where Newton stopped), non-finite values.
pub fn assemble<S: ForwardSystem>(
    system: &mut S,
    q: &mut [f64],
    t: f64,
) -> Result<(), IntegrateError> {
    let (n, m) = (system.coords(), system.rows());
    if q.len() != n {
        return Err(IntegrateError::Setup(format!(
            "{n} coordinates, given {} positions",
            q.len()
        )));
    }
    let mut phi = vec![0.0; m];
    let mut jac = vec![0.0; m * n];
    let mut rhs = vec![0.0; n + m];
    let ones = vec![1.0; n];
    let mut saddle = Saddle::new(n, m);
    let work = Work {
        phi: &mut phi,
        jac: &mut jac,
        rhs: &mut rhs,
        ones: &ones,
        saddle: &mut saddle,
    };
    newton(system, q, t, work).map(|_| ())
}

/// The prescribed motion and its state.
#[derive(Debug)]
pub struct Prescribed<S> {
    system: S,
    n: usize,
    m: usize,
    t: f64,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    lambda: Vec<f64>,
    mass: Vec<f64>,
    qa: Vec<f64>,
    jac: Vec<f64>,
    /// Φ_qᵀ (n × m).
    jac_t: Vec<f64>,
    phi: Vec<f64>,
    nu: Vec<f64>,
    rhs: Vec<f64>,
    dual_rhs: Vec<f64>,
    ones_n: Vec<f64>,
    ones_m: Vec<f64>,
    saddle: Saddle,
    dual: Saddle,
    work: f64,
    power: f64,
    monitor: Monitor,
    /// Newton iterations in all.
    iterations: usize,
}

fn amax(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
}

impl<S: ForwardSystem> Prescribed<S> {
    /// The motion at t₀ from the guess q₀ (assembled by Newton).
    /// Allocates every buffer of the run.
    ///
    /// # Errors
    /// Wrong lengths, a configuration that cannot be assembled, non-finite
    /// values, a coordinate without inertia.
    pub fn new(system: S, q0: &[f64], t0: f64) -> Result<Prescribed<S>, IntegrateError> {
        let (n, m) = (system.coords(), system.rows());
        if q0.len() != n {
            return Err(IntegrateError::Setup(format!(
                "{n} coordinates, given {} positions",
                q0.len()
            )));
        }
        let mut p = Prescribed {
            system,
            n,
            m,
            t: t0,
            q: q0.to_vec(),
            qd: vec![0.0; n],
            qdd: vec![0.0; n],
            lambda: vec![0.0; m],
            mass: vec![0.0; n],
            qa: vec![0.0; n],
            jac: vec![0.0; m * n],
            jac_t: vec![0.0; n * m],
            phi: vec![0.0; m],
            nu: vec![0.0; m],
            rhs: vec![0.0; n + m],
            dual_rhs: vec![0.0; n + m],
            ones_n: vec![1.0; n],
            ones_m: vec![1.0; m],
            saddle: Saddle::new(n, m),
            dual: Saddle::new(m, n),
            work: 0.0,
            power: 0.0,
            monitor: Monitor::inactive(),
            iterations: 0,
        };
        p.solve_at(t0)?;
        p.monitor = Monitor::new(&mut p.system, &p.q, t0, 0.0);
        Ok(p)
    }

    /// q, q̇, q̈, λ at `t`, Newton starting from the current q.
    fn solve_at(&mut self, t: f64) -> Result<(), IntegrateError> {
        let n = self.n;
        let work = Work {
            phi: &mut self.phi,
            jac: &mut self.jac,
            rhs: &mut self.rhs,
            ones: &self.ones_n,
            saddle: &mut self.saddle,
        };
        self.iterations += newton(&mut self.system, &mut self.q, t, work)?;
        // Velocity and acceleration: minimum-norm (unique: rank n).
        self.system.nu(&self.q, t, &mut self.nu);
        self.rhs[..n].fill(0.0);
        self.rhs[n..].copy_from_slice(&self.nu);
        self.saddle.solve(&self.jac, &mut self.rhs);
        self.qd.copy_from_slice(&self.rhs[..n]);
        self.system.gamma(&self.q, &self.qd, t, &mut self.phi);
        self.rhs[..n].fill(0.0);
        self.rhs[n..].copy_from_slice(&self.phi);
        self.saddle.solve(&self.jac, &mut self.rhs);
        self.qdd.copy_from_slice(&self.rhs[..n]);
        // λ: the minimum-norm solution of Φ_qᵀλ = Q_A − M q̈.
        self.system.mass(&self.q, &mut self.mass);
        self.system.applied(&self.q, &self.qd, t, &mut self.qa);
        for r in 0..self.m {
            for c in 0..n {
                self.jac_t[c * self.m + r] = self.jac[r * n + c];
            }
        }
        self.dual
            .factor(&self.ones_m, &self.jac_t)
            .map_err(|_| IntegrateError::Singular {
                t,
                what: "the multipliers' system [I Φ_q; Φ_qᵀ 0]",
                at: "λ".to_owned(),
            })?;
        let m = self.m;
        self.dual_rhs[..m].fill(0.0);
        for (i, f) in self.dual_rhs[m..].iter_mut().enumerate() {
            *f = self.qa[i] - self.mass[i] * self.qdd[i];
        }
        self.dual.solve(&self.jac_t, &mut self.dual_rhs);
        self.lambda.copy_from_slice(&self.dual_rhs[..m]);
        let all = [&self.qd, &self.qdd, &self.lambda];
        if !all.iter().all(|v| v.iter().all(|x| x.is_finite())) {
            return Err(IntegrateError::NonFinite {
                t,
                what: "q̇, q̈ or λ".to_owned(),
            });
        }
        let pq: f64 = self.qa.iter().zip(&self.qd).map(|(a, b)| a * b).sum();
        let pc: f64 = self.lambda.iter().zip(&self.nu).map(|(a, b)| a * b).sum();
        self.power = pq - pc;
        Ok(())
    }

    /// The motion at `t_end`: Newton from the Taylor prediction of the
    /// current state; the work account by the trapezoidal rule.
    ///
    /// # Errors
    /// As [`Prescribed::new`].
    pub fn advance_to(&mut self, t_end: f64) -> Result<(), IntegrateError> {
        let h = t_end - self.t;
        if !(h.is_finite() && h > 0.0) {
            return Err(IntegrateError::Setup(format!(
                "cannot move from t = {} to t = {t_end}",
                self.t
            )));
        }
        for ((q, &v), &a) in self.q.iter_mut().zip(&self.qd).zip(&self.qdd) {
            *q += h * v + 0.5 * h * h * a;
        }
        let p0 = self.power;
        self.solve_at(t_end)?;
        self.t = t_end;
        self.work += 0.5 * h * (p0 + self.power);
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
    /// Velocities.
    #[must_use]
    pub fn qd(&self) -> &[f64] {
        &self.qd
    }
    /// Accelerations.
    #[must_use]
    pub fn qdd(&self) -> &[f64] {
        &self.qdd
    }
    /// The minimum-norm multipliers.
    #[must_use]
    pub fn lambda(&self) -> &[f64] {
        &self.lambda
    }
    /// Work of Q_A and of the drivers since the start (trapezoidal rule
    /// over the output times).
    #[must_use]
    pub fn work(&self) -> f64 {
        self.work
    }
    /// Kinetic energy ½ q̇ᵀ M q̇.
    pub fn kinetic_energy(&mut self) -> f64 {
        self.system.mass(&self.q, &mut self.mass);
        super::kinetic_energy(&self.mass, &self.qd)
    }
    /// Newton iterations in all.
    #[must_use]
    pub fn iterations(&self) -> usize {
        self.iterations
    }
    /// The redundancy found at the start.
    #[must_use]
    pub fn monitor(&self) -> &Monitor {
        &self.monitor
    }
    /// The system.
    pub fn system_mut(&mut self) -> &mut S {
        &mut self.system
    }
}
