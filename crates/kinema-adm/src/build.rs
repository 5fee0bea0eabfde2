//! Builds the model kinema checks — kinema-model's syntax tree — straight
//! from an ADM model, for `kinema run model.adm`: no `.kin` text is printed
//! and parsed again, and every name and expression carries the line and
//! column of the JSON value it comes from, so a message of the checker or
//! of the derivation points into the ADM file.
//!
//! It is the crate's one translation of an ADM model: `kinema import`
//! prints this tree ([`crate::to_kin`], through kinema-model's printer),
//! so the text parses back to it: the same items in the same order, the
//! same identifiers ([`Names`]), the same expressions node for node (a
//! negative number is `-` applied to its magnitude, as the parser reads
//! it), the same doc comments. The mapping is the table of
//! [`crate::emit`].

use kinema_model::syntax::{
    BinOp, BodyDecl, BodyVelocity, EquationDecl, EquationKeyword, Expr, ExprKind, ExprNode,
    ForceDecl, GravityDecl, Item, Mechanism, Name, PointDecl,
};
use kinema_model::{Diagnostics, Parsed, ParsedModel, Source, Span};

use crate::adm::{Body, Constraint, ConstraintKind, Fields, Force, ForceKind, Model, Vec2};
use crate::emit::{Names, RackPinion, SumTerm, body_name, comment_text, normalised};
use crate::fun::{self, BinOp as FunOp, Func, Func2, Node};
use crate::pos::Pos;

/// The parsed form of `model` read from `source`: kinema-model's front
/// door takes it from here (check, derive), and every message of those
/// phases points into the ADM file's text.
///
/// ```
/// use kinema_model::Source;
/// let adm = Source::new("pendulum.adm", r#"{ "name": "pendulum",
///   "bodies": [ { "name": "gear", "id": 1, "q0": [1, 0, 0] } ],
///   "constraints": [
///     { "name": "x", "id": 1, "type": "AbsoluteX", "body1": 1, "sP1": [-1, 0], "fun": "0" },
///     { "name": "y", "id": 2, "type": "AbsoluteY", "body1": 1, "sP1": [-1, 0], "fun": "0" },
///     { "name": "swing", "id": 3, "type": "AbsoluteAngle", "body1": 1, "fun": "sin(t)" } ] }"#);
/// let model = kinema_adm::Model::parse(&adm).unwrap();
/// let derived = kinema_adm::parsed(&model, adm).derive().unwrap();
/// assert_eq!(derived.checked().bodies[0].name, "gear");
/// ```
#[must_use]
pub fn parsed(model: &Model, source: Source) -> Parsed {
    Parsed::new(source, build(model))
}

/// The model of `model`, ready for [`ParsedModel::check`] (the syntax tree
/// of [`parsed`], without its source).
#[must_use]
pub fn build(model: &Model) -> ParsedModel {
    ParsedModel::from_syntax(mechanism(model))
}

/// The syntax tree of `model` (see [`build`]).
#[must_use]
pub fn mechanism(model: &Model) -> Mechanism {
    let names = Names::of(model);
    let mut items = Vec::new();
    for (body, ident) in model.bodies.iter().zip(&names.bodies) {
        items.push(Item::Body(body_decl(model, body, ident)));
        items.extend(vis_points(body, ident).map(Item::Point));
    }
    for (c, idents) in model.constraints.iter().zip(&names.constraints) {
        items.extend(
            constraint_decls(c, idents, &names.bodies)
                .into_iter()
                .map(Item::Equation),
        );
    }
    if crate::dynamics::has_dynamics(model) {
        items.push(Item::Gravity(gravity_decl(model)));
        let forces = crate::dynamics::force_names(model);
        for (f, name) in model.forces.iter().zip(forces) {
            items.extend(force_decl(f, name, &names.bodies).map(Item::Force));
        }
    }
    let at = model.fields.get("name").unwrap_or_else(Pos::start);
    Mechanism {
        docs: Vec::new(),
        name: Name::new(names.mechanism, span(at)),
        items,
        errors: Diagnostics::new(),
    }
}

/// The span of one character at `pos` (kinema-model's columns are 0-based).
fn span(pos: Pos) -> Span {
    pos.span()
}

