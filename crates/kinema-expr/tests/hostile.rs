//! Hostile input for the engine: long products must differentiate in linear
//! size, the budget must stop a derivation, and no simplification may make an
//! undefined constant look defined.

use kinema_expr::{Arena, ExprId, SymId, SymKind};

/// A product of `n` coordinates, its Jacobian, its directional derivative
/// along the velocities and the directional derivative of that (what γ
/// needs). Returns the arena, the pieces and the arena size they needed.
struct Product {
    a: Arena,
    q: Vec<SymId>,
    p: ExprId,
    jac: Vec<(u32, ExprId)>,
    first: ExprId,
    second: ExprId,
    added: usize,
}

fn product(n: u32) -> Product {
    let mut a = Arena::new();
    let xs: Vec<ExprId> = (0..n).map(|i| a.coordinate(&format!("x{i}"), i)).collect();
    let q: Vec<SymId> = xs.iter().filter_map(|&x| a.symbol_of(x)).collect();
    let pairs: Vec<(SymId, ExprId)> = (0..n)
        .map(|i| {
            let v = a.velocity(&format!("v{i}"), i);
            (q[i as usize], v)
        })
        .collect();
    let p = a.product(&xs);
    let before = a.size();
    let seeds = a.seeds(&pairs);
    let jac = a.jacobian(&[p], &q);
    let first = a.directional(p, seeds);
    let second = a.directional(first, seeds);
    let added = a.size() - before;
    let jac = jac.entries.iter().map(|e| (e.col, e.expr)).collect();
    Product {
        a,
        q,
        p,
        jac,
        first,
        second,
        added,
    }
}

/// Values of x and v at a point where no coordinate is zero.
fn point(n: usize) -> (Vec<f64>, Vec<f64>) {
    let x = (0..n)
        .map(|i| 1.0 + 0.001 * ((i * 7) % 13) as f64)
        .collect();
    let v = (0..n).map(|i| 0.5 - 0.1 * ((i * 5) % 11) as f64).collect();
    (x, v)
}

fn eval(a: &Arena, e: ExprId, x: &[f64], v: &[f64]) -> f64 {
    a.eval(e, |s| match a.symbol(s).kind {
        SymKind::Coordinate(i) => x[i as usize],
        SymKind::Velocity(i) => v[i as usize],
        _ => f64::NAN,
    })
}

#[test]
fn derivatives_of_a_long_product_grow_linearly() {
    let small = product(200);
    let large = product(800);
    // Four times the factors: about four times the entries, never sixteen.
    let ratio = large.added as f64 / small.added as f64;
    assert!(
        ratio < 5.0,
        "200 factors: {} entries, 800 factors: {} entries",
        small.added,
        large.added
    );
    assert!(
        large.added < 400 * 800,
        "800 factors needed {} entries",
        large.added
    );
}

#[test]
fn derivatives_of_a_long_product_have_the_closed_form_values() {
    let n = 120;
    let Product {
        a,
        q,
        p,
        jac,
        first,
        second,
        ..
    } = product(n);
    let (x, v) = point(n as usize);
    let pv = eval(&a, p, &x, &v);
    let rel = |got: f64, want: f64| (got - want).abs() <= 1e-12 * want.abs().max(1.0);
    // ∂P/∂x_i = P / x_i (no coordinate is zero here).
    assert_eq!(jac.len(), q.len());
    for &(col, e) in &jac {
        let i = col as usize;
        let got = eval(&a, e, &x, &v);
        assert!(rel(got, pv / x[i]), "column {i}: {got} vs {}", pv / x[i]);
    }
    // Ṗ = Σ P v_i / x_i; P̈ along v = Σ_{i≠j} P v_i v_j / (x_i x_j).
    let s1: f64 = (0..x.len()).map(|i| v[i] / x[i]).sum();
    let s2: f64 = (0..x.len()).map(|i| (v[i] / x[i]).powi(2)).sum();
    let got1 = eval(&a, first, &x, &v);
    assert!(rel(got1, pv * s1), "{got1} vs {}", pv * s1);
    let got2 = eval(&a, second, &x, &v);
    let want2 = pv * (s1 * s1 - s2);
    assert!(
        (got2 - want2).abs() <= 1e-9 * want2.abs().max(1.0),
        "{got2} vs {want2}"
    );
    // Exactly zero factors: the cofactors never divide by a factor.
    let mut x0 = x.clone();
    x0[3] = 0.0;
    let (col, e) = jac[3];
    assert_eq!(col, 3);
    let want: f64 = x0
        .iter()
        .enumerate()
        .filter(|&(j, _)| j != 3)
        .map(|(_, v)| v)
        .product();
    assert!(rel(eval(&a, e, &x0, &v), want));
    assert_eq!(eval(&a, jac[4].1, &x0, &v), 0.0);
}

