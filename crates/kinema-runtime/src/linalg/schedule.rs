//! Refactorization with a fixed pivot order: the recorded elimination
//! replayed by every solver (see the `linalg` module docs, section
//! "Refactorization").

use std::collections::{BTreeMap, BTreeSet};

use super::{PivotReport, order_accepted, permutation_sign};

/// Why a replay stopped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Replay {
    /// A pivot failed the threshold or the singularity test: repivot.
    Repivot,
}

/// The structure of P A Q during symbolic elimination.
pub(crate) trait Structure {
    /// Marks (i, j) as a structural nonzero.
    fn insert(&mut self, i: usize, j: usize);
    /// Columns j > k of row k, increasing, into `out`.
    fn row_right(&self, k: usize, out: &mut Vec<u32>);
    /// Rows i > k of column k, increasing, into `out`.
    fn col_below(&self, k: usize, out: &mut Vec<u32>);
    /// Columns of row i, increasing, into `out`.
    fn row(&self, i: usize, out: &mut Vec<u32>);
}

/// Dense boolean structure on caller-provided storage (no allocation).
pub(crate) struct DenseStructure<'a> {
    pub(crate) n: usize,
    pub(crate) mask: &'a mut [bool],
}

impl Structure for DenseStructure<'_> {
    fn insert(&mut self, i: usize, j: usize) {
        if let Some(m) = self.mask.get_mut(i * self.n + j) {
            *m = true;
        }
    }
    fn row_right(&self, k: usize, out: &mut Vec<u32>) {
        let row = &self.mask[k * self.n..(k + 1) * self.n];
        out.extend((k + 1..self.n).filter(|&j| row[j]).map(|j| j as u32));
    }
    fn col_below(&self, k: usize, out: &mut Vec<u32>) {
        out.extend(
            (k + 1..self.n)
                .filter(|&i| self.mask[i * self.n + k])
                .map(|i| i as u32),
        );
    }
    fn row(&self, i: usize, out: &mut Vec<u32>) {
        let row = &self.mask[i * self.n..(i + 1) * self.n];
        out.extend((0..self.n).filter(|&j| row[j]).map(|j| j as u32));
    }
}

/// Sparse structure (rows and columns as ordered sets; allocates).
pub(crate) struct SparseStructure {
    rows: Vec<BTreeSet<u32>>,
    cols: Vec<BTreeSet<u32>>,
}

impl SparseStructure {
    pub(crate) fn new(n: usize) -> Self {
        Self {
            rows: vec![BTreeSet::new(); n],
            cols: vec![BTreeSet::new(); n],
        }
    }
}

impl Structure for SparseStructure {
    fn insert(&mut self, i: usize, j: usize) {
        if let (Some(r), Some(c)) = (self.rows.get_mut(i), self.cols.get_mut(j)) {
            r.insert(j as u32);
            c.insert(i as u32);
        }
    }
    fn row_right(&self, k: usize, out: &mut Vec<u32>) {
        out.extend(self.rows[k].range(k as u32 + 1..).copied());
    }
    fn col_below(&self, k: usize, out: &mut Vec<u32>) {
        out.extend(self.cols[k].range(k as u32 + 1..).copied());
    }
    fn row(&self, i: usize, out: &mut Vec<u32>) {
        out.extend(self.rows[i].iter().copied());
    }
}

/// Elimination step k: its pivot's slot and how many L and U entries it
/// owns (the entry streams are consumed in step order).
#[derive(Debug, Clone, Copy, Default)]
struct Step {
    /// Slot of u_kk.
    diag: u32,
    /// Entries in column k of L.
    l_len: u32,
    /// Entries in row k of strict U.
    u_len: u32,
}

