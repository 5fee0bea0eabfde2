//! The kinema model language: parsing, validation, the planar constraint
//! library and the symbolic derivation.
//!
//! Three phases, three types:
//!
//! 1. [`ParsedModel`] — the syntax tree ([`syntax`]), parsed with syn from text
//!    ([`ParsedModel::parse_str`]) or from the tokens of a proc-macro
//!    ([`ParsedModel::parse_tokens`]). It keeps tokens and spans. All of the
//!    parsing lives in `src/syntax.rs` and `src/syntax/`.
//! 2. [`CheckedModel`] — validated by [`ParsedModel::check`] ([`check`]): names
//!    resolved, expressions typed, counts right. Every independent error is
//!    reported at once as [`Diagnostics`], which render like rustc for text
//!    ([`Diagnostics::render`]) or become one combined `syn::Error` for the
//!    proc-macro ([`Diagnostics::into_syn_error`]). All of the checking lives
//!    in `src/check/`, with the lowering of checked expressions into the
//!    engine's arena (`check/lower.rs`): the checker needs it for constants'
//!    values and undefined parts, and the derivation reuses it.
//! 3. [`Derivation`] — built by [`Derivation::new`], which fails only when
//!    an equation's derivatives would outgrow [`DERIVATION_BUDGET`]:
//!    Φ, sparse Φ_q, Φ_t, Φ_qt, Φ_tt, (Φ_q q̇)_q q̇, ν, γ in one
//!    [`kinema_expr::Arena`], the DOF report, and [`Derivation::render`].
//!    The derivation is `src/derive.rs` and the modules it calls:
//!    [`dynamics`], [`outputs`], [`follower`], [`linkage`], the constraint
//!    library's rows (`library.rs`) and the text rendering (`render.rs`).
//!    [`Derivation::sensitivities`] adds, for chosen params, Φ_p and the
//!    right-hand sides of the sensitivity systems ([`sensitivity`]).
//!
//! Phases only point down: syntax ← check ← derivation. A phase imports
//! the phases before it and the shared modules ([`span`], [`diagnostic`],
//! [`source`], [`algebra`]), never a later one; `tests/phases.rs` fails if
//! syntax or check does. A feature spans the phases in parallel files: the dynamics is
//! `syntax/dynamics.rs`, `check/dynamics.rs`, `dynamics.rs`; coordinates of
//! their own, curves and followers are `syntax/coord.rs`, `check/coord.rs`,
//! `follower.rs`; measures are `syntax/output.rs`, `check/output.rs`,
//! `outputs.rs`.
//!
//! ```
//! use kinema_model::{Derivation, ParsedModel};
//! let src = r#"
//! mechanism Pendulum {
//!     /// bar half-length [m]
//!     param L = 1;
//!     body bar { guess: (L, 0, 0) }
//!     joint pin: revolute(bar(-L, 0), ground(0, 0));
//!     driver swing: bar.phi == 4 * t * t;
//! }"#;
//! let model = ParsedModel::parse_str(src).and_then(|m| m.check());
//! let checked = match model {
//!     Ok(c) => c,
//!     Err(d) => panic!("{}", d.render(src, "pendulum.kin")),
//! };
//! let derivation = match Derivation::new(&checked) {
//!     Ok(d) => d,
//!     Err(d) => panic!("{}", d.render(src, "pendulum.kin")),
//! };
//! assert_eq!(derivation.dof.ndof(), 0);
//! assert!(derivation.render().contains("swing"));
//! ```
//!
//! Front ends enter through [`Source`] (a file or text) or [`Parsed`] (the
//! macro's tokens, another reader's syntax tree), which chain the phases
//! once and report failures as a [`Report`]: the diagnostics as data with
//! the source they point into ([`front`]).
//!
//! # The language
//!
//! Tokens are Rust tokens: `//` comments are skipped, `///` doc comments are
//! kept (on the mechanism, params, bodies, points and equations), and so are
//! `//!` comments at the top of a file or of the mechanism's body (they
//! document the mechanism).
//!
//! ```text
//! Mechanism  := Doc* "mechanism" Ident "{" Item* "}"
//! Item       := Doc* ( Param | Body | Point | Coord | Curve | Equation | Output )
//! Param      := "param" Ident "=" Expr ";"              constant: numbers, `pi`, earlier params
//! Body       := "body" Ident "{" BodyField,* "}"
//!             | "body" Ident ";"                          guess (0, 0, 0)
//! BodyField  := "guess" ":" "(" Expr "," Expr "," Expr ")"     (x, y, phi), constants of params
//!             | "mass" ":" Expr | "inertia" ":" Expr       dynamics: constants ≥ 0
//!             | "velocity" ":" "(" Expr "," Expr "," Expr ")"  initial (ẋ, ẏ, φ̇) of forward
//!                                                          dynamics (needs inertia), constants
//! Point      := "point" Body "." Ident "=" Expr ";"      local coordinates, constants of params
//! Coord      := "coord" Ident ( "{" "guess" ":" Expr "}" | ";" )   a coordinate of its own (guess 0)
//! Curve      := "curve" Body "." Ident "(" Ident ")" "=" Expr ";"  vector of params and the parameter
//! Equation   := ( "joint" | "constraint" | "driver" ) Ident ":" ( Expr "==" Expr | LibraryCall ) ";"
//! Output     := "output" Ident ":" Expr ";"                a measure: scalar or vector of q, params, t
//! Expr       := Product ( ( "+" | "-" ) Product )*
//! Product    := Unary ( ( "*" | "/" ) Unary )*
//! Unary      := "-"* Postfix
//! Postfix    := Primary ( "." Ident )*
//! Primary    := Number | Ident | Ident "(" Expr,* ")" | "(" Expr ")" | "(" Expr "," Expr ")"
//! ```
//!
//! - Numbers are written as in maths: `2`, `0.3`, `1e-3`. Type suffixes
//!   (`2f64`) are errors, so are non-finite values (`1e999`) and `1.e5`
//!   (Rust reads it as the field `e5` of `1`; write `1e5` or `1.0e5`).
//! - Names: `pi`; `t` (time); `ground` (the fixed body, no coordinates; a
//!   point on ground `ground(x, y)` is a global point); params; bodies;
//!   coordinates of their own (`coord`, a scalar by its bare name).
//! - Scalars: numbers, params, `pi`, `t`, coordinates `B.x`, `B.y`,
//!   `B.phi`, components `v.x`, `v.y` of a vector `v`, `+ - * /`, unary `-`,
//!   and the functions `sin cos tan asin acos atan sinh cosh tanh exp ln sqrt
//!   abs`, `atan2(y, x)`, `pow(x, y)`, `powi(x, n)` (n an integer literal),
//!   `step(x, x0, h0, x1, h1)` (cubic step), `dot(a, b)`,
//!   `cross(a, b)` (= a_x b_y − a_y b_x), `norm(a)`.
//! - Vectors: points `B(sx, sy)` and `B.name` (global position of a
//!   body-fixed point, local coordinates in the body frame), literals
//!   `(a, b)`, `u + v`, `u - v`, `-u`, `c * u`, `u * c`, `u / c`,
//!   `rot(angle, v)` (= A(angle) v), `perp(v)` (= R v, rotated +90°).
//! - `lhs == rhs` is the equation Φ = lhs − rhs; a vector equation gives two
//!   rows `name.x`, `name.y`.
//! - `joint` and `constraint` are kinematic: they may not depend on `t`.
//!   `driver` rows are driving equations, normally functions of `t` (a driver
//!   that does not mention `t` is accepted with a warning).
//! - Every equation depends on at least one coordinate.
//! - The mechanism must have NDOF = 3·bodies + coords − kinematic rows −
//!   driving rows = 0.
//!
//! - `output NAME: EXPR;` is a measure, a result of the analysis with its
//!   first and second time derivatives (columns `NAME`, `NAME_dot`,
//!   `NAME_ddot`; a vector gives `NAME.x`, `NAME.y` and their suffixed
//!   forms). Named points are results too (`B.name.x`, `B.name.y`). See
//!   [`outputs`].
//!
//! In the derivation, coordinates are `B.x`, `B.y`, `B.phi` for each body in
//! declaration order, then the coordinates of their own (`coord`) by name in
//! declaration order (velocities `B.x_dot`, …, `alpha_dot`); rows of Φ are
//! the kinematic equations in declaration order, then the driving ones.
//!
//! A curve `curve B.c(u) = (x(u), y(u));` is fixed in body `B` (or
//! `ground`); its expression may use params, `pi` and its parameter `u`
//! (nothing else: no `t`, no coordinates) and must depend on `u`. The
//! followers take it as `B.c` with a coordinate of its own, which they
//! substitute for `u` ([`follower`]).
//!
//! Library constraints (docs/src/constraints.md; P is a point `B(sx, sy)`, `B.name`
//! or `ground(x, y)`; B a body or `ground`; v, a body-fixed vectors `(vx, vy)`
//! in the frame of the body of the point they follow; f, C, L, c, R, θ scalar
//! expressions of params and `t`). Rows are named `name` for one row,
//! `name.x`/`name.y` for `revolute` and `point_follower`, and `name.1`,
//! `name.2` (, `name.3`) for the other constraints of several rows. Distance forms are Φ = dᵀd − C² (no ½).
//!
//! | call | Φ | rows |
//! |---|---|---|
//! | `abs_x(P, f)`, `abs_y(P, f)` | x (y) of P − f | 1 |
//! | `abs_angle(B, f)` | φ_B − f | 1 |
//! | `abs_distance(P, (cx, cy), C)` | hᵀh − C², h = P − c | 1 |
//! | `rel_x(Pi, Pj, f)`, `rel_y(Pi, Pj, f)` | x (y) of d − f, d = Pj − Pi | 1 |
//! | `rel_angle(Bi, Bj, f)` | φ_j − φ_i − f | 1 |
//! | `rel_distance(Pi, Pj, C)` | dᵀd − C² | 1 |
//! | `revolute(Pi, Pj)` | Pi − Pj | 2 |
//! | `translational(Pi, vi, Pj, vj)` | [n_iᵀd; n_iᵀu_j], u = A v, n_i = R u_i | 2 |
//! | `revolute_revolute(Pi, Pj, L)` | dᵀd − L² | 1 |
//! | `revolute_translational(Pi, vi, Pj, c)` | n̂_iᵀd − c (v normalised) | 1 |
//! | `gear(Pi, Pj, Ri, Rj, theta_i, theta_j)` | e⊥ᵀd (CONSTRAINTS §3) | 1 |
//! | `rack_pinion(Pi, vi, Pj, Rp, c0)` | [n̂ᵀd − Rp; ûᵀd + Rp(φ_j − φ_i) − c0] | 2 |
//! | `translational_distance(Pi, vi, Pj, C)` | ûᵀd − C | 1 |
//! | `dp1(Bi, ai, Bj, aj, f)` | a_iᵀa_j − f | 1 |
//! | `dp2(Pi, ai, Pj, f)` | a_iᵀd − f | 1 |
//! | `d(Pi, Pj, f)` | dᵀd − f | 1 |
//! | `cd((cx, cy), Pi, Pj, f)` | cᵀd − f | 1 |
//! | `point_follower(P, B.curve, alpha)` | P − (r_B + A_B c'(α)) (Haug PF) | 2 |
//! | `cam_follower(Bi.ci, alpha_i, Bj.cj, alpha_j)` | [p_i − p_j; (R t_i)ᵀt_j], p = r + A c'(α), t = A dc'/dα (Haug CF) | 3 |
//! | `flat_follower(B.curve, alpha, P, v)` | [n̂ᵀ(c − P); (R t)ᵀû], c, t of the curve at α, û = A v̂, n̂ = R û | 2 |
//!
//! Every library constraint is written with the same vector algebra users
//! have ([`algebra`]); no derivative is written by hand. The followers'
//! curves are differentiated with respect to their coordinate by the
//! engine (the tangent dc'/dα and, in Φ_q, ν, γ, its derivatives).

