//! Analysis: the fixed order's plan. The pivot order chosen by
//! Markowitz's criterion under threshold partial pivoting on the values at
//! the initial guess, the elimination simulated with every entry either a
//! constant or a run-time value ([`Plan`]), and the factorization's and the
//! solves' operation lists recorded ([`Folded::plan`]). Runs once, when a
//! system is analysed; never per step.

use std::collections::{BTreeMap, BTreeSet};

use super::{FactorScan, Folded, Op, SolveOp, Val};
use crate::linalg::schedule::MAGNITUDE_MASK;
use crate::linalg::{PIVOT_THRESHOLD, permutation_sign};

/// θ_g used to choose pivots on the values at the initial guess: stricter
/// than the replay's θ to leave room for the motion (the generated LU's).
const CHOICE_THRESHOLD: f64 = 0.5;
/// Above this many operations the plan is not built (the general solver
/// does the work instead).
const MAX_OPERATIONS: usize = 200_000;
/// Above this many entries looked at by the pivot search (candidates and
/// their columns' magnitudes), the plan is given up for the general
/// solver: the search costs up to the active entries per pivot, so a large
/// system without cheap pivots would otherwise plan for seconds. Mechanisms
/// find a constant of cost 0 early in most steps (the chain N = 1000,
/// n = 3000, plans in about 5 ms).
const MAX_SEARCH: usize = 20_000_000;
/// An entry of the active matrix during the simulated elimination.
#[derive(Clone, Copy, Debug)]
struct Cell {
    /// Value at the initial guess (chooses pivots).
    num: f64,
    val: Val,
}
/// The elimination being simulated.
struct Plan {
    rows: Vec<BTreeMap<u32, Cell>>,
    cols: Vec<BTreeSet<u32>>,
    /// (active entries, row) of every row, for a search by count.
    by_count: BTreeSet<(usize, u32)>,
    ops: Vec<Op>,
    inputs: usize,
    /// Entries the pivot search has looked at so far (see [`MAX_SEARCH`]).
    searched: usize,
}
impl Folded {
    pub(super) fn plan(
        n: usize,
        pattern: &[(u32, u32)],
        constants: &[Option<f64>],
        values: &[f64],
    ) -> Option<Folded> {
        let (mut plan, inputs, constant_entries) = Plan::start(n, pattern, constants, values)?;
        let mut lu = Folded {
            inputs,
            constants: constant_entries,
            trusted: false,
            ops: Vec::new(),
            v: Vec::new(),
            pivot_vars: Vec::new(),
            multiplier_vars: Vec::new(),
            const_min_pivot: f64::INFINITY,
            const_max_multiplier: 0.0,
            const_scale: 0.0,
            inv: Vec::with_capacity(n),
            row_order: Vec::with_capacity(n),
            col_order: Vec::with_capacity(n),
            forward: Vec::new(),
            backward: Vec::new(),
            forward_t: Vec::new(),
            backward_t: Vec::new(),
            fixed_sign: 1.0,
            scan: FactorScan {
                scale: 0.0,
                finite: false,
                same: false,
                negative: false,
                min_pivot: 0.0,
                max_multiplier: f64::INFINITY,
            }
            .to_raw(),
            work: vec![0.0; n],
            compiled: None,
            compiled_factor: None,
        };
        // Per step k: L entries (original row, l_ik), U entries (original column, u_kj).
        let mut lower: Vec<Vec<(u32, Val)>> = Vec::with_capacity(n);
        let mut upper: Vec<Vec<(u32, Val)>> = Vec::with_capacity(n);
        for _ in 0..n {
            let (r, c) = plan.choose()?;
            let (pivot, right, below) = plan.take(r, c);
            match pivot.val {
                Val::Const(p) if p == 0.0 || !p.is_finite() => return None,
                Val::Const(p) => {
                    lu.const_min_pivot = lu.const_min_pivot.min(p.abs());
                    if p < 0.0 {
                        lu.fixed_sign = -lu.fixed_sign;
                    }
                }
                Val::Var(p) => lu.pivot_vars.push(p),
            }
            lu.row_order.push(r);
            lu.col_order.push(c);
            let inv = plan.recip(pivot.val);
            lu.inv.push(inv);
            let inv_num = 1.0 / pivot.num;
            let mut column = Vec::with_capacity(below.len());
            for &(i, cell) in &below {
                let l = plan.mul(cell.val, inv);
                match l {
                    Val::Const(m) if !m.is_finite() || m.abs() > 1.0 / PIVOT_THRESHOLD => {
                        return None;
                    }
                    Val::Const(m) => {
                        lu.const_max_multiplier = lu.const_max_multiplier.max(m.abs());
                    }
                    Val::Var(m) => lu.multiplier_vars.push(m),
                }
                column.push((i, l));
                let l_num = cell.num * inv_num;
                for &(j, u) in &right {
                    plan.update(i, j, l, l_num, u);
                }
                if plan.ops.len() > MAX_OPERATIONS {
                    return None;
                }
            }
            lower.push(column);
            upper.push(right.iter().map(|&(j, u)| (j, u.val)).collect());
        }
        lu.v = vec![0.0; plan.inputs + plan.ops.len()];
        lu.ops = plan.ops;
        lu.record_solves(&lower, &upper);
        let mut scratch = vec![0usize; n];
        lu.fixed_sign *= permutation_sign(lu.row_order.iter().map(|&r| r as usize), &mut scratch)
            * permutation_sign(lu.col_order.iter().map(|&c| c as usize), &mut scratch);
        lu.const_scale = f64::from_bits(
            lu.constants
                .iter()
                .map(|&(_, c)| c.to_bits() & MAGNITUDE_MASK)
                .max()
                .unwrap_or(0),
        );
        Some(lu)
    }

