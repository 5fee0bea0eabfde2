//! Parameter sensitivities, derived symbolically: for chosen params p, the
//! right-hand sides of the linear systems whose solutions are ∂q/∂p,
//! ∂q̇/∂p and ∂q̈/∂p, and the sensitivities of every named point and
//! measure (issue 40).
//!
//! With q, q̇, q̈ solving Φ(q, p, t) = 0, Φ_q q̇ = ν, Φ_q q̈ = γ, differentiate
//! each level with respect to one param p (s = ∂q/∂p, ṡ = ∂q̇/∂p,
//! s̈ = ∂q̈/∂p):
//!
//! - position: Φ_q s = −Φ_p;
//! - velocity: with R_v = Φ_q q̇ − ν, Φ_q ṡ = −[(R_v)_q s + (R_v)_p]: minus
//!   the directional derivative of R_v along the seeds {q_k → s_k, p → 1}
//!   ([`ParamSensitivity::velocity_rhs`]);
//! - acceleration: with R_a = Φ_q q̈ − γ,
//!   Φ_q s̈ = −[(R_a)_q s + (R_a)_q̇ ṡ + (R_a)_p] = D γ − W q̈, where D is the
//!   directional derivative along {q_k → s_k, q̇_k → ṡ_k, p → 1}
//!   ([`ParamSensitivity::acceleration_rhs`]) and W = (Φ_q s + Φ_p)_q
//!   ([`ParamSensitivity::acceleration_qdd`]): q̈ enters only through that
//!   sparse matrix, as it enters ÿ only through y_q for the outputs
//!   ([`crate::outputs`]), so no expression reads q̈;
//! - a result y(q, p, t) with ẏ and ÿ = y_q q̈ + c: y_p = D y (the
//!   position seeds), ẏ_p = D ẏ, ÿ_p = y_q s̈ + (y_p)_q q̈ + D c;
//! - with inertia, Φ_qᵀλ = Q_A − M q̈ gives
//!   Φ_qᵀ λ_p = D Q_A − M_p q̈ − M s̈ − Wᵀ λ ([`DynamicsSensitivity`]);
//!   a reaction [F; T_O] = −Φ_q,bᵀ λ_c, its torque moved to the element's
//!   point by the arm a(q, p), has F_p = −Φ_q,bᵀ (λ_p)_c − W_bᵀ λ_c (W is
//!   the derivative of Φ_q along (s, 1)) and needs a's derivative D a
//!   ([`DynamicsSensitivity::arms`]); a driver's effort −λ has −λ_p.
//!
//! Every matrix that multiplies an unknown is Φ_q itself, so one
//! factorization of the step serves every parameter and level: one extra
//! solve per parameter and level.
//!
//! # The symbols the expressions read
//!
//! s and ṡ are new symbols in the derivation's arena, laid out after q and
//! q̇ in the same input vectors (the tapes' and generated code's `q` and
//! `qd`): s_k is [`SymKind::Coordinate`]`(nc + k)`, named `∂B.x` etc., and
//! ṡ_k is [`SymKind::Velocity`]`(nc + k)`, named `∂B.x_dot`. So an
//! expression of this module evaluates on the augmented vectors
//! `[q; s]` and `[q̇; ṡ]` (with [`Derivation::eval`], a tape, or generated
//! code alike) — the sensitivity system is the derivation's own
//! kinematics of the augmented state (q, s), nothing more. One set of s
//! and ṡ symbols serves every param: evaluate param k's expressions with
//! that param's s and ṡ. The params are the derivation's param symbols:
//! each p is an independent input, as [`Derivation::params`] are at run
//! time (a param whose default was written in terms of another does not
//! follow it: ∂/∂p is the partial derivative, as setting p alone does).
//!
//! [`SymKind::Coordinate`]: kinema_expr::SymKind::Coordinate
//! [`SymKind::Velocity`]: kinema_expr::SymKind::Velocity

use std::fmt;

use kinema_expr::{Arena, Columns, Entry, ExprId, SeedsId, SparseMatrix, SymId};