#[test]
fn the_budget_stops_a_derivation() {
    let mut a = Arena::new();
    let xs: Vec<ExprId> = (0..400)
        .map(|i| a.coordinate(&format!("x{i}"), i))
        .collect();
    let q: Vec<SymId> = xs.iter().filter_map(|&x| a.symbol_of(x)).collect();
    let p = a.product(&xs);
    assert!(!a.budget_exceeded());
    a.set_budget(Some(a.size() + 1_000));
    let pairs: Vec<(SymId, ExprId)> = q.iter().map(|&s| (s, a.one())).collect();
    let seeds = a.seeds(&pairs);
    let d = a.directional(p, seeds);
    let d2 = a.directional(d, seeds);
    assert!(a.budget_exceeded());
    assert!(a.is_zero(d2));
    // Without a budget the same derivation completes.
    let mut b = Arena::new();
    let xs: Vec<ExprId> = (0..400)
        .map(|i| b.coordinate(&format!("x{i}"), i))
        .collect();
    let p = b.product(&xs);
    let s = b.symbol_of(xs[0]).unwrap_or_else(|| unreachable!());
    let d = b.diff(p, s);
    assert!(!b.budget_exceeded());
    assert!(!b.is_zero(d));
}

#[test]
fn undefined_constants_never_vanish() {
    let mut a = Arena::new();
    let t = a.time();
    let x = a.coordinate("x", 0);
    let zero = a.zero();
    let one = a.one();
    // 0/0, x/0 and 1e308·1e308 are undefined; so is what contains them.
    let zz = a.div(zero, zero);
    let x0 = a.div(x, zero);
    let big = a.num(1e308);
    let inf = a.mul(big, big);
    let ln0 = a.ln(zero);
    for u in [zz, x0, inf, ln0] {
        assert!(a.is_undefined(u), "{}", a.display(u));
        // 0·u, u − u, u/u, u^0 and 0·u + t keep the undefined part.
        let zu = a.mul(zero, u);
        let uu = a.sub(u, u);
        let q = a.div(u, u);
        let p0 = a.powi(u, 0);
        let s0 = a.scale(0.0, u);
        let zu_t = a.mul(zu, t);
        let sum = a.add(zu_t, t);
        for e in [zu, uu, q, p0, s0, sum] {
            assert!(a.is_undefined(e), "{} from {}", a.display(e), a.display(u));
            let v = a.eval(e, |_| 0.5);
            assert!(!v.is_finite(), "{} evaluates to {v}", a.display(e));
        }
    }
    // Folds stay finite or are not made: atan(∞) is not π/2.
    let at = a.atan(inf);
    assert!(a.is_undefined(at));
    // Defined expressions simplify as before.
    let xx = a.sub(x, x);
    assert!(a.is_zero(xx) && !a.is_undefined(xx));
    let zx = a.mul(zero, x);
    assert!(a.is_zero(zx));
    let xq = a.div(x, x);
    assert_eq!(xq, one);
    let two = a.num(2.0);
    let h = a.div(one, two);
    assert_eq!(a.as_num(h), Some(0.5));
    assert!(!a.is_undefined(h));
}

#[test]
fn tree_sizes_count_shared_nodes_at_each_use() {
    let mut a = Arena::new();
    let x = a.coordinate("x", 0);
    let s = a.sin(x);
    // e_k = sin(e_{k−1} + e_{k−1}·x) doubles its tree each step.
    let mut e = s;
    for _ in 0..40 {
        let m = a.mul(e, x);
        let p = a.add(e, m);
        e = a.sin(p);
    }
    let sizes = a.tree_sizes();
    assert!(sizes[e.index()] > 1 << 40);
    assert!(a.dag_size(&[e]) < 200);
    assert_eq!(sizes[x.index()], 1);
    assert_eq!(sizes[s.index()], 2);
}

