//! Static equilibrium of a system with inertia ([`equilibrium`]):
//! Φ(q, t₀) = 0 and Φ_qᵀ λ = Q_A(q, 0, t₀), the **stable** one reached from
//! a start, and its stability. It reads the system through
//! [`ForwardSystem`] alone (Φ, Φ_q, γ, Q_A and ∂Q_A/∂q), so generated code
//! and the tape back end run the same descent.
//!
//! Plain Newton on the stationarity equations converges to whichever root
//! is nearest, a maximum of the potential as readily as a minimum. Instead
//! the solver descends the potential V (Q_A = −∇V for the conservative
//! part) on the constraint manifold:
//!
//! 1. q is kept on Φ(q, t₀) = 0 by minimum-norm Newton steps;
//! 2. with N an orthonormal basis of the null space of Φ_q, the reduced
//!    gradient is g = −Nᵀ Q_A and the reduced Hessian H = Nᵀ (K + Σ λᵢ ∇²Φᵢ) N,
//!    K = −∂Q_A/∂q ([`ForwardSystem::applied_q`]), the constraint curvature
//!    vᵀ∇²Φᵢ v from γ ([`ForwardSystem::gamma`]) (γ(v) + γ(−v) − 2γ(0) = −2 vᵀ∇²Φ v),
//!    λ the least-squares multipliers;
//! 3. the step solves |H| d = −g (H's eigenvalues taken in absolute value,
//!    so the step always goes downhill, away from maxima and saddles) and is
//!    accepted when the potential drops, ΔV ≈ −½ (Q(q) + Q(q'))ᵀ(q' − q)
//!    (the work of the forces along the step), halving it otherwise;
//! 4. at a point with g ≈ 0 and a negative eigenvalue of H (a saddle or a
//!    maximum: only when started exactly there) it steps along that
//!    eigenvector.
//!
//! The result is stable when every eigenvalue of H is positive, unstable
//! when one is negative, neutral otherwise (a zero eigenvalue: higher
//! derivatives decide).

use std::fmt;

use nalgebra::{DMatrix, DVector};

use crate::integrate::{DenseScratch, ForwardStructure, ForwardSystem};

/// How stable an equilibrium is, from the reduced Hessian.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stability {
    /// Every eigenvalue of the reduced Hessian is positive: a strict
    /// minimum of the potential on the constraints.
    Stable,
    /// One eigenvalue is zero (within roundoff): the second derivatives do
    /// not decide.
    Neutral,
    /// One eigenvalue is negative: a saddle or a maximum of the potential.
    Unstable,
}

impl fmt::Display for Stability {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Stability::Stable => "stable",
            Stability::Neutral => "neutral (a zero eigenvalue of the reduced Hessian)",
            Stability::Unstable => "unstable",
        })
    }
}

/// A static equilibrium.
#[derive(Clone, Debug)]
pub struct Equilibrium {
    /// Time t₀ of the drivers (if any).
    pub t: f64,
    /// The configuration.
    pub q: Vec<f64>,
    /// λ, one per row of Φ: Φ_qᵀ λ = Q_A.
    pub lambda: Vec<f64>,
    /// Stability from the reduced Hessian.
    pub stability: Stability,
    /// Eigenvalues of the reduced Hessian (ascending; empty when NDOF = 0).
    pub eigenvalues: Vec<f64>,
    /// ‖Φ‖∞ at q.
    pub residual: f64,
    /// ‖Nᵀ Q_A‖∞ at q (the reduced gradient; 0 at an exact equilibrium).
    pub gradient: f64,
    /// Descent iterations.
    pub iterations: usize,
}