use crate::derive::{DERIVATION_BUDGET, Derivation};
use crate::idx;

/// The sensitivities of a derivation with respect to some of its params
/// ([`Derivation::sensitivities`]); every expression is in
/// [`Derivation::arena`] (module docs: what each reads).
#[derive(Clone, Debug)]
pub struct Sensitivities {
    /// s_k = ∂q_k/∂p: symbol of kind `Coordinate(nc + k)`, named `∂{q_k}`.
    pub coordinates: Vec<SymId>,
    /// ṡ_k = ∂q̇_k/∂p: symbol of kind `Velocity(nc + k)`, named
    /// `∂{q_k}_dot`.
    pub velocities: Vec<SymId>,
    /// One entry per param asked for, in the order asked.
    pub params: Vec<ParamSensitivity>,
}

/// Everything needed for the sensitivities with respect to one param p.
/// Vectors are indexed by the rows of Φ ([`Derivation::rows`]); sparse
/// matrices are rows × nc, columns the coordinates q.
#[derive(Clone, Debug)]
pub struct ParamSensitivity {
    /// The param's name.
    pub name: String,
    /// Its index among [`Derivation::params`] (declaration order): the
    /// slot its symbol reads.
    pub index: usize,
    /// Its symbol (kind `Parameter(index)`).
    pub sym: SymId,
    /// Φ_p = ∂Φ/∂p; s solves Φ_q s = −Φ_p. Reads q, p, t.
    pub phi_p: Vec<ExprId>,
    /// −[(R_v)_q s + (R_v)_p] with R_v = Φ_q q̇ − ν; ṡ solves
    /// Φ_q ṡ = this. Reads q, q̇, s, p, t.
    pub velocity_rhs: Vec<ExprId>,
    /// D γ along {q → s, q̇ → ṡ, p → 1}: the acceleration right-hand side
    /// without its q̈ terms. s̈ solves
    /// Φ_q s̈ = `acceleration_rhs` − [`acceleration_qdd`](Self::acceleration_qdd) q̈.
    /// Reads q, q̇, s, ṡ, p, t.
    pub acceleration_rhs: Vec<ExprId>,
    /// W = (Φ_q s + Φ_p)_q, sparse (rows × nc): the q̈ terms of the
    /// acceleration right-hand side are −W q̈. Reads q, s, p, t.
    pub acceleration_qdd: SparseMatrix,
    /// One per result column, in the order of [`Derivation::outputs`].
    pub outputs: Vec<OutputSensitivity>,
    /// For a model with inertia, what the multipliers' sensitivity needs;
    /// `None` for a kinematic model.
    pub dynamics: Option<DynamicsSensitivity>,
}

/// The p-derivatives of the dynamics' terms: with λ solving
/// Φ_qᵀλ = Q_A − M q̈, its sensitivity λ_p solves
///
/// Φ_qᵀ λ_p = `applied` − `mass` ∘ q̈ − M ∘ s̈ − Wᵀ λ
///
/// (∘ entrywise, M being diagonal; W = (Φ_q s + Φ_p)_q is
/// [`ParamSensitivity::acceleration_qdd`], the derivative of Φ_q along
/// (s, 1)), with the transposed factorization the step made. The
/// reactions' sensitivities follow from λ_p, W and the arms' derivatives
/// (module docs); the efforts' are −λ_p.
#[derive(Clone, Debug)]
pub struct DynamicsSensitivity {
    /// ∂(diag M)/∂p, one entry per entry of
    /// [`crate::DynamicsDerivation::mass`]. Reads p.
    pub mass: Vec<ExprId>,
    /// d/dp Q_A: its directional derivative along {q → s, q̇ → ṡ, p → 1},
    /// one entry per coordinate. Reads q, q̇, s, ṡ, p, t.
    pub applied: Vec<ExprId>,
    /// d/dp of each reaction's arm ([`crate::Reaction::arm`]): its
    /// directional derivative along {q → s, p → 1}, one pair per entry of
    /// [`crate::DynamicsDerivation::reactions`]. Reads q, s, p, t.
    pub arms: Vec<[ExprId; 2]>,
}

