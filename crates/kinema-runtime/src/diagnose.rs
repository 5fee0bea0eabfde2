//! Rank-revealing diagnosis of Φ_q (error and monitor paths only;
//! allocates): the one rank rule of the runtime and of `kinema check`.
//!
//! Every decision is made on the equilibrated matrix R Φ_q C (R, C diagonal
//! powers of two, every row and column maximum in [½, 2]; see
//! `linalg::Equilibration`), so it does not depend on the units of the
//! coordinates or the equations, and entries of any finite size reach the
//! SVD near 1, where it cannot overflow.

use nalgebra::{DMatrix, SVD};

use crate::error::Dependency;
use crate::linalg::Equilibration;
use crate::system::System;

/// Largest n for which the dense SVD is run (≈ 1 s at n = 600).
pub const MAX_DENSE_DIAGNOSIS: usize = 600;

/// A component of a unit singular vector at least this large names its
/// equation or coordinate. Near (not at) a singular configuration — where a
/// passage's bisection locates it, condition ~10⁶ — the smallest singular
/// vectors carry components of order σ_min/σ of the uninvolved rows: 10⁻⁶
/// named nearly every equation of a six-bar whose dyad straightens.
const INVOLVED: f64 = 1e-3;

/// Numerical rank and condition of Φ_q under the runtime's rule (see
/// [`rank`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rank {
    /// n minus the number of negligible singular values.
    pub rank: usize,
    /// n.
    pub dim: usize,
    /// σ_max / σ_min of the equilibrated Φ_q (∞ if exactly singular).
    pub condition: f64,
}

impl Rank {
    /// `true` when Φ_q is singular or within the threshold of a singular
    /// configuration: rank deficient, or condition ≥ τ^−0.4 (10⁴ for the
    /// default τ = 10⁻¹⁰). The threshold is where q̈ stops being trustworthy:
    /// its error grows like the square of the condition times Newton's
    /// residual (the position's error enters γ through q̇).
    #[must_use]
    pub fn near_singular(&self, singular_tolerance: f64) -> bool {
        self.rank < self.dim || self.condition >= near_singular_condition(singular_tolerance)
    }
}

/// The condition number from which Φ_q counts as near singular: τ^−0.4.
#[must_use]
pub fn near_singular_condition(singular_tolerance: f64) -> f64 {
    singular_tolerance.powf(-0.4)
}

/// Why [`rank`] could not decide.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RankError {
    /// n > [`MAX_DENSE_DIAGNOSIS`].
    #[error("Φ_q is {0} × {0}: outside the sizes of the dense rank-revealing diagnosis")]
    Size(usize),
    /// An entry of Φ_q is NaN or infinite.
    #[error("Φ_q has a non-finite entry")]
    NonFinite,
    /// The SVD did not converge or produced a non-finite singular value.
    #[error("the singular value decomposition of Φ_q failed")]
    Decomposition,
}

/// The runtime's rank rule, shared by the lock-up diagnosis, the run-time
/// monitor and `kinema check`: equilibrate Φ_q (nonzeros `values` at
/// `pattern`, n × n) to R Φ_q C, take its singular values σ₁ ≥ … ≥ σₙ;
/// σₖ is negligible when σₖ ≤ max(10 τ, n ε) σ₁. The condition is σ₁/σₙ of
/// the equilibrated matrix.
///
/// A 0 × 0 Φ_q (a system without coordinates) has full rank 0 and
/// condition 1: it is never singular.
///
/// # Errors
/// [`RankError`] for a size above [`MAX_DENSE_DIAGNOSIS`], a
/// non-finite entry, or a failed decomposition — never a panic.
pub fn rank(
    n: usize,
    pattern: &[(u32, u32)],
    values: &[f64],
    singular_tolerance: f64,
) -> Result<Rank, RankError> {
    if n == 0 {
        return Ok(Rank {
            rank: 0,
            dim: 0,
            condition: 1.0,
        });
    }
    let svd = equilibrated_svd(n, pattern, values, false)?;
    Ok(svd.rank(singular_tolerance))
}

/// The SVD of the equilibrated matrix, checked.
struct Decomposition {
    n: usize,
    svd: SVD<f64, nalgebra::Dyn, nalgebra::Dyn>,
}

impl Decomposition {
    fn sigma_max(&self) -> f64 {
        self.svd.singular_values.max()
    }

    fn cutoff(&self, singular_tolerance: f64) -> f64 {
        (10.0 * singular_tolerance).max(self.n as f64 * f64::EPSILON) * self.sigma_max()
    }

