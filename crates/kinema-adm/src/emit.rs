//! Prints an ADM model as the equivalent model in kinema's language
//! (`kinema import model.adm`): the tree of [`crate::build()`], printed by
//! kinema-model's printer, after a header; and the identifiers both use.
//!
//! Mapping (bodies and equations keep the ADM order, so q and Φ's rows are
//! the same as the engine's):
//!
//! | ADM | kinema |
//! |---|---|
//! | body, `q0` | `body name { guess: (x, y, phi) }` |
//! | AbsoluteX / AbsoluteY, `sP1`, `fun` | `abs_x(B(sx, sy), f)` / `abs_y(…)` |
//! | AbsoluteAngle, `fun` | `abs_angle(B, f)` |
//! | RevoluteJoint | `joint n: revolute(Bi(sP1), Bj(sP2))` |
//! | TranslationalJoint | `joint n: translational(Bi(sP1), v1, Bj(sP2), v2)`, v normalised |
//! | RackPinion | `constraint n: rack_pinion(Bi(sP1), sQ1 - sP1, Bj(sP2), R2, c0)`, c0 below |
//!
//! An Absolute* element whose `fun` mentions `t` is a `driver`, otherwise a
//! `constraint`. Names become identifiers ([`Names`]); each item carries a
//! `///` doc comment with the original name, id and type. `fun` strings are
//! translated node for node ([`crate::fun::Expr::to_kin`] shows the text).

use std::collections::HashSet;
use std::fmt::Write as _;

use crate::adm::{ConstraintKind, Model, Vec2};
use crate::check::ignored_by_kinematics;
use crate::fun::format_number;

/// True for a word an identifier must not be: a name kinema's checker
/// refuses for a body (`pi`, `t`, `ground`, a function's name). Bodies
/// and equations share one name space here, so the body rule covers both.
fn reserved(s: &str) -> bool {
    !kinema_model::check::may_declare(s, true)
}

/// The identifiers used for a model in kinema's language.
///
/// Names are kept as far as possible: characters other than ASCII letters,
/// digits and `_` become `_` (runs collapsed, ends trimmed: "Long Rod" →
/// `Long_Rod`), a leading digit gets a prefix, names kinema reserves get a trailing
/// `_` (`ground` → `ground_`, `sin` → `sin_`), and clashes get `_2`, `_3`, … Bodies and
/// equations share one namespace.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Names {
    /// The mechanism's name, in UpperCamelCase ("Double Pend 6.5.2" →
    /// `DoublePend6_5_2`).
    pub mechanism: String,
    /// One identifier per body, in order.
    pub bodies: Vec<String>,
    /// Per constraint element, the names of the items it becomes (one
    /// each).
    pub constraints: Vec<Vec<String>>,
}

impl Names {
    /// The identifiers of `model`'s mechanism, bodies and constraints.
    #[must_use]
    pub fn of(model: &Model) -> Names {
        let mut used: HashSet<String> = HashSet::new();
        let mut take = |base: String| -> String {
            let mut name = base.clone();
            let mut k = 2;
            while used.contains(&name) {
                name = format!("{base}_{k}");
                k += 1;
            }
            used.insert(name.clone());
            name
        };
        let bodies = model
            .bodies
            .iter()
            .map(|b| take(identifier(&b.name, "body", b.id)))
            .collect();
        let constraints = model
            .constraints
            .iter()
            .map(|c| vec![take(identifier(&c.name, "c", c.id))])
            .collect();
        Names {
            mechanism: camel_identifier(&model.name),
            bodies,
            constraints,
        }
    }
}

/// One row of Φ in the emitted model: its name in kinema and the ADM
/// constraint it comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RowOrigin {
    /// The row's name in kinema: `name` for a one-row element,
    /// `name.x`/`name.y` for a revolute joint, `name.1`/`name.2` for a
    /// translational joint and a rack-and-pinion (kinema's naming of
    /// library rows).
    pub row: String,
    /// 0-based index of the constraint in [`Model::constraints`].
    pub constraint: usize,
}

