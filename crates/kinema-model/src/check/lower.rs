//! Lowering typed expressions of a [`CheckedModel`] into the engine's arena.
//! A forward loop over flat expressions: no recursion, whatever the depth.
//!
//! The checker owns this layer and the derivation reuses it, so that the
//! phases only point down (`derive` imports `check::lower`, never the
//! reverse). The checker needs it for two rules that a small evaluator of
//! its own could not state: the values of constants ([`super::eval`]: a
//! param, a guess or a local coordinate has the value the tape and the
//! generated code compute from the same expression, in the engine's own
//! arithmetic), and the parts of equations, curves and outputs that are
//! undefined whatever the coordinates and time once the engine has
//! simplified them (`1 / (B.x − B.x)`: [`Lowerer::lower_reporting`]).
//! Both depend on exactly how the arena folds and simplifies; a second
//! evaluator would have to copy those rules and could drift from them. The
//! layer reads only the checked model's types and [`crate::algebra`], so
//! it sits at the bottom of the checking phase, under the rules that use
//! it and under the derivation that differentiates what it builds.

use kinema_expr::{Arena, ExprId, Factor, Term};

use super::{BodyRef, CheckedModel, Comp, TExpr, TNode, Ty};
use crate::algebra::{Vec2, VecAlgebra};
use crate::idx;
use kinema_index::{Axis, Body};

/// A lowered value: scalar or vector.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Value {
    S(ExprId),
    V(Vec2),
}

/// Why a lowered expression is undefined (see [`Arena::is_undefined`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Undefined {
    /// The node is a divisor that is identically zero.
    ZeroDivisor,
    /// The node is a divisor that is a nonzero number whose reciprocal is
    /// beyond f64's range (`1e-320`): the quotient cannot be formed.
    TinyDivisor,
    /// The node's value is undefined though its operands' are not.
    Value,
}

/// The symbols of a model in an arena, and the lowered named points.
pub(crate) struct Lowerer<'m> {
    /// The model (its named points); `None` when lowering constants.
    pub(crate) model: Option<&'m CheckedModel>,
    pub(crate) params: Vec<ExprId>,
    /// `[x, y, phi]` per body.
    pub(crate) coords: Vec<[ExprId; 3]>,
    /// `[x_dot, y_dot, phi_dot]` per body (the derivation's velocity symbols).
    pub(crate) velocities: Vec<[ExprId; 3]>,
    /// The coordinates of their own (`coord` items), after the bodies' in q.
    pub(crate) extra: Vec<ExprId>,
    pub(crate) time: ExprId,
    /// Local coordinates of each named point.
    pub(crate) point_locals: Vec<Vec2>,
}

impl<'m> Lowerer<'m> {
    /// Creates the symbols: params, then coordinates (bodies in order, x, y,
    /// phi), then time; and lowers the named points' local coordinates.
    pub(crate) fn new(arena: &mut Arena, model: &'m CheckedModel) -> Self {
        let params = model
            .params
            .iter()
            .enumerate()
            .map(|(i, p)| arena.parameter(&p.name, idx(i)))
            .collect();
        let coords = model
            .bodies
            .iter()
            .enumerate()
            .map(|(k, b)| {
                Axis::ALL.map(|a| {
                    let q = Body::new(k).coord(a).index();
                    arena.coordinate(&format!("{}.{}", b.name, a.name()), idx(q))
                })
            })
            .collect();
        let nb = 3 * model.bodies.len();
        let extra = model
            .coords
            .iter()
            .enumerate()
            .map(|(k, c)| arena.coordinate(&c.name, idx(nb + k)))
            .collect();
        // Time before the velocities: the order in which derive.rs created
        // symbols before the lowerer made velocities.
        let time = arena.time();
        let velocities = model
            .bodies
            .iter()
            .enumerate()
            .map(|(k, b)| {
                Axis::ALL.map(|a| {
                    let q = Body::new(k).coord(a).index();
                    arena.velocity(&format!("{}.{}_dot", b.name, a.name()), idx(q))
                })
            })
            .collect();
        let mut me = Lowerer {
            model: Some(model),
            params,
            coords,
            velocities,
            extra,
            time,
            point_locals: Vec::new(),
        };
        let mut locals = Vec::with_capacity(model.points.len());
        for p in &model.points {
            locals.push(me.vector(arena, &p.local));
        }
        me.point_locals = locals;
        me
    }