/// A recorded elimination for a fixed pivot order, and the factors it
/// computes. All indices are slots into `values`.
#[derive(Debug, Clone, Default)]
pub(crate) struct Schedule {
    n: usize,
    /// Position k of P A Q holds original row `row_order[k]`.
    row_order: Vec<u32>,
    /// Position k of P A Q holds original column `col_order[k]`.
    col_order: Vec<u32>,
    /// Slot of each pattern entry.
    entry_slot: Vec<u32>,
    /// L + U (and A before elimination), one value per structural nonzero.
    values: Vec<f64>,
    diag_slot: Vec<u32>,
    inv_diag: Vec<f64>,
    /// L by columns: entries l_ptr[k]..l_ptr[k+1] are (row, slot) of column k.
    l_ptr: Vec<u32>,
    l_row: Vec<u32>,
    l_slot: Vec<u32>,
    /// Strict U by rows, laid out last row first after `build`: (column, slot) of each entry.
    /// `u_ptr` keeps the row offsets of the build order (row k had entries
    /// u_ptr[k]..u_ptr[k+1] before the reversal).
    u_ptr: Vec<u32>,
    u_col: Vec<u32>,
    u_slot: Vec<u32>,
    /// For each step k, each L entry of column k, each U entry of row k (in
    /// that nesting): the slot of a_ij to update.
    update: Vec<u32>,
    /// Column k of each L entry, row k of each U entry (for the solves).
    l_col: Vec<u32>,
    u_row: Vec<u32>,
    /// Values of L (by columns) and of strict U scaled by its pivot,
    /// u_kj / u_kk (by rows), packed in the order the solves read them.
    l_val: Vec<f64>,
    u_val: Vec<f64>,
    /// Per-step ranges, derived from the above.
    steps: Vec<Step>,
    /// Slots of fill-ins (not in A's pattern), zeroed before each replay.
    fill: Vec<u32>,
    /// Scratch vector for solves.
    work: Vec<f64>,
    /// Scratch lists for building.
    list_a: Vec<u32>,
    list_b: Vec<u32>,
    /// Scratch for the permutations' sign.
    perm_scratch: Vec<usize>,
    /// sign(P) sign(Q) of the recorded order.
    perm_sign: f64,
    /// maxᵢⱼ |aᵢⱼ| of the last replay.
    scale: f64,
    ready: bool,
}

impl Schedule {
    /// An empty schedule for dimension n; `capacity_hint` reserves room for
    /// that many structural nonzeros of L + U and updates so that rebuilding
    /// within it does not allocate.
    pub(crate) fn with_capacity(n: usize, nnz: usize, slots: usize, updates: usize) -> Self {
        Self {
            n,
            row_order: Vec::with_capacity(n),
            col_order: Vec::with_capacity(n),
            entry_slot: Vec::with_capacity(nnz),
            values: Vec::with_capacity(slots),
            diag_slot: Vec::with_capacity(n),
            inv_diag: Vec::with_capacity(n),
            l_ptr: Vec::with_capacity(n + 1),
            l_row: Vec::with_capacity(slots),
            l_slot: Vec::with_capacity(slots),
            u_ptr: Vec::with_capacity(n + 1),
            u_col: Vec::with_capacity(slots),
            u_slot: Vec::with_capacity(slots),
            update: Vec::with_capacity(updates),
            l_col: Vec::with_capacity(slots),
            u_row: Vec::with_capacity(slots),
            l_val: Vec::with_capacity(slots),
            u_val: Vec::with_capacity(slots),
            steps: Vec::with_capacity(n),
            fill: Vec::with_capacity(slots),
            work: Vec::with_capacity(n),
            list_a: Vec::with_capacity(n),
            list_b: Vec::with_capacity(n),
            perm_scratch: Vec::with_capacity(n),
            perm_sign: 1.0,
            scale: 0.0,
            ready: false,
        }
    }

    /// `true` once a schedule has been built.
    #[inline]
    pub(crate) fn is_ready(&self) -> bool {
        self.ready
    }

    /// Records the elimination of P A Q for the pivot order `row_order`,
    /// `col_order` (original row / column at each position), using
    /// `structure` (empty on entry) for the symbolic work.
    ///
    /// `slot_index` maps a filled (position row, position column) to its slot
    /// while building; it is cleared here.
    pub(crate) fn build<S: Structure>(
        &mut self,
        pattern: &[(u32, u32)],
        row_order: impl Iterator<Item = u32>,
        col_order: impl Iterator<Item = u32>,
        structure: &mut S,
        slot_index: &mut SlotIndex<'_>,
    ) {
        self.ready = false;
        self.set_orders(row_order, col_order);
        self.fill_structure(pattern, structure);
        self.assign_slots(pattern, structure, slot_index);
        self.record_elimination(structure, slot_index);
        self.record_steps();
        self.record_fill_and_sign();
        self.ready = true;
    }