/// The sensitivity of one result column y (a named point's component or a
/// measure) with respect to one param.
#[derive(Clone, Debug)]
pub struct OutputSensitivity {
    /// The result's column name ([`crate::OutputColumn::name`]).
    pub name: String,
    /// y_p = y_q s + ∂y/∂p. Reads q, s, p, t.
    pub value: ExprId,
    /// ẏ_p = d/dp ẏ. Reads q, q̇, s, ṡ, p, t.
    pub velocity: ExprId,
    /// ÿ_p without its q̈ and s̈ terms. Reads q, q̇, s, ṡ, p, t. The whole
    /// is ÿ_p = Σ (y_q)_k s̈_k + Σ `qdd`_k q̈_k + this, with y_q the
    /// result's own [`crate::OutputColumn::jacobian`].
    pub acceleration: ExprId,
    /// (y_p)_q: the coefficients of q̈ in ÿ_p as (coordinate index,
    /// expression), structural nonzeros in increasing index. Reads q, s,
    /// p, t.
    pub qdd: Vec<(u32, ExprId)>,
}

/// Why sensitivities could not be derived.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SensitivityError {
    /// A name that is not a param of the model.
    NotAParam {
        /// The name asked for.
        name: String,
        /// What the name is instead, when the model has something of that
        /// name (`"a body"`, `"a coordinate"`, `"an output"`, `"time"`).
        is: Option<&'static str>,
        /// The model's params, in declaration order.
        known: Vec<String>,
    },
    /// A param asked for twice.
    Repeated {
        /// Its name.
        name: String,
    },
    /// The derivatives with respect to `param` of one equation or result
    /// would outgrow the arena budget (see [`DERIVATION_BUDGET`]). The
    /// derivation is left as it was.
    TooLarge {
        /// The param.
        param: String,
        /// The equation or result (declared name).
        item: String,
        /// The budget, in arena entries.
        budget: usize,
    },
}

impl fmt::Display for SensitivityError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SensitivityError::NotAParam { name, is, known } => {
                match is {
                    Some(what) => write!(f, "`{name}` is {what}, not a param")?,
                    None => write!(f, "no param named `{name}`")?,
                }
                if known.is_empty() {
                    write!(f, "; the model has no params")
                } else {
                    write!(f, "; the model's params are {}", known.join(", "))
                }
            }
            SensitivityError::Repeated { name } => {
                write!(f, "the param `{name}` is asked for more than once")
            }
            SensitivityError::TooLarge {
                param,
                item,
                budget,
            } => write!(
                f,
                "the derivatives of `{item}` with respect to `{param}` are too large: they \
                 would need more than {budget} expression entries (the limit per equation)"
            ),
        }
    }
}

impl std::error::Error for SensitivityError {}

/// The seeds and columns one param's derivatives are taken along.
struct Along<'a> {
    /// {q_k → s_k, p → 1}.
    position: SeedsId,
    /// {q_k → s_k, q̇_k → ṡ_k, p → 1}.
    full: SeedsId,
    /// The coordinates q (columns of W and of (y_p)_q).
    columns: &'a Columns,
}

impl Derivation {
    /// The sensitivities with respect to the params named `params` (in
    /// that order), within [`DERIVATION_BUDGET`] per equation and result
    /// and param. Their expressions are added to [`Derivation::arena`];
    /// see [`crate::sensitivity`] for the equations and the symbols each
    /// expression reads. Asking again reuses what was derived (the arena
    /// memoizes derivatives).
    ///
    /// # Errors
    /// A name that is not a param, or one named twice (the error names
    /// the model's params); derivatives that would outgrow the budget. On
    /// error the derivation is unchanged.
    pub fn sensitivities(&mut self, params: &[&str]) -> Result<Sensitivities, SensitivityError> {
        self.sensitivities_with_budget(params, DERIVATION_BUDGET)
    }