    /// A lowerer for constant expressions in which every param has been
    /// replaced by its value: no symbols but time, no bodies, no points.
    pub(crate) fn constants(arena: &mut Arena) -> Lowerer<'static> {
        Lowerer {
            model: None,
            params: Vec::new(),
            coords: Vec::new(),
            velocities: Vec::new(),
            extra: Vec::new(),
            time: arena.time(),
            point_locals: Vec::new(),
        }
    }

    /// Global position of the body-fixed point with local coordinates `s`.
    pub(crate) fn global(&self, arena: &mut Arena, body: BodyRef, s: Vec2) -> Vec2 {
        match body {
            BodyRef::Ground => s,
            BodyRef::Body(k) => {
                let [x, y, phi] = self.coords[k as usize];
                let a = arena.rot(phi, s);
                arena.vadd(Vec2::new(x, y), a)
            }
        }
    }

    /// A body-fixed vector expressed globally: `A(φ) v`.
    pub(crate) fn rotate(&self, arena: &mut Arena, body: BodyRef, v: Vec2) -> Vec2 {
        match body {
            BodyRef::Ground => v,
            BodyRef::Body(k) => arena.rot(self.coords[k as usize][2], v),
        }
    }

    /// The angle of a body (0 for ground).
    pub(crate) fn angle(&self, arena: &mut Arena, body: BodyRef) -> ExprId {
        match body {
            BodyRef::Ground => arena.num(0.0),
            BodyRef::Body(k) => self.coords[k as usize][2],
        }
    }

    /// Lowers a scalar expression (a vector one gives its x component; the
    /// checker never lets that happen).
    pub(crate) fn scalar(&self, arena: &mut Arena, t: &TExpr) -> ExprId {
        match self.lower(arena, t) {
            Value::S(e) => e,
            Value::V(v) => v.x,
        }
    }

    /// Lowers a vector expression.
    pub(crate) fn vector(&self, arena: &mut Arena, t: &TExpr) -> Vec2 {
        match self.lower(arena, t) {
            Value::V(v) => v,
            Value::S(e) => Vec2::new(e, e),
        }
    }

    /// Lowers a typed expression, forward over its nodes.
    ///
    /// Chains of scalar `+`/`-` (and of `*`/`/`) are built as one n-ary sum
    /// (product) in a single engine call: building `a + b + c + …` pairwise
    /// would copy the growing sum at every step.
    pub(crate) fn lower(&self, arena: &mut Arena, t: &TExpr) -> Value {
        self.lower_reporting(arena, t, &mut |_, _| {})
    }

    /// [`lower`](Self::lower), calling `report(node, why)` for each typed
    /// node where the value first becomes undefined: an identically zero
    /// divisor, or a node whose value is undefined while its operands' are
    /// not (`ln(B.x − B.x)`).
    pub(crate) fn lower_reporting(
        &self,
        arena: &mut Arena,
        t: &TExpr,
        report: &mut dyn FnMut(u32, Undefined),
    ) -> Value {
        let nan = arena.num(f64::NAN);
        self.lower_with(arena, t, report, nan)
    }

    /// Local coordinates of curve `k` of the model at `arg` (an expression
    /// substituted for the curve's parameter); NaN for a curve that does
    /// not exist.
    pub(crate) fn curve(&self, arena: &mut Arena, k: u32, arg: ExprId) -> Vec2 {
        self.curve_reporting(arena, k, arg, &mut |_, _| {})
    }

    /// [`curve`](Self::curve), reporting undefined parts as
    /// [`lower_reporting`](Self::lower_reporting) does.
    pub(crate) fn curve_reporting(
        &self,
        arena: &mut Arena,
        k: u32,
        arg: ExprId,
        report: &mut dyn FnMut(u32, Undefined),
    ) -> Vec2 {
        match self.model.and_then(|m| m.curves.get(k as usize)) {
            Some(c) => match self.lower_with(arena, &c.local, report, arg) {
                Value::V(v) => v,
                Value::S(e) => Vec2::new(e, e),
            },
            None => {
                let nan = arena.num(f64::NAN);
                Vec2::new(nan, nan)
            }
        }
    }

    /// The coordinate of its own `k` (NaN if there is none).
    pub(crate) fn extra(&self, arena: &mut Arena, k: u32) -> ExprId {
        match self.extra.get(k as usize) {
            Some(&e) => e,
            None => arena.num(f64::NAN),
        }
    }

    /// [`lower_reporting`](Self::lower_reporting) with `arg` standing for
    /// a curve's parameter. One forward pass over the nodes (children
    /// first); a chain of scalar sums (or products) is built by its root
    /// as one n-ary node ([`Self::sum_chain`], [`Self::product_chain`]).
    fn lower_with(
        &self,
        arena: &mut Arena,
        t: &TExpr,
        report: &mut dyn FnMut(u32, Undefined),
        arg: ExprId,
    ) -> Value {
        // Operands of the node being lowered (chain operands for chain roots).
        let mut operands: Vec<u32> = Vec::new();
        let mut vals: Vec<Value> = Vec::with_capacity(t.nodes.len());
        let zero = arena.num(0.0);
        let chains = Chains::new(t);
        for (i, n) in t.nodes.iter().enumerate() {
            if chains.inner[i] {
                // Built by the root of its chain.
                vals.push(Value::S(zero));
                continue;
            }
            operands.clear();
            // A divisor found undefined (0, or a number with no finite
            // reciprocal) has been reported at its own span.
            let mut reported = false;
            let v = match *n {
                TNode::Add(..) | TNode::Sub(..) if chains.is_sum(i) => {
                    Self::sum_chain(arena, &chains, &vals, i, &mut operands, zero)
                }
                TNode::Mul(..) | TNode::Div(..) if chains.is_product(i) => {
                    let (v, divisor_reported) =
                        Self::product_chain(arena, &chains, &vals, i, &mut operands, zero, report);
                    reported = divisor_reported;
                    v
                }
                _ => match self.leaf(arena, n, &vals, arg, zero) {
                    Some(v) => v,
                    None => operation(arena, n, &vals, zero),
                },
            };
            if undefined(arena, v) && !reported {
                let chain = chains.is_sum(i) || chains.is_product(i);
                let lowered = Lowered {
                    arena,
                    vals: &vals,
                    zero,
                };
                report_undefined(
                    lowered,
                    UndefinedNode { n, i, chain },
                    &mut operands,
                    report,
                );
            }
            vals.push(v);
        }
        vals.last().copied().unwrap_or(Value::S(zero))
    }

    /// The chain of scalar sums and differences rooted at node `i` as one
    /// linear combination Σ ±operand (signs pushed through `−`); its
    /// operands are recorded in `operands`.
    fn sum_chain(
        arena: &mut Arena,
        chains: &Chains<'_>,
        vals: &[Value],
        i: usize,
        operands: &mut Vec<u32>,
        zero: ExprId,
    ) -> Value {
        let links = chains.operands(i, |n| match *n {
            TNode::Add(a, b) => Some((a, b, false)),
            TNode::Sub(a, b) => Some((a, b, true)),
            _ => None,
        });
        let mut terms = Vec::with_capacity(links.len());
        for (k, sign) in links {
            operands.push(k);
            terms.push(Term {
                coeff: sign,
                expr: scalar(vals, k, zero),
            });
        }
        Value::S(arena.linear(0.0, &terms))
    }

    /// The chain of scalar products and quotients rooted at node `i` as
    /// one product Π operand^±1 (a divisor gets exponent −1); a divisor
    /// that is the number 0 is reported, and one that is a number whose
    /// reciprocal overflows when the product is undefined. Returns the
    /// value and whether such a divisor was reported.
    fn product_chain(
        arena: &mut Arena,
        chains: &Chains<'_>,
        vals: &[Value],
        i: usize,
        operands: &mut Vec<u32>,
        zero: ExprId,
        report: &mut dyn FnMut(u32, Undefined),
    ) -> (Value, bool) {
        let links = chains.operands(i, |n| match *n {
            TNode::Mul(a, b) => Some((a, b, false)),
            TNode::Div(a, b) => Some((a, b, true)),
            _ => None,
        });
        let mut reported = false;
        let mut factors = Vec::with_capacity(links.len());
        // Divisors that are numbers with no finite reciprocal: the cause if
        // the product is undefined (the engine folds a product's numbers as
        // a set, so 1/(5e-324 · 1e308 · t) is defined).
        let mut tiny = Vec::new();
        for (k, exp) in links {
            let base = scalar(vals, k, zero);
            if exp < 0.0 && base == zero {
                report(k, Undefined::ZeroDivisor);
                reported = true;
            } else if exp < 0.0 && arena.as_num(base).is_some_and(|v| !(1.0 / v).is_finite()) {
                tiny.push(k);
            }
            operands.push(k);
            factors.push(Factor { base, exp });
        }
        let product = arena.product_of(1.0, &factors);
        if !reported && !tiny.is_empty() && undefined(arena, Value::S(product)) {
            for k in tiny {
                report(k, Undefined::TinyDivisor);
            }
            reported = true;
        }
        (Value::S(product), reported)
    }

    /// A node that names something of the model (a number, π, t, a param,
    /// a coordinate or velocity, the curve's parameter, a point: r + A s′);
    /// `None` for an operation.
    fn leaf(
        &self,
        arena: &mut Arena,
        n: &TNode,
        vals: &[Value],
        arg: ExprId,
        zero: ExprId,
    ) -> Option<Value> {
        Some(match *n {
            TNode::Num(x) => Value::S(arena.num(x)),
            TNode::Pi => Value::S(arena.num(std::f64::consts::PI)),
            TNode::Time => Value::S(self.time),
            TNode::Param(i) => Value::S(self.params.get(i as usize).copied().unwrap_or(zero)),
            TNode::Coord(k, Comp::Extra) => Value::S(self.extra(arena, k)),
            TNode::Coord(k, c) => {
                let xyz = self.coords[k as usize];
                Value::S(match c {
                    Comp::X => xyz[0],
                    Comp::Y => xyz[1],
                    Comp::Phi | Comp::Extra => xyz[2],
                })
            }
            TNode::Vel(k, c) => Value::S(
                self.velocities
                    .get(k as usize)
                    .map_or(zero, |v| v[c as usize]),
            ),
            TNode::CurveArg => Value::S(arg),
            TNode::Point(body, local) => {
                let l = vector(vals, local, zero);
                Value::V(self.global(arena, body, l))
            }
            TNode::NamedPoint(p) => {
                // A constant has no named point (the checker's rule).
                let point = self.model.and_then(|m| m.points.get(p as usize));
                let l = self.point_locals.get(p as usize).copied();
                match (point, l) {
                    (Some(point), Some(l)) => Value::V(self.global(arena, point.body, l)),
                    _ => {
                        let nan = arena.num(f64::NAN);
                        Value::V(Vec2::new(nan, nan))
                    }
                }
            }
            _ => return None,
        })
    }
}