impl Names {
    /// The rows of Φ in the engine's order (the order of `constraints`, a
    /// two-row element's rows consecutively), each with its kinema name and
    /// its ADM constraint; for messages that must name the ADM element
    /// (a singular Jacobian, a residual that does not converge). kinema may
    /// order its own rows differently (kinematic rows before drivers): match
    /// by name.
    #[must_use]
    pub fn rows(&self, model: &Model) -> Vec<RowOrigin> {
        let mut rows = Vec::new();
        for (k, (c, idents)) in model.constraints.iter().zip(&self.constraints).enumerate() {
            let mut push = |row: String| rows.push(RowOrigin { row, constraint: k });
            let first = idents.first().cloned().unwrap_or_default();
            match c.kind {
                ConstraintKind::Revolute { .. } => {
                    push(format!("{first}.x"));
                    push(format!("{first}.y"));
                }
                ConstraintKind::Translational { .. } => {
                    push(format!("{first}.1"));
                    push(format!("{first}.2"));
                }
                // The engine's first row rolls (kinema's `.2`), its second
                // keeps the centre off the pitch line (`.1`).
                ConstraintKind::RackPinion { .. } => {
                    push(format!("{first}.2"));
                    push(format!("{first}.1"));
                }
                _ => idents.iter().cloned().for_each(push),
            }
        }
        rows
    }
}

/// `name` as an identifier: see [`Names`]. `prefix` and `id` make the
/// fallback for a name with no usable character, and the prefix for a
/// leading digit.
pub(crate) fn identifier(name: &str, prefix: &str, id: usize) -> String {
    let mut s = String::new();
    for c in name.chars() {
        let c = if c.is_ascii_alphanumeric() { c } else { '_' };
        if c == '_' && (s.is_empty() || s.ends_with('_')) {
            continue;
        }
        s.push(c);
    }
    while s.ends_with('_') {
        s.pop();
    }
    if s.is_empty() {
        return format!("{prefix}_{id}");
    }
    if s.starts_with(|c: char| c.is_ascii_digit()) {
        s = format!("{prefix}_{s}");
    }
    if reserved(&s) {
        s.push('_');
    }
    s
}

/// `name` as an UpperCamelCase identifier; digit groups that would touch are
/// separated by `_`.
fn camel_identifier(name: &str) -> String {
    let mut s = String::new();
    for word in name
        .split(|c: char| !c.is_ascii_alphanumeric())
        .filter(|w| !w.is_empty())
    {
        if s.ends_with(|c: char| c.is_ascii_digit())
            && word.starts_with(|c: char| c.is_ascii_digit())
        {
            s.push('_');
        }
        let mut chars = word.chars();
        if let Some(first) = chars.next() {
            s.push(first.to_ascii_uppercase());
            s.extend(chars);
        }
    }
    if s.is_empty() {
        return "Model".to_string();
    }
    if s.starts_with(|c: char| c.is_ascii_digit()) {
        s.insert_str(0, "Model");
    }
    if reserved(&s) {
        s.push('_');
    }
    s
}

/// Text for a comment: control characters (a newline in a JSON string)
/// become spaces so the comment stays on its line.
pub(crate) fn comment_text(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect()
}

/// `(x, y)` in kinema's syntax.
pub(crate) fn pair(v: Vec2) -> String {
    format!("({}, {})", format_number(v[0]), format_number(v[1]))
}

/// `|v|`, the engine's formula for ordinary vectors (so that printed
/// numbers are the engine's); when the sum of squares would overflow
/// (`[1e200, 1e200]`) or lose a component to underflow (`[1e-200,
/// 1e-200]`, `[5e-324, 0]`), scaled first (`hypot`), which is exact to
/// rounding whatever the magnitude. Infinite only if `|v|` exceeds
/// `f64::MAX`.
pub(crate) fn length(v: Vec2) -> f64 {
    let n = (v[0] * v[0] + v[1] * v[1]).sqrt();
    // Below 1e-100 a component that matters at the last bit may have
    // squared into the subnormals; an infinite n overflowed.
    if n.is_finite() && n >= 1e-100 {
        n
    } else {
        v[0].hypot(v[1])
    }
}

