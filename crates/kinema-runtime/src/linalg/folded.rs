//! A fixed-order LU specialised for one system when it is analysed:
//! [`FoldedLu`], the run-time counterpart of a generated LU.
//!
//! A generated LU chooses its pivot order at generation time and emits the
//! elimination as straight-line code with the constant entries of Φ_q (the
//! ±1 of every joint's x and y rows) folded away. A system known only at run
//! time (a model file's tapes) gets the same plan here, at analysis: the
//! order chosen by Markowitz's criterion under threshold partial pivoting on
//! the values at the initial guess, constants preferred among equals; the
//! elimination simulated with every entry either a number known now or a
//! value computed at run time; and what remains recorded as one flat list
//! of operations, each writing the next value. A factorization copies the
//! run-time entries in and runs that list; the solves run lists of the same
//! kind. No index lists per step, no structural zeros, no multiplication by
//! a unit pivot.
//!
//! The acceptance rule and the fallback are the generated LU's: every input
//! finite, every constant entry still its constant, every pivot
//! |u_kk| > τ · maxᵢⱼ |aᵢⱼ| and every multiplier |l_ik| ≤ 1/θ
//! ([`order_accepted`]); otherwise the factorization is done by the general
//! solver it holds ([`Auto`]'s dense or sparse LU), whose partial pivoting
//! gives the singularity verdict.

use std::collections::{BTreeMap, BTreeSet};

use super::{
    Auto, LinalgError, LinearSolver, PIVOT_THRESHOLD, PivotReport, check_len, order_accepted,
    permutation_sign,
};

use super::schedule::{INFINITY_BITS, MAGNITUDE_MASK};

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

/// A value during the simulated elimination.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Val {
    /// Known at analysis.
    Const(f64),
    /// Computed at run time: index into the value array.
    Var(u32),
}

/// One operation of the factorization; it writes the next value (see
/// [`FoldedFactor`]). `o`, `a`, `b` index the value array, `c` and `k` are
/// folded constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Op {
    /// 1 / a.
    Recip(u32),
    /// −a.
    Neg(u32),
    /// k · a.
    Scale(f64, u32),
    /// a · b.
    Mul(u32, u32),
    /// a − c.
    SubConst(u32, f64),
    /// o − a.
    Sub(u32, u32),
    /// o + a.
    Add(u32, u32),
    /// o − k · a.
    SubScaled(u32, f64, u32),
    /// o − a · b.
    SubMul(u32, u32, u32),
    /// c − k · a.
    ConstSubScaled(f64, f64, u32),
    /// c − a · b.
    ConstSubMul(f64, u32, u32),
}

/// A read-only view of a [`FoldedLu`]'s factorization, for a compiler of
/// it (kinema-jit). From the Jacobian's values (`nnz` of them): value i <
/// `inputs.len()` is `values[inputs[i]]`; op k writes value
/// `inputs.len() + k`; the scan is a [`RawScan`].
#[derive(Clone, Copy, Debug)]
pub struct FoldedFactor<'a> {
    /// Number of Jacobian values.
    pub nnz: usize,
    /// Length of the value array.
    pub values: usize,
    /// Pattern positions of the run-time entries.
    pub inputs: &'a [u32],
    /// Pattern positions and values of the constant entries.
    pub constants: &'a [(u32, f64)],
    /// The factorization.
    pub ops: &'a [Op],
    /// Values that are run-time pivots (scanned for the smallest |u_kk|).
    pub pivot_vars: &'a [u32],
    /// Values that are run-time multipliers (scanned for the largest |l_ik|).
    pub multiplier_vars: &'a [u32],
    /// The constant pivots' smallest magnitude (the scan's start).
    pub const_min_pivot: f64,
    /// The constant multipliers' largest magnitude (the scan's start).
    pub const_max_multiplier: f64,
    /// The constant entries' largest magnitude (the scale's start: the
    /// scale is taken over the run-time entries from there).
    pub const_scale: f64,
}

/// What a factorization's scan found, as the interpreter computes it: the
/// acceptance test ([`order_accepted`]) and the pivot report read it.
///
/// The scale and finiteness are taken over the run-time entries, from
/// [`FoldedFactor::const_scale`]: when every constant entry is its constant
/// (the only case the order is accepted in) that is maxᵢⱼ |aᵢⱼ| and the
/// finiteness of every value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FactorScan {
    /// maxᵢⱼ |aᵢⱼ|, as [`scale_and_finite`](super::scale_and_finite)
    /// computes it (the largest magnitude's bits).
    pub scale: f64,
    /// Every run-time Jacobian value finite.
    pub finite: bool,
    /// Every constant entry still its constant, bit for bit.
    pub same: bool,
    /// An odd number of the run-time pivots has its sign bit set (the
    /// determinant's sign, with the permutations' and the constant pivots').
    pub negative: bool,
    /// Smallest pivot magnitude, from `const_min_pivot` over `pivot_vars`
    /// in order (a NaN counts as zero).
    pub min_pivot: f64,
    /// Largest multiplier magnitude, from `const_max_multiplier` over
    /// `multiplier_vars` in order (a NaN counts as infinite).
    pub max_multiplier: f64,
}

