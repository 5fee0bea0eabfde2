//! Phase 3: the derivation. From a [`CheckedModel`] it builds Φ and all its
//! derivatives in one arena. It cannot fail.
//!
//! With q the coordinates, q̇ their velocities and t time:
//!
//! - `Φ_q q̇` = directional derivative of Φ along seeds {q_k → q̇_k};
//! - `(Φ_q q̇)_q q̇` = directional derivative of `Φ_q q̇` along the same seeds
//!   (no Hessian is formed);
//! - `Φ_t = ∂Φ/∂t`, `Φ_tt = ∂Φ_t/∂t`, `Φ_qt q̇ = ∂(Φ_q q̇)/∂t`;
//! - `ν = −Φ_t`, `γ = −(Φ_q q̇)_q q̇ − 2Φ_qt q̇ − Φ_tt`.

use kinema_expr::{Arena, ExprId, SparseMatrix, SymId};

use crate::check::{CheckedModel, Comp, DofReport, Form, LibKind};
use crate::lower::Lowerer;
use crate::syntax::EquationKeyword;

/// One generalized coordinate.
#[derive(Clone, Debug)]
pub struct Coordinate {
    /// `B.x`, `B.y` or `B.phi`.
    pub name: String,
    /// Index of the body (declaration order).
    pub body: usize,
    /// Which coordinate of the body.
    pub comp: Comp,
    /// The coordinate's symbol (kind `Coordinate(index)`).
    pub sym: SymId,
    /// The velocity's symbol (kind `Velocity(index)`), named `B.x_dot` etc.
    pub velocity: SymId,
    /// The initial guess, an expression of the params.
    pub guess: ExprId,
    /// The initial guess at the default params.
    pub guess_value: f64,
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
    /// Body names in declaration order; body k owns coordinates 3k..3k+3.
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
}

impl Derivation {
    /// Derives everything from a checked model. Cannot fail.
    #[must_use]
    pub fn new(model: &CheckedModel) -> Self {
        let mut arena = Arena::new();
        let lo = Lowerer::new(&mut arena, model);

        // Coordinates, velocities, guesses.
        let mut coordinates = Vec::with_capacity(3 * model.bodies.len());
        for (k, b) in model.bodies.iter().enumerate() {
            for (c, comp) in [Comp::X, Comp::Y, Comp::Phi].into_iter().enumerate() {
                let i = 3 * k + c;
                let q = lo.coords[k][c];
                let suffix = ["x", "y", "phi"][c];
                let qd = arena.velocity(&format!("{}.{suffix}_dot", b.name), idx(i));
                let guess = lo.scalar(&mut arena, &b.guess[c]);
                coordinates.push(Coordinate {
                    name: format!("{}.{suffix}", b.name),
                    body: k,
                    comp,
                    sym: sym(&arena, q),
                    velocity: sym(&arena, qd),
                    guess,
                    guess_value: b.guess_value[c],
                });
            }
        }
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

        // Φ: kinematic equations first, then drivers, each in declaration order.
        let mut rows = Vec::new();
        let mut phi = Vec::new();
        for driving in [false, true] {
            for e in model.equations.iter().filter(|e| e.is_driver() == driving) {
                let exprs = match &e.form {
                    Form::User { lhs, rhs } => {
                        let l = lo.lower(&mut arena, lhs);
                        let r = lo.lower(&mut arena, rhs);
                        match (l, r) {
                            (crate::lower::Value::V(a), crate::lower::Value::V(b)) => {
                                vec![arena.sub(a.x, b.x), arena.sub(a.y, b.y)]
                            }
                            (crate::lower::Value::S(a), crate::lower::Value::S(b)) => {
                                vec![arena.sub(a, b)]
                            }
                            // The checker gives both sides the same type.
                            _ => Vec::new(),
                        }
                    }
                    Form::Library(kind, args) => crate::library::rows(&lo, &mut arena, *kind, args),
                };
                for (name, ex) in e.row_names().into_iter().zip(exprs) {
                    rows.push(Row {
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
                    phi.push(ex);
                }
            }
        }

        // Derivatives.
        let q_syms: Vec<SymId> = coordinates.iter().map(|c| c.sym).collect();
        let pairs: Vec<(SymId, ExprId)> = coordinates
            .iter()
            .map(|c| (c.sym, arena.sym_expr(c.velocity)))
            .collect();
        let seeds = arena.seeds(&pairs);
        let phi_q = arena.jacobian(&phi, &q_syms);
        let phi_t: Vec<ExprId> = phi.iter().map(|&e| arena.diff(e, time)).collect();
        let phi_tt: Vec<ExprId> = phi_t.iter().map(|&e| arena.diff(e, time)).collect();
        let phi_qt = arena.jacobian(&phi_t, &q_syms);
        let phi_q_qdot: Vec<ExprId> = phi.iter().map(|&e| arena.directional(e, seeds)).collect();
        let phi_q_qdot_q_qdot: Vec<ExprId> = phi_q_qdot
            .iter()
            .map(|&e| arena.directional(e, seeds))
            .collect();
        let phi_qt_qdot: Vec<ExprId> = phi_q_qdot.iter().map(|&e| arena.diff(e, time)).collect();
        let nu: Vec<ExprId> = phi_t.iter().map(|&e| arena.neg(e)).collect();
        let gamma: Vec<ExprId> = (0..phi.len())
            .map(|i| {
                let a = arena.neg(phi_q_qdot_q_qdot[i]);
                let b = arena.scale(2.0, phi_qt_qdot[i]);
                let ab = arena.sub(a, b);
                arena.sub(ab, phi_tt[i])
            })
            .collect();

        Derivation {
            name: model.name.clone(),
            docs: model.docs.clone(),
            params,
            bodies: model.bodies.iter().map(|b| b.name.clone()).collect(),
            body_docs: model.bodies.iter().map(|b| b.docs.clone()).collect(),
            coordinates,
            time,
            rows,
            phi,
            phi_q,
            phi_t,
            phi_qt,
            phi_tt,
            phi_q_qdot,
            phi_q_qdot_q_qdot,
            phi_qt_qdot,
            nu,
            gamma,
            dof: model.dof(),
            arena,
        }
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

fn sym(arena: &Arena, e: ExprId) -> SymId {
    // Symbols built by `coordinate`/`velocity`/`parameter`/`time` are leaves.
    arena
        .symbol_of(e)
        .unwrap_or_else(|| unreachable!("a symbol constructor returned a non-symbol"))
}

fn idx(i: usize) -> u32 {
    u32::try_from(i).unwrap_or(u32::MAX)
}
