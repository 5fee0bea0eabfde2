//! Constructors. Each one canonicalizes, then interns.
//!
//! Canonical forms:
//! - numbers are finite where folding keeps them so; `-0.0` is `0.0`;
//! - a sum is `constant + Σ cᵢ·eᵢ` with each `eᵢ` distinct, not a number, not a
//!   sum and not a product with a coefficient ≠ 1; `cᵢ ≠ 0`; terms sorted by
//!   [`Arena::term_cmp`]; a sum of one term and no constant is that term;
//! - a product is `c · Π bᵢ^pᵢ` with each `bᵢ` distinct, not a number (unless
//!   folding it would not be finite), not a product raised to an integer power
//!   (it is flattened), `pᵢ ≠ 0`, `c ≠ 0`; factors sorted by [`Arena::factor_cmp`]; `c·x` is the product
//!   `c · x^1`, and `1 · x^1` is `x`.
//!
//! Simplification never changes a value where the original expression is
//! defined (it may define a value where the original was not, e.g. `x/x → 1`
//! where `x` may vanish). It never makes an expression with an undefined
//! constant look defined ([`Arena::is_undefined`]): `0 · u`, `u − u` and
//! `u / u` with such a `u` are NaN, not 0 or 1, and numbers are folded only
//! while they stay finite.
//!
//! A product of more than [`FLATTEN_MAX`] factors is kept as one factor when
//! it is multiplied further instead of being flattened into its parent, so
//! that nested products (the prefix and suffix products of a long product's
//! derivative) cost O(1) each instead of a copy of their factors.

use crate::arena::Arena;
use crate::node::{ExprId, Factor, Node, NodeRef, Term, UnaryOp};

/// Products of at most this many factors are flattened into a product they
/// are a factor of (with an integer exponent); larger ones stay one factor.
///
/// Every product of a hand-written model is far smaller, so their canonical
/// forms are those of full flattening; the bound only matters for very long
/// products, whose derivatives it keeps linear in size.
pub const FLATTEN_MAX: usize = 8;

/// Whether `p` is an integer small enough for `powi`.
pub(crate) fn is_int(p: f64) -> bool {
    p.fract() == 0.0 && p.abs() <= f64::from(i32::MAX)
}

/// `x^p` evaluated the way both the tree evaluator and the tape do it.
#[inline]
pub(crate) fn powv(x: f64, p: f64) -> f64 {
    if p == 1.0 {
        x
    } else if p == 2.0 {
        x * x
    } else if p == 0.5 {
        x.sqrt()
    } else if is_int(p) {
        x.powi(p as i32)
    } else {
        x.powf(p)
    }
}

/// An operand of a sum (a term and its coefficient) or of a product (a
/// factor and its exponent): an expression with a numeric weight.
trait Weighted: Copy {
    fn expr(&self) -> ExprId;
    fn weight(&self) -> f64;
    fn add_weight(&mut self, w: f64);
}

impl Weighted for Term {
    fn expr(&self) -> ExprId {
        self.expr
    }
    fn weight(&self) -> f64 {
        self.coeff
    }
    fn add_weight(&mut self, w: f64) {
        self.coeff += w;
    }
}

impl Weighted for Factor {
    fn expr(&self) -> ExprId {
        self.base
    }
    fn weight(&self) -> f64 {
        self.exp
    }
    fn add_weight(&mut self, w: f64) {
        self.exp += w;
    }
}

/// Sorts operands into canonical order, merges equal expressions (adding
/// their weights: like terms, like bases) and drops zero weights.
/// Operands already at weight 0 are slots the caller consumed (folded or
/// flattened) and are simply dropped.
///
/// Returns whether an undefined operand (`undefined`) merged to a zero
/// weight (`u − u`, `u / u`): the caller's result is then NaN, not the
/// simplified form.
#[must_use]
fn merge_like<T: Weighted>(
    buf: &mut Vec<T>,
    order: impl Fn(ExprId, ExprId) -> std::cmp::Ordering,
    undefined: impl Fn(ExprId) -> bool,
) -> bool {
    buf.retain(|o| o.weight() != 0.0);
    buf.sort_by(|a, b| order(a.expr(), b.expr()));
    let mut w: usize = 0;
    for r in 0..buf.len() {
        let next = buf[r];
        if w > 0 && buf[w - 1].expr() == next.expr() {
            buf[w - 1].add_weight(next.weight());
        } else {
            buf[w] = next;
            w += 1;
        }
    }
    buf.truncate(w);
    let lost = buf.iter().any(|o| o.weight() == 0.0 && undefined(o.expr()));
    buf.retain(|o| o.weight() != 0.0);
    lost
}

