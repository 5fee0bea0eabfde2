//! The typed ADM model and its reader.
//!
//! [`Model::parse`] reads the JSON text of an ADM file (see SIMENGINE2D.md),
//! checks it and reports every mistake at once, each naming the element (by
//! name and id) and the field:
//!
//! ```text
//! model.adm:40:16: constraint "rev_crank_rod" (id 3): field "body2": body 7 does not exist (the model has 3 bodies)
//! ```
//!
//! Rules checked: required fields are present and of the right shape; a body's
//! `id` equals its 1-based position in `bodies` (because `body1`/`body2` are
//! positions); `body1`/`body2` refer to existing bodies, and differ for
//! two-body elements; constraint types are known; `fun` strings parse
//! ("NONE" only where the engine ignored `fun`); translational direction
//! vectors and the rack's pitch line have non-zero length. A constraint's or
//! force's `id` is a label to the engine: an `id` different from the position
//! is a warning ([`Model::warnings`]), not an error.
//!
//! Fields kinematics does not use (mass, jbar, qd0, gravity, forces, vis) are
//! read and kept. Unknown top-level keys are ignored, as the engine did, and
//! listed in [`Model::ignored_keys`]; unknown keys inside elements are
//! ignored.

use crate::error::{Diagnostic, Error, Pos, Source};
use crate::fun::{Fun, FunError};
use crate::json::{self, Value};

/// A 2-vector `[x, y]`.
pub type Vec2 = [f64; 2];

/// A simEngine2D model read from an ADM file.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The file name given to [`Model::parse`].
    pub file: String,
    /// The model's `name` (default "model").
    pub name: String,
    /// `gravity` (default `[0, -9.81]`); dynamics only.
    pub gravity: Vec2,
    /// Drawing limits and background colour.
    pub vis: Option<SceneVis>,
    /// The bodies, in the order of the file (the order of q).
    pub bodies: Vec<Body>,
    /// The constraints, in the order of the file (the order of Φ's rows).
    pub constraints: Vec<Constraint>,
    /// The force elements (dynamics only; kept, not used by kinematics).
    pub forces: Vec<Force>,
    /// Top-level keys the engine ignored (e.g. `contacts`), in file order.
    pub ignored_keys: Vec<String>,
    /// Warnings: things the engine accepted that look like mistakes.
    pub warnings: Vec<Diagnostic>,
}

/// The model-level `vis` object: drawing limits and background colour.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SceneVis {
    /// `xlim`: `[min, max]` of the drawing's x axis.
    pub xlim: Option<Vec2>,
    /// `ylim`: `[min, max]` of the drawing's y axis.
    pub ylim: Option<Vec2>,
    /// `bgRGB`: background colour, components in 0..1.
    pub bg_rgb: Option<[f64; 3]>,
}

/// A body.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// Display name (may contain spaces).
    pub name: String,
    /// The `id`, equal to the 1-based position in `bodies`.
    pub id: usize,
    /// Where the body's object starts in the file.
    pub pos: Pos,
    /// `mass` (dynamics only).
    pub mass: Option<f64>,
    /// `jbar`, polar moment of inertia about the centroid (dynamics only).
    pub jbar: Option<f64>,
    /// `q0` = `[x, y, φ]`: the initial guess of the position analysis at t = 0.
    pub q0: [f64; 3],
    /// `qd0` = `[ẋ, ẏ, φ̇]` (dynamics only).
    pub qd0: Option<[f64; 3]>,
    /// Drawing data.
    pub vis: Option<BodyVis>,
}

/// A body's drawing data (body frame).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct BodyVis {
    /// `RGB` colour, components in 0..1.
    pub rgb: Option<[f64; 3]>,
    /// Rectangles.
    pub shapes: Vec<Rect>,
    /// Points to draw or trace, body frame.
    pub points: Vec<Vec2>,
}

/// A rectangle in a body's frame: centred at `loc`, full width and height `size`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Centre, body frame.
    pub loc: Vec2,
    /// `[width, height]`.
    pub size: Vec2,
}

/// A constraint element.
#[derive(Clone, Debug, PartialEq)]
pub struct Constraint {
    /// Display name (may contain spaces).
    pub name: String,
    /// The `id` label (normally the 1-based position).
    pub id: usize,
    /// Where the constraint's object starts in the file.
    pub pos: Pos,
    /// The element and its fields.
    pub kind: ConstraintKind,
}

