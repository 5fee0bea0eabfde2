//! Property tests on random expressions.
//!
//! A random expression is generated as a plain tree (`T`) and evaluated three
//! independent ways: directly in f64 (the unsimplified reference, with a
//! running bound of its rounding error), in dual numbers (the reference
//! derivative), and through the engine (canonicalized, differentiated
//! symbolically, evaluated by tree and by tape). The suite runs more than
//! 10 000 cases.

use kinema_expr::{Arena, SymId, Tape, TapeInputs, smooth};
use proptest::prelude::*;

#[path = "common/random_expr.rs"]
mod random_expr;
use random_expr::{Fun, T, build, expr, symbols};

const EPS: f64 = f64::EPSILON;

/// Reference number: value, rounding-error bound of the value, derivative
/// along one seeded variable, and the magnitude of the derivative's
/// contributions (the derivative computed with absolute values), plus a flag
/// cleared where the function is not smooth (or not defined) near the point.
#[derive(Clone, Copy, Debug)]
struct R {
    v: f64,
    e: f64,
    d: f64,
    dm: f64,
    smooth: bool,
    /// Set where the value itself hinges on the sign of a zero (atan2 on its
    /// branch cut), which canonical forms legitimately do not preserve.
    cut: bool,
}

impl R {
    fn leaf(v: f64, d: f64) -> R {
        R {
            v,
            e: 0.0,
            d,
            dm: d.abs(),
            smooth: true,
            cut: false,
        }
    }
    /// [`chain`](Self::chain) for a function with second derivative f2:
    /// where the argument's rounding-error bound moves f' by more than
    /// 1e-9 of itself (cos near its zeros at a large argument, whose last
    /// bits two exact forms round differently), f' is not known to the
    /// derivative check's tolerance, so the point is not smooth for it
    /// (seen in CI: sin(x0³/x2³) against sin((x0/x2)³), 1.4e-8 apart).
    fn chain2(self, v: f64, f1: f64, f2: f64, smooth: bool) -> R {
        let conditioned = f2.abs() * self.e <= 1e-9 * f1.abs();
        self.chain(v, f1, smooth && conditioned)
    }

    /// Applies f with derivative f1 = f'(x).
    fn chain(self, v: f64, f1: f64, smooth: bool) -> R {
        R {
            v,
            e: f1.abs() * self.e + EPS * v.abs(),
            d: f1 * self.d,
            dm: f1.abs() * self.dm,
            smooth: self.smooth && smooth && v.is_finite() && f1.is_finite(),
            cut: self.cut,
        }
    }
}

fn add(a: R, b: R, sign: f64) -> R {
    let v = a.v + sign * b.v;
    R {
        v,
        e: a.e + b.e + EPS * v.abs(),
        d: a.d + sign * b.d,
        dm: a.dm + b.dm,
        smooth: a.smooth && b.smooth,
        cut: a.cut || b.cut,
    }
}

/// Whether a derivative `d` (contributions of magnitude `dm`) is known to
/// the derivative check's tolerance when the values it multiplies carry the
/// rounding-error bound `moved` of its result: a factor that is a roundoff
/// residue (x0 · (t − (x2 + t) − |x2|), exactly 0 · … symbolically but
/// 2.2e-16 · 1 in floating point, seen in CI) makes its product's
/// derivative a roundoff value, not a point for the check.
fn conditioned(d: f64, dm: f64, moved: f64) -> bool {
    moved <= 1e-9 * d.abs().max(dm)
}

fn mul(a: R, b: R) -> R {
    let v = a.v * b.v;
    let (d, dm) = (a.d * b.v + a.v * b.d, a.dm * b.v.abs() + a.v.abs() * b.dm);
    let moved = a.e * b.d.abs() + b.e * a.d.abs();
    R {
        v,
        e: b.v.abs() * a.e + a.v.abs() * b.e + EPS * v.abs(),
        d,
        dm,
        smooth: a.smooth && b.smooth && conditioned(d, dm, moved),
        cut: a.cut || b.cut,
    }
}

/// A divisor (or the base of a negative power) whose error bound reaches
/// its value may be 0: the quotient is not determined, so its bound is
/// infinite (the first-order bound would claim ±4.5e15 for the roundoff
/// residue of x1 − (x0 + x1) + x0, whose exact value 0 gives ∞).
fn undetermined(b: &R) -> bool {
    b.e >= b.v.abs()
}

