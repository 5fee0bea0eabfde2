//! The fixed order's plan as data for a compiler (kinema-jit): the
//! operation lists of the factorization ([`Op`], [`FoldedFactor`]) and of
//! the solves ([`SolveOp`], [`FoldedSolves`]), the scan a factorization
//! reports ([`FactorScan`]), and the traits compiled code implements to be
//! plugged in ([`CompiledFactor`], [`CompiledSolves`]). The interpreter in
//! `interpret` runs the same lists: both must give the same numbers.

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
///
/// [`FoldedLu`]: super::FoldedLu
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
///
/// [`order_accepted`]: crate::linalg::order_accepted
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FactorScan {
    /// maxᵢⱼ |aᵢⱼ|, as [`scale_and_finite`](crate::linalg::scale_and_finite)
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
///
/// [`FoldedLu`]: super::FoldedLu
/// [`FoldedLu::set_compiled_factor`]: super::FoldedLu::set_compiled_factor
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
///
/// [`FoldedLu`]: super::FoldedLu
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
///
/// [`FoldedLu`]: super::FoldedLu
/// [`FoldedLu::set_compiled_solves`]: super::FoldedLu::set_compiled_solves
pub trait CompiledSolves: std::fmt::Debug + Send + Sync {
    /// Solves in place from the factors' values `v`; `transpose` for Aᵀ.
    /// `work` is scratch of n values (the interpreter's y; its contents on
    /// entry and on return mean nothing). Returns `false` (and leaves
    /// `rhs` as it was) if it cannot, for instance on slices of unexpected
    /// lengths: the interpreter then solves.
    fn solve(&self, v: &[f64], rhs: &mut [f64], work: &mut [f64], transpose: bool) -> bool;
}