/// The constraint types. Body indices are 0-based positions in
/// [`Model::bodies`] (the file's 1-based `body1`/`body2` minus one).
#[derive(Clone, Debug, PartialEq)]
pub enum ConstraintKind {
    /// `AbsoluteX`: Φ = x_i + sx cos φ_i − sy sin φ_i − f(t); 1 row.
    AbsoluteX {
        /// Body i.
        body1: usize,
        /// `sP1`, the point in body i's frame.
        sp1: Vec2,
        /// f(t).
        fun: crate::fun::Expr,
    },
    /// `AbsoluteY`: Φ = y_i + sx sin φ_i + sy cos φ_i − f(t); 1 row.
    AbsoluteY {
        /// Body i.
        body1: usize,
        /// `sP1`, the point in body i's frame.
        sp1: Vec2,
        /// f(t).
        fun: crate::fun::Expr,
    },
    /// `AbsoluteAngle`: Φ = φ_i − f(t); 1 row.
    AbsoluteAngle {
        /// Body i.
        body1: usize,
        /// f(t).
        fun: crate::fun::Expr,
    },
    /// `RevoluteJoint`: Φ = r_i + A_i sP1 − r_j − A_j sP2; 2 rows.
    Revolute {
        /// Body i.
        body1: usize,
        /// `sP1`, body i's frame.
        sp1: Vec2,
        /// Body j.
        body2: usize,
        /// `sP2`, body j's frame.
        sp2: Vec2,
        /// The `fun` text, ignored (the engine ignored it).
        fun: Option<String>,
    },
    /// `TranslationalJoint`: with v1 = vP1/|vP1|, v2 = vP2/|vP2|,
    /// n1 = R A_i v1, d = r_j^{sP2} − r_i^{sP1}: Φ = [n1·d ; n1·A_j v2]; 2 rows.
    Translational {
        /// Body i.
        body1: usize,
        /// `sP1`, body i's frame.
        sp1: Vec2,
        /// `vP1` as written (not normalised).
        vp1: Vec2,
        /// Body j.
        body2: usize,
        /// `sP2`, body j's frame.
        sp2: Vec2,
        /// `vP2` as written (not normalised).
        vp2: Vec2,
        /// The `fun` text, ignored.
        fun: Option<String>,
    },
    /// `RackPinion`: see SIMENGINE2D.md; 2 rows.
    RackPinion {
        /// The rack, body i.
        body1: usize,
        /// The pinion, body j.
        body2: usize,
        /// `sP1`: a point of the rack's pitch line (rack frame).
        sp1: Vec2,
        /// `sQ1`: a second point of the pitch line (rack frame).
        sq1: Vec2,
        /// `sP2`: the pinion's centre (pinion frame).
        sp2: Vec2,
        /// `R2`: pitch radius.
        r2: f64,
        /// `theta1`: angle offset of the rack (rad).
        theta1: f64,
        /// `theta2`: angle offset of the pinion (rad).
        theta2: f64,
        /// The `fun` text, ignored.
        fun: Option<String>,
    },
}

impl ConstraintKind {
    /// The ADM type name (`"RevoluteJoint"`, …).
    #[must_use]
    pub fn type_name(&self) -> &'static str {
        match self {
            ConstraintKind::AbsoluteX { .. } => "AbsoluteX",
            ConstraintKind::AbsoluteY { .. } => "AbsoluteY",
            ConstraintKind::AbsoluteAngle { .. } => "AbsoluteAngle",
            ConstraintKind::Revolute { .. } => "RevoluteJoint",
            ConstraintKind::Translational { .. } => "TranslationalJoint",
            ConstraintKind::RackPinion { .. } => "RackPinion",
        }
    }

    /// The number of rows (equations) the element contributes to Φ.
    #[must_use]
    pub fn rows(&self) -> usize {
        match self {
            ConstraintKind::AbsoluteX { .. }
            | ConstraintKind::AbsoluteY { .. }
            | ConstraintKind::AbsoluteAngle { .. } => 1,
            ConstraintKind::Revolute { .. }
            | ConstraintKind::Translational { .. }
            | ConstraintKind::RackPinion { .. } => 2,
        }
    }

    /// Whether the element depends on time (an Absolute* element whose `fun`
    /// mentions `t`): a driver rather than a kinematic constraint.
    #[must_use]
    pub fn is_driver(&self) -> bool {
        match self {
            ConstraintKind::AbsoluteX { fun, .. }
            | ConstraintKind::AbsoluteY { fun, .. }
            | ConstraintKind::AbsoluteAngle { fun, .. } => fun.mentions_t(),
            _ => false,
        }
    }
}