/// Why no equilibrium was found.
#[derive(Clone, Debug, PartialEq)]
pub enum EquilibriumError {
    /// The model has no inertia, gravity or forces (a model file's; a
    /// [`ForwardSystem`] always has them).
    NoDynamics,
    /// More equations than coordinates, or dependent equations (Φ_q does
    /// not have full row rank at q).
    Singular {
        /// Where: `"assembly"` or the iteration.
        at: String,
    },
    /// Φ(q, t₀) = 0 could not be met from the configuration reached.
    NoAssembly {
        /// ‖Φ‖∞ where it stopped.
        residual: f64,
    },
    /// The descent stopped before the reduced gradient vanished.
    NoConvergence {
        /// Iterations done.
        iterations: usize,
        /// ‖Nᵀ Q_A‖∞ where it stopped.
        gradient: f64,
    },
    /// A value of Φ, Φ_q, Q_A or ∂Q_A/∂q is NaN or infinite.
    NonFinite {
        /// Which quantity.
        what: &'static str,
    },
}

impl fmt::Display for EquilibriumError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EquilibriumError::NoDynamics => f.write_str(
                "the model has no inertia, gravity or forces: an equilibrium needs them",
            ),
            EquilibriumError::Singular { at } => write!(
                f,
                "Φ_q does not have full row rank ({at}): dependent or too many equations"
            ),
            EquilibriumError::NoAssembly { residual } => write!(
                f,
                "the constraints cannot be met from the configuration reached (‖Φ‖∞ = {residual:.3e})"
            ),
            EquilibriumError::NoConvergence {
                iterations,
                gradient,
            } => write!(
                f,
                "no equilibrium after {iterations} descent steps (reduced gradient {gradient:.3e})"
            ),
            EquilibriumError::NonFinite { what } => {
                write!(f, "a non-finite value of {what} during the descent")
            }
        }
    }
}

impl std::error::Error for EquilibriumError {}

const MAX_ITERATIONS: usize = 500;
const MAX_HALVINGS: usize = 60;

/// The evaluations the descent makes, on a [`ForwardSystem`] at t₀ and
/// q̇ = 0: Φ_q and ∂Q_A/∂q as dense matrices, from the sparse values
/// written into zeros when the system gives its structure (the entries
/// outside it exactly +0), else from the dense methods.
struct Evaluator<'s, S: ForwardSystem + ?Sized> {
    system: &'s mut S,
    structure: Option<ForwardStructure>,
    values: Vec<f64>,
    dense: Vec<f64>,
    t: f64,
    zeros: Vec<f64>,
    n: usize,
    m: usize,
}

