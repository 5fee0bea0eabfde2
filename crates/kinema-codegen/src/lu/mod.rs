//! A sparse LU generated for one Jacobian pattern: the pivot order is chosen
//! here, at generation time, and the factorization and both triangular
//! solves are emitted as straight-line code over fixed-size arrays.
//!
//! # Choosing the order
//!
//! Φ_q is evaluated at the model's initial guess (default parameters,
//! t = 0). The elimination is then simulated on those values with
//! Markowitz's criterion under threshold partial pivoting: at each step the
//! candidate (i, j) with |a_ij| ≥ θ_g max_r |a_rj| (θ_g = 1/2, stricter
//! than the runtime's θ = 1/10 to leave room for the motion) and the least
//! (r_i − 1)(c_j − 1) wins; among equals an entry that is a compile-time
//! constant (the ±1 of a joint's x and y rows, of a driver's angle) wins, then
//! the larger |a_ij| relative to its column. Mechanism Jacobians are mostly
//! such constants, so most pivots need no division and no check.
//!
//! # Constant folding
//!
//! Every entry is tracked as either a number known at generation time or a
//! value computed at run time. Multiplying by a unit pivot, updates by zero
//! and products of constants fold away; only the remaining arithmetic is
//! emitted. For the serial chain with absolute-angle drivers the Jacobian is
//! a permuted triangular matrix with unit pivots, and the factorization
//! emits no arithmetic at all — only the checks.
//!
//! # Checks and fallback
//!
//! A factorization is accepted under the runtime's rule, which the generated
//! code calls through `__private` (`linalg::scale_and_finite_array` on the
//! run-time inputs, then `linalg::order_accepted`): every input value finite,
//! every pivot |u_kk| > τ · maxᵢⱼ |aᵢⱼ| and every multiplier |l_ik| ≤ 1/θ,
//! where a NaN pivot or multiplier (finite inputs whose products overflow)
//! fails the test. When the static order fails
//! them at some q, the generated type factors with the runtime solver it
//! holds (`DenseLu<N>` or `Auto`), whose partial pivoting also gives the
//! singularity verdict and so the diagnostics.

use std::collections::{BTreeMap, BTreeSet};

mod emit;

pub(crate) use emit::Names;

/// θ of the runtime's replay (`kinema_runtime::linalg::PIVOT_THRESHOLD`):
/// generation refuses an order whose constant multipliers exceed 1/θ. The
/// generated code checks every multiplier, constants included, with the
/// runtime's own rule (`linalg::order_accepted`, through `__private`), so a
/// change of the runtime's θ cannot be silently ignored.
const RUNTIME_THRESHOLD: f64 = 0.1;
/// θ_g used to choose pivots on the values at the initial guess.
const GENERATION_THRESHOLD: f64 = 0.5;
/// Above this many emitted operations the static LU is not generated (the
/// runtime's sparse LU does the work instead).
const MAX_OPERATIONS: usize = 200_000;
/// Up to this many entries, per-entry work (checks, copies) is emitted
/// straight-line; beyond it, as a loop over a table of positions, which keeps
/// the code of large systems small enough for the instruction caches.
const MAX_UNROLLED: usize = 16;
/// Functions with more bindings than this keep them in a local array
/// instead of `let`s: every `let` opens a nested scope, and very deep nests
/// overflow the compiler's stack when it writes debug information.
pub(crate) const MAX_LETS: usize = 1000;

/// A value during the simulated elimination.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Val {
    /// Known at generation time.
    Const(f64),
    /// Computed at run time: index into [`Plan::vars`].
    Var(u32),
}

/// How a run-time value is computed in the factorization.
#[derive(Clone, Debug)]
enum Def {
    /// `values[k]`, an input.
    Input(usize),
    /// −x.
    Neg(u32),
    /// k · x.
    Scale(f64, u32),
    /// x · y.
    Mul(u32, u32),
    /// 1 / x.
    Recip(u32),
    /// old − p where p is one of the above shapes.
    Sub(Val, Product),
}