/// Whether a lowered value (either component of a vector) is undefined.
fn undefined(arena: &Arena, v: Value) -> bool {
    match v {
        Value::S(e) => arena.is_undefined(e),
        Value::V(v) => arena.is_undefined(v.x) || arena.is_undefined(v.y),
    }
}

/// Operand `i` as a scalar (a vector's x; 0 when missing).
fn scalar(vals: &[Value], i: u32, zero: ExprId) -> ExprId {
    match vals.get(i as usize) {
        Some(Value::S(e)) => *e,
        Some(Value::V(v)) => v.x,
        None => zero,
    }
}

/// Operand `i` as a vector (a scalar twice; 0 when missing).
fn vector(vals: &[Value], i: u32, zero: ExprId) -> Vec2 {
    match vals.get(i as usize) {
        Some(Value::V(v)) => *v,
        Some(Value::S(e)) => Vec2::new(*e, *e),
        None => Vec2::new(zero, zero),
    }
}

/// An operation on lowered operands, scalar or vector by their types: the
/// `Vec2` algebra for vectors (u ± v, c u, u / c, A(θ) v, R v, uᵀv, u × v,
/// |u|), the arena's constructors for scalars.
fn operation(arena: &mut Arena, n: &TNode, vals: &[Value], zero: ExprId) -> Value {
    let s = |i: u32| scalar(vals, i, zero);
    let w = |i: u32| vector(vals, i, zero);
    let get = |i: u32| vals.get(i as usize);
    match *n {
        TNode::Vec(a, b) => Value::V(Vec2::new(s(a), s(b))),
        TNode::X(a) => Value::S(w(a).x),
        TNode::Y(a) => Value::S(w(a).y),
        TNode::Neg(a) => match get(a) {
            Some(Value::V(v)) => Value::V(arena.vneg(*v)),
            _ => Value::S(arena.neg(s(a))),
        },
        TNode::Add(a, b) => match (get(a), get(b)) {
            (Some(Value::V(u)), Some(Value::V(v))) => Value::V(arena.vadd(*u, *v)),
            _ => Value::S(arena.add(s(a), s(b))),
        },
        TNode::Sub(a, b) => match (get(a), get(b)) {
            (Some(Value::V(u)), Some(Value::V(v))) => Value::V(arena.vsub(*u, *v)),
            _ => Value::S(arena.sub(s(a), s(b))),
        },
        TNode::Mul(a, b) => match (get(a), get(b)) {
            (Some(Value::V(u)), Some(Value::S(c))) | (Some(Value::S(c)), Some(Value::V(u))) => {
                Value::V(arena.vscale(*c, *u))
            }
            _ => Value::S(arena.mul(s(a), s(b))),
        },
        TNode::Div(a, b) => match get(a) {
            Some(Value::V(u)) => Value::V(arena.vdiv(*u, s(b))),
            _ => Value::S(arena.div(s(a), s(b))),
        },
        TNode::F1(f, a) => Value::S(arena.unary(f, s(a))),
        TNode::Sqrt(a) => Value::S(arena.sqrt(s(a))),
        TNode::Atan2(a, b) => Value::S(arena.atan2(s(a), s(b))),
        TNode::Pow(a, b) => Value::S(arena.pow(s(a), s(b))),
        TNode::Powi(a, k) => Value::S(arena.powi(s(a), k)),
        TNode::Step([x, x0, h0, x1, h1]) => Value::S(arena.step(s(x), s(x0), s(h0), s(x1), s(h1))),
        TNode::Dot(a, b) => Value::S(arena.dot(w(a), w(b))),
        TNode::Cross(a, b) => Value::S(arena.cross(w(a), w(b))),
        TNode::Norm(a) => Value::S(arena.norm(w(a))),
        TNode::Rot(a, b) => Value::V(arena.rot(s(a), w(b))),
        TNode::Perp(a) => Value::V(arena.perp(w(a))),
        // Leaves are lowered by `Lowerer::leaf`.
        TNode::Num(_)
        | TNode::Pi
        | TNode::Time
        | TNode::Param(_)
        | TNode::Coord(..)
        | TNode::Vel(..)
        | TNode::CurveArg
        | TNode::Point(..)
        | TNode::NamedPoint(_) => Value::S(zero),
    }
}

