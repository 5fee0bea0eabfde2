//! The validated model: what the checker produces and the derivation reads.

use kinema_expr::UnaryOp;

use crate::diagnostic::Diagnostics;
use crate::span::Span;
use crate::syntax::EquationKeyword;

use super::library::LibKind;

/// A body, or the fixed ground.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BodyRef {
    /// The fixed body: its points are global points.
    Ground,
    /// The body with this index (declaration order, 0-based).
    Body(u32),
}

/// A coordinate of a body.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Comp {
    /// `B.x`
    X,
    /// `B.y`
    Y,
    /// `B.phi`
    Phi,
    /// A coordinate of its own (a `coord` item): in `TNode::Coord(k, _)`,
    /// `k` is then its index among the `coord` items, not a body (see
    /// [`crate::Coordinate::body`]).
    Extra,
}

/// The type of an expression.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Ty {
    /// A number.
    Scalar,
    /// A planar vector.
    Vector,
}

/// A node of a typed, resolved expression. Children precede parents.
#[derive(Clone, Debug)]
pub(crate) enum TNode {
    Num(f64),
    Pi,
    Time,
    Param(u32),
    Coord(u32, Comp),
    /// The velocity of a coordinate (`B.x_dot`): in forces only.
    Vel(u32, Comp),
    /// Global position of the body-fixed point whose local coordinates are
    /// the vector node.
    Point(BodyRef, u32),
    /// Global position of a declared point.
    NamedPoint(u32),
    Vec(u32, u32),
    X(u32),
    Y(u32),
    Neg(u32),
    Add(u32, u32),
    Sub(u32, u32),
    Mul(u32, u32),
    Div(u32, u32),
    /// A scalar function of one scalar (`sin(x)`, …).
    F1(UnaryOp, u32),
    /// `sqrt(x)`.
    Sqrt(u32),
    Atan2(u32, u32),
    Pow(u32, u32),
    Powi(u32, i32),
    Step([u32; 5]),
    Dot(u32, u32),
    Cross(u32, u32),
    Norm(u32),
    Rot(u32, u32),
    Perp(u32),
    /// The parameter of the curve being defined (in a curve's expression
    /// only; a follower substitutes a coordinate for it).
    CurveArg,
}

/// A typed expression: flat, children first, root last.
#[derive(Clone, Debug)]
pub(crate) struct TExpr {
    pub(crate) nodes: Vec<TNode>,
    pub(crate) types: Vec<Ty>,
    /// Source span of each node, where known: `spans[i]` is node i's for
    /// every i below `spans.len()` (nodes the checker adds itself have none).
    pub(crate) spans: Vec<Span>,
}

impl TExpr {
    pub(crate) fn root(&self) -> u32 {
        crate::idx(self.nodes.len().saturating_sub(1))
    }
    pub(crate) fn ty(&self) -> Ty {
        self.types.last().copied().unwrap_or(Ty::Scalar)
    }
    pub(super) fn push(&mut self, node: TNode, ty: Ty) -> u32 {
        let id = crate::idx(self.nodes.len());
        self.nodes.push(node);
        self.types.push(ty);
        id
    }
    pub(super) fn push_spanned(&mut self, node: TNode, ty: Ty, span: Span) -> u32 {
        // Keep `spans` aligned with `nodes`: a node without a span ends it.
        if self.spans.len() == self.nodes.len() {
            self.spans.push(span);
        }
        self.push(node, ty)
    }
    /// The span of node `i`, if known.
    pub(crate) fn span(&self, i: u32) -> Option<Span> {
        self.spans.get(i as usize).copied()
    }
}

/// A parameter.
#[derive(Clone, Debug)]
pub struct Param {
    /// Its name.
    pub name: String,
    /// Span of its name.
    pub span: Span,
    /// Doc comments.
    pub docs: Vec<String>,
    /// Its default value, evaluated.
    pub value: f64,
}

/// A moving body.
#[derive(Clone, Debug)]
pub struct Body {
    /// Its name.
    pub name: String,
    /// Span of its name.
    pub span: Span,
    /// Doc comments.
    pub docs: Vec<String>,
    /// The initial guess `(x, y, phi)` at the default params.
    pub guess_value: [f64; 3],
    pub(crate) guess: [TExpr; 3],
    /// The initial velocity `(vx, vy, omega)`, if the body states one.
    pub velocity: Option<InitialVelocity>,
}

/// A body's stated initial velocity (`velocity: (vx, vy, omega)`).
#[derive(Clone, Debug)]
pub struct InitialVelocity {
    /// Span of the `velocity` keyword.
    pub keyword: Span,
    /// (ẋ, ẏ, φ̇) at the default params.
    pub value: [f64; 3],
    pub(crate) exprs: [TExpr; 3],
}

/// A named body-fixed point.
#[derive(Clone, Debug)]
pub struct Point {
    /// Its name (without the body).
    pub name: String,
    /// The body it is fixed in.
    pub body: BodyRef,
    /// Span of the declaration's name.
    pub span: Span,
    /// Doc comments.
    pub docs: Vec<String>,
    /// Local coordinates at the default params.
    pub local_value: [f64; 2],
    pub(crate) local: TExpr,
}