    /// The pivot order, and its inverse permutations in `list_a` (rows) and
    /// `list_b` (columns).
    fn set_orders(
        &mut self,
        row_order: impl Iterator<Item = u32>,
        col_order: impl Iterator<Item = u32>,
    ) {
        let n = self.n;
        self.row_order.clear();
        self.row_order.extend(row_order);
        self.col_order.clear();
        self.col_order.extend(col_order);
        // Inverse permutations, kept in list_a / list_b while building.
        let (row_pos, col_pos) = (&mut self.list_a, &mut self.list_b);
        row_pos.clear();
        row_pos.resize(n, 0);
        col_pos.clear();
        col_pos.resize(n, 0);
        for (k, &r) in self.row_order.iter().enumerate() {
            row_pos[r as usize] = k as u32;
        }
        for (k, &c) in self.col_order.iter().enumerate() {
            col_pos[c as usize] = k as u32;
        }
    }

    /// A's pattern in P A Q, the diagonal, and the fill of symbolic
    /// elimination, into `structure`.
    fn fill_structure<S: Structure>(&mut self, pattern: &[(u32, u32)], structure: &mut S) {
        let n = self.n;
        let (row_pos, col_pos) = (&self.list_a, &self.list_b);
        for &(r, c) in pattern {
            structure.insert(row_pos[r as usize] as usize, col_pos[c as usize] as usize);
        }
        for k in 0..n {
            structure.insert(k, k);
        }
        // Symbolic elimination: fill.
        let (below, right) = (&mut self.l_row, &mut self.u_col);
        for k in 0..n {
            below.clear();
            right.clear();
            structure.col_below(k, below);
            structure.row_right(k, right);
            for &i in below.iter() {
                for &j in right.iter() {
                    structure.insert(i as usize, j as usize);
                }
            }
        }
    }

    /// One slot per structural nonzero of L + U, row by row; the slots of
    /// A's entries and of the diagonal.
    fn assign_slots<S: Structure>(
        &mut self,
        pattern: &[(u32, u32)],
        structure: &S,
        slot_index: &mut SlotIndex<'_>,
    ) {
        let n = self.n;
        // Slots, row by row.
        slot_index.clear();
        let mut slots = 0u32;
        let mut row = std::mem::take(&mut self.l_slot);
        for i in 0..n {
            row.clear();
            structure.row(i, &mut row);
            for &j in &row {
                slot_index.insert(i, j as usize, slots);
                slots += 1;
            }
        }
        self.l_slot = row;
        self.values.clear();
        self.values.resize(slots as usize, 0.0);
        self.entry_slot.clear();
        for &(r, c) in pattern {
            let (i, j) = (
                self.list_a[r as usize] as usize,
                self.list_b[c as usize] as usize,
            );
            self.entry_slot.push(slot_index.get(i, j));
        }
        self.diag_slot.clear();
        for k in 0..n {
            self.diag_slot.push(slot_index.get(k, k));
        }
        self.inv_diag.clear();
        self.inv_diag.resize(n, 0.0);
    }

    /// L by columns, strict U by rows (laid out last row first) and the
    /// update list of every step.
    fn record_elimination<S: Structure>(&mut self, structure: &S, slot_index: &SlotIndex<'_>) {
        let n = self.n;
        // L columns, U rows, updates.
        self.l_ptr.clear();
        self.l_row.clear();
        self.l_slot.clear();
        self.u_ptr.clear();
        self.u_col.clear();
        self.u_slot.clear();
        self.update.clear();
        self.l_ptr.push(0);
        self.u_ptr.push(0);
        let mut below = std::mem::take(&mut self.list_a);
        let mut right = std::mem::take(&mut self.list_b);
        for k in 0..n {
            below.clear();
            right.clear();
            structure.col_below(k, &mut below);
            structure.row_right(k, &mut right);
            for &j in &right {
                self.u_col.push(j);
                self.u_slot.push(slot_index.get(k, j as usize));
            }
            for &i in &below {
                self.l_row.push(i);
                self.l_slot.push(slot_index.get(i as usize, k));
                for &j in &right {
                    self.update.push(slot_index.get(i as usize, j as usize));
                }
            }
            self.l_ptr.push(self.l_row.len() as u32);
            self.u_ptr.push(self.u_col.len() as u32);
        }
        self.list_a = below;
        self.list_b = right;
        // Lay U's rows out last row first (each row's entries in their
        // order), so that back substitution reads them front to back: reverse
        // the whole array, then each row's segment back. In place, so a
        // rebuild on re-pivoting allocates nothing.
        let len = self.u_col.len();
        for array in [&mut self.u_col, &mut self.u_slot] {
            array.reverse();
            for k in 0..n {
                let (start, end) = (self.u_ptr[k] as usize, self.u_ptr[k + 1] as usize);
                array[len - end..len - start].reverse();
            }
        }
    }