/// Whether `a·b` of two coefficients is not flushed to zero from nonzero
/// operands (an underflowed coefficient would silently turn a whole term
/// into 0, as in [`fold_power`]).
fn scales_within_range(a: f64, b: f64) -> bool {
    a == 0.0 || b == 0.0 || a * b != 0.0
}

fn finite_or(v: f64) -> Option<f64> {
    v.is_finite().then_some(if v == 0.0 { 0.0 } else { v })
}

/// `coeff · v^p` for folding into a coefficient, unless that would lose the
/// term to underflow: `v^p` not finite, or `v^p` or the product flushed to
/// zero from nonzero operands (an underflowed coefficient would silently
/// turn a whole term into 0; a subnormal one keeps it, less precisely, and
/// folds so that constants stay numbers: acos(π + 1e-3/1.8e308) is still
/// seen to be undefined). An overflowing product is returned (±∞): the
/// caller keeps it visible as undefined.
fn fold_power(coeff: f64, v: f64, p: f64) -> Option<f64> {
    let r = finite_or(powv(v, p))?;
    if v != 0.0 && r == 0.0 {
        return None;
    }
    if !scales_within_range(coeff, r) {
        return None;
    }
    let product = coeff * r;
    Some(if product == 0.0 { 0.0 } else { product })
}

/// Folds `v^p` into the coefficient `coeff`: as [`fold_power`] (`wide`
/// is `None`), or, for `p = ±1`, into the wide coefficient, which no
/// product of f64 numbers leaves (other powers fold as [`fold_power`] does
/// on the wide value). The new coefficient (the wide one rounded to f64:
/// possibly 0 or ±∞ until later numbers bring it back), or `None` if the
/// number stays a factor.
fn fold(coeff: f64, wide: &mut Option<Wide>, v: f64, p: f64) -> Option<f64> {
    let Some(w) = wide else {
        return fold_power(coeff, v, p);
    };
    if !v.is_finite() || v == 0.0 || (p != 1.0 && p != -1.0) {
        let folded = fold_power(w.to_f64(), v, p).filter(|x| x.is_finite())?;
        *w = Wide::of(folded);
        return Some(folded);
    }
    w.mul_pow(v, p);
    Some(w.to_f64())
}

/// A number m·2^e with m in [0.5, 1) (or 0): a product of f64 numbers and
/// their reciprocals never leaves its range, and each product rounds as
/// the same product of f64s does where that one stays normal.
#[derive(Clone, Copy, Debug)]
struct Wide {
    m: f64,
    e: i64,
}

impl Wide {
    /// `v` (finite) split into mantissa and exponent.
    fn of(v: f64) -> Wide {
        if v == 0.0 || !v.is_finite() {
            return Wide { m: v, e: 0 };
        }
        // Subnormals are scaled into the normal range first.
        let (v, bias) = if v.abs() < f64::MIN_POSITIVE {
            (v * 2f64.powi(64), -64)
        } else {
            (v, 0)
        };
        let bits = v.to_bits();
        let biased = ((bits >> 52) & 0x7ff) as i64;
        let m = f64::from_bits((bits & !(0x7ff << 52)) | (1022 << 52));
        Wide {
            m,
            e: biased - 1022 + bias,
        }
    }

    /// Multiplies by `v` (finite, nonzero) to the power `p = ±1`.
    fn mul_pow(&mut self, v: f64, p: f64) {
        let x = Wide::of(v);
        let (m, e) = if p > 0.0 {
            (self.m * x.m, self.e + x.e)
        } else {
            (self.m / x.m, self.e - x.e)
        };
        let n = Wide::of(m);
        *self = Wide { m: n.m, e: n.e + e };
    }