/// The nodes lowered so far (children before parents), in the arena their
/// values live in, with that arena's 0.
#[derive(Clone, Copy)]
struct Lowered<'a> {
    arena: &'a Arena,
    vals: &'a [Value],
    zero: ExprId,
}

/// A node whose value came out undefined: its kind, its index, and whether
/// it is the root of a sum or product chain.
#[derive(Clone, Copy)]
struct UndefinedNode<'a> {
    n: &'a TNode,
    i: usize,
    chain: bool,
}

/// Node `i` lowered to an undefined value: reported where it starts — at
/// the node itself, or at a vector's divisor that is 0 — unless an operand
/// already was undefined (reported there). A `chain` root's operands are
/// its links: its divisor node, inside the chain, has no value of its own
/// (a placeholder 0 that must not read as a zero divisor).
fn report_undefined(
    lowered: Lowered<'_>,
    node: UndefinedNode<'_>,
    operands: &mut Vec<u32>,
    report: &mut dyn FnMut(u32, Undefined),
) {
    let Lowered { arena, vals, zero } = lowered;
    let UndefinedNode { n, i, chain } = node;
    if operands.is_empty() {
        children(n, operands);
    }
    let inherited = operands
        .iter()
        .any(|&k| vals.get(k as usize).is_some_and(|&c| undefined(arena, c)));
    match *n {
        _ if inherited => {}
        // A vector divided by zero (scalar quotients are chains).
        TNode::Div(_, b) if !chain && scalar(vals, b, zero) == zero => {
            report(b, Undefined::ZeroDivisor);
        }
        _ => report(idx(i), Undefined::Value),
    }
}

