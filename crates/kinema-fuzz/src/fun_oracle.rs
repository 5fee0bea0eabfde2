//! The `fun` target's reference: simEngine2D's evaluator (IEEE arithmetic,
//! left to right), traced so that the oracles judge kinema only where that
//! reference means what the symbolic engine means (exact real arithmetic
//! rounded once per operation).
//!
//! Where they part, the oracles stand aside and say why in the code:
//! - a range event — an operation on finite operands that overflows, or on
//!   nonzero operands that underflows to 0 — makes IEEE's value differ from
//!   the real one ((1e308 + t)·3·0 is NaN in IEEE and −3 in the reals);
//! - `atan2` on the negative x axis (y = ±0, or a y that rounding left near
//!   0, x < 0) is ±π by the sign of a zero, which algebra does not keep; at
//!   the origin it has no value;
//! - a power whose base rounding left near 0 (`abs(t - t*t/t)` is 1.4e-17
//!   at t = 0.1): xᵖ jumps from 0 to about 1 there for a small p, so the
//!   reference's value is the rounding's, and the reals' (kinema's
//!   t·t/t → t) is 0;
//! - an undefined value that starts in a part that varies with `t`
//!   (`acos(t + 9)` for t ≥ 0) is a domain the run leaves, not an undefined
//!   expression: kinema's 0·u → 0 may drop it, as computer algebra does;
//! - finite differences cannot resolve features narrower than their step:
//!   a tiny t-free constant (`tan(1e-10 + t)`), `abs` of a nearly zero
//!   argument (a corner within the stencil), or a large intermediate.

use kinema_adm::fun::{BinOp, Expr, Func, Func2, Node};
use kinema_expr::UnaryOp;

/// One evaluation of a `fun` at `t`, with what the oracles need to know.
pub(crate) struct Trace {
    /// Every node's value, children before parents.
    pub(crate) values: Vec<f64>,
    /// The largest finite intermediate magnitude.
    pub(crate) scale: f64,
    /// An overflow or underflow happened (see the module docs).
    pub(crate) range_event: bool,
    /// `atan2` at the origin or on the negative x axis.
    pub(crate) atan2_ambiguous: bool,
    /// A power of a nonzero base within 1e-12 of 0 relative to the scale.
    pub(crate) power_of_roundoff: bool,
    /// `abs` of an argument within 1e-6 of 0 relative to the scale.
    pub(crate) abs_near_zero: bool,
    /// A division by a divisor smaller than 1e-9: a pole (or a removable
    /// singularity, t²/cos(atan2(8, t)) at 0) within the differences' step.
    pub(crate) divisor_near_zero: bool,
    /// Nodes whose value is not finite while their operands' are.
    pub(crate) origins: Vec<usize>,
}

impl Trace {
    /// The expression's value.
    pub(crate) fn value(&self) -> f64 {
        self.values.last().copied().unwrap_or(f64::NAN)
    }
}

/// The operands of a node.
fn operands(node: Node) -> [Option<u32>; 2] {
    match node {
        Node::Num(_) | Node::Pi | Node::T => [None, None],
        Node::Neg(a) | Node::Call(_, a) => [Some(a), None],
        Node::Bin(_, a, b) | Node::Call2(_, a, b) => [Some(a), Some(b)],
    }
}