/// `v / |v|`, the engine's normalisation of direction vectors, for any
/// nonzero finite `v`; `None` for a zero or non-finite vector (the reader
/// refuses those at their field, so emitted text never holds one).
pub(crate) fn normalised(v: Vec2) -> Option<Vec2> {
    let m = v[0].abs().max(v[1].abs());
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let n = length(v);
    let u = if n.is_finite() && n >= 1e-100 {
        [v[0] / n, v[1] / n]
    } else {
        // Scaled by the largest component first: |w| is in [1, √2].
        let w = [v[0] / m, v[1] / m];
        let n = w[0].hypot(w[1]);
        [w[0] / n, w[1] / n]
    };
    u.iter().all(|x| x.is_finite()).then_some(u)
}

/// A term of the constant part of the rack-pinion's angle,
/// θ1 − θ2 + 3π/2, shared by the printer and [`crate::build()`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum SumTerm {
    /// A number from field `key`; its sign is the term's (zero: no term).
    Num(f64, &'static str),
    /// `3 * pi / 2`.
    ThreePiOverTwo,
}

/// A RackPinion element's numbers (docs/src/simengine2d.md): u = sQ1 − sP1 along
/// the pitch line, L = |u| (finite: the reader refuses a pitch line whose
/// length overflows), and the terms of its angle's constant.
///
/// The engine's two rows, with d = r_pinion(sP2) − r_rack(sP1),
/// a = A(φ_rack) u and α = φ_rack + θ1 − φ_pinion − θ2 + 3π/2, are
///
/// - rolling: (d − a)ᵀ a − L R2 α = L (ûᵀd + R2 (φ_pinion − φ_rack) − c0),
/// - contact: dᵀ(R a) − L R2 = L (n̂ᵀd − R2),
///
/// with û = a / L, n̂ = R û and c0 = L + R2 (θ1 − θ2 + 3π/2): L times the
/// rows `.2` and `.1` of kinema's `rack_pinion(rack(sP1), u, pinion(sP2),
/// R2, c0)`. The import writes that element, so its reaction is one element
/// about its own points (sP1 on the rack, sP2 on the pinion); its
/// multipliers are the engine's divided by L, its rows in kinema's order.
pub(crate) struct RackPinion<'a> {
    pub(crate) bodies: &'a [String],
    pub(crate) rack: usize,
    pub(crate) pinion: usize,
    pub(crate) sp1: Vec2,
    pub(crate) sp2: Vec2,
    pub(crate) u: Vec2,
    pub(crate) length: f64,
    pub(crate) r2: f64,
    theta: [f64; 2],
    pub(crate) fun: &'a Option<String>,
}

impl<'a> RackPinion<'a> {
    /// The numbers of a `RackPinion` kind (`None` for another kind).
    pub(crate) fn of(kind: &'a ConstraintKind, bodies: &'a [String]) -> Option<RackPinion<'a>> {
        let ConstraintKind::RackPinion {
            body1,
            body2,
            sp1,
            sq1,
            sp2,
            r2,
            theta1,
            theta2,
            fun,
        } = kind
        else {
            return None;
        };
        let u = [sq1[0] - sp1[0], sq1[1] - sp1[1]];
        Some(RackPinion {
            bodies,
            rack: *body1,
            pinion: *body2,
            sp1: *sp1,
            sp2: *sp2,
            u,
            length: length(u),
            r2: *r2,
            theta: [*theta1, *theta2],
            fun,
        })
    }

    /// θ1 − θ2 + 3π/2, term by term; a zero θ is no term.
    pub(crate) fn angle_terms(&self) -> Vec<SumTerm> {
        [
            SumTerm::Num(self.theta[0], "theta1"),
            SumTerm::Num(-self.theta[1], "theta2"),
            SumTerm::ThreePiOverTwo,
        ]
        .into_iter()
        .filter(|t| !matches!(t, SumTerm::Num(x, _) if *x == 0.0))
        .collect()
    }

    /// What the doc comment says after the element's head.
    pub(crate) fn doc(&self) -> String {
        let name = |i: usize| body_name(self.bodies, i);
        format!(
            "(body1 {} is the rack, body2 {} the pinion): u = sQ1 - sP1, c0 = |u| + R2 (theta1 - theta2 + 3 pi / 2); rows .1 (contact) and .2 (rolling) are the engine's rows 2 and 1 divided by |u|",
            name(self.rack),
            name(self.pinion)
        )
    }
}

