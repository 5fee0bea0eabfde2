//! Kinks: where a tape's outputs, at a given point, go through a function
//! at a point where it is not differentiable (or whose derivative is
//! infinite), within the uncertainty of its argument ([`Tape::kink`]).
//!
//! A derivation's derivatives of `sqrt(x)`, `|x|`, `atan2(y, x)` … are right
//! wherever the function is differentiable. A solution that puts such an
//! argument at its kink *within roundoff* (a norm of a vector that is zero
//! but for rounding, say) gives derivatives that are the roundoff's: Φ_q
//! holds r/|r|, the direction of the rounding errors, and a solver that
//! prints q̇ and q̈ from them prints noise. So the argument's value is
//! compared with a bound on its absolute error, propagated through the tape
//! to first order from the coordinates' own uncertainty and one unit
//! roundoff per operation.

use super::{Instr, Reg, Tape, TapeError, TapeInputs, cached, check};
use crate::node::{UnaryOp, smooth};

/// A function of a tape at a point where it is not differentiable, within
/// the uncertainty of its argument (see [`Tape::kink`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TapeKink {
    /// The first output that depends on the function's value; `None` if
    /// none does (dead code).
    pub output: Option<usize>,
    /// The function: `"sqrt"` (a square root or a norm), `"power"` (a
    /// fractional power), `"abs"`, `"atan2"`, `"asin"`, `"acos"`, `"ln"`
    /// or `"smoothstep"` (the ends of the cubic step, where its second
    /// derivative jumps).
    pub function: &'static str,
}

/// How many error bounds an argument may be from a kink and still count as
/// on it: the bound is a first-order estimate, and the library's sin, cos,
/// powf … round within a few units, not one.
const MARGIN: f64 = 16.0;

/// Unit roundoff, 2⁻⁵³.
const UNIT: f64 = f64::EPSILON / 2.0;

impl Tape {
    /// Whether the tape has an instruction that can be at a kink (see
    /// [`kink`](Self::kink)); a tape without one never is.
    #[must_use]
    pub fn has_kinks(&self) -> bool {
        self.instrs.iter().any(|ins| kink_kind(ins).is_some())
    }

    /// The first instruction whose argument, at `inputs`, is at its kink
    /// within a bound on its absolute error: each coordinate q_k uncertain
    /// by `q_error` + one unit roundoff of `q_size` + |q_k| (a solution's q
    /// is never exact: a coordinate at 0 is 0 within the rounding of the
    /// model's other numbers, whose size `q_size` is — 1 for a model in
    /// metres, 10⁻⁶ for one of micrometres drawn in metres), q̇, the
    /// parameters, `t` and the constants exact, one unit roundoff added by
    /// each operation, propagated to first order. An argument that reads
    /// no coordinate (its bound 0) is never at a kink: its derivative with
    /// respect to q vanishes, and a function of time at its kink at an
    /// exact time (a driver's `abs(t - 1)` at t = 1) is the model's own
    /// one-sided definition, not roundoff.
    ///
    /// `registers` and `errors` are scratch of at least
    /// [`registers`](Self::registers) values each; `trig` is the cache of
    /// the coordinates' sines and cosines of
    /// [`eval_with_cache`](Self::eval_with_cache) (filled, and used, as
    /// there; empty for none). Without a kink, `errors[..outputs]` hold the
    /// outputs' error bounds on return. Does not allocate unless a kink is
    /// found (to name the output that reads it).
    ///
    /// # Errors
    /// [`TapeError::ShortSlice`] as [`eval`](Self::eval), for `errors` too.
    pub fn kink(
        &self,
        inputs: &TapeInputs<'_>,
        q_error: f64,
        q_size: f64,
        registers: &mut [f64],
        errors: &mut [f64],
        trig: &mut [f64],
    ) -> Result<Option<TapeKink>, TapeError> {
        self.propagate::<true>(inputs, q_error, q_size, registers, errors, trig)
    }