/// Evaluates `expr` at `t`, every number and `t` scaled by 1 ± `delta`
/// (alternating by node; `delta = 0` is the engine's own evaluation).
pub(crate) fn trace(expr: &Expr, t: f64, delta: f64) -> Trace {
    let nodes = expr.nodes();
    let mut tr = Trace {
        values: Vec::with_capacity(nodes.len()),
        scale: 0.0,
        range_event: false,
        atan2_ambiguous: false,
        power_of_roundoff: false,
        abs_near_zero: false,
        divisor_near_zero: false,
        origins: Vec::new(),
    };
    let mut abs_args = Vec::new();
    for (k, &node) in nodes.iter().enumerate() {
        let get = |i: u32| tr.values.get(i as usize).copied().unwrap_or(f64::NAN);
        let nudge = if k % 2 == 0 { 1.0 + delta } else { 1.0 - delta };
        let x = match node {
            Node::Num(x) => x * nudge,
            Node::Pi => std::f64::consts::PI * nudge,
            Node::T => t * nudge,
            Node::Neg(a) => -get(a),
            Node::Bin(op, a, b) => {
                let (a, b) = (get(a), get(b));
                tr.divisor_near_zero |= op == BinOp::Div && b.abs() < 1e-9;
                tr.power_of_roundoff |= op == BinOp::Pow && roundoff(a, tr.scale);
                op.apply(a, b)
            }
            Node::Call(f, a) => {
                if f == Func::Unary(UnaryOp::Abs) {
                    abs_args.push(get(a));
                }
                // A sine, cosine or tangent of an argument whose ulp is a
                // radian or more (|x| ≥ 2⁵²) is the rounding's value, not
                // the reals': two evaluators that round x differently agree
                // on nothing, not even the sign (sin of −6e27 to the power
                // π: NaN in one, a number in the other; fuzz seed 2626).
                let periodic = matches!(f, Func::Unary(UnaryOp::Sin | UnaryOp::Cos | UnaryOp::Tan));
                tr.range_event |= periodic && get(a).abs() >= 4_503_599_627_370_496.0;
                f.apply(get(a))
            }
            Node::Call2(Func2::Atan2, a, b) => {
                let (y, x) = (get(a), get(b));
                // On the negative x axis the branch cut: a y that is 0 in
                // the reals but ±1e-17 from rounding (t − t·t/t) picks ±π.
                tr.atan2_ambiguous |= x <= 0.0 && y.abs() <= 1e-12 * (1.0 + tr.scale);
                y.atan2(x)
            }
            Node::Call2(Func2::Power, a, b) => {
                tr.power_of_roundoff |= roundoff(get(a), tr.scale);
                get(a).powf(get(b))
            }
        };
        let ops: Vec<f64> = operands(node).iter().flatten().map(|&i| get(i)).collect();
        let finite_operands = ops.iter().all(|v| v.is_finite());
        if finite_operands && !x.is_finite() {
            tr.origins.push(k);
            // A division by an exact zero, or a function outside its domain,
            // is undefined in the reals too; anything else overflowed.
            let by_zero = matches!(node, Node::Bin(BinOp::Div, _, _)) && ops.get(1) == Some(&0.0);
            tr.range_event |= !by_zero && !x.is_nan() && !domain_pole(node, &ops);
        }
        let nonzero_operands = !ops.is_empty() && ops.iter().all(|&v| v != 0.0 && v.is_finite());
        let flushing = matches!(
            node,
            Node::Bin(BinOp::Mul | BinOp::Div | BinOp::Pow, _, _)
                | Node::Call2(Func2::Power, _, _)
                | Node::Call(Func::Unary(UnaryOp::Exp), _)
        );
        // Underflow: flushed to 0, or into the subnormals where precision is
        // lost (5e-324·π is 1.5e-323, and / 5e-324 gives 3, not π).
        if flushing && nonzero_operands && x.abs() < f64::MIN_POSITIVE {
            tr.range_event = true;
        }
        if ops.iter().any(|v| v.is_subnormal()) && flushing {
            tr.range_event = true;
        }
        if x.is_finite() {
            tr.scale = tr.scale.max(x.abs());
        }
        tr.values.push(x);
    }
    let near = 1e-6 * (1.0 + tr.scale);
    tr.abs_near_zero = abs_args.iter().any(|a| a.abs() < near);
    tr
}

/// Whether `x` is nonzero and within 1e-12 of 0 relative to `scale`: a
/// value that may be 0 in the reals and only rounding's in IEEE.
fn roundoff(x: f64, scale: f64) -> bool {
    x != 0.0 && x.abs() <= 1e-12 * (1.0 + scale)
}