    fn rank(&self, singular_tolerance: f64) -> Rank {
        let sigma = &self.svd.singular_values;
        let cutoff = self.cutoff(singular_tolerance);
        let min = sigma.min();
        Rank {
            rank: sigma.iter().filter(|&&s| s > cutoff).count(),
            dim: self.n,
            condition: if min > 0.0 {
                self.sigma_max() / min
            } else {
                f64::INFINITY
            },
        }
    }
}

/// Equilibrated entries below this magnitude are dropped before the SVD
/// (see [`equilibrated_svd`]).
const NEGLIGIBLE: f64 = 1e-100;

fn equilibrated_svd(
    n: usize,
    pattern: &[(u32, u32)],
    values: &[f64],
    vectors: bool,
) -> Result<Decomposition, RankError> {
    if n == 0 || n > MAX_DENSE_DIAGNOSIS {
        // n = 0 is answered by the callers (full rank 0).
        return Err(RankError::Size(n));
    }
    if values.iter().any(|v| !v.is_finite()) {
        return Err(RankError::NonFinite);
    }
    let mut eq = Equilibration::new(n, values.len());
    eq.compute(pattern, values);
    // Factors near the ends of the exponent range can overflow in rᵢ cⱼ,
    // making an equilibrated entry infinite or NaN: the decomposition is
    // refused (Φ_q's own entries are finite, checked above).
    if eq.values.iter().any(|v| !v.is_finite()) {
        return Err(RankError::Decomposition);
    }
    let mut a = DMatrix::<f64>::zeros(n, n);
    for (&(r, c), &v) in pattern.iter().zip(eq.values.iter()) {
        if let Some(slot) = a.get_mut((r as usize, c as usize)) {
            // Negligible entries are dropped: nalgebra's SVD turns columns
            // of entries near 1e-154 (whose squares underflow) into a NaN
            // singular value and panics (fuzz seed 2828: one entry of
            // 1.8e308 equilibrated the others of its column to 1e-154).
            // The perturbation, at most n · NEGLIGIBLE in a matrix whose
            // rows and columns have maxima near 1, is far below the SVD's
            // own error (ε ‖A‖), so no rank or condition the rule reads
            // changes.
            *slot = if v.abs() < NEGLIGIBLE { 0.0 } else { v };
        }
    }
    // Entries are now at most 2 in magnitude: nothing the SVD squares can
    // overflow. Its result is checked all the same.
    let svd = SVD::try_new(a, vectors, vectors, f64::EPSILON, 200 * n + 1000)
        .ok_or(RankError::Decomposition)?;
    if svd.singular_values.iter().any(|s| !s.is_finite()) {
        return Err(RankError::Decomposition);
    }
    if vectors && (svd.u.is_none() || svd.v_t.is_none()) {
        return Err(RankError::Decomposition);
    }
    Ok(Decomposition { n, svd })
}

/// Explains a singular or nearly singular Φ_q (nonzeros `values` in the
/// system's pattern order): which equations are dependent, which are
/// redundant, which coordinates move freely, under the rule of [`rank`].
/// See [`Dependency`] for the maths. Allocates; `rank` and `condition` are
/// `None` when the diagnosis cannot run (see [`RankError`]).
#[must_use]
pub fn dependency<S: System + ?Sized>(
    system: &S,
    values: &[f64],
    singular_tolerance: f64,
) -> Dependency {
    let n = system.len();
    let mut dep = Dependency {
        rank: None,
        condition: None,
        dim: n,
        equations: Vec::new(),
        redundant: Vec::new(),
        coordinates: Vec::new(),
    };
    if n == 0 {
        // Nothing to depend on: full rank 0, condition 1 (see [`rank`]).
        dep.rank = Some(0);
        dep.condition = Some(1.0);
        return dep;
    }
    let Ok(decomposition) = equilibrated_svd(n, system.jacobian_pattern(), values, true) else {
        return dep;
    };
    let rank = decomposition.rank(singular_tolerance);
    let svd = &decomposition.svd;
    let (Some(u), Some(v_t)) = (&svd.u, &svd.v_t) else {
        return dep;
    };
    let sigma = &svd.singular_values;
    dep.condition = Some(rank.condition);
    let cutoff = decomposition.cutoff(singular_tolerance);
    let smallest = sigma.imin();
    let null: Vec<usize> = (0..n)
        .filter(|&k| sigma[k] <= cutoff || k == smallest)
        .collect();
    dep.rank = Some(rank.rank);

    let mut eq_involved = vec![false; n];
    let mut coord_involved = vec![false; n];
    for &k in &null {
        for i in 0..n {
            eq_involved[i] |= u[(i, k)].abs() >= INVOLVED;
            coord_involved[i] |= v_t[(k, i)].abs() >= INVOLVED;
        }
    }
    dep.equations = names(system, &eq_involved, S::equation_name);
    dep.coordinates = names(system, &coord_involved, S::coordinate_name);

    // Redundant equations: Gaussian elimination on the null vectors (rows of
    // W = [u_k]ᵀ). Each step picks, among the entries at least 1e-3 of the
    // largest remaining one, the last-written equation; it is called
    // redundant (the others of its combination can replace it), and is
    // eliminated from the remaining null vectors.
    let w: Vec<Vec<f64>> = null
        .iter()
        .map(|&k| (0..n).map(|i| u[(i, k)]).collect())
        .collect();
    let picked = redundant_set(w);
    dep.redundant = picked
        .iter()
        .map(|&i| system.equation_name(i).to_owned())
        .collect();
    dep
}