impl<'s, S: ForwardSystem + ?Sized> Evaluator<'s, S> {
    fn new(system: &'s mut S, t: f64) -> Evaluator<'s, S> {
        let (n, m) = (system.coords(), system.rows());
        let structure = system.structure();
        let most = structure
            .as_ref()
            .map_or(0, |s| s.jacobian.len().max(s.applied_q.len()));
        Evaluator {
            system,
            structure,
            values: vec![0.0; most],
            dense: vec![0.0; n * n.max(m)],
            t,
            zeros: vec![0.0; n],
            n,
            m,
        }
    }

    fn phi(&mut self, q: &[f64]) -> Result<DVector<f64>, EquilibriumError> {
        let mut out = vec![0.0; self.m];
        self.system.phi(q, self.t, &mut out);
        finite(out, "Φ").map(DVector::from_vec)
    }

    /// `rows` × n from the sparse values at `positions` (assigned into
    /// zeros, negated if `negate`) or from the dense method's `dense`.
    fn matrix(
        &mut self,
        rows: usize,
        which: Matrix,
        q: &[f64],
    ) -> Result<DMatrix<f64>, EquilibriumError> {
        let (n, t) = (self.n, self.t);
        let negate = matches!(which, Matrix::Stiffness);
        let what = if negate { "∂Q_A/∂q" } else { "Φ_q" };
        let mut out = DMatrix::zeros(rows, n);
        let dense = &mut self.dense[..rows * n];
        match &self.structure {
            Some(s) => {
                let positions = if negate { &s.applied_q } else { &s.jacobian };
                let values = &mut self.values[..positions.len()];
                let scratch = DenseScratch {
                    buffer: dense,
                    cols: n,
                    positions,
                };
                if negate {
                    self.system
                        .applied_q_values(q, &self.zeros, t, scratch, values);
                } else {
                    self.system.jacobian_values(q, t, scratch, values);
                }
                if !values.iter().all(|v| v.is_finite()) {
                    return Err(EquilibriumError::NonFinite { what });
                }
                for (&v, &(r, c)) in values.iter().zip(positions) {
                    out[(r as usize, c as usize)] = if negate { -v } else { v };
                }
            }
            None => {
                if negate {
                    self.system.applied_q(q, &self.zeros, t, dense);
                } else {
                    self.system.jacobian(q, t, dense);
                }
                if !dense.iter().all(|v| v.is_finite()) {
                    return Err(EquilibriumError::NonFinite { what });
                }
                for (k, &v) in dense.iter().enumerate() {
                    // Zeros stay +0, as the structured path leaves them.
                    if v != 0.0 {
                        out[(k / n, k % n)] = if negate { -v } else { v };
                    }
                }
            }
        }
        Ok(out)
    }

    fn jacobian(&mut self, q: &[f64]) -> Result<DMatrix<f64>, EquilibriumError> {
        self.matrix(self.m, Matrix::Jacobian, q)
    }

    fn applied(&mut self, q: &[f64]) -> Result<DVector<f64>, EquilibriumError> {
        let mut out = vec![0.0; self.n];
        self.system.applied(q, &self.zeros, self.t, &mut out);
        finite(out, "Q_A").map(DVector::from_vec)
    }

    /// K = −∂Q_A/∂q.
    fn stiffness(&mut self, q: &[f64]) -> Result<DMatrix<f64>, EquilibriumError> {
        self.matrix(self.n, Matrix::Stiffness, q)
    }

    /// vᵀ∇²Φᵢ v for every row, from γ: γ(v) + γ(−v) − 2γ(0) = −2 vᵀ∇²Φ v.
    fn curvature(&mut self, q: &[f64], v: &[f64]) -> Result<DVector<f64>, EquilibriumError> {
        let m = self.m;
        let (mut plus, mut minus, mut zero) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        let neg: Vec<f64> = v.iter().map(|x| -x).collect();
        let zeros = vec![0.0; v.len()];
        self.system.gamma(q, v, self.t, &mut plus);
        self.system.gamma(q, &neg, self.t, &mut minus);
        self.system.gamma(q, &zeros, self.t, &mut zero);
        let ok = [&plus, &minus, &zero]
            .iter()
            .all(|g| g.iter().all(|x| x.is_finite()));
        if !ok {
            return Err(EquilibriumError::NonFinite { what: "γ" });
        }
        Ok(DVector::from_iterator(
            m,
            (0..m).map(|i| -(plus[i] + minus[i] - 2.0 * zero[i]) / 2.0),
        ))
    }
    /// Moves q onto Φ = 0 by minimum-norm Newton steps.
    fn restore(&mut self, q: &mut DVector<f64>) -> Result<(), EquilibriumError> {
        let scale = q.amax().max(1.0);
        let mut residual = f64::INFINITY;
        for _ in 0..50 {
            let phi = self.phi(q.as_slice())?;
            residual = phi.amax();
            if residual <= 1e-13 * scale {
                return Ok(());
            }
            let j = self.jacobian(q.as_slice())?;
            let jjt = &j * j.transpose();
            let Some(y) = jjt.lu().solve(&phi) else {
                return Err(EquilibriumError::Singular {
                    at: "restoring the constraints".to_owned(),
                });
            };
            *q -= j.transpose() * y;
        }
        // Converged to roundoff without reaching the bound: accept what
        // Newton's quadratic convergence could give.
        if residual <= 1e-10 * scale {
            Ok(())
        } else {
            Err(EquilibriumError::NoAssembly { residual })
        }
    }
}

/// Which matrix [`Evaluator::matrix`] evaluates.
#[derive(Clone, Copy)]
enum Matrix {
    Jacobian,
    Stiffness,
}

/// `values` if every one is finite.
fn finite(values: Vec<f64>, what: &'static str) -> Result<Vec<f64>, EquilibriumError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(values)
    } else {
        Err(EquilibriumError::NonFinite { what })
    }
}