/// The operands of a typed node.
fn children(n: &TNode, out: &mut Vec<u32>) {
    match *n {
        TNode::Num(_)
        | TNode::Pi
        | TNode::Time
        | TNode::Param(_)
        | TNode::Coord(..)
        | TNode::Vel(..) => {}
        TNode::CurveArg => {}
        TNode::NamedPoint(_) => {}
        TNode::Point(_, a)
        | TNode::X(a)
        | TNode::Y(a)
        | TNode::Neg(a)
        | TNode::F1(_, a)
        | TNode::Sqrt(a)
        | TNode::Powi(a, _)
        | TNode::Norm(a)
        | TNode::Perp(a) => out.push(a),
        TNode::Vec(a, b)
        | TNode::Add(a, b)
        | TNode::Sub(a, b)
        | TNode::Mul(a, b)
        | TNode::Div(a, b)
        | TNode::Atan2(a, b)
        | TNode::Pow(a, b)
        | TNode::Dot(a, b)
        | TNode::Cross(a, b)
        | TNode::Rot(a, b) => out.extend([a, b]),
        TNode::Step(k) => out.extend(k),
    }
}

/// Which nodes are inside a chain of scalar sums (or products) and are
/// built by the chain's root.
struct Chains<'t> {
    t: &'t TExpr,
    inner: Vec<bool>,
}