    /// Bounds on the outputs' absolute errors at `inputs`, into
    /// `errors[..outputs]`: the coordinates uncertain by `q_error` and
    /// roundoff of `q_size` + |q_k|, one unit roundoff added by each
    /// operation, propagated to first order, as [`kink`](Self::kink)
    /// propagates them (without stopping at a kink). Where the first-order
    /// bound overstates a function's change, the change's own bound is
    /// taken (a sine moves by at most 2, √x by at most √e, acos by at most
    /// π/√2 · √e). A bound far above an output's roundoff says that its
    /// value is lost to the rounding of its operations: `sin(1e30 * t)`,
    /// whose argument is uncertain by 10¹⁴ radians, or a difference of two
    /// large numbers.
    ///
    /// `registers`, `errors` and `trig` as in [`kink`](Self::kink).
    /// Does not allocate.
    ///
    /// # Errors
    /// [`TapeError::ShortSlice`] as [`eval`](Self::eval), for `errors` too.
    pub fn error_bounds(
        &self,
        inputs: &TapeInputs<'_>,
        q_error: f64,
        q_size: f64,
        registers: &mut [f64],
        errors: &mut [f64],
        trig: &mut [f64],
    ) -> Result<(), TapeError> {
        self.propagate::<false>(inputs, q_error, q_size, registers, errors, trig)
            .map(|_| ())
    }

    /// The values and error bounds of the tape's registers at `inputs`,
    /// stopping at the first kink if `KINKS` (see [`kink`](Self::kink)).
    fn propagate<const KINKS: bool>(
        &self,
        inputs: &TapeInputs<'_>,
        q_error: f64,
        q_size: f64,
        registers: &mut [f64],
        errors: &mut [f64],
        trig: &mut [f64],
    ) -> Result<Option<TapeKink>, TapeError> {
        self.check_inputs(inputs, registers)?;
        check("errors", self.registers, errors.len())?;
        let (r, e) = (registers, errors);
        self.load(inputs, r);
        // The inputs' and constants' errors are set here, every other
        // register's by the instruction that writes it.
        e[..self.registers].fill(0.0);
        for (k, &x) in inputs.q[..self.need_q].iter().enumerate() {
            e[self.outputs + k] = q_error.abs() + UNIT * (q_size.abs() + x.abs());
        }
        for (i, ins) in self.instrs.iter().enumerate() {
            if KINKS
                && let Some(function) = kink_kind(ins)
                && at_kink(ins, r, e)
            {
                return Ok(Some(TapeKink {
                    output: self.first_reader(i),
                    function,
                }));
            }
            let (value, error) = value_and_error(ins, r, e, trig);
            let dst = ins.dst() as usize;
            r[dst] = value;
            e[dst] = error + UNIT * value.abs();
        }
        Ok(None)
    }

    /// The first output that depends on the value instruction `at` writes
    /// (forward through the registers; a register overwritten by a value
    /// that does not depend on it no longer does).
    #[cold]
    pub(super) fn first_reader(&self, at: usize) -> Option<usize> {
        let mut tainted = vec![false; self.registers];
        let dst = self.instrs.get(at)?.dst() as usize;
        *tainted.get_mut(dst)? = true;
        for ins in &self.instrs[at + 1..] {
            let (sources, n) = ins.sources();
            let reads = sources[..n]
                .iter()
                .any(|&a| tainted.get(a as usize).copied().unwrap_or(false));
            if let Some(d) = tainted.get_mut(ins.dst() as usize) {
                *d = reads;
            }
        }
        tainted[..self.outputs].iter().position(|&t| t)
    }
}

/// The function of an instruction that can be at a kink, by name.
fn kink_kind(ins: &Instr) -> Option<&'static str> {
    match *ins {
        Instr::Sqrt { .. } => Some("sqrt"),
        // A fractional power below 2 has an infinite first or second
        // derivative at 0 (γ needs the second).
        Instr::PowF { p, .. } if p < 2.0 => Some("power"),
        Instr::Pow { .. } => Some("power"),
        Instr::Atan2 { .. } => Some("atan2"),
        Instr::Unary { op, .. } => match op {
            UnaryOp::Abs => Some("abs"),
            UnaryOp::Asin => Some("asin"),
            UnaryOp::Acos => Some("acos"),
            UnaryOp::Ln => Some("ln"),
            UnaryOp::Smooth(_) => Some("smoothstep"),
            _ => None,
        },
        _ => None,
    }
}