/// A force element (dynamics only; read and kept).
#[derive(Clone, Debug, PartialEq)]
pub struct Force {
    /// Display name.
    pub name: String,
    /// The `id` label.
    pub id: usize,
    /// Where the element's object starts in the file.
    pub pos: Pos,
    /// The element and its fields.
    pub kind: ForceKind,
}

/// The force element types. Body indices are 0-based.
#[derive(Clone, Debug, PartialEq)]
pub enum ForceKind {
    /// `PointForce`: a force at `sP1`, components `funX`, `funY` in the
    /// global frame (`frame` "GRF") or the body frame.
    PointForce {
        /// The body.
        body1: usize,
        /// Point of application, body frame.
        sp1: Vec2,
        /// `"GRF"` for the global frame; anything else is the body frame.
        frame: String,
        /// x component f(t).
        fun_x: crate::fun::Expr,
        /// y component f(t).
        fun_y: crate::fun::Expr,
    },
    /// `PointForceFile`: a force computed by a MATLAB function (not portable).
    PointForceFile {
        /// The body.
        body1: usize,
        /// Point of application, body frame.
        sp1: Vec2,
        /// Frame, as in `PointForce`.
        frame: String,
        /// The MATLAB function's name.
        mfile: String,
    },
    /// `Torque`: a torque f(t) on the body.
    Torque {
        /// The body.
        body1: usize,
        /// Torque f(t).
        fun: crate::fun::Expr,
    },
    /// `RSDA1`: rotational spring-damper-actuator between a body and ground.
    Rsda1 {
        /// The body.
        body1: usize,
        /// Free angle.
        theta0: f64,
        /// Stiffness.
        k: f64,
        /// Damping.
        c: f64,
        /// Actuator h(t).
        fun: crate::fun::Expr,
    },
    /// `RSDA2`: rotational spring-damper-actuator between two bodies.
    Rsda2 {
        /// Body i.
        body1: usize,
        /// Body j.
        body2: usize,
        /// Free angle.
        theta0: f64,
        /// Stiffness.
        k: f64,
        /// Damping.
        c: f64,
        /// Actuator h(t).
        fun: crate::fun::Expr,
    },
}

impl ForceKind {
    /// The ADM type name.
    #[must_use]
    pub fn type_name(&self) -> &'static str {
        match self {
            ForceKind::PointForce { .. } => "PointForce",
            ForceKind::PointForceFile { .. } => "PointForceFile",
            ForceKind::Torque { .. } => "Torque",
            ForceKind::Rsda1 { .. } => "RSDA1",
            ForceKind::Rsda2 { .. } => "RSDA2",
        }
    }
}

const CONSTRAINT_TYPES: [&str; 6] = [
    "AbsoluteX",
    "AbsoluteY",
    "AbsoluteAngle",
    "RevoluteJoint",
    "TranslationalJoint",
    "RackPinion",
];

const FORCE_TYPES: [&str; 5] = ["PointForce", "PointForceFile", "Torque", "RSDA1", "RSDA2"];

const TOP_LEVEL_KEYS: [&str; 6] = ["name", "gravity", "vis", "bodies", "constraints", "forces"];

impl Model {
    /// Reads an ADM model from its JSON text; `file` names it in messages.
    ///
    /// # Errors
    /// Every mistake found, each located and naming the element and field.
    pub fn parse(text: &str, file: &str) -> Result<Model, Error> {
        let source = Source::new(file, text);
        let root = json::parse(&source)?;
        let mut cx = Cx {
            src: &source,
            diags: Vec::new(),
            warnings: Vec::new(),
        };
        let model = read_model(&mut cx, &root, file);
        if cx.diags.is_empty() {
            let mut model = model;
            model.warnings = cx.warnings;
            Ok(model)
        } else {
            cx.diags.sort_by_key(|d| d.pos.map(|p| p.offset));
            Err(Error::new(cx.diags))
        }
    }