    /// Per-step ranges, and the columns of L's and rows of U's entries for
    /// the solves.
    fn record_steps(&mut self) {
        let n = self.n;
        self.l_val.clear();
        self.l_val.resize(self.l_row.len(), 0.0);
        self.u_val.clear();
        self.u_val.resize(self.u_col.len(), 0.0);
        self.steps.clear();
        self.l_col.clear();
        self.u_row.clear();
        for k in 0..n {
            let (l_len, u_len) = (
                self.l_ptr[k + 1] - self.l_ptr[k],
                self.u_ptr[k + 1] - self.u_ptr[k],
            );
            self.steps.push(Step {
                diag: self.diag_slot[k],
                l_len,
                u_len,
            });
            self.l_col
                .extend(std::iter::repeat_n(k as u32, l_len as usize));
        }
        for k in (0..n).rev() {
            let u_len = self.u_ptr[k + 1] - self.u_ptr[k];
            self.u_row
                .extend(std::iter::repeat_n(k as u32, u_len as usize));
        }
    }

    /// Slots no pattern entry writes (zeroed before each replay), the solve's
    /// scratch and sign(P) sign(Q).
    fn record_fill_and_sign(&mut self) {
        let n = self.n;
        // Fill-ins: slots no pattern entry writes.
        let mut written = std::mem::take(&mut self.work);
        written.clear();
        written.resize(self.values.len(), 0.0);
        for &s in &self.entry_slot {
            written[s as usize] = 1.0;
        }
        self.fill.clear();
        self.fill
            .extend((0..self.values.len() as u32).filter(|&s| written[s as usize] == 0.0));
        self.work = written;
        self.work.clear();
        self.work.resize(n, 0.0);
        self.perm_scratch.clear();
        self.perm_scratch.resize(n, 0);
        self.perm_sign = permutation_sign(
            self.row_order.iter().map(|&r| r as usize),
            &mut self.perm_scratch,
        ) * permutation_sign(
            self.col_order.iter().map(|&c| c as usize),
            &mut self.perm_scratch,
        );
    }

    /// Replays the elimination on new values of A (pattern order). The
    /// caller has checked the length of `values`.
    ///
    /// The threshold test |u_kk| ≥ θ |a_ik| is checked as |l_ik| ≤ 1/θ on the
    /// multipliers, and the singularity test on the smallest pivot, both once
    /// at the end: a failed replay is thrown away anyway.
    pub(crate) fn refactor(
        &mut self,
        values: &[f64],
        singular_tolerance: f64,
    ) -> Result<(), Replay> {
        let (scale, finite) = scale_and_finite(values);
        self.scale = scale;
        let lu = &mut self.values[..];
        for &s in &self.fill {
            lu[s as usize] = 0.0;
        }
        for (&slot, &v) in self.entry_slot.iter().zip(values) {
            lu[slot as usize] = v;
        }
        let (mut min_pivot, mut max_multiplier) = (f64::INFINITY, 0.0_f64);
        let mut update = self.update.iter();
        let (mut l_at, mut u_at) = (0usize, 0usize);
        let u_total = self.u_val.len();
        for (step, inv_diag) in self.steps.iter().zip(self.inv_diag.iter_mut()) {
            let pivot = lu[step.diag as usize];
            if pivot.abs() < min_pivot {
                min_pivot = pivot.abs();
            }
            let inv = 1.0 / pivot;
            *inv_diag = inv;
            // Row k of U is final: pack it, scaled by 1/u_kk (rows are laid
            // out last first: row k ends where rows 0..k−1 begin).
            let u_end = u_at + step.u_len as usize;
            let (r0, r1) = (u_total - u_end, u_total - u_at);
            let u_row = &mut self.u_val[r0..r1];
            for (u, &us) in u_row.iter_mut().zip(&self.u_slot[r0..r1]) {
                *u = lu[us as usize] * inv;
            }
            let u_row = &*u_row;
            // Column k of L: l_ik = a_ik / u_kk; a_ij −= l_ik u_kj = a_ik (u_kj / u_kk).
            let l_end = l_at + step.l_len as usize;
            for (lv, &ls) in self.l_val[l_at..l_end]
                .iter_mut()
                .zip(&self.l_slot[l_at..l_end])
            {
                let a = lu[ls as usize];
                let l = a * inv;
                *lv = l;
                if l.abs() > max_multiplier {
                    max_multiplier = l.abs();
                }
                for (&u, &dst) in u_row.iter().zip(update.by_ref()) {
                    lu[dst as usize] -= a * u;
                }
            }
            (l_at, u_at) = (l_end, u_end);
        }
        // With finite inputs, a zero pivot makes `min_pivot` 0 before any ∞
        // or NaN can spread; an overflow shows in the multipliers.
        if order_accepted(finite, max_multiplier, min_pivot, singular_tolerance, scale) {
            Ok(())
        } else {
            Err(Replay::Repivot)
        }
    }