pub mod algebra;
pub mod chain;
pub mod check;
mod ctxt;
pub mod derive;
pub mod diagnostic;
pub mod dynamics;
pub mod follower;
pub mod front;
mod library;
pub mod linkage;
pub mod outputs;
mod points;
pub mod print;
mod render;
pub mod sensitivity;
pub mod source;
pub mod span;
pub mod syntax;

/// `i` as the `u32` a model counts its declarations, coordinates, rows and
/// expression nodes in; past `u32::MAX` it panics with a message (a bug, never
/// an alias of another index).
#[track_caller]
pub(crate) fn idx(i: usize) -> u32 {
    kinema_index::u32_of(i, "a model's declaration, coordinate or node")
}

pub use check::{BodyRef, CheckedModel, Comp, Coord, Curve, DofReport, LibKind, Output};
pub use derive::{Coordinate, DERIVATION_BUDGET, Derivation, ParamInfo, Row, RowKind};
pub use diagnostic::{Diagnostic, Diagnostics, Renderer, Severity};
pub use dynamics::{DynamicsDerivation, Reaction};
pub use front::{Checked, Derived, Entry, MAX_SOURCE_BYTES, Parsed, Report, Source};
pub use linkage::{LinkageAngle, LinkageDesc, LinkagePin};
pub use outputs::{OutputColumn, OutputSource};
pub use points::EquationPoint;
pub use sensitivity::{
    DynamicsSensitivity, OutputSensitivity, ParamSensitivity, Sensitivities, SensitivityError,
};
pub use span::Span;
pub use syntax::EquationKeyword;