    /// The four triangular sweeps as operation lists, in positions of P A Q.
    fn record_solves(&mut self, lower: &[Vec<(u32, Val)>], upper: &[Vec<(u32, Val)>]) {
        let n = self.row_order.len();
        let (mut row_pos, mut col_pos) = (vec![0u32; n], vec![0u32; n]);
        for k in 0..n {
            row_pos[self.row_order[k] as usize] = k as u32;
            col_pos[self.col_order[k] as usize] = k as u32;
        }
        for (k, column) in lower.iter().enumerate() {
            for &(i, l) in column {
                self.forward
                    .extend(mul_sub(row_pos[i as usize], k as u32, l));
            }
        }
        for k in (0..n).rev() {
            for &(j, u) in &upper[k] {
                self.backward
                    .extend(mul_sub(k as u32, col_pos[j as usize], u));
            }
            self.backward.extend(scale(k as u32, self.inv[k]));
        }
        for (k, row) in upper.iter().enumerate() {
            self.forward_t.extend(scale(k as u32, self.inv[k]));
            for &(j, u) in row {
                self.forward_t
                    .extend(mul_sub(col_pos[j as usize], k as u32, u));
            }
        }
        for k in (0..n).rev() {
            for &(i, l) in &lower[k] {
                self.backward_t
                    .extend(mul_sub(k as u32, row_pos[i as usize], l));
            }
        }
    }
}

/// y[dst] −= x · y[src], folded (nothing for a zero x).
fn mul_sub(dst: u32, src: u32, x: Val) -> Option<SolveOp> {
    match x {
        Val::Const(0.0) => None,
        Val::Const(1.0) => Some(SolveOp::Sub { dst, src }),
        Val::Const(-1.0) => Some(SolveOp::Add { dst, src }),
        Val::Const(c) => Some(SolveOp::ConstMulSub { dst, src, c }),
        Val::Var(s) => Some(SolveOp::MulSub { dst, src, s }),
    }
}