    /// [`Derivation::sensitivities`] with another budget (arena entries
    /// per equation or result and param).
    ///
    /// # Errors
    /// As [`Derivation::sensitivities`].
    pub fn sensitivities_with_budget(
        &mut self,
        params: &[&str],
        budget: usize,
    ) -> Result<Sensitivities, SensitivityError> {
        let chosen = self.param_indices(params)?;
        // Work on a copy: an arena that hit its budget stays marked and
        // its last derivatives are incomplete, so the derivation's own
        // arena is replaced only on success.
        let mut arena = self.arena.clone();
        let nc = self.nc();
        let mut s = Vec::with_capacity(nc);
        let mut sd = Vec::with_capacity(nc);
        for (k, c) in self.coordinates.iter().enumerate() {
            let e = arena.coordinate(&format!("∂{}", c.name), idx(nc + k));
            let ed = arena.velocity(&format!("∂{}_dot", c.name), idx(nc + k));
            s.push(sym(&arena, e));
            sd.push(sym(&arena, ed));
        }
        let columns = Columns::new(&self.coordinate_syms());
        let mut out = Vec::with_capacity(chosen.len());
        for i in chosen {
            let p = &self.params[i];
            let one = arena.one();
            let mut pairs: Vec<(SymId, ExprId)> = self
                .coordinates
                .iter()
                .zip(&s)
                .map(|(c, &sk)| (c.sym, arena.sym_expr(sk)))
                .collect();
            pairs.push((p.sym, one));
            let position = arena.seeds(&pairs);
            pairs.extend(
                self.coordinates
                    .iter()
                    .zip(&sd)
                    .map(|(c, &sk)| (c.velocity, arena.sym_expr(sk))),
            );
            let full = arena.seeds(&pairs);
            let along = Along {
                position,
                full,
                columns: &columns,
            };
            let result = self.one_param(&mut arena, i, &along, budget);
            arena.set_budget(None);
            out.push(result?);
        }
        self.arena = arena;
        Ok(Sensitivities {
            coordinates: s,
            velocities: sd,
            params: out,
        })
    }

    /// The indices of the named params, or the error naming the known
    /// ones.
    fn param_indices(&self, names: &[&str]) -> Result<Vec<usize>, SensitivityError> {
        let mut out: Vec<usize> = Vec::with_capacity(names.len());
        for &name in names {
            let Some(i) = self.params.iter().position(|p| p.name == name) else {
                return Err(SensitivityError::NotAParam {
                    name: name.to_owned(),
                    is: self.what_is(name),
                    known: self.params.iter().map(|p| p.name.clone()).collect(),
                });
            };
            if out.contains(&i) {
                return Err(SensitivityError::Repeated {
                    name: name.to_owned(),
                });
            }
            out.push(i);
        }
        Ok(out)
    }