/// The doc comment's note on a joint's `fun`, which the engine ignores.
pub(crate) fn ignored_fun(fun: Option<&str>) -> String {
    match fun {
        None | Some("NONE") => String::new(),
        Some(f) => format!(
            " (its fun \"{}\" is ignored, as by the engine)",
            comment_text(f)
        ),
    }
}

/// Prints `model` in kinema's language: the parsed form of [`crate::build()`]
/// (the one translation of an ADM model), printed by kinema-model's
/// printer ([`kinema_model::print`]), after a header of `//` comments
/// that says where it comes from and what was left out (a force computed
/// by a MATLAB function is among what kinematics ignores). The text parses
/// with kinema's model parser and states the same equations, in the same
/// order, as the engine.
///
/// ```
/// let adm = kinema_adm::Source::new("pendulum.adm", r#"{ "name": "pendulum",
///   "bodies": [ { "name": "rod", "id": 1, "q0": [1, 0, 0] } ],
///   "constraints": [
///     { "name": "x", "id": 1, "type": "AbsoluteX", "body1": 1, "sP1": [-1, 0], "fun": "0" },
///     { "name": "y", "id": 2, "type": "AbsoluteY", "body1": 1, "sP1": [-1, 0], "fun": "0" },
///     { "name": "swing", "id": 3, "type": "AbsoluteAngle", "body1": 1, "fun": "sin(t)" } ] }"#);
/// let model = kinema_adm::Model::parse(&adm).unwrap();
/// let kin = kinema_adm::to_kin(&model);
/// assert!(kin.contains("driver swing: abs_angle(rod, sin(t));"));
/// ```
#[must_use]
pub fn to_kin(model: &Model) -> String {
    let mut out = header(model);
    out.push_str(&kinema_model::print::mechanism(&crate::build::mechanism(
        model,
    )));
    out
}

/// The `//` comments before `mechanism`: the model's origin, what its
/// bodies' numbers become, and what the printed model leaves out (what a
/// kinematic run ignores, PointForceFile forces included, and a vis point
/// that is not finite).
fn header(model: &Model) -> String {
    let mut out = String::new();
    let file = std::path::Path::new(&model.file)
        .file_name()
        .map_or(model.file.clone(), |f| f.to_string_lossy().into_owned());
    let _ = writeln!(
        out,
        "// Imported by kinema from the simEngine2D model \"{}\" ({}).",
        comment_text(&model.name),
        comment_text(&file)
    );
    if crate::dynamics::has_dynamics(model) {
        let _ = writeln!(
            out,
            "// Each body's q0 is its guess; mass and jbar are its inertia; qd0, where not zero, \
             is its velocity."
        );
    } else {
        let _ = writeln!(
            out,
            "// Each body's q0 is its guess. Kinematics does not use mass, jbar, qd0 or gravity {}.",
            pair(model.gravity)
        );
    }
    let ignored = ignored_by_kinematics(model);
    if ignored.is_empty() {
        // A model with dynamics writes its forces as `force` items.
        if model.forces.is_empty() {
            let _ = writeln!(out, "// No force elements.");
        }
    } else {
        let _ = writeln!(out, "// Ignored:");
        for line in &ignored {
            let _ = writeln!(out, "//   {}", comment_text(line));
        }
    }
    // What the syntax tree cannot hold: comments that document no item.
    for body in &model.bodies {
        let points = body.vis.as_ref().map_or(&[][..], |v| &v.points[..]);
        for (k, p) in points.iter().enumerate() {
            if !p.iter().all(|v| v.is_finite()) {
                let _ = writeln!(
                    out,
                    "// vis point {} of body {} \"{}\" left out: it is not finite",
                    k + 1,
                    body.id,
                    comment_text(&body.name)
                );
            }
        }
    }
    out
}

