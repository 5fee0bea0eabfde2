//! Domains: where a tape's outputs, at a time known only to within a
//! bracket, go through a function outside its domain or at a pole
//! ([`Tape::undefined`]).
//!
//! A solver that cannot take a step is told nothing by a NaN or a branch
//! it cannot follow; the cause is often an equation that has no value (or
//! no finite one) there: `atan2(t, t)` at t = 0, `1 / (t − 0.5)` at 0.5,
//! `ln(f)` or `sqrt(f)` once f < 0. So the argument of each function with
//! a restricted domain is compared with the points where it leaves it,
//! within a first-order bound on how far the argument moves while t moves
//! across the bracket (the kink check's propagation, [`super::kink`], with
//! the uncertainty put on t instead of the coordinates).

use super::kink::value_and_error;
use super::{Instr, Reg, Tape, TapeError, TapeInputs, check};
use crate::function::{FUNCTIONS, FunctionKind};
use crate::node::UnaryOp;

/// How the function left its domain (see [`TapeUndefined`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Domain {
    /// At a pole: a divisor, the base of a negative power, the argument of
    /// `ln` at 0, `tan` at an odd multiple of π/2: the value is unbounded.
    Pole,
    /// The argument is outside the domain: `sqrt`, `ln` or a fractional
    /// power of a negative number, `asin` or `acos` beyond ±1.
    Outside,
    /// At the edge of the domain, where the derivative is unbounded:
    /// `sqrt`, a fractional power, `asin` or `acos` of an argument that
    /// reaches the edge within its bound without being past it (the next
    /// moment it is).
    Edge,
    /// `atan2(0, 0)`: no angle.
    NoAngle,
    /// The value overflows f64 from finite arguments (`exp(1000)`).
    Overflow,
}

/// A function of a tape outside its domain (see [`Tape::undefined`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TapeUndefined {
    /// The first output that depends on the function's value; `None` if
    /// none does (dead code).
    pub output: Option<usize>,
    /// The function as the model language names it (`"ln"`, `"sqrt"`,
    /// `"atan2"`, `"pow"`, `"tan"` …), or `"division"` for a quotient or
    /// a negative integer power, `"multiplication"`, `"addition"` for an
    /// overflow of those.
    pub function: &'static str,
    /// How it left its domain.
    pub domain: Domain,
    /// The argument's value at the inputs (for `atan2`, y; for a
    /// division, the divisor).
    pub argument: f64,
}

/// How many bounds an argument may be from a pole or a domain's edge and
/// still count as on it (as the kink check's margin).
const MARGIN: f64 = 16.0;

/// Unit roundoff, 2⁻⁵³.
const UNIT: f64 = f64::EPSILON / 2.0;

impl Tape {
    /// The first instruction that, at `inputs` with t uncertain by
    /// `t_error` (the coordinates, parameters and constants exact), applies
    /// a function outside its domain or at a pole (see [`Domain`]), or
    /// overflows from finite operands. An argument within [`MARGIN`]
    /// first-order bounds of the domain's edge counts: `t_error` is the
    /// half-width of a bracket around `inputs.t` in which the tape's value
    /// is in question, and 0 asks about `inputs.t` alone (then only an
    /// argument exactly at a pole or outside counts, and tan's pole within
    /// the argument's roundoff).
    ///
    /// `registers` and `errors` are scratch of at least
    /// [`registers`](Self::registers) values each; `trig` as in
    /// [`eval_with_cache`](Self::eval_with_cache). Meant for the error
    /// path: allocates when it finds one (to name the output).
    ///
    /// # Errors
    /// [`TapeError::ShortSlice`] as [`eval`](Self::eval), for `errors` too.
    pub fn undefined(
        &self,
        inputs: &TapeInputs<'_>,
        t_error: f64,
        registers: &mut [f64],
        errors: &mut [f64],
        trig: &mut [f64],
    ) -> Result<Option<TapeUndefined>, TapeError> {
        self.check_inputs(inputs, registers)?;
        check("errors", self.registers, errors.len())?;
        let (r, e) = (registers, errors);
        self.load(inputs, r);
        e[..self.registers].fill(0.0);
        if let Some(t) = self.t_reg {
            e[t] = t_error.abs();
        }
        for (i, ins) in self.instrs.iter().enumerate() {
            let (value, error) = value_and_error(ins, r, e, trig);
            if let Some((function, domain, argument)) = outside(ins, r, e, value) {
                return Ok(Some(TapeUndefined {
                    output: self.first_reader(i),
                    function,
                    domain,
                    argument,
                }));
            }
            let dst = ins.dst() as usize;
            r[dst] = value;
            // A NaN bound (∞ − ∞ of an argument's move) says nothing:
            // taken as no move.
            e[dst] = if error.is_nan() { 0.0 } else { error };
        }
        Ok(None)
    }
}

