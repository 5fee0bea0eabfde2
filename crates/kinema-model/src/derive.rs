//! Phase 3: the derivation. From a [`CheckedModel`] it builds Φ and all its
//! derivatives in one arena. It fails only when one equation's derivatives
//! would outgrow [`DERIVATION_BUDGET`] (an error at the equation's name).
//!
//! With q the coordinates, q̇ their velocities and t time:
//!
//! - `Φ_q q̇` = directional derivative of Φ along seeds {q_k → q̇_k};
//! - `(Φ_q q̇)_q q̇` = directional derivative of `Φ_q q̇` along the same seeds
//!   (no Hessian is formed);
//! - `Φ_t = ∂Φ/∂t`, `Φ_tt = ∂Φ_t/∂t`, `Φ_qt q̇ = ∂(Φ_q q̇)/∂t`;
//! - `ν = −Φ_t`, `γ = −(Φ_q q̇)_q q̇ − 2Φ_qt q̇ − Φ_tt`.

use kinema_expr::{Arena, Columns, Entry, ExprId, SparseMatrix, SymId};

use crate::check::lower::Lowerer;
use crate::check::{CheckedModel, Comp, DofReport, Form, LibKind};
use crate::diagnostic::{Diagnostic, Diagnostics};
use crate::idx;
use crate::syntax::EquationKeyword;
use kinema_index::{Axis, Body};

/// The most arena entries (nodes, sum terms, product factors: see
/// [`Arena::size`]) that the derivatives of one declared equation may add:
/// Φ_q, Φ_t, Φ_tt, Φ_qt, Φ_q q̇, (Φ_q q̇)_q q̇, Φ_qt q̇ and γ of its rows
/// together.
///
/// Derivatives are linear in the size of the equation, so real equations
/// stay far below it (a joint of a chain of 1000 bodies adds a few hundred
/// entries; one product of 800 coordinates about 100 000). It is there so that an
/// equation whose derivatives would not fit in memory ends with an error
/// naming it instead of an allocation failure. About 100 bytes per entry:
/// the limit is some 200 MB.
pub const DERIVATION_BUDGET: usize = 2_000_000;

/// One generalized coordinate.
#[derive(Clone, Debug)]
pub struct Coordinate {
    /// `B.x`, `B.y` or `B.phi`; a coordinate of its own (`coord`) has its
    /// declared name.
    pub name: String,
    /// Index of the body (declaration order); for [`Comp::Extra`], the
    /// number of bodies plus the index among the `coord` items (never a
    /// body's index).
    pub body: usize,
    /// Which coordinate of the body, or [`Comp::Extra`].
    pub comp: Comp,
    /// The coordinate's symbol (kind `Coordinate(index)`).
    pub sym: SymId,
    /// The velocity's symbol (kind `Velocity(index)`), named `B.x_dot` etc.
    pub velocity: SymId,
    /// The initial guess, an expression of the params.
    pub guess: ExprId,
    /// The initial guess at the default params.
    pub guess_value: f64,
    /// The stated initial velocity (a body's `velocity` item), an
    /// expression of the params; `None` when not stated (zero).
    pub initial_velocity: Option<ExprId>,
    /// The initial velocity at the default params (0 when not stated):
    /// where forward dynamics starts.
    pub initial_velocity_value: f64,
}

/// One parameter.
#[derive(Clone, Debug)]
pub struct ParamInfo {
    /// Its name.
    pub name: String,
    /// Its default value.
    pub value: f64,
    /// Doc comments.
    pub docs: Vec<String>,
    /// Its symbol (kind `Parameter(index)`).
    pub sym: SymId,
}

/// Whether a row is kinematic or driving.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RowKind {
    /// A kinematic constraint (`joint` or `constraint`): does not depend on t.
    Kinematic,
    /// A driving constraint (`driver`).
    Driving,
}

/// One scalar row of Φ.
#[derive(Clone, Debug)]
pub struct Row {
    /// `name`, `name.x`/`name.y` or `name.1`/`name.2`.
    pub name: String,
    /// Kinematic or driving.
    pub kind: RowKind,
    /// The keyword that declared it.
    pub keyword: EquationKeyword,
    /// The library constraint it comes from, if any.
    pub library: Option<LibKind>,
    /// Name of the declared equation it belongs to.
    pub equation: String,
    /// Doc comments of that equation.
    pub docs: Vec<String>,
}

