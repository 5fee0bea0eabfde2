//! Row and column equilibration of a sparse matrix (Ruiz's iteration):
//! powers of two rᵢ, cⱼ such that every nonzero row and column of
//! rᵢ aᵢⱼ cⱼ has its largest magnitude in [½, 2].
//!
//! Rank and condition decisions are made on the equilibrated matrix. They
//! are then independent of the units of coordinates and equations (a
//! pendulum 10¹⁰ long is as regular as one 1 long), and entries of any
//! finite size are brought near 1 before a decomposition squares them.
//! Powers of two make the scaling exact.

/// Most sweeps (each halves every row and column maximum's distance to 1 on
/// the log scale; 64 reach 1 from 2^±1074).
const MAX_SWEEPS: usize = 64;

/// Bounds of a single factor's exponent: every product rᵢ cⱼ then lies in
/// [2^−1022, 2^1022], a normal finite number, so no scaled entry is ever
/// formed through an intermediate that overflows (∞ · 0 = NaN) or flushes to
/// zero. Entries below 2^−1022 relative to their row and column stay small
/// after scaling, which is what they are: negligible.
const MAX_EXPONENT: f64 = 511.0;

/// Scale factors of an equilibration, and the scaled values.
#[derive(Debug, Clone)]
pub(crate) struct Equilibration {
    /// rᵢ, one per equation.
    pub(crate) row: Box<[f64]>,
    /// cⱼ, one per coordinate.
    pub(crate) col: Box<[f64]>,
    /// Scratch: maxima per row or column during [`Self::compute`].
    max: Box<[f64]>,
    /// rᵢ aᵢⱼ cⱼ in pattern order, after [`Self::apply`].
    pub(crate) values: Box<[f64]>,
}

impl Equilibration {
    /// Buffers for an n × n matrix with `nnz` nonzeros (allocates).
    pub(crate) fn new(n: usize, nnz: usize) -> Self {
        Self {
            row: vec![1.0; n].into_boxed_slice(),
            col: vec![1.0; n].into_boxed_slice(),
            max: vec![0.0; n].into_boxed_slice(),
            values: vec![0.0; nnz].into_boxed_slice(),
        }
    }

    /// Computes r and c for the matrix whose nonzeros `values` sit at
    /// `pattern` (rows and columns without a finite nonzero get 1), then
    /// [`apply`](Self::apply)s them. Does not allocate.
    pub(crate) fn compute(&mut self, pattern: &[(u32, u32)], values: &[f64]) {
        self.row.fill(1.0);
        self.col.fill(1.0);
        for _ in 0..MAX_SWEEPS {
            let rows = sweep(
                pattern,
                values,
                &mut self.row,
                &self.col,
                &mut self.max,
                false,
            );
            let cols = sweep(
                pattern,
                values,
                &mut self.col,
                &self.row,
                &mut self.max,
                true,
            );
            if !(rows || cols) {
                break;
            }
        }
        self.apply(pattern, values);
    }

    /// `self.values` ← rᵢ aᵢⱼ cⱼ with the current factors. Does not allocate.
    #[inline]
    pub(crate) fn apply(&mut self, pattern: &[(u32, u32)], values: &[f64]) {
        for ((out, &(r, c)), &v) in self.values.iter_mut().zip(pattern).zip(values) {
            let (ri, cj) = (
                self.row.get(r as usize).copied().unwrap_or(1.0),
                self.col.get(c as usize).copied().unwrap_or(1.0),
            );
            *out = v * (ri * cj);
        }
    }
}

/// One half-sweep: rescales `target` (rows, or columns when `by_col`) so
/// that the maxima of the scaled matrix move to [½, 2]; `true` if a factor
/// changed.
fn sweep(
    pattern: &[(u32, u32)],
    values: &[f64],
    target: &mut [f64],
    other: &[f64],
    max: &mut [f64],
    by_col: bool,
) -> bool {
    max.fill(0.0);
    for (&(r, c), &v) in pattern.iter().zip(values) {
        let (mine, theirs) = if by_col {
            (c as usize, r as usize)
        } else {
            (r as usize, c as usize)
        };
        let (Some(&t), Some(&o), Some(m)) =
            (target.get(mine), other.get(theirs), max.get_mut(mine))
        else {
            continue;
        };
        // t·o is normal (see MAX_EXPONENT); a product past f64::MAX counts
        // as f64::MAX, so its row or column is still scaled down.
        let a = (v * (t * o)).abs();
        let a = if a.is_nan() { 0.0 } else { a.min(f64::MAX) };
        if a > *m {
            *m = a;
        }
    }
    let mut changed = false;
    for (s, &m) in target.iter_mut().zip(max.iter()) {
        if m > 0.0 && !(0.5..=2.0).contains(&m) {
            // 2^−round(log₂ m / 2): exact, halves the distance to 1.
            let e = -(m.log2() * 0.5).round();
            let e = if e == 0.0 { -m.log2().signum() } else { e };
            let old = *s;
            let exponent = (old.log2() + e).clamp(-MAX_EXPONENT, MAX_EXPONENT);
            *s = exponent.exp2();
            changed |= *s != old;
        }
    }
    changed
}

