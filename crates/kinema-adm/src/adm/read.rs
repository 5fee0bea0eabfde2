//! The ADM reader: JSON values to the typed [`Model`], every mistake
//! located and named (see the parent module).

use super::*;
use kinema_model::{Diagnostic, Diagnostics};

use crate::fun::FunError;
use crate::json::Value;
use crate::pos::{Pos, in_order};

/// Reads the model from its parsed JSON, collecting every mistake.
pub(super) fn read(root: &Value, file: &str) -> Result<Model, Diagnostics> {
    let mut cx = Cx {
        diags: Vec::new(),
        warnings: Diagnostics::new(),
    };
    let model = read_model(&mut cx, root, file);
    if cx.diags.is_empty() {
        let mut model = model;
        model.warnings = cx.warnings;
        Ok(model)
    } else {
        Err(in_order(cx.diags))
    }
}

struct Cx {
    diags: Vec<Diagnostic>,
    /// In the order found (the order of the file).
    warnings: Diagnostics,
}

impl Cx {
    fn err(&mut self, pos: Pos, message: String) {
        self.diags.push(pos.error(message));
    }
}

/// An element being read: its label for messages and its JSON object.
struct Elem<'v> {
    label: String,
    obj: &'v Value,
    needs: &'static str,
}

impl<'v> Elem<'v> {
    /// The `index`-th element of an array of `kind`s (`body`, `constraint`,
    /// `force`): an object, labelled by its name and id; anything else is
    /// reported at its position and gives `None`.
    fn of_array_item(cx: &mut Cx, kind: &str, v: &'v Value, index: usize) -> Option<Self> {
        if v.as_object().is_none() {
            cx.err(
                v.pos,
                format!(
                    "{kind} number {}: expected an object, found {}",
                    index + 1,
                    v.describe()
                ),
            );
            return None;
        }
        Some(Elem {
            label: label(kind, v, index),
            obj: v,
            needs: "",
        })
    }
}

fn plural(n: usize, one: &str, many: &str) -> String {
    if n == 1 {
        format!("{n} {one}")
    } else {
        format!("{n} {many}")
    }
}

