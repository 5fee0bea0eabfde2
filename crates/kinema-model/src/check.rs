//! Phase 2: validation. Every rule of the language lives in this file, each
//! with a comment showing what the user sees. The output is a
//! [`CheckedModel`]: names resolved, expressions typed (scalar or vector),
//! spans kept; everything the derivation needs so that it cannot fail.
//!
//! All independent errors are collected (in a `Ctxt`); an error inside an
//! expression does not cascade into its parents.

use std::collections::HashMap;

use crate::ctxt::Ctxt;
use crate::diagnostic::{Diagnostic, Diagnostics};
use crate::span::Span;
use crate::syntax::{self, BinOp, EquationKeyword, ExprKind, Item};

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
}

/// The type of an expression.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Ty {
    /// A number.
    Scalar,
    /// A planar vector.
    Vector,
}

/// Scalar functions of one scalar.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Func1 {
    /// sin
    Sin,
    /// cos
    Cos,
    /// tan
    Tan,
    /// asin
    Asin,
    /// acos
    Acos,
    /// atan
    Atan,
    /// sinh
    Sinh,
    /// cosh
    Cosh,
    /// tanh
    Tanh,
    /// exp
    Exp,
    /// ln
    Ln,
    /// sqrt
    Sqrt,
    /// abs
    Abs,
}

/// A node of a typed, resolved expression. Children precede parents.
#[derive(Clone, Debug)]
pub(crate) enum TNode {
    Num(f64),
    Pi,
    Time,
    Param(u32),
    Coord(u32, Comp),
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
    F1(Func1, u32),
    Atan2(u32, u32),
    Pow(u32, u32),
    Powi(u32, i32),
    Step([u32; 5]),
    Dot(u32, u32),
    Cross(u32, u32),
    Norm(u32),
    Rot(u32, u32),
    Perp(u32),
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
        u32::try_from(self.nodes.len().saturating_sub(1)).unwrap_or(u32::MAX)
    }
    pub(crate) fn ty(&self) -> Ty {
        self.types.last().copied().unwrap_or(Ty::Scalar)
    }
    fn push(&mut self, node: TNode, ty: Ty) -> u32 {
        let id = u32::try_from(self.nodes.len()).unwrap_or(u32::MAX);
        self.nodes.push(node);
        self.types.push(ty);
        id
    }
    fn push_spanned(&mut self, node: TNode, ty: Ty, span: Span) -> u32 {
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

/// The constraints of the library (CONSTRAINTS.md §1–5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LibKind {
    /// `abs_x(P, f)`
    AbsX,
    /// `abs_y(P, f)`
    AbsY,
    /// `abs_angle(B, f)`
    AbsAngle,
    /// `abs_distance(P, (cx, cy), C)`
    AbsDistance,
    /// `rel_x(Pi, Pj, f)`
    RelX,
    /// `rel_y(Pi, Pj, f)`
    RelY,
    /// `rel_angle(Bi, Bj, f)`
    RelAngle,
    /// `rel_distance(Pi, Pj, C)`
    RelDistance,
    /// `revolute(Pi, Pj)`
    Revolute,
    /// `translational(Pi, vi, Pj, vj)`
    Translational,
    /// `revolute_revolute(Pi, Pj, L)`
    RevoluteRevolute,
    /// `revolute_translational(Pi, vi, Pj, c)`
    RevoluteTranslational,
    /// `gear(Pi, Pj, Ri, Rj, theta_i, theta_j)`
    Gear,
    /// `rack_pinion(Pi, vi, Pj, Rp, c0)`
    RackPinion,
    /// `translational_distance(Pi, vi, Pj, C)`
    TranslationalDistance,
    /// `dp1(Bi, ai, Bj, aj, f)`
    Dp1,
    /// `dp2(Pi, ai, Pj, f)`
    Dp2,
    /// `d(Pi, Pj, f)`
    D,
    /// `cd((cx, cy), Pi, Pj, f)`
    Cd,
}

/// The kind of one argument of a library constraint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum ArgKind {
    /// A point: `B(sx, sy)`, `B.name` or `ground(x, y)`.
    Point,
    /// A body name or `ground`.
    Body,
    /// A constant vector `(vx, vy)` (body-fixed, or global for `cd`).
    Vector,
    /// A scalar expression of params and `t`.
    Scalar,
}

/// Signature of a library constraint.
struct LibSpec {
    name: &'static str,
    kind: LibKind,
    args: &'static [ArgKind],
    signature: &'static str,
    rows: usize,
    /// Arguments whose bodies must differ (a joint between a body and itself).
    pair: Option<(usize, usize)>,
}

use ArgKind::{Body as AB, Point as AP, Scalar as AS, Vector as AV};

const LIBRARY: &[LibSpec] = &[
    LibSpec {
        name: "abs_x",
        kind: LibKind::AbsX,
        args: &[AP, AS],
        signature: "abs_x(P, f)",
        rows: 1,
        pair: None,
    },
    LibSpec {
        name: "abs_y",
        kind: LibKind::AbsY,
        args: &[AP, AS],
        signature: "abs_y(P, f)",
        rows: 1,
        pair: None,
    },
    LibSpec {
        name: "abs_angle",
        kind: LibKind::AbsAngle,
        args: &[AB, AS],
        signature: "abs_angle(B, f)",
        rows: 1,
        pair: None,
    },
    LibSpec {
        name: "abs_distance",
        kind: LibKind::AbsDistance,
        args: &[AP, AV, AS],
        signature: "abs_distance(P, (cx, cy), C)",
        rows: 1,
        pair: None,
    },
    LibSpec {
        name: "rel_x",
        kind: LibKind::RelX,
        args: &[AP, AP, AS],
        signature: "rel_x(Pi, Pj, f)",
        rows: 1,
        pair: Some((0, 1)),
    },
    LibSpec {
        name: "rel_y",
        kind: LibKind::RelY,
        args: &[AP, AP, AS],
        signature: "rel_y(Pi, Pj, f)",
        rows: 1,
        pair: Some((0, 1)),
    },
    LibSpec {
        name: "rel_angle",
        kind: LibKind::RelAngle,
        args: &[AB, AB, AS],
        signature: "rel_angle(Bi, Bj, f)",
        rows: 1,
        pair: Some((0, 1)),
    },
    LibSpec {
        name: "rel_distance",
        kind: LibKind::RelDistance,
        args: &[AP, AP, AS],
        signature: "rel_distance(Pi, Pj, C)",
        rows: 1,
        pair: Some((0, 1)),
    },
    LibSpec {
        name: "revolute",
        kind: LibKind::Revolute,
        args: &[AP, AP],
        signature: "revolute(Pi, Pj)",
        rows: 2,
        pair: Some((0, 1)),
    },
    LibSpec {
        name: "translational",
        kind: LibKind::Translational,
        args: &[AP, AV, AP, AV],
        signature: "translational(Pi, vi, Pj, vj)",
        rows: 2,
        pair: Some((0, 2)),
    },
    LibSpec {
        name: "revolute_revolute",
        kind: LibKind::RevoluteRevolute,
        args: &[AP, AP, AS],
        signature: "revolute_revolute(Pi, Pj, L)",
        rows: 1,
        pair: Some((0, 1)),
    },
    LibSpec {
        name: "revolute_translational",
        kind: LibKind::RevoluteTranslational,
        args: &[AP, AV, AP, AS],
        signature: "revolute_translational(Pi, vi, Pj, c)",
        rows: 1,
        pair: Some((0, 2)),
    },
    LibSpec {
        name: "gear",
        kind: LibKind::Gear,
        args: &[AP, AP, AS, AS, AS, AS],
        signature: "gear(Pi, Pj, Ri, Rj, theta_i, theta_j)",
        rows: 1,
        pair: Some((0, 1)),
    },
    LibSpec {
        name: "rack_pinion",
        kind: LibKind::RackPinion,
        args: &[AP, AV, AP, AS, AS],
        signature: "rack_pinion(Pi, vi, Pj, Rp, c0)",
        rows: 2,
        pair: Some((0, 2)),
    },
    LibSpec {
        name: "translational_distance",
        kind: LibKind::TranslationalDistance,
        args: &[AP, AV, AP, AS],
        signature: "translational_distance(Pi, vi, Pj, C)",
        rows: 1,
        pair: Some((0, 2)),
    },
    LibSpec {
        name: "dp1",
        kind: LibKind::Dp1,
        args: &[AB, AV, AB, AV, AS],
        signature: "dp1(Bi, ai, Bj, aj, f)",
        rows: 1,
        pair: Some((0, 2)),
    },
    LibSpec {
        name: "dp2",
        kind: LibKind::Dp2,
        args: &[AP, AV, AP, AS],
        signature: "dp2(Pi, ai, Pj, f)",
        rows: 1,
        pair: Some((0, 2)),
    },
    LibSpec {
        name: "d",
        kind: LibKind::D,
        args: &[AP, AP, AS],
        signature: "d(Pi, Pj, f)",
        rows: 1,
        pair: Some((0, 1)),
    },
    LibSpec {
        name: "cd",
        kind: LibKind::Cd,
        args: &[AV, AP, AP, AS],
        signature: "cd((cx, cy), Pi, Pj, f)",
        rows: 1,
        pair: Some((1, 2)),
    },
];

