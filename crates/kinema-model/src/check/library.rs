//! The table of library constraints (CONSTRAINTS.md §1–5, and the
//! followers of §3 in [`crate::follower`]): names,
//! argument kinds, signatures and row counts, read by the checker.

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