fn div(a: R, b: R) -> R {
    let q = a.v / b.v;
    let e = if undetermined(&b) {
        f64::INFINITY
    } else {
        (a.e + q.abs() * b.e) / b.v.abs() + EPS * q.abs()
    };
    let (d, dm) = ((a.d - q * b.d) / b.v, (a.dm + q.abs() * b.dm) / b.v.abs());
    // q's and b's rounding errors move d = (a' − q b') / b by about this.
    let moved = (e * b.d.abs() + d.abs() * b.e) / b.v.abs();
    R {
        v: q,
        e,
        d,
        dm,
        smooth: a.smooth && b.smooth && b.v.abs() > 1e-6 && conditioned(d, dm, moved),
        cut: a.cut || b.cut,
    }
}

fn powf(a: R, p: f64) -> R {
    let integer = p.fract() == 0.0;
    let ok = if integer {
        p >= 0.0 || a.v.abs() > 1e-6
    } else {
        a.v > 1e-6
    };
    let negative_power_of_zero = p < 0.0 && undetermined(&a);
    // The second derivative conditions the first (see `chain2`): the
    // square of a tan(7.6e6) of 0.076, whose argument's rounding moves
    // it by 6.6e-8 of itself, has a derivative 2 tan · tan′ known to no
    // better (seen in a seed hunt, 1.2e-8 from the engine's).
    let f2 = if p == 0.0 || p == 1.0 {
        0.0
    } else {
        p * (p - 1.0) * a.v.powf(p - 2.0)
    };
    let mut r = a.chain2(a.v.powf(p), p * a.v.powf(p - 1.0), f2, ok);
    if negative_power_of_zero {
        r.e = f64::INFINITY;
    }
    r
}

/// Evaluates the reference at `x`, differentiating along variable `seed`
/// (`3` = parameter, `4` = time, `None` = no derivative).
fn reference(t: &T, x: &[f64; 5], seed: Option<usize>) -> R {
    let mut r = reference_node(t, x, seed);
    // Magnitudes near the ends of the f64 range make mathematically equal
    // forms overflow differently (e.g. sinh(u)² vs sinh(u)): not a derivative
    // check any more.
    let a = r.v.abs();
    if a != 0.0 && !(1e-100..1e100).contains(&a) {
        r.smooth = false;
    }
    r
}