    /// The pivots of the last replay (meaningful after a successful one).
    pub(crate) fn pivot_report(&self) -> PivotReport {
        PivotReport::from_inverse_pivots(&self.inv_diag, self.scale, self.perm_sign)
    }

    /// Overwrites b with A⁻¹ b using the last successful replay. The caller
    /// has checked the length.
    pub(crate) fn solve(&mut self, b: &mut [f64]) {
        let y = &mut self.work[..];
        for (yk, &r) in y.iter_mut().zip(&self.row_order) {
            *yk = b[r as usize];
        }
        // Forward, L y = P b: entries in column order, so y_k is final when
        // column k's entries are reached.
        for ((&i, &k), &l) in self.l_row.iter().zip(&self.l_col).zip(&self.l_val) {
            y[i as usize] -= l * y[k as usize];
        }
        // Backward, U x = y with U's rows scaled by 1/u_kk: rows from the
        // last up, so x_j (j > k) is final when row k's entries are reached.
        for (yk, &inv) in y.iter_mut().zip(&self.inv_diag) {
            *yk *= inv;
        }
        for ((&k, &j), &u) in self.u_row.iter().zip(&self.u_col).zip(&self.u_val) {
            y[k as usize] -= u * y[j as usize];
        }
        for (&yk, &c) in y.iter().zip(&self.col_order) {
            b[c as usize] = yk;
        }
    }
    /// Overwrites b with A⁻ᵀ b using the last successful replay (the same
    /// factors read the other way). The caller has checked the length.
    ///
    /// P A Q = L U gives Aᵀ = Q Uᵀ Lᵀ P: w = Qᵀ b, Uᵀ v = w (forward, U's
    /// rows read first row first), Lᵀ u = v (backward, L's columns last
    /// first), x = Pᵀ u.
    pub(crate) fn solve_transpose(&mut self, b: &mut [f64]) {
        let y = &mut self.work[..];
        for (yk, &c) in y.iter_mut().zip(&self.col_order) {
            *yk = b[c as usize];
        }
        // U = D (I + N), N_kj = u_kj / u_kk stored; Uᵀ v = w is
        // (I + Nᵀ) s = w then v = D⁻¹ s. Row k's entries reach s_j, j > k,
        // and s_k is final once the rows above k are done.
        for ((&k, &j), &u) in self.u_row.iter().zip(&self.u_col).zip(&self.u_val).rev() {
            y[j as usize] -= u * y[k as usize];
        }
        for (yk, &inv) in y.iter_mut().zip(&self.inv_diag) {
            *yk *= inv;
        }
        // Lᵀ u = v: column k's entries l_ik (i > k) give u_k −= l_ik u_i;
        // columns from the last, so u_i is final when reached.
        for ((&i, &k), &l) in self.l_row.iter().zip(&self.l_col).zip(&self.l_val).rev() {
            y[k as usize] -= l * y[i as usize];
        }
        for (&yk, &r) in y.iter().zip(&self.row_order) {
            b[r as usize] = yk;
        }
    }
}