/// The tree of a `fun` expression alone, every node at the start of the
/// text (for printing it: [`crate::fun::Expr::to_kin`]). `e` must have a
/// node.
pub(crate) fn fun_expr(e: &fun::Expr) -> Expr {
    let mut t = Tree::new();
    let root = t.fun(e, &Fields::default(), "");
    t.finish(root)
}

/// A doc comment as the parser keeps `/// text`.
fn doc(text: String) -> Vec<String> {
    vec![text]
}

/// Builds one flat expression, children before parents.
struct Tree {
    nodes: Vec<ExprNode>,
}

impl Tree {
    fn new() -> Tree {
        Tree { nodes: Vec::new() }
    }

    fn push(&mut self, kind: ExprKind, span: Span) -> u32 {
        let id = u32::try_from(self.nodes.len()).expect("an ADM expression has < 2^32 nodes");
        self.nodes.push(ExprNode { kind, span });
        id
    }

    fn span(&self, i: u32) -> Span {
        self.nodes[i as usize].span
    }

    fn finish(self, root: u32) -> Expr {
        Expr {
            nodes: self.nodes,
            root,
        }
    }

    /// A number as the parser reads the printed one: a literal of its
    /// magnitude, negated when negative.
    fn num(&mut self, x: f64, at: Span) -> u32 {
        let lit = self.push(
            ExprKind::Num {
                value: x.abs(),
                suffix: String::new(),
            },
            at,
        );
        if x < 0.0 {
            self.push(ExprKind::Neg(lit), at)
        } else {
            lit
        }
    }

    fn ident(&mut self, name: &str, at: Span) -> u32 {
        self.push(ExprKind::Ident(Name::new(name, at)), at)
    }

    fn call(&mut self, name: &str, at: Span, args: Vec<u32>) -> u32 {
        let span = args.last().map_or(at, |&a| at.to(self.span(a)));
        self.push(ExprKind::Call(Name::new(name, at), args), span)
    }

    fn bin(&mut self, op: BinOp, a: u32, b: u32) -> u32 {
        let span = self.span(a).to(self.span(b));
        self.push(ExprKind::Binary(op, a, b), span)
    }

    fn pair(&mut self, v: Vec2, at: Span) -> u32 {
        let x = self.num(v[0], at);
        let y = self.num(v[1], at);
        self.push(ExprKind::Tuple(vec![x, y]), at)
    }

    /// `B(sx, sy)`, or `ground(sx, sy)` for a body index out of range.
    fn point(&mut self, bodies: &[String], body: usize, s: Vec2, at: (Span, Span)) -> u32 {
        let x = self.num(s[0], at.1);
        let y = self.num(s[1], at.1);
        self.call(body_name(bodies, body), at.0, vec![x, y])
    }