/// y[dst] ·= x, folded (nothing for x = 1).
fn scale(dst: u32, x: Val) -> Option<SolveOp> {
    match x {
        Val::Const(1.0) => None,
        Val::Const(c) => Some(SolveOp::ConstScale { dst, c }),
        Val::Var(s) => Some(SolveOp::Scale { dst, s }),
    }
}

/// Entries of a row or a column: (column or row, cell).
type Entries = Vec<(u32, Cell)>;

/// The run-time entries, the constant ones, and the elimination's start.
type Start = (Plan, Vec<u32>, Vec<(u32, f64)>);

impl Plan {
    fn start(
        n: usize,
        pattern: &[(u32, u32)],
        constants: &[Option<f64>],
        values: &[f64],
    ) -> Option<Start> {
        let mut rows: Vec<BTreeMap<u32, Cell>> = vec![BTreeMap::new(); n];
        let mut cols: Vec<BTreeSet<u32>> = vec![BTreeSet::new(); n];
        let (mut inputs, mut constant_entries) = (Vec::new(), Vec::new());
        for (k, ((&(r, c), &constant), &num)) in
            pattern.iter().zip(constants).zip(values).enumerate()
        {
            if r as usize >= n || c as usize >= n {
                return None;
            }
            let k = u32::try_from(k).ok()?;
            let val = match constant {
                Some(x) if !x.is_finite() => return None,
                Some(x) => {
                    constant_entries.push((k, x));
                    Val::Const(x)
                }
                None => {
                    inputs.push(k);
                    Val::Var(inputs.len() as u32 - 1)
                }
            };
            let num = if num.is_finite() { num } else { 0.0 };
            rows[r as usize].insert(c, Cell { num, val });
            cols[c as usize].insert(r);
        }
        let by_count = (0..n as u32).map(|r| (rows[r as usize].len(), r)).collect();
        let plan = Plan {
            rows,
            cols,
            by_count,
            ops: Vec::new(),
            inputs: inputs.len(),
            searched: 0,
        };
        Some((plan, inputs, constant_entries))
    }

    /// The next pivot (row, column): least Markowitz cost among the entries
    /// passing the threshold, constants first among equals, then the largest
    /// magnitude relative to its column, then the smallest (row, column);
    /// `None` once the search has looked at more than [`MAX_SEARCH`]
    /// entries in all.
    fn choose(&mut self) -> Option<(u32, u32)> {
        // (fails threshold, cost, run-time value, −relative magnitude, row, column)
        type Key = (bool, usize, bool, f64, u32, u32);
        let better = |a: &Key, b: &Key| {
            (a.0, a.1, a.2)
                .cmp(&(b.0, b.1, b.2))
                .then(a.3.total_cmp(&b.3))
                .then((a.4, a.5).cmp(&(b.4, b.5)))
                .is_lt()
        };
        let mut col_max: BTreeMap<u32, f64> = BTreeMap::new();
        let mut best: Option<Key> = None;
        let mut searched = 0;
        for &(count, r) in &self.by_count {
            if count == 0 {
                continue;
            }
            // A constant passing at cost 0 cannot be beaten by a later row.
            if best.is_some_and(|b| !b.0 && b.1 == 0 && !b.2) {
                break;
            }
            for (&c, cell) in &self.rows[r as usize] {
                searched += 1;
                let max = *col_max.entry(c).or_insert_with(|| {
                    searched += self.cols[c as usize].len();
                    self.cols[c as usize]
                        .iter()
                        .filter_map(|&i| self.rows[i as usize].get(&c))
                        .map(|x| x.num.abs())
                        .fold(0.0, f64::max)
                });
                let rel = if max > 0.0 { cell.num.abs() / max } else { 0.0 };
                let passes = cell.num != 0.0 && rel >= CHOICE_THRESHOLD;
                let cost = (count - 1) * (self.cols[c as usize].len() - 1);
                let key = (!passes, cost, matches!(cell.val, Val::Var(_)), -rel, r, c);
                if best.as_ref().is_none_or(|b| better(&key, b)) {
                    best = Some(key);
                }
            }
        }
        self.searched += searched;
        if self.searched > MAX_SEARCH {
            return None;
        }
        best.map(|b| (b.4, b.5))
    }