/// Sign of a permutation (given as the images of 0, 1, …, n − 1), +1 if
/// even, −1 if odd, by sorting a copy in `scratch` (length n) with swaps.
/// Entries out of range count as fixed points. Does not allocate.
pub(crate) fn permutation_sign(perm: impl Iterator<Item = usize>, scratch: &mut [usize]) -> f64 {
    let n = scratch.len();
    for (s, p) in scratch.iter_mut().zip(perm) {
        *s = p;
    }
    let mut sign = 1.0;
    for i in 0..n {
        loop {
            let j = scratch[i];
            if j == i || j >= n || scratch[j] == j {
                break;
            }
            scratch.swap(i, j);
            sign = -sign;
        }
    }
    sign
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permutation_signs() {
        let mut scratch = [0usize; 4];
        assert_eq!(
            permutation_sign([0, 1, 2, 3].into_iter(), &mut scratch),
            1.0
        );
        assert_eq!(
            permutation_sign([1, 0, 2, 3].into_iter(), &mut scratch),
            -1.0
        );
        assert_eq!(
            permutation_sign([1, 2, 0, 3].into_iter(), &mut scratch),
            1.0
        );
        assert_eq!(
            permutation_sign([3, 2, 1, 0].into_iter(), &mut scratch),
            1.0
        );
        assert_eq!(
            permutation_sign([1, 2, 3, 0].into_iter(), &mut scratch),
            -1.0
        );
    }

    #[test]
    fn subnormal_and_huge_entries_scale_to_finite_values() {
        // A column whose only entry is the smallest subnormal needs a factor
        // of 2^1074, past f64::MAX: factors are bounded, every scaled entry
        // (zeros of the pattern included) stays finite.
        let pattern = [(0, 0), (0, 1), (1, 0), (1, 1), (2, 2)];
        let values = [5e-324, 0.0, 1e300, 1.0, 5e-324];
        let mut e = Equilibration::new(3, values.len());
        e.compute(&pattern, &values);
        assert!(e.values.iter().all(|v| v.is_finite()), "{:?}", e.values);
        assert!(
            e.row
                .iter()
                .chain(e.col.iter())
                .all(|s| s.is_finite() && *s > 0.0)
        );
        assert!((0.5..=2.0).contains(&e.values[2].abs()), "{:?}", e.values);
    }

    #[test]
    fn scaled_maxima_lie_in_a_half_to_two() {
        // A pendulum's Φ_q with L = 1e10, and entries near overflow.
        for (pattern, values) in [
            (
                vec![(0, 0), (0, 2), (1, 1), (1, 2), (2, 2)],
                vec![1.0, 5e9, 1.0, -3e9, 1.0],
            ),
            (
                vec![(0, 0), (0, 1), (1, 0), (1, 1)],
                vec![1e160, 2e160, -3e160, 1e-300],
            ),
        ] {
            let mut e = Equilibration::new(3, values.len());
            e.compute(&pattern, &values);
            let mut rmax = [0.0f64; 3];
            let mut cmax = [0.0f64; 3];
            for (&(r, c), &v) in pattern.iter().zip(e.values.iter()) {
                rmax[r as usize] = rmax[r as usize].max(v.abs());
                cmax[c as usize] = cmax[c as usize].max(v.abs());
            }
            for m in rmax.iter().chain(&cmax).filter(|&&m| m > 0.0) {
                assert!((0.5..=2.0).contains(m), "{m} in {:?}", e.values);
            }
            for s in e.row.iter().chain(e.col.iter()) {
                assert_eq!(s.log2().fract(), 0.0, "{s} is a power of two");
            }
        }
    }
}