/// l · u, folded.
#[derive(Clone, Copy, Debug)]
enum Product {
    /// A constant (l and u both known).
    Const(f64),
    /// A var times a constant (1: the var itself).
    Scaled(f64, u32),
    /// Two vars.
    Mul(u32, u32),
}

#[derive(Clone, Copy, Debug)]
struct Cell {
    /// Value at the initial guess (chooses pivots).
    num: f64,
    val: Val,
}

/// The elimination for one pivot order, with everything folded: what the
/// emitted factorization computes and what the solves read.
#[derive(Debug, Clone)]
pub(crate) struct Plan {
    n: usize,
    nnz: usize,
    /// Original row and column eliminated at step k.
    row_order: Vec<usize>,
    col_order: Vec<usize>,
    /// Run-time values, in computation order.
    vars: Vec<Def>,
    /// Per step k: the pivot u_kk.
    pivots: Vec<Val>,
    /// Per step k: 1 / u_kk.
    inv: Vec<Val>,
    /// L entries (row position i, column k, l_ik), by columns.
    lower: Vec<(usize, usize, Val)>,
    /// Strict U entries (row k, column position j, u_kj), by rows.
    upper: Vec<(usize, usize, Val)>,
    /// Pattern entries that are run-time values.
    runtime_inputs: Vec<usize>,
    /// max |a_ij| over the constant entries.
    constant_scale: f64,
    /// Operations past which the factorization and each solve are emitted
    /// as private functions of about this many operations
    /// ([`Plan::split_above`]; no limit until set).
    chunk_ops: usize,
}

impl Plan {
    /// Chooses a pivot order and simulates the elimination. `pattern` holds
    /// (row, column, constant value if the entry is a number) per entry;
    /// `values` the entries at the initial guess. `None` when no usable
    /// static order exists (a constant pivot of zero, a constant multiplier
    /// over 1/θ) or it would be too large to emit.
    pub(crate) fn new(
        n: usize,
        pattern: &[(u32, u32, Option<f64>)],
        values: &[f64],
    ) -> Option<Plan> {
        let (mut plan, mut active) = Plan::start(n, pattern, values)?;
        let mut below: Vec<(usize, Cell)> = Vec::new();
        let mut right: Vec<(usize, Cell)> = Vec::new();
        for _ in 0..n {
            let (r, c) = choose(&active.rows, &active.cols, &active.by_count)?;
            let pivot = active.rows[r]
                .get(&c)
                .copied()
                .expect("`choose` returns an entry of the active matrix");
            if pivot.val == Val::Const(0.0) {
                return None;
            }
            active.take_pivot(r, c, &mut right, &mut below);
            plan.eliminate(&mut active, (r, c), pivot, &right, &below)?;
        }
        plan.renumber_by_position();
        Some(plan)
    }

