//! Refactorization with a fixed pivot order: the fast path of [`DenseLu`]
//! and [`SparseLu`].
//!
//! The Jacobian's structure never changes, and along a motion its row pivots
//! rarely do. So once a pivoting factorization P A Q = L U has chosen the
//! order (the dense kernel for [`DenseLu`], faer for [`SparseLu`]), the
//! filled structure of L + U is computed and the whole elimination is
//! written down as a list of slots: for step k, each row i below with
//! l_ik ≠ 0 gets `a_ij −= l_ik u_kj` for the u_kj ≠ 0 of row k. A numeric
//! refactorization then only replays that list — the work is the number of
//! structural multiply-adds, with no search, no swaps and no symbolic work
//! (the idea of KLU's refactorization).
//!
//! Each replayed pivot must pass the threshold test |u_kk| ≥ θ maxᵢ |l_ik
//! u_kk| (θ = [`PIVOT_THRESHOLD`], as in threshold partial pivoting) and the
//! singularity test |u_kk| > τ · scale; if one fails the caller repivots
//! with its pivoting factorization and rebuilds the schedule, so the
//! singularity verdict is always that of partial pivoting.
//!
//! [`DenseLu`]: super::DenseLu
//! [`SparseLu`]: super::SparseLu

use std::collections::{BTreeMap, BTreeSet};

/// θ of the threshold test on replayed pivots.
pub(crate) const PIVOT_THRESHOLD: f64 = 0.1;

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
        out.extend((k + 1..self.n).filter(|&i| self.mask[i * self.n + k]).map(|i| i as u32));
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

