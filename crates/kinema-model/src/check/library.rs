//! The table of library constraints (docs/src/constraints.md, and the
//! followers in [`crate::follower`]): names,
//! argument kinds, signatures and row counts, read by the checker.

/// The constraints of the library (docs/src/constraints.md).
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
    /// `point_follower(P, B.curve, alpha)` (Haug PF, eq. 3.4.32)
    PointFollower,
    /// `cam_follower(Bi.ci, alpha_i, Bj.cj, alpha_j)` (Haug CF, §3.4.4)
    CamFollower,
    /// `flat_follower(B.curve, alpha, P, v)`: a flat face tangent to a cam
    FlatFollower,
}

/// The kind of one argument of a library constraint.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ArgKind {
    /// A point: `B(sx, sy)`, `B.name` or `ground(x, y)`.
    Point,
    /// A body name or `ground`.
    Body,
    /// A constant vector `(vx, vy)` (body-fixed, or global for `cd`).
    Vector,
    /// A scalar expression of params and `t`.
    Scalar,
    /// A curve `B.name` declared with `curve`.
    Curve,
    /// A coordinate declared with `coord`.
    Coord,
}

/// Signature of a library constraint.
pub(super) struct LibSpec {
    pub(super) name: &'static str,
    pub(super) kind: LibKind,
    pub(super) args: &'static [ArgKind],
    pub(super) signature: &'static str,
    pub(super) rows: usize,
    /// Arguments whose bodies must differ (a joint between a body and itself).
    pub(super) pair: Option<(usize, usize)>,
}

impl LibSpec {
    /// The names of the parameters in [`signature`](Self::signature)
    /// (`(cx, cy)` is one).
    fn parameters(&self) -> Vec<&'static str> {
        let sig = self.signature;
        let inner = sig
            .find('(')
            .and_then(|open| sig.get(open + 1..sig.len().saturating_sub(1)))
            .unwrap_or("");
        let (mut out, mut depth, mut start) = (Vec::new(), 0usize, 0usize);
        for (i, c) in inner.char_indices() {
            match c {
                '(' => depth += 1,
                ')' => depth = depth.saturating_sub(1),
                ',' if depth == 0 => {
                    out.push(inner[start..i].trim());
                    start = i + 1;
                }
                _ => {}
            }
        }
        out.push(inner[start..].trim());
        out
    }

    /// Help for a wrong argument `k`: which parameter it is and what the
    /// call takes, every parameter by kind.
    ///   `vi` is argument 2 of `translational(Pi, vi, Pj, vj)`, which takes Pi, Pj: points …; vi, vj: directions in their bodies' frames, constant vectors of params such as `(1, 0)`
    pub(super) fn argument_help(&self, k: usize) -> String {
        let names = self.parameters();
        let name = names.get(k).copied().unwrap_or("?");
        // The kinds in the order they first appear, each with its names.
        let mut groups: Vec<(ArgKind, bool, Vec<&str>)> = Vec::new();
        for (&kind, &n) in self.args.iter().zip(&names) {
            let global = n.starts_with('(');
            match groups
                .iter_mut()
                .find(|(g, gl, _)| *g == kind && *gl == global)
            {
                Some((_, _, list)) => list.push(n),
                None => groups.push((kind, global, vec![n])),
            }
        }
        let takes: Vec<String> = groups
            .iter()
            .map(|(kind, global, list)| {
                let many = list.len() > 1;
                format!("{}: {}", list.join(", "), describe(*kind, *global, many))
            })
            .collect();
        format!(
            "`{name}` is argument {} of `{}`, which takes {}",
            k + 1,
            self.signature,
            takes.join("; ")
        )
    }
}

/// What an argument of `kind` is, for [`LibSpec::argument_help`]
/// (`global`: a vector in the global frame; `many`: plural).
fn describe(kind: ArgKind, global: bool, many: bool) -> &'static str {
    match (kind, many) {
        (ArgKind::Point, false) => {
            "a point (`B(sx, sy)` in body B's frame, `B.name`, or `ground(x, y)`)"
        }
        (ArgKind::Point, true) => {
            "points (`B(sx, sy)` in body B's frame, `B.name`, or `ground(x, y)`)"
        }
        (ArgKind::Body, false) => "a body's name (or `ground`)",
        (ArgKind::Body, true) => "bodies' names (or `ground`)",
        (ArgKind::Vector, _) if global => {
            "a constant vector of params in the global frame, such as `(0, 0)`"
        }
        (ArgKind::Vector, false) => {
            "a direction in its body's frame, a constant vector of params such as `(1, 0)`"
        }
        (ArgKind::Vector, true) => {
            "directions in their bodies' frames, constant vectors of params such as `(1, 0)`"
        }
        (ArgKind::Scalar, false) => "a scalar expression of params and `t`",
        (ArgKind::Scalar, true) => "scalar expressions of params and `t`",
        (ArgKind::Curve, false) => "a curve `B.name` declared with `curve`",
        (ArgKind::Curve, true) => "curves `B.name` declared with `curve`",
        (ArgKind::Coord, false) => "a coordinate declared with `coord`",
        (ArgKind::Coord, true) => "coordinates declared with `coord`",
    }
}

use ArgKind::{Body as AB, Coord as AQ, Curve as AC, Point as AP, Scalar as AS, Vector as AV};

pub(super) const LIBRARY: &[LibSpec] = &[
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
    LibSpec {
        name: "point_follower",
        kind: LibKind::PointFollower,
        args: &[AP, AC, AQ],
        signature: "point_follower(P, B.curve, alpha)",
        rows: 2,
        pair: Some((0, 1)),
    },
    LibSpec {
        name: "cam_follower",
        kind: LibKind::CamFollower,
        args: &[AC, AQ, AC, AQ],
        signature: "cam_follower(Bi.ci, alpha_i, Bj.cj, alpha_j)",
        rows: 3,
        pair: Some((0, 2)),
    },
    LibSpec {
        name: "flat_follower",
        kind: LibKind::FlatFollower,
        args: &[AC, AQ, AP, AV],
        signature: "flat_follower(B.curve, alpha, P, v)",
        rows: 2,
        pair: Some((0, 2)),
    },
];

pub(super) fn library(name: &str) -> Option<&'static LibSpec> {
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
            LibKind::Revolute | LibKind::PointFollower => &[".x", ".y"],
            LibKind::Translational | LibKind::RackPinion | LibKind::FlatFollower => &[".1", ".2"],
            LibKind::CamFollower => &[".1", ".2", ".3"],
            _ => &[""],
        }
    }
}