    /// An empty plan and the whole matrix as the active one: constant
    /// entries as [`Val::Const`], the others as run-time inputs.
    fn start(
        n: usize,
        pattern: &[(u32, u32, Option<f64>)],
        values: &[f64],
    ) -> Option<(Plan, Active)> {
        let mut vars: Vec<Def> = Vec::new();
        let mut rows: Vec<BTreeMap<usize, Cell>> = vec![BTreeMap::new(); n];
        let mut cols: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); n];
        let mut runtime_inputs = Vec::new();
        let mut constant_scale = 0.0f64;
        for (k, (&(r, c, constant), &num)) in pattern.iter().zip(values).enumerate() {
            let (r, c) = (r as usize, c as usize);
            if r >= n || c >= n {
                return None;
            }
            let val = match constant {
                Some(v) => {
                    constant_scale = constant_scale.max(v.abs());
                    Val::Const(v)
                }
                None => {
                    runtime_inputs.push(k);
                    vars.push(Def::Input(k));
                    Val::Var(vars.len() as u32 - 1)
                }
            };
            let num = if num.is_finite() { num } else { 0.0 };
            rows[r].insert(c, Cell { num, val });
            cols[c].insert(r);
        }
        // Rows by count, for a search that usually stops at a singleton.
        let by_count = rows.iter().enumerate().map(|(r, m)| (m.len(), r)).collect();
        let plan = Plan {
            n,
            nnz: pattern.len(),
            row_order: Vec::with_capacity(n),
            col_order: Vec::with_capacity(n),
            vars,
            pivots: Vec::with_capacity(n),
            inv: Vec::with_capacity(n),
            lower: Vec::new(),
            upper: Vec::new(),
            runtime_inputs,
            constant_scale,
            chunk_ops: usize::MAX,
        };
        Some((
            plan,
            Active {
                rows,
                cols,
                by_count,
            },
        ))
    }

    /// One elimination step at pivot `(r, c)` (already taken out of
    /// `active`, with its row's other entries `right` and its column's
    /// `below`): records the pivot, its reciprocal, U's row and L's column,
    /// and applies the rank-one update a_ij −= l_i·u_j to the active matrix,
    /// with the fill it creates. `None` when a constant multiplier exceeds
    /// 1/θ or the plan grows past [`MAX_OPERATIONS`].
    fn eliminate(
        &mut self,
        active: &mut Active,
        (r, c): (usize, usize),
        pivot: Cell,
        right: &[(usize, Cell)],
        below: &[(usize, Cell)],
    ) -> Option<()> {
        let k = self.pivots.len();
        self.row_order.push(r);
        self.col_order.push(c);
        self.pivots.push(pivot.val);
        let inv = self.recip(pivot.val);
        self.inv.push(inv);
        let inv_num = 1.0 / pivot.num;
        for &(j, cell) in right {
            self.upper.push((k, j, cell.val));
        }
        for &(i, cell) in below {
            let l = self.mul(cell.val, inv);
            if let Val::Const(v) = l
                && v.abs() > 1.0 / RUNTIME_THRESHOLD
            {
                return None;
            }
            let l_num = cell.num * inv_num;
            self.lower.push((i, k, l));
            for &(j, u) in right {
                let old = active.rows[i].get(&j).copied();
                let old_val = old.map_or(Val::Const(0.0), |o| o.val);
                let val = self.update(old_val, l, u.val);
                let num = old.map_or(0.0, |o| o.num) - l_num * u.num;
                let num = if num.is_finite() { num } else { 0.0 };
                if old.is_none() {
                    active.fill(i, j);
                }
                active.rows[i].insert(j, Cell { num, val });
            }
            if self.vars.len() > MAX_OPERATIONS {
                return None;
            }
        }
        Some(())
    }

    /// The plan with its emitted factorization and solves split above
    /// `ops` operations each into private `#[inline(never)]` functions of
    /// about that many (the bound of `Config::chunk_nodes`): LLVM's time on
    /// one function grows faster than its size, and the 1000-body chain's
    /// solves were its largest functions.
    pub(crate) fn split_above(self, ops: usize) -> Plan {
        Plan {
            chunk_ops: ops,
            ..self
        }
    }

    /// Renumbers L's rows and U's columns as elimination positions.
    fn renumber_by_position(&mut self) {
        let mut row_pos = vec![0usize; self.n];
        for (k, &r) in self.row_order.iter().enumerate() {
            row_pos[r] = k;
        }
        let mut col_pos = vec![0usize; self.n];
        for (k, &c) in self.col_order.iter().enumerate() {
            col_pos[c] = k;
        }
        for e in &mut self.lower {
            e.0 = row_pos[e.0];
        }
        for e in &mut self.upper {
            e.1 = col_pos[e.1];
        }
    }

    fn push(&mut self, def: Def) -> Val {
        self.vars.push(def);
        Val::Var(self.vars.len() as u32 - 1)
    }

    fn recip(&mut self, p: Val) -> Val {
        match p {
            Val::Const(v) => Val::Const(1.0 / v),
            Val::Var(x) => self.push(Def::Recip(x)),
        }
    }

    /// a · b, folded.
    fn mul(&mut self, a: Val, b: Val) -> Val {
        match (a, b) {
            (Val::Const(x), Val::Const(y)) => Val::Const(x * y),
            (Val::Const(k), Val::Var(v)) | (Val::Var(v), Val::Const(k)) => {
                if k == 1.0 {
                    Val::Var(v)
                } else if k == -1.0 {
                    self.push(Def::Neg(v))
                } else if k == 0.0 {
                    Val::Const(0.0)
                } else {
                    self.push(Def::Scale(k, v))
                }
            }
            (Val::Var(x), Val::Var(y)) => self.push(Def::Mul(x, y)),
        }
    }

    /// old − l · u, folded.
    fn update(&mut self, old: Val, l: Val, u: Val) -> Val {
        let product = match (l, u) {
            (Val::Const(x), Val::Const(y)) => {
                let p = x * y;
                return match old {
                    _ if p == 0.0 => old,
                    Val::Const(o) => Val::Const(o - p),
                    Val::Var(_) => self.push(Def::Sub(old, Product::Const(p))),
                };
            }
            (Val::Const(k), Val::Var(v)) | (Val::Var(v), Val::Const(k)) => {
                if k == 0.0 {
                    return old;
                }
                Product::Scaled(k, v)
            }
            (Val::Var(x), Val::Var(y)) => Product::Mul(x, y),
        };
        self.push(Def::Sub(old, product))
    }

    /// Number of emitted floating-point operations in the factorization.
    pub(crate) fn operations(&self) -> usize {
        self.vars
            .iter()
            .filter(|d| !matches!(d, Def::Input(_)))
            .count()
    }

    /// Which run-time values the solves read (stored by the factorization),
    /// as a map var → slot in the stored array.
    fn stored(&self) -> BTreeMap<u32, usize> {
        let mut needed = BTreeSet::new();
        let vals = self
            .inv
            .iter()
            .chain(self.lower.iter().map(|e| &e.2))
            .chain(self.upper.iter().map(|e| &e.2));
        for v in vals {
            if let Val::Var(x) = *v {
                needed.insert(x);
            }
        }
        // Inputs first, in input order (copied by one loop), then the
        // computed values.
        let mut stored = BTreeMap::new();
        let inputs = needed
            .iter()
            .filter(|&&x| matches!(self.vars[x as usize], Def::Input(_)));
        let computed = needed
            .iter()
            .filter(|&&x| !matches!(self.vars[x as usize], Def::Input(_)));
        for &x in inputs.chain(computed) {
            let next = stored.len();
            stored.insert(x, next);
        }
        stored
    }
}