/// A [`FactorScan`] as a factorization writes it: six `f64` at the
/// indices [`FactorScan::SCALE`] … [`FactorScan::MAX_MULTIPLIER`], each
/// flag 1 or 0 (anything but 0 reads as set). The folded LU keeps its scan
/// in this form, so that a compiled factorization writes it in place, one
/// 8-byte store per entry, and the acceptance test reads it back one 8-byte
/// load per entry: no copy, no conversion, and no load spanning two
/// stores (which waits for them to reach the cache).
pub type RawScan = [f64; FactorScan::LEN];

impl FactorScan {
    /// Entries of a [`RawScan`].
    pub const LEN: usize = 6;
    /// Index of [`scale`](Self::scale) in a [`RawScan`].
    pub const SCALE: usize = 0;
    /// Index of [`finite`](Self::finite) (1 or 0).
    pub const FINITE: usize = 1;
    /// Index of [`same`](Self::same) (1 or 0).
    pub const SAME: usize = 2;
    /// Index of [`negative`](Self::negative) (1 or 0).
    pub const NEGATIVE: usize = 3;
    /// Index of [`min_pivot`](Self::min_pivot).
    pub const MIN_PIVOT: usize = 4;
    /// Index of [`max_multiplier`](Self::max_multiplier).
    pub const MAX_MULTIPLIER: usize = 5;

    /// The scan a [`RawScan`] holds.
    #[must_use]
    pub fn from_raw(raw: &RawScan) -> FactorScan {
        FactorScan {
            scale: raw[Self::SCALE],
            finite: raw[Self::FINITE] != 0.0,
            same: raw[Self::SAME] != 0.0,
            negative: raw[Self::NEGATIVE] != 0.0,
            min_pivot: raw[Self::MIN_PIVOT],
            max_multiplier: raw[Self::MAX_MULTIPLIER],
        }
    }

    /// The scan as a [`RawScan`].
    #[must_use]
    pub fn to_raw(self) -> RawScan {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let mut raw = [0.0; Self::LEN];
        raw[Self::SCALE] = self.scale;
        raw[Self::FINITE] = flag(self.finite);
        raw[Self::SAME] = flag(self.same);
        raw[Self::NEGATIVE] = flag(self.negative);
        raw[Self::MIN_PIVOT] = self.min_pivot;
        raw[Self::MAX_MULTIPLIER] = self.max_multiplier;
        raw
    }
}

/// A [`FoldedLu`]'s factorization compiled elsewhere (kinema-jit), plugged
/// in with [`FoldedLu::set_compiled_factor`]: it must write the value array
/// and find the scan exactly as the interpreter does.
pub trait CompiledFactor: std::fmt::Debug + Send + Sync {
    /// Factors `values` into `v` and writes every entry of the scan into
    /// `scan`; `false` (nothing written) if it cannot, for instance on
    /// slices of unexpected lengths: the interpreter then factors. With
    /// `check` false the constant entries may be taken as planned,
    /// unchecked (`same` then set); checking them anyway is never wrong.
    /// (The scan is written in place in its raw form, not returned: see
    /// [`RawScan`].)
    fn factor(&self, values: &[f64], v: &mut [f64], check: bool, scan: &mut RawScan) -> bool;
}

/// One operation of a triangular solve on y, reading the factors' values v
/// (see [`FoldedSolves`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SolveOp {
    /// `y[dst] −= v[s] · y[src]`.
    MulSub {
        /// Entry of y written.
        dst: u32,
        /// Entry of y read.
        src: u32,
        /// Entry of v read.
        s: u32,
    },
    /// `y[dst] −= c · y[src]`.
    ConstMulSub {
        /// Entry of y written.
        dst: u32,
        /// Entry of y read.
        src: u32,
        /// The folded constant.
        c: f64,
    },
    /// `y[dst] −= y[src]`.
    Sub {
        /// Entry of y written.
        dst: u32,
        /// Entry of y read.
        src: u32,
    },
    /// `y[dst] += y[src]`.
    Add {
        /// Entry of y written.
        dst: u32,
        /// Entry of y read.
        src: u32,
    },
    /// `y[dst] ·= v[s]`.
    Scale {
        /// Entry of y written.
        dst: u32,
        /// Entry of v read.
        s: u32,
    },
    /// `y[dst] ·= c`.
    ConstScale {
        /// Entry of y written.
        dst: u32,
        /// The folded constant.
        c: f64,
    },
}