/// What one point of the descent gives.
struct Local {
    q_a: DVector<f64>,
    basis: DMatrix<f64>,
    lambda: DVector<f64>,
    gradient: DVector<f64>,
    hessian: DMatrix<f64>,
}

fn local<S: ForwardSystem + ?Sized>(
    tapes: &mut Evaluator<'_, S>,
    q: &DVector<f64>,
) -> Result<Local, EquilibriumError> {
    let n = q.len();
    let j = tapes.jacobian(q.as_slice())?;
    let m = j.nrows();
    let q_a = tapes.applied(q.as_slice())?;
    // Null space of Φ_q: eigenvectors of Φ_qᵀΦ_q with the n − m smallest
    // eigenvalues; the m-th must be clearly nonzero (full row rank).
    let jtj = j.transpose() * &j;
    let eig = jtj.symmetric_eigen();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let d = n - m;
    let largest = eig.eigenvalues.amax();
    if m > 0 && eig.eigenvalues[order[d]] <= 1e-20 * largest.max(f64::MIN_POSITIVE) {
        return Err(EquilibriumError::Singular {
            at: "the descent".to_owned(),
        });
    }
    let basis = DMatrix::from_fn(n, d, |r, c| eig.eigenvectors[(r, order[c])]);
    // λ: least squares of Φ_qᵀλ = Q_A.
    let lambda = if m == 0 {
        DVector::zeros(0)
    } else {
        (&j * j.transpose())
            .lu()
            .solve(&(&j * &q_a))
            .ok_or_else(|| EquilibriumError::Singular {
                at: "the multipliers".to_owned(),
            })?
    };
    let gradient = -(basis.transpose() * &q_a);
    let k = tapes.stiffness(q.as_slice())?;
    let mut hessian = basis.transpose() * k * &basis;
    // Constraint curvature Σ λᵢ B_i(n_a, n_b), by polarization.
    let h = |tapes: &mut Evaluator<'_, S>, v: &DVector<f64>| -> Result<f64, EquilibriumError> {
        Ok(tapes.curvature(q.as_slice(), v.as_slice())?.dot(&lambda))
    };
    let diag: Vec<f64> = (0..d)
        .map(|a| h(tapes, &basis.column(a).into_owned()))
        .collect::<Result<_, _>>()?;
    for a in 0..d {
        hessian[(a, a)] += diag[a];
        for b in a + 1..d {
            let sum = basis.column(a) + basis.column(b);
            let c = (h(tapes, &sum)? - diag[a] - diag[b]) / 2.0;
            hessian[(a, b)] += c;
            hessian[(b, a)] += c;
        }
    }
    let hessian = (&hessian + hessian.transpose()) / 2.0;
    Ok(Local {
        q_a,
        basis,
        lambda,
        gradient,
        hessian,
    })
}

/// Eigenvalues (ascending) and eigenvectors of a symmetric matrix.
fn eigen(h: &DMatrix<f64>) -> (Vec<f64>, DMatrix<f64>) {
    let e = h.clone().symmetric_eigen();
    let mut order: Vec<usize> = (0..h.nrows()).collect();
    order.sort_by(|&a, &b| e.eigenvalues[a].total_cmp(&e.eigenvalues[b]));
    let values = order.iter().map(|&k| e.eigenvalues[k]).collect();
    let vectors = DMatrix::from_fn(h.nrows(), h.ncols(), |r, c| e.eigenvectors[(r, order[c])]);
    (values, vectors)
}

/// The stable static equilibrium of `system` reached from its stated
/// start ([`ForwardSystem::initial_state`]) at time `t0` (drivers, if any,
/// held at their value there); see [the module docs](self).
///
/// # Errors
/// As [`equilibrium`].
pub fn equilibrium_from_start<S: ForwardSystem + ?Sized>(
    system: &mut S,
    t0: f64,
) -> Result<Equilibrium, EquilibriumError> {
    let n = system.coords();
    let (mut q, mut qd) = (vec![0.0; n], vec![0.0; n]);
    system.initial_state(&mut q, &mut qd);
    equilibrium(system, &q, t0)
}