/// The full kinematic derivation of a mechanism.
///
/// Every output is an [`ExprId`] in [`Derivation::arena`]; sparse matrices
/// store only structural nonzeros, row-major.
#[derive(Clone, Debug)]
pub struct Derivation {
    /// The arena holding every expression below.
    pub arena: Arena,
    /// The mechanism's name.
    pub name: String,
    /// Its doc comments.
    pub docs: Vec<String>,
    /// Parameters in declaration order (`Parameter(i)` is `params[i]`).
    pub params: Vec<ParamInfo>,
    /// Body names in declaration order; body k owns coordinates 3k..3k+3,
    /// and the coordinates of their own (`coord`) follow the bodies'.
    pub bodies: Vec<String>,
    /// Doc comments of each body.
    pub body_docs: Vec<Vec<String>>,
    /// Coordinates q (`Coordinate(i)` is `coordinates[i]`).
    pub coordinates: Vec<Coordinate>,
    /// The time symbol.
    pub time: SymId,
    /// The rows of Φ: kinematic first (declaration order), then driving.
    pub rows: Vec<Row>,
    /// Φ(q, t).
    pub phi: Vec<ExprId>,
    /// Φ_q, sparse (rows × nc).
    pub phi_q: SparseMatrix,
    /// Φ_t.
    pub phi_t: Vec<ExprId>,
    /// Φ_qt = ∂Φ_t/∂q, sparse.
    pub phi_qt: SparseMatrix,
    /// Φ_tt.
    pub phi_tt: Vec<ExprId>,
    /// Φ_q q̇.
    pub phi_q_qdot: Vec<ExprId>,
    /// (Φ_q q̇)_q q̇.
    pub phi_q_qdot_q_qdot: Vec<ExprId>,
    /// Φ_qt q̇.
    pub phi_qt_qdot: Vec<ExprId>,
    /// ν = −Φ_t (velocity right-hand side).
    pub nu: Vec<ExprId>,
    /// γ = −(Φ_q q̇)_q q̇ − 2Φ_qt q̇ − Φ_tt (acceleration right-hand side).
    pub gamma: Vec<ExprId>,
    /// The DOF report.
    pub dof: DofReport,
    /// Named points (`.x`, `.y`) then measures, with their derivatives
    /// ([`crate::outputs`]).
    pub outputs: Vec<crate::outputs::OutputColumn>,
    /// Mass matrix, applied forces, their derivatives and the reactions'
    /// arms; `None` for a kinematic model.
    pub dynamics: Option<crate::dynamics::DynamicsDerivation>,
    /// The model as revolute joints and driven angles, if that is all it
    /// is (a closed-form position solution may exist: see
    /// [`crate::linkage`]).
    pub linkage: Option<crate::linkage::LinkageDesc>,
}

impl Derivation {
    /// Derives everything from a checked model, each equation within
    /// [`DERIVATION_BUDGET`].
    ///
    /// # Errors
    /// An equation whose derivatives would outgrow the budget, at its name.
    pub fn new(model: &CheckedModel) -> Result<Self, Diagnostics> {
        Self::with_budget(model, DERIVATION_BUDGET)
    }