impl SolveOp {
    /// The entry of y the operation writes (it reads it too).
    #[must_use]
    pub fn dst(self) -> u32 {
        match self {
            SolveOp::MulSub { dst, .. }
            | SolveOp::ConstMulSub { dst, .. }
            | SolveOp::Sub { dst, .. }
            | SolveOp::Add { dst, .. }
            | SolveOp::Scale { dst, .. }
            | SolveOp::ConstScale { dst, .. } => dst,
        }
    }

    /// The other entry of y the operation reads, if any.
    #[must_use]
    pub fn src(self) -> Option<u32> {
        match self {
            SolveOp::MulSub { src, .. }
            | SolveOp::ConstMulSub { src, .. }
            | SolveOp::Sub { src, .. }
            | SolveOp::Add { src, .. } => Some(src),
            SolveOp::Scale { .. } | SolveOp::ConstScale { .. } => None,
        }
    }
}

/// A read-only view of a [`FoldedLu`]'s solves, for a compiler of them
/// (kinema-jit): a solve of A x = b gathers `y[k] = b[gather[k]]`, runs the
/// two sweeps on y in order (rounding each operation as written, no fused
/// multiply-add), and scatters `b[scatter[k]] = y[k]`; the transposed solve
/// the same with the `_t` lists, the gather and scatter swapped.
#[derive(Clone, Copy, Debug)]
pub struct FoldedSolves<'a> {
    /// Dimension: y, b and the orders have n entries.
    pub n: usize,
    /// Length of the factors' value array v.
    pub values: usize,
    /// Original row at each position (the solve's gather, the transposed
    /// solve's scatter).
    pub row_order: &'a [u32],
    /// Original column at each position (the solve's scatter, the
    /// transposed solve's gather).
    pub col_order: &'a [u32],
    /// L y = P b.
    pub forward: &'a [SolveOp],
    /// U x = y.
    pub backward: &'a [SolveOp],
    /// Uᵀ z = Qᵀ b.
    pub forward_t: &'a [SolveOp],
    /// Lᵀ x = z.
    pub backward_t: &'a [SolveOp],
}

/// Solves of a [`FoldedLu`] compiled elsewhere (kinema-jit), plugged in
/// with [`FoldedLu::set_compiled_solves`]: each must compute exactly what
/// the interpreted solve computes from the same v and b.
pub trait CompiledSolves: std::fmt::Debug + Send + Sync {
    /// Solves in place from the factors' values `v`; `transpose` for Aᵀ.
    /// `work` is scratch of n values (the interpreter's y; its contents on
    /// entry and on return mean nothing). Returns `false` (and leaves
    /// `rhs` as it was) if it cannot, for instance on slices of unexpected
    /// lengths: the interpreter then solves.
    fn solve(&self, v: &[f64], rhs: &mut [f64], work: &mut [f64], transpose: bool) -> bool;
}

/// An entry of the active matrix during the simulated elimination.
#[derive(Clone, Copy, Debug)]
struct Cell {
    /// Value at the initial guess (chooses pivots).
    num: f64,
    val: Val,
}

/// Which factorization the solves use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Current {
    None,
    Folded,
    Fallback,
}

/// LU with a pivot order fixed at analysis and the system's constant
/// Jacobian entries folded out (see the module `linalg::folded`). Built by
/// [`Auto`]'s [`LinearSolver::analyze_system`] for systems that say which
/// entries are constant ([`System::jacobian_constant`]); falls back to a
/// general [`Auto`] at any factorization the fixed order does not accept.
///
/// [`System::jacobian_constant`]: crate::System::jacobian_constant
#[derive(Debug)]
pub struct FoldedLu {
    n: usize,
    nnz: usize,
    /// The fixed order's plan; `None` when there is none (always the
    /// general solver).
    folded: Option<Box<Folded>>,
    current: Current,
    /// The general solver for orders the fixed one does not accept.
    fallback: Auto,
}