impl Chains<'_> {
    /// The operands of the chain rooted at node `i`, left to right, each
    /// with its sign: `link` splits a chained node into (left, right,
    /// whether the right operand is inverted — `−` for a sum, a divisor's
    /// exponent −1 for a product); signs multiply down the chain.
    fn operands(
        &self,
        i: usize,
        link: impl Fn(&TNode) -> Option<(u32, u32, bool)>,
    ) -> Vec<(u32, f64)> {
        let mut out = Vec::new();
        let mut stack = vec![(idx(i), 1.0)];
        while let Some((k, sign)) = stack.pop() {
            let chained = k as usize == i || self.inner[k as usize];
            match self.t.nodes.get(k as usize).and_then(&link) {
                Some((a, b, inverted)) if chained => {
                    stack.push((b, if inverted { -sign } else { sign }));
                    stack.push((a, sign));
                }
                _ => out.push((k, sign)),
            }
        }
        out
    }
}

impl<'t> Chains<'t> {
    fn new(t: &'t TExpr) -> Self {
        let n = t.nodes.len();
        let mut inner = vec![false; n];
        let scalar = |k: u32| t.types.get(k as usize) == Some(&Ty::Scalar);
        for (i, node) in t.nodes.iter().enumerate() {
            if !scalar(idx(i)) {
                continue;
            }
            match *node {
                TNode::Add(a, b) | TNode::Sub(a, b) => {
                    for c in [a, b] {
                        if scalar(c)
                            && matches!(t.nodes[c as usize], TNode::Add(..) | TNode::Sub(..))
                        {
                            inner[c as usize] = true;
                        }
                    }
                }
                TNode::Mul(a, b) | TNode::Div(a, b) => {
                    for c in [a, b] {
                        if scalar(c)
                            && matches!(t.nodes[c as usize], TNode::Mul(..) | TNode::Div(..))
                        {
                            inner[c as usize] = true;
                        }
                    }
                }
                _ => {}
            }
        }
        Chains { t, inner }
    }

    /// A scalar sum that is the root of its chain.
    fn is_sum(&self, i: usize) -> bool {
        self.t.types[i] == Ty::Scalar && !self.inner[i]
    }

    /// A scalar product that is the root of its chain.
    fn is_product(&self, i: usize) -> bool {
        self.t.types[i] == Ty::Scalar && !self.inner[i]
    }
}
