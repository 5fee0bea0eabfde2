//! Tree evaluation: the reference the tape is tested against.
//!
//! The arithmetic order is fixed and shared with the tape (see [`crate::tape`]):
//! - sum `c + Σ kᵢ·eᵢ`: `acc = k₀·e₀`, then `acc = acc + kᵢ·eᵢ` in term order
//!   (`±1` coefficients as plain `+`/`−`), then `acc + c` if `c ≠ 0`;
//! - product `k · Π bᵢ^pᵢ`: the factors with `p > 0` multiplied in order into a
//!   numerator, those with `p < 0` (as `b^−p`) into a denominator, then
//!   `num / den` (or `1 / den`), then the coefficient;
//! - powers by `x·x` for 2, `sqrt` for ½, `powi` for other integers, else `powf`.
//!
//! So the tape and the tree give bit-identical results.

use crate::arena::Arena;
use crate::build::powv;
use crate::node::{ExprId, NodeRef, SymId};

#[inline]
pub(crate) fn scaled(k: f64, v: f64) -> f64 {
    if k == 1.0 {
        v
    } else if k == -1.0 {
        -v
    } else {
        k * v
    }
}

#[inline]
pub(crate) fn accumulate(acc: f64, k: f64, v: f64) -> f64 {
    if k == 1.0 {
        acc + v
    } else if k == -1.0 {
        acc - v
    } else {
        acc + k * v
    }
}

impl Arena {
    /// Evaluates `e` with symbol values from `value`. Iterative.
    ///
    /// ```
    /// use kinema_expr::Arena;
    /// let mut a = Arena::new();
    /// let x = a.coordinate("x", 0);
    /// let e = a.powi(x, 3);
    /// assert_eq!(a.eval(e, |_| 2.0), 8.0);
    /// ```
    pub fn eval(&self, e: ExprId, value: impl Fn(SymId) -> f64) -> f64 {
        self.eval_many(&[e], value).pop().unwrap_or(f64::NAN)
    }

    /// Evaluates several expressions, sharing common subexpressions.
    pub fn eval_many(&self, outputs: &[ExprId], value: impl Fn(SymId) -> f64) -> Vec<f64> {
        // Values indexed by schedule position: children always come first.
        let schedule = self.schedule(outputs);
        let mut values: Vec<f64> = Vec::with_capacity(schedule.len());
        for &n in schedule.nodes() {
            let v = self.eval_node(
                n,
                |c| schedule.position(c).map_or(f64::NAN, |p| values[p]),
                &value,
            );
            values.push(v);
        }
        outputs
            .iter()
            .map(|&o| schedule.position(o).map_or(f64::NAN, |p| values[p]))
            .collect()
    }

    /// One node's value from its children's values.
    pub(crate) fn eval_node(
        &self,
        n: ExprId,
        child: impl Fn(ExprId) -> f64,
        value: impl Fn(SymId) -> f64,
    ) -> f64 {
        match self.node(n) {
            NodeRef::Num(v) => v,
            NodeRef::Sym(s) => value(s),
            NodeRef::Add { constant, terms } => {
                let mut acc = scaled(terms[0].coeff, child(terms[0].expr));
                for t in &terms[1..] {
                    acc = accumulate(acc, t.coeff, child(t.expr));
                }
                if constant != 0.0 { acc + constant } else { acc }
            }
            NodeRef::Mul { coeff, factors } => {
                let mut num: Option<f64> = None;
                let mut den: Option<f64> = None;
                for f in factors {
                    let v = child(f.base);
                    if f.exp > 0.0 {
                        let p = powv(v, f.exp);
                        num = Some(num.map_or(p, |x| x * p));
                    } else {
                        let p = powv(v, -f.exp);
                        den = Some(den.map_or(p, |x| x * p));
                    }
                }
                let r = match (num, den) {
                    (Some(a), None) => a,
                    (Some(a), Some(b)) => a / b,
                    (None, Some(b)) => 1.0 / b,
                    (None, None) => 1.0,
                };
                scaled(coeff, r)
            }
            NodeRef::Unary(op, a) => op.apply(child(a)),
            NodeRef::Pow(a, b) => child(a).powf(child(b)),
            NodeRef::Atan2(y, x) => child(y).atan2(child(x)),
        }
    }
}