/// The stable static equilibrium of `system` reached from the
/// configuration `start` (n values) at time `t0`: the descent of [the
/// module docs](self). Allocates (dense matrices, an eigendecomposition
/// per iteration); not a per-step path.
///
/// # Errors
/// [`EquilibriumError`]: singular constraints, no assembly, no
/// convergence, non-finite values; a `start` of another length is
/// [`EquilibriumError::Singular`] at `"a start of the wrong length"`.
pub fn equilibrium<S: ForwardSystem + ?Sized>(
    system: &mut S,
    start: &[f64],
    t0: f64,
) -> Result<Equilibrium, EquilibriumError> {
    if start.len() != system.coords() {
        return Err(EquilibriumError::Singular {
            at: "a start of the wrong length".to_owned(),
        });
    }
    if system.rows() > system.coords() {
        return Err(EquilibriumError::Singular {
            at: "more equations than coordinates".to_owned(),
        });
    }
    let mut tapes = Evaluator::new(system, t0);
    let mut q = DVector::from_column_slice(start);
    tapes.restore(&mut q)?;
    let mut last_gradient = f64::INFINITY;
    for iteration in 0..MAX_ITERATIONS {
        let here = local(&mut tapes, &q)?;
        let force_scale = here.q_a.amax().max(here.lambda.amax()).max(1e-300);
        let gnorm = here.gradient.amax();
        last_gradient = gnorm;
        let (values, vectors) = eigen(&here.hessian);
        let hscale = values.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let small = 1e-9 * hscale.max(1e-300);
        let stationary = gnorm <= 1e-11 * force_scale.max(1.0);
        let lowest = values.first().copied().unwrap_or(0.0);
        if stationary && lowest >= -small {
            let stability = if lowest > small || values.is_empty() {
                Stability::Stable
            } else {
                Stability::Neutral
            };
            let residual = tapes.phi(q.as_slice())?.amax();
            return Ok(Equilibrium {
                t: t0,
                q: q.as_slice().to_vec(),
                lambda: here.lambda.as_slice().to_vec(),
                stability,
                eigenvalues: values,
                residual,
                gradient: gnorm,
                iterations: iteration,
            });
        }
        // The step in null-space coordinates, and the predicted decrease
        // (its directional derivative, negative).
        let dred = if stationary {
            // A saddle or a maximum: along the most negative curvature.
            vectors.column(0).into_owned() * 0.1
        } else {
            let mut x = vectors.transpose() * &here.gradient;
            for (k, xk) in x.iter_mut().enumerate() {
                *xk /= -values[k].abs().max(small.max(1e-12 * force_scale));
            }
            vectors * x
        };
        let step = &here.basis * &dred;
        // Trust: at most half a unit (radian or length unit) per iteration.
        let longest = step.amax();
        let cap = if longest > 0.5 { 0.5 / longest } else { 1.0 };
        let slope = here.gradient.dot(&dred);
        let mut alpha = cap;
        let mut accepted = false;
        for _ in 0..MAX_HALVINGS {
            let mut trial = &q + &step * alpha;
            if tapes.restore(&mut trial).is_ok() {
                let q1 = tapes.applied(trial.as_slice())?;
                let dv = -0.5 * (&here.q_a + &q1).dot(&(&trial - &q));
                let predicted = if stationary {
                    // Second order along negative curvature.
                    0.5 * alpha * alpha * lowest * dred.norm_squared()
                } else {
                    alpha * slope
                };
                if dv <= 1e-4 * predicted || (dv <= 0.0 && stationary) {
                    q = trial;
                    accepted = true;
                    break;
                }
            }
            alpha /= 2.0;
        }
        if !accepted {
            break;
        }
    }
    Err(EquilibriumError::NoConvergence {
        iterations: MAX_ITERATIONS,
        gradient: last_gradient,
    })
}
