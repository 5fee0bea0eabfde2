//! First-order error bounds of straight-line arithmetic ([`Bounded`]) and
//! the kink test on them ([`KinkFunction`]): what the kink and precision
//! checks of a [`System`](crate::System) compute, for code that evaluates
//! Φ without the symbolic engine (generated code writes its checks as
//! straight-line code over [`Bounded`]).
//!
//! A value carries a bound on its absolute error: each coordinate q_k is
//! uncertain by the caller's `uncertainty` (a solution's residual, as a
//! stand-in for Newton's error in q) plus one unit roundoff of `size` +
//! |q_k| (a coordinate at 0 is 0 within the rounding of the model's other
//! numbers, whose size `size` is); parameters, t and constants are exact;
//! each operation propagates its operands' bounds to first order and adds
//! one unit roundoff of its result. Where the first-order bound overstates
//! a function's change, the change's own bound is taken (a sine moves by at
//! most 2, √x by at most √e, acos by at most π/√2 · √(2e)).
//!
//! These are the rules of the tape back end's analysis (kinema-expr's
//! `Tape::kink` and `Tape::error_bounds`), operation for operation: each
//! method here is one of the tape's instructions, so a system that applies
//! them in the tape's order gets the tape's bounds. The two are kept apart
//! because the runtime must not depend on the symbolic engine; a change to
//! one is a change to the other (`tests/generated_checks.rs` compares
//! them).

/// Unit roundoff, 2⁻⁵³.
pub const UNIT: f64 = f64::EPSILON / 2.0;

/// How many error bounds an argument may be from a kink and still count as
/// on it: the bound is a first-order estimate, and the library's sin, cos,
/// powf … round within a few units, not one.
pub const MARGIN: f64 = 16.0;

/// A value and a bound on its absolute error (see [the module](self)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounded {
    /// The value, as plain evaluation computes it.
    pub value: f64,
    /// A first-order bound on its absolute error.
    pub error: f64,
}

/// The result of an operation: its value, the error propagated from its
/// operands, and one unit roundoff of the value.
#[inline]
fn rounded(value: f64, error: f64) -> Bounded {
    Bounded {
        value,
        error: error + UNIT * value.abs(),
    }
}

impl Bounded {
    /// An exact input: a constant, a parameter, the time.
    #[inline]
    #[must_use]
    pub fn exact(value: f64) -> Bounded {
        Bounded { value, error: 0.0 }
    }

    /// Coordinate `x`, uncertain by `uncertainty` and by one unit roundoff
    /// of `size` + |x|.
    #[inline]
    #[must_use]
    pub fn coordinate(x: f64, uncertainty: f64, size: f64) -> Bounded {
        Bounded {
            value: x,
            error: uncertainty.abs() + UNIT * (size.abs() + x.abs()),
        }
    }

    /// k · a (−a for k = −1, as the tape's compiler emits it).
    #[inline]
    #[must_use]
    pub fn scale(self, k: f64) -> Bounded {
        if k == -1.0 {
            return -self;
        }
        rounded(k * self.value, k.abs() * self.error)
    }

    /// a + k · b (a sum and a difference for k = ±1).
    #[inline]
    #[must_use]
    pub fn mul_add(self, k: f64, b: Bounded) -> Bounded {
        if k == 1.0 {
            return self + b;
        }
        if k == -1.0 {
            return self - b;
        }
        let product = k * b.value;
        rounded(
            self.value + product,
            self.error + k.abs() * b.error + UNIT * product.abs(),
        )
    }

    /// a + c for a constant c.
    #[inline]
    #[must_use]
    pub fn add_const(self, c: f64) -> Bounded {
        rounded(self.value + c, self.error)
    }

    /// `constant + Σ k · term`, left to right: the first term scaled, the
    /// others accumulated, then the constant (an expression's sum).
    #[must_use]
    pub fn sum(constant: f64, terms: &[(f64, Bounded)]) -> Bounded {
        let Some(&(k, first)) = terms.first() else {
            return Bounded::exact(constant);
        };
        let mut acc = if k == 1.0 { first } else { first.scale(k) };
        for &(k, t) in &terms[1..] {
            acc = acc.mul_add(k, t);
        }
        if constant == 0.0 {
            acc
        } else {
            acc.add_const(constant)
        }
    }

    /// 1 / a.
    #[inline]
    #[must_use]
    pub fn recip(self) -> Bounded {
        let q = 1.0 / self.value;
        rounded(q, power_error(-1.0, self.value, q, self.error))
    }

