//! HHT's start: the consistent initial state (positions and velocities
//! projected onto the constraints, mass-orthogonally, through the
//! regularized saddle-point matrix), q̈ and λ from the index-1 system, and
//! the sparse Newton matrix's first factorization.

use super::{Consistency, Correct, Hht, amax, finite};
use crate::integrate::{ForwardSystem, IntegrateError};
use crate::linalg::LinearSolver;

impl<S: ForwardSystem> Hht<S> {
    /// Factors the sparse Newton matrix once at the start (h → 0: M and
    /// the constraint columns), so the sparse LU chooses its pivots and
    /// records its elimination (which allocates) here rather than in the
    /// first step. A failure is left to the first step to report.
    pub(super) fn prepare_sparse(&mut self) {
        if self.kkt.is_none() {
            return;
        }
        self.qn.copy_from_slice(&self.q);
        self.qdn.copy_from_slice(&self.qd);
        self.lambdan.copy_from_slice(&self.lambda);
        if self.evaluate(self.t, true).is_err() {
            return;
        }
        if let Some(kkt) = &mut self.kkt {
            kkt.assemble(&self.mass, (1.0 + self.alpha, 0.0, 0.0));
            kkt.regularize(&self.mass, 1.0 + self.alpha, &mut self.row_max);
            if finite(&kkt.values) {
                // An error here is met again, and reported, by the step.
                let _ = kkt.lu.factor(&kkt.values, 1e-14);
            }
        }
    }

    /// Factors the projections' matrix [I Φ_qᵀ; Φ_q −E] (regularized
    /// where Φ_q loses rank; the jacobian in `self.jac`).
    pub(super) fn factor_projection(&mut self, what: &'static str) -> Result<(), IntegrateError> {
        let n = self.n;
        self.saddle
            .factor(&self.ones, &self.jac)
            .map_err(|k| IntegrateError::Singular {
                t: self.t,
                what,
                at: if k < n {
                    self.system.coordinate_name(k).to_owned()
                } else {
                    self.system.equation_name(k - n).to_owned()
                },
            })
    }

    /// `ys[n..]` ← ν − Φ_q q̇, from `jac` (dense m × n) and `nu`; `ys[..n]`
    /// ← 0: the right-hand side of the velocity projection.
    pub(super) fn velocity_residual(&mut self) {
        let n = self.n;
        self.ys[..n].fill(0.0);
        for i in 0..self.m {
            let r: f64 = self.jac[i * n..(i + 1) * n]
                .iter()
                .zip(&self.qd)
                .map(|(a, v)| a * v)
                .sum();
            self.ys[n + i] = self.nu[i] - r;
        }
    }

    /// x ← x + Δx, the minimum-norm correction Φ_q Δx = `ys[n..]`
    /// (the projections' matrix factored).
    pub(super) fn correct(&mut self, which: Correct) {
        let n = self.n;
        self.saddle.solve(&self.jac, &mut self.ys);
        let x = match which {
            Correct::Positions => &mut self.q,
            Correct::Velocities => &mut self.qd,
            Correct::Reported => &mut self.qd_out,
        };
        for (xj, d) in x.iter_mut().zip(&self.ys[..n]) {
            *xj += d;
        }
    }

    pub(super) fn make_consistent(&mut self) -> Result<Consistency, IntegrateError> {
        let mut c = Consistency::default();
        let t = self.t;
        let q0 = self.q.clone();
        let scale = amax(&self.q).max(1.0);
        let mut residual = f64::INFINITY;
        let mut done = false;
        for it in 0..50 {
            self.system.phi(&self.q, t, &mut self.phi);
            if !finite(&self.phi) {
                return Err(self.non_finite("Φ at the start"));
            }
            residual = amax(&self.phi);
            if it == 0 {
                c.phi = residual;
            }
            if residual <= 1e-14 * scale {
                done = true;
                break;
            }
            self.system.jacobian(&self.q, t, &mut self.jac);
            if !finite(&self.jac) {
                return Err(self.non_finite("Φ_q at the start"));
            }
            self.factor_projection("the projection of the initial positions")?;
            let n = self.n;
            self.ys[..n].fill(0.0);
            for (y, &p) in self.ys[n..].iter_mut().zip(&self.phi) {
                *y = -p;
            }
            self.correct(Correct::Positions);
        }
        if !done && residual > 1e-10 * scale {
            return Err(IntegrateError::NoAssembly {
                residual,
                iterations: 50,
            });
        }
        c.dq = self
            .q
            .iter()
            .zip(&q0)
            .fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
        // Velocities: one linear projection.
        self.system.jacobian(&self.q, t, &mut self.jac);
        self.system.nu(&self.q, t, &mut self.nu);
        if !finite(&self.jac) || !finite(&self.nu) {
            return Err(self.non_finite("Φ_q or ν at the start"));
        }
        self.velocity_residual();
        c.velocity = amax(&self.ys);
        if self.m > 0 {
            self.factor_projection("the projection of the initial velocities")?;
            let qd0 = self.qd.clone();
            self.correct(Correct::Velocities);
            c.dqd = self
                .qd
                .iter()
                .zip(&qd0)
                .fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
        }
        Ok(c)
    }

    /// q̈, λ at the current state from [M Φ_qᵀ; Φ_q 0][q̈; λ] = [Q_A; γ].
    pub(super) fn index1(&mut self) -> Result<(), IntegrateError> {
        let (n, t) = (self.n, self.t);
        let s = &mut self.system;
        s.mass(&self.q, &mut self.mass);
        s.applied(&self.q, &self.qd, t, &mut self.qa);
        s.jacobian(&self.q, t, &mut self.jac);
        s.gamma(&self.q, &self.qd, t, &mut self.phi);
        if !finite(&self.mass) || !finite(&self.qa) || !finite(&self.jac) || !finite(&self.phi) {
            return Err(self.non_finite("M, Q_A, Φ_q or γ at the start"));
        }
        self.rhs[..n].copy_from_slice(&self.qa);
        self.rhs[n..].copy_from_slice(&self.phi);
        self.saddle
            .factor(&self.mass, &self.jac)
            .map_err(|k| IntegrateError::Singular {
                t,
                what: "the index-1 matrix [M Φ_qᵀ; Φ_q 0]",
                at: if k < n {
                    format!("q̈ of {}", self.system.coordinate_name(k))
                } else {
                    format!("λ of {}", self.system.equation_name(k - n))
                },
            })?;
        self.saddle.solve(&self.jac, &mut self.rhs);
        self.qdd.copy_from_slice(&self.rhs[..n]);
        self.lambda.copy_from_slice(&self.rhs[n..]);
        if !finite(&self.rhs) {
            return Err(self.non_finite("q̈ or λ at the start"));
        }
        if let Some(kkt) = &mut self.kkt {
            kkt.eval_jacobian(&mut self.system, &self.q, t, &mut self.jac);
        }
        self.store_force_and_power();
        Ok(())
    }
}