    /// Reads an ADM file.
    ///
    /// # Errors
    /// The file cannot be read, or [`Model::parse`]'s errors.
    pub fn read(path: &std::path::Path) -> Result<Model, Error> {
        let name = path.display().to_string();
        let text = crate::error::read_text(path)
            .map_err(|e| Diagnostic::whole_file(&name, e.to_string()))?;
        Model::parse(&text, &name)
    }

    /// The body names, in order (the names of the file, which may contain
    /// spaces; see [`crate::emit::Names`] for identifiers).
    #[must_use]
    pub fn body_names(&self) -> Vec<&str> {
        self.bodies.iter().map(|b| b.name.as_str()).collect()
    }

    /// The initial guess q0 of all bodies, stacked as q = [x1, y1, φ1, x2, …].
    #[must_use]
    pub fn q0(&self) -> Vec<f64> {
        self.bodies.iter().flat_map(|b| b.q0).collect()
    }
}

// ---------------------------------------------------------------- reader

struct Cx<'s> {
    src: &'s Source<'s>,
    diags: Vec<Diagnostic>,
    warnings: Vec<Diagnostic>,
}

impl Cx<'_> {
    fn err(&mut self, pos: Pos, message: String) {
        self.diags.push(self.src.diagnostic(pos, message));
    }
}

/// An element being read: its label for messages and its JSON object.
struct Elem<'v> {
    label: String,
    obj: &'v Value,
    needs: &'static str,
}

fn plural(n: usize, one: &str, many: &str) -> String {
    if n == 1 {
        format!("{n} {one}")
    } else {
        format!("{n} {many}")
    }
}

