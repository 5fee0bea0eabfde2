//! A small dense LU with partial pivoting in preallocated storage: the
//! integrators factor the same-sized matrix every Newton iteration and must
//! not allocate.

/// LU factors of an n × n matrix (row-major), with row pivots.
#[derive(Clone, Debug)]
pub struct Lu {
    n: usize,
    a: Vec<f64>,
    piv: Vec<usize>,
}

impl Lu {
    /// Storage for n × n (allocates; once).
    #[must_use]
    pub fn new(n: usize) -> Lu {
        Lu {
            n,
            a: vec![0.0; n * n],
            piv: vec![0; n],
        }
    }

    /// The matrix to factor, row-major, to be filled by the caller.
    pub fn matrix_mut(&mut self) -> &mut [f64] {
        &mut self.a
    }

    /// Factors the matrix in place. Returns the first column without a
    /// usable pivot (|pivot| ≤ 1e-14 × the largest entry) as `Err`.
    ///
    /// # Errors
    /// The column of a zero pivot: the matrix is singular.
    pub fn factor(&mut self) -> Result<(), usize> {
        let n = self.n;
        let scale = self.a.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        if !scale.is_finite() {
            return Err(0);
        }
        let tiny = 1e-14 * scale.max(f64::MIN_POSITIVE);
        for k in 0..n {
            let mut p = k;
            let mut best = self.a[k * n + k].abs();
            for r in k + 1..n {
                let v = self.a[r * n + k].abs();
                if v > best {
                    best = v;
                    p = r;
                }
            }
            self.piv[k] = p;
            if best <= tiny {
                return Err(k);
            }
            if p != k {
                for c in 0..n {
                    self.a.swap(k * n + c, p * n + c);
                }
            }
            let d = self.a[k * n + k];
            for r in k + 1..n {
                let f = self.a[r * n + k] / d;
                self.a[r * n + k] = f;
                if f != 0.0 {
                    let (top, bottom) = self.a.split_at_mut(r * n);
                    let row_k = &top[k * n + k + 1..k * n + n];
                    for (x, &y) in bottom[k + 1..n].iter_mut().zip(row_k) {
                        *x -= f * y;
                    }
                }
            }
        }
        Ok(())
    }

    /// Solves A x = b in place with the factors.
    pub fn solve(&self, b: &mut [f64]) {
        let n = self.n;
        if b.len() != n {
            b.fill(f64::NAN);
            return;
        }
        for k in 0..n {
            b.swap(k, self.piv[k]);
        }
        for r in 1..n {
            let row = &self.a[r * n..r * n + r];
            let s: f64 = row.iter().zip(&b[..r]).map(|(a, x)| a * x).sum();
            b[r] -= s;
        }
        for r in (0..n).rev() {
            let row = &self.a[r * n + r + 1..r * n + n];
            let s: f64 = row.iter().zip(&b[r + 1..]).map(|(a, x)| a * x).sum();
            b[r] = (b[r] - s) / self.a[r * n + r];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Lu;

    #[test]
    fn solves_a_pivoting_system() {
        let mut lu = Lu::new(3);
        lu.matrix_mut()
            .copy_from_slice(&[0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0]);
        assert!(lu.factor().is_ok());
        // x = (1, 2, 3): b = A x.
        let mut b = [7.0, 3.0, 6.0];
        lu.solve(&mut b);
        for (x, e) in b.iter().zip([1.0, 2.0, 3.0]) {
            assert!((x - e).abs() < 1e-14, "{b:?}");
        }
    }

    #[test]
    fn reports_a_singular_column() {
        let mut lu = Lu::new(2);
        lu.matrix_mut().copy_from_slice(&[1.0, 2.0, 2.0, 4.0]);
        assert_eq!(lu.factor(), Err(1));
    }
}