    /// a².
    #[inline]
    #[must_use]
    pub fn square(self) -> Bounded {
        let x = self.value;
        rounded(x * x, 2.0 * x.abs() * self.error)
    }

    /// √a. |√(x + e) − √x| ≤ √e: the first-order e / 2√x overstates the
    /// change near 0 (and is infinite at 0).
    #[inline]
    #[must_use]
    pub fn sqrt(self) -> Bounded {
        let s = self.value.sqrt();
        rounded(s, first_order_or(self.error / (2.0 * s), self.error.sqrt()))
    }

    /// aⁿ.
    #[inline]
    #[must_use]
    pub fn powi(self, n: i32) -> Bounded {
        let p = self.value.powi(n);
        rounded(p, power_error(f64::from(n), self.value, p, self.error))
    }

    /// aᵖ for a constant, non-integer p.
    #[inline]
    #[must_use]
    pub fn powf(self, p: f64) -> Bounded {
        let value = self.value.powf(p);
        rounded(value, power_error(p, self.value, value, self.error))
    }

    /// aᵖ for a constant p > 0, p ≠ 1, as an expression's factor computes
    /// it: a², √a, an integer power or a real one.
    #[inline]
    #[must_use]
    pub fn power(self, p: f64) -> Bounded {
        if p == 2.0 {
            self.square()
        } else if p == 0.5 {
            self.sqrt()
        } else if p.fract() == 0.0 && p.abs() <= f64::from(i32::MAX) {
            #[allow(clippy::cast_possible_truncation)]
            self.powi(p as i32)
        } else {
            self.powf(p)
        }
    }

    /// `coeff · Π base^exp` over `factors` (base, exp), an expression's
    /// product: the numerator (positive exponents) multiplied left to
    /// right, divided by the denominator's product (or its reciprocal),
    /// then scaled.
    #[must_use]
    pub fn product(coeff: f64, factors: &[(Bounded, f64)]) -> Bounded {
        let (mut num, mut den): (Option<Bounded>, Option<Bounded>) = (None, None);
        for &(base, exp) in factors {
            let p = exp.abs();
            let value = if p == 1.0 { base } else { base.power(p) };
            let part = if exp > 0.0 { &mut num } else { &mut den };
            *part = Some(match *part {
                None => value,
                Some(c) => c * value,
            });
        }
        let r = match (num, den) {
            (Some(a), None) => a,
            (Some(a), Some(b)) => a / b,
            (None, Some(b)) => b.recip(),
            (None, None) => Bounded::exact(1.0),
        };
        if coeff == 1.0 { r } else { r.scale(coeff) }
    }

    /// sin a (one library call for sin and cos: the bound needs the other).
    #[inline]
    #[must_use]
    pub fn sin(self) -> Bounded {
        sine_or_cosine(self.value.sin_cos(), true, self.error)
    }

    /// cos a.
    #[inline]
    #[must_use]
    pub fn cos(self) -> Bounded {
        sine_or_cosine(self.value.sin_cos(), false, self.error)
    }

    /// A unary function with its slope at the value.
    #[inline]
    fn unary(self, value: f64, slope: f64) -> Bounded {
        rounded(value, slope.abs() * self.error)
    }

    /// tan a.
    #[must_use]
    pub fn tan(self) -> Bounded {
        let x = self.value;
        self.unary(x.tan(), 1.0 + x.tan().powi(2))
    }

    /// asin a; near ±1, where the slope is infinite, the change is at most
    /// π/√2 · √(2e) (the ½-Hölder bound).
    #[must_use]
    pub fn asin(self) -> Bounded {
        self.arc(self.value.asin())
    }

    /// acos a (as [`asin`](Self::asin)).
    #[must_use]
    pub fn acos(self) -> Bounded {
        self.arc(self.value.acos())
    }

    fn arc(self, value: f64) -> Bounded {
        let x = self.value;
        let first = (1.0 / (1.0 - x * x).sqrt()).abs() * self.error;
        rounded(
            value,
            first_order_or(
                first,
                std::f64::consts::FRAC_PI_2 * (2.0 * self.error).sqrt(),
            ),
        )
    }

    /// atan a.
    #[must_use]
    pub fn atan(self) -> Bounded {
        let x = self.value;
        self.unary(x.atan(), 1.0 / (1.0 + x * x))
    }

    /// sinh a.
    #[must_use]
    pub fn sinh(self) -> Bounded {
        let x = self.value;
        self.unary(x.sinh(), x.cosh())
    }

    /// cosh a.
    #[must_use]
    pub fn cosh(self) -> Bounded {
        let x = self.value;
        self.unary(x.cosh(), x.sinh())
    }