    /// [`Derivation::new`] with another budget per equation (arena entries,
    /// see [`DERIVATION_BUDGET`]).
    ///
    /// # Errors
    /// An equation whose derivatives would outgrow `budget`, at its name.
    pub fn with_budget(model: &CheckedModel, budget: usize) -> Result<Self, Diagnostics> {
        let mut arena = Arena::new();
        let lo = Lowerer::new(&mut arena, model);
        let coordinates = coordinates(&mut arena, &lo, model);
        let params = model
            .params
            .iter()
            .zip(&lo.params)
            .map(|(p, &e)| ParamInfo {
                name: p.name.clone(),
                value: p.value,
                docs: p.docs.clone(),
                sym: sym(&arena, e),
            })
            .collect();
        let time = sym(&arena, lo.time);
        let Phi { rows, phi, source } = phi_rows(&mut arena, &lo, model);

        let q_syms: Vec<SymId> = coordinates.iter().map(|c| c.sym).collect();
        let pairs: Vec<(SymId, ExprId)> = coordinates
            .iter()
            .map(|c| (c.sym, arena.sym_expr(c.velocity)))
            .collect();
        let along = crate::outputs::Along {
            seeds: arena.seeds(&pairs),
            columns: &Columns::new(&q_syms),
            time,
            budget,
        };
        let d = Derivatives::of(&mut arena, &phi, &source, q_syms.len(), &along)
            .map_err(|row| too_large(&model.equations[source[row]], budget))?;
        let outputs = crate::outputs::derive_outputs(model, &lo, &mut arena, &along)?;
        let linkage = crate::linkage::describe(&mut arena, &lo, model, &phi, &d.phi_q, &source);
        let dynamics = model.dynamics.as_ref().map(|dy| {
            crate::dynamics::derive(&lo, &mut arena, model, dy, &rows, &d.phi_q, along.seeds)
        });

        Ok(Derivation {
            name: model.name.clone(),
            docs: model.docs.clone(),
            params,
            bodies: model.bodies.iter().map(|b| b.name.clone()).collect(),
            body_docs: model.bodies.iter().map(|b| b.docs.clone()).collect(),
            coordinates,
            time,
            rows,
            phi,
            phi_q: d.phi_q,
            phi_t: d.phi_t,
            phi_qt: d.phi_qt,
            phi_tt: d.phi_tt,
            phi_q_qdot: d.phi_q_qdot,
            phi_q_qdot_q_qdot: d.phi_q_qdot_q_qdot,
            phi_qt_qdot: d.phi_qt_qdot,
            nu: d.nu,
            gamma: d.gamma,
            dof: model.dof(),
            outputs,
            dynamics,
            linkage,
            arena,
        })
    }

    /// Number of coordinates nc.
    #[must_use]
    pub fn nc(&self) -> usize {
        self.coordinates.len()
    }

    /// Symbols of the coordinates, in order (the columns of Φ_q).
    #[must_use]
    pub fn coordinate_syms(&self) -> Vec<SymId> {
        self.coordinates.iter().map(|c| c.sym).collect()
    }

    /// Symbols of the velocities, in order.
    #[must_use]
    pub fn velocity_syms(&self) -> Vec<SymId> {
        self.coordinates.iter().map(|c| c.velocity).collect()
    }

    /// Symbols of the params, in order.
    #[must_use]
    pub fn param_syms(&self) -> Vec<SymId> {
        self.params.iter().map(|p| p.sym).collect()
    }

    /// Default param values, in order.
    #[must_use]
    pub fn param_values(&self) -> Vec<f64> {
        self.params.iter().map(|p| p.value).collect()
    }

    /// Initial guess of q at the default params.
    #[must_use]
    pub fn guess_values(&self) -> Vec<f64> {
        self.coordinates.iter().map(|c| c.guess_value).collect()
    }

    /// The initial velocities at the default params: each body's stated
    /// `velocity`, zero elsewhere (forward dynamics starts there).
    #[must_use]
    pub fn initial_velocity_values(&self) -> Vec<f64> {
        self.coordinates
            .iter()
            .map(|c| c.initial_velocity_value)
            .collect()
    }

    /// The stated start at the params `p` (declaration order): the
    /// guesses q⁰ and the initial velocities q̇⁰ (zero where no `velocity`
    /// is stated), evaluated again, so a start written in terms of params
    /// follows them. At the default params, the values above.
    #[must_use]
    pub fn start_at(&self, p: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let q = self
            .coordinates
            .iter()
            .map(|c| self.eval(c.guess, &[], &[], 0.0, p))
            .collect();
        let qd = self
            .coordinates
            .iter()
            .map(|c| {
                c.initial_velocity
                    .map_or(0.0, |v| self.eval(v, &[], &[], 0.0, p))
            })
            .collect();
        (q, qd)
    }

    /// Evaluates `e` at coordinates `q`, velocities `qd`, time `t` and
    /// params `p` (missing entries read as NaN).
    #[must_use]
    pub fn eval(&self, e: ExprId, q: &[f64], qd: &[f64], t: f64, p: &[f64]) -> f64 {
        self.arena.eval(e, |s| {
            use kinema_expr::SymKind;
            let get = |v: &[f64], i: u32| v.get(i as usize).copied().unwrap_or(f64::NAN);
            match self.arena.symbol(s).kind {
                SymKind::Coordinate(i) => get(q, i),
                SymKind::Velocity(i) => get(qd, i),
                SymKind::Parameter(i) => get(p, i),
                SymKind::Time => t,
            }
        })
    }

    /// Evaluates a vector of expressions (see [`Derivation::eval`]).
    #[must_use]
    pub fn eval_vec(&self, es: &[ExprId], q: &[f64], qd: &[f64], t: f64, p: &[f64]) -> Vec<f64> {
        es.iter().map(|&e| self.eval(e, q, qd, t, p)).collect()
    }