fn reference_node(t: &T, x: &[f64; 5], seed: Option<usize>) -> R {
    let dv = |i: usize| if seed == Some(i) { 1.0 } else { 0.0 };
    match t {
        T::X(i) => R::leaf(x[*i as usize], dv(*i as usize)),
        T::P => R::leaf(x[3], dv(3)),
        T::Time => R::leaf(x[4], dv(4)),
        T::C(c) => R::leaf(*c, 0.0),
        T::Add(a, b) => add(reference(a, x, seed), reference(b, x, seed), 1.0),
        T::Sub(a, b) => add(reference(a, x, seed), reference(b, x, seed), -1.0),
        T::Mul(a, b) => mul(reference(a, x, seed), reference(b, x, seed)),
        T::Div(a, b) => div(reference(a, x, seed), reference(b, x, seed)),
        T::Neg(a) => {
            let a = reference(a, x, seed);
            R {
                v: -a.v,
                d: -a.d,
                ..a
            }
        }
        T::PowI(a, n) => powf(reference(a, x, seed), f64::from(*n)),
        T::PowF(a, p) => powf(reference(a, x, seed), *p),
        T::Sqrt(a) => powf(reference(a, x, seed), 0.5),
        T::Pow(a, b) => {
            let (a, b) = (reference(a, x, seed), reference(b, x, seed));
            let v = a.v.powf(b.v);
            let ln = a.v.ln();
            let e = v.abs() * (b.e * ln.abs() + b.v.abs() * a.e / a.v.abs()) + EPS * v.abs();
            let slope = b.d * ln + b.v * a.d / a.v;
            let d = v * slope;
            let dm = v.abs() * (b.dm * ln.abs() + b.v.abs() * a.dm / a.v.abs());
            // The operands' rounding errors move d = aᵇ (b' ln a + b a'/a)
            // by about this: a base that is 1 but for a roundoff residue
            // (((x2 + 1) − x2)^x0, exactly 1 symbolically, so a derivative
            // 0; seen in a seed hunt) leaves b' ln a a roundoff value.
            let rel_a = a.e / a.v.abs();
            let moved = e * slope.abs()
                + v.abs() * (b.d.abs() * rel_a + (b.e + b.v.abs() * rel_a) * (a.d / a.v).abs());
            R {
                v,
                e,
                d,
                dm,
                smooth: a.smooth
                    && b.smooth
                    && a.v > 1e-6
                    && v.is_finite()
                    && conditioned(d, dm, moved),
                cut: a.cut || b.cut,
            }
        }
        T::Un(f, a) => {
            let a = reference(a, x, seed);
            let u = a.v;
            match f {
                Fun::Sin => a.chain2(u.sin(), u.cos(), -u.sin(), true),
                Fun::Cos => a.chain2(u.cos(), -u.sin(), -u.cos(), true),
                Fun::Tan => {
                    let sec2 = 1.0 / (u.cos() * u.cos());
                    a.chain2(u.tan(), sec2, 2.0 * sec2 * u.tan(), u.cos().abs() > 1e-3)
                }
                Fun::Asin => {
                    let w = 1.0 - u * u;
                    a.chain2(
                        u.asin(),
                        1.0 / w.sqrt(),
                        u / (w * w.sqrt()),
                        u.abs() < 1.0 - 1e-6,
                    )
                }
                Fun::Acos => {
                    let w = 1.0 - u * u;
                    a.chain2(
                        u.acos(),
                        -1.0 / w.sqrt(),
                        -u / (w * w.sqrt()),
                        u.abs() < 1.0 - 1e-6,
                    )
                }
                Fun::Atan => {
                    let w = 1.0 + u * u;
                    a.chain2(u.atan(), 1.0 / w, -2.0 * u / (w * w), true)
                }
                Fun::Sinh => a.chain2(u.sinh(), u.cosh(), u.sinh(), true),
                Fun::Cosh => a.chain2(u.cosh(), u.sinh(), u.cosh(), true),
                Fun::Tanh => {
                    // sech², without 1 − tanh²'s cancellation for large |u|.
                    let (th, c) = (u.tanh(), u.cosh());
                    let sech2 = 1.0 / (c * c);
                    a.chain2(th, sech2, -2.0 * th * sech2, true)
                }
                Fun::Exp => a.chain2(u.exp(), u.exp(), u.exp(), true),
                Fun::Ln => a.chain2(u.ln(), 1.0 / u, -1.0 / (u * u), u > 1e-6),
                Fun::Abs => a.chain2(u.abs(), u.signum(), 0.0, u.abs() > 1e-6),
            }
        }
        T::Atan2(y, xx) => {
            let (y, xx) = (reference(y, x, seed), reference(xx, x, seed));
            let r2 = xx.v * xx.v + y.v * y.v;
            let v = y.v.atan2(xx.v);
            // (|x| e_y + |y| e_x) / r², scaled by the larger operand: r²
            // overflows beyond 10¹⁵⁴ (and underflows below 10⁻¹⁶²).
            let m = xx.v.abs().max(y.v.abs());
            let (xs, ys) = (xx.v / m, y.v / m);
            let e = (xs.abs() * y.e + ys.abs() * xx.e) / m / (xs * xs + ys * ys);
            let d = (xx.v * y.d - y.v * xx.d) / r2;
            let dm = (xx.v.abs() * y.dm + y.v.abs() * xx.dm) / r2;
            // The operands' rounding errors move d by about this: an x
            // that is a roundoff residue (x0 − x2 / (x2 / x0), exactly 0
            // symbolically, 1.5e-17 in floating point; seen in a seed
            // hunt) makes d = x y' / r² a roundoff value.
            let moved = (xx.e * y.d.abs() + y.e * xx.d.abs()) / r2;
            R {
                v,
                e: e + EPS * v.abs(),
                d,
                dm,
                // Not smooth across the branch cut (negative x axis).
                smooth: y.smooth
                    && xx.smooth
                    && r2 > 1e-6
                    && !(xx.v < 0.0 && y.v.abs() < 1e-6)
                    && conditioned(d, dm, moved),
                // On the cut the sign of y decides ±π: a y within its
                // rounding error of 0 (x0 · (t + (x0 − t) − x0), 0
                // symbolically, −1.9e-16 in floating point; seen in a
                // seed hunt) has no sign to decide it; at the origin
                // (both within their errors of 0) no angle is determined.
                cut: y.cut || xx.cut || (y.v.abs() <= y.e && (xx.v < 0.0 || xx.v.abs() <= xx.e)),
            }
        }
        T::Step(a, x0, h0, x1, h1) => {
            let a = reference(a, x, seed);
            let w = x1 - x0;
            let u = (a.v - x0) / w;
            let s = a.chain(
                smooth(0, u),
                smooth(1, u) / w,
                (u.abs() > 1e-6) && ((u - 1.0).abs() > 1e-6),
            );
            R {
                v: h0 + (h1 - h0) * s.v,
                e: (h1 - h0).abs() * s.e + EPS * (h0.abs() + (h1 - h0).abs()),
                d: (h1 - h0) * s.d,
                dm: (h1 - h0).abs() * s.dm,
                smooth: s.smooth,
                cut: s.cut,
            }
        }
    }
}