/// The active submatrix of the elimination: each row's entries by column,
/// each column's rows, and the rows ordered by their entry count.
struct Active {
    rows: Vec<BTreeMap<usize, Cell>>,
    cols: Vec<BTreeSet<usize>>,
    by_count: BTreeSet<(usize, usize)>,
}

impl Active {
    /// Takes row `r` and column `c` out of the active matrix: the row's
    /// other entries into `right`, the column's other entries into `below`.
    fn take_pivot(
        &mut self,
        r: usize,
        c: usize,
        right: &mut Vec<(usize, Cell)>,
        below: &mut Vec<(usize, Cell)>,
    ) {
        self.by_count.remove(&(self.rows[r].len(), r));
        right.clear();
        right.extend(
            self.rows[r]
                .iter()
                .filter(|&(&j, _)| j != c)
                .map(|(&j, &cell)| (j, cell)),
        );
        self.rows[r].clear();
        for &(j, _) in right.iter() {
            self.cols[j].remove(&r);
        }
        below.clear();
        for &i in self.cols[c].iter().filter(|&&i| i != r) {
            if let Some(cell) = self.rows[i].remove(&c) {
                self.by_count.remove(&(self.rows[i].len() + 1, i));
                self.by_count.insert((self.rows[i].len(), i));
                below.push((i, cell));
            }
        }
        self.cols[c].clear();
    }

    /// Registers a new entry (fill) at `(i, j)` before it is inserted.
    fn fill(&mut self, i: usize, j: usize) {
        self.by_count.remove(&(self.rows[i].len(), i));
        self.by_count.insert((self.rows[i].len() + 1, i));
        self.cols[j].insert(i);
    }
}