    /// A `fun` expression, node for node as [`fun::Expr::to_kin`] writes
    /// it (`log` → `ln`, `log10(x)` → `ln(x) / ln(10)`, an integer power
    /// → `powi`, another → `pow`), each node at its character of the
    /// `fun` string `key` of `fields`.
    fn fun(&mut self, e: &fun::Expr, fields: &Fields, key: &str) -> u32 {
        let nodes = e.nodes();
        let exponents = e.int_exponents();
        let int = |b: u32| exponents.get(b as usize).copied().flatten();
        // Only the nodes the printed text shows: an integer exponent is
        // printed as its value, not as its own expression.
        let mut shown = vec![false; nodes.len()];
        if let Some(last) = shown.last_mut() {
            *last = true;
        }
        for i in (0..nodes.len()).rev() {
            if !shown[i] {
                continue;
            }
            match nodes[i] {
                Node::Num(_) | Node::Pi | Node::T => {}
                Node::Neg(a) | Node::Call(_, a) => shown[a as usize] = true,
                Node::Bin(FunOp::Pow, a, b) | Node::Call2(Func2::Power, a, b)
                    if int(b).is_some() =>
                {
                    shown[a as usize] = true;
                }
                Node::Bin(_, a, b) | Node::Call2(_, a, b) => {
                    shown[a as usize] = true;
                    shown[b as usize] = true;
                }
            }
        }
        // Each node at its character, found in one pass over the string.
        let exact = fields.char_positions(key, e.text());
        let whole = fields.get(key).unwrap_or_else(Pos::start);
        let mut ids = vec![0u32; nodes.len()];
        for (i, node) in nodes.iter().enumerate() {
            if !shown[i] {
                continue;
            }
            let offset = e.offset_of(i);
            let at = span(
                exact
                    .as_ref()
                    .and_then(|v| v.get(offset).copied())
                    .unwrap_or(whole),
            );
            let id = |k: u32| ids[k as usize];
            ids[i] = match *node {
                Node::Num(x) => self.num(x, at),
                Node::Pi => self.ident("pi", at),
                Node::T => self.ident("t", at),
                Node::Neg(a) => {
                    let s = at.to(self.span(id(a)));
                    self.push(ExprKind::Neg(id(a)), s)
                }
                Node::Bin(FunOp::Add, a, b) => self.bin(BinOp::Add, id(a), id(b)),
                Node::Bin(FunOp::Sub, a, b) => self.bin(BinOp::Sub, id(a), id(b)),
                Node::Bin(FunOp::Mul, a, b) => self.bin(BinOp::Mul, id(a), id(b)),
                Node::Bin(FunOp::Div, a, b) => self.bin(BinOp::Div, id(a), id(b)),
                Node::Bin(FunOp::Pow, a, b) | Node::Call2(Func2::Power, a, b) => match int(b) {
                    #[expect(clippy::cast_precision_loss, reason = "|n| <= 1e6")]
                    Some(n) => {
                        let n = self.num(n as f64, at);
                        self.call("powi", at, vec![id(a), n])
                    }
                    None => self.call("pow", at, vec![id(a), id(b)]),
                },
                Node::Call(Func::Log10, a) => {
                    let ln = self.call("ln", at, vec![id(a)]);
                    let ten = self.num(10.0, at);
                    let ln10 = self.call("ln", at, vec![ten]);
                    self.bin(BinOp::Div, ln, ln10)
                }
                Node::Call(f, a) => self.call(f.kin_name(), at, vec![id(a)]),
                Node::Call2(Func2::Atan2, a, b) => self.call("atan2", at, vec![id(a), id(b)]),
            };
        }
        *ids.last()
            .expect("a parsed `fun` has at least one node: its root")
    }

    /// A sum of signed terms as the parser reads `a - 1.5 - b`
    /// (numbers fold into the sign), left-associative.
    fn sum(&mut self, terms: Vec<(bool, u32)>, at: Span) -> u32 {
        let mut acc: Option<u32> = None;
        for (negative, term) in terms {
            acc = Some(match (acc, negative) {
                (None, false) => term,
                (None, true) => {
                    let s = self.span(term);
                    self.push(ExprKind::Neg(term), s)
                }
                (Some(a), false) => self.bin(BinOp::Add, a, term),
                (Some(a), true) => self.bin(BinOp::Sub, a, term),
            });
        }
        acc.unwrap_or_else(|| self.num(0.0, at))
    }
}

/// Where `key` of `fields` is, or else where the element starts.
fn field_span(fields: &Fields, key: &str, element: Pos) -> Span {
    span(fields.get(key).unwrap_or(element))
}

fn body_decl(model: &Model, body: &Body, ident: &str) -> BodyDecl {
    let at = |key: &str| field_span(&body.fields, key, body.pos);
    let one = |x: f64, key: &str| {
        let mut t = Tree::new();
        let root = t.num(x, at(key));
        t.finish(root)
    };
    let [x, y, phi] = body.q0;
    let (mass, inertia) = match (crate::dynamics::has_dynamics(model), body.mass, body.jbar) {
        (true, Some(m), Some(j)) => (Some(one(m, "mass")), Some(one(j, "jbar"))),
        _ => (None, None),
    };
    let velocity = crate::dynamics::stated_velocity(model, body).map(|[vx, vy, w]| BodyVelocity {
        keyword: at("qd0"),
        value: [one(vx, "qd0"), one(vy, "qd0"), one(w, "qd0")],
    });
    BodyDecl {
        docs: doc(format!("body {} \"{}\"", body.id, comment_text(&body.name))),
        name: Name::new(ident, at("name")),
        guess: Some([one(x, "q0"), one(y, "q0"), one(phi, "q0")]),
        mass,
        inertia,
        velocity,
    }
}