    /// Evaluates a sparse matrix densely (row-major `rows × cols`).
    #[must_use]
    pub fn eval_dense(
        &self,
        m: &SparseMatrix,
        q: &[f64],
        qd: &[f64],
        t: f64,
        p: &[f64],
    ) -> Vec<Vec<f64>> {
        let mut out = vec![vec![0.0; m.cols]; m.rows];
        for en in &m.entries {
            out[en.row as usize][en.col as usize] = self.eval(en.expr, q, qd, t, p);
        }
        out
    }
}

/// The coordinates q, in order: x, y, φ of each body, then the
/// coordinates of their own; each with its velocity symbol q̇ and guess.
fn coordinates(arena: &mut Arena, lo: &Lowerer<'_>, model: &CheckedModel) -> Vec<Coordinate> {
    let mut coordinates = Vec::with_capacity(3 * model.bodies.len());
    for (k, b) in model.bodies.iter().enumerate() {
        for (c, comp) in [Comp::X, Comp::Y, Comp::Phi].into_iter().enumerate() {
            let axis = Axis::ALL[c];
            let i = Body::new(k).coord(axis).index();
            let q = lo.coords[k][c];
            let suffix = axis.name();
            let qd = arena.velocity(&format!("{}.{suffix}_dot", b.name), idx(i));
            let guess = lo.scalar(arena, &b.guess[c]);
            let initial_velocity = b.velocity.as_ref().map(|v| lo.scalar(arena, &v.exprs[c]));
            coordinates.push(Coordinate {
                name: format!("{}.{suffix}", b.name),
                body: k,
                comp,
                sym: sym(arena, q),
                velocity: sym(arena, qd),
                guess,
                guess_value: b.guess_value[c],
                initial_velocity,
                initial_velocity_value: b.velocity.as_ref().map_or(0.0, |v| v.value[c]),
            });
        }
    }
    crate::follower::push_coordinates(arena, lo, model, &mut coordinates);
    coordinates
}

/// Φ's rows, lowered: kinematic equations first, then drivers, each in
/// declaration order.
struct Phi {
    rows: Vec<Row>,
    phi: Vec<ExprId>,
    /// The equation each row comes from (for budget errors).
    source: Vec<usize>,
}

/// Lowers every equation into rows of Φ: `lhs == rhs` is Φ = lhs − rhs
/// (a vector equation two rows, x then y); a library call its rows
/// ([`crate::library::rows`]).
fn phi_rows(arena: &mut Arena, lo: &Lowerer<'_>, model: &CheckedModel) -> Phi {
    use crate::check::lower::Value;
    let mut out = Phi {
        rows: Vec::new(),
        phi: Vec::new(),
        source: Vec::new(),
    };
    for driving in [false, true] {
        for (eq, e) in model
            .equations
            .iter()
            .enumerate()
            .filter(|(_, e)| e.is_driver() == driving)
        {
            let exprs = match &e.form {
                Form::User { lhs, rhs } => match (lo.lower(arena, lhs), lo.lower(arena, rhs)) {
                    (Value::V(a), Value::V(b)) => vec![arena.sub(a.x, b.x), arena.sub(a.y, b.y)],
                    (Value::S(a), Value::S(b)) => vec![arena.sub(a, b)],
                    // The checker gives both sides the same type.
                    _ => Vec::new(),
                },
                Form::Library(kind, args) => crate::library::rows(lo, arena, *kind, args),
            };
            for (name, ex) in e.row_names().into_iter().zip(exprs) {
                out.rows.push(Row {
                    name,
                    kind: if driving {
                        RowKind::Driving
                    } else {
                        RowKind::Kinematic
                    },
                    keyword: e.keyword,
                    library: e.library,
                    equation: e.name.clone(),
                    docs: e.docs.clone(),
                });
                out.phi.push(ex);
                out.source.push(eq);
            }
        }
    }
    out
}

/// Φ's derivatives, row by row (module docs): Φ_q and Φ_qt sparse, the
/// others one entry per row.
struct Derivatives {
    phi_q: SparseMatrix,
    phi_qt: SparseMatrix,
    phi_t: Vec<ExprId>,
    phi_tt: Vec<ExprId>,
    phi_q_qdot: Vec<ExprId>,
    phi_q_qdot_q_qdot: Vec<ExprId>,
    phi_qt_qdot: Vec<ExprId>,
    nu: Vec<ExprId>,
    gamma: Vec<ExprId>,
}

