//! Random expressions for property tests, shared by kinema-expr's and
//! kinema-jit's suites (each includes this file with `#[path]`): a plain
//! tree `T` over coordinates x0..x2, a parameter and time, its proptest
//! strategy [`expr`], and [`build`], which builds it in an [`Arena`].

use kinema_expr::{Arena, ExprId, SymId};
use proptest::prelude::*;

/// A random expression over coordinates x0..x2, parameter p0 and time.
#[derive(Clone, Debug)]
pub enum T {
    X(u32),
    P,
    Time,
    C(f64),
    Add(Box<T>, Box<T>),
    Sub(Box<T>, Box<T>),
    Mul(Box<T>, Box<T>),
    Div(Box<T>, Box<T>),
    Neg(Box<T>),
    PowI(Box<T>, i32),
    PowF(Box<T>, f64),
    Pow(Box<T>, Box<T>),
    Sqrt(Box<T>),
    Un(Fun, Box<T>),
    Atan2(Box<T>, Box<T>),
    Step(Box<T>, f64, f64, f64, f64),
}

#[derive(Clone, Copy, Debug)]
pub enum Fun {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Sinh,
    Cosh,
    Tanh,
    Exp,
    Ln,
    Abs,
}

pub fn leaf() -> impl Strategy<Value = T> {
    prop_oneof![
        4 => (0u32..3).prop_map(T::X),
        1 => Just(T::P),
        1 => Just(T::Time),
        1 => prop_oneof![Just(0.0), Just(1.0), Just(-1.0), Just(2.0), Just(0.5)].prop_map(T::C),
        1 => (-3.0f64..3.0).prop_map(T::C),
    ]
}

pub fn fun() -> impl Strategy<Value = Fun> {
    prop_oneof![
        Just(Fun::Sin),
        Just(Fun::Cos),
        Just(Fun::Tan),
        Just(Fun::Asin),
        Just(Fun::Acos),
        Just(Fun::Atan),
        Just(Fun::Sinh),
        Just(Fun::Cosh),
        Just(Fun::Tanh),
        Just(Fun::Exp),
        Just(Fun::Ln),
        Just(Fun::Abs),
    ]
}

pub fn expr() -> impl Strategy<Value = T> {
    leaf().prop_recursive(6, 48, 2, |inner| {
        let b = |t| Box::new(t);
        prop_oneof![
            4 => (inner.clone(), inner.clone()).prop_map(move |(x, y)| T::Add(b(x), b(y))),
            3 => (inner.clone(), inner.clone()).prop_map(move |(x, y)| T::Sub(b(x), b(y))),
            4 => (inner.clone(), inner.clone()).prop_map(move |(x, y)| T::Mul(b(x), b(y))),
            2 => (inner.clone(), inner.clone()).prop_map(move |(x, y)| T::Div(b(x), b(y))),
            1 => inner.clone().prop_map(move |x| T::Neg(b(x))),
            2 => (inner.clone(), -3i32..=4).prop_map(move |(x, n)| T::PowI(b(x), n)),
            1 => (inner.clone(), prop_oneof![Just(0.5), Just(1.5), Just(-0.5), Just(2.5)])
                .prop_map(move |(x, p)| T::PowF(b(x), p)),
            1 => (inner.clone(), inner.clone()).prop_map(move |(x, y)| T::Pow(b(x), b(y))),
            1 => inner.clone().prop_map(move |x| T::Sqrt(b(x))),
            4 => (fun(), inner.clone()).prop_map(move |(f, x)| T::Un(f, b(x))),
            1 => (inner.clone(), inner.clone()).prop_map(move |(y, x)| T::Atan2(b(y), b(x))),
            1 => (inner, -1.0f64..0.0, -2.0f64..2.0, 0.1f64..1.5, -2.0f64..2.0)
                .prop_map(move |(x, x0, h0, w, h1)| T::Step(b(x), x0, h0, x0 + w, h1)),
        ]
    })
}

/// Builds the tree in the engine. `mirror` swaps the operands of commutative
/// operations and builds the right operand first, to test that construction
/// order does not matter.
pub fn build(a: &mut Arena, t: &T, mirror: bool) -> ExprId {
    let two = |a: &mut Arena, x: &T, y: &T| {
        if mirror {
            let ey = build(a, y, mirror);
            let ex = build(a, x, mirror);
            (ex, ey)
        } else {
            let ex = build(a, x, mirror);
            let ey = build(a, y, mirror);
            (ex, ey)
        }
    };
    match t {
        T::X(i) => a.coordinate(&format!("x{i}"), *i),
        T::P => a.parameter("p", 0),
        T::Time => a.time(),
        T::C(c) => a.num(*c),
        T::Add(x, y) => {
            let (ex, ey) = two(a, x, y);
            if mirror { a.add(ey, ex) } else { a.add(ex, ey) }
        }
        T::Sub(x, y) => {
            let (ex, ey) = two(a, x, y);
            if mirror {
                let n = a.neg(ey);
                a.add(n, ex)
            } else {
                a.sub(ex, ey)
            }
        }
        T::Mul(x, y) => {
            let (ex, ey) = two(a, x, y);
            if mirror { a.mul(ey, ex) } else { a.mul(ex, ey) }
        }
        T::Div(x, y) => {
            let (ex, ey) = two(a, x, y);
            if mirror {
                let r = a.powi(ey, -1);
                a.mul(r, ex)
            } else {
                a.div(ex, ey)
            }
        }
        T::Neg(x) => {
            let e = build(a, x, mirror);
            if mirror { a.scale(-1.0, e) } else { a.neg(e) }
        }
        T::PowI(x, n) => {
            let e = build(a, x, mirror);
            a.powi(e, *n)
        }
        T::PowF(x, p) => {
            let e = build(a, x, mirror);
            a.powf(e, *p)
        }
        T::Pow(x, y) => {
            let (ex, ey) = two(a, x, y);
            a.pow(ex, ey)
        }
        T::Sqrt(x) => {
            let e = build(a, x, mirror);
            a.sqrt(e)
        }
        T::Un(f, x) => {
            let e = build(a, x, mirror);
            match f {
                Fun::Sin => a.sin(e),
                Fun::Cos => a.cos(e),
                Fun::Tan => a.tan(e),
                Fun::Asin => a.asin(e),
                Fun::Acos => a.acos(e),
                Fun::Atan => a.atan(e),
                Fun::Sinh => a.sinh(e),
                Fun::Cosh => a.cosh(e),
                Fun::Tanh => a.tanh(e),
                Fun::Exp => a.exp(e),
                Fun::Ln => a.ln(e),
                Fun::Abs => a.abs(e),
            }
        }
        T::Atan2(y, x) => {
            let (ey, ex) = two(a, y, x);
            a.atan2(ey, ex)
        }
        T::Step(x, x0, h0, x1, h1) => {
            let e = build(a, x, mirror);
            let (x0, h0, x1, h1) = (a.num(*x0), a.num(*h0), a.num(*x1), a.num(*h1));
            a.step(e, x0, h0, x1, h1)
        }
    }
}

/// The engine's symbols in seed order: x0, x1, x2, p, t.
pub fn symbols(a: &mut Arena) -> Vec<SymId> {
    let mut out = Vec::new();
    for i in 0..3 {
        let e = a.coordinate(&format!("x{i}"), i);
        out.extend(a.symbol_of(e));
    }
    let p = a.parameter("p", 0);
    out.extend(a.symbol_of(p));
    let t = a.time();
    out.extend(a.symbol_of(t));
    out
}