/// A body's finite `vis.points` as points `p1`, `p2`, … (see
/// [`crate::emit`]).
fn vis_points<'a>(body: &'a Body, ident: &'a str) -> impl Iterator<Item = PointDecl> + 'a {
    let at = field_span(&body.fields, "vis", body.pos);
    let points = body.vis.as_ref().map_or(&[][..], |v| &v.points[..]);
    points
        .iter()
        .enumerate()
        .filter(|(_, p)| p.iter().all(|v| v.is_finite()))
        .map(move |(k, &p)| {
            let mut t = Tree::new();
            let root = t.pair(p, at);
            PointDecl {
                docs: doc(format!("vis point {}", k + 1)),
                body: Name::new(ident, at),
                name: Name::new(format!("p{}", k + 1), at),
                value: t.finish(root),
            }
        })
}

/// The equation of one constraint element.
fn constraint_decls(c: &Constraint, idents: &[String], bodies: &[String]) -> Vec<EquationDecl> {
    let at = |key: &str| field_span(&c.fields, key, c.pos);
    let head = format!(
        "constraint {} \"{}\": {}",
        c.id,
        comment_text(&c.name),
        c.kind.type_name()
    );
    let name = |k: usize| {
        let fallback = ["c", "c_2"][k.min(1)];
        Name::new(idents.get(k).map_or(fallback, String::as_str), at("name"))
    };
    let equation = |keyword, doc_text, name, (lhs, rhs): (Expr, Option<Expr>)| EquationDecl {
        docs: doc(doc_text),
        keyword,
        keyword_span: span(c.pos),
        name,
        lhs,
        rhs,
    };
    if let Some(rp) = RackPinion::of(&c.kind, bodies) {
        let ignored = crate::emit::ignored_fun(rp.fun.as_deref());
        let doc_text = format!("{head} {}{ignored}", rp.doc());
        let mut t = Tree::new();
        let root = rack_pinion_call(&mut t, &rp, &at);
        return vec![equation(
            EquationKeyword::Constraint,
            doc_text,
            name(0),
            (t.finish(root), None),
        )];
    }
    let mut t = Tree::new();
    let (keyword, doc_text, root) = one_row(&mut t, c, bodies, &head, &at);
    vec![equation(keyword, doc_text, name(0), (t.finish(root), None))]
}

/// The one equation of an element other than a RackPinion: its keyword,
/// doc comment and call (see [`crate::emit`]'s table).
fn one_row(
    t: &mut Tree,
    c: &Constraint,
    bodies: &[String],
    head: &str,
    at: &dyn Fn(&str) -> Span,
) -> (EquationKeyword, String, u32) {
    let ignored = |fun: &Option<String>| crate::emit::ignored_fun(fun.as_deref());
    let point = |t: &mut Tree, body: usize, s: Vec2, n: usize| {
        let (bkey, skey) = [("body1", "sP1"), ("body2", "sP2")][n];
        t.point(bodies, body, s, (at(bkey), at(skey)))
    };
    // `f(subject, fun)`: a driver when the fun mentions t.
    let absolute = |t: &mut Tree, f: &str, subject: u32, fun: &fun::Expr| {
        let f_t = t.fun(fun, &c.fields, "fun");
        let root = t.call(f, at("type"), vec![subject, f_t]);
        let doc_text = format!("{head}, fun \"{}\"", comment_text(fun.text()));
        (keyword(fun), doc_text, root)
    };
    match &c.kind {
        ConstraintKind::AbsoluteX { body1, sp1, fun }
        | ConstraintKind::AbsoluteY { body1, sp1, fun } => {
            let f = if matches!(c.kind, ConstraintKind::AbsoluteX { .. }) {
                "abs_x"
            } else {
                "abs_y"
            };
            let p = point(t, *body1, *sp1, 0);
            absolute(t, f, p, fun)
        }
        ConstraintKind::AbsoluteAngle { body1, fun } => {
            let b = t.ident(body_name(bodies, *body1), at("body1"));
            absolute(t, "abs_angle", b, fun)
        }
        ConstraintKind::Revolute {
            body1,
            sp1,
            body2,
            sp2,
            fun,
        } => {
            let p1 = point(t, *body1, *sp1, 0);
            let p2 = point(t, *body2, *sp2, 1);
            let root = t.call("revolute", at("type"), vec![p1, p2]);
            (
                EquationKeyword::Joint,
                format!("{head}{}", ignored(fun)),
                root,
            )
        }
        ConstraintKind::Translational {
            body1,
            sp1,
            vp1,
            body2,
            sp2,
            vp2,
            fun,
        } => {
            let p1 = point(t, *body1, *sp1, 0);
            let v1 = t.pair(normalised(*vp1).unwrap_or(*vp1), at("vP1"));
            let p2 = point(t, *body2, *sp2, 1);
            let v2 = t.pair(normalised(*vp2).unwrap_or(*vp2), at("vP2"));
            let root = t.call("translational", at("type"), vec![p1, v1, p2, v2]);
            let doc_text = format!(
                "{head}, directions vP1 = {} and vP2 = {} normalised{}",
                crate::emit::pair(*vp1),
                crate::emit::pair(*vp2),
                ignored(fun)
            );
            (EquationKeyword::Joint, doc_text, root)
        }
        // Never here: `constraint_decls` makes a RackPinion's call
        // itself. An empty call would be refused by the checker.
        ConstraintKind::RackPinion { .. } => {
            let root = t.call("rack_pinion", at("type"), Vec::new());
            (EquationKeyword::Constraint, head.to_string(), root)
        }
    }
}