    /// The value rounded to f64 (±∞ or 0 outside its range).
    fn to_f64(self) -> f64 {
        if self.m == 0.0 || !self.m.is_finite() {
            return self.m;
        }
        // m·2^e in two steps, each by a power of two within f64's range
        // (exact, but for the rounding of a subnormal result); beyond it
        // the result is ±∞ or 0, as it should be.
        let e = self.e.clamp(-2200, 2200) as i32;
        let half = e / 2;
        self.m * 2f64.powi(half) * 2f64.powi(e - half)
    }
}

/// Whether a number left as a factor, `v^p`, has a value: `v` finite and the
/// power finite (a power that underflows is kept unfolded, and is defined).
pub(crate) fn number_power_defined(v: f64, p: f64) -> bool {
    v.is_finite() && powv(v, p).is_finite()
}

impl Arena {
    /// A number. `-0.0` becomes `0.0`.
    pub fn num(&mut self, v: f64) -> ExprId {
        let v = if v == 0.0 { 0.0 } else { v };
        self.intern(Node::Num(v))
    }

    /// `a + b`.
    pub fn add(&mut self, a: ExprId, b: ExprId) -> ExprId {
        self.linear(
            0.0,
            &[
                Term {
                    coeff: 1.0,
                    expr: a,
                },
                Term {
                    coeff: 1.0,
                    expr: b,
                },
            ],
        )
    }

    /// `a − b`.
    pub fn sub(&mut self, a: ExprId, b: ExprId) -> ExprId {
        self.linear(
            0.0,
            &[
                Term {
                    coeff: 1.0,
                    expr: a,
                },
                Term {
                    coeff: -1.0,
                    expr: b,
                },
            ],
        )
    }

    /// `−a`.
    pub fn neg(&mut self, a: ExprId) -> ExprId {
        self.scale(-1.0, a)
    }

    /// `c · a`.
    pub fn scale(&mut self, c: f64, a: ExprId) -> ExprId {
        self.linear(0.0, &[Term { coeff: c, expr: a }])
    }

    /// `Σ items` in one canonicalization pass (linear in the number of terms;
    /// prefer it to repeated [`add`](Self::add) for long sums).
    pub fn sum(&mut self, items: &[ExprId]) -> ExprId {
        let terms: Vec<Term> = items
            .iter()
            .map(|&expr| Term { coeff: 1.0, expr })
            .collect();
        self.linear(0.0, &terms)
    }

    /// `constant + Σ coeff·expr`, canonicalized.
    pub fn linear(&mut self, constant: f64, terms: &[Term]) -> ExprId {
        // 0 · u is not 0 when u is undefined.
        if terms
            .iter()
            .any(|t| t.coeff == 0.0 && self.is_undefined(t.expr))
        {
            return self.num(f64::NAN);
        }
        let mut buf = std::mem::take(&mut self.scratch_terms);
        buf.clear();
        buf.extend_from_slice(terms);
        let mut constant = constant;
        // Expand in place: numbers go to the constant, sums are flattened,
        // scaled products become a coefficient on their unit product.
        let mut i = 0;
        while i < buf.len() {
            let Term { coeff, expr } = buf[i];
            if coeff == 0.0 {
                i += 1;
                continue;
            }
            match self.node(expr) {
                NodeRef::Num(v) => {
                    constant += coeff * v;
                    buf[i].coeff = 0.0;
                }
                // Inner sums are canonical: their terms need no further
                // expansion. A term whose coefficient would underflow keeps
                // the sum unflattened, as the scaled product below.
                NodeRef::Add {
                    constant: c,
                    terms: inner,
                } if inner.iter().all(|t| scales_within_range(coeff, t.coeff)) => {
                    constant += coeff * c;
                    buf[i].coeff = 0.0;
                    buf.extend(inner.iter().map(|t| Term {
                        coeff: coeff * t.coeff,
                        expr: t.expr,
                    }));
                }
                // c·X: the unit product X may itself be a sum (c·(a + b)),
                // so the slot is examined again. Unless coeff·c underflows:
                // a coefficient flushed to 0 would drop the term, and with it
                // a pole (1e-300/t·1e-300 is undefined at t = 0, finding
                // F18), so the product keeps its own coefficient.
                NodeRef::Mul { coeff: c, .. } if c != 1.0 && scales_within_range(coeff, c) => {
                    let unit = self.unit_product(expr);
                    buf[i] = Term {
                        coeff: coeff * c,
                        expr: unit,
                    };
                    continue;
                }
                _ => {}
            }
            i += 1;
        }
        let lost = merge_like(
            &mut buf,
            |a, b| self.term_cmp(a, b),
            |e| self.is_undefined(e),
        );
        let constant = if constant == 0.0 { 0.0 } else { constant };
        let result = match (buf.as_slice(), constant == 0.0) {
            _ if lost => self.num(f64::NAN),
            ([], _) => self.num(constant),
            ([t], true) if t.coeff == 1.0 => t.expr,
            ([t], true) => {
                // c·e is a product.
                let (c, e) = (t.coeff, t.expr);
                self.product_of(c, &[Factor { base: e, exp: 1.0 }])
            }
            _ => {
                let start = self.terms.len() as u32;
                let len = buf.len() as u32;
                self.terms.extend_from_slice(&buf);
                self.intern(Node::Add {
                    constant,
                    start,
                    len,
                })
            }
        };
        self.scratch_terms = buf;
        result
    }