/// max |v| over `values`, and whether all are finite, in one branch-free
/// pass. (The scale is meaningless when not all are finite.)
///
/// Short vectors (the small mechanisms' Φ, whose norm decides every Newton
/// iteration) go through the bit patterns in four scalar lanes: for IEEE
/// doubles with the sign cleared, the integer order is the order of |v|, and
/// every infinity or NaN lies at or above the bits of +∞ — short latency.
/// Long ones through f64 lanes that vectorize: |v| kept when larger (a NaN
/// never is), and v − v, 0 for a finite v and NaN otherwise, summed.
///
/// This is the runtime's one finiteness and scale test: of a factorization's
/// input (the scale of its singularity test), of Φ (its norm), of Newton's
/// updates, of the solutions. Generated LUs call it too.
#[inline(always)]
pub fn scale_and_finite(values: &[f64]) -> (f64, bool) {
    if values.len() <= 32 {
        scale_and_finite_bits(values)
    } else {
        scale_and_finite_lanes(values)
    }
}

/// [`scale_and_finite`] of values gathered by value, for generated code:
/// with the length a constant the test unrolls into four lanes of integer
/// maxima over the bits, and the array never exists in memory.
#[inline(always)]
pub fn scale_and_finite_array<const N: usize>(values: [f64; N]) -> (f64, bool) {
    let mut lanes = [0u64; 4];
    for (k, v) in values.into_iter().enumerate() {
        lanes[k % 4] = lanes[k % 4].max(v.to_bits() & MAGNITUDE_MASK);
    }
    let max_bits = lanes[0].max(lanes[1]).max(lanes[2].max(lanes[3]));
    (f64::from_bits(max_bits), max_bits < INFINITY_BITS)
}

/// The sign bit cleared: for IEEE doubles the integer order of
/// `v.to_bits() & MAGNITUDE_MASK` is the order of |v|, which the scans'
/// maxima and minima of magnitudes use (the JIT's compiled scans too, so
/// that both compute the same bits).
pub const MAGNITUDE_MASK: u64 = !(1 << 63);
/// The bits of +∞: every ±∞ or NaN lies at or above them once the sign is
/// cleared with [`MAGNITUDE_MASK`].
pub const INFINITY_BITS: u64 = 0x7FF0_0000_0000_0000;

#[inline(always)]
fn scale_and_finite_bits(values: &[f64]) -> (f64, bool) {
    let bits = |v: f64| v.to_bits() & MAGNITUDE_MASK;
    let (mut m0, mut m1, mut m2, mut m3) = (0u64, 0u64, 0u64, 0u64);
    let chunks = values.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        m0 = m0.max(bits(c[0]));
        m1 = m1.max(bits(c[1]));
        m2 = m2.max(bits(c[2]));
        m3 = m3.max(bits(c[3]));
    }
    for &v in rest {
        m0 = m0.max(bits(v));
    }
    let max_bits = m0.max(m1).max(m2.max(m3));
    (f64::from_bits(max_bits), max_bits < INFINITY_BITS)
}

/// One lane's step of the test: |v| kept when larger (a NaN never is), and
/// v − v (0 for a finite v, NaN otherwise) summed.
// `v - v` is the point: 0 or NaN.
#[allow(clippy::eq_op)]
#[inline(always)]
fn lane(max: &mut f64, nan: &mut f64, v: f64) {
    let a = v.abs();
    *max = if a > *max { a } else { *max };
    *nan += v - v;
}

/// The four lanes' verdict: (max |v|, all finite).
#[inline(always)]
fn lanes_verdict(max: [f64; 4], nan: [f64; 4]) -> (f64, bool) {
    let scale = max[0].max(max[1]).max(max[2].max(max[3]));
    let finite = (nan[0] + nan[1]) + (nan[2] + nan[3]) == 0.0;
    (scale, finite)
}

#[inline(never)]
fn scale_and_finite_lanes(values: &[f64]) -> (f64, bool) {
    let mut max = [0.0f64; 4];
    let mut nan = [0.0f64; 4];
    let chunks = values.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for ((m, z), &v) in max.iter_mut().zip(nan.iter_mut()).zip(c) {
            lane(m, z, v);
        }
    }
    for (&v, (m, z)) in rest.iter().zip(max.iter_mut().zip(nan.iter_mut())) {
        lane(m, z, v);
    }
    lanes_verdict(max, nan)
}