impl<'v> Elem<'v> {
    fn field(&self, cx: &mut Cx, key: &str) -> Option<&'v Value> {
        let v = self.obj.get(key);
        if v.is_none() {
            let needs = if self.needs.is_empty() {
                String::new()
            } else {
                format!(" ({})", self.needs)
            };
            cx.err(
                self.obj.pos,
                format!("{}: missing field \"{key}\"{needs}", self.label),
            );
        }
        v
    }

    fn wrong(&self, cx: &mut Cx, key: &str, v: &Value, expected: &str) {
        cx.err(
            v.pos,
            format!(
                "{}: field \"{key}\": expected {expected}, found {}",
                self.label,
                v.describe()
            ),
        );
    }

    fn num_of(&self, cx: &mut Cx, key: &str, v: &Value) -> Option<f64> {
        let x = v.as_f64();
        if x.is_none() {
            self.wrong(cx, key, v, "a number");
        }
        x
    }

    fn num(&self, cx: &mut Cx, key: &str) -> Option<f64> {
        let v = self.field(cx, key)?;
        self.num_of(cx, key, v)
    }

    /// An optional number that must be finite and ≥ 0 (a mass, an
    /// inertia): the model language's own rule, so that an imported model
    /// never fails to check on it.
    fn opt_non_negative(&self, cx: &mut Cx, key: &str) -> Option<f64> {
        let v = self.obj.get(key)?;
        let x = self.num_of(cx, key, v)?;
        if x.is_finite() && x >= 0.0 {
            return Some(x);
        }
        cx.err(
            v.pos,
            format!(
                "{}: field \"{key}\": expected a finite number ≥ 0, found {x}",
                self.label
            ),
        );
        None
    }

    fn array_of<const N: usize>(&self, cx: &mut Cx, key: &str, v: &Value) -> Option<[f64; N]> {
        let expected = format!("an array of {N} numbers");
        let Some(items) = v.as_array() else {
            self.wrong(cx, key, v, &expected);
            return None;
        };
        if items.len() != N {
            cx.err(
                v.pos,
                format!(
                    "{}: field \"{key}\": expected {expected}, found an array of {}",
                    self.label,
                    plural(items.len(), "element", "elements")
                ),
            );
            return None;
        }
        let mut out = [0.0; N];
        let mut ok = true;
        for (slot, item) in out.iter_mut().zip(items) {
            match item.as_f64() {
                Some(x) => *slot = x,
                None => {
                    cx.err(
                        item.pos,
                        format!(
                            "{}: field \"{key}\": expected a number, found {}",
                            self.label,
                            item.describe()
                        ),
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(out)
    }

    fn vec2(&self, cx: &mut Cx, key: &str) -> Option<Vec2> {
        let v = self.field(cx, key)?;
        self.array_of::<2>(cx, key, v)
    }

    fn opt_array<const N: usize>(&self, cx: &mut Cx, key: &str) -> Option<[f64; N]> {
        let v = self.obj.get(key)?;
        self.array_of::<N>(cx, key, v)
    }

    fn string(&self, cx: &mut Cx, key: &str) -> Option<&'v Value> {
        let v = self.field(cx, key)?;
        if v.as_str().is_none() {
            self.wrong(cx, key, v, "a string");
            return None;
        }
        Some(v)
    }

    fn text(&self, cx: &mut Cx, key: &str) -> Option<String> {
        self.string(cx, key)
            .and_then(Value::as_str)
            .map(|s| s.text.clone())
    }

    /// A `fun` string as an expression ("NONE" is refused with `why`).
    fn expr(&self, cx: &mut Cx, key: &str, none_why: &str) -> Option<crate::fun::Expr> {
        let v = self.string(cx, key)?;
        let text = v.as_str().map(|s| s.text.as_str()).unwrap_or_default();
        match Fun::parse(text) {
            Ok(Fun::Expr(e)) if !e.mentions_t() && !e.eval(0.0).is_finite() => {
                cx.err(
                    v.pos_in_string(0),
                    format!(
                        "{}: field \"{key}\": \"{}\" is a constant that is not a finite number (it evaluates to {})",
                        self.label,
                        text.escape_debug(),
                        e.eval(0.0)
                    ),
                );
                None
            }
            Ok(Fun::Expr(e)) => match crate::defined::first_undefined(&e) {
                None => Some(e),
                Some(u) => {
                    cx.err(
                        v.pos_in_string(u.offset),
                        format!(
                            "{}: field \"{key}\": \"{}\" is undefined whatever the time: {} (at character {})",
                            self.label,
                            text.escape_debug(),
                            u.what,
                            u.offset + 1
                        ),
                    );
                    None
                }
            },
            Ok(Fun::None) => {
                cx.err(
                    v.pos,
                    format!(
                        "{}: field \"{key}\": \"NONE\" is not valid here: {none_why}",
                        self.label
                    ),
                );
                None
            }
            Err(FunError { offset, message }) => {
                cx.err(
                    v.pos_in_string(offset),
                    format!(
                        "{}: field \"{key}\": cannot parse \"{}\": {message}",
                        self.label,
                        text.escape_debug()
                    ),
                );
                None
            }
        }
    }

    /// An ignored `fun`: kept as text if it is a string.
    fn ignored_fun(&self) -> Option<String> {
        self.obj
            .get("fun")
            .and_then(Value::as_str)
            .map(|s| s.text.clone())
    }

    fn positive_int(&self, cx: &mut Cx, key: &str, v: &Value) -> Option<usize> {
        match v.as_f64() {
            Some(x) if x >= 1.0 && x.fract() == 0.0 && x <= 1e9 => Some(x as usize),
            Some(x) => {
                cx.err(
                    v.pos,
                    format!(
                        "{}: field \"{key}\": expected a positive integer, found {}",
                        self.label,
                        crate::fun::format_number(x)
                    ),
                );
                None
            }
            None => {
                self.wrong(cx, key, v, "a positive integer");
                None
            }
        }
    }

    /// `body1`/`body2`: a 1-based body number, returned 0-based.
    fn body(&self, cx: &mut Cx, key: &str, nbodies: usize) -> Option<usize> {
        let v = self.field(cx, key)?;
        let n = self.positive_int(cx, key, v)?;
        if n > nbodies {
            cx.err(
                v.pos,
                format!(
                    "{}: field \"{key}\": body {n} does not exist (the model has {})",
                    self.label,
                    plural(nbodies, "body", "bodies")
                ),
            );
            return None;
        }
        Some(n - 1)
    }

    fn two_bodies(&self, cx: &mut Cx, nbodies: usize) -> Option<(usize, usize)> {
        let b1 = self.body(cx, "body1", nbodies);
        let b2 = self.body(cx, "body2", nbodies);
        let (b1, b2) = (b1?, b2?);
        if b1 == b2 {
            let pos = self.obj.get("body2").map_or(self.obj.pos, |v| v.pos);
            cx.err(
                pos,
                format!(
                    "{}: field \"body2\": body1 and body2 are the same body ({}); \
                     the element needs two different bodies",
                    self.label,
                    b1 + 1
                ),
            );
            return None;
        }
        Some((b1, b2))
    }

    fn nonzero(&self, cx: &mut Cx, key: &str, v: Option<Vec2>, what: &str) -> Option<Vec2> {
        let v = v?;
        if v[0] == 0.0 && v[1] == 0.0 {
            return self.refuse(cx, key, what);
        }
        Some(v)
    }

    /// Reports `{label}: field "key": what` at the field (at the element
    /// when it has no such key); `None`, for `return`.
    fn refuse<T>(&self, cx: &mut Cx, key: &str, what: &str) -> Option<T> {
        let pos = self.obj.get(key).map_or(self.obj.pos, |x| x.pos);
        cx.err(pos, format!("{}: field \"{key}\": {what}", self.label));
        None
    }
}

/// The label of an element for messages: `constraint "rev" (id 3)`.
/// Reads `name` and `id` leniently (their errors are reported later).
fn label(kind: &str, obj: &Value, index: usize) -> String {
    let name = obj
        .get("name")
        .and_then(Value::as_str)
        .map(|s| s.text.as_str());
    let id = obj
        .get("id")
        .and_then(Value::as_f64)
        .filter(|x| x.fract() == 0.0 && x.is_finite());
    match (name, id) {
        (Some(n), Some(id)) => format!("{kind} \"{}\" (id {})", n.escape_debug(), id as i64),
        (Some(n), None) => format!("{kind} \"{}\" (number {})", n.escape_debug(), index + 1),
        (None, Some(id)) => format!("{kind} with id {}", id as i64),
        (None, None) => format!("{kind} number {}", index + 1),
    }
}

fn read_model(cx: &mut Cx, root: &Value, file: &str) -> Model {
    let mut model = Model {
        file: file.to_string(),
        name: "model".to_string(),
        gravity: [0.0, -9.81],
        vis: None,
        bodies: Vec::new(),
        constraints: Vec::new(),
        forces: Vec::new(),
        ignored_keys: Vec::new(),
        warnings: Diagnostics::new(),
        fields: super::Fields::of(root),
    };
    let Some(members) = root.as_object() else {
        cx.err(
            root.pos,
            format!(
                "expected the model as a JSON object {{ … }}, found {}",
                root.describe()
            ),
        );
        return model;
    };
    let top = Elem {
        label: "model".to_string(),
        obj: root,
        needs: "",
    };
    for m in members {
        if !TOP_LEVEL_KEYS.contains(&m.key.as_str()) {
            model.ignored_keys.push(m.key.clone());
        }
    }
    if let Some(v) = root.get("name") {
        match v.as_str() {
            Some(s) => model.name = s.text.clone(),
            None => top.wrong(cx, "name", v, "a string"),
        }
    }
    if let Some(g) = top.opt_array::<2>(cx, "gravity") {
        model.gravity = g;
    }
    if let Some(v) = root.get("vis") {
        if v.as_object().is_some() {
            let e = Elem {
                label: "model vis".to_string(),
                obj: v,
                needs: "",
            };
            model.vis = Some(SceneVis {
                xlim: e.opt_array::<2>(cx, "xlim"),
                ylim: e.opt_array::<2>(cx, "ylim"),
                bg_rgb: e.opt_array::<3>(cx, "bgRGB"),
            });
        } else {
            top.wrong(cx, "vis", v, "an object");
        }
    }

    let bodies = list(cx, &top, "bodies", true);
    for (i, b) in bodies.iter().enumerate() {
        if let Some(body) = read_body(cx, b, i) {
            model.bodies.push(body);
        }
    }
    // Body references are checked against the number of bodies in the file,
    // even if some of them had errors (reported separately).
    let nbodies = bodies.len();

    for (i, c) in list(cx, &top, "constraints", true).iter().enumerate() {
        if let Some(con) = read_constraint(cx, c, i, nbodies) {
            model.constraints.push(con);
        }
    }
    let mut index = 0;
    for f in list(cx, &top, "forces", false) {
        if f.as_object().is_some_and(<[_]>::is_empty) {
            continue; // `{}` yields no force element, as in the engine
        }
        if let Some(force) = read_force(cx, f, index, nbodies) {
            model.forces.push(force);
        }
        index += 1;
    }
    model
}

/// The array `key` of the top level (empty if absent and optional).
fn list<'v>(cx: &mut Cx, top: &Elem<'v>, key: &str, required: bool) -> &'v [Value] {
    let v = if required {
        top.field(cx, key)
    } else {
        top.obj.get(key)
    };
    match v {
        None => &[],
        Some(v) => match v.as_array() {
            Some(a) => a,
            None => {
                top.wrong(cx, key, v, "an array");
                &[]
            }
        },
    }
}