/// One argument of a library call, resolved.
#[derive(Clone, Debug)]
pub(crate) enum LibArg {
    /// A point on a body (or a global point when the body is ground); the
    /// local coordinates are a vector expression of params.
    Point(BodyRef, TExpr),
    Body(BodyRef),
    Vector(TExpr),
    Scalar(TExpr),
    /// A declared curve: its body, its index into [`CheckedModel::curves`].
    Curve(BodyRef, u32),
    /// A coordinate of its own (index into [`CheckedModel::coords`]).
    Coord(u32),
}

/// What an equation is made of.
#[derive(Clone, Debug)]
pub(crate) enum Form {
    /// `lhs == rhs`, scalar or vector.
    User { lhs: TExpr, rhs: TExpr },
    /// A library constraint.
    Library(LibKind, Vec<LibArg>),
}

/// One declared equation (`joint`, `constraint` or `driver`), one or two rows.
#[derive(Clone, Debug)]
pub struct Equation {
    /// Its name.
    pub name: String,
    /// Span of the name.
    pub span: Span,
    /// Doc comments.
    pub docs: Vec<String>,
    /// The keyword that introduced it.
    pub keyword: EquationKeyword,
    /// Number of scalar rows (1, 2, or 3 for `cam_follower`).
    pub rows: usize,
    /// The library constraint, if it is one.
    pub library: Option<LibKind>,
    pub(crate) form: Form,
}

impl Equation {
    /// True for a `driver` (its rows are driving equations).
    #[must_use]
    pub fn is_driver(&self) -> bool {
        self.keyword == EquationKeyword::Driver
    }

    /// Names of its rows: `name`, or `name.x`/`name.y`, or `name.1`/`name.2`.
    #[must_use]
    pub fn row_names(&self) -> Vec<String> {
        let suffixes: &[&str] = match (self.library, self.rows) {
            (Some(k), _) => k.row_suffixes(),
            (None, 2) => &[".x", ".y"],
            (None, _) => &[""],
        };
        suffixes
            .iter()
            .map(|s| format!("{}{s}", self.name))
            .collect()
    }
}

/// Degree-of-freedom counts (docs/src/constraints.md, "Degrees of freedom").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DofReport {
    /// Number of coordinates, nc = 3·nb + the `coord` items.
    pub coordinates: usize,
    /// Number of kinematic equations m_K.
    pub kinematic: usize,
    /// Number of driving equations m_D.
    pub driving: usize,
}

impl DofReport {
    /// KDOF = nc − m_K.
    #[must_use]
    pub fn kdof(&self) -> i64 {
        self.coordinates as i64 - self.kinematic as i64
    }

    /// NDOF = nc − m_K − m_D.
    #[must_use]
    pub fn ndof(&self) -> i64 {
        self.kdof() - self.driving as i64
    }
}

impl std::fmt::Display for DofReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "nc = {}, kinematic equations = {}, drivers = {}, KDOF = {}, NDOF = {}",
            self.coordinates,
            self.kinematic,
            self.driving,
            self.kdof(),
            self.ndof()
        )
    }
}

/// A validated mechanism: every name resolved, every expression typed, every
/// count right. Deriving it cannot fail.
#[derive(Clone, Debug)]
pub struct CheckedModel {
    /// The mechanism's name.
    pub name: String,
    /// Span of the name.
    pub span: Span,
    /// Doc comments of the mechanism.
    pub docs: Vec<String>,
    /// Parameters in declaration order.
    pub params: Vec<Param>,
    /// Bodies in declaration order (their coordinates in this order).
    pub bodies: Vec<Body>,
    /// Named points in declaration order.
    pub points: Vec<Point>,
    /// Coordinates of their own (`coord` items) in declaration order: in q
    /// after every body's.
    pub coords: Vec<super::coord::Coord>,
    /// Body-fixed curves (`curve` items) in declaration order.
    pub curves: Vec<super::coord::Curve>,
    /// Equations in declaration order (joints, constraints and drivers mixed).
    pub equations: Vec<Equation>,
    /// Measures (`output NAME: EXPR;`) in declaration order.
    pub outputs: Vec<super::Output>,
    /// Warnings found while checking (e.g. a driver that does not depend on `t`).
    pub warnings: Diagnostics,
    /// Inertia, gravity and forces; `None` for a kinematic model (no
    /// `mass`, `inertia`, `gravity` or `force` anywhere).
    pub dynamics: Option<super::dynamics::Dynamics>,
}

impl CheckedModel {
    /// The DOF report.
    #[must_use]
    pub fn dof(&self) -> DofReport {
        let mut r = DofReport {
            coordinates: 3 * self.bodies.len() + self.coords.len(),
            kinematic: 0,
            driving: 0,
        };
        for e in &self.equations {
            if e.is_driver() {
                r.driving += e.rows;
            } else {
                r.kinematic += e.rows;
            }
        }
        r
    }
}