    /// tanh a.
    #[must_use]
    pub fn tanh(self) -> Bounded {
        let x = self.value;
        self.unary(x.tanh(), 1.0 - x.tanh().powi(2))
    }

    /// eᵃ.
    #[must_use]
    pub fn exp(self) -> Bounded {
        let x = self.value;
        self.unary(x.exp(), x.exp())
    }

    /// ln a.
    #[must_use]
    pub fn ln(self) -> Bounded {
        let x = self.value;
        self.unary(x.ln(), 1.0 / x)
    }

    /// |a|.
    #[must_use]
    pub fn abs(self) -> Bounded {
        self.unary(self.value.abs(), 1.0)
    }

    /// The k-th derivative of the unit cubic step (the model language's
    /// `smoothstep` and its derivatives).
    #[must_use]
    pub fn smooth(self, k: u8) -> Bounded {
        let x = self.value;
        let slope = if k < 3 { smooth(k + 1, x) } else { 0.0 };
        self.unary(smooth(k, x), slope)
    }

    /// aᵇ for a b that varies.
    #[must_use]
    pub fn pow(self, b: Bounded) -> Bounded {
        let (x, y) = (self.value, b.value);
        let p = x.powf(y);
        rounded(
            p,
            (y * x.powf(y - 1.0)).abs() * self.error + (p * x.ln()).abs() * b.error,
        )
    }

    /// atan2(a, x), a the ordinate.
    #[must_use]
    pub fn atan2(self, x: Bounded) -> Bounded {
        let (yv, xv) = (self.value, x.value);
        rounded(
            yv.atan2(xv),
            (xv.abs() * self.error + yv.abs() * x.error) / (xv * xv + yv * yv),
        )
    }
}

/// −a.
impl std::ops::Neg for Bounded {
    type Output = Bounded;
    #[inline]
    fn neg(self) -> Bounded {
        rounded(-self.value, self.error)
    }
}

/// a + b.
impl std::ops::Add for Bounded {
    type Output = Bounded;
    #[inline]
    fn add(self, b: Bounded) -> Bounded {
        rounded(self.value + b.value, self.error + b.error)
    }
}

/// a − b.
impl std::ops::Sub for Bounded {
    type Output = Bounded;
    #[inline]
    fn sub(self, b: Bounded) -> Bounded {
        rounded(self.value - b.value, self.error + b.error)
    }
}

/// a · b.
impl std::ops::Mul for Bounded {
    type Output = Bounded;
    #[inline]
    fn mul(self, b: Bounded) -> Bounded {
        rounded(
            self.value * b.value,
            b.value.abs() * self.error + self.value.abs() * b.error,
        )
    }
}

/// a / b.
impl std::ops::Div for Bounded {
    type Output = Bounded;
    #[inline]
    fn div(self, b: Bounded) -> Bounded {
        let q = self.value / b.value;
        rounded(q, (self.error + q.abs() * b.error) / b.value.abs())
    }
}

/// The k-th derivative of the unit cubic step at u: 0 before 0, 1 (k = 0)
/// or 0 after 1, the cubic in between.
fn smooth(k: u8, u: f64) -> f64 {
    if u.is_nan() {
        return u;
    }
    let inside = u > 0.0 && u < 1.0;
    match k {
        0 if u <= 0.0 => 0.0,
        0 if u >= 1.0 => 1.0,
        0 => u * u * (3.0 - 2.0 * u),
        1 if inside => 6.0 * u * (1.0 - u),
        2 if inside => 6.0 - 12.0 * u,
        3 if inside => -12.0,
        _ => 0.0,
    }
}

/// The error of p = xⁿ from x's error `e`: |n xⁿ⁻¹| e, computed as
/// |n| |p| (e / |x|) so that it holds wherever p does (xⁿ⁻¹ itself under-
/// or overflows where p does not). At x = 0 the slope's own form.
fn power_error(n: f64, x: f64, p: f64, e: f64) -> f64 {
    if x == 0.0 {
        (n * x.powf(n - 1.0)).abs() * e
    } else {
        n.abs() * p.abs() * (e / x.abs())
    }
}

/// sin x (`sine`) or cos x from (sin x, cos x), with the bound from x's
/// error (second order: the slope may be near 0 where the argument is far
/// from exact; at most 2).
fn sine_or_cosine((sin, cos): (f64, f64), sine: bool, error: f64) -> Bounded {
    let (value, slope) = if sine { (sin, cos) } else { (cos, sin) };
    let bound = slope.abs() * error + 0.5 * error * error;
    rounded(value, first_order_or(bound, 2.0))
}