/// Elimination step k: where its pivot, L column and U row live.
#[derive(Debug, Clone, Copy, Default)]
struct Step {
    /// Slot of u_kk.
    diag: u32,
    /// L entries l_ptr[k]..l_ptr[k+1].
    l0: u32,
    l1: u32,
    /// U entries u_ptr[k]..u_ptr[k+1].
    u0: u32,
    u1: u32,
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
    /// Strict U by rows: entries u_ptr[k]..u_ptr[k+1] are (column, slot) of row k.
    u_ptr: Vec<u32>,
    u_col: Vec<u32>,
    u_slot: Vec<u32>,
    /// For each step k, each L entry of column k, each U entry of row k (in
    /// that nesting): the slot of a_ij to update.
    update: Vec<u32>,
    /// Per-step ranges, derived from the above.
    steps: Vec<Step>,
    /// Slots of fill-ins (not in A's pattern), zeroed before each replay.
    fill: Vec<u32>,
    /// Scratch vector for solves.
    work: Vec<f64>,
    /// Scratch lists for building.
    list_a: Vec<u32>,
    list_b: Vec<u32>,
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
            steps: Vec::with_capacity(n),
            fill: Vec::with_capacity(slots),
            work: Vec::with_capacity(n),
            list_a: Vec::with_capacity(n),
            list_b: Vec::with_capacity(n),
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
        let n = self.n;
        self.ready = false;
        self.row_order.clear();
        self.row_order.extend(row_order);
        self.col_order.clear();
        self.col_order.extend(col_order);
        // Inverse permutations, kept in l_row / u_col temporarily.
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
            let (i, j) = (self.list_a[r as usize] as usize, self.list_b[c as usize] as usize);
            self.entry_slot.push(slot_index.get(i, j));
        }
        self.diag_slot.clear();
        for k in 0..n {
            self.diag_slot.push(slot_index.get(k, k));
        }
        self.inv_diag.clear();
        self.inv_diag.resize(n, 0.0);
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
        self.steps.clear();
        for k in 0..n {
            self.steps.push(Step {
                diag: self.diag_slot[k],
                l0: self.l_ptr[k],
                l1: self.l_ptr[k + 1],
                u0: self.u_ptr[k],
                u1: self.u_ptr[k + 1],
            });
        }
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
        self.ready = true;
    }

    /// Replays the elimination on new values of A (pattern order). The
    /// caller has checked the length of `values`.
    ///
    /// The threshold test |u_kk| ≥ θ |a_ik| is checked as |l_ik| ≤ 1/θ on the
    /// multipliers, and the singularity test on the smallest pivot, both once
    /// at the end: a failed replay is thrown away anyway.
    pub(crate) fn refactor(&mut self, values: &[f64], singular_tolerance: f64) -> Result<(), Replay> {
        let (scale, finite) = scale_and_finite(values);
        let lu = &mut self.values[..];
        for &s in &self.fill {
            lu[s as usize] = 0.0;
        }
        for (&slot, &v) in self.entry_slot.iter().zip(values) {
            lu[slot as usize] = v;
        }
        let (mut min_pivot, mut max_multiplier) = (f64::INFINITY, 0.0_f64);
        let mut update = self.update.iter();
        for (step, inv_diag) in self.steps.iter().zip(self.inv_diag.iter_mut()) {
            let pivot = lu[step.diag as usize];
            if pivot.abs() < min_pivot {
                min_pivot = pivot.abs();
            }
            let inv = 1.0 / pivot;
            *inv_diag = inv;
            let u_slots = &self.u_slot[step.u0 as usize..step.u1 as usize];
            for &ls in &self.l_slot[step.l0 as usize..step.l1 as usize] {
                let l = lu[ls as usize] * inv;
                lu[ls as usize] = l;
                if l.abs() > max_multiplier {
                    max_multiplier = l.abs();
                }
                for (&us, &dst) in u_slots.iter().zip(update.by_ref()) {
                    lu[dst as usize] -= l * lu[us as usize];
                }
            }
        }
        // With finite inputs, a zero pivot makes `min_pivot` 0 before any ∞
        // or NaN can spread; an overflow shows in the multipliers.
        let stable = max_multiplier <= 1.0 / PIVOT_THRESHOLD && finite;
        if stable && min_pivot > singular_tolerance * scale {
            Ok(())
        } else {
            Err(Replay::Repivot)
        }
    }

    /// Overwrites b with A⁻¹ b using the last successful replay. The caller
    /// has checked the length.
    pub(crate) fn solve(&mut self, b: &mut [f64]) {
        let y = &mut self.work[..];
        let lu = &self.values[..];
        for (yk, &r) in y.iter_mut().zip(&self.row_order) {
            *yk = b[r as usize];
        }
        for (k, step) in self.steps.iter().enumerate() {
            let yk = y[k];
            let (l0, l1) = (step.l0 as usize, step.l1 as usize);
            for (&i, &s) in self.l_row[l0..l1].iter().zip(&self.l_slot[l0..l1]) {
                y[i as usize] -= lu[s as usize] * yk;
            }
        }
        for (k, (step, &inv)) in self.steps.iter().zip(&self.inv_diag).enumerate().rev() {
            let (u0, u1) = (step.u0 as usize, step.u1 as usize);
            let mut s = y[k];
            for (&j, &us) in self.u_col[u0..u1].iter().zip(&self.u_slot[u0..u1]) {
                s -= lu[us as usize] * y[j as usize];
            }
            y[k] = s * inv;
        }
        for (&yk, &c) in y.iter().zip(&self.col_order) {
            b[c as usize] = yk;
        }
    }
}

/// max |v| over `values`, and whether all are finite; four independent
/// lanes so that the comparisons do not form one long dependency chain.
#[inline]
pub(crate) fn scale_and_finite(values: &[f64]) -> (f64, bool) {
    let mut lanes = [0.0_f64; 4];
    let mut finite = true;
    let chunks = values.chunks_exact(4);
    let rest = chunks.remainder();
    for c in chunks {
        for (m, &v) in lanes.iter_mut().zip(c) {
            let a = v.abs();
            finite &= a <= f64::MAX;
            *m = if a > *m { a } else { *m };
        }
    }
    for (m, &v) in lanes.iter_mut().zip(rest) {
        let a = v.abs();
        finite &= a <= f64::MAX;
        *m = if a > *m { a } else { *m };
    }
    let scale = lanes.iter().fold(0.0_f64, |m, &a| if a > m { a } else { m });
    (scale, finite)
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
