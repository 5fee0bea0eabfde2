//! The functions compiled code calls: Rust's own, so results are the
//! interpreter's bit for bit.

use kinema_expr::UnaryOp;

/// Sine and cosine of a coordinate, written where the sin/cos cache keeps
/// them (`out` points into the cache, as the compiled code passes it); the
/// same two calls as the interpreter's cache makes.
extern "C" fn sin_cos(x: f64, out: &mut [f64; 2]) {
    out[0] = x.sin();
    out[1] = x.cos();
}

extern "C" fn powi(x: f64, n: i32) -> f64 {
    x.powi(n)
}

extern "C" fn powf(x: f64, p: f64) -> f64 {
    x.powf(p)
}

extern "C" fn atan2(y: f64, x: f64) -> f64 {
    y.atan2(x)
}

/// The unary functions by code (the index in this table); a code beyond it
/// gives NaN.
const UNARY: [UnaryOp; 16] = [
    UnaryOp::Sin,
    UnaryOp::Cos,
    UnaryOp::Tan,
    UnaryOp::Asin,
    UnaryOp::Acos,
    UnaryOp::Atan,
    UnaryOp::Sinh,
    UnaryOp::Cosh,
    UnaryOp::Tanh,
    UnaryOp::Exp,
    UnaryOp::Ln,
    UnaryOp::Abs,
    UnaryOp::Smooth(0),
    UnaryOp::Smooth(1),
    UnaryOp::Smooth(2),
    UnaryOp::Smooth(3),
];

/// The code of `op` for [`unary`], if it has one.
pub(crate) fn unary_code(op: UnaryOp) -> Option<i32> {
    UNARY
        .iter()
        .position(|u| *u == op)
        .and_then(|i| i32::try_from(i).ok())
}

extern "C" fn unary(code: i32, x: f64) -> f64 {
    usize::try_from(code)
        .ok()
        .and_then(|i| UNARY.get(i))
        .map_or(f64::NAN, |op| op.apply(x))
}

/// A shim's signature.
#[derive(Clone, Copy)]
pub(crate) enum Shape {
    /// `(f64, i32) → f64`
    FI,
    /// `(f64, f64) → f64`
    FF,
    /// `(i32, f64) → f64`
    IF,
    /// `(f64, pointer) → ()`
    FP,
}

/// One shim: its symbol, address and signature.
pub(crate) struct Shim {
    pub(crate) name: &'static str,
    pub(crate) address: *const u8,
    pub(crate) shape: Shape,
}

/// Which shim.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub(crate) enum Which {
    PowI = 0,
    PowF = 1,
    Atan2 = 2,
    Unary = 3,
    SinCos = 4,
}

/// All shims, indexed by [`Which`].
pub(crate) fn all() -> [Shim; 5] {
    [
        Shim {
            name: "kinema_jit_powi",
            address: powi as *const u8,
            shape: Shape::FI,
        },
        Shim {
            name: "kinema_jit_powf",
            address: powf as *const u8,
            shape: Shape::FF,
        },
        Shim {
            name: "kinema_jit_atan2",
            address: atan2 as *const u8,
            shape: Shape::FF,
        },
        Shim {
            name: "kinema_jit_unary",
            address: unary as *const u8,
            shape: Shape::IF,
        },
        Shim {
            name: "kinema_jit_sin_cos",
            address: sin_cos as *const u8,
            shape: Shape::FP,
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_unary_function_has_a_code() {
        for f in kinema_expr::FUNCTIONS {
            if let kinema_expr::FunctionKind::Unary(op) = f.kind {
                let code = unary_code(op).expect("a code");
                assert_eq!(unary(code, 0.3).to_bits(), op.apply(0.3).to_bits());
            }
        }
        assert!(unary(99, 1.0).is_nan());
    }
}