fn read_id(cx: &mut Cx, e: &Elem<'_>, index: usize, strict: bool) -> Option<usize> {
    let v = e.field(cx, "id")?;
    let id = e.positive_int(cx, "id", v)?;
    if id != index + 1 {
        let message = format!(
            "{}: field \"id\": id {id} differs from the element's position {} in the list",
            e.label,
            index + 1
        );
        if strict {
            cx.err(
                v.pos,
                format!("{message}; body1/body2 refer to bodies by position, so the ids must be 1, 2, 3, … in order"),
            );
            return None;
        }
        cx.warnings.push(v.pos.warning(format!(
            "{message} (the id is only a label; the position counts)"
        )));
    }
    Some(id)
}

fn read_body(cx: &mut Cx, v: &Value, index: usize) -> Option<Body> {
    let e = Elem::of_array_item(cx, "body", v, index)?;
    let name = e.text(cx, "name");
    let id = read_id(cx, &e, index, true);
    let q0 = e.field(cx, "q0").and_then(|q| e.array_of::<3>(cx, "q0", q));
    let mass = e.opt_non_negative(cx, "mass");
    let jbar = e.opt_non_negative(cx, "jbar");
    let qd0 = e.opt_array::<3>(cx, "qd0");
    let vis = v.get("vis").and_then(|vis| read_body_vis(cx, &e, vis));
    Some(Body {
        name: name?,
        id: id?,
        pos: v.pos,
        fields: super::Fields::of(v),
        mass,
        jbar,
        q0: q0?,
        qd0,
        vis,
    })
}