/// A pole of a function at a finite argument (log 0, 0^−1): undefined in
/// the reals, not an overflow.
fn domain_pole(node: Node, ops: &[f64]) -> bool {
    match node {
        Node::Call(Func::Unary(UnaryOp::Ln) | Func::Log10, _) => ops.first() == Some(&0.0),
        Node::Bin(BinOp::Pow, _, _) | Node::Call2(Func2::Power, _, _) => {
            ops.first() == Some(&0.0) && ops.get(1).is_some_and(|&p| p < 0.0)
        }
        _ => false,
    }
}

/// Times far from the samples at which a part that seems constant is probed:
/// `t − 3.4e16` does not move over [0, 2] in f64, nor `sin(1e160 + t)` at
/// 1e30, but both do here.
const PROBE_TIMES: [f64; 6] = [-1e300, -1e30, -7.25, 3.5e3, 1e30, 1e300];

/// Whether `expr` is undefined at every time because of a part that does not
/// vary with time — what kinema must refuse — given its traces at the sample
/// times: every value non-finite, no range event, and the nodes where the
/// value first becomes undefined have the same operands at every sample and
/// at the far [`PROBE_TIMES`].
pub(crate) fn undefined_whatever_t(expr: &Expr, traces: &[Trace]) -> bool {
    let Some(first) = traces.first() else {
        return false;
    };
    if traces
        .iter()
        .any(|tr| tr.value().is_finite() || tr.range_event)
    {
        return false;
    }
    let probes: Vec<Trace> = PROBE_TIMES.iter().map(|&t| trace(expr, t, 0.0)).collect();
    let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
    traces.iter().all(|tr| {
        tr.origins.iter().all(|&k| {
            expr.nodes().get(k).is_some_and(|&node| {
                operands(node).iter().flatten().all(|&i| {
                    let at =
                        |trace: &Trace| trace.values.get(i as usize).copied().unwrap_or(f64::NAN);
                    traces
                        .iter()
                        .chain(&probes)
                        .all(|other| same(at(other), at(first)))
                })
            })
        })
    })
}

/// What the value comparison may tolerate at `t`: `None` where the reference
/// is not comparable (a range event, an ambiguous atan2, a power of a base
/// that may be rounding's), else rounding at
/// the scale of the intermediate values plus the expression's sensitivity to
/// perturbing every number and `t` by a few ulps (tan of 1e9).
pub(crate) fn tolerance(expr: &Expr, t: f64) -> Option<f64> {
    let tr = trace(expr, t, 0.0);
    if tr.range_event || tr.atan2_ambiguous || tr.power_of_roundoff {
        return None;
    }
    // The value's sensitivity to a few ulps on every number, π and t, with
    // the nudges' signs alternating along the nodes, both ways (one pattern
    // alone can cancel: tan at its pole, where the argument's ulps decide
    // the value, was missed by one).
    let mut sensitivity = 0.0f64;
    for delta in [4.0 * f64::EPSILON, -4.0 * f64::EPSILON] {
        let w = trace(expr, t, delta).value();
        // A few ulps carry the value out of a function's domain (asin of
        // log10(10) = 1): at its edge, where the slope is infinite, one
        // rounding of either evaluator moves the value by √ε; not
        // comparable.
        if !w.is_finite() && tr.value().is_finite() {
            return None;
        }
        if (w - tr.value()).is_finite() {
            sensitivity = sensitivity.max((w - tr.value()).abs());
        }
    }
    Some(1e-9 * (1.0 + tr.scale) * (expr.nodes().len() as f64) + 1000.0 * sensitivity)
}