fn values(a: &Arena, syms: &[SymId], x: &[f64; 5]) -> impl Fn(SymId) -> f64 {
    let map: Vec<(SymId, f64)> = syms.iter().copied().zip(x.iter().copied()).collect();
    let _ = a;
    move |s| {
        map.iter()
            .find(|(k, _)| *k == s)
            .map_or(f64::NAN, |&(_, v)| v)
    }
}

fn point() -> impl Strategy<Value = [f64; 5]> {
    [
        -2.0f64..2.0,
        -2.0f64..2.0,
        -2.0f64..2.0,
        -2.0f64..2.0,
        0.0f64..3.0,
    ]
}

/// A random case of issue 13's run: (x1 − (x0 + x1) + x0)⁻¹ is 1/0 exactly
/// (the engine: ∞) but 1/1.4e-16 in floating point; the reference must call
/// it undetermined, not claim 7e15 within a finite bound.
#[test]
fn a_negative_power_of_a_roundoff_residue_is_undetermined() {
    let residue = T::Add(
        Box::new(T::Sub(
            Box::new(T::X(1)),
            Box::new(T::Add(Box::new(T::X(0)), Box::new(T::X(1)))),
        )),
        Box::new(T::X(0)),
    );
    let x = [0.1, 0.7, 0.0, 0.0, 0.0];
    assert_ne!(reference(&residue, &x, None).v, 0.0, "a nonzero residue");
    for t in [
        T::PowI(Box::new(residue.clone()), -1),
        T::Div(Box::new(T::C(1.0)), Box::new(residue)),
    ] {
        assert!(reference(&t, &x, None).e.is_infinite(), "{t:?}");
    }
}

/// A random case of CI's run at stop 14: d/dx0 of x0 · (t − (x2 + t) − |x2|)
/// is the second factor, exactly 0 (the engine folds it to 0) but 2.2e-16
/// in floating point. The reference must not hold the engine to that
/// roundoff residue within 1e-8 of itself: the point is not one for the
/// derivative check.
#[test]
fn a_derivative_that_is_a_roundoff_residue_is_not_checked() {
    let residue = T::Sub(
        Box::new(T::Sub(
            Box::new(T::Time),
            Box::new(T::Add(Box::new(T::X(2)), Box::new(T::Time))),
        )),
        Box::new(T::Un(Fun::Abs, Box::new(T::X(2)))),
    );
    let product = T::Mul(Box::new(residue), Box::new(T::X(0)));
    let x = [0.0, 0.0, -0.813243553178588, 0.0, 2.852224326494225];
    let r = reference(&product, &x, Some(0));
    assert_ne!(r.d, 0.0, "floating point leaves a residue");
    assert!(!r.smooth, "{r:?}");
    // Along x2 the derivative is not a residue and stays checked.
    assert!(reference(&product, &[0.5, 0.0, -0.8, 0.0, 2.8], Some(2)).smooth);
}