/// Whether the argument of a kink instruction is at its kink within
/// [`MARGIN`] error bounds (never when the bound is 0).
fn at_kink(ins: &Instr, r: &[f64], e: &[f64]) -> bool {
    let near = |distance: f64, error: f64| error > 0.0 && distance <= MARGIN * error;
    let arg = |a: Reg| (r[a as usize], e[a as usize]);
    match *ins {
        Instr::Sqrt { a, .. } | Instr::PowF { a, .. } | Instr::Pow { a, .. } => {
            let (x, ex) = arg(a);
            near(x.abs(), ex)
        }
        Instr::Atan2 { y, x, .. } => {
            let ((y, ey), (x, ex)) = (arg(y), arg(x));
            near(y.abs(), ey) && near(x.abs(), ex)
        }
        Instr::Unary { op, a, .. } => {
            let (x, ex) = arg(a);
            match op {
                UnaryOp::Abs | UnaryOp::Ln => near(x.abs(), ex),
                UnaryOp::Asin | UnaryOp::Acos => near(1.0 - x.abs(), ex),
                UnaryOp::Smooth(_) => near(x.abs().min((x - 1.0).abs()), ex),
                _ => false,
            }
        }
        _ => false,
    }
}

/// An instruction's value, as [`Tape::eval`] computes it (sines and
/// cosines to within an ulp), and the
/// first-order bound on its error from its operands' (the rounding of the
/// result is added by the caller).
pub(super) fn value_and_error(ins: &Instr, r: &[f64], e: &[f64], trig: &mut [f64]) -> (f64, f64) {
    let v = |a: Reg| r[a as usize];
    let err = |a: Reg| e[a as usize];
    match *ins {
        Instr::Const { v: c, .. } => (c, 0.0),
        Instr::Copy { a, .. } => (v(a), err(a)),
        Instr::Neg { a, .. } => (-v(a), err(a)),
        Instr::Scale { a, k, .. } => (k * v(a), k.abs() * err(a)),
        Instr::Add { a, b, .. } => (v(a) + v(b), err(a) + err(b)),
        Instr::Sub { a, b, .. } => (v(a) - v(b), err(a) + err(b)),
        Instr::MulAdd { acc, a, k, .. } => {
            let product = k * v(a);
            (
                v(acc) + product,
                err(acc) + k.abs() * err(a) + UNIT * product.abs(),
            )
        }
        Instr::AddConst { a, c, .. } => (v(a) + c, err(a)),
        Instr::Mul { a, b, .. } => (v(a) * v(b), v(b).abs() * err(a) + v(a).abs() * err(b)),
        Instr::Div { a, b, .. } => {
            let q = v(a) / v(b);
            (q, (err(a) + q.abs() * err(b)) / v(b).abs())
        }
        Instr::Recip { a, .. } => {
            let q = 1.0 / v(a);
            (q, power_error(-1.0, v(a), q, err(a)))
        }
        Instr::Square { a, .. } => {
            let x = v(a);
            (x * x, 2.0 * x.abs() * err(a))
        }
        // |√(x + e) − √x| ≤ √e: the first-order e / 2√x overstates the
        // change near 0 (and is infinite at 0).
        Instr::Sqrt { a, .. } => {
            let s = v(a).sqrt();
            (s, first_order_or(err(a) / (2.0 * s), err(a).sqrt()))
        }
        Instr::PowI { a, n, .. } => {
            let p = v(a).powi(n);
            (p, power_error(f64::from(n), v(a), p, err(a)))
        }
        Instr::PowF { a, p, .. } => {
            let value = v(a).powf(p);
            (value, power_error(p, v(a), value, err(a)))
        }
        // One library call for both (the bound needs the other): the
        // values may differ from the tape's by an ulp, which decides no
        // kink. The coordinates' go through the cache.
        Instr::Sin { a, .. } | Instr::Cos { a, .. } => {
            sine_or_cosine(v(a).sin_cos(), matches!(ins, Instr::Sin { .. }), err(a))
        }
        Instr::SinQ { a, k, .. } | Instr::CosQ { a, k, .. } => {
            let x = v(a);
            let both = cached(trig, k, x).unwrap_or_else(|| x.sin_cos());
            sine_or_cosine(both, matches!(ins, Instr::SinQ { .. }), err(a))
        }
        Instr::Unary { op, a, .. } => {
            let x = v(a);
            let first = slope(op, x).abs() * err(a);
            let error = match op {
                // Near ±1, where the slope is infinite, the change is at
                // most π/√2 · √e (the 1/2-Hölder bound of acos).
                UnaryOp::Asin | UnaryOp::Acos => {
                    first_order_or(first, std::f64::consts::FRAC_PI_2 * (2.0 * err(a)).sqrt())
                }
                UnaryOp::Sin | UnaryOp::Cos => first_order_or(first, 2.0),
                _ => first,
            };
            (op.apply(x), error)
        }
        Instr::Pow { a, b, .. } => {
            let (x, y) = (v(a), v(b));
            let p = x.powf(y);
            (
                p,
                power_error(y, x, p, err(a)) + (p * x.ln()).abs() * err(b),
            )
        }
        Instr::Atan2 { y, x, .. } => {
            let (yv, xv) = (v(y), v(x));
            (yv.atan2(xv), atan2_error(yv, xv, err(y), err(x)))
        }
    }
}