fn read_body_vis(cx: &mut Cx, body: &Elem<'_>, v: &Value) -> Option<BodyVis> {
    if v.as_object().is_none() {
        body.wrong(cx, "vis", v, "an object");
        return None;
    }
    let e = Elem {
        label: format!("{} vis", body.label),
        obj: v,
        needs: "",
    };
    let mut vis = BodyVis {
        rgb: e.opt_array::<3>(cx, "RGB"),
        ..BodyVis::default()
    };
    if let Some(shapes) = v.get("shapes") {
        match shapes.as_array() {
            Some(items) => {
                for s in items {
                    if s.as_object().is_none() {
                        e.wrong(cx, "shapes", s, "an object {loc, size}");
                        continue;
                    }
                    let se = Elem {
                        label: format!("{} shape", body.label),
                        obj: s,
                        needs: "",
                    };
                    if let (Some(loc), Some(size)) = (se.vec2(cx, "loc"), se.vec2(cx, "size")) {
                        vis.shapes.push(Rect { loc, size });
                    }
                }
            }
            None => e.wrong(cx, "shapes", shapes, "an array"),
        }
    }
    if let Some(points) = v.get("points") {
        match points.as_array() {
            Some(items) => {
                for p in items {
                    if let Some(p) = e.array_of::<2>(cx, "points", p) {
                        vis.points.push(p);
                    }
                }
            }
            None => e.wrong(cx, "points", points, "an array"),
        }
    }
    Some(vis)
}

