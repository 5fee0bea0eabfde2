//! The vocabulary of the arena: ids, symbols and node kinds.

kinema_index::entity! {
    /// Identifier of an expression node in an [`Arena`](crate::Arena).
    ///
    /// Ids are small and `Copy`. Because the arena hash-conses its nodes, two ids
    /// are equal exactly when the expressions they denote are structurally equal
    /// (after canonicalization), so `==` on ids is expression equality in O(1).
    /// The numeric order of ids is construction order; it never influences output.
    pub struct ExprId(pub(crate) u32); "e"
}

kinema_index::entity! {
    /// Identifier of a symbol (a leaf that is not a number) in an [`Arena`](crate::Arena).
    pub struct SymId(pub(crate) u32); "s"
}

/// What a symbol stands for. The index is the symbol's slot in the input
/// vector it is read from at evaluation time (see [`TapeInputs`](crate::TapeInputs)).
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Debug)]
pub enum SymKind {
    /// A value known only at run time and never folded, read from `params[i]`.
    Parameter(u32),
    /// Generalized coordinate `q[i]`.
    Coordinate(u32),
    /// Time derivative of a generalized coordinate, `q̇[i]`.
    Velocity(u32),
    /// Time `t`.
    Time,
}

impl SymKind {
    /// Rank used to order symbols of different kinds in printed output.
    pub(crate) fn rank(self) -> (u8, u32) {
        match self {
            SymKind::Parameter(i) => (0, i),
            SymKind::Coordinate(i) => (1, i),
            SymKind::Velocity(i) => (2, i),
            SymKind::Time => (3, 0),
        }
    }
}

/// A named leaf.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Symbol {
    /// Display name, e.g. `crank.phi`.
    pub name: String,
    /// What the symbol stands for.
    pub kind: SymKind,
}

/// Functions of one argument.
///
/// `Smooth(k)` is the k-th derivative of the unit cubic step
/// `S(u) = 0 (u ≤ 0), u²(3 − 2u) (0 < u < 1), 1 (u ≥ 1)`, for k = 0..=3;
/// the multibody `step(x, x0, h0, x1, h1)` is built from `Smooth(0)`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub enum UnaryOp {
    /// sin
    Sin,
    /// cos
    Cos,
    /// tan
    Tan,
    /// arcsine
    Asin,
    /// arccosine
    Acos,
    /// arctangent
    Atan,
    /// hyperbolic sine
    Sinh,
    /// hyperbolic cosine
    Cosh,
    /// hyperbolic tangent
    Tanh,
    /// e^x
    Exp,
    /// natural logarithm
    Ln,
    /// absolute value
    Abs,
    /// k-th derivative of the unit cubic step (k ≤ 3)
    Smooth(u8),
}

impl UnaryOp {
    /// The function applied to a number.
    #[must_use]
    pub fn apply(self, x: f64) -> f64 {
        match self {
            UnaryOp::Sin => x.sin(),
            UnaryOp::Cos => x.cos(),
            UnaryOp::Tan => x.tan(),
            UnaryOp::Asin => x.asin(),
            UnaryOp::Acos => x.acos(),
            UnaryOp::Atan => x.atan(),
            UnaryOp::Sinh => x.sinh(),
            UnaryOp::Cosh => x.cosh(),
            UnaryOp::Tanh => x.tanh(),
            UnaryOp::Exp => x.exp(),
            UnaryOp::Ln => x.ln(),
            UnaryOp::Abs => x.abs(),
            UnaryOp::Smooth(k) => smooth(k, x),
        }
    }