fn library(name: &str) -> Option<&'static LibSpec> {
    LIBRARY.iter().find(|s| s.name == name)
}

impl LibKind {
    /// The constraint's name in the language.
    #[must_use]
    pub fn name(self) -> &'static str {
        LIBRARY
            .iter()
            .find(|s| s.kind == self)
            .map_or("?", |s| s.name)
    }

    /// Its signature, e.g. `revolute(Pi, Pj)`.
    #[must_use]
    pub fn signature(self) -> &'static str {
        LIBRARY
            .iter()
            .find(|s| s.kind == self)
            .map_or("?", |s| s.signature)
    }

    /// Names of its rows (suffixes of the equation name).
    #[must_use]
    pub fn row_suffixes(self) -> &'static [&'static str] {
        match self {
            LibKind::Revolute => &[".x", ".y"],
            LibKind::Translational | LibKind::RackPinion => &[".1", ".2"],
            _ => &[""],
        }
    }
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
    /// Number of scalar rows (1 or 2).
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

/// Degree-of-freedom counts (CONSTRAINTS.md §6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DofReport {
    /// Number of coordinates, nc = 3·nb.
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
    /// Equations in declaration order (joints, constraints and drivers mixed).
    pub equations: Vec<Equation>,
    /// Warnings found while checking (e.g. a driver that does not depend on `t`).
    pub warnings: Diagnostics,
}