/// The fixed order's factorization and solves, as operation lists.
#[derive(Debug)]
struct Folded {
    /// Pattern positions of the run-time entries: value i is `values[inputs[i]]`.
    inputs: Vec<u32>,
    /// Pattern positions and values of the constant entries.
    constants: Vec<(u32, f64)>,
    /// Whether the constants are trusted as written (see
    /// [`FoldedLu::trust_constants`]).
    trusted: bool,
    /// The factorization: op k writes value `inputs.len() + k`.
    ops: Vec<Op>,
    /// Inputs, then the ops' results.
    v: Vec<f64>,
    /// Run-time pivots and multipliers (checked), and the constants' worst.
    pivot_vars: Vec<u32>,
    multiplier_vars: Vec<u32>,
    const_min_pivot: f64,
    const_max_multiplier: f64,
    /// The constant entries' largest magnitude.
    const_scale: f64,
    /// 1 / u_kk per position k.
    inv: Vec<Val>,
    /// Original row and column at each position of P A Q.
    row_order: Vec<u32>,
    col_order: Vec<u32>,
    /// L y = P b, U x = y; Uᵀ z = Qᵀ b, Lᵀ x = z.
    forward: Vec<SolveOp>,
    backward: Vec<SolveOp>,
    forward_t: Vec<SolveOp>,
    backward_t: Vec<SolveOp>,
    /// sign(P) sign(Q) ∏ sign(constant pivots): the determinant's sign
    /// but for the run-time pivots'.
    fixed_sign: f64,
    /// The last factorization's scan (the pivot report's numbers).
    scan: RawScan,
    work: Vec<f64>,
    /// The solves compiled to native code, if they were.
    compiled: Option<Box<dyn CompiledSolves>>,
    /// The factorization compiled to native code, if it was.
    compiled_factor: Option<Box<dyn CompiledFactor>>,
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

impl FoldedLu {
    /// Plans the factorization of the n × n matrix with nonzeros `pattern`,
    /// `constants[k]` the value of entry k if it never changes, `values` the
    /// entries at the initial guess (they choose the order). Without a
    /// usable fixed order (a constant pivot of zero, a constant multiplier
    /// over 1/θ, slices of other lengths than the pattern) or with one too
    /// large, every factorization is the general solver's.
    ///
    /// # Errors
    /// The general solver's analysis errors (an invalid pattern).
    pub fn new(
        n: usize,
        pattern: &[(u32, u32)],
        constants: &[Option<f64>],
        values: &[f64],
    ) -> Result<FoldedLu, LinalgError> {
        let fallback = Auto::analyze(n, pattern)?;
        let folded = if constants.len() == pattern.len() && values.len() == pattern.len() {
            Folded::plan(n, pattern, constants, values).map(Box::new)
        } else {
            None
        };
        Ok(FoldedLu {
            n,
            nnz: pattern.len(),
            folded,
            current: Current::None,
            fallback,
        })
    }

    /// Whether a fixed order was planned (else every factorization is the
    /// general solver's).
    #[must_use]
    pub fn is_planned(&self) -> bool {
        self.folded.is_some()
    }

    /// The solves' operation lists, read-only (see [`FoldedSolves`]);
    /// `None` without a plan.
    #[must_use]
    pub fn solves(&self) -> Option<FoldedSolves<'_>> {
        self.folded.as_ref().map(|f| FoldedSolves {
            n: self.n,
            values: f.v.len(),
            row_order: &f.row_order,
            col_order: &f.col_order,
            forward: &f.forward,
            backward: &f.backward,
            forward_t: &f.forward_t,
            backward_t: &f.backward_t,
        })
    }

    /// Plugs in compiled solves (see [`CompiledSolves`]); without a plan
    /// they are dropped. The factorization, its acceptance test and the
    /// fallback are unchanged.
    pub fn set_compiled_solves(&mut self, solves: Box<dyn CompiledSolves>) {
        if let Some(f) = &mut self.folded {
            f.compiled = Some(solves);
        }
    }

    /// The factorization's operation lists, read-only (see
    /// [`FoldedFactor`]); `None` without a plan.
    #[must_use]
    pub fn factorization(&self) -> Option<FoldedFactor<'_>> {
        self.folded.as_ref().map(|f| FoldedFactor {
            nnz: self.nnz,
            values: f.v.len(),
            inputs: &f.inputs,
            constants: &f.constants,
            ops: &f.ops,
            pivot_vars: &f.pivot_vars,
            multiplier_vars: &f.multiplier_vars,
            const_min_pivot: f.const_min_pivot,
            const_max_multiplier: f.const_max_multiplier,
            const_scale: f.const_scale,
        })
    }

    /// Stops checking the constant entries in
    /// [`factor_as_written`](LinearSolver::factor_as_written): the system
    /// vouches that its Jacobian has them bit for bit (see
    /// [`System::jacobian_constants_exact`](crate::System::jacobian_constants_exact)).
    /// [`factor`](LinearSolver::factor) still checks them: its values may
    /// be the equilibrated R Φ_q C.
    pub fn trust_constants(&mut self) {
        if let Some(f) = &mut self.folded {
            f.trusted = true;
        }
    }

    /// Plugs in a compiled factorization (see [`CompiledFactor`]); without
    /// a plan it is dropped. The acceptance rule, the pivot report and the
    /// fallback are unchanged.
    pub fn set_compiled_factor(&mut self, factor: Box<dyn CompiledFactor>) {
        if let Some(f) = &mut self.folded {
            f.compiled_factor = Some(factor);
        }
    }

    /// Whether a compiled factorization is plugged in.
    #[must_use]
    pub fn has_compiled_factor(&self) -> bool {
        self.folded
            .as_ref()
            .is_some_and(|f| f.compiled_factor.is_some())
    }

    /// Whether compiled solves are plugged in.
    #[must_use]
    pub fn has_compiled_solves(&self) -> bool {
        self.folded.as_ref().is_some_and(|f| f.compiled.is_some())
    }

    /// Number of operations a factorization in the fixed order runs (after
    /// the copy of the run-time entries); 0 without a plan.
    #[must_use]
    pub fn operations(&self) -> usize {
        self.folded.as_ref().map_or(0, |f| f.ops.len())
    }
}

