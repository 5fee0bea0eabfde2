//! The fixed order at run time: a factorization (the compiled one if it
//! is plugged in and runs, else the operation lists interpreted, with the
//! scan the acceptance test reads) and the solves (likewise). The per-step
//! hot path of a folded LU.

use super::{FactorScan, Folded, Op, SolveOp};
use crate::linalg::order_accepted;
use crate::linalg::schedule::{INFINITY_BITS, MAGNITUDE_MASK};

impl Folded {
    /// Tries the fixed order on `values`, checking the constant entries if
    /// `check`: `true` if accepted.
    #[inline]
    pub(super) fn factor(&mut self, values: &[f64], singular_tolerance: f64, check: bool) -> bool {
        let compiled = self
            .compiled_factor
            .as_ref()
            .is_some_and(|c| c.factor(values, &mut self.v, check, &mut self.scan));
        if !compiled {
            self.interpret(values, check);
        }
        let scan = &self.scan;
        order_accepted(
            scan[FactorScan::FINITE] != 0.0 && scan[FactorScan::SAME] != 0.0,
            scan[FactorScan::MAX_MULTIPLIER],
            scan[FactorScan::MIN_PIVOT],
            singular_tolerance,
            scan[FactorScan::SCALE],
        )
    }

    /// The interpreted factorization: the value array and the scan. Out of
    /// line, and writing the scan itself: the compiled factorization's
    /// call stays a light frame.
    #[inline(never)]
    fn interpret(&mut self, values: &[f64], check: bool) {
        let mut max_bits = self.const_scale.to_bits();
        for &k in &self.inputs {
            max_bits = max_bits.max(values[k as usize].to_bits() & MAGNITUDE_MASK);
        }
        let (scale, finite) = (f64::from_bits(max_bits), max_bits < INFINITY_BITS);
        let mut same = true;
        for &(k, c) in if check { &self.constants[..] } else { &[] } {
            same &= values[k as usize].to_bits() == c.to_bits();
        }
        let m = self.inputs.len();
        let v = &mut self.v[..];
        for (x, &k) in v.iter_mut().zip(&self.inputs) {
            *x = values[k as usize];
        }
        for (k, op) in (m..).zip(&self.ops) {
            v[k] = match *op {
                Op::Recip(a) => 1.0 / v[a as usize],
                Op::Neg(a) => -v[a as usize],
                Op::Scale(c, a) => c * v[a as usize],
                Op::Mul(a, b) => v[a as usize] * v[b as usize],
                Op::SubConst(a, c) => v[a as usize] - c,
                Op::Sub(o, a) => v[o as usize] - v[a as usize],
                Op::Add(o, a) => v[o as usize] + v[a as usize],
                Op::SubScaled(o, c, a) => v[o as usize] - c * v[a as usize],
                Op::SubMul(o, a, b) => v[o as usize] - v[a as usize] * v[b as usize],
                Op::ConstSubScaled(o, c, a) => o - c * v[a as usize],
                Op::ConstSubMul(o, a, b) => o - v[a as usize] * v[b as usize],
            };
        }
        let mut min_pivot = self.const_min_pivot;
        let mut negative = false;
        for &p in &self.pivot_vars {
            negative ^= v[p as usize].is_sign_negative();
            let a = v[p as usize].abs();
            // A NaN pivot counts as zero.
            min_pivot = if a >= min_pivot {
                min_pivot
            } else if a.is_nan() {
                0.0
            } else {
                a
            };
        }
        let mut max_multiplier = self.const_max_multiplier;
        for &l in &self.multiplier_vars {
            let a = v[l as usize].abs();
            // A NaN multiplier counts as infinite.
            max_multiplier = if a <= max_multiplier {
                max_multiplier
            } else if a.is_nan() {
                f64::INFINITY
            } else {
                a
            };
        }
        self.scan = FactorScan {
            scale,
            finite,
            same,
            negative,
            min_pivot,
            max_multiplier,
        }
        .to_raw();
    }

    /// Runs the folded solve: gather by `gather`, two sweeps, scatter by `scatter`.
    #[inline]
    pub(super) fn solve(&mut self, rhs: &mut [f64], transpose: bool) {
        if let Some(c) = &self.compiled
            && c.solve(&self.v, rhs, &mut self.work, transpose)
        {
            return;
        }
        self.interpret_solve(rhs, transpose);
    }

    /// The interpreted solve. Out of line, as [`interpret`](Self::interpret).
    #[inline(never)]
    fn interpret_solve(&mut self, rhs: &mut [f64], transpose: bool) {
        let (gather, first, second, scatter) = if transpose {
            (
                &self.col_order,
                &self.forward_t,
                &self.backward_t,
                &self.row_order,
            )
        } else {
            (
                &self.row_order,
                &self.forward,
                &self.backward,
                &self.col_order,
            )
        };
        let y = &mut self.work[..];
        for (yk, &r) in y.iter_mut().zip(gather) {
            *yk = rhs[r as usize];
        }
        sweep(first, &self.v, y);
        sweep(second, &self.v, y);
        for (&yk, &c) in y.iter().zip(scatter) {
            rhs[c as usize] = yk;
        }
    }
}

/// Runs one triangular sweep.
fn sweep(ops: &[SolveOp], v: &[f64], y: &mut [f64]) {
    for op in ops {
        match *op {
            SolveOp::MulSub { dst, src, s } => y[dst as usize] -= v[s as usize] * y[src as usize],
            SolveOp::ConstMulSub { dst, src, c } => y[dst as usize] -= c * y[src as usize],
            SolveOp::Sub { dst, src } => y[dst as usize] -= y[src as usize],
            SolveOp::Add { dst, src } => y[dst as usize] += y[src as usize],
            SolveOp::Scale { dst, s } => y[dst as usize] *= v[s as usize],
            SolveOp::ConstScale { dst, c } => y[dst as usize] *= c,
        }
    }
}