impl CheckedModel {
    /// The DOF report.
    #[must_use]
    pub fn dof(&self) -> DofReport {
        let mut r = DofReport {
            coordinates: 3 * self.bodies.len(),
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

// ---------------------------------------------------------------- names

const RESERVED: &[&str] = &["pi", "t", "ground"];

const FUNCTIONS: &[(&str, &str)] = &[
    ("sin", "sin(x)"),
    ("cos", "cos(x)"),
    ("tan", "tan(x)"),
    ("asin", "asin(x)"),
    ("acos", "acos(x)"),
    ("atan", "atan(x)"),
    ("sinh", "sinh(x)"),
    ("cosh", "cosh(x)"),
    ("tanh", "tanh(x)"),
    ("exp", "exp(x)"),
    ("ln", "ln(x)"),
    ("sqrt", "sqrt(x)"),
    ("abs", "abs(x)"),
    ("atan2", "atan2(y, x)"),
    ("pow", "pow(x, y)"),
    ("powi", "powi(x, n)"),
    ("step", "step(x, x0, h0, x1, h1)"),
    ("dot", "dot(a, b)"),
    ("cross", "cross(a, b)"),
    ("norm", "norm(a)"),
    ("rot", "rot(angle, v)"),
    ("perp", "perp(v)"),
];

fn function_names() -> String {
    FUNCTIONS
        .iter()
        .map(|(n, _)| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn library_names() -> String {
    LIBRARY
        .iter()
        .map(|s| format!("`{}`", s.name))
        .collect::<Vec<_>>()
        .join(", ")
}

/// What a name declared at mechanism level stands for.
#[derive(Clone, Copy)]
enum Decl {
    Param(u32),
    Body(u32),
}

/// Per-node facts gathered while typing: the first token that makes the
/// node depend on time, and on coordinates.
#[derive(Clone, Copy, Default)]
struct Deps {
    time: Option<Span>,
    coord: Option<Span>,
}

impl Deps {
    fn or(self, other: Deps) -> Deps {
        Deps {
            time: self.time.or(other.time),
            coord: self.coord.or(other.coord),
        }
    }
}

/// A typed subexpression and its dependencies.
struct Typed {
    expr: TExpr,
    deps: Deps,
}

/// The names seen by expressions.
struct Names<'a> {
    decls: HashMap<String, Decl>,
    bodies: Vec<String>,
    points: HashMap<(BodyRef, String), u32>,
    point_decls: &'a [Point],
}

/// Checks a parsed mechanism.
///
/// # Errors
/// Every error found (and the warnings).
pub fn check(mech: &syntax::Mechanism) -> Result<CheckedModel, Diagnostics> {
    if !mech.errors.is_empty() {
        // Parse errors come alone: names missing from a bad item would
        // otherwise show up again as "unknown name" errors.
        return Err(mech.errors.clone());
    }
    let mut cx = Ctxt::default();

    // ---- Rule: names are unique. Params and bodies share one namespace
    // (both are read by bare name in expressions); they may not shadow `pi`,
    // `t`, `ground`, and a body may not shadow a function (`sin(…)` would
    // become a point).
    //   error: duplicate name `l1`
    //    --> m.kin:4:11
    //     = help: `l1` is first declared at 3:11
    let mut decls: HashMap<String, Decl> = HashMap::new();
    let mut first_span: HashMap<String, Span> = HashMap::new();
    let mut bodies: Vec<&syntax::BodyDecl> = Vec::new();
    let mut params: Vec<&syntax::ParamDecl> = Vec::new();
    for item in &mech.items {
        let (ident, decl) = match item {
            Item::Param(p) => {
                params.push(p);
                (&p.name, Decl::Param(idx(params.len() - 1)))
            }
            Item::Body(b) => {
                bodies.push(b);
                (&b.name, Decl::Body(idx(bodies.len() - 1)))
            }
            _ => continue,
        };
        let name = ident.to_string();
        let span = Span::new(ident.span());
        if RESERVED.contains(&name.as_str()) {
            // error: `t` is reserved (time) and cannot be declared
            cx.error(
                span,
                format!(
                    "`{name}` is reserved ({}) and cannot be declared",
                    reserved_meaning(&name)
                ),
            );
            continue;
        }
        if matches!(decl, Decl::Body(_))
            && (FUNCTIONS.iter().any(|(f, _)| *f == name) || library(&name).is_some())
        {
            // error: a body cannot be named `sin`: it is a function
            cx.error(
                span,
                format!("a body cannot be named `{name}`: it is the name of a function"),
            );
            continue;
        }
        if let Some(first) = first_span.get(&name) {
            let s = first.start();
            cx.push(
                Diagnostic::error(span, format!("duplicate name `{name}`")).with_help(format!(
                    "`{name}` is first declared at {}:{}",
                    s.line,
                    s.column + 1
                )),
            );
            continue;
        }
        first_span.insert(name.clone(), span);
        decls.insert(name, decl);
    }
    let body_names: Vec<String> = bodies.iter().map(|b| b.name.to_string()).collect();

    // ---- Points: the body must exist; names unique per body; `x`, `y`,
    // `phi` are coordinates, not point names.
    //   error: unknown body `crnk`
    //   error: a point cannot be named `phi`: `crank.phi` is a coordinate
    let mut point_names: HashMap<(BodyRef, String), u32> = HashMap::new();
    let mut point_items: Vec<(&syntax::PointDecl, BodyRef)> = Vec::new();
    for item in &mech.items {
        let Item::Point(p) = item else { continue };
        let body_name = p.body.to_string();
        let body = if body_name == "ground" {
            BodyRef::Ground
        } else if let Some(Decl::Body(b)) = decls.get(&body_name) {
            BodyRef::Body(*b)
        } else {
            cx.push(unknown_body(
                Span::new(p.body.span()),
                &body_name,
                &body_names,
            ));
            continue;
        };
        let name = p.name.to_string();
        if matches!(name.as_str(), "x" | "y" | "phi") {
            cx.error(
                Span::new(p.name.span()),
                format!("a point cannot be named `{name}`: `{body_name}.{name}` is a coordinate"),
            );
            continue;
        }
        if point_names.contains_key(&(body, name.clone())) {
            cx.error(
                Span::new(p.name.span()),
                format!("duplicate point `{body_name}.{name}`"),
            );
            continue;
        }
        point_names.insert((body, name), idx(point_items.len()));
        point_items.push((p, body));
    }

    let mut names = Names {
        decls,
        bodies: body_names,
        points: point_names,
        point_decls: &[],
    };

    // ---- Params: a constant expression of earlier params and `pi`.
    //   error: param `b` is used before its declaration
    //   error: param `k` has no value: expected `param k = <expression>;`
    let mut out_params: Vec<Param> = Vec::new();
    let mut param_values: Vec<f64> = Vec::new();
    for (i, p) in params.iter().enumerate() {
        let name = p.name.to_string();
        let span = Span::new(p.name.span());
        let typed = match &p.value {
            None => {
                cx.error(
                    span,
                    format!("param `{name}` has no value: expected `param {name} = <expression>;`"),
                );
                None
            }
            Some(e) => check_expr(&mut cx, &names, e, e.root, i)
                .and_then(|t| constant(&mut cx, &t, "the value of a param").then_some(t)),
        };
        let typed = typed.and_then(|t| {
            expect_ty(
                &mut cx,
                t,
                Ty::Scalar,
                p.value.as_ref().map(|e| e.span()).unwrap_or(span),
            )
        });
        let value = match typed {
            Some(t) => {
                let v = eval_scalar(&t.expr, &param_values);
                if !v.is_finite() && !uses_bad_param(&t.expr, &param_values) {
                    // error: the value of param `x` is NaN: expected a finite number
                    cx.error(
                        p.value.as_ref().map_or(span, |e| e.span()),
                        format!(
                            "the value of param `{name}` is {}: expected a finite number",
                            show_nonfinite(v)
                        ),
                    );
                }
                v
            }
            None => f64::NAN,
        };
        param_values.push(value);
        out_params.push(Param {
            name,
            span,
            docs: p.docs.clone(),
            value,
        });
    }
    let all_params = out_params.len();

    // ---- Points' local coordinates: constant vectors of params.
    let mut out_points: Vec<Point> = Vec::new();
    for (p, body) in &point_items {
        let t = check_expr(&mut cx, &names, &p.value, p.value.root, all_params)
            .and_then(|t| constant(&mut cx, &t, "the local coordinates of a point").then_some(t))
            .and_then(|t| expect_ty(&mut cx, t, Ty::Vector, p.value.span()));
        let (local, local_value) = match t {
            Some(t) => {
                let v = eval_vector(&t.expr, &param_values);
                finite_vector(&mut cx, v, p.value.span(), &t.expr, &param_values);
                (t.expr, v)
            }
            None => (vector_const(0.0, 0.0), [0.0, 0.0]),
        };
        out_points.push(Point {
            name: p.name.to_string(),
            body: *body,
            span: Span::new(p.name.span()),
            docs: p.docs.clone(),
            local_value,
            local,
        });
    }
    names.point_decls = &out_points;

    // ---- Bodies' initial guesses: constant scalars of params.
    let mut out_bodies: Vec<Body> = Vec::new();
    for b in &bodies {
        let mut guess = [scalar_const(0.0), scalar_const(0.0), scalar_const(0.0)];
        let mut guess_value = [0.0; 3];
        if let Some(g) = &b.guess {
            for k in 0..3 {
                let t = check_expr(&mut cx, &names, &g[k], g[k].root, all_params)
                    .and_then(|t| constant(&mut cx, &t, "an initial guess").then_some(t))
                    .and_then(|t| expect_ty(&mut cx, t, Ty::Scalar, g[k].span()));
                if let Some(t) = t {
                    let v = eval_scalar(&t.expr, &param_values);
                    if !v.is_finite() && !uses_bad_param(&t.expr, &param_values) {
                        cx.error(
                            g[k].span(),
                            format!(
                                "this initial guess is {}: expected a finite number",
                                show_nonfinite(v)
                            ),
                        );
                    }
                    guess[k] = t.expr;
                    guess_value[k] = v;
                }
            }
        }
        out_bodies.push(Body {
            name: b.name.to_string(),
            span: Span::new(b.name.span()),
            docs: b.docs.clone(),
            guess_value,
            guess,
        });
    }

    // ---- Equations.
    let mut out_eqs: Vec<Equation> = Vec::new();
    let mut eq_names: HashMap<String, Span> = HashMap::new();
    let mut rows_known = true;
    for item in &mech.items {
        let Item::Equation(e) = item else { continue };
        let name = e.name.to_string();
        let span = Span::new(e.name.span());
        // Rule: equation names are unique.
        //   error: duplicate equation name `pin`
        if let Some(first) = eq_names.get(&name) {
            let s = first.start();
            cx.push(
                Diagnostic::error(span, format!("duplicate equation name `{name}`")).with_help(
                    format!("`{name}` is first declared at {}:{}", s.line, s.column + 1),
                ),
            );
        } else {
            eq_names.insert(name.clone(), span);
        }
        let Some((form, deps, library_kind, rows)) =
            check_equation(&mut cx, &names, e, all_params, &param_values)
        else {
            // Its row count is unknown: the DOF rule stays quiet.
            rows_known = false;
            continue;
        };
        // Rule: an equation constrains at least one body (a row without
        // coordinates makes Φ_q singular).
        //   error: constraint `c` does not depend on any coordinate
        if deps.coord.is_none() {
            cx.push(
                Diagnostic::error(
                    span,
                    format!("{} `{name}` does not depend on any coordinate", e.keyword.as_str()),
                )
                .with_help("expected an equation in coordinates (`B.x`, `B.y`, `B.phi`) or points of a moving body; it would make Φ_q singular"),
            );
        }
        // Rule: kinematic constraints do not depend on time.
        //   error: kinematic constraint `on_axis` depends on time `t`
        //   = help: declare it with `driver` if it drives the mechanism
        if e.keyword != EquationKeyword::Driver {
            if let Some(t) = deps.time {
                cx.push(
                    Diagnostic::error(
                        t,
                        format!(
                            "{} `{name}` is kinematic and cannot depend on time `t`",
                            e.keyword.as_str()
                        ),
                    )
                    .with_help("declare it with `driver` if it drives the mechanism"),
                );
            }
        } else if deps.time.is_none() {
            // Rule (warning): a driver that does not depend on time is a
            // constant constraint.
            //   warning: driver `lock` does not depend on time `t`
            cx.push(
                Diagnostic::warning(span, format!("driver `{name}` does not depend on time `t`"))
                    .with_help("it holds a constant value; `constraint` says so"),
            );
        }
        out_eqs.push(Equation {
            name,
            span,
            docs: e.docs.clone(),
            keyword: e.keyword,
            rows,
            library: library_kind,
            form,
        });
    }

    let mut model = CheckedModel {
        name: mech.name.to_string(),
        span: Span::new(mech.name.span()),
        docs: mech.docs.clone(),
        params: out_params,
        bodies: out_bodies,
        points: out_points,
        equations: out_eqs,
        warnings: Diagnostics::new(),
    };

    // ---- Rule: the mechanism is kinematically determined, NDOF = 0.
    //   error: mechanism `M` has NDOF = 1, expected 0: nc = 9, kinematic equations = 7, drivers = 1, KDOF = 2
    // Reported only when everything else is right: a count over a model
    // with missing or bad declarations would mislead.
    if rows_known && cx.error_count() == 0 {
        let dof = model.dof();
        if dof.ndof() != 0 {
            let help = if dof.ndof() > 0 {
                format!(
                    "add {} driving or kinematic equation{}",
                    dof.ndof(),
                    if dof.ndof() == 1 { "" } else { "s" }
                )
            } else {
                format!(
                    "remove {} equation{}, or add a body",
                    -dof.ndof(),
                    if dof.ndof() == -1 { "" } else { "s" }
                )
            };
            cx.push(
                Diagnostic::error(
                    model.span,
                    format!(
                        "mechanism `{}` has NDOF = {}, expected 0: nc = {}, kinematic equations = {}, drivers = {}, KDOF = {}",
                        model.name,
                        dof.ndof(),
                        dof.coordinates,
                        dof.kinematic,
                        dof.driving,
                        dof.kdof()
                    ),
                )
                .with_help(help),
            );
        }
    }

    if cx.error_count() == 0 {
        undefined_parts(&mut cx, &model);
    }

    let diagnostics = cx.finish();
    if diagnostics.has_errors() {
        return Err(diagnostics);
    }
    model.warnings = diagnostics;
    Ok(model)
}

/// Rule: no part of an equation is undefined whatever the coordinates and
/// time, once simplified: a divisor that is identically zero (`(B.x − B.x)`)
/// or a function of one (`ln(B.y − B.y)`). The engine's constructors keep
/// such parts undefined (NaN) instead of simplifying them away
/// ([`kinema_expr::Arena::is_undefined`]); this reports each at its span.
///   error: division by zero: this divisor is identically zero
fn undefined_parts(cx: &mut Ctxt, model: &CheckedModel) {
    let mut arena = kinema_expr::Arena::new();
    let lo = crate::lower::Lowerer::new(&mut arena, model);
    for eq in &model.equations {
        let exprs: Vec<&TExpr> = match &eq.form {
            Form::User { lhs, rhs } => vec![lhs, rhs],
            Form::Library(_, args) => args
                .iter()
                .filter_map(|a| match a {
                    LibArg::Point(_, t) | LibArg::Vector(t) | LibArg::Scalar(t) => Some(t),
                    LibArg::Body(_) => None,
                })
                .collect(),
        };
        for t in exprs {
            lo.lower_reporting(&mut arena, t, &mut |i, why| {
                let span = t.span(i).unwrap_or(eq.span);
                cx.push(match why {
                    crate::lower::Undefined::ZeroDivisor => Diagnostic::error(
                        span,
                        "division by zero: this divisor is identically zero",
                    )
                    .with_help("the quotient is undefined whatever the coordinates and time"),
                    crate::lower::Undefined::Value => Diagnostic::error(
                        span,
                        "this expression is undefined whatever the coordinates and time",
                    )
                    .with_help("a function is applied where it has no finite value (such as `ln` of an expression that is identically zero)"),
                });
            });
        }
    }
}

fn idx(i: usize) -> u32 {
    u32::try_from(i).unwrap_or(u32::MAX)
}

fn reserved_meaning(name: &str) -> &'static str {
    match name {
        "pi" => "the number π",
        "t" => "time",
        _ => "the fixed body",
    }
}

fn show_nonfinite(v: f64) -> &'static str {
    if v.is_nan() {
        "NaN"
    } else if v > 0.0 {
        "infinite"
    } else {
        "-infinite"
    }
}

fn unknown_body(span: Span, name: &str, bodies: &[String]) -> Diagnostic {
    // error: unknown body `crnk`
    //  = help: the bodies are `crank`, `rod`, `slider`, and `ground`
    // A model may declare thousands of bodies: name a few, count the rest,
    // so that each error costs the same whatever the model's size.
    const SHOWN: usize = 8;
    let mut list: Vec<String> = bodies
        .iter()
        .take(SHOWN)
        .map(|b| format!("`{b}`"))
        .collect();
    if bodies.len() > SHOWN {
        list.push(format!("… ({} more)", bodies.len() - SHOWN));
    }
    list.push("`ground`".to_string());
    Diagnostic::error(span, format!("unknown body `{name}`"))
        .with_help(format!("expected one of: {}", list.join(", ")))
}

fn scalar_const(v: f64) -> TExpr {
    TExpr {
        nodes: vec![TNode::Num(v)],
        types: vec![Ty::Scalar],
        spans: Vec::new(),
    }
}

fn vector_const(a: f64, b: f64) -> TExpr {
    TExpr {
        nodes: vec![TNode::Num(a), TNode::Num(b), TNode::Vec(0, 1)],
        types: vec![Ty::Scalar, Ty::Scalar, Ty::Vector],
        spans: Vec::new(),
    }
}

/// Rule: constant contexts (param values, guesses, point coordinates,
/// body-fixed vectors) use only numbers, params and `pi`.
///   error: time `t` cannot appear in the value of a param: expected a constant expression of params
fn constant(cx: &mut Ctxt, t: &Typed, what: &str) -> bool {
    let mut ok = true;
    if let Some(s) = t.deps.time {
        cx.error(
            s,
            format!("time `t` cannot appear in {what}: expected a constant expression of params"),
        );
        ok = false;
    }
    if let Some(s) = t.deps.coord {
        cx.error(s, format!("coordinates and points cannot appear in {what}: expected a constant expression of params"));
        ok = false;
    }
    ok
}

/// Rule: an expression has the type its place needs.
///   error: expected a scalar, found a vector
fn expect_ty(cx: &mut Ctxt, t: Typed, ty: Ty, span: Span) -> Option<Typed> {
    if t.expr.ty() == ty {
        return Some(t);
    }
    cx.error(
        span,
        format!("expected {}, found {}", ty_name(ty), ty_name(t.expr.ty())),
    );
    None
}

fn ty_name(ty: Ty) -> &'static str {
    match ty {
        Ty::Scalar => "a scalar",
        Ty::Vector => "a vector",
    }
}

/// True when `t` reads a param whose value is not finite (already reported).
fn uses_bad_param(t: &TExpr, params: &[f64]) -> bool {
    t.nodes.iter().any(|n| match n {
        TNode::Param(i) => !params.get(*i as usize).is_some_and(|v| v.is_finite()),
        _ => false,
    })
}

/// Rule: constant vectors are finite (unless a bad param, already reported,
/// is the cause).
fn finite_vector(cx: &mut Ctxt, v: [f64; 2], span: Span, t: &TExpr, params: &[f64]) {
    let finite = v[0].is_finite() && v[1].is_finite();
    if !finite && !uses_bad_param(t, params) {
        cx.error(span, "this vector is not finite: expected finite numbers");
    }
}

/// Rules: a constant of numbers and `pi` folds to a finite number, and no
/// divisor is identically zero.
///   error: division by zero: this divisor is zero
///   error: this constant overflows: its value is infinite
///
/// Computes the folded value of the typed node `n` about to be pushed after
/// the nodes whose values are `folded` (None: not such a constant). The
/// first node whose value stops being finite is reported; its parents are
/// then not constants any more, so one mistake gives one error.
fn fold_constant(
    cx: &mut Ctxt,
    n: &TNode,
    folded: &[Option<f64>],
    out: &TExpr,
    span: Span,
) -> Option<f64> {
    let v = |i: u32| folded.get(i as usize).copied().flatten();
    let value = match *n {
        TNode::Num(x) => Some(x),
        TNode::Pi => Some(std::f64::consts::PI),
        TNode::Neg(a) => v(a).map(|x| -x),
        TNode::Add(a, b) => v(a).zip(v(b)).map(|(x, y)| x + y),
        TNode::Sub(a, b) => v(a).zip(v(b)).map(|(x, y)| x - y),
        TNode::Mul(a, b) => v(a).zip(v(b)).map(|(x, y)| x * y),
        TNode::Div(a, b) => {
            if v(b) == Some(0.0) {
                cx.push(
                    Diagnostic::error(
                        out.span(b).unwrap_or(span),
                        "division by zero: this divisor is zero",
                    )
                    .with_help("the quotient is undefined whatever the coordinates and time"),
                );
                return None;
            }
            v(a).zip(v(b)).map(|(x, y)| x / y)
        }
        TNode::F1(f, a) => v(a).map(|x| match f {
            Func1::Sqrt => x.sqrt(),
            Func1::Sin => x.sin(),
            Func1::Cos => x.cos(),
            Func1::Tan => x.tan(),
            Func1::Asin => x.asin(),
            Func1::Acos => x.acos(),
            Func1::Atan => x.atan(),
            Func1::Sinh => x.sinh(),
            Func1::Cosh => x.cosh(),
            Func1::Tanh => x.tanh(),
            Func1::Exp => x.exp(),
            Func1::Ln => x.ln(),
            Func1::Abs => x.abs(),
        }),
        TNode::Atan2(a, b) => v(a).zip(v(b)).map(|(y, x)| y.atan2(x)),
        TNode::Pow(a, b) => v(a).zip(v(b)).map(|(x, y)| x.powf(y)),
        TNode::Powi(a, k) => v(a).map(|x| x.powi(k)),
        _ => None,
    };
    match value {
        Some(x) if !x.is_finite() => {
            cx.push(
                Diagnostic::error(
                    span,
                    format!("this constant is {}: expected a finite number", show_nonfinite(x)),
                )
                .with_help("its value overflows or is undefined (such as `1e308 * 1e308`, `ln(0)` or `0 / 0`)"),
            );
            None
        }
        other => other,
    }
}

/// Describes a syntax node for "found …" messages.
fn describe(expr: &syntax::Expr, i: u32, ty: Ty) -> String {
    let what = match &expr.node(i).kind {
        ExprKind::Field(b, f) => match &expr.node(*b).kind {
            ExprKind::Ident(body) => format!(" (point `{body}.{f}`)"),
            _ => String::new(),
        },
        ExprKind::Call(f, _) => format!(" (`{f}(…)`)"),
        ExprKind::Tuple(_) => " (a vector literal)".to_string(),
        ExprKind::Ident(n) => format!(" (`{n}`)"),
        _ => String::new(),
    };
    format!("{}{what}", ty_name(ty))
}

/// Types the subtree of `expr` rooted at `root`. `params_visible`: params
/// with a smaller index may be used. Reports errors; `None` if any.
fn check_expr(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    root: u32,
    params_visible: usize,
) -> Option<Typed> {
    let order = expr.subtree(root);
    // Map from syntax index to (typed index, deps); None = failed.
    let mut map: HashMap<u32, (u32, Deps)> = HashMap::with_capacity(order.len());
    // Field bases that name a body (handled by the field itself).
    let mut body_base: std::collections::HashSet<u32> = std::collections::HashSet::new();
    for &i in &order {
        if let ExprKind::Field(b, _) = &expr.node(i).kind
            && let ExprKind::Ident(id) = &expr.node(*b).kind
        {
            let n = id.to_string();
            if n == "ground" || matches!(names.decls.get(&n), Some(Decl::Body(_))) {
                body_base.insert(*b);
            }
        }
    }
    let mut out = TExpr {
        nodes: Vec::new(),
        types: Vec::new(),
        spans: Vec::new(),
    };
    // The value of each typed node that is a constant of numbers and `pi`
    // alone (what the engine folds), to report a fold that is not finite.
    let mut folded: Vec<Option<f64>> = Vec::new();
    let errors_before = cx.error_count();
    let mut failed: std::collections::HashSet<u32> = std::collections::HashSet::new();
    for &i in &order {
        if body_base.contains(&i) {
            continue;
        }
        let node = expr.node(i);
        let span = node.span;
        // Children: if any failed, this node fails silently (no cascade),
        // and the loop goes on so that independent errors are all reported.
        macro_rules! child {
            ($j:expr) => {
                match map.get($j).copied() {
                    Some(c) => c,
                    None => {
                        failed.insert(i);
                        continue;
                    }
                }
            };
        }
        let res: Option<(TNode, Ty, Deps)> = match &node.kind {
            ExprKind::Num { value, suffix } => {
                // Rule: numbers are written as in maths.
                //   error: number with a type suffix `f64`: write numbers as in maths (`2`, `0.3`, `1e-3`)
                if !suffix.is_empty() {
                    cx.error(span, format!("number with a type suffix `{suffix}`: expected a plain number such as `2`, `0.3` or `1e-3`"));
                    None
                } else if !value.is_finite() {
                    // error: number out of range: expected a finite number
                    cx.error(span, "number out of range: expected a finite number");
                    None
                } else {
                    Some((TNode::Num(*value), Ty::Scalar, Deps::default()))
                }
            }
            ExprKind::Ident(id) => {
                let n = id.to_string();
                match n.as_str() {
                    "pi" => Some((TNode::Pi, Ty::Scalar, Deps::default())),
                    "t" => Some((
                        TNode::Time,
                        Ty::Scalar,
                        Deps {
                            time: Some(span),
                            coord: None,
                        },
                    )),
                    "ground" => {
                        cx.push(
                            Diagnostic::error(span, "expected a scalar, found the body `ground`")
                                .with_help("a point on ground is `ground(x, y)`"),
                        );
                        None
                    }
                    _ => {
                        match names.decls.get(&n) {
                            Some(Decl::Param(p)) => {
                                if (*p as usize) < params_visible {
                                    Some((TNode::Param(*p), Ty::Scalar, Deps::default()))
                                } else {
                                    // error: param `b` is used before its declaration
                                    cx.error(span, format!("param `{n}` is used before its value is known: a param may use only params declared before it"));
                                    None
                                }
                            }
                            Some(Decl::Body(_)) => {
                                // error: expected a scalar, found the body `crank`
                                cx.push(Diagnostic::error(span, format!("expected a scalar, found the body `{n}`"))
                                .with_help(format!("use a coordinate (`{n}.x`, `{n}.y`, `{n}.phi`) or a point (`{n}(sx, sy)`)")));
                                None
                            }
                            None => {
                                // error: unknown name `l3`
                                cx.push(Diagnostic::error(span, format!("unknown name `{n}`"))
                                .with_help("expected a param, `pi`, `t`, or a coordinate such as `body.x`"));
                                None
                            }
                        }
                    }
                }
            }
            ExprKind::Field(b, field) => {
                let f = field.to_string();
                if body_base.contains(b) {
                    let ExprKind::Ident(body_id) = &expr.node(*b).kind else {
                        continue;
                    };
                    let bn = body_id.to_string();
                    let body = if bn == "ground" {
                        BodyRef::Ground
                    } else if let Some(Decl::Body(k)) = names.decls.get(&bn) {
                        BodyRef::Body(*k)
                    } else {
                        continue;
                    };
                    match (f.as_str(), body) {
                        ("x" | "y" | "phi", BodyRef::Ground) => {
                            // error: `ground` has no coordinates
                            cx.error(span, "`ground` has no coordinates: it is fixed");
                            None
                        }
                        ("x" | "y" | "phi", BodyRef::Body(k)) => {
                            let c = match f.as_str() {
                                "x" => Comp::X,
                                "y" => Comp::Y,
                                _ => Comp::Phi,
                            };
                            Some((
                                TNode::Coord(k, c),
                                Ty::Scalar,
                                Deps {
                                    time: None,
                                    coord: Some(span),
                                },
                            ))
                        }
                        _ => match names.points.get(&(body, f.clone())) {
                            Some(p) => {
                                let deps = Deps {
                                    time: None,
                                    coord: (body != BodyRef::Ground).then_some(span),
                                };
                                Some((TNode::NamedPoint(*p), Ty::Vector, deps))
                            }
                            None => {
                                // error: body `crank` has no point `q`
                                cx.push(Diagnostic::error(Span::new(field.span()), format!("body `{bn}` has no point `{f}`"))
                                    .with_help(format!("expected `x`, `y`, `phi` or a point declared with `point {bn}.{f} = (sx, sy);`")));
                                None
                            }
                        },
                    }
                } else {
                    let (a, da) = child!(b);
                    let ta = out.types[a as usize];
                    match f.as_str() {
                        "x" | "y" if ta == Ty::Vector => {
                            let n = if f == "x" { TNode::X(a) } else { TNode::Y(a) };
                            Some((n, Ty::Scalar, da))
                        }
                        "x" | "y" => {
                            cx.error(
                                expr.node(*b).span,
                                format!(
                                    "expected a vector before `.{f}`, found {}",
                                    describe(expr, *b, ta)
                                ),
                            );
                            None
                        }
                        _ => {
                            // error: unknown field `z`: expected `x` or `y`
                            cx.error(Span::new(field.span()), format!("unknown field `{f}`: expected `x` or `y` (or a body before the `.`)"));
                            None
                        }
                    }
                }
            }
            ExprKind::Tuple(items) => {
                if items.len() != 2 {
                    cx.error(
                        span,
                        format!(
                            "expected a vector `(a, b)`, found a tuple of {} elements",
                            items.len()
                        ),
                    );
                    None
                } else {
                    let (a, da) = child!(&items[0]);
                    let (b2, db) = child!(&items[1]);
                    let ok_a = scalar_arg(cx, expr, &out, items[0], a);
                    let ok_b = scalar_arg(cx, expr, &out, items[1], b2);
                    (ok_a && ok_b).then(|| (TNode::Vec(a, b2), Ty::Vector, da.or(db)))
                }
            }
            ExprKind::Neg(a) => {
                let (a2, da) = child!(a);
                Some((TNode::Neg(a2), out.types[a2 as usize], da))
            }
            ExprKind::Binary(op, a, b) => {
                let (x, dx) = child!(a);
                let (y, dy) = child!(b);
                let (tx, ty) = (out.types[x as usize], out.types[y as usize]);
                let deps = dx.or(dy);
                match (op, tx, ty) {
                    (BinOp::Add | BinOp::Sub, _, _) if tx == ty => {
                        let n = if *op == BinOp::Add {
                            TNode::Add(x, y)
                        } else {
                            TNode::Sub(x, y)
                        };
                        Some((n, tx, deps))
                    }
                    (BinOp::Add | BinOp::Sub, _, _) => {
                        // error: expected a scalar, found a vector (point `crank.o`)
                        let (v, other) = if tx == Ty::Vector { (*a, *b) } else { (*b, *a) };
                        let verb = if *op == BinOp::Add {
                            "added to"
                        } else {
                            "subtracted from"
                        };
                        let other_name = match &expr.node(other).kind {
                            ExprKind::Ident(n) => format!(" (`{n}`)"),
                            _ => String::new(),
                        };
                        cx.push(
                            Diagnostic::error(
                                expr.node(v).span,
                                format!(
                                    "expected a scalar, found {}",
                                    describe(expr, v, Ty::Vector)
                                ),
                            )
                            .with_label(format!("a vector cannot be {verb} a scalar"))
                            .with_help(format!("the other operand is a scalar{other_name}")),
                        );
                        None
                    }
                    (BinOp::Mul, Ty::Vector, Ty::Vector) => {
                        cx.push(Diagnostic::error(expr.node(*b).span, format!("expected a scalar, found {}", describe(expr, *b, ty)))
                            .with_help("a vector may be multiplied by a scalar only; use `dot(a, b)` or `cross(a, b)` for products of vectors"));
                        None
                    }
                    (BinOp::Mul, _, _) => {
                        let t = if tx == Ty::Vector || ty == Ty::Vector {
                            Ty::Vector
                        } else {
                            Ty::Scalar
                        };
                        Some((TNode::Mul(x, y), t, deps))
                    }
                    (BinOp::Div, _, Ty::Vector) => {
                        cx.error(
                            expr.node(*b).span,
                            format!(
                                "expected a scalar divisor, found {}",
                                describe(expr, *b, ty)
                            ),
                        );
                        None
                    }
                    (BinOp::Div, _, _) => Some((TNode::Div(x, y), tx, deps)),
                }
            }
            ExprKind::Call(fname, args) => {
                let f = fname.to_string();
                let fspan = Span::new(fname.span());
                // A body name called: a point `B(sx, sy)` in the body's frame.
                let body = if f == "ground" {
                    Some(BodyRef::Ground)
                } else if let Some(Decl::Body(k)) = names.decls.get(&f) {
                    Some(BodyRef::Body(*k))
                } else {
                    None
                };
                // (`child!` cannot be used in this inner loop: its
                // `continue` would skip an argument, not the node.)
                let typed_args: Vec<(u32, Deps)> =
                    args.iter().filter_map(|a| map.get(a).copied()).collect();
                if typed_args.len() != args.len() {
                    failed.insert(i);
                    continue;
                }
                if let Some(body) = body {
                    if args.len() != 2 {
                        // error: wrong number of arguments: expected `crank(sx, sy)`, found 3 arguments
                        cx.error(span, format!("wrong number of arguments: expected `{f}(sx, sy)` (a point in the body's frame), found {}", plural_args(args.len())));
                        None
                    } else {
                        let ok0 = scalar_arg(cx, expr, &out, args[0], typed_args[0].0);
                        let ok1 = scalar_arg(cx, expr, &out, args[1], typed_args[1].0);
                        // Rule: a point's local coordinates are constants of params.
                        let deps = typed_args[0].1.or(typed_args[1].1);
                        let mut ok = ok0 && ok1;
                        if let Some(s) = deps.time {
                            cx.error(s, "time `t` cannot appear in the local coordinates of a point: expected a constant expression of params");
                            ok = false;
                        }
                        if let Some(s) = deps.coord {
                            cx.error(s, "coordinates and points cannot appear in the local coordinates of a point: expected a constant expression of params");
                            ok = false;
                        }
                        if ok {
                            let v = out.push_spanned(
                                TNode::Vec(typed_args[0].0, typed_args[1].0),
                                Ty::Vector,
                                span,
                            );
                            folded.push(None);
                            let coord = (body != BodyRef::Ground).then_some(span);
                            Some((
                                TNode::Point(body, v),
                                Ty::Vector,
                                Deps { time: None, coord },
                            ))
                        } else {
                            None
                        }
                    }
                } else {
                    check_call(cx, expr, &mut out, &f, fspan, span, args, &typed_args)
                }
            }
        };
        match res {
            Some((n, ty, deps)) => {
                let value = fold_constant(cx, &n, &folded, &out, span);
                folded.push(value);
                let id = out.push_spanned(n, ty, span);
                map.insert(i, (id, deps));
            }
            None => {
                failed.insert(i);
            }
        }
    }
    if cx.error_count() > errors_before || !failed.is_empty() {
        return None;
    }
    let (_, deps) = map.get(&root).copied()?;
    // The typed root must be the last node (children first): it is, since
    // the root has the largest syntax index and nodes are pushed in order.
    Some(Typed { expr: out, deps })
}

fn plural_args(n: usize) -> String {
    if n == 1 {
        "1 argument".to_string()
    } else {
        format!("{n} arguments")
    }
}

/// Rule: a scalar is needed here.
fn scalar_arg(cx: &mut Ctxt, expr: &syntax::Expr, out: &TExpr, syn_i: u32, typed_i: u32) -> bool {
    let ty = out.types[typed_i as usize];
    if ty == Ty::Scalar {
        return true;
    }
    // error: expected a scalar, found a vector (point `crank.o`)
    cx.error(
        expr.node(syn_i).span,
        format!("expected a scalar, found {}", describe(expr, syn_i, ty)),
    );
    false
}

fn vector_arg(cx: &mut Ctxt, expr: &syntax::Expr, out: &TExpr, syn_i: u32, typed_i: u32) -> bool {
    let ty = out.types[typed_i as usize];
    if ty == Ty::Vector {
        return true;
    }
    // error: expected a vector, found a scalar
    cx.error(
        expr.node(syn_i).span,
        format!("expected a vector, found {}", describe(expr, syn_i, ty)),
    );
    false
}

/// Types a function call.
#[allow(clippy::too_many_arguments)] // one call site; the pieces are all distinct
fn check_call(
    cx: &mut Ctxt,
    expr: &syntax::Expr,
    out: &mut TExpr,
    f: &str,
    fspan: Span,
    span: Span,
    args: &[u32],
    typed: &[(u32, Deps)],
) -> Option<(TNode, Ty, Deps)> {
    // Rule: functions are known.
    //   error: unknown function `sine`
    let Some((_, signature)) = FUNCTIONS.iter().find(|(n, _)| *n == f) else {
        let help = if library(f).is_some() {
            format!(
                "`{f}` is a library constraint: it is a whole equation, as in `joint j: {};`",
                library(f).map_or("", |s| s.signature)
            )
        } else {
            format!(
                "expected a body (for a point `B(sx, sy)`) or one of: {}",
                function_names()
            )
        };
        cx.push(Diagnostic::error(fspan, format!("unknown function `{f}`")).with_help(help));
        return None;
    };
    let arity = match f {
        "atan2" | "pow" | "powi" | "dot" | "cross" | "rot" => 2,
        "step" => 5,
        _ => 1,
    };
    // Rule: argument counts match the signature.
    //   error: wrong number of arguments: expected `atan2(y, x)`, found 1 argument
    if args.len() != arity {
        cx.error(
            span,
            format!(
                "wrong number of arguments: expected `{signature}`, found {}",
                plural_args(args.len())
            ),
        );
        return None;
    }
    let deps = typed.iter().fold(Deps::default(), |d, (_, e)| d.or(*e));
    let a = |k: usize| typed[k].0;
    let node = match f {
        "dot" | "cross" => {
            let ok =
                vector_arg(cx, expr, out, args[0], a(0)) & vector_arg(cx, expr, out, args[1], a(1));
            if !ok {
                return None;
            }
            let n = if f == "dot" {
                TNode::Dot(a(0), a(1))
            } else {
                TNode::Cross(a(0), a(1))
            };
            return Some((n, Ty::Scalar, deps));
        }
        "norm" => {
            if !vector_arg(cx, expr, out, args[0], a(0)) {
                return None;
            }
            return Some((TNode::Norm(a(0)), Ty::Scalar, deps));
        }
        "perp" => {
            if !vector_arg(cx, expr, out, args[0], a(0)) {
                return None;
            }
            return Some((TNode::Perp(a(0)), Ty::Vector, deps));
        }
        "rot" => {
            let ok =
                scalar_arg(cx, expr, out, args[0], a(0)) & vector_arg(cx, expr, out, args[1], a(1));
            if !ok {
                return None;
            }
            return Some((TNode::Rot(a(0), a(1)), Ty::Vector, deps));
        }
        "powi" => {
            if !scalar_arg(cx, expr, out, args[0], a(0)) {
                return None;
            }
            // Rule: the exponent of `powi` is an integer literal.
            //   error: expected an integer literal exponent for `powi`
            let Some(n) = integer_literal(expr, args[1]) else {
                cx.error(expr.node(args[1]).span, "expected an integer exponent for `powi` (such as `2` or `-1`); use `pow(x, y)` for other exponents");
                return None;
            };
            TNode::Powi(a(0), n)
        }
        _ => {
            let mut ok = true;
            for (k, &arg) in args.iter().enumerate() {
                ok &= scalar_arg(cx, expr, out, arg, a(k));
            }
            if !ok {
                return None;
            }
            match f {
                "atan2" => TNode::Atan2(a(0), a(1)),
                "pow" => TNode::Pow(a(0), a(1)),
                "step" => TNode::Step([a(0), a(1), a(2), a(3), a(4)]),
                _ => TNode::F1(
                    match f {
                        "sin" => Func1::Sin,
                        "cos" => Func1::Cos,
                        "tan" => Func1::Tan,
                        "asin" => Func1::Asin,
                        "acos" => Func1::Acos,
                        "atan" => Func1::Atan,
                        "sinh" => Func1::Sinh,
                        "cosh" => Func1::Cosh,
                        "tanh" => Func1::Tanh,
                        "exp" => Func1::Exp,
                        "ln" => Func1::Ln,
                        "sqrt" => Func1::Sqrt,
                        _ => Func1::Abs,
                    },
                    a(0),
                ),
            }
        }
    };
    Some((node, Ty::Scalar, deps))
}

/// `n` or `-n` with n an integer literal without suffix.
fn integer_literal(expr: &syntax::Expr, i: u32) -> Option<i32> {
    let (neg, j) = match &expr.node(i).kind {
        ExprKind::Neg(j) => (true, *j),
        _ => (false, i),
    };
    match &expr.node(j).kind {
        ExprKind::Num { value, suffix }
            if suffix.is_empty() && value.fract() == 0.0 && value.abs() <= 1e6 =>
        {
            // Checked range above: the cast is exact.
            #[allow(clippy::cast_possible_truncation)]
            let n = *value as i32;
            Some(if neg { -n } else { n })
        }
        _ => None,
    }
}

/// Checks one equation: a user-written `lhs == rhs`, or a library call.
/// Returns the form, the dependencies, the library kind and the row count.
fn check_equation(
    cx: &mut Ctxt,
    names: &Names<'_>,
    e: &syntax::EquationDecl,
    all_params: usize,
    param_values: &[f64],
) -> Option<(Form, Deps, Option<LibKind>, usize)> {
    let lhs_root = e.lhs.node(e.lhs.root);
    let lib = match &lhs_root.kind {
        ExprKind::Call(f, args) => library(&f.to_string()).map(|s| (s, f, args)),
        _ => None,
    };
    match (&e.rhs, lib) {
        (Some(rhs), None) => {
            let l = check_expr(cx, names, &e.lhs, e.lhs.root, all_params);
            let r = check_expr(cx, names, rhs, rhs.root, all_params);
            let (l, r) = (l?, r?);
            if l.expr.ty() != r.expr.ty() {
                // error: expected a scalar, found a vector: both sides of `==` have the same type
                cx.push(
                    Diagnostic::error(
                        rhs.span(),
                        format!(
                            "expected {}, found {}",
                            ty_name(l.expr.ty()),
                            describe(rhs, rhs.root, r.expr.ty())
                        ),
                    )
                    .with_label(format!("the left side is {}", ty_name(l.expr.ty()))),
                );
                return None;
            }
            let rows = if l.expr.ty() == Ty::Vector { 2 } else { 1 };
            let deps = l.deps.or(r.deps);
            Some((
                Form::User {
                    lhs: l.expr,
                    rhs: r.expr,
                },
                deps,
                None,
                rows,
            ))
        }
        (Some(_), Some((spec, f, _))) => {
            // error: `revolute(…)` is a whole equation and cannot be compared with `==`
            cx.push(
                Diagnostic::error(Span::new(f.span()), format!("`{}` is a library constraint, a whole equation: it cannot be compared with `==`", spec.name))
                    .with_help(format!("write `{} {}: {};`", e.keyword.as_str(), e.name, spec.signature)),
            );
            None
        }
        (None, None) => {
            // error: expected `==` and a right-hand side, or a library constraint
            let found = match &lhs_root.kind {
                ExprKind::Call(f, _) => format!("unknown library constraint `{f}`"),
                _ => "an expression without `==`".to_string(),
            };
            let span = match &lhs_root.kind {
                ExprKind::Call(f, _) => Span::new(f.span()),
                _ => e.lhs.span(),
            };
            cx.push(
                Diagnostic::error(
                    span,
                    format!(
                        "expected a library constraint or an equation `lhs == rhs`, found {found}"
                    ),
                )
                .with_help(format!("the library constraints are {}", library_names())),
            );
            None
        }
        (None, Some((spec, _, args))) => {
            check_library(cx, names, e, spec, args, all_params, param_values)
        }
    }
}

fn check_library(
    cx: &mut Ctxt,
    names: &Names<'_>,
    e: &syntax::EquationDecl,
    spec: &LibSpec,
    args: &[u32],
    all_params: usize,
    param_values: &[f64],
) -> Option<(Form, Deps, Option<LibKind>, usize)> {
    let expr = &e.lhs;
    // Rule: argument counts match the signature.
    //   error: wrong number of arguments: expected `revolute(Pi, Pj)`, found 3 arguments
    if args.len() != spec.args.len() {
        cx.error(
            expr.span(),
            format!(
                "wrong number of arguments: expected `{}`, found {}",
                spec.signature,
                plural_args(args.len())
            ),
        );
        return None;
    }
    let mut out = Vec::new();
    let mut deps = Deps::default();
    let mut ok = true;
    let mut bodies: Vec<Option<BodyRef>> = Vec::new();
    for (&a, &kind) in args.iter().zip(spec.args) {
        let node = expr.node(a);
        let (arg, body) = match kind {
            ArgKind::Body => match &node.kind {
                ExprKind::Ident(id) => {
                    let n = id.to_string();
                    if n == "ground" {
                        (Some(LibArg::Body(BodyRef::Ground)), Some(BodyRef::Ground))
                    } else if let Some(Decl::Body(k)) = names.decls.get(&n) {
                        (
                            Some(LibArg::Body(BodyRef::Body(*k))),
                            Some(BodyRef::Body(*k)),
                        )
                    } else {
                        cx.push(unknown_body(node.span, &n, &names.bodies));
                        (None, None)
                    }
                }
                _ => {
                    // error: expected a body name, found an expression
                    cx.error(
                        node.span,
                        format!("expected a body name (or `ground`) in `{}`", spec.signature),
                    );
                    (None, None)
                }
            },
            ArgKind::Point => {
                let r = check_point_arg(cx, names, expr, a, spec, all_params);
                match r {
                    Some((b, local)) => {
                        let v = eval_vector(&local, param_values);
                        finite_vector(cx, v, node.span, &local, param_values);
                        (Some(LibArg::Point(b, local)), Some(b))
                    }
                    None => (None, None),
                }
            }
            ArgKind::Vector => {
                let t = check_expr(cx, names, expr, a, all_params)
                    .and_then(|t| constant(cx, &t, "a body-fixed vector").then_some(t))
                    .and_then(|t| expect_ty(cx, t, Ty::Vector, node.span));
                match t {
                    Some(t) => {
                        let v = eval_vector(&t.expr, param_values);
                        finite_vector(cx, v, node.span, &t.expr, param_values);
                        (Some(LibArg::Vector(t.expr)), None)
                    }
                    None => (None, None),
                }
            }
            ArgKind::Scalar => {
                let t = check_expr(cx, names, expr, a, all_params).and_then(|t| {
                    if let Some(s) = t.deps.coord {
                        // error: coordinates cannot appear in a library constraint's scalar argument
                        cx.push(Diagnostic::error(s, format!("coordinates and points cannot appear in the scalar arguments of `{}`: expected an expression of params and `t`", spec.name))
                            .with_help("write the equation by hand (`lhs == rhs`) for anything else"));
                        None
                    } else {
                        Some(t)
                    }
                });
                let t = t.and_then(|t| expect_ty(cx, t, Ty::Scalar, node.span));
                match t {
                    Some(t) => {
                        deps = deps.or(t.deps);
                        (Some(LibArg::Scalar(t.expr)), None)
                    }
                    None => (None, None),
                }
            }
        };
        bodies.push(body);
        match arg {
            Some(arg) => out.push(arg),
            None => ok = false,
        }
    }
    // Rule: a two-body constraint joins two different bodies.
    //   error: `revolute` joins the body `crank` to itself
    if let Some((i, j)) = spec.pair
        && let (Some(Some(bi)), Some(Some(bj))) = (bodies.get(i), bodies.get(j))
        && bi == bj
    {
        let name = match bi {
            BodyRef::Ground => "ground".to_string(),
            BodyRef::Body(k) => names.bodies.get(*k as usize).cloned().unwrap_or_default(),
        };
        cx.push(
            Diagnostic::error(
                expr.span(),
                format!("`{}` joins the body `{name}` to itself", spec.name),
            )
            .with_help("expected two different bodies"),
        );
        ok = false;
    }
    if !ok {
        return None;
    }
    // A library constraint depends on coordinates through its points and bodies.
    if bodies.iter().any(|b| matches!(b, Some(BodyRef::Body(_)))) {
        deps.coord = Some(expr.span());
    }
    Some((
        Form::Library(spec.kind, out),
        deps,
        Some(spec.kind),
        spec.rows,
    ))
}

/// A point argument: `B(sx, sy)`, `B.name` or `ground(x, y)`.
fn check_point_arg(
    cx: &mut Ctxt,
    names: &Names<'_>,
    expr: &syntax::Expr,
    a: u32,
    spec: &LibSpec,
    all_params: usize,
) -> Option<(BodyRef, TExpr)> {
    let node = expr.node(a);
    let resolve = |n: &str| -> Option<BodyRef> {
        if n == "ground" {
            Some(BodyRef::Ground)
        } else if let Some(Decl::Body(k)) = names.decls.get(n) {
            Some(BodyRef::Body(*k))
        } else {
            None
        }
    };
    match &node.kind {
        ExprKind::Call(b, args) => {
            let bn = b.to_string();
            let Some(body) = resolve(&bn) else {
                cx.push(unknown_body(Span::new(b.span()), &bn, &names.bodies));
                return None;
            };
            if args.len() != 2 {
                cx.error(node.span, format!("wrong number of arguments: expected `{bn}(sx, sy)` (a point in the body's frame), found {}", plural_args(args.len())));
                return None;
            }
            let mut parts = Vec::new();
            for &k in args {
                let t = check_expr(cx, names, expr, k, all_params)
                    .and_then(|t| constant(cx, &t, "the local coordinates of a point").then_some(t))
                    .and_then(|t| expect_ty(cx, t, Ty::Scalar, expr.node(k).span));
                parts.push(t);
            }
            let y = parts.pop().flatten();
            let x = parts.pop().flatten();
            let (x, y) = (x?, y?);
            // Concatenate the two scalar expressions into one vector expression.
            let mut local = x.expr;
            let xr = local.root();
            let off = idx(local.nodes.len());
            for (n, ty) in y.expr.nodes.into_iter().zip(y.expr.types) {
                local.push(shift(n, off), ty);
            }
            local.spans.extend(y.expr.spans);
            let yr = local.root();
            local.push(TNode::Vec(xr, yr), Ty::Vector);
            Some((body, local))
        }
        ExprKind::Field(b, f) => {
            let ExprKind::Ident(bid) = &expr.node(*b).kind else {
                cx.error(
                    node.span,
                    format!(
                        "expected a point (`B(sx, sy)`, `B.name` or `ground(x, y)`) in `{}`",
                        spec.signature
                    ),
                );
                return None;
            };
            let bn = bid.to_string();
            let Some(body) = resolve(&bn) else {
                cx.push(unknown_body(Span::new(bid.span()), &bn, &names.bodies));
                return None;
            };
            let fname = f.to_string();
            match names.points.get(&(body, fname.clone())) {
                Some(&p) => {
                    let point = names.point_decls.get(p as usize)?;
                    Some((body, point.local.clone()))
                }
                None => {
                    cx.push(
                        Diagnostic::error(
                            Span::new(f.span()),
                            format!("body `{bn}` has no point `{fname}`"),
                        )
                        .with_help(format!(
                            "expected a point declared with `point {bn}.{fname} = (sx, sy);`"
                        )),
                    );
                    None
                }
            }
        }
        _ => {
            // error: expected a point (`B(sx, sy)`, `B.name` or `ground(x, y)`)
            cx.error(
                node.span,
                format!(
                    "expected a point (`B(sx, sy)`, `B.name` or `ground(x, y)`) in `{}`",
                    spec.signature
                ),
            );
            None
        }
    }
}

/// Shifts the child indices of a node by `off`.
fn shift(n: TNode, off: u32) -> TNode {
    use TNode::*;
    match n {
        Num(_) | Pi | Time | Param(_) | Coord(..) | NamedPoint(_) => n,
        Point(b, a) => Point(b, a + off),
        Vec(a, b) => Vec(a + off, b + off),
        X(a) => X(a + off),
        Y(a) => Y(a + off),
        Neg(a) => Neg(a + off),
        Add(a, b) => Add(a + off, b + off),
        Sub(a, b) => Sub(a + off, b + off),
        Mul(a, b) => Mul(a + off, b + off),
        Div(a, b) => Div(a + off, b + off),
        F1(f, a) => F1(f, a + off),
        Atan2(a, b) => Atan2(a + off, b + off),
        Pow(a, b) => Pow(a + off, b + off),
        Powi(a, k) => Powi(a + off, k),
        Step(s) => Step(s.map(|a| a + off)),
        Dot(a, b) => Dot(a + off, b + off),
        Cross(a, b) => Cross(a + off, b + off),
        Norm(a) => Norm(a + off),
        Rot(a, b) => Rot(a + off, b + off),
        Perp(a) => Perp(a + off),
    }
}

// ---------------------------------------------------------------- constant evaluation

/// Numeric value of a node: scalar or vector.
#[derive(Clone, Copy)]
enum Val {
    S(f64),
    V(f64, f64),
}

/// Evaluates a constant expression (numbers, `pi`, params) forward.
fn eval(t: &TExpr, params: &[f64]) -> Val {
    let mut v: Vec<Val> = Vec::with_capacity(t.nodes.len());
    let s = |v: &Vec<Val>, i: u32| match v.get(i as usize) {
        Some(Val::S(x)) => *x,
        _ => f64::NAN,
    };
    let w = |v: &Vec<Val>, i: u32| match v.get(i as usize) {
        Some(Val::V(x, y)) => (*x, *y),
        _ => (f64::NAN, f64::NAN),
    };
    for n in &t.nodes {
        let val = match *n {
            TNode::Num(x) => Val::S(x),
            TNode::Pi => Val::S(std::f64::consts::PI),
            TNode::Param(i) => Val::S(params.get(i as usize).copied().unwrap_or(f64::NAN)),
            // Not constant: never evaluated here (checked before).
            TNode::Time | TNode::Coord(..) => Val::S(f64::NAN),
            TNode::Point(..) | TNode::NamedPoint(_) => Val::V(f64::NAN, f64::NAN),
            TNode::Vec(a, b) => Val::V(s(&v, a), s(&v, b)),
            TNode::X(a) => Val::S(w(&v, a).0),
            TNode::Y(a) => Val::S(w(&v, a).1),
            TNode::Neg(a) => match v.get(a as usize) {
                Some(Val::V(x, y)) => Val::V(-x, -y),
                _ => Val::S(-s(&v, a)),
            },
            TNode::Add(a, b) | TNode::Sub(a, b) => {
                let sign = if matches!(n, TNode::Add(..)) {
                    1.0
                } else {
                    -1.0
                };
                match (v.get(a as usize), v.get(b as usize)) {
                    (Some(Val::V(x1, y1)), Some(Val::V(x2, y2))) => {
                        Val::V(x1 + sign * x2, y1 + sign * y2)
                    }
                    _ => Val::S(s(&v, a) + sign * s(&v, b)),
                }
            }
            TNode::Mul(a, b) => match (v.get(a as usize), v.get(b as usize)) {
                (Some(Val::V(x, y)), Some(Val::S(c))) | (Some(Val::S(c)), Some(Val::V(x, y))) => {
                    Val::V(c * x, c * y)
                }
                _ => Val::S(s(&v, a) * s(&v, b)),
            },
            TNode::Div(a, b) => match v.get(a as usize) {
                Some(Val::V(x, y)) => Val::V(x / s(&v, b), y / s(&v, b)),
                _ => Val::S(s(&v, a) / s(&v, b)),
            },
            TNode::F1(f, a) => {
                let x = s(&v, a);
                Val::S(match f {
                    Func1::Sin => x.sin(),
                    Func1::Cos => x.cos(),
                    Func1::Tan => x.tan(),
                    Func1::Asin => x.asin(),
                    Func1::Acos => x.acos(),
                    Func1::Atan => x.atan(),
                    Func1::Sinh => x.sinh(),
                    Func1::Cosh => x.cosh(),
                    Func1::Tanh => x.tanh(),
                    Func1::Exp => x.exp(),
                    Func1::Ln => x.ln(),
                    Func1::Sqrt => x.sqrt(),
                    Func1::Abs => x.abs(),
                })
            }
            TNode::Atan2(a, b) => Val::S(s(&v, a).atan2(s(&v, b))),
            TNode::Pow(a, b) => Val::S(s(&v, a).powf(s(&v, b))),
            TNode::Powi(a, k) => Val::S(s(&v, a).powi(k)),
            TNode::Step([x, x0, h0, x1, h1]) => {
                let (x, x0, h0, x1, h1) = (s(&v, x), s(&v, x0), s(&v, h0), s(&v, x1), s(&v, h1));
                let u = (x - x0) / (x1 - x0);
                let sm = if u.is_nan() {
                    u
                } else if u <= 0.0 {
                    0.0
                } else if u >= 1.0 {
                    1.0
                } else {
                    u * u * (3.0 - 2.0 * u)
                };
                Val::S(h0 + (h1 - h0) * sm)
            }
            TNode::Dot(a, b) => {
                let (p, q) = (w(&v, a), w(&v, b));
                Val::S(p.0 * q.0 + p.1 * q.1)
            }
            TNode::Cross(a, b) => {
                let (p, q) = (w(&v, a), w(&v, b));
                Val::S(p.0 * q.1 - p.1 * q.0)
            }
            TNode::Norm(a) => {
                let p = w(&v, a);
                Val::S(p.0.hypot(p.1))
            }
            TNode::Rot(a, b) => {
                let (c, sn) = (s(&v, a).cos(), s(&v, a).sin());
                let p = w(&v, b);
                Val::V(c * p.0 - sn * p.1, sn * p.0 + c * p.1)
            }
            TNode::Perp(a) => {
                let p = w(&v, a);
                Val::V(-p.1, p.0)
            }
        };
        v.push(val);
    }
    v.last().copied().unwrap_or(Val::S(f64::NAN))
}

fn eval_scalar(t: &TExpr, params: &[f64]) -> f64 {
    match eval(t, params) {
        Val::S(x) => x,
        Val::V(..) => f64::NAN,
    }
}

pub(crate) fn eval_vector(t: &TExpr, params: &[f64]) -> [f64; 2] {
    match eval(t, params) {
        Val::V(x, y) => [x, y],
        Val::S(_) => [f64::NAN, f64::NAN],
    }
}