    /// Name as printed (and as written in the model language).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            UnaryOp::Sin => "sin",
            UnaryOp::Cos => "cos",
            UnaryOp::Tan => "tan",
            UnaryOp::Asin => "asin",
            UnaryOp::Acos => "acos",
            UnaryOp::Atan => "atan",
            UnaryOp::Sinh => "sinh",
            UnaryOp::Cosh => "cosh",
            UnaryOp::Tanh => "tanh",
            UnaryOp::Exp => "exp",
            UnaryOp::Ln => "ln",
            UnaryOp::Abs => "abs",
            UnaryOp::Smooth(0) => "smoothstep",
            UnaryOp::Smooth(1) => "smoothstep_d1",
            UnaryOp::Smooth(2) => "smoothstep_d2",
            UnaryOp::Smooth(_) => "smoothstep_d3",
        }
    }

    /// The `f64` method generated code calls (`x.sin()`): the name; `None`
    /// for `Smooth(k)`, which is emitted inline.
    #[must_use]
    pub fn rust_method(self) -> Option<&'static str> {
        match self {
            UnaryOp::Smooth(_) => None,
            op => Some(op.name()),
        }
    }

    pub(crate) fn tag(self) -> u64 {
        match self {
            UnaryOp::Sin => 1,
            UnaryOp::Cos => 2,
            UnaryOp::Tan => 3,
            UnaryOp::Asin => 4,
            UnaryOp::Acos => 5,
            UnaryOp::Atan => 6,
            UnaryOp::Sinh => 7,
            UnaryOp::Cosh => 8,
            UnaryOp::Tanh => 9,
            UnaryOp::Exp => 10,
            UnaryOp::Ln => 11,
            UnaryOp::Abs => 12,
            UnaryOp::Smooth(k) => 16 + u64::from(k),
        }
    }
}

/// The k-th derivative of the unit cubic step `S(u) = u²(3 − 2u)` on (0, 1),
/// constant outside. Derivatives are taken as 0 at and beyond the ends.
#[must_use]
pub fn smooth(k: u8, u: f64) -> f64 {
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

/// One term `coeff · expr` of a sum.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct Term {
    /// Numeric coefficient, never 0.
    pub coeff: f64,
    /// The term; never a number, a sum, or a product with a coefficient ≠ 1.
    pub expr: ExprId,
}

/// One factor `base ^ exp` of a product.
#[derive(Clone, Copy, PartialEq, Debug)]
pub struct Factor {
    /// The base; never a product with an integer exponent (it would be flattened).
    pub base: ExprId,
    /// Constant real exponent, never 0.
    pub exp: f64,
}

/// Internal node storage. Sums and products point into the arena's pools.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Node {
    Num(f64),
    Sym(SymId),
    Add { constant: f64, start: u32, len: u32 },
    Mul { coeff: f64, start: u32, len: u32 },
    Unary(UnaryOp, ExprId),
    Pow(ExprId, ExprId),
    Atan2(ExprId, ExprId),
}

impl Node {
    /// Rank of the node kind in the canonical operand order.
    pub(crate) fn rank(&self) -> u8 {
        match self {
            Node::Num(_) => 0,
            Node::Sym(_) => 1,
            Node::Unary(..) => 2,
            Node::Pow(..) => 3,
            Node::Atan2(..) => 4,
            Node::Mul { .. } => 5,
            Node::Add { .. } => 6,
        }
    }
}

/// A read-only view of one node, for printers, code generators and analyses.
#[derive(Clone, Copy, Debug)]
pub enum NodeRef<'a> {
    /// A finite number.
    Num(f64),
    /// A symbol.
    Sym(SymId),
    /// `constant + Σ coeff·expr`, terms in canonical order.
    Add {
        /// The numeric part (may be 0).
        constant: f64,
        /// At least one term; at least two when `constant` is 0.
        terms: &'a [Term],
    },
    /// `coeff · Π base^exp`, factors in canonical order.
    Mul {
        /// Numeric coefficient, never 0.
        coeff: f64,
        /// At least one factor.
        factors: &'a [Factor],
    },
    /// A function of one argument.
    Unary(UnaryOp, ExprId),
    /// `base ^ exponent` with a non-constant exponent.
    Pow(ExprId, ExprId),
    /// `atan2(y, x)`.
    Atan2(ExprId, ExprId),
}