/// The (row, column) of the next pivot: least Markowitz cost among the
/// entries passing the threshold, constants first among equals, then the
/// largest relative magnitude, then the smallest (row, column).
fn choose(
    rows: &[BTreeMap<usize, Cell>],
    cols: &[BTreeSet<usize>],
    by_count: &BTreeSet<(usize, usize)>,
) -> Option<(usize, usize)> {
    // (passes threshold, cost, variable, −relative magnitude, row, col): smaller is better.
    type Key = (bool, usize, bool, f64, usize, usize);
    let better = |a: &Key, b: &Key| {
        (!a.0, a.1, a.2)
            .cmp(&(!b.0, b.1, b.2))
            .then(a.3.total_cmp(&b.3))
            .then((a.4, a.5).cmp(&(b.4, b.5)))
            .is_lt()
    };
    let mut col_max: BTreeMap<usize, f64> = BTreeMap::new();
    let mut best: Option<Key> = None;
    for &(count, r) in by_count {
        if count == 0 {
            continue;
        }
        // Any entry of this row costs at least (count − 1) · 0; stop when the
        // best found is a constant passing with cost 0.
        if let Some(b) = &best
            && b.0
            && b.1 == 0
            && !b.2
        {
            break;
        }
        for (&c, cell) in &rows[r] {
            let max = *col_max.entry(c).or_insert_with(|| {
                cols[c]
                    .iter()
                    .filter_map(|&i| rows[i].get(&c))
                    .map(|x| x.num.abs())
                    .fold(0.0, f64::max)
            });
            let rel = if max > 0.0 { cell.num.abs() / max } else { 0.0 };
            let passes = cell.num != 0.0 && rel >= GENERATION_THRESHOLD;
            let cost = (count - 1) * (cols[c].len() - 1);
            let key = (passes, cost, matches!(cell.val, Val::Var(_)), -rel, r, c);
            if best.as_ref().is_none_or(|b| better(&key, b)) {
                best = Some(key);
            }
        }
    }
    best.map(|b| (b.4, b.5))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A lower-bidiagonal chain, rows and columns shuffled: unit pivots,
    /// no fill, nothing to compute.
    #[test]
    fn a_permuted_triangular_matrix_needs_no_arithmetic() {
        // Row i: x_i − x_{i−1} (entries (i, i) = 1 and (i, i − 1) = −1), rows
        // reversed.
        let n = 5;
        let mut pattern = Vec::new();
        for i in 0..n as u32 {
            let r = n as u32 - 1 - i;
            pattern.push((r, i, Some(1.0)));
            if i > 0 {
                pattern.push((r, i - 1, None));
            }
        }
        let values: Vec<f64> = pattern.iter().map(|p| p.2.unwrap_or(-1.0)).collect();
        let plan = Plan::new(n, &pattern, &values).expect("a plan");
        assert_eq!(plan.operations(), 0);
        assert!(plan.pivots.iter().all(|p| *p == Val::Const(1.0)));
        assert!(plan.upper.is_empty());
    }

    /// A full 2 × 2 matrix of run-time values: 1/p, one multiplier, one
    /// update, 1/p again.
    #[test]
    fn a_full_matrix_is_eliminated_with_threshold_pivoting() {
        let pattern = [(0, 0, None), (0, 1, None), (1, 0, None), (1, 1, None)];
        // |a_00| is below ½ |a_10|: the first pivot is another entry.
        let plan = Plan::new(2, &pattern, &[0.1, 1.0, 1.0, 1.0]).expect("a plan");
        assert_ne!((plan.row_order[0], plan.col_order[0]), (0, 0));
        assert_eq!(plan.operations(), 4);
    }

    #[test]
    fn unusable_orders_are_refused() {
        // A constant zero pivot is forced (structurally the only choice).
        assert!(Plan::new(1, &[(0, 0, Some(0.0))], &[0.0]).is_none());
        // Out-of-range pattern.
        assert!(Plan::new(1, &[(1, 0, None)], &[1.0]).is_none());
    }
}