/// The model language's name of a scalar function.
fn unary_name(op: UnaryOp) -> &'static str {
    if let UnaryOp::Smooth(_) = op {
        return "step";
    }
    FUNCTIONS
        .iter()
        .find(|f| f.kind == FunctionKind::Unary(op))
        .map_or("a function", |f| f.name)
}

/// Past the edge of the domain (`Outside`), or at it within the argument's
/// bound (`Edge`).
fn past(outside: bool) -> Domain {
    if outside {
        Domain::Outside
    } else {
        Domain::Edge
    }
}

/// Whether instruction `ins` (its operands in `r`, their bounds in `e`,
/// its value `value`) leaves its function's domain: the function, how, and
/// its argument.
fn outside(ins: &Instr, r: &[f64], e: &[f64], value: f64) -> Option<(&'static str, Domain, f64)> {
    let arg = |a: Reg| (r[a as usize], e[a as usize]);
    // Within the margin of a point (distance 0 at the point itself).
    let near = |distance: f64, error: f64| distance <= MARGIN * error;
    // An interval x ± margin·e reaching below 0 (strictly: √0 is defined).
    let below = |x: f64, error: f64| x - MARGIN * error < 0.0;
    let (sources, n) = ins.sources();
    let finite_operands = sources[..n].iter().all(|&a| r[a as usize].is_finite());
    if !finite_operands {
        // Not this instruction's doing: an input or an earlier one.
        return None;
    }
    let found = match *ins {
        Instr::Div { b: a, .. } | Instr::Recip { a, .. } => {
            let (x, ex) = arg(a);
            near(x.abs(), ex).then_some(("division", Domain::Pole, x))
        }
        Instr::PowI { a, n, .. } if n < 0 => {
            let (x, ex) = arg(a);
            near(x.abs(), ex).then_some(("division", Domain::Pole, x))
        }
        Instr::Sqrt { a, .. } => {
            let (x, ex) = arg(a);
            below(x, ex).then_some(("sqrt", past(x < 0.0), x))
        }
        Instr::PowF { a, p, .. } => {
            let (x, ex) = arg(a);
            if p < 0.0 && near(x.abs(), ex) {
                Some(("pow", Domain::Pole, x))
            } else if p.fract() != 0.0 && below(x, ex) {
                Some(("pow", past(x < 0.0), x))
            } else {
                None
            }
        }
        Instr::Pow { a, b, .. } => {
            let ((x, ex), (y, ey)) = (arg(a), arg(b));
            let integer = y.fract() == 0.0 && ey == 0.0;
            if y < 0.0 && near(x.abs(), ex) {
                Some(("pow", Domain::Pole, x))
            } else if !integer && below(x, ex) {
                Some(("pow", past(x < 0.0), x))
            } else {
                None
            }
        }
        Instr::Atan2 { y, x, .. } => {
            let ((y, ey), (x, ex)) = (arg(y), arg(x));
            (near(y.abs(), ey) && near(x.abs(), ex)).then_some(("atan2", Domain::NoAngle, y))
        }
        Instr::Unary { op, a, .. } => {
            let (x, ex) = arg(a);
            match op {
                UnaryOp::Ln if x <= 0.0 || below(x, ex) => {
                    let domain = if near(x.abs(), ex) {
                        Domain::Pole
                    } else {
                        Domain::Outside
                    };
                    Some(("ln", domain, x))
                }
                UnaryOp::Asin | UnaryOp::Acos if x.abs() + MARGIN * ex > 1.0 => {
                    Some((unary_name(op), past(x.abs() > 1.0), x))
                }
                // cos x is 0 at the pole: within its move and the roundoff
                // of x itself (no double is an odd multiple of π/2).
                UnaryOp::Tan if near(x.cos().abs(), ex + 4.0 * UNIT * x.abs()) => {
                    Some(("tan", Domain::Pole, x))
                }
                _ => None,
            }
        }
        _ => None,
    };
    if found.is_some() {
        return found;
    }
    // Finite operands, a value that is not: an overflow (or a domain
    // left in a way the rules above do not know).
    if value.is_finite() {
        return None;
    }
    let x = r[sources[0] as usize];
    let function = match *ins {
        Instr::Unary { op, .. } => unary_name(op),
        Instr::Mul { .. } | Instr::Scale { .. } | Instr::Square { .. } => "multiplication",
        Instr::Div { .. } | Instr::Recip { .. } => "division",
        Instr::PowI { .. } => "powi",
        Instr::PowF { .. } | Instr::Pow { .. } => "pow",
        Instr::Sqrt { .. } => "sqrt",
        Instr::Atan2 { .. } => "atan2",
        Instr::Sin { .. } | Instr::SinQ { .. } => "sin",
        Instr::Cos { .. } | Instr::CosQ { .. } => "cos",
        Instr::Add { .. }
        | Instr::Sub { .. }
        | Instr::MulAdd { .. }
        | Instr::AddConst { .. }
        | Instr::Neg { .. }
        | Instr::Copy { .. }
        | Instr::Const { .. } => "addition",
    };
    let domain = if value.is_nan() {
        Domain::Outside
    } else {
        Domain::Overflow
    };
    Some((function, domain, x))
}