impl<'v> Elem<'v> {
    fn field(&self, cx: &mut Cx<'_>, key: &str) -> Option<&'v Value> {
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

    fn wrong(&self, cx: &mut Cx<'_>, key: &str, v: &Value, expected: &str) {
        cx.err(
            v.pos,
            format!(
                "{}: field \"{key}\": expected {expected}, found {}",
                self.label,
                v.describe()
            ),
        );
    }

    fn num_of(&self, cx: &mut Cx<'_>, key: &str, v: &Value) -> Option<f64> {
        let x = v.as_f64();
        if x.is_none() {
            self.wrong(cx, key, v, "a number");
        }
        x
    }

    fn num(&self, cx: &mut Cx<'_>, key: &str) -> Option<f64> {
        let v = self.field(cx, key)?;
        self.num_of(cx, key, v)
    }

    fn opt_num(&self, cx: &mut Cx<'_>, key: &str) -> Option<f64> {
        let v = self.obj.get(key)?;
        self.num_of(cx, key, v)
    }

    fn array_of<const N: usize>(&self, cx: &mut Cx<'_>, key: &str, v: &Value) -> Option<[f64; N]> {
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

    fn vec2(&self, cx: &mut Cx<'_>, key: &str) -> Option<Vec2> {
        let v = self.field(cx, key)?;
        self.array_of::<2>(cx, key, v)
    }

    fn opt_array<const N: usize>(&self, cx: &mut Cx<'_>, key: &str) -> Option<[f64; N]> {
        let v = self.obj.get(key)?;
        self.array_of::<N>(cx, key, v)
    }

    fn string(&self, cx: &mut Cx<'_>, key: &str) -> Option<&'v Value> {
        let v = self.field(cx, key)?;
        if v.as_str().is_none() {
            self.wrong(cx, key, v, "a string");
            return None;
        }
        Some(v)
    }

    fn text(&self, cx: &mut Cx<'_>, key: &str) -> Option<String> {
        self.string(cx, key)
            .and_then(Value::as_str)
            .map(|s| s.text.clone())
    }

    /// A `fun` string as an expression ("NONE" is refused with `why`).
    fn expr(&self, cx: &mut Cx<'_>, key: &str, none_why: &str) -> Option<crate::fun::Expr> {
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

    fn positive_int(&self, cx: &mut Cx<'_>, key: &str, v: &Value) -> Option<usize> {
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
    fn body(&self, cx: &mut Cx<'_>, key: &str, nbodies: usize) -> Option<usize> {
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

    fn two_bodies(&self, cx: &mut Cx<'_>, nbodies: usize) -> Option<(usize, usize)> {
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

    fn nonzero(&self, cx: &mut Cx<'_>, key: &str, v: Option<Vec2>, what: &str) -> Option<Vec2> {
        let v = v?;
        if v[0] == 0.0 && v[1] == 0.0 {
            let pos = self.obj.get(key).map_or(self.obj.pos, |x| x.pos);
            cx.err(pos, format!("{}: field \"{key}\": {what}", self.label));
            return None;
        }
        Some(v)
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

fn read_model(cx: &mut Cx<'_>, root: &Value, file: &str) -> Model {
    let mut model = Model {
        file: file.to_string(),
        name: "model".to_string(),
        gravity: [0.0, -9.81],
        vis: None,
        bodies: Vec::new(),
        constraints: Vec::new(),
        forces: Vec::new(),
        ignored_keys: Vec::new(),
        warnings: Vec::new(),
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
fn list<'v>(cx: &mut Cx<'_>, top: &Elem<'v>, key: &str, required: bool) -> &'v [Value] {
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

fn read_id(cx: &mut Cx<'_>, e: &Elem<'_>, index: usize, strict: bool) -> Option<usize> {
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
        cx.warnings.push(cx.src.diagnostic(
            v.pos,
            format!("{message} (the id is only a label; the position counts)"),
        ));
    }
    Some(id)
}

fn read_body(cx: &mut Cx<'_>, v: &Value, index: usize) -> Option<Body> {
    if v.as_object().is_none() {
        cx.err(
            v.pos,
            format!(
                "body number {}: expected an object, found {}",
                index + 1,
                v.describe()
            ),
        );
        return None;
    }
    let e = Elem {
        label: label("body", v, index),
        obj: v,
        needs: "",
    };
    let name = e.text(cx, "name");
    let id = read_id(cx, &e, index, true);
    let q0 = e.field(cx, "q0").and_then(|q| e.array_of::<3>(cx, "q0", q));
    let mass = e.opt_num(cx, "mass");
    let jbar = e.opt_num(cx, "jbar");
    let qd0 = e.opt_array::<3>(cx, "qd0");
    let vis = v.get("vis").and_then(|vis| read_body_vis(cx, &e, vis));
    Some(Body {
        name: name?,
        id: id?,
        pos: v.pos,
        mass,
        jbar,
        q0: q0?,
        qd0,
        vis,
    })
}

fn read_body_vis(cx: &mut Cx<'_>, body: &Elem<'_>, v: &Value) -> Option<BodyVis> {
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

fn read_constraint(cx: &mut Cx<'_>, v: &Value, index: usize, nbodies: usize) -> Option<Constraint> {
    if v.as_object().is_none() {
        cx.err(
            v.pos,
            format!(
                "constraint number {}: expected an object, found {}",
                index + 1,
                v.describe()
            ),
        );
        return None;
    }
    let mut e = Elem {
        label: label("constraint", v, index),
        obj: v,
        needs: "",
    };
    let name = e.text(cx, "name");
    let id = read_id(cx, &e, index, false);
    let ty_v = e.string(cx, "type")?;
    let ty = ty_v.as_str().map(|s| s.text.as_str()).unwrap_or_default();
    let abs_none = "an Absolute* element needs a function of t (write \"0\" for a constant zero)";
    e.needs = match ty {
        "AbsoluteX" | "AbsoluteY" => "AbsoluteX/AbsoluteY need body1, sP1, fun",
        "AbsoluteAngle" => "AbsoluteAngle needs body1, fun",
        "RevoluteJoint" => "RevoluteJoint needs body1, sP1, body2, sP2",
        "TranslationalJoint" => "TranslationalJoint needs body1, sP1, vP1, body2, sP2, vP2",
        "RackPinion" => "RackPinion needs body1, body2, sP1, sQ1, sP2, R2, theta1, theta2",
        _ => "",
    };
    let kind = match ty {
        "AbsoluteX" | "AbsoluteY" => {
            let body1 = e.body(cx, "body1", nbodies);
            let sp1 = e.vec2(cx, "sP1");
            let fun = e.expr(cx, "fun", abs_none);
            let (body1, sp1, fun) = (body1?, sp1?, fun?);
            if ty == "AbsoluteX" {
                ConstraintKind::AbsoluteX { body1, sp1, fun }
            } else {
                ConstraintKind::AbsoluteY { body1, sp1, fun }
            }
        }
        "AbsoluteAngle" => {
            let body1 = e.body(cx, "body1", nbodies);
            let fun = e.expr(cx, "fun", abs_none);
            ConstraintKind::AbsoluteAngle {
                body1: body1?,
                fun: fun?,
            }
        }
        "RevoluteJoint" => {
            let bodies = e.two_bodies(cx, nbodies);
            let sp1 = e.vec2(cx, "sP1");
            let sp2 = e.vec2(cx, "sP2");
            let (body1, body2) = bodies?;
            ConstraintKind::Revolute {
                body1,
                sp1: sp1?,
                body2,
                sp2: sp2?,
                fun: e.ignored_fun(),
            }
        }
        "TranslationalJoint" => {
            let bodies = e.two_bodies(cx, nbodies);
            let sp1 = e.vec2(cx, "sP1");
            let vp1 = e.vec2(cx, "vP1");
            let vp1 = e.nonzero(cx, "vP1", vp1, "the direction vector must not be zero");
            let sp2 = e.vec2(cx, "sP2");
            let vp2 = e.vec2(cx, "vP2");
            let vp2 = e.nonzero(cx, "vP2", vp2, "the direction vector must not be zero");
            let (body1, body2) = bodies?;
            ConstraintKind::Translational {
                body1,
                sp1: sp1?,
                vp1: vp1?,
                body2,
                sp2: sp2?,
                vp2: vp2?,
                fun: e.ignored_fun(),
            }
        }
        "RackPinion" => {
            let bodies = e.two_bodies(cx, nbodies);
            let sp1 = e.vec2(cx, "sP1");
            let sq1 = e.vec2(cx, "sQ1");
            let sp2 = e.vec2(cx, "sP2");
            let r2 = e.num(cx, "R2");
            let theta1 = e.num(cx, "theta1");
            let theta2 = e.num(cx, "theta2");
            let (sp1, sq1) = (sp1?, sq1?);
            if sp1 == sq1 {
                let pos = v.get("sQ1").map_or(v.pos, |x| x.pos);
                cx.err(
                    pos,
                    format!(
                        "{}: field \"sQ1\": sQ1 equals sP1; the two points must span the rack's pitch line",
                        e.label
                    ),
                );
                return None;
            }
            let u = [sq1[0] - sp1[0], sq1[1] - sp1[1]];
            if !crate::emit::length(u).is_finite() {
                let pos = v.get("sQ1").map_or(v.pos, |x| x.pos);
                cx.err(
                    pos,
                    format!(
                        "{}: field \"sQ1\": the pitch line from sP1 to sQ1 is longer than the largest number (about 1.8e308)",
                        e.label
                    ),
                );
                return None;
            }
            let r2 = r2?;
            // The rolling row is scaled by L = |sQ1 − sP1|: L·R2 is a
            // constant of the imported equations, and must be a number.
            let scale = crate::emit::length(u) * r2;
            if !scale.is_finite() {
                let pos = v.get("R2").map_or(v.pos, |x| x.pos);
                cx.err(
                    pos,
                    format!(
                        "{}: field \"R2\": R2 times the pitch line's length |sQ1 - sP1| is larger than the largest number (about 1.8e308)",
                        e.label
                    ),
                );
                return None;
            }
            // The rolling angle's constant, θ1 − θ2 + 3π/2, must be a number.
            let (theta1, theta2) = (theta1?, theta2?);
            if !(theta1 - theta2).is_finite() {
                let pos = v.get("theta2").map_or(v.pos, |x| x.pos);
                cx.err(
                    pos,
                    format!(
                        "{}: field \"theta2\": theta1 - theta2 is larger than the largest number (about 1.8e308)",
                        e.label
                    ),
                );
                return None;
            }
            let (body1, body2) = bodies?;
            ConstraintKind::RackPinion {
                body1,
                body2,
                sp1,
                sq1,
                sp2: sp2?,
                r2,
                theta1,
                theta2,
                fun: e.ignored_fun(),
            }
        }
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
            return None;
        }
    };
    Some(Constraint {
        name: name?,
        id: id?,
        pos: v.pos,
        kind,
    })
}

fn read_force(cx: &mut Cx<'_>, v: &Value, index: usize, nbodies: usize) -> Option<Force> {
    if v.as_object().is_none() {
        cx.err(
            v.pos,
            format!(
                "force number {}: expected an object, found {}",
                index + 1,
                v.describe()
            ),
        );
        return None;
    }
    let e = Elem {
        label: label("force", v, index),
        obj: v,
        needs: "",
    };
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
        kind,
    })
}