fn read_constraint(cx: &mut Cx, v: &Value, index: usize, nbodies: usize) -> Option<Constraint> {
    let mut e = Elem::of_array_item(cx, "constraint", v, index)?;
    let name = e.text(cx, "name");
    let id = read_id(cx, &e, index, false);
    let ty_v = e.string(cx, "type")?;
    let ty = ty_v.as_str().map(|s| s.text.as_str()).unwrap_or_default();
    e.needs = match ty {
        "AbsoluteX" | "AbsoluteY" => "AbsoluteX/AbsoluteY need body1, sP1, fun",
        "AbsoluteAngle" => "AbsoluteAngle needs body1, fun",
        "RevoluteJoint" => "RevoluteJoint needs body1, sP1, body2, sP2",
        "TranslationalJoint" => "TranslationalJoint needs body1, sP1, vP1, body2, sP2, vP2",
        "RackPinion" => "RackPinion needs body1, body2, sP1, sQ1, sP2, R2, theta1, theta2",
        _ => "",
    };
    let kind = match ty {
        "AbsoluteX" | "AbsoluteY" | "AbsoluteAngle" => read_absolute(cx, &e, ty, nbodies),
        "RevoluteJoint" | "TranslationalJoint" => read_joint(cx, &e, ty, nbodies),
        "RackPinion" => read_rack_pinion(cx, &e, nbodies),
        other => {
            let hint = CONSTRAINT_TYPES
                .iter()
                .find(|t| {
                    t.eq_ignore_ascii_case(other) || t.starts_with(other) && !other.is_empty()
                })
                .map(|t| format!("; did you mean \"{t}\"?"))
                .unwrap_or_default();
            cx.err(
                ty_v.pos,
                format!(
                    "{}: field \"type\": unknown constraint type \"{}\" (expected one of {}){hint}",
                    e.label,
                    other.escape_debug(),
                    CONSTRAINT_TYPES.join(", ")
                ),
            );
            None
        }
    }?;
    Some(Constraint {
        name: name?,
        id: id?,
        pos: v.pos,
        fields: super::Fields::of(v),
        kind,
    })
}

/// AbsoluteX, AbsoluteY (body1, sP1, fun) and AbsoluteAngle (body1, fun).
fn read_absolute(cx: &mut Cx, e: &Elem<'_>, ty: &str, nbodies: usize) -> Option<ConstraintKind> {
    let abs_none = "an Absolute* element needs a function of t (write \"0\" for a constant zero)";
    let body1 = e.body(cx, "body1", nbodies);
    if ty == "AbsoluteAngle" {
        let fun = e.expr(cx, "fun", abs_none);
        return Some(ConstraintKind::AbsoluteAngle {
            body1: body1?,
            fun: fun?,
        });
    }
    let sp1 = e.vec2(cx, "sP1");
    let fun = e.expr(cx, "fun", abs_none);
    let (body1, sp1, fun) = (body1?, sp1?, fun?);
    Some(if ty == "AbsoluteX" {
        ConstraintKind::AbsoluteX { body1, sp1, fun }
    } else {
        ConstraintKind::AbsoluteY { body1, sp1, fun }
    })
}

/// RevoluteJoint (body1, sP1, body2, sP2) and TranslationalJoint (also
/// vP1, vP2, nonzero directions); their `fun` is kept as text, ignored.
fn read_joint(cx: &mut Cx, e: &Elem<'_>, ty: &str, nbodies: usize) -> Option<ConstraintKind> {
    let bodies = e.two_bodies(cx, nbodies);
    let sp1 = e.vec2(cx, "sP1");
    if ty == "RevoluteJoint" {
        let sp2 = e.vec2(cx, "sP2");
        let (body1, body2) = bodies?;
        return Some(ConstraintKind::Revolute {
            body1,
            sp1: sp1?,
            body2,
            sp2: sp2?,
            fun: e.ignored_fun(),
        });
    }
    let zero = "the direction vector must not be zero";
    let vp1 = e.vec2(cx, "vP1");
    let vp1 = e.nonzero(cx, "vP1", vp1, zero);
    let sp2 = e.vec2(cx, "sP2");
    let vp2 = e.vec2(cx, "vP2");
    let vp2 = e.nonzero(cx, "vP2", vp2, zero);
    let (body1, body2) = bodies?;
    Some(ConstraintKind::Translational {
        body1,
        sp1: sp1?,
        vp1: vp1?,
        body2,
        sp2: sp2?,
        vp2: vp2?,
        fun: e.ignored_fun(),
    })
}