/// The identifier of body `i`; `ground` for an index out of range.
pub(crate) fn body_name(bodies: &[String], i: usize) -> &str {
    bodies.get(i).map_or("ground", String::as_str)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identifiers() {
        assert_eq!(identifier("Long Rod", "body", 3), "Long_Rod");
        assert_eq!(
            identifier("Revolute Crank-Collar", "c", 3),
            "Revolute_Crank_Collar"
        );
        assert_eq!(identifier("absX_crank", "c", 1), "absX_crank");
        // Rust's and the language's keywords are names (issue 15, item 4);
        // only what kinema's checker refuses gets a `_`.
        assert_eq!(identifier("driver", "c", 3), "driver");
        assert_eq!(identifier("type", "body", 3), "type");
        assert_eq!(identifier("sin", "body", 3), "sin_");
        assert_eq!(identifier("t", "c", 3), "t_");
        assert_eq!(identifier("ground", "body", 1), "ground_");
        assert_eq!(identifier("  ", "body", 4), "body_4");
        assert_eq!(identifier("1st pin", "c", 2), "c_1st_pin");
        assert_eq!(identifier("Zoë", "body", 2), "Zo");
        assert_eq!(camel_identifier("Double Pend 6.5.2"), "DoublePend6_5_2");
        assert_eq!(camel_identifier("shurikenCatapult"), "ShurikenCatapult");
        assert_eq!(camel_identifier("Example3.4.2"), "Example3_4_2");
        assert_eq!(camel_identifier(""), "Model");
        assert_eq!(camel_identifier("4bar"), "Model4bar");
    }

    /// A unit vector along `v`: length 1 to rounding, same direction
    /// (cross product zero relative to the larger component), same signs.
    fn assert_unit_along(v: Vec2) {
        let u = normalised(v).unwrap_or_else(|| panic!("{v:?} has a direction"));
        assert!(u.iter().all(|x| x.is_finite()), "{v:?} -> {u:?}");
        let len = (u[0] * u[0] + u[1] * u[1]).sqrt();
        assert!((len - 1.0).abs() < 4.0 * f64::EPSILON, "{v:?} -> {u:?}");
        for k in 0..2 {
            assert_eq!(u[k] == 0.0, v[k] == 0.0, "{v:?} -> {u:?}");
            assert_eq!(u[k] < 0.0, v[k] < 0.0, "{v:?} -> {u:?}");
        }
        // Ratios u0/u1 = v0/v1 where both are nonzero (compared through
        // the scaled components, which do not overflow).
        let m = v[0].abs().max(v[1].abs());
        let w = [v[0] / m, v[1] / m];
        let cross = u[0] * w[1] - u[1] * w[0];
        assert!(cross.abs() < 4.0 * f64::EPSILON, "{v:?} -> {u:?}");
    }

    #[test]
    fn directions_normalise_at_any_magnitude() {
        for v in [
            [1e-200, 1e-200],
            [5e-324, 0.0],
            [0.0, -5e-324],
            [1e200, 1e200],
            [f64::MAX, f64::MAX],
            [-f64::MAX, 1.0],
            [1e-160, 3e-170],
            [3.0, 4.0],
            [2.0, 0.0],
        ] {
            assert_unit_along(v);
        }
        // The engine's own formula for ordinary vectors, to the bit.
        assert_eq!(normalised([3.0, 4.0]), Some([0.6, 0.8]));
        let v: Vec2 = [0.3, -1.7];
        let n = (v[0] * v[0] + v[1] * v[1]).sqrt();
        assert_eq!(normalised(v), Some([v[0] / n, v[1] / n]));
        assert_eq!(normalised([0.0, 0.0]), None);
        assert_eq!(normalised([f64::NAN, 1.0]), None);
    }

    #[test]
    fn lengths_neither_overflow_nor_underflow() {
        assert_eq!(length([3.0, 4.0]), 5.0);
        assert!((length([3e200, 4e200]) / 5e200 - 1.0).abs() < 1e-15);
        assert!((length([3e-200, 4e-200]) / 5e-200 - 1.0).abs() < 1e-15);
        assert_eq!(length([5e-324, 0.0]), 5e-324);
        assert!(length([f64::MAX, f64::MAX]).is_infinite());
    }
}