impl Derivatives {
    /// Derives every row of `phi` (`cols` coordinates); the rows of one
    /// equation (`source`)
    /// share a budget of `along.budget` arena entries, counted from its
    /// first row. On overflow, the index of the row that overflowed.
    fn of(
        arena: &mut Arena,
        phi: &[ExprId],
        source: &[usize],
        cols: usize,
        along: &crate::outputs::Along<'_>,
    ) -> Result<Derivatives, usize> {
        let n = phi.len();
        let empty = SparseMatrix {
            rows: n,
            cols,
            entries: Vec::new(),
        };
        let mut d = Derivatives {
            phi_q: empty.clone(),
            phi_qt: empty,
            phi_t: Vec::with_capacity(n),
            phi_tt: Vec::with_capacity(n),
            phi_q_qdot: Vec::with_capacity(n),
            phi_q_qdot_q_qdot: Vec::with_capacity(n),
            phi_qt_qdot: Vec::with_capacity(n),
            nu: Vec::with_capacity(n),
            gamma: Vec::with_capacity(n),
        };
        let mut limit_of: Option<(usize, usize)> = None;
        for (i, &e) in phi.iter().enumerate() {
            let limit = match limit_of {
                Some((eq, limit)) if eq == source[i] => limit,
                _ => {
                    let limit = arena.size().saturating_add(along.budget);
                    limit_of = Some((source[i], limit));
                    limit
                }
            };
            arena.set_budget(Some(limit));
            d.push_row(arena, i, e, along);
            if arena.budget_exceeded() || arena.size() > limit {
                return Err(i);
            }
        }
        arena.set_budget(None);
        Ok(d)
    }

    /// Row `i` with Φ_i = `e`: Φ_q, Φ_t, Φ_tt = ∂Φ_t/∂t, Φ_qt, Φ_q q̇ (the
    /// directional derivative v along q → q̇), (Φ_q q̇)_q q̇ (that of v),
    /// Φ_qt q̇ = ∂v/∂t; ν = −Φ_t and γ = −(Φ_q q̇)_q q̇ − 2Φ_qt q̇ − Φ_tt.
    fn push_row(
        &mut self,
        arena: &mut Arena,
        i: usize,
        e: ExprId,
        along: &crate::outputs::Along<'_>,
    ) {
        let row = |m: SparseMatrix| {
            m.entries
                .into_iter()
                .map(move |en| Entry { row: idx(i), ..en })
        };
        let jq = arena.jacobian_by(&[e], along.columns);
        self.phi_q.entries.extend(row(jq));
        let et = arena.diff(e, along.time);
        let ett = arena.diff(et, along.time);
        let jqt = arena.jacobian_by(&[et], along.columns);
        self.phi_qt.entries.extend(row(jqt));
        let v = arena.directional(e, along.seeds);
        let vv = arena.directional(v, along.seeds);
        let vt = arena.diff(v, along.time);
        self.phi_t.push(et);
        self.phi_tt.push(ett);
        self.phi_q_qdot.push(v);
        self.phi_q_qdot_q_qdot.push(vv);
        self.phi_qt_qdot.push(vt);
        self.nu.push(arena.neg(et));
        let a = arena.neg(vv);
        let b = arena.scale(2.0, vt);
        let ab = arena.sub(a, b);
        self.gamma.push(arena.sub(ab, ett));
    }
}

/// The error for an equation whose derivatives outgrow `budget`, at its
/// name.
fn too_large(eq: &crate::check::Equation, budget: usize) -> Diagnostics {
    let mut errors = Diagnostics::new();
    errors.push(
        Diagnostic::error(
            eq.span,
            format!(
                "the derivatives of `{}` are too large: they would need more than {budget} \
                 expression entries (the limit per equation)",
                eq.name
            ),
        )
        .with_help(
            "write the equation with fewer terms or factors (e.g. split a long product \
             with extra coordinates), or derive it with a larger budget",
        ),
    );
    errors
}

fn sym(arena: &Arena, e: ExprId) -> SymId {
    // Symbols built by `coordinate`/`velocity`/`parameter`/`time` are leaves.
    arena
        .symbol_of(e)
        .unwrap_or_else(|| unreachable!("a symbol constructor returned a non-symbol"))
}