/// The smaller of a first-order bound and a bound on the function's whole
/// change (the latter where the first is not a number: 0/0 at √0).
fn first_order_or(first: f64, cap: f64) -> f64 {
    if first <= cap { first } else { cap }
}

/// A function that is not differentiable somewhere (or whose derivative
/// is infinite there): where [`at`](Self::at) its argument is, within
/// [`MARGIN`] error bounds, Φ_q, ν and γ are the roundoff's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KinkFunction {
    /// √x at 0 (a square root or a norm).
    Sqrt,
    /// A fractional power below 2, or a varying one, at 0.
    Power,
    /// |x| at 0.
    Abs,
    /// atan2(y, x) at (0, 0).
    Atan2,
    /// asin x at ±1.
    Asin,
    /// acos x at ±1.
    Acos,
    /// ln x at 0.
    Ln,
    /// The cubic step at 0 and 1, where its second derivative jumps.
    Smoothstep,
}

impl KinkFunction {
    /// Its name as [`Kink::function`](crate::Kink::function) spells it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            KinkFunction::Sqrt => "sqrt",
            KinkFunction::Power => "power",
            KinkFunction::Abs => "abs",
            KinkFunction::Atan2 => "atan2",
            KinkFunction::Asin => "asin",
            KinkFunction::Acos => "acos",
            KinkFunction::Ln => "ln",
            KinkFunction::Smoothstep => "smoothstep",
        }
    }

    /// Whether the function applied to `x` (and, for atan2, `y` the
    /// ordinate; ignored otherwise) is at its kink within [`MARGIN`]
    /// error bounds. Never when the bound is 0: an argument that reads no
    /// coordinate is exact, and a function of time at its kink at an exact
    /// time is the model's own one-sided definition, not roundoff.
    #[must_use]
    pub fn at(self, x: Bounded, y: Bounded) -> bool {
        let near = |distance: f64, error: f64| error > 0.0 && distance <= MARGIN * error;
        let (v, e) = (x.value, x.error);
        match self {
            KinkFunction::Sqrt | KinkFunction::Power | KinkFunction::Abs | KinkFunction::Ln => {
                near(v.abs(), e)
            }
            KinkFunction::Atan2 => near(y.value.abs(), y.error) && near(v.abs(), e),
            KinkFunction::Asin | KinkFunction::Acos => near(1.0 - v.abs(), e),
            KinkFunction::Smoothstep => near(v.abs().min((v - 1.0).abs()), e),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Bounded, KinkFunction, UNIT};

    #[test]
    fn a_norm_of_roundoff_is_at_its_kink_and_a_determined_one_is_not() {
        let norm = |x: f64, y: f64, uncertainty: f64| {
            let nine = 9.0;
            let dx = Bounded::coordinate(x, uncertainty, 1.0).add_const(-nine);
            let dy = Bounded::coordinate(y, uncertainty, 1.0).add_const(-nine);
            Bounded::sum(0.0, &[(1.0, dx.square()), (1.0, dy.square())])
        };
        let at = |s: Bounded| KinkFunction::Sqrt.at(s, Bounded::exact(0.0));
        assert!(at(norm(9.0 + 1e-15, 9.0 - 2e-15, 0.0)));
        assert!(!at(norm(12.0, 5.0, 0.0)));
        assert!(!at(norm(9.0 + 1e-8, 9.0, 0.0)));
        assert!(at(norm(9.0 + 1e-8, 9.0, 1e-8)));
    }

    #[test]
    fn exact_arguments_are_never_at_a_kink() {
        assert!(!KinkFunction::Abs.at(Bounded::exact(0.0), Bounded::exact(0.0)));
        assert!(KinkFunction::Abs.at(Bounded::coordinate(0.0, 0.0, 1.0), Bounded::exact(0.0)));
    }

    #[test]
    fn a_sine_of_a_huge_argument_is_bounded_by_its_range() {
        let t = Bounded::exact(0.7);
        let fast = t.scale(1e30).sin();
        assert!(fast.error >= 1.0 && fast.error <= 2.0 + UNIT);
        assert!(t.sin().error < 1e-15);
    }

    #[test]
    fn products_follow_numerator_then_denominator() {
        let (a, b) = (Bounded::exact(3.0), Bounded::coordinate(2.0, 0.0, 0.0));
        let p = Bounded::product(-2.0, &[(a, 1.0), (b, -0.5)]);
        assert_eq!(p.value, -2.0 * (3.0 / 2.0f64.sqrt()));
        assert!(p.error > 0.0 && p.error < 1e-14);
    }
}