/// A power of a scaled expression is not distributed when the scale's power
/// leaves f64's range: (x / ln 10)^1000 flattened would fold 0.434^1000 to 0
/// and the term would vanish (fuzz, `fun`: `(log10(t)^1000)*t` ran as 0);
/// (1e200·x)^2 would overflow to a refused constant. All keep their values;
/// derivatives are checked against finite differences where their
/// coefficients are representable (that of (1e200·x)^2, 2e400, is not: it is
/// refused as undefined, never a wrong number).
#[test]
fn powers_of_scaled_terms_keep_their_values() {
    for (scale, n, x0) in [
        (
            1.0 / std::f64::consts::LN_10,
            1000,
            -std::f64::consts::LN_10,
        ),
        (1e200, 2, 3e-200),
        (1e-200, -2, 5e199),
    ] {
        let mut a = Arena::new();
        let x = a.coordinate("x", 0);
        let c = a.num(scale);
        let cx = a.mul(c, x);
        let p = a.powi(cx, n);
        assert!(!a.is_undefined(p), "{}", a.display(p));
        assert!(!a.is_zero(p), "{}", a.display(p));
        let want = (scale * x0).powi(n);
        let got = eval(&a, p, &[x0], &[0.0]);
        assert!(
            (got - want).abs() <= 1e-12 * want.abs(),
            "{}: {got} vs {want}",
            a.display(p)
        );
        let s = a.symbol_of(x).unwrap_or_else(|| unreachable!());
        let d = a.diff(p, s);
        if a.is_undefined(d) {
            assert_eq!(scale, 1e200, "{}", a.display(d));
            continue;
        }
        let h = 1e-6 * x0.abs();
        let fd = (eval(&a, p, &[x0 + h], &[0.0]) - eval(&a, p, &[x0 - h], &[0.0])) / (2.0 * h);
        let dv = eval(&a, d, &[x0], &[0.0]);
        assert!(
            (dv - fd).abs() <= 1e-5 * fd.abs().max(1e-300),
            "{}: {dv} vs {fd}",
            a.display(d)
        );
    }
}

/// An expression with an undefined part has one canonical form whatever the
/// order it was built in (the property test `construction_order_does_not_matter`
/// found x0 / (√(step(0; 0, −0.41, 0.1, 0)) · 0⁻¹) folding to `NaN` one way
/// and to `NaN*x0` the other), and its derivatives are undefined too.
#[test]
fn undefined_expressions_have_one_form_whatever_the_order() {
    let mut a = Arena::new();
    let x = a.coordinate("x0", 0);
    let zero = a.zero();
    let minus = a.num(-0.41);
    let root = a.sqrt(minus);
    let inv0 = a.powi(zero, -1);
    assert!(a.is_undefined(root) && a.is_undefined(inv0));
    let left = a.mul(root, inv0);
    let right = a.mul(inv0, root);
    let e1 = a.div(x, left);
    let e2 = a.div(x, right);
    let p1 = a.product(&[x, root, inv0]);
    let p2 = a.product(&[inv0, x, root]);
    let s1 = a.add(x, root);
    let s2 = a.add(root, x);
    let nan = a.num(f64::NAN);
    for e in [left, right, e1, e2, p1, p2, s1, s2] {
        assert_eq!(e, nan, "{}", a.display(e));
    }
    let sx = a.symbol_of(x).unwrap_or_else(|| unreachable!());
    // ∂(x·√−0.41)/∂x is undefined, not 0.
    let d = a.diff(p1, sx);
    assert!(a.is_undefined(d), "{}", a.display(d));
    // Every non-finite number is the one NaN: ∞ built by overflow, −∞, −NaN.
    let big = a.num(1e308);
    let inf = a.mul(big, big);
    for v in [f64::INFINITY, f64::NEG_INFINITY, -f64::NAN] {
        assert_eq!(a.num(v), nan);
    }
    assert_eq!(inf, nan);
}