#[cfg(test)]
mod tests {
    use super::{Domain, TapeUndefined};
    use crate::ExprId;
    use crate::arena::Arena;
    use crate::node::UnaryOp;
    use crate::tape::{Tape, TapeInputs};

    /// The undefined function of `f` (built on coordinate x and time t, as
    /// the second of two outputs) at x, t ± `t_error`.
    fn undefined_at(
        f: impl Fn(&mut Arena, ExprId, ExprId) -> ExprId,
        x: f64,
        t: f64,
        t_error: f64,
    ) -> Option<TapeUndefined> {
        let mut a = Arena::new();
        let xs = a.coordinate("x", 0);
        let ts = a.time();
        let out = f(&mut a, xs, ts);
        let other = a.add(xs, ts);
        let tape = Tape::compile(&a, &[other, out]);
        let inputs = TapeInputs {
            q: &[x],
            qd: &[],
            params: &[],
            t,
        };
        let mut r = vec![0.0; tape.registers()];
        let mut e = vec![0.0; tape.registers()];
        tape.undefined(&inputs, t_error, &mut r, &mut e, &mut [])
            .expect("slices of the tape's lengths")
    }

    fn shifted(a: &mut Arena, t: ExprId, c: f64) -> ExprId {
        let c = a.num(c);
        a.sub(t, c)
    }

    fn kind(u: Option<TapeUndefined>) -> Option<(Option<usize>, &'static str, Domain)> {
        u.map(|u| (u.output, u.function, u.domain))
    }

    #[test]
    fn atan2_of_two_zeros_has_no_angle_at_the_time_and_near_it() {
        let f = |a: &mut Arena, x, t| {
            let y = shifted(a, t, 0.5);
            let at = a.atan2(y, y);
            a.add(x, at)
        };
        let found = Some((Some(1), "atan2", Domain::NoAngle));
        assert_eq!(kind(undefined_at(f, 0.3, 0.5, 0.0)), found);
        // A bracket of 1e-9 around a time 1e-10 off the zero.
        assert_eq!(kind(undefined_at(f, 0.3, 0.5 + 1e-10, 1e-9)), found);
        assert_eq!(kind(undefined_at(f, 0.3, 0.5 + 1e-6, 1e-9)), None);
        assert_eq!(kind(undefined_at(f, 0.3, 0.4, 0.0)), None);
    }