/// The error of p = xⁿ from x's error `e`: |n xⁿ⁻¹| e, computed as
/// |n| |p| (e / |x|) — the relative error times n — so that it holds
/// wherever p does: xⁿ⁻¹ itself underflows or overflows where p does not
/// (1/y² of a y near 10¹⁴⁷, whose bound came out 0 and let a move of the
/// coordinates exceed it). At x = 0 the slope's own form.
fn power_error(n: f64, x: f64, p: f64, e: f64) -> f64 {
    if x == 0.0 {
        (n * x.powf(n - 1.0)).abs() * e
    } else {
        n.abs() * p.abs() * (e / x.abs())
    }
}

/// The error of atan2(y, x) from the operands' errors: (|x| e_y +
/// |y| e_x) / (x² + y²), with both scaled by the larger magnitude first so
/// that it holds wherever the operands do: x² + y² itself overflows for
/// operands beyond 10¹⁵⁴ (a cosh of a few hundred, whose bound came out 0
/// and let a move of the coordinates exceed it) and underflows below
/// 10⁻¹⁶². At (0, 0) the unscaled form (NaN: the kink check stops there).
fn atan2_error(y: f64, x: f64, ey: f64, ex: f64) -> f64 {
    let m = x.abs().max(y.abs());
    if m == 0.0 || !m.is_finite() {
        return (x.abs() * ey + y.abs() * ex) / (x * x + y * y);
    }
    let (xs, ys) = (x / m, y / m);
    (xs.abs() * ey + ys.abs() * ex) / m / (xs * xs + ys * ys)
}

/// sin x (`sine`) or cos x from (sin x, cos x), with the bound from x's
/// error `error` (the slope is the other one).
fn sine_or_cosine((sin, cos): (f64, f64), sine: bool, error: f64) -> (f64, f64) {
    let (value, slope) = if sine { (sin, cos) } else { (cos, sin) };
    // Second order: the slope itself may be near 0 where the argument is
    // far from exact. A sine moves by 2 at most.
    let bound = slope.abs() * error + 0.5 * error * error;
    (value, first_order_or(bound, 2.0))
}

/// The smaller of a first-order bound and a bound on the function's whole
/// change (the latter where the first is not a number: 0/0 at √0).
fn first_order_or(first: f64, cap: f64) -> f64 {
    if first <= cap { first } else { cap }
}