/// Whether finite differences can judge the derivatives of `expr` at the
/// sample times `times`: every value comparable, intermediates below 1e4, no
/// `abs` near its corner, no divisor near 0, and every t-free constant 0 or at least 1e-3 in
/// magnitude (a smaller one sets a scale in t the steps cannot resolve).
pub(crate) fn resolvable(expr: &Expr, times: &[f64]) -> bool {
    let nodes = expr.nodes();
    let mut has_t: Vec<bool> = Vec::with_capacity(nodes.len());
    for &node in nodes {
        let h = matches!(node, Node::T)
            || operands(node)
                .iter()
                .flatten()
                .any(|&i| has_t.get(i as usize).copied().unwrap_or(true));
        has_t.push(h);
    }
    times.iter().all(|&t| {
        let tr = trace(expr, t, 0.0);
        let tiny_constant = tr
            .values
            .iter()
            .zip(&has_t)
            .any(|(&v, &h)| !h && v != 0.0 && v.abs() < 1e-3);
        tr.scale < 1e4
            && !tr.abs_near_zero
            && !tr.divisor_near_zero
            && !tiny_constant
            && tolerance(expr, t).is_some()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn traces(s: &str) -> (Expr, Vec<Trace>) {
        let e = Expr::parse(s).expect("parses");
        let tr = crate::FUN_TIMES
            .iter()
            .map(|&t| trace(&e, t, 0.0))
            .collect();
        (e, tr)
    }

    #[test]
    fn undefined_whatever_t_only_from_parts_that_do_not_vary() {
        for (s, want) in [
            ("0/0 + t", true),
            ("t + (t - t)/(t - t)", true),
            ("t + 0*(1e308*1e308)", false), // an overflow: a range event
            ("exp((t-t)/(t-t)+0)", true),
            ("sin(t-t)*acos(t+9)+t", false), // acos leaves its domain with t
            ("(1e308+t)*3*0-3", false),      // overflow
            ("t/t", false),                  // undefined at t = 0 only
            ("log(t-t) + t", true),
            // sin of −6e27 (its ulp is 1e12): the sign, and so whether the
            // power π is defined, is the rounding's (fuzz seed 2626).
            ("atan2((2),sin(log(73858507214e-30)^--17)^pi)", false),
            // t − 3.4e16 is constant in f64 over [0, 2], not in the reals.
            (
                "acos(power((t-34568901234567890-pi),9))*(pi-t)/5*(t-t)",
                false,
            ),
        ] {
            let (e, tr) = traces(s);
            assert_eq!(undefined_whatever_t(&e, &tr), want, "{s}");
        }
    }

    #[test]
    fn comparisons_stand_aside_where_ieee_and_the_reals_part() {
        let e = |s: &str| Expr::parse(s).expect("parses");
        assert!(tolerance(&e("atan2(-t*tan(tan(0)), -t)"), 0.1).is_none());
        assert!(tolerance(&e("atan2(7,atan2(t-t*t/t,t*5*log(1e-1)))"), 0.1).is_none());
        assert!(tolerance(&e("(1e-200*t)*(1e-200*t)/t + t"), 0.1).is_none());
        assert!(tolerance(&e("sin(t)*2"), 0.1).is_some());
        // Fuzz seed 6060: the base is 1.4e-17 in IEEE, 0 in the reals.
        let tiny_power = "abs(t - t*t / t).^+2.2250738585072014e-308";
        assert!(tolerance(&e(tiny_power), 0.1).is_none());
        assert!(tolerance(&e("power(abs(t - t*t / t), 1e-3)"), 0.1).is_none());
        assert!(tolerance(&e("abs(t - 0.05).^0.5"), 0.1).is_some());
        assert!(tolerance(&e("5e-324*pi / 5e-324"), 0.0).is_none());
        assert!(tolerance(&e("power(asin(log10((10))), 4)"), 0.0).is_none());
        assert!(!resolvable(
            &e("tan(t)/tan(sin(1e-10)+t)*t"),
            &crate::FUN_TIMES
        ));
        assert!(!resolvable(&e("abs(t*t+tan(pi))"), &crate::FUN_TIMES));
        assert!(!resolvable(&e("t/3*t/cos(atan2(8,t))"), &crate::FUN_TIMES));
        assert!(resolvable(&e("abs(t*t+1) + sin(t)"), &crate::FUN_TIMES));
    }
}