    /// The product `X` of a product `c·X`.
    fn unit_product(&mut self, e: ExprId) -> ExprId {
        let mut buf = std::mem::take(&mut self.scratch_factors);
        buf.clear();
        if let NodeRef::Mul { factors, .. } = self.node(e) {
            buf.extend_from_slice(factors);
        }
        let unit = self.product_from(1.0, &mut buf);
        self.scratch_factors = buf;
        unit
    }

    /// `a · b`.
    pub fn mul(&mut self, a: ExprId, b: ExprId) -> ExprId {
        self.product_of(
            1.0,
            &[Factor { base: a, exp: 1.0 }, Factor { base: b, exp: 1.0 }],
        )
    }

    /// `a / b`.
    pub fn div(&mut self, a: ExprId, b: ExprId) -> ExprId {
        self.product_of(
            1.0,
            &[Factor { base: a, exp: 1.0 }, Factor { base: b, exp: -1.0 }],
        )
    }

    /// `Π items` in one canonicalization pass.
    pub fn product(&mut self, items: &[ExprId]) -> ExprId {
        let factors: Vec<Factor> = items
            .iter()
            .map(|&base| Factor { base, exp: 1.0 })
            .collect();
        self.product_of(1.0, &factors)
    }

    /// `a^n` for an integer `n`.
    pub fn powi(&mut self, a: ExprId, n: i32) -> ExprId {
        self.powf(a, f64::from(n))
    }

    /// `a^p` for a constant real `p` (for non-integer `p`, defined for `a ≥ 0`).
    pub fn powf(&mut self, a: ExprId, p: f64) -> ExprId {
        if p == 0.0 && !self.is_undefined(a) {
            return self.one;
        }
        self.product_of(1.0, &[Factor { base: a, exp: p }])
    }

    /// `√a`.
    pub fn sqrt(&mut self, a: ExprId) -> ExprId {
        self.powf(a, 0.5)
    }

    /// `a^b`; with a constant `b` this is [`powf`](Self::powf).
    pub fn pow(&mut self, a: ExprId, b: ExprId) -> ExprId {
        if let Some(p) = self.as_num(b) {
            return self.powf(a, p);
        }
        if a == self.one && !self.is_undefined(b) {
            return self.one;
        }
        self.intern(Node::Pow(a, b))
    }

    /// `coeff · Π base^exp`, canonicalized.
    pub fn product_of(&mut self, coeff: f64, factors: &[Factor]) -> ExprId {
        let mut buf = std::mem::take(&mut self.scratch_factors);
        buf.clear();
        buf.extend_from_slice(factors);
        let e = self.product_from(coeff, &mut buf);
        self.scratch_factors = buf;
        e
    }