/// A parsed (not yet validated) mechanism.
#[derive(Clone, Debug)]
pub struct ParsedModel {
    syntax: syntax::Mechanism,
}

impl ParsedModel {
    /// Parses the text of a `.kin` file.
    ///
    /// # Errors
    /// Lexer and parser errors.
    pub fn parse_str(source: &str) -> Result<ParsedModel, Diagnostics> {
        syntax::parse_str(source).map(|syntax| ParsedModel { syntax })
    }

    /// Parses the tokens of a `mechanism! { … }` invocation.
    ///
    /// # Errors
    /// Parser errors.
    pub fn parse_tokens(tokens: proc_macro2::TokenStream) -> Result<ParsedModel, Diagnostics> {
        syntax::parse_tokens(tokens).map(|syntax| ParsedModel { syntax })
    }

    /// A syntax tree built by another front end (the simEngine2D
    /// importer builds one from its JSON, each span at the place in its
    /// file that the item comes from). The checker treats it as parsed
    /// text.
    #[must_use]
    pub fn from_syntax(syntax: syntax::Mechanism) -> ParsedModel {
        ParsedModel { syntax }
    }

    /// The syntax tree.
    #[must_use]
    pub fn syntax(&self) -> &syntax::Mechanism {
        &self.syntax
    }

    /// Validates the model (all rules of [`check`]).
    ///
    /// # Errors
    /// Every error found, with the warnings.
    pub fn check(&self) -> Result<CheckedModel, Diagnostics> {
        check::check(&self.syntax)
    }
}

/// Parses and checks the text of a `.kin` file in one go.
///
/// # Errors
/// Every error found, with the warnings.
pub fn check_str(source: &str) -> Result<CheckedModel, Diagnostics> {
    ParsedModel::parse_str(source)?.check()
}

/// Parses, checks and derives the text of a `.kin` file in one go.
///
/// # Errors
/// Every error found, with the warnings.
pub fn derive_str(source: &str) -> Result<Derivation, Diagnostics> {
    let parsed = ParsedModel::parse_str(source)?;
    Parsed::new(Source::new("model.kin", source), parsed)
        .derive_at_tokens()
        .map(|derived| derived.into_parts().1)
}