/// Redundant equations from the left null vectors `w` (each of length m):
/// Gaussian elimination on them. Each step picks, among the entries at
/// least 1e-3 of the largest remaining one, the last-written equation; it
/// is called redundant (the others of its combination can replace it), and
/// is eliminated from the remaining null vectors. Sorted indices.
pub(crate) fn redundant_set(mut w: Vec<Vec<f64>>) -> Vec<usize> {
    let mut picked = Vec::with_capacity(w.len());
    for r in 0..w.len() {
        let largest = w[r..].iter().flatten().fold(0.0_f64, |m, x| m.max(x.abs()));
        if largest == 0.0 {
            break;
        }
        let mut choice = None;
        for (s, row) in w.iter().enumerate().skip(r) {
            for (i, &x) in row.iter().enumerate() {
                let better = match choice {
                    None => true,
                    Some((_, j, y)) => i > j || (i == j && x.abs() > f64::abs(y)),
                };
                if x.abs() >= 1e-3 * largest && better {
                    choice = Some((s, i, x));
                }
            }
        }
        let Some((s, i, _)) = choice else { break };
        w.swap(r, s);
        let pivot_row = w[r].clone();
        for row in w.iter_mut().skip(r + 1) {
            let f = row[i] / pivot_row[i];
            for (x, p) in row.iter_mut().zip(&pivot_row) {
                *x -= f * p;
            }
        }
        picked.push(i);
    }
    picked.sort_unstable();
    picked
}

fn names<S: System + ?Sized>(
    system: &S,
    mask: &[bool],
    name: fn(&S, usize) -> &str,
) -> Vec<String> {
    mask.iter()
        .enumerate()
        .filter(|&(_, &m)| m)
        .map(|(i, _)| name(system, i).to_owned())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Fuzz seed 2828: a Φ_q with one entry of f64::MAX (a point drawn at
    /// y = −1.8e308) equilibrates the rest of its column to about 1e-154,
    /// on which nalgebra's SVD made a NaN singular value and panicked. The
    /// diagnosis must run (or refuse), never panic.
    #[test]
    fn extreme_entries_do_not_panic_the_svd() {
        let pattern: [(u32, u32); 26] = [
            (0, 2),
            (1, 2),
            (2, 3),
            (2, 5),
            (3, 4),
            (3, 5),
            (4, 3),
            (4, 5),
            (4, 6),
            (4, 8),
            (5, 4),
            (5, 5),
            (5, 7),
            (5, 8),
            (6, 8),
            (7, 3),
            (7, 5),
            (7, 9),
            (7, 11),
            (8, 4),
            (8, 5),
            (8, 10),
            (8, 11),
            (9, 11),
            (10, 2),
            (11, 5),
        ];
        let values = [
            1.0,
            1.0,
            1.0,
            f64::MAX,
            1.0,
            -5.0,
            1.0,
            -4.0,
            -1.0,
            0.993_346_653_975_306_1,
            1.0,
            121.267,
            -1.0,
            -4.900_332_889_206_208,
            1.0,
            1.0,
            4.0,
            -1.0,
            11.575,
            1.0,
            12.626,
            -1.0,
            -700.0,
            1.0,
            1.0,
            1.0,
        ];
        let decomposition = equilibrated_svd(12, &pattern, &values, true).expect("a diagnosis");
        // Rows 0, 1 and 10 have their only entry in column 2: dependent.
        assert!(decomposition.rank(1e-10).rank < 12);
    }
}