/// A term whose coefficient would underflow keeps its coefficient, and with
/// it its pole: `x − 1e-300/t · 1e-300` is undefined at t = 0 (fuzz finding
/// F18: the sum folded the product's 1e-300 into the term's, the
/// coefficient flushed to 0 and the term, 1/t and all, vanished, so a
/// driver ran through its pole). Where the coefficients stay in range,
/// scaled products and sums fold as before.
#[test]
fn underflowing_coefficients_keep_their_terms() {
    let mut a = Arena::new();
    let t = a.time();
    let x = a.coordinate("x", 0);
    let tiny = a.num(1e-300);
    let over_t = a.div(tiny, t);
    let product = a.mul(over_t, tiny);
    let scaled_t = a.mul(tiny, t);
    let inner = a.add(scaled_t, over_t);
    let scaled_sum = a.mul(inner, tiny);
    let at = |a: &Arena, e: ExprId, time: f64| {
        a.eval(e, |s| match a.symbol(s).kind {
            SymKind::Time => time,
            _ => 0.5,
        })
    };
    for term in [product, scaled_sum] {
        for e in [a.sub(x, term), a.scale(-2.0, term), a.add(term, t)] {
            assert!(!at(&a, e, 0.0).is_finite(), "{}", a.display(e));
            assert!(at(&a, e, 1.0).is_finite(), "{}", a.display(e));
        }
    }
    // x − (1e-300/t)·1e-300 at t = 1 is x (the term is below f64's range).
    let e = a.sub(x, product);
    assert_eq!(at(&a, e, 1.0), 0.5);
    // In range, the coefficients fold: 2·(3·x) is 6·x, and 2·(x + 3·t)
    // scaled is 2·x + 6·t.
    let (two, three) = (a.num(2.0), a.num(3.0));
    let three_x = a.mul(three, x);
    let six_x = a.scale(6.0, x);
    assert_eq!(a.mul(two, three_x), six_x);
    let three_t = a.mul(three, t);
    let sum = a.add(x, three_t);
    let doubled = a.scale(2.0, sum);
    let two_x = a.scale(2.0, x);
    let six_t = a.scale(6.0, t);
    assert_eq!(doubled, a.add(two_x, six_t));
}

/// A product's numbers fold as a set (finding F14): the product of
/// 1e300, 1e300, 1e-300 and x is 1e300·x in every order, with 1e300·x
/// built first too, and 1/(5e-324·1e308·x) is 2.02e15/x, though a fold
/// one number at a time overflows on the way (1e300·1e300, 1/5e-324). A
/// product whose numbers leave f64's range as a whole is undefined still,
/// as is a constant that does on its own (1e300·1e300).
#[test]
fn numbers_fold_as_a_set() {
    let mut a = Arena::new();
    let x = a.coordinate("x", 0);
    let (big, small) = (a.num(1e300), a.num(1e-300));
    let big_x = a.mul(big, x);
    let mut forms = Vec::new();
    for factors in [
        [big, big, small, x],
        [big, small, big, x],
        [x, small, big, big],
    ] {
        forms.push(a.product(&factors));
    }
    forms.push(a.product(&[big, big_x, small]));
    forms.push(a.product(&[small, big, big_x]));
    for &e in &forms {
        assert!(!a.is_undefined(e), "{}", a.display(e));
        let v = eval(&a, e, &[2.0], &[0.0]);
        assert!((v - 2e300).abs() <= 1e-15 * 2e300, "{}: {v}", a.display(e));
    }
    let tiny = a.num(5e-324);
    let huge = a.num(1e308);
    let d = a.product(&[tiny, huge, x]);
    let one = a.one();
    let q = a.div(one, d);
    assert!(!a.is_undefined(q), "{}", a.display(q));
    let want = 1.0 / (5e-324 * 1e308 * 2.0);
    let v = eval(&a, q, &[2.0], &[0.0]);
    assert!(
        (v - want).abs() <= 1e-15 * want,
        "{}: {v} vs {want}",
        a.display(q)
    );
    // Beyond the range as a whole, or on its own: undefined, as before.
    let over = a.product(&[big, big, x]);
    assert!(a.is_undefined(over), "{}", a.display(over));
    let constant = a.mul(big, big);
    assert!(a.is_undefined(constant), "{}", a.display(constant));
}