    /// [`product_of`](Self::product_of) working in (and clobbering) `buf`.
    fn product_from(&mut self, coeff0: f64, buf: &mut Vec<Factor>) -> ExprId {
        // u^0 is not 1 when u is undefined.
        if buf
            .iter()
            .any(|f| f.exp == 0.0 && self.is_undefined(f.base))
        {
            return self.num(f64::NAN);
        }
        // Numbers fold one at a time while the coefficient stays in f64's
        // range; if one cannot (1e300·1e300·1e-300, 1/5e-324 · 1e308), the
        // numbers are folded again as a set, in a wider range, and kept
        // folded when the whole coefficient is in range (finding F14).
        let mut saved = std::mem::take(&mut self.scratch_numbers);
        saved.clone_from(buf);
        let (mut coeff, refused) = self.fold_numbers(coeff0, buf, None);
        if refused {
            let mut wide = std::mem::take(&mut self.scratch_wide);
            wide.clone_from(&saved);
            let (c, _) = self.fold_numbers(coeff0, &mut wide, Some(Wide::of(coeff0)));
            if c.is_finite() && c != 0.0 {
                std::mem::swap(buf, &mut wide);
                coeff = c;
            }
            self.scratch_wide = wide;
        }
        self.scratch_numbers = saved;
        // A factor undefined, or a number whose power is not finite: 0 times
        // it is not 0.
        let undefined = |arena: &Self, f: &Factor| {
            f.exp != 0.0
                && (arena.is_undefined(f.base)
                    || arena
                        .as_num(f.base)
                        .is_some_and(|v| !number_power_defined(v, f.exp)))
        };
        if coeff == 0.0 {
            return if buf.iter().any(|f| undefined(self, f)) {
                self.num(f64::NAN)
            } else {
                self.zero
            };
        }
        if merge_like(buf, |a, b| self.factor_cmp(a, b), |e| self.is_undefined(e)) {
            return self.num(f64::NAN);
        }
        if !coeff.is_finite() {
            // Overflowed coefficient: keep it visible as a factor instead of folding.
            let c = self.intern(Node::Num(coeff));
            buf.insert(0, Factor { base: c, exp: 1.0 });
            coeff = 1.0;
        }
        match buf.as_slice() {
            [] => self.num(coeff),
            [f] if coeff == 1.0 && f.exp == 1.0 => f.base,
            _ => {
                let start = self.factors.len() as u32;
                let len = buf.len() as u32;
                self.factors.extend_from_slice(buf);
                self.intern(Node::Mul { coeff, start, len })
            }
        }
    }

    /// The expansion of [`product_from`](Self::product_from), in place:
    /// numbers fold into the coefficient, products raised to integer powers
    /// are flattened (their factors are examined again). Folds as
    /// [`fold_power`] does, or with `wide` in [`Wide`]'s range (the
    /// coefficient returned is then the wide one rounded to f64). Returns
    /// the coefficient and whether a number could not be folded.
    fn fold_numbers(
        &mut self,
        coeff: f64,
        buf: &mut Vec<Factor>,
        mut wide: Option<Wide>,
    ) -> (f64, bool) {
        let mut coeff = coeff;
        let mut refused = false;
        // Expand in place: numbers fold into the coefficient, products raised
        // to integer powers are flattened (their factors are examined again).
        let mut i = 0;
        while i < buf.len() {
            let Factor { base, exp } = buf[i];
            if exp == 0.0 {
                i += 1;
                continue;
            }
            match self.node(base) {
                NodeRef::Num(v) => {
                    // An overflowing coefficient is taken (and kept
                    // visible as undefined below) unless the wide fold
                    // brings it back into range.
                    if v.is_finite()
                        && let Some(next) = fold(coeff, &mut wide, v, exp)
                    {
                        refused |= !next.is_finite();
                        coeff = next;
                        buf[i].exp = 0.0;
                    } else {
                        refused |= v.is_finite();
                    }
                }
                // (c·Π xᵢ^eᵢ)^n = cⁿ · Π xᵢ^(eᵢn) only when cⁿ folds within
                // f64's range: (ln t / ln 10)^1000 flattened would fold
                // 0.434^1000 to 0 and the whole term would vanish, and
                // (1e200·t)^2 would overflow; both stay as written.
                NodeRef::Mul {
                    coeff: c,
                    factors: inner,
                } if is_int(exp) && inner.len() <= FLATTEN_MAX => {
                    if let Some(next) =
                        fold(coeff, &mut wide, c, exp).filter(|x| wide.is_some() || x.is_finite())
                    {
                        coeff = next;
                        buf[i].exp = 0.0;
                        buf.extend(inner.iter().map(|f| Factor {
                            base: f.base,
                            exp: f.exp * exp,
                        }));
                    } else {
                        refused = true;
                    }
                }
                NodeRef::Mul { coeff: c, .. } if c > 0.0 && c != 1.0 => {
                    // (c·X)^p = c^p · X^p for c > 0, under the same condition.
                    if let Some(next) =
                        fold(coeff, &mut wide, c, exp).filter(|x| wide.is_some() || x.is_finite())
                    {
                        coeff = next;
                        buf[i].base = self.unit_product(base);
                    } else {
                        refused = true;
                    }
                }
                _ => {}
            }
            i += 1;
        }
        (coeff, refused)
    }

