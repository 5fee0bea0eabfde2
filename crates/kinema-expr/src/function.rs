//! The vocabulary of functions, once: every function a model may call, with
//! its name, signature and arity ([`FUNCTIONS`]), and for the scalar
//! functions of one scalar ([`UnaryOp`]) the value and the name of the Rust
//! method generated code calls ([`UnaryOp::apply`], [`UnaryOp::rust_method`]).
//! Their derivative rules are `calculus.rs`'s, one arm per [`UnaryOp`].
//!
//! The model checker (names, arities, signatures in messages), the code
//! generator (method names), the simEngine2D reader (its `fun` functions
//! map onto these) and the fuzzer (its generators) all read this table.

use crate::node::UnaryOp;

/// What a function of the model language is in the engine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FunctionKind {
    /// A scalar function of one scalar, a node of its own (`sin(x)`, …).
    Unary(UnaryOp),
    /// `sqrt(x)`, the power x^(1/2).
    Sqrt,
    /// `atan2(y, x)`.
    Atan2,
    /// `pow(x, y)`, x^y.
    Pow,
    /// `powi(x, n)`, x^n for an integer literal n.
    Powi,
    /// `step(x, x0, h0, x1, h1)`: h0 before x0, h1 after x1, the cubic step
    /// ([`crate::smooth`]) between.
    Step,
    /// `dot(a, b)` of two vectors.
    Dot,
    /// `cross(a, b)`, the scalar cross product of two vectors.
    Cross,
    /// `norm(a)` of a vector.
    Norm,
    /// `rot(angle, v)`: v rotated by the angle.
    Rot,
    /// `perp(v)`: v rotated by a quarter turn.
    Perp,
}

/// One function of the model language.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Function {
    /// Its name as written in a model (`sin`).
    pub name: &'static str,
    /// How it is called, for messages (`atan2(y, x)`).
    pub signature: &'static str,
    /// Its number of arguments.
    pub arity: usize,
    /// What it is in the engine.
    pub kind: FunctionKind,
}

const fn unary(name: &'static str, signature: &'static str, op: UnaryOp) -> Function {
    Function {
        name,
        signature,
        arity: 1,
        kind: FunctionKind::Unary(op),
    }
}

const fn other(
    name: &'static str,
    signature: &'static str,
    arity: usize,
    kind: FunctionKind,
) -> Function {
    Function {
        name,
        signature,
        arity,
        kind,
    }
}

/// Every function of the model language, in the order messages list them.
pub const FUNCTIONS: &[Function] = &[
    unary("sin", "sin(x)", UnaryOp::Sin),
    unary("cos", "cos(x)", UnaryOp::Cos),
    unary("tan", "tan(x)", UnaryOp::Tan),
    unary("asin", "asin(x)", UnaryOp::Asin),
    unary("acos", "acos(x)", UnaryOp::Acos),
    unary("atan", "atan(x)", UnaryOp::Atan),
    unary("sinh", "sinh(x)", UnaryOp::Sinh),
    unary("cosh", "cosh(x)", UnaryOp::Cosh),
    unary("tanh", "tanh(x)", UnaryOp::Tanh),
    unary("exp", "exp(x)", UnaryOp::Exp),
    unary("ln", "ln(x)", UnaryOp::Ln),
    other("sqrt", "sqrt(x)", 1, FunctionKind::Sqrt),
    unary("abs", "abs(x)", UnaryOp::Abs),
    other("atan2", "atan2(y, x)", 2, FunctionKind::Atan2),
    other("pow", "pow(x, y)", 2, FunctionKind::Pow),
    other("powi", "powi(x, n)", 2, FunctionKind::Powi),
    other("step", "step(x, x0, h0, x1, h1)", 5, FunctionKind::Step),
    other("dot", "dot(a, b)", 2, FunctionKind::Dot),
    other("cross", "cross(a, b)", 2, FunctionKind::Cross),
    other("norm", "norm(a)", 1, FunctionKind::Norm),
    other("rot", "rot(angle, v)", 2, FunctionKind::Rot),
    other("perp", "perp(v)", 1, FunctionKind::Perp),
];

/// The function of the model language named `name`.
#[must_use]
pub fn function(name: &str) -> Option<&'static Function> {
    FUNCTIONS.iter().find(|f| f.name == name)
}

/// A scalar function of one scalar, as written in a model (`sin`, …,
/// `abs`); `None` for the others (and for the engine's internal
/// `Smooth(k)`).
#[must_use]
pub fn unary_function(name: &str) -> Option<UnaryOp> {
    match function(name)?.kind {
        FunctionKind::Unary(op) => Some(op),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_unary_names_round_trip() {
        for (i, f) in FUNCTIONS.iter().enumerate() {
            assert!(
                FUNCTIONS[..i].iter().all(|g| g.name != f.name),
                "{}",
                f.name
            );
            assert!(f.signature.starts_with(&format!("{}(", f.name)));
            let commas = f.signature.matches(',').count();
            assert_eq!(commas + 1, f.arity, "{}", f.signature);
            if let FunctionKind::Unary(op) = f.kind {
                assert_eq!(op.name(), f.name);
                assert_eq!(op.rust_method(), Some(f.name));
                assert_eq!(unary_function(f.name), Some(op));
            }
        }
    }

    #[test]
    fn unary_values_are_the_std_functions() {
        let x: f64 = 0.37;
        let cases = [
            ("sin", x.sin()),
            ("cos", x.cos()),
            ("tan", x.tan()),
            ("asin", x.asin()),
            ("acos", x.acos()),
            ("atan", x.atan()),
            ("sinh", x.sinh()),
            ("cosh", x.cosh()),
            ("tanh", x.tanh()),
            ("exp", x.exp()),
            ("ln", x.ln()),
            ("abs", x),
        ];
        for (name, want) in cases {
            let op = unary_function(name).unwrap_or_else(|| panic!("{name}"));
            assert_eq!(op.apply(x).to_bits(), want.to_bits(), "{name}");
        }
        assert_eq!(unary_function("sqrt"), None, "sqrt is a power");
    }
}