    /// What a name that is not a param names in this model, if anything.
    fn what_is(&self, name: &str) -> Option<&'static str> {
        if self.bodies.iter().any(|b| b == name) {
            Some("a body")
        } else if self.coordinates.iter().any(|c| c.name == name) {
            Some("a coordinate")
        } else if self
            .outputs
            .iter()
            .any(|o| o.name == name || o.declared == name)
        {
            Some("an output")
        } else if self
            .rows
            .iter()
            .any(|r| r.equation == name || r.name == name)
        {
            Some("an equation")
        } else if name == "t" {
            Some("time")
        } else {
            None
        }
    }

    /// Param `i`'s sensitivities, each equation's rows and each declared
    /// result within `budget` entries.
    fn one_param(
        &self,
        arena: &mut Arena,
        i: usize,
        along: &Along<'_>,
        budget: usize,
    ) -> Result<ParamSensitivity, SensitivityError> {
        let p = &self.params[i];
        let too_large = |item: &str| SensitivityError::TooLarge {
            param: p.name.clone(),
            item: item.to_owned(),
            budget,
        };
        let n = self.phi.len();
        let mut phi_p = Vec::with_capacity(n);
        let mut velocity_rhs = Vec::with_capacity(n);
        let mut acceleration_rhs = Vec::with_capacity(n);
        let mut acceleration_qdd = SparseMatrix {
            rows: n,
            cols: self.nc(),
            entries: Vec::new(),
        };
        let mut limit = Budget::new(budget);
        for (r, row) in self.rows.iter().enumerate() {
            limit.enter(arena, &row.equation);
            phi_p.push(arena.diff(self.phi[r], p.sym));
            // R_v = Φ_q q̇ − ν; its derivative along (s, 1), negated.
            let rv = arena.sub(self.phi_q_qdot[r], self.nu[r]);
            let drv = arena.directional(rv, along.position);
            velocity_rhs.push(arena.neg(drv));
            acceleration_rhs.push(arena.directional(self.gamma[r], along.full));
            // w = Φ_q s + Φ_p, and W = w_q.
            let w = arena.directional(self.phi[r], along.position);
            let wq = arena.jacobian_by(&[w], along.columns);
            acceleration_qdd
                .entries
                .extend(wq.entries.into_iter().map(|en| Entry { row: idx(r), ..en }));
            if limit.exceeded(arena) {
                return Err(too_large(&row.equation));
            }
        }
        let mut outputs = Vec::with_capacity(self.outputs.len());
        for o in &self.outputs {
            limit.enter(arena, &o.declared);
            let value = arena.directional(o.value, along.position);
            let velocity = arena.directional(o.velocity, along.full);
            let acceleration = arena.directional(o.acceleration, along.full);
            let qdd = arena
                .jacobian_by(&[value], along.columns)
                .entries
                .into_iter()
                .map(|en| (en.col, en.expr))
                .collect();
            if limit.exceeded(arena) {
                return Err(too_large(&o.declared));
            }
            outputs.push(OutputSensitivity {
                name: o.name.clone(),
                value,
                velocity,
                acceleration,
                qdd,
            });
        }
        let dynamics = match &self.dynamics {
            Some(dy) => {
                limit.enter(arena, APPLIED);
                let mass = dy.mass.iter().map(|&m| arena.diff(m, p.sym)).collect();
                let applied = dy
                    .applied
                    .iter()
                    .map(|&q| arena.directional(q, along.full))
                    .collect();
                if limit.exceeded(arena) {
                    return Err(too_large(APPLIED));
                }
                let mut arms = Vec::with_capacity(dy.reactions.len());
                for r in &dy.reactions {
                    limit.enter(arena, &r.element);
                    arms.push(r.arm.map(|a| arena.directional(a, along.position)));
                    if limit.exceeded(arena) {
                        return Err(too_large(&r.element));
                    }
                }
                Some(DynamicsSensitivity {
                    mass,
                    applied,
                    arms,
                })
            }
            None => None,
        };
        Ok(ParamSensitivity {
            name: p.name.clone(),
            index: i,
            sym: p.sym,
            phi_p,
            velocity_rhs,
            acceleration_rhs,
            acceleration_qdd,
            outputs,
            dynamics,
        })
    }
}

/// How an over-budget error names the applied forces.
const APPLIED: &str = "the applied forces Q_A";

/// The budget of one declared equation or result: its rows (or
/// components) share `budget` entries, counted from the first.
struct Budget<'a> {
    budget: usize,
    current: Option<(&'a str, usize)>,
}

impl<'a> Budget<'a> {
    fn new(budget: usize) -> Self {
        Budget {
            budget,
            current: None,
        }
    }

    /// Starts counting for `item` unless its previous row was counted.
    fn enter(&mut self, arena: &mut Arena, item: &'a str) {
        let limit = match self.current {
            Some((name, limit)) if name == item => limit,
            _ => arena.size().saturating_add(self.budget),
        };
        self.current = Some((item, limit));
        arena.set_budget(Some(limit));
    }

    fn exceeded(&self, arena: &Arena) -> bool {
        arena.budget_exceeded() || self.current.is_some_and(|(_, limit)| arena.size() > limit)
    }
}

fn sym(arena: &Arena, e: ExprId) -> SymId {
    // `coordinate` and `velocity` return their symbol's leaf.
    arena
        .symbol_of(e)
        .unwrap_or_else(|| unreachable!("a symbol constructor returned a non-symbol"))
}
