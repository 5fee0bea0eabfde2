//! The typed ADM model and its reader.
//!
//! [`Model::parse`] reads the JSON text of an ADM file (see docs/src/simengine2d.md),
//! checks it and reports every mistake at once, each naming the element (by
//! name and id) and the field:
//!
//! ```text
//! error: constraint "rev_crank_rod" (id 3): field "body2": body 7 does not exist (the model has 3 bodies)
//!   --> model.adm:40:16
//!    |
//! 40 |       "body2": 7,
//!    |                ^
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

use std::sync::Arc;

use kinema_model::{Diagnostics, Report, Source};

use crate::fun::Fun;
use crate::json;
use crate::pos::Pos;

mod read;

/// A 2-vector `[x, y]`.
pub type Vec2 = [f64; 2];

/// Where the fields of an ADM object are in its file: the position of each
/// key's value, so that a model built from the object (kinema-adm's
/// `build`) points every message at the JSON value it comes from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fields {
    at: Vec<FieldPos>,
}

#[derive(Clone, Debug, PartialEq)]
struct FieldPos {
    key: String,
    /// The value's first character.
    pos: Pos,
    /// A string without escapes: its first character after the quote.
    text: Option<Pos>,
}

impl Fields {
    /// The members of `object` (none for another kind of value).
    pub(crate) fn of(object: &json::Value) -> Fields {
        let at = object
            .as_object()
            .unwrap_or_default()
            .iter()
            .map(|m| FieldPos {
                key: m.key.clone(),
                pos: m.value.pos,
                text: m
                    .value
                    .as_str()
                    .filter(|s| s.verbatim)
                    .map(|_| m.value.pos.advance('"')),
            })
            .collect();
        Fields { at }
    }

    /// Where the value of `key` starts (`None` when the object has no such
    /// key: a default was used).
    #[must_use]
    pub fn get(&self, key: &str) -> Option<Pos> {
        self.at.iter().find(|f| f.key == key).map(|f| f.pos)
    }

    /// Where each character of the string value `text` of `key` is (one
    /// more entry for the end), computed in one pass; `None` for a string
    /// written with escapes (only where it starts is known: [`get`]) or
    /// no such key.
    ///
    /// [`get`]: Fields::get
    #[must_use]
    pub fn char_positions(&self, key: &str, text: &str) -> Option<Vec<Pos>> {
        let start = self.at.iter().find(|f| f.key == key)?.text?;
        let mut out = Vec::with_capacity(text.len() + 1);
        let mut pos = start;
        for c in text.chars() {
            out.push(pos);
            pos = pos.advance(c);
        }
        out.push(pos);
        Some(out)
    }
}

/// A simEngine2D model read from an ADM file.
#[derive(Clone, Debug)]
pub struct Model {
    /// The name of the source given to [`Model::parse`].
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
    /// Warnings: things the engine accepted that look like mistakes, each
    /// at its place in the file's text.
    pub warnings: Diagnostics,
    /// Where the top-level fields are.
    pub fields: Fields,
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
    /// Where its fields are.
    pub fields: Fields,
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
    /// Where its fields are.
    pub fields: Fields,
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
    /// `RackPinion`: see docs/src/simengine2d.md; 2 rows.
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
    /// Where its fields are.
    pub fields: Fields,
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
    /// Reads an ADM model from the JSON text of `source` (its name names
    /// the model's file in messages).
    ///
    /// # Errors
    /// Every mistake found, each at its place in the text and naming the
    /// element and field (render them with a [`Report`] of `source`).
    pub fn parse(source: &Source) -> Result<Model, Diagnostics> {
        let root = json::parse(source.text())?;
        read::read(&root, source.name())
    }

    /// Reads the ADM file at `path` ([`Source::read`]: the one size cap and
    /// UTF-8 rule), then [`Model::parse`]s it; the source is returned with
    /// the model, for the messages of later phases that point into it.
    ///
    /// # Errors
    /// The file cannot be read, or [`Model::parse`]'s errors, as a report
    /// against the file.
    pub fn read(path: &std::path::Path) -> Result<(Model, Source), Report> {
        let source = Source::read(path)?;
        match Model::parse(&source) {
            Ok(model) => Ok((model, source)),
            Err(diagnostics) => Err(diagnostics.report(Arc::new(source))),
        }
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