    #[test]
    fn divisors_logarithms_roots_and_powers_leave_their_domains() {
        let recip = |a: &mut Arena, x, t| {
            let d = shifted(a, t, 0.5);
            let one = a.num(1.0);
            let q = a.div(one, d);
            a.add(x, q)
        };
        assert_eq!(
            kind(undefined_at(recip, 0.0, 0.5, 0.0)),
            Some((Some(1), "division", Domain::Pole))
        );
        assert_eq!(
            kind(undefined_at(recip, 0.0, 0.5 - 1e-12, 1e-11)),
            Some((Some(1), "division", Domain::Pole))
        );
        assert_eq!(kind(undefined_at(recip, 0.0, 0.4, 1e-6)), None);
        let ln = |a: &mut Arena, x, t| {
            let d = shifted(a, t, 0.5);
            let l = a.unary(UnaryOp::Ln, d);
            a.add(x, l)
        };
        assert_eq!(
            kind(undefined_at(ln, 0.0, 0.4, 0.0)),
            Some((Some(1), "ln", Domain::Outside))
        );
        assert_eq!(
            kind(undefined_at(ln, 0.0, 0.5, 0.0)),
            Some((Some(1), "ln", Domain::Pole))
        );
        assert_eq!(kind(undefined_at(ln, 0.0, 0.6, 0.0)), None);
        let root = |a: &mut Arena, x, t| {
            let d = shifted(a, t, 0.5);
            let s = a.sqrt(d);
            a.add(x, s)
        };
        assert_eq!(
            kind(undefined_at(root, 0.0, 0.4, 0.0)),
            Some((Some(1), "sqrt", Domain::Outside))
        );
        // √0 is defined, just past 0 it is not.
        assert_eq!(kind(undefined_at(root, 0.0, 0.5, 0.0)), None);
        assert_eq!(
            kind(undefined_at(root, 0.0, 0.5, 1e-9)),
            Some((Some(1), "sqrt", Domain::Edge))
        );
        assert_eq!(
            kind(undefined_at(root, 0.0, 0.5 - 1e-9, 1e-9)),
            Some((Some(1), "sqrt", Domain::Outside))
        );
        let arc = |a: &mut Arena, x, t| {
            let s = a.acos(t);
            a.add(x, s)
        };
        assert_eq!(
            kind(undefined_at(arc, 0.0, 1.5, 0.0)),
            Some((Some(1), "acos", Domain::Outside))
        );
        assert_eq!(kind(undefined_at(arc, 0.0, 0.5, 0.0)), None);
        let tan = |a: &mut Arena, x, t| {
            let s = a.unary(UnaryOp::Tan, t);
            a.add(x, s)
        };
        assert_eq!(
            kind(undefined_at(tan, 0.0, std::f64::consts::FRAC_PI_2, 0.0)),
            Some((Some(1), "tan", Domain::Pole))
        );
        assert_eq!(kind(undefined_at(tan, 0.0, 1.0, 0.0)), None);
        let exp = |a: &mut Arena, x, t| {
            let k = a.scale(1000.0, t);
            let s = a.unary(UnaryOp::Exp, k);
            a.add(x, s)
        };
        assert_eq!(
            kind(undefined_at(exp, 0.0, 1.0, 0.0)),
            Some((Some(1), "exp", Domain::Overflow))
        );
        assert_eq!(kind(undefined_at(exp, 0.0, 0.1, 0.0)), None);
    }

    #[test]
    fn functions_of_the_coordinates_alone_count_only_outside() {
        // √(x²) at x = 0 is defined (its bound is 0: no t in it).
        let norm = |a: &mut Arena, x, _| {
            let s = a.powi(x, 2);
            a.sqrt(s)
        };
        assert_eq!(kind(undefined_at(norm, 0.0, 0.5, 1.0)), None);
        let recip = |a: &mut Arena, x, _| {
            let one = a.num(1.0);
            a.div(one, x)
        };
        assert_eq!(
            kind(undefined_at(recip, 0.0, 0.5, 1.0)),
            Some((Some(1), "division", Domain::Pole))
        );
        assert_eq!(kind(undefined_at(recip, 1e-300, 0.5, 1.0)), None);
    }
}