    /// A function of one argument, folded when the argument is a number and
    /// the result is finite.
    pub fn unary(&mut self, op: UnaryOp, a: ExprId) -> ExprId {
        if let Some(v) = self.as_num(a)
            && v.is_finite()
            && let Some(r) = finite_or(op.apply(v))
        {
            return self.num(r);
        }
        match (op, self.node(a)) {
            (UnaryOp::Smooth(k), _) if k > 3 => self.zero,
            (UnaryOp::Abs, NodeRef::Unary(UnaryOp::Abs | UnaryOp::Exp, _)) => a,
            (UnaryOp::Ln, NodeRef::Unary(UnaryOp::Exp, x)) => x,
            _ => self.intern(Node::Unary(op, a)),
        }
    }

    /// `sin a`.
    pub fn sin(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Sin, a)
    }
    /// `cos a`.
    pub fn cos(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Cos, a)
    }
    /// `tan a`.
    pub fn tan(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Tan, a)
    }
    /// `asin a`.
    pub fn asin(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Asin, a)
    }
    /// `acos a`.
    pub fn acos(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Acos, a)
    }
    /// `atan a`.
    pub fn atan(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Atan, a)
    }
    /// `sinh a`.
    pub fn sinh(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Sinh, a)
    }
    /// `cosh a`.
    pub fn cosh(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Cosh, a)
    }
    /// `tanh a`.
    pub fn tanh(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Tanh, a)
    }
    /// `e^a`.
    pub fn exp(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Exp, a)
    }
    /// `ln a`.
    pub fn ln(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Ln, a)
    }
    /// `|a|`.
    pub fn abs(&mut self, a: ExprId) -> ExprId {
        self.unary(UnaryOp::Abs, a)
    }

    /// `atan2(y, x)`: the angle of the vector (x, y).
    pub fn atan2(&mut self, y: ExprId, x: ExprId) -> ExprId {
        if let (Some(yv), Some(xv)) = (self.as_num(y), self.as_num(x))
            && yv.is_finite()
            && xv.is_finite()
            && let Some(r) = finite_or(yv.atan2(xv))
        {
            return self.num(r);
        }
        self.intern(Node::Atan2(y, x))
    }

    /// The smooth cubic step of multibody tools:
    /// `h0` for `x ≤ x0`, `h1` for `x ≥ x1`, and in between
    /// `h0 + (h1 − h0)·Δ²(3 − 2Δ)` with `Δ = (x − x0)/(x1 − x0)`.
    /// C¹ in `x`; its second derivative jumps at `x0` and `x1`.
    pub fn step(&mut self, x: ExprId, x0: ExprId, h0: ExprId, x1: ExprId, h1: ExprId) -> ExprId {
        let num = self.sub(x, x0);
        let den = self.sub(x1, x0);
        let u = self.div(num, den);
        let s = self.unary(UnaryOp::Smooth(0), u);
        let dh = self.sub(h1, h0);
        let rise = self.mul(dh, s);
        self.add(h0, rise)
    }
}