    /// Takes row r and column c out of the active matrix: the pivot, the
    /// rest of row r (column, cell) and the rest of column c (row, cell).
    fn take(&mut self, r: u32, c: u32) -> (Cell, Entries, Entries) {
        let row = std::mem::take(&mut self.rows[r as usize]);
        self.by_count.remove(&(row.len(), r));
        let pivot = row[&c];
        let right: Vec<(u32, Cell)> = row.into_iter().filter(|&(j, _)| j != c).collect();
        for &(j, _) in &right {
            self.cols[j as usize].remove(&r);
        }
        let mut below = Vec::new();
        for i in std::mem::take(&mut self.cols[c as usize]) {
            if i == r {
                continue;
            }
            if let Some(cell) = self.rows[i as usize].remove(&c) {
                let len = self.rows[i as usize].len();
                self.by_count.remove(&(len + 1, i));
                self.by_count.insert((len, i));
                below.push((i, cell));
            }
        }
        (pivot, right, below)
    }

    fn push(&mut self, op: Op) -> Val {
        self.ops.push(op);
        Val::Var((self.inputs + self.ops.len() - 1) as u32)
    }

    fn recip(&mut self, p: Val) -> Val {
        match p {
            Val::Const(x) => Val::Const(1.0 / x),
            Val::Var(x) => self.push(Op::Recip(x)),
        }
    }

    /// a · b, folded.
    fn mul(&mut self, a: Val, b: Val) -> Val {
        match (a, b) {
            (Val::Const(x), Val::Const(y)) => Val::Const(x * y),
            (Val::Const(k), Val::Var(x)) | (Val::Var(x), Val::Const(k)) => {
                if k == 1.0 {
                    Val::Var(x)
                } else if k == -1.0 {
                    self.push(Op::Neg(x))
                } else if k == 0.0 {
                    Val::Const(0.0)
                } else {
                    self.push(Op::Scale(k, x))
                }
            }
            (Val::Var(x), Val::Var(y)) => self.push(Op::Mul(x, y)),
        }
    }

    /// a_ij −= l u, folded; a new entry of the active matrix if (i, j) was
    /// not one.
    fn update(&mut self, i: u32, j: u32, l: Val, l_num: f64, u: Cell) {
        let old = self.rows[i as usize].get(&j).copied();
        let old_val = old.map_or(Val::Const(0.0), |o| o.val);
        let val = match (l, u.val) {
            (Val::Const(x), Val::Const(y)) => match (x * y, old_val) {
                (0.0, _) => old_val,
                (p, Val::Const(o)) => Val::Const(o - p),
                (p, Val::Var(o)) => self.push(Op::SubConst(o, p)),
            },
            (Val::Const(k), Val::Var(a)) | (Val::Var(a), Val::Const(k)) => match old_val {
                _ if k == 0.0 => old_val,
                Val::Var(o) if k == 1.0 => self.push(Op::Sub(o, a)),
                Val::Var(o) if k == -1.0 => self.push(Op::Add(o, a)),
                Val::Var(o) => self.push(Op::SubScaled(o, k, a)),
                Val::Const(o) => self.push(Op::ConstSubScaled(o, k, a)),
            },
            (Val::Var(a), Val::Var(b)) => match old_val {
                Val::Var(o) => self.push(Op::SubMul(o, a, b)),
                Val::Const(o) => self.push(Op::ConstSubMul(o, a, b)),
            },
        };
        let num = old.map_or(0.0, |o| o.num) - l_num * u.num;
        let num = if num.is_finite() { num } else { 0.0 };
        if old.is_none() {
            let len = self.rows[i as usize].len();
            self.by_count.remove(&(len, i));
            self.by_count.insert((len + 1, i));
            self.cols[j as usize].insert(i);
        }
        self.rows[i as usize].insert(j, Cell { num, val });
    }
}