/// The derivative of a unary function at x.
fn slope(op: UnaryOp, x: f64) -> f64 {
    match op {
        UnaryOp::Sin => x.cos(),
        UnaryOp::Cos => x.sin(),
        UnaryOp::Tan => 1.0 + x.tan().powi(2),
        UnaryOp::Asin | UnaryOp::Acos => 1.0 / (1.0 - x * x).sqrt(),
        UnaryOp::Atan => 1.0 / (1.0 + x * x),
        UnaryOp::Sinh => x.cosh(),
        UnaryOp::Cosh => x.sinh(),
        UnaryOp::Tanh => 1.0 - x.tanh().powi(2),
        UnaryOp::Exp => x.exp(),
        UnaryOp::Ln => 1.0 / x,
        UnaryOp::Abs => 1.0,
        UnaryOp::Smooth(k) if k < 3 => smooth(k + 1, x),
        UnaryOp::Smooth(_) => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use crate::arena::Arena;
    use crate::node::UnaryOp;
    use crate::tape::{Tape, TapeInputs};

    /// The kink of `f` (built on coordinates x, y) at (x, y), uncertain by
    /// `q_error`.
    fn kink_at(
        f: impl Fn(&mut Arena, crate::ExprId, crate::ExprId) -> crate::ExprId,
        x: f64,
        y: f64,
        q_error: f64,
    ) -> Option<super::TapeKink> {
        let mut a = Arena::new();
        let xs = a.coordinate("x", 0);
        let ys = a.coordinate("y", 1);
        let out = f(&mut a, xs, ys);
        let other = a.add(xs, ys);
        let tape = Tape::compile(&a, &[other, out]);
        let inputs = TapeInputs {
            q: &[x, y],
            qd: &[],
            params: &[],
            t: 0.0,
        };
        let mut r = vec![0.0; tape.registers()];
        let mut e = vec![0.0; tape.registers()];
        tape.kink(&inputs, q_error, 1.0, &mut r, &mut e, &mut [])
            .expect("slices of the tape's lengths")
    }

    fn norm(a: &mut Arena, x: crate::ExprId, y: crate::ExprId) -> crate::ExprId {
        let (x2, y2) = (a.powi(x, 2), a.powi(y, 2));
        let s = a.add(x2, y2);
        a.sqrt(s)
    }

    #[test]
    fn a_norm_of_roundoff_is_at_its_kink_and_names_its_output() {
        // (x − 9) + 9 is 0 but for rounding at x = 9 − 1e-15.
        let shifted = |a: &mut Arena, x, y| {
            let nine = a.num(9.0);
            let dx = a.sub(x, nine);
            let dy = a.sub(y, nine);
            norm(a, dx, dy)
        };
        let kink = kink_at(shifted, 9.0 + 1e-15, 9.0 - 2e-15, 0.0).expect("a kink");
        assert_eq!((kink.output, kink.function), (Some(1), "sqrt"));
        // A norm well away from zero is no kink, nor one whose smallness
        // the coordinates determine (1e-8 against errors of 1e-15).
        assert_eq!(kink_at(shifted, 12.0, 5.0, 0.0), None);
        assert_eq!(kink_at(shifted, 9.0 + 1e-8, 9.0, 0.0), None);
        // … unless the coordinates are that uncertain.
        assert!(kink_at(shifted, 9.0 + 1e-8, 9.0, 1e-8).is_some());
    }

    #[test]
    fn each_kind_of_kink_is_found_and_exact_arguments_are_not() {
        let abs = |a: &mut Arena, x, _| a.abs(x);
        assert_eq!(
            kink_at(abs, 1e-300, 0.0, 1e-16).map(|k| k.function),
            Some("abs")
        );
        // A coordinate at exactly 0 is 0 within rounding.
        assert_eq!(kink_at(abs, 0.0, 0.0, 0.0).map(|k| k.function), Some("abs"));
        assert_eq!(kink_at(abs, 0.5, 0.0, 1e-16), None);
        let atan2 = |a: &mut Arena, x, y| a.atan2(y, x);
        assert_eq!(
            kink_at(atan2, 1e-17, -1e-17, 1e-16).map(|k| k.function),
            Some("atan2")
        );
        assert_eq!(kink_at(atan2, 1e-17, 1.0, 1e-16), None);
        let acos = |a: &mut Arena, x, _| a.acos(x);
        assert_eq!(
            kink_at(acos, 1.0 - 1e-16, 0.0, 1e-16).map(|k| k.function),
            Some("acos")
        );
        assert_eq!(kink_at(acos, 0.9, 0.0, 1e-16), None);
        let power = |a: &mut Arena, x, _| a.powf(x, 1.5);
        assert_eq!(
            kink_at(power, 1e-17, 0.0, 1e-16).map(|k| k.function),
            Some("power")
        );
        let step = |a: &mut Arena, x, _| a.unary(UnaryOp::Smooth(0), x);
        assert_eq!(
            kink_at(step, 1.0 + 1e-17, 0.0, 1e-16).map(|k| k.function),
            Some("smoothstep")
        );
        assert_eq!(kink_at(step, 0.5, 0.0, 1e-16), None);
    }

    #[test]
    fn arguments_that_read_no_coordinate_are_never_at_a_kink() {
        // |t − 0.5| at t = 0.5 and √p at p = 0: exact, whatever q's error.
        let mut a = Arena::new();
        let x = a.coordinate("x", 0);
        let t = a.time();
        let p = a.parameter("p", 0);
        let half = a.num(0.5);
        let d = a.sub(t, half);
        let at_t = a.abs(d);
        let at_p = a.sqrt(p);
        let smooth = a.add(x, at_t);
        let out = a.add(smooth, at_p);
        let tape = Tape::compile(&a, &[out]);
        assert!(tape.has_kinks());
        let inputs = TapeInputs {
            q: &[0.3],
            qd: &[],
            params: &[0.0],
            t: 0.5,
        };
        let mut r = vec![0.0; tape.registers()];
        let mut e = vec![0.0; tape.registers()];
        assert_eq!(
            tape.kink(&inputs, 1e-3, 1.0, &mut r, &mut e, &mut []),
            Ok(None)
        );
    }

    /// A power's bound holds where the power does though the slope's
    /// xⁿ⁻¹ under- or overflows: 1/x² at x = 1e150 (x⁻³ is 0 in doubles),
    /// 1/x at 1e-160 (1/x² is infinite), x^-2.5 at 1e120.
    #[test]
    fn power_bounds_hold_where_the_slope_underflows() {
        let (x, u): (f64, f64) = (1e150, super::UNIT);
        for (x, build, slope_times_x) in [
            (x, 0, 2.0 * x.powi(-2)),
            (1e-160, 1, 1e160),
            (1e120, 2, 2.5 * 1e120f64.powf(-2.5)),
        ] {
            let mut a = Arena::new();
            let c = a.coordinate("x", 0);
            let out = match build {
                0 => a.powi(c, -2),
                1 => {
                    let one = a.num(1.0);
                    a.div(one, c)
                }
                _ => a.powf(c, -2.5),
            };
            let tape = Tape::compile(&a, &[out]);
            let inputs = TapeInputs {
                q: &[x],
                qd: &[],
                params: &[],
                t: 0.0,
            };
            let mut r = vec![0.0; tape.registers()];
            let mut e = vec![0.0; tape.registers()];
            // Size 0: x uncertain by its own roundoff u |x| alone.
            assert_eq!(
                tape.kink(&inputs, 0.0, 0.0, &mut r, &mut e, &mut []),
                Ok(None)
            );
            let expected = slope_times_x * u;
            assert!(
                e[0] >= 0.99 * expected && e[0] <= 8.0 * expected,
                "x = {x:e}: bound {:e}, expected {expected:e}",
                e[0]
            );
        }
    }

    #[test]
    fn atan2_bounds_hold_where_the_sum_of_squares_overflows_or_underflows() {
        let u = super::UNIT;
        // atan2(2, cosh x) at x = 480: cosh x ≈ 1.5e208, whose square
        // overflows; the value ≈ 2 / cosh x moves with x like itself
        // (slope −tanh x · value), so x's 1e-9 moves it by 1e-9 · value.
        let mut a = Arena::new();
        let (x, y) = (a.coordinate("x", 0), a.coordinate("y", 1));
        let two = a.num(2.0);
        let cosh = a.unary(UnaryOp::Cosh, x);
        let far = a.atan2(two, cosh);
        // atan2(x, y) at (1e-170, 1e-170), the coordinates uncertain by
        // their own roundoff u |x| alone (size 0): x² + y² underflows to
        // 0; the bound is u (each error over |x|, times 1/2).
        let near = a.atan2(x, y);
        let tape = Tape::compile(&a, &[far, near]);
        for (q, q_error, q_size, output, expected) in [
            ([480.0, 0.0], 1e-9, 1.0, 0, 2.0 / 480f64.cosh() * 1e-9),
            ([1e-170, 1e-170], 0.0, 0.0, 1, u),
        ] {
            let inputs = TapeInputs {
                q: &q,
                qd: &[],
                params: &[],
                t: 0.0,
            };
            let mut r = vec![0.0; tape.registers()];
            let mut e = vec![0.0; tape.registers()];
            tape.error_bounds(&inputs, q_error, q_size, &mut r, &mut e, &mut [])
                .expect("slices of the tape's lengths");
            let bound = e[output];
            assert!(
                bound >= 0.99 * expected && bound <= 4.0 * expected,
                "q = {q:?}: bound {bound:e}, expected {expected:e}"
            );
        }
    }

    /// The error bound of each of `outputs` (built on coordinate x and
    /// time t) at x, t.
    fn bounds_at(
        outputs: impl Fn(&mut Arena, crate::ExprId, crate::ExprId) -> Vec<crate::ExprId>,
        x: f64,
        t: f64,
    ) -> Vec<f64> {
        let mut a = Arena::new();
        let (xs, ts) = (a.coordinate("x", 0), a.time());
        let roots = outputs(&mut a, xs, ts);
        let tape = Tape::compile(&a, &roots);
        let inputs = TapeInputs {
            q: &[x],
            qd: &[],
            params: &[],
            t,
        };
        let mut r = vec![0.0; tape.registers()];
        let mut e = vec![0.0; tape.registers()];
        tape.error_bounds(&inputs, 0.0, 1.0, &mut r, &mut e, &mut [])
            .expect("slices of the tape's lengths");
        e.truncate(roots.len());
        e
    }

    #[test]
    fn error_bounds_see_arguments_and_differences_lost_to_rounding() {
        let bounds = bounds_at(
            |a, x, t| {
                // x − sin(ω t) for ω = 1e30 and 1; a difference of large
                // numbers; √x and acos(1 − x) at their kinks.
                let fast = a.scale(1e30, t);
                let fast = a.sin(fast);
                let slow = a.sin(t);
                let big = a.num(1e10);
                let shifted = a.add(x, big);
                let squared = a.powi(shifted, 2);
                let big2 = a.num(1e20);
                let cancelled = a.sub(squared, big2);
                let root = a.sqrt(x);
                let one = a.num(1.0);
                let near_one = a.sub(one, x);
                let arc = a.acos(near_one);
                vec![a.sub(x, fast), a.sub(x, slow), cancelled, root, arc]
            },
            0.0,
            0.7,
        );
        // sin(7e29): its argument is uncertain by 4e13 radians, the sine
        // by its whole range.
        assert!(bounds[0] >= 1.0 && bounds[0] <= 4.0, "{bounds:?}");
        assert!(bounds[1] < 1e-15, "{bounds:?}");
        // (x + 1e10)² − 1e20 at x = 0: 0, within the rounding of 1e20
        // (1.1e4) and of 1e10 + x (1.1e-6, times 2e10).
        assert!(bounds[2] > 3e4 && bounds[2] < 4e4, "{bounds:?}");
        // √x and acos(1 − x) at x = 0 ± 1.1e-16: at most √e and π/√2 · √2e,
        // not the first-order bounds (infinite).
        assert!(bounds[3] > 1e-9 && bounds[3] < 2e-8, "{bounds:?}");
        assert!(bounds[4] > 1e-9 && bounds[4] < 4e-8, "{bounds:?}");
    }

    #[test]
    fn tapes_without_kink_functions_say_so() {
        let mut a = Arena::new();
        let x = a.coordinate("x", 0);
        let s = a.sin(x);
        let r = a.sqrt(x);
        assert!(!Tape::compile(&a, &[s]).has_kinks());
        assert!(Tape::compile(&a, &[s, r]).has_kinks());
    }
}