/// `driver` when the `fun` mentions `t`, otherwise `constraint`.
fn keyword(fun: &fun::Expr) -> EquationKeyword {
    if fun.mentions_t() {
        EquationKeyword::Driver
    } else {
        EquationKeyword::Constraint
    }
}

/// A RackPinion as kinema's library element (see [`RackPinion`]):
/// `rack_pinion(rack(sP1), u, pinion(sP2), R2, L + R2 * (θ1 − θ2 + 3π/2))`
/// with u = sQ1 − sP1 and L = |u|.
fn rack_pinion_call(t: &mut Tree, rp: &RackPinion<'_>, at: &dyn Fn(&str) -> Span) -> u32 {
    let rack = t.point(rp.bodies, rp.rack, rp.sp1, (at("body1"), at("sP1")));
    let u = t.pair(rp.u, at("sQ1"));
    let pinion = t.point(rp.bodies, rp.pinion, rp.sp2, (at("body2"), at("sP2")));
    let r2 = t.num(rp.r2, at("R2"));
    let l = t.num(rp.length, at("sQ1"));
    let r2_again = t.num(rp.r2, at("R2"));
    let mut terms = Vec::new();
    for term in rp.angle_terms() {
        terms.push(match term {
            // A leading negative number is parsed as `-` applied to it,
            // straight after its literal; a later one is subtracted.
            SumTerm::Num(x, key) if terms.is_empty() => (false, t.num(x, at(key))),
            SumTerm::Num(x, key) => {
                let lit = t.num(x.abs(), at(key));
                (x < 0.0, lit)
            }
            SumTerm::ThreePiOverTwo => {
                let s = at("type");
                let three = t.num(3.0, s);
                let pi = t.ident("pi", s);
                let num = t.bin(BinOp::Mul, three, pi);
                let two = t.num(2.0, s);
                (false, t.bin(BinOp::Div, num, two))
            }
        });
    }
    let angle = t.sum(terms, at("type"));
    let scaled = t.bin(BinOp::Mul, r2_again, angle);
    let c0 = t.bin(BinOp::Add, l, scaled);
    t.call("rack_pinion", at("type"), vec![rack, u, pinion, r2, c0])
}

fn gravity_decl(model: &Model) -> GravityDecl {
    let at = model
        .fields
        .get("gravity")
        .map_or_else(|| span(Pos::start()), span);
    let mut t = Tree::new();
    let root = t.pair(model.gravity, at);
    GravityDecl {
        keyword: at,
        value: t.finish(root),
    }
}

