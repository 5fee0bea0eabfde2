//! Saddle-point systems that stay solvable where Φ_q loses rank.
//!
//! Forward dynamics solves systems of the form
//!
//! ```text
//! [ W    Φ_qᵀ ] [x]   [a]
//! [ Φ_q  0    ] [y] = [b]
//! ```
//!
//! (the index-1 system with W = M, the projections onto the constraints,
//! HHT's Newton matrix). Where Φ_q has full row rank the system has one
//! solution; at a singular configuration, or with redundant constraints,
//! the zero block leaves y undetermined in the null space of Φ_qᵀ and the
//! matrix is singular, and near such a configuration the solution's y (the
//! multipliers) grows like 1/σ_min² with any inconsistency in b.
//!
//! Here the zero block is replaced by −E, E = diag(εᵣ) with
//!
//! ```text
//! εᵣ = REGULARIZATION · (Φ_q W⁻¹ Φ_qᵀ)ᵣᵣ
//! ```
//!
//! (the Gram matrix's diagonal in W's metric: the regularization is
//! relative, whatever the units of the rows). The regularized matrix is
//! quasi-definite: nonsingular for any rank of Φ_q. Eliminating y shows
//! what it solves: (W + Φ_qᵀE⁻¹Φ_q) x = a + Φ_qᵀE⁻¹ b, an augmented
//! Lagrangian with penalty E⁻¹ (Bayo & Ledesma 1996). A few corrections
//! against the unregularized matrix (iterative refinement: the augmented
//! Lagrangian's multiplier updates) remove the regularization's effect in
//! every direction with σ² ≫ ε at a rate ε/(σ² + ε) per correction — to
//! rounding after two where the configuration is regular — while in the
//! directions with σ² ≲ ε (at and next to a singular configuration) the
//! constraint acts as a stiff penalty instead of an exact one, and y stays
//! bounded. Factored without forming Φ_qᵀE⁻¹Φ_q, the matrix keeps the
//! conditioning of the unregularized one wherever that one is regular.

use super::dense::Lu;

/// εᵣ relative to the row's Gram diagonal (see the module documentation):
/// the constraint becomes a penalty only where σ_min² of the row-scaled
/// Φ_q falls below this, i.e. within about 10⁻⁵ of a singular
/// configuration.
pub const REGULARIZATION: f64 = 1e-10;

/// Refinements after the regularized solve: the remaining relative error
/// in a direction of Φ_q with scaled singular value σ is
/// (ε/(σ² + ε))^(1 + REFINEMENTS), 10⁻²⁴ at σ = 10⁻³.
pub const REFINEMENTS: usize = 2;

/// εᵣ for each row of the dense m × n `jac` (row-major) in the metric of
/// the diagonal `w` (n), times `scale`, into `out` (m). A row of zero
/// gradient gets the largest εᵣ of the others (or `REGULARIZATION · scale`
/// when every row is zero), so the matrix stays nonsingular.
pub fn regularization(jac: &[f64], w: &[f64], scale: f64, out: &mut [f64]) {
    let n = w.len();
    let mut largest = 0.0_f64;
    for (r, e) in out.iter_mut().enumerate() {
        let row = jac.get(r * n..(r + 1) * n).unwrap_or(&[]);
        let g: f64 = row
            .iter()
            .zip(w)
            .map(|(a, &wj)| if wj != 0.0 { a * a / wj.abs() } else { 0.0 })
            .sum();
        *e = REGULARIZATION * scale * g;
        largest = largest.max(*e);
    }
    let floor = if largest > 0.0 {
        largest
    } else {
        REGULARIZATION * scale
    };
    for e in out.iter_mut() {
        if e.is_nan() || *e <= 0.0 {
            *e = floor;
        }
    }
}

/// The dense regularized saddle-point matrix [W Φ_qᵀ; Φ_q −E] with W
/// diagonal, its LU factors, and the refinement against the unregularized
/// matrix. Every buffer is allocated at construction.
#[derive(Clone, Debug)]
pub struct Saddle {
    n: usize,
    m: usize,
    lu: Lu,
    /// W as factored.
    w: Vec<f64>,
    /// E as factored.
    eps: Vec<f64>,
    /// The right-hand side as given (refinement).
    b: Vec<f64>,
    /// The residual of the refinement.
    r: Vec<f64>,
}

impl Saddle {
    /// Storage for n coordinates and m rows (allocates; once).
    #[must_use]
    pub fn new(n: usize, m: usize) -> Saddle {
        Saddle {
            n,
            m,
            lu: Lu::new(n + m),
            w: vec![0.0; n],
            eps: vec![0.0; m],
            b: vec![0.0; n + m],
            r: vec![0.0; n + m],
        }
    }

    /// Factors [diag(w) Φ_qᵀ; Φ_q −E] for the dense m × n `jac`.
    ///
    /// # Errors
    /// The index of an unknown without a pivot: with E > 0 only a zero or
    /// non-finite entry of `w` (a coordinate without inertia) or non-finite
    /// values make it singular.
    pub fn factor(&mut self, w: &[f64], jac: &[f64]) -> Result<(), usize> {
        let (n, m) = (self.n, self.m);
        self.w.copy_from_slice(w);
        regularization(jac, w, 1.0, &mut self.eps);
        let width = n + m;
        let a = self.lu.matrix_mut();
        a.fill(0.0);
        for (i, &wi) in w.iter().enumerate() {
            a[i * width + i] = wi;
        }
        for r in 0..m {
            for c in 0..n {
                let v = jac[r * n + c];
                a[(n + r) * width + c] = v;
                a[c * width + n + r] = v;
            }
            a[(n + r) * width + n + r] = -self.eps[r];
        }
        self.lu.factor()
    }