impl Folded {
    fn plan(
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

    /// Tries the fixed order on `values`, checking the constant entries if
    /// `check`: `true` if accepted.
    #[inline]
    fn factor(&mut self, values: &[f64], singular_tolerance: f64, check: bool) -> bool {
        let compiled = self
            .compiled_factor
            .as_ref()
            .is_some_and(|c| c.factor(values, &mut self.v, check, &mut self.scan));
        if !compiled {
            self.interpret(values, check);
        }
        let scan = &self.scan;
        order_accepted(
            scan[FactorScan::FINITE] != 0.0 && scan[FactorScan::SAME] != 0.0,
            scan[FactorScan::MAX_MULTIPLIER],
            scan[FactorScan::MIN_PIVOT],
            singular_tolerance,
            scan[FactorScan::SCALE],
        )
    }

    /// The interpreted factorization: the value array and the scan. Out of
    /// line, and writing the scan itself: the compiled factorization's
    /// call stays a light frame.
    #[inline(never)]
    fn interpret(&mut self, values: &[f64], check: bool) {
        let mut max_bits = self.const_scale.to_bits();
        for &k in &self.inputs {
            max_bits = max_bits.max(values[k as usize].to_bits() & MAGNITUDE_MASK);
        }
        let (scale, finite) = (f64::from_bits(max_bits), max_bits < INFINITY_BITS);
        let mut same = true;
        for &(k, c) in if check { &self.constants[..] } else { &[] } {
            same &= values[k as usize].to_bits() == c.to_bits();
        }
        let m = self.inputs.len();
        let v = &mut self.v[..];
        for (x, &k) in v.iter_mut().zip(&self.inputs) {
            *x = values[k as usize];
        }
        for (k, op) in (m..).zip(&self.ops) {
            v[k] = match *op {
                Op::Recip(a) => 1.0 / v[a as usize],
                Op::Neg(a) => -v[a as usize],
                Op::Scale(c, a) => c * v[a as usize],
                Op::Mul(a, b) => v[a as usize] * v[b as usize],
                Op::SubConst(a, c) => v[a as usize] - c,
                Op::Sub(o, a) => v[o as usize] - v[a as usize],
                Op::Add(o, a) => v[o as usize] + v[a as usize],
                Op::SubScaled(o, c, a) => v[o as usize] - c * v[a as usize],
                Op::SubMul(o, a, b) => v[o as usize] - v[a as usize] * v[b as usize],
                Op::ConstSubScaled(o, c, a) => o - c * v[a as usize],
                Op::ConstSubMul(o, a, b) => o - v[a as usize] * v[b as usize],
            };
        }
        let mut min_pivot = self.const_min_pivot;
        let mut negative = false;
        for &p in &self.pivot_vars {
            negative ^= v[p as usize].is_sign_negative();
            let a = v[p as usize].abs();
            // A NaN pivot counts as zero.
            min_pivot = if a >= min_pivot {
                min_pivot
            } else if a.is_nan() {
                0.0
            } else {
                a
            };
        }
        let mut max_multiplier = self.const_max_multiplier;
        for &l in &self.multiplier_vars {
            let a = v[l as usize].abs();
            // A NaN multiplier counts as infinite.
            max_multiplier = if a <= max_multiplier {
                max_multiplier
            } else if a.is_nan() {
                f64::INFINITY
            } else {
                a
            };
        }
        self.scan = FactorScan {
            scale,
            finite,
            same,
            negative,
            min_pivot,
            max_multiplier,
        }
        .to_raw();
    }

    /// Runs the folded solve: gather by `gather`, two sweeps, scatter by `scatter`.
    #[inline]
    fn solve(&mut self, rhs: &mut [f64], transpose: bool) {
        if let Some(c) = &self.compiled
            && c.solve(&self.v, rhs, &mut self.work, transpose)
        {
            return;
        }
        self.interpret_solve(rhs, transpose);
    }

    /// The interpreted solve. Out of line, as [`interpret`](Self::interpret).
    #[inline(never)]
    fn interpret_solve(&mut self, rhs: &mut [f64], transpose: bool) {
        let (gather, first, second, scatter) = if transpose {
            (
                &self.col_order,
                &self.forward_t,
                &self.backward_t,
                &self.row_order,
            )
        } else {
            (
                &self.row_order,
                &self.forward,
                &self.backward,
                &self.col_order,
            )
        };
        let y = &mut self.work[..];
        for (yk, &r) in y.iter_mut().zip(gather) {
            *yk = rhs[r as usize];
        }
        sweep(first, &self.v, y);
        sweep(second, &self.v, y);
        for (&yk, &c) in y.iter().zip(scatter) {
            rhs[c as usize] = yk;
        }
    }
}

/// Runs one triangular sweep.
fn sweep(ops: &[SolveOp], v: &[f64], y: &mut [f64]) {
    for op in ops {
        match *op {
            SolveOp::MulSub { dst, src, s } => y[dst as usize] -= v[s as usize] * y[src as usize],
            SolveOp::ConstMulSub { dst, src, c } => y[dst as usize] -= c * y[src as usize],
            SolveOp::Sub { dst, src } => y[dst as usize] -= y[src as usize],
            SolveOp::Add { dst, src } => y[dst as usize] += y[src as usize],
            SolveOp::Scale { dst, s } => y[dst as usize] *= v[s as usize],
            SolveOp::ConstScale { dst, c } => y[dst as usize] *= c,
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

impl FoldedLu {
    /// [`factor`](LinearSolver::factor), checking the constant entries if
    /// `check`.
    #[inline(always)]
    fn factor_checking(
        &mut self,
        values: &[f64],
        singular_tolerance: f64,
        check: bool,
    ) -> Result<(), LinalgError> {
        check_len("Jacobian values", self.nnz, values.len())?;
        self.current = Current::None;
        if let Some(folded) = &mut self.folded
            && folded.factor(values, singular_tolerance, check)
        {
            self.current = Current::Folded;
            return Ok(());
        }
        self.factor_fallback(values, singular_tolerance)
    }

    /// A factorization the fixed order refused, by the general solver. Out
    /// of line: inlined, its code made every factorization save and
    /// restore the registers it uses.
    #[cold]
    #[inline(never)]
    fn factor_fallback(
        &mut self,
        values: &[f64],
        singular_tolerance: f64,
    ) -> Result<(), LinalgError> {
        self.fallback.factor(values, singular_tolerance)?;
        self.current = Current::Fallback;
        Ok(())
    }

    /// A solve with the general solver's factorization (out of line, as
    /// [`factor_fallback`](Self::factor_fallback)).
    #[inline(never)]
    fn solve_fallback(&mut self, rhs: &mut [f64], transpose: bool) -> Result<(), LinalgError> {
        if transpose {
            self.fallback.solve_transpose_in_place(rhs)
        } else {
            self.fallback.solve_in_place(rhs)
        }
    }
}

impl LinearSolver for FoldedLu {
    /// Without the system's constants and values: every entry a run-time
    /// value, the order chosen on a matrix of ones. A factorization the
    /// order does not accept is the general solver's.
    fn analyze(n: usize, pattern: &[(u32, u32)]) -> Result<Self, LinalgError> {
        FoldedLu::new(
            n,
            pattern,
            &vec![None; pattern.len()],
            &vec![1.0; pattern.len()],
        )
    }

    #[inline]
    fn dim(&self) -> usize {
        self.n
    }

    #[inline]
    fn factor(&mut self, values: &[f64], singular_tolerance: f64) -> Result<(), LinalgError> {
        self.factor_checking(values, singular_tolerance, true)
    }

    /// Skips the constants' check if they are trusted
    /// ([`trust_constants`](FoldedLu::trust_constants)).
    #[inline]
    fn factor_as_written(
        &mut self,
        values: &[f64],
        singular_tolerance: f64,
    ) -> Result<(), LinalgError> {
        let check = !self.folded.as_ref().is_some_and(|f| f.trusted);
        self.factor_checking(values, singular_tolerance, check)
    }

    #[inline]
    fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        check_len("right-hand side", self.n, rhs.len())?;
        match (self.current, &mut self.folded) {
            (Current::Folded, Some(folded)) => {
                folded.solve(rhs, false);
                Ok(())
            }
            (Current::Fallback, _) => self.solve_fallback(rhs, false),
            _ => Err(LinalgError::NotFactored),
        }
    }

    #[inline]
    fn solve_transpose_in_place(&mut self, rhs: &mut [f64]) -> Result<(), LinalgError> {
        check_len("right-hand side", self.n, rhs.len())?;
        match (self.current, &mut self.folded) {
            (Current::Folded, Some(folded)) => {
                folded.solve(rhs, true);
                Ok(())
            }
            (Current::Fallback, _) => self.solve_fallback(rhs, true),
            _ => Err(LinalgError::NotFactored),
        }
    }

    #[inline]
    fn pivot_report(&self) -> Option<PivotReport> {
        match (self.current, &self.folded) {
            (Current::Folded, Some(f)) => Some(PivotReport::from_smallest_pivot(
                f.scan[FactorScan::MIN_PIVOT],
                f.scan[FactorScan::SCALE],
                if f.scan[FactorScan::NEGATIVE] != 0.0 {
                    -f.fixed_sign
                } else {
                    f.fixed_sign
                },
            )),
            (Current::Fallback, _) => self.fallback.pivot_report(),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::DynDenseLu;

    /// A scan survives its raw form, each flag on its own index (a
    /// swapped index would swap two flags here).
    #[test]
    fn raw_scan_round_trips() {
        for bits in 0..8u8 {
            let scan = FactorScan {
                scale: 2.5,
                finite: bits & 1 != 0,
                same: bits & 2 != 0,
                negative: bits & 4 != 0,
                min_pivot: 0.125,
                max_multiplier: f64::INFINITY,
            };
            assert_eq!(FactorScan::from_raw(&scan.to_raw()), scan);
        }
        let raw = [1.0, 1.0, 0.0, 1.0, 3.0, 4.0];
        let scan = FactorScan::from_raw(&raw);
        assert!(scan.finite && !scan.same && scan.negative);
        assert_eq!(
            (scan.scale, scan.min_pivot, scan.max_multiplier),
            (1.0, 3.0, 4.0)
        );
    }

    /// A slider-crank-like Jacobian: unit entries (constant) on the x and y
    /// coordinates of two joints, run-time entries on the angle columns,
    /// one driver row. 5 × 5.
    fn pattern() -> (Vec<(u32, u32)>, Vec<Option<f64>>) {
        let entries = [
            (0, 0, Some(1.0)),
            (0, 2, None),
            (1, 1, Some(1.0)),
            (1, 2, None),
            (2, 0, Some(-1.0)),
            (2, 3, Some(1.0)),
            (2, 2, None),
            (2, 4, None),
            (3, 1, Some(-1.0)),
            (3, 2, None),
            (3, 4, None),
            (4, 2, Some(1.0)),
        ];
        (
            entries.iter().map(|&(r, c, _)| (r, c)).collect(),
            entries.iter().map(|&(_, _, k)| k).collect(),
        )
    }

    /// Values for angle θ: the constants, and trigonometric run-time entries.
    fn values(constants: &[Option<f64>], theta: f64) -> Vec<f64> {
        let mut run = [
            -theta.sin(),
            theta.cos(),
            0.7 * theta.sin(),
            -(theta * 0.3).sin(),
            -0.7 * theta.cos(),
            (theta * 0.3).cos(),
        ]
        .into_iter();
        constants
            .iter()
            .map(|c| c.unwrap_or_else(|| run.next().unwrap_or(0.0)))
            .collect()
    }

    fn dense(pattern: &[(u32, u32)], values: &[f64], n: usize) -> Vec<Vec<f64>> {
        let mut a = vec![vec![0.0; n]; n];
        for (&(r, c), &v) in pattern.iter().zip(values) {
            a[r as usize][c as usize] = v;
        }
        a
    }

    /// ‖A x − b‖∞ and ‖Aᵀ y − b‖∞ of the solver's two solves.
    fn residuals(lu: &mut FoldedLu, a: &[Vec<f64>]) -> (f64, f64) {
        let n = a.len();
        let b: Vec<f64> = (0..n).map(|i| 1.0 + i as f64 * 0.25).collect();
        let (mut x, mut y) = (b.clone(), b.clone());
        lu.solve_in_place(&mut x).expect("factored");
        lu.solve_transpose_in_place(&mut y).expect("factored");
        let mut worst = (0.0f64, 0.0f64);
        for i in 0..n {
            let ax: f64 = (0..n).map(|j| a[i][j] * x[j]).sum();
            let aty: f64 = (0..n).map(|j| a[j][i] * y[j]).sum();
            worst.0 = worst.0.max((ax - b[i]).abs());
            worst.1 = worst.1.max((aty - b[i]).abs());
        }
        worst
    }

    #[test]
    fn the_folded_order_solves_both_ways_and_reports_the_determinants_sign() {
        let (pattern, constants) = pattern();
        let mut lu = FoldedLu::new(5, &pattern, &constants, &values(&constants, 0.3))
            .expect("a valid pattern");
        assert!(lu.is_planned());
        let mut reference = DynDenseLu::analyze(5, &pattern).expect("a valid pattern");
        for theta in [0.3, 1.0, 2.0, -0.8] {
            let v = values(&constants, theta);
            lu.factor(&v, 1e-10).expect("regular");
            assert_eq!(lu.current, Current::Folded, "θ = {theta}");
            let (r, rt) = residuals(&mut lu, &dense(&pattern, &v, 5));
            assert!(r < 1e-13 && rt < 1e-13, "θ = {theta}: {r:e} {rt:e}");
            reference.factor(&v, 1e-10).expect("regular");
            let (mine, theirs) = (lu.pivot_report(), reference.pivot_report());
            assert_eq!(
                mine.map(|p| p.det_sign),
                theirs.map(|p| p.det_sign),
                "θ = {theta}"
            );
            // The ratio from the scan's smallest pivot is, bit for bit, the
            // one from every 1 / u_kk.
            let f = lu.folded.as_ref().expect("planned");
            let inverse = f.inv.iter().map(|&x| match x {
                Val::Const(c) => c,
                Val::Var(s) => f.v[s as usize],
            });
            let from_inverse =
                PivotReport::from_inverse_pivot_values(inverse, f.scan[FactorScan::SCALE], 1.0);
            assert_eq!(
                mine.map(|p| p.ratio.to_bits()),
                Some(from_inverse.ratio.to_bits()),
                "θ = {theta}"
            );
        }
    }

    #[test]
    fn folding_leaves_less_work_than_treating_every_entry_as_run_time() {
        let (pattern, constants) = pattern();
        let v = values(&constants, 0.3);
        let folded = FoldedLu::new(5, &pattern, &constants, &v).expect("valid");
        let general = FoldedLu::new(5, &pattern, &[None; 12], &v).expect("valid");
        assert!(folded.operations() < general.operations());
    }

    #[test]
    fn a_constant_that_changes_or_a_failing_order_goes_to_the_general_solver() {
        let (pattern, constants) = pattern();
        let mut lu =
            FoldedLu::new(5, &pattern, &constants, &values(&constants, 0.3)).expect("valid");
        // Entry 0 is declared constant 1: another value is not folded away.
        let mut v = values(&constants, 0.3);
        v[0] = 2.0;
        lu.factor(&v, 1e-10).expect("regular");
        assert_eq!(lu.current, Current::Fallback);
        let (r, rt) = residuals(&mut lu, &dense(&pattern, &v, 5));
        assert!(r < 1e-13 && rt < 1e-13, "{r:e} {rt:e}");
        // Non-finite values: refused by both.
        v[1] = f64::NAN;
        assert!(lu.factor(&v, 1e-10).is_err());
        assert!(matches!(
            lu.solve_in_place(&mut [0.0; 5]),
            Err(LinalgError::NotFactored)
        ));
        // Row 3 = −row 1 (entry (3, 4) zero, (3, 2) = −(1, 2)): singular,
        // reported as partial pivoting reports it.
        let mut a = values(&constants, 0.4);
        a[10] = 0.0;
        a[9] = -a[3];
        let mut reference = DynDenseLu::analyze(5, &pattern).expect("valid");
        assert!(matches!(
            lu.factor(&a, 1e-10),
            Err(LinalgError::Singular { .. })
        ));
        assert!(matches!(
            reference.factor(&a, 1e-10),
            Err(LinalgError::Singular { .. })
        ));
    }

    /// Trusted constants are not checked when factored as written (a
    /// changed constant then goes unseen: the caller's promise), still are
    /// by `factor` (equilibrated values); on values that keep them the
    /// trusting LU factors and solves as the checking one, bit for bit.
    #[test]
    fn trusted_constants_are_checked_only_when_not_as_written() {
        let (pattern, constants) = pattern();
        let start = values(&constants, 0.3);
        let mut checking = FoldedLu::new(5, &pattern, &constants, &start).expect("valid");
        let mut trusting = FoldedLu::new(5, &pattern, &constants, &start).expect("valid");
        trusting.trust_constants();
        for theta in [0.1, 0.7, 2.0] {
            let v = values(&constants, theta);
            checking.factor_as_written(&v, 1e-10).expect("regular");
            trusting.factor_as_written(&v, 1e-10).expect("regular");
            assert_eq!(trusting.current, Current::Folded);
            let b: Vec<f64> = (0..5).map(|i| 1.0 + f64::from(i) * 0.25).collect();
            let (mut x, mut y) = (b.clone(), b);
            checking.solve_in_place(&mut x).expect("factored");
            trusting.solve_in_place(&mut y).expect("factored");
            assert_eq!(x, y, "θ = {theta}");
        }
        let mut v = values(&constants, 0.3);
        v[0] = 2.0;
        trusting.factor_as_written(&v, 1e-10).expect("regular");
        assert_eq!(trusting.current, Current::Folded);
        trusting.factor(&v, 1e-10).expect("regular");
        assert_eq!(trusting.current, Current::Fallback);
        checking.factor_as_written(&v, 1e-10).expect("regular");
        assert_eq!(checking.current, Current::Fallback);
    }

    #[test]
    fn analysis_without_the_system_plans_on_ones() {
        let (pattern, constants) = pattern();
        let mut lu = FoldedLu::analyze(5, &pattern).expect("valid");
        let v = values(&constants, 1.0);
        lu.factor(&v, 1e-10).expect("regular");
        let (r, rt) = residuals(&mut lu, &dense(&pattern, &v, 5));
        assert!(r < 1e-13 && rt < 1e-13, "{r:e} {rt:e}");
    }
}