/// RackPinion (body1 the rack, body2 the pinion, sP1, sQ1, sP2, R2,
/// theta1, theta2). The imported equations' constants must be numbers:
/// the pitch line u = sQ1 − sP1 nonzero with a finite length L = |u|,
/// θ1 − θ2 and the rolling row's constant L + R2 (θ1 − θ2 + 3π/2)
/// finite.
fn read_rack_pinion(cx: &mut Cx, e: &Elem<'_>, nbodies: usize) -> Option<ConstraintKind> {
    let bodies = e.two_bodies(cx, nbodies);
    let sp1 = e.vec2(cx, "sP1");
    let sq1 = e.vec2(cx, "sQ1");
    let sp2 = e.vec2(cx, "sP2");
    let r2 = e.num(cx, "R2");
    let theta1 = e.num(cx, "theta1");
    let theta2 = e.num(cx, "theta2");
    let (sp1, sq1) = (sp1?, sq1?);
    if sp1 == sq1 {
        return e.refuse(
            cx,
            "sQ1",
            "sQ1 equals sP1; the two points must span the rack's pitch line",
        );
    }
    let u = [sq1[0] - sp1[0], sq1[1] - sp1[1]];
    if !crate::emit::length(u).is_finite() {
        return e.refuse(
            cx,
            "sQ1",
            "the pitch line from sP1 to sQ1 is longer than the largest number (about 1.8e308)",
        );
    }
    let (r2, theta1, theta2) = (r2?, theta1?, theta2?);
    if !(theta1 - theta2).is_finite() {
        return e.refuse(
            cx,
            "theta2",
            "theta1 - theta2 is larger than the largest number (about 1.8e308)",
        );
    }
    let c0 = crate::emit::length(u) + r2 * (theta1 - theta2 + 3.0 * std::f64::consts::FRAC_PI_2);
    if !c0.is_finite() {
        return e.refuse(
            cx,
            "R2",
            "the rolling row's constant |sQ1 - sP1| + R2 (theta1 - theta2 + 3 pi / 2) is larger than the largest number (about 1.8e308)",
        );
    }
    let (body1, body2) = bodies?;
    Some(ConstraintKind::RackPinion {
        body1,
        body2,
        sp1,
        sq1,
        sp2: sp2?,
        r2,
        theta1,
        theta2,
        fun: e.ignored_fun(),
    })
}

fn read_force(cx: &mut Cx, v: &Value, index: usize, nbodies: usize) -> Option<Force> {
    let e = Elem::of_array_item(cx, "force", v, index)?;
    let name = e.text(cx, "name");
    let id = read_id(cx, &e, index, false);
    let ty_v = e.string(cx, "type")?;
    let ty = ty_v.as_str().map(|s| s.text.as_str()).unwrap_or_default();
    let none = "a force element needs a function of t";
    let kind = match ty {
        "PointForce" => {
            let body1 = e.body(cx, "body1", nbodies);
            let sp1 = e.vec2(cx, "sP1");
            let frame = e.text(cx, "frame");
            let fun_x = e.expr(cx, "funX", none);
            let fun_y = e.expr(cx, "funY", none);
            ForceKind::PointForce {
                body1: body1?,
                sp1: sp1?,
                frame: frame?,
                fun_x: fun_x?,
                fun_y: fun_y?,
            }
        }
        "PointForceFile" => {
            let body1 = e.body(cx, "body1", nbodies);
            let sp1 = e.vec2(cx, "sP1");
            let frame = e.text(cx, "frame");
            let mfile = e.text(cx, "mfile");
            ForceKind::PointForceFile {
                body1: body1?,
                sp1: sp1?,
                frame: frame?,
                mfile: mfile?,
            }
        }
        "Torque" => {
            let body1 = e.body(cx, "body1", nbodies);
            let fun = e.expr(cx, "fun", none);
            ForceKind::Torque {
                body1: body1?,
                fun: fun?,
            }
        }
        "RSDA1" | "RSDA2" => {
            let bodies = if ty == "RSDA1" {
                e.body(cx, "body1", nbodies).map(|b| (b, b))
            } else {
                e.two_bodies(cx, nbodies)
            };
            let theta0 = e.num(cx, "theta0");
            let k = e.num(cx, "k");
            let c = e.num(cx, "c");
            let fun = e.expr(cx, "fun", none);
            let (body1, body2) = bodies?;
            let (theta0, k, c, fun) = (theta0?, k?, c?, fun?);
            if ty == "RSDA1" {
                ForceKind::Rsda1 {
                    body1,
                    theta0,
                    k,
                    c,
                    fun,
                }
            } else {
                ForceKind::Rsda2 {
                    body1,
                    body2,
                    theta0,
                    k,
                    c,
                    fun,
                }
            }
        }
        other => {
            cx.err(
                ty_v.pos,
                format!(
                    "{}: field \"type\": unknown force type \"{}\" (expected one of {})",
                    e.label,
                    other.escape_debug(),
                    FORCE_TYPES.join(", ")
                ),
            );
            return None;
        }
    };
    Some(Force {
        name: name?,
        id: id?,
        pos: v.pos,
        fields: super::Fields::of(v),
        kind,
    })
}