/// [`scale_and_finite`] of `values` and, in the same pass, the largest
/// |values\[i\]| among those selected by `mask[i]` ([`MASK_ALL`], or 0 to
/// leave it out; missing masks are 0): a folded LU's run-time entries,
/// their scale and their multipliers' largest magnitude at once, in f64
/// lanes that vectorize. When every value is finite both maxima are those
/// of the magnitudes' bits; otherwise the verdict is `false` and the
/// maxima mean nothing.
#[inline(never)]
pub fn scale_and_masked_max(values: &[f64], mask: &[u64]) -> (f64, f64, bool) {
    let (mut max, mut nan, mut masked) = ([0.0f64; 4], [0.0f64; 4], [0.0f64; 4]);
    let n = values.len().min(mask.len());
    let (values, rest_values) = values.split_at(n);
    let chunks = values.chunks_exact(4).zip(mask.chunks_exact(4));
    let split = n / 4 * 4;
    for (c, m) in chunks {
        for i in 0..4 {
            lane(&mut max[i], &mut nan[i], c[i]);
            masked_lane(&mut masked[i], c[i], m[i]);
        }
    }
    for (&v, &m) in values[split..].iter().zip(&mask[split..]) {
        lane(&mut max[0], &mut nan[0], v);
        masked_lane(&mut masked[0], v, m);
    }
    for &v in rest_values {
        lane(&mut max[0], &mut nan[0], v);
    }
    let (scale, finite) = lanes_verdict(max, nan);
    let most = masked[0].max(masked[1]).max(masked[2].max(masked[3]));
    (scale, most, finite)
}

/// One lane's step of the masked maximum: |v| kept when selected and
/// larger.
#[inline(always)]
fn masked_lane(max: &mut f64, v: f64, mask: u64) {
    let a = f64::from_bits(v.to_bits() & mask & MAGNITUDE_MASK);
    *max = if a > *max { a } else { *max };
}

/// The mask selecting a value in [`scale_and_masked_max`].
pub const MASK_ALL: u64 = u64::MAX;

/// [`scale_and_finite`] over the entries `values[k]` for the positions `at`
/// (a generated LU's run-time inputs, its other entries being constants),
/// without gathering them first. Positions outside `values` are skipped.
/// Scattered reads do not vectorize, so this takes the bit-pattern lanes of
/// the short path (equal to the f64 lanes, see the tests).
#[inline]
pub fn scale_and_finite_at(values: &[f64], at: &[usize]) -> (f64, bool) {
    let bits = |k: usize| values.get(k).map_or(0, |v| v.to_bits() & MAGNITUDE_MASK);
    let mut m = [0u64; 4];
    let chunks = at.chunks_exact(4);
    for &k in chunks.remainder() {
        m[0] = m[0].max(bits(k));
    }
    for c in chunks {
        for (m, &k) in m.iter_mut().zip(c) {
            *m = (*m).max(bits(k));
        }
    }
    let max_bits = m[0].max(m[1]).max(m[2].max(m[3]));
    (f64::from_bits(max_bits), max_bits < INFINITY_BITS)
}

/// Map from a filled position (i, j) to its slot while building.
pub(crate) enum SlotIndex<'a> {
    /// Dense table on caller storage (no allocation), n × n.
    Dense { n: usize, table: &'a mut [u32] },
    /// Ordered map (allocates).
    Sparse(BTreeMap<(u32, u32), u32>),
}

impl SlotIndex<'_> {
    fn clear(&mut self) {
        match self {
            Self::Dense { table, .. } => table.fill(u32::MAX),
            Self::Sparse(map) => map.clear(),
        }
    }

    fn insert(&mut self, i: usize, j: usize, slot: u32) {
        match self {
            Self::Dense { n, table } => {
                if let Some(t) = table.get_mut(i * *n + j) {
                    *t = slot;
                }
            }
            Self::Sparse(map) => {
                map.insert((i as u32, j as u32), slot);
            }
        }
    }

    /// The slot of (i, j); (i, j) is in the filled structure by construction.
    fn get(&self, i: usize, j: usize) -> u32 {
        match self {
            Self::Dense { n, table } => table.get(i * n + j).copied().unwrap_or(0),
            Self::Sparse(map) => map.get(&(i as u32, j as u32)).copied().unwrap_or(0),
        }
    }
}

#[cfg(test)]
mod tests;