/// A force element as a `force` item; none for a `PointForceFile` (a
/// MATLAB function, which a run refuses).
fn force_decl(f: &Force, name: String, bodies: &[String]) -> Option<ForceDecl> {
    let at = |key: &str| field_span(&f.fields, key, f.pos);
    let mut t = Tree::new();
    let body = |t: &mut Tree, i: usize, key: &str| t.ident(body_name(bodies, i), at(key));
    let root = match &f.kind {
        ForceKind::PointForce {
            body1,
            sp1,
            frame,
            fun_x,
            fun_y,
        } => {
            let p = t.point(bodies, *body1, *sp1, (at("body1"), at("sP1")));
            let fx = t.fun(fun_x, &f.fields, "funX");
            let fy = t.fun(fun_y, &f.fields, "funY");
            let force = t.push(ExprKind::Tuple(vec![fx, fy]), at("funX"));
            let element = if frame == "GRF" {
                "point_force"
            } else {
                "point_force_local"
            };
            t.call(element, at("type"), vec![p, force])
        }
        ForceKind::PointForceFile { .. } => return None,
        ForceKind::Torque { body1, fun } => {
            let b = body(&mut t, *body1, "body1");
            let f_t = t.fun(fun, &f.fields, "fun");
            t.call("torque", at("type"), vec![b, f_t])
        }
        ForceKind::Rsda1 {
            body1,
            theta0,
            k,
            c,
            fun,
        } => {
            let g = t.ident("ground", at("type"));
            let b = body(&mut t, *body1, "body1");
            let args = rsda_args(&mut t, [*k, *c, *theta0], fun, f, &at);
            t.call("rsda", at("type"), [vec![g, b], args].concat())
        }
        ForceKind::Rsda2 {
            body1,
            body2,
            theta0,
            k,
            c,
            fun,
        } => {
            let b1 = body(&mut t, *body1, "body1");
            let b2 = body(&mut t, *body2, "body2");
            let args = rsda_args(&mut t, [*k, *c, *theta0], fun, f, &at);
            t.call("rsda", at("type"), [vec![b1, b2], args].concat())
        }
    };
    Some(ForceDecl {
        docs: doc(format!(
            "force {} \"{}\": {}",
            f.id,
            f.name.replace(['\n', '\r'], " "),
            f.kind.type_name()
        )),
        keyword: span(f.pos),
        name: Name::new(name, at("name")),
        call: t.finish(root),
    })
}

/// `k, c, theta0, fun` of an RSDA.
fn rsda_args(
    t: &mut Tree,
    [k, c, theta0]: [f64; 3],
    fun: &fun::Expr,
    f: &Force,
    at: &dyn Fn(&str) -> Span,
) -> Vec<u32> {
    vec![
        t.num(k, at("k")),
        t.num(c, at("c")),
        t.num(theta0, at("theta0")),
        t.fun(fun, &f.fields, "fun"),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rack-and-pinion's constant, printed: numbers fold their sign
    /// into the sum (`0.5 - 2`, not `0.5 + -2`), a leading negative one is
    /// negated, and no θ is no term.
    #[test]
    fn rack_pinion_constant_folds_signs() {
        let bodies = ["rack".to_string(), "gear".to_string()];
        let text = |theta1: f64, theta2: f64| {
            let kind = ConstraintKind::RackPinion {
                body1: 0,
                body2: 1,
                sp1: [0.0, 0.0],
                sq1: [2.0, 0.0],
                sp2: [0.0, -1.0],
                r2: 0.5,
                theta1,
                theta2,
                fun: None,
            };
            let rp = RackPinion::of(&kind, &bodies).expect("a rack-pinion");
            let mut t = Tree::new();
            let root = rack_pinion_call(&mut t, &rp, &|_| span(Pos::start()));
            kinema_model::print::expr(&t.finish(root))
        };
        let call = "rack_pinion(rack(0, 0), (2, 0), gear(0, -1), 0.5, 2 + 0.5 * ";
        assert_eq!(text(-1.5, -2.0), format!("{call}(-1.5 + 2 + 3 * pi / 2))"));
        assert_eq!(text(0.5, 2.0), format!("{call}(0.5 - 2 + 3 * pi / 2))"));
        assert_eq!(text(0.0, 0.0), format!("{call}(3 * pi / 2))"));
    }
}