    /// Solves [diag(w) Φ_qᵀ; Φ_q 0] [x; y] = `rhs` in place with the
    /// regularized factors and [`REFINEMENTS`] corrections against the
    /// unregularized matrix (`jac` as factored).
    pub fn solve(&mut self, jac: &[f64], rhs: &mut [f64]) {
        let (n, m) = (self.n, self.m);
        self.b.copy_from_slice(rhs);
        self.lu.solve(rhs);
        for _ in 0..REFINEMENTS {
            // r = b − [W Φᵀ; Φ 0] [x; y].
            self.r.copy_from_slice(&self.b);
            let (x, y) = rhs.split_at(n);
            for (i, (ri, &xi)) in self.r[..n].iter_mut().zip(x).enumerate() {
                *ri -= self.w[i] * xi;
            }
            for (row, &yr) in y.iter().enumerate().take(m) {
                let g = &jac[row * n..(row + 1) * n];
                let mut s = 0.0;
                for (c, (&a, &xc)) in g.iter().zip(x).enumerate() {
                    self.r[c] -= a * yr;
                    s += a * xc;
                }
                self.r[n + row] -= s;
            }
            self.lu.solve(&mut self.r);
            for (v, d) in rhs.iter_mut().zip(&self.r) {
                *v += d;
            }
        }
    }

    /// Solves with the regularized factors alone (no refinement): the
    /// monitor's inverse iteration.
    pub fn solve_regularized(&self, rhs: &mut [f64]) {
        self.lu.solve(rhs);
    }

    /// E as last factored.
    #[must_use]
    pub fn eps(&self) -> &[f64] {
        &self.eps
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn residual(w: &[f64], jac: &[f64], x: &[f64], b: &[f64]) -> f64 {
        let n = w.len();
        let m = b.len() - n;
        let mut worst = 0.0_f64;
        for i in 0..n {
            let mut v = w[i] * x[i];
            for r in 0..m {
                v += jac[r * n + i] * x[n + r];
            }
            worst = worst.max((v - b[i]).abs());
        }
        for r in 0..m {
            let v: f64 = (0..n).map(|c| jac[r * n + c] * x[c]).sum();
            worst = worst.max((v - b[n + r]).abs());
        }
        worst
    }

    /// A regular system is solved to rounding: the regularization is
    /// refined away.
    #[test]
    fn regular_systems_are_solved_exactly() {
        let w = [2.0, 3.0, 0.5];
        let jac = [1.0, -1.0, 0.25, 0.0, 2.0, 1.0];
        let b = [1.0, -2.0, 0.5, 0.3, -0.7];
        let mut s = Saddle::new(3, 2);
        s.factor(&w, &jac).expect("nonsingular");
        let mut x = b;
        s.solve(&jac, &mut x);
        assert!(residual(&w, &jac, &x, &b) < 1e-15, "{x:?}");
    }

    /// Two copies of one row (a redundant constraint): the unregularized
    /// matrix is singular; the regularized solve meets both rows, the
    /// motion part x is the unique one, and y splits the multiplier
    /// between the copies (the minimum-norm split).
    #[test]
    fn redundant_rows_are_met_with_the_minimum_norm_split() {
        let w = [1.0, 1.0];
        let jac = [1.0, 1.0, 1.0, 1.0];
        let b = [3.0, 1.0, 2.0, 2.0];
        let mut s = Saddle::new(2, 2);
        s.factor(&w, &jac).expect("regularized: nonsingular");
        let mut x = b;
        s.solve(&jac, &mut x);
        assert!(residual(&w, &jac, &x, &b) < 1e-12, "{x:?}");
        // x = (2, 0) + ... : x0 + x1 = 2, x0 − x1 = 3 − 1 (y cancels).
        assert!((x[0] - 2.0).abs() < 1e-12 && x[1].abs() < 1e-12, "{x:?}");
        // y₀ + y₁ = 1, split evenly.
        assert!(
            (x[2] - 0.5).abs() < 1e-9 && (x[3] - 0.5).abs() < 1e-9,
            "{x:?}"
        );
    }

    /// Inconsistent rows at a singular configuration: the solution stays
    /// bounded (a penalty), never NaN or a failed factorization.
    #[test]
    fn inconsistent_singular_rows_stay_bounded() {
        let w = [1.0, 1.0];
        let jac = [1.0, 0.0, 1.0, 0.0];
        let b = [0.0, 0.0, 1.0, 1.0 + 1e-9];
        let mut s = Saddle::new(2, 2);
        s.factor(&w, &jac).expect("nonsingular");
        let mut x = b;
        s.solve(&jac, &mut x);
        assert!(x.iter().all(|v| v.is_finite()), "{x:?}");
        assert!((x[0] - 1.0).abs() < 1e-6, "{x:?}");
    }

    #[test]
    fn zero_rows_get_a_floor() {
        let mut e = [0.0; 3];
        regularization(&[0.0, 0.0, 1.0, 0.0, 0.0, 0.0], &[1.0, 1.0], 1.0, &mut e);
        assert!(e.iter().all(|&v| v > 0.0), "{e:?}");
        regularization(&[0.0; 6], &[1.0, 1.0], 1.0, &mut e);
        assert!(e.iter().all(|&v| v == REGULARIZATION), "{e:?}");
    }
}