/// Seed-hunt cases of atan2 whose y is a roundoff residue (x0 · (t +
/// (x0 − t) − x0): 0 symbolically, −8e-17 in floating point): on the
/// negative x axis the residue's sign picks ±π, at the origin (x = p − p)
/// it picks −π/2 where the engine's exact 0 gives 0. Neither value is
/// determined, so neither is compared.
#[test]
fn atan2_of_a_residue_on_its_cut_or_at_the_origin_is_not_compared() {
    let residue = || {
        T::Mul(
            Box::new(T::X(0)),
            Box::new(T::Add(
                Box::new(T::Time),
                Box::new(T::Sub(
                    Box::new(T::Sub(Box::new(T::X(0)), Box::new(T::Time))),
                    Box::new(T::X(0)),
                )),
            )),
        )
    };
    let x = [-0.43009525959911055, 0.0, 0.0, 0.0, 2.941541780851727];
    let origin = T::Sub(Box::new(T::P), Box::new(T::P));
    for denominator in [T::X(0), origin] {
        let t = T::Atan2(Box::new(residue()), Box::new(denominator));
        let r = reference(&t, &x, None);
        assert_ne!(r.v, 0.0, "floating point leaves a residue");
        assert!(r.cut, "{r:?}");
    }
    // Off the axis, with a y that is not a residue, the value is compared.
    let t = T::Atan2(Box::new(T::X(0)), Box::new(T::X(0)));
    assert!(!reference(&t, &x, None).cut);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, max_global_rejects: 100_000, ..ProptestConfig::default() })]

    /// Canonicalization never changes a value where the original is defined.
    #[test]
    fn canonical_value_equals_unsimplified(t in expr(), x in point()) {
        let r = reference(&t, &x, None);
        prop_assume!(r.v.is_finite() && r.e.is_finite() && !r.cut);
        let mut a = Arena::new();
        let syms = symbols(&mut a);
        let e = build(&mut a, &t, false);
        let v = a.eval(e, values(&a, &syms, &x));
        let tol = 1e3 * (r.e + EPS * r.v.abs()) + 1e-300;
        prop_assert!((v - r.v).abs() <= tol,
            "engine {v:e} vs reference {:e} (tol {tol:e}) for {}", r.v, a.display(e));
    }

    /// The symbolic derivative equals the dual-number derivative wherever the
    /// function is smooth, along every variable, the parameter and time.
    #[test]
    fn symbolic_derivative_equals_dual_numbers(t in expr(), x in point()) {
        let mut a = Arena::new();
        let syms = symbols(&mut a);
        let e = build(&mut a, &t, false);
        for (k, &s) in syms.iter().enumerate() {
            let r = reference(&t, &x, Some(k));
            if !(r.smooth && r.v.is_finite() && r.d.is_finite() && r.dm.is_finite()) {
                continue;
            }
            let d = a.diff(e, s);
            let v = a.eval(d, values(&a, &syms, &x));
            let tol = 1e-8 * r.d.abs().max(r.dm) + 1e-300;
            prop_assert!((v - r.d).abs() <= tol,
                "d/d{} of {}: engine {v:e} vs dual {:e} (tol {tol:e}); derivative {}",
                a.symbol(s).name, a.display(e), r.d, a.display(d));
        }
    }

    /// A tape computes exactly what the tree evaluator computes.
    #[test]
    fn tape_equals_tree(t in expr(), x in point()) {
        let mut a = Arena::new();
        let syms = symbols(&mut a);
        let e = build(&mut a, &t, false);
        let mut outputs = vec![e];
        for &s in &syms {
            outputs.push(a.diff(e, s));
        }
        let tree = a.eval_many(&outputs, values(&a, &syms, &x));
        let tape = Tape::compile(&a, &outputs);
        let inputs = TapeInputs { q: &x[..3], qd: &[], params: &x[3..4], t: x[4] };
        // Register files left dirty by earlier evaluations (a `TapeSystem`
        // shares one among its tapes): no register is read before written.
        for dirt in [0.0, 7.0e300, -3.5e-300] {
            let mut regs = vec![dirt; tape.registers() + 2];
            let mut out = vec![dirt; outputs.len()];
            prop_assert!(tape.eval(&inputs, &mut regs, &mut out).is_ok());
            for (k, (tv, ev)) in out.iter().zip(&tree).enumerate() {
                prop_assert!(tv.to_bits() == ev.to_bits() || (tv.is_nan() && ev.is_nan()),
                    "output {k}: tape {tv:e} vs tree {ev:e}");
            }
        }
        // Through the sin/cos cache: primed at another point (misses), then
        // at this one twice (misses, then hits), then with a cache too short
        // for every coordinate: the same bits each time.
        let mut regs = vec![0.0; tape.registers()];
        let mut trig = vec![f64::NAN; 9];
        let mut out = vec![0.0; outputs.len()];
        let q_other = [x[1], x[2], x[0]];
        let other = TapeInputs { q: &q_other, ..inputs };
        prop_assert!(tape.eval_with_cache(&other, &mut regs, &mut trig, &mut out).is_ok());
        for cache in [9, 9, 4] {
            let trig = &mut trig[..cache];
            prop_assert!(tape.eval_with_cache(&inputs, &mut regs, trig, &mut out).is_ok());
            for (k, (tv, ev)) in out.iter().zip(&tree).enumerate() {
                prop_assert!(tv.to_bits() == ev.to_bits() || (tv.is_nan() && ev.is_nan()),
                    "output {k}, cache of {cache}: tape {tv:e} vs tree {ev:e}");
            }
        }
    }

    /// The kink check's error bound (`Tape::kink`, which leaves each
    /// output's bound in `errors` when it finds no kink, as
    /// `Tape::error_bounds` computes it) covers what moving
    /// the coordinates by up to their uncertainty does to the value: the
    /// first-order propagation through every operation is right. Moves
    /// are small (10⁻⁹ relative) so that second-order terms stay below it.
    #[test]
    fn kink_bound_covers_a_move_of_the_coordinates(
        t in expr(),
        x in point(),
        signs in proptest::array::uniform3(prop_oneof![Just(-1.0f64), Just(1.0)]),
    ) {
        let mut a = Arena::new();
        symbols(&mut a);
        let e = build(&mut a, &t, false);
        let tape = Tape::compile(&a, &[e]);
        let inputs = TapeInputs { q: &x[..3], qd: &[], params: &x[3..4], t: x[4] };
        let delta = 1e-9;
        let mut regs = vec![0.0; tape.registers()];
        let mut errors = vec![0.0; tape.registers()];
        let found = tape.kink(&inputs, delta, 1.0, &mut regs, &mut errors, &mut []);
        prop_assert!(found.is_ok());
        let bound = errors[0];
        // `error_bounds` is the same pass without the stop: where no kink
        // stopped it, the same bound (NaN included).
        let mut bounds = vec![0.0; tape.registers()];
        prop_assert!(tape
            .error_bounds(&inputs, delta, 1.0, &mut regs, &mut bounds, &mut [])
            .is_ok());
        if found == Ok(None) {
            prop_assert_eq!(bounds[0].to_bits(), bound.to_bits());
        }
        let mut out = [0.0];
        prop_assert!(tape.eval(&inputs, &mut regs, &mut out).is_ok());
        let value = out[0];
        // Only where the check passed and the bound says something: a
        // relative bound near 1 leaves first order (a pole, a steep tan).
        if found != Ok(None) || !value.is_finite() || !bound.is_finite()
            || bound > 1e-3 * (1.0 + value.abs())
        {
            return Ok(());
        }
        let q: Vec<f64> = x[..3].iter().zip(signs).map(|(v, s)| v + s * delta).collect();
        let moved_inputs = TapeInputs { q: &q, ..inputs };
        let mut moved = [0.0];
        prop_assert!(tape.eval(&moved_inputs, &mut regs, &mut moved).is_ok());
        if !moved[0].is_finite() {
            return Ok(());
        }
        // Each evaluation rounds within the bound (its rounding part), the
        // move within it too (its first-order part): twice, with room for
        // the library's functions' few ulps.
        let change = (moved[0] - value).abs();
        prop_assert!(change <= 2.0 * bound + 8.0 * EPS * value.abs(),
            "{}: moved by {change:e}, bound {bound:e} (value {value:e})", a.display(e));
    }

    /// Building in another order (operands swapped, right operand first, in a
    /// fresh arena whose symbols were created in reverse order) prints the
    /// same text; in the same arena it yields the same id.
    #[test]
    fn construction_order_does_not_matter(t in expr()) {
        let mut a = Arena::new();
        symbols(&mut a);
        let e1 = build(&mut a, &t, false);
        let e2 = build(&mut a, &t, true);
        prop_assert_eq!(e1, e2);

        let mut b = Arena::new();
        b.time();
        b.parameter("p", 0);
        for i in (0..3).rev() {
            b.coordinate(&format!("x{i}"), i);
        }
        let f = build(&mut b, &t, true);
        prop_assert_eq!(a.display(e1).to_string(), b.display(f).to_string());
    }
}
