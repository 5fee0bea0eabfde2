//! HHT's Newton matrix on a fixed sparse pattern, assembled straight from
//! the values a [`ForwardSystem`] gives in the order of its
//! [`ForwardStructure`] (no n × n buffer touched per iteration):
//!
//! ```text
//! [ M + (1+α)[(∂(Φ_qᵀλ)/∂q − ∂Q_A/∂q) β h² − ∂Q_A/∂q̇ γ h]   (1+α) Φ_qᵀ ]
//! [ Φ_q                                                      0          ]
//! ```
//!
//! The pattern is the n × n block's distinct positions (sorted, the
//! diagonal among them), then for each entry of Φ_q its own position and
//! its transpose's; each value list of the block has a precomputed map to
//! its block entry. Sums are formed in the order the dense assembly forms
//! them, so the two paths build the same matrix to the last bit.

use super::saddle::REGULARIZATION;
use super::{DenseScratch, ForwardStructure, ForwardSystem};
use crate::linalg::SparseLu;

/// The dense scratch buffers of the default `*_values` methods (untouched
/// by a system that writes its values itself).
pub(super) struct Scratch<'a> {
    /// n × n, for ∂Q_A/∂q.
    pub applied_q: &'a mut [f64],
    /// n × n, for ∂Q_A/∂q̇.
    pub applied_qd: &'a mut [f64],
    /// n × n, for ∂(Φ_qᵀλ)/∂q.
    pub hessian: &'a mut [f64],
}

/// Newton's matrix on its sparse pattern, its values and its factors.
#[derive(Debug)]
pub(super) struct SparseKkt {
    n: usize,
    m: usize,
    /// The runtime's sparse LU on `pattern`.
    pub lu: SparseLu,
    /// (row, column) of each entry of `values`.
    pattern: Vec<(u32, u32)>,
    /// Newton's matrix in pattern order.
    pub values: Vec<f64>,
    /// Number of block entries (the first of `values`).
    blocks: usize,
    /// The block entry of (i, i), per coordinate.
    diagonal: Vec<u32>,
    /// The system's lists of positions.
    structure: ForwardStructure,
    /// The block entry of each value of ∂Q_A/∂q, ∂Q_A/∂q̇, ∂(Φ_qᵀλ)/∂q.
    to_block: [Vec<u32>; 3],
    /// Φ_q's values by (row, column): products with Φ_qᵀ add in the
    /// dense loop's order.
    jacobian_order: Vec<u32>,
    /// Φ_q's values (structure order), at the last evaluation.
    pub jacobian: Vec<f64>,
    /// The block matrices' values (structure order): ∂Q_A/∂q, ∂Q_A/∂q̇,
    /// ∂(Φ_qᵀλ)/∂q.
    block_values: [Vec<f64>; 3],
    /// Their sums per block entry.
    sums: [Vec<f64>; 3],
    /// The M the regularization last saw, and 1 / |Mⱼⱼ| of it (0 where
    /// Mⱼⱼ is 0).
    mass_seen: Vec<f64>,
    inverse_mass: Vec<f64>,
}

/// The names of the three block matrices, in `block_values`' order.
const BLOCK_NAMES: [&str; 3] = ["∂Q_A/∂q", "∂Q_A/∂q̇", "∂(Φ_qᵀλ)/∂q"];

impl SparseKkt {
    /// The pattern of `structure` for n coordinates and m rows, analyzed
    /// (allocates; once), or `None` when the structure does not fit n and
    /// m, repeats a position of Φ_q, or the pattern cannot be analyzed.
    pub fn new(structure: ForwardStructure, n: usize, m: usize) -> Option<SparseKkt> {
        let inside = |&(r, c): &(u32, u32), rows: usize| (r as usize) < rows && (c as usize) < n;
        let lists = [
            &structure.applied_q,
            &structure.applied_qd,
            &structure.hessian,
        ];
        if !structure.jacobian.iter().all(|e| inside(e, m))
            || !lists.iter().all(|l| l.iter().all(|e| inside(e, n)))
        {
            return None;
        }
        let mut jacobian_order: Vec<u32> =
            (0..u32::try_from(structure.jacobian.len()).ok()?).collect();
        jacobian_order.sort_unstable_by_key(|&j| structure.jacobian[j as usize]);
        if jacobian_order
            .windows(2)
            .any(|w| structure.jacobian[w[0] as usize] == structure.jacobian[w[1] as usize])
        {
            return None;
        }
        let n32 = u32::try_from(n).ok()?;
        let mut block: Vec<(u32, u32)> = (0..n32).map(|i| (i, i)).collect();
        for list in lists {
            block.extend_from_slice(list);
        }
        block.sort_unstable();
        block.dedup();
        let find = |e: &(u32, u32)| {
            block
                .binary_search(e)
                .ok()
                .and_then(|b| u32::try_from(b).ok())
        };
        let diagonal = (0..n32)
            .map(|i| find(&(i, i)))
            .collect::<Option<Vec<_>>>()?;
        let to_block = lists.map(|l| l.iter().map(find).collect::<Option<Vec<_>>>());
        let [Some(q), Some(qd), Some(h)] = to_block else {
            return None;
        };
        let blocks = block.len();
        let mut pattern = block;
        for &(r, c) in &structure.jacobian {
            let row = n32.checked_add(r)?;
            pattern.push((row, c));
            pattern.push((c, row));
        }
        // The regularization's diagonal of the lower block (saddle.rs):
        // tiny values that never pivot, so the fill-reducing ordering is
        // the one of the pattern without them (with them, COLAMD orders
        // for a fill the elimination does not have: a third more work per
        // solve on the chain N = 10).
        let structural = pattern.len();
        for r in 0..u32::try_from(m).ok()? {
            let row = n32.checked_add(r)?;
            pattern.push((row, row));
        }
        let lu = SparseLu::analyze_ordered_by(n + m, &pattern, &pattern[..structural]).ok()?;
        Some(SparseKkt {
            n,
            m,
            lu,
            values: vec![0.0; pattern.len()],
            pattern,
            blocks,
            diagonal,
            jacobian_order,
            jacobian: vec![0.0; structure.jacobian.len()],
            block_values: lists.map(|l| vec![0.0; l.len()]),
            sums: [(); 3].map(|()| vec![0.0; blocks]),
            to_block: [q, qd, h],
            structure,
            mass_seen: Vec::with_capacity(n),
            inverse_mass: vec![0.0; n],
        })
    }

    /// Φ_q's values at (q, t) into `jacobian`.
    pub fn eval_jacobian<S: ForwardSystem>(
        &mut self,
        system: &mut S,
        q: &[f64],
        t: f64,
        dense: &mut [f64],
    ) {
        let scratch = DenseScratch {
            buffer: dense,
            cols: self.n,
            positions: &self.structure.jacobian,
        };
        system.jacobian_values(q, t, scratch, &mut self.jacobian);
    }

    /// The block matrices' values at (q, q̇, λ, t).
    pub fn eval_block<S: ForwardSystem>(
        &mut self,
        system: &mut S,
        (q, qd, lambda, t): (&[f64], &[f64], &[f64], f64),
        dense: Scratch<'_>,
    ) {
        let n = self.n;
        let s = &self.structure;
        let [aq, aqd, hess] = &mut self.block_values;
        let scratch = |buffer, positions| DenseScratch {
            buffer,
            cols: n,
            positions,
        };
        system.applied_q_values(q, qd, t, scratch(dense.applied_q, &s.applied_q), aq);
        system.applied_qd_values(q, qd, t, scratch(dense.applied_qd, &s.applied_qd), aqd);
        system.constraint_hessian_values(q, lambda, t, scratch(dense.hessian, &s.hessian), hess);
    }

    /// `out[c] += scale Σ_r Φ_q[r, c] λ[r]` from the last Φ_q values.
    pub fn add_transposed_product(&self, lambda: &[f64], scale: f64, out: &mut [f64]) {
        for &j in &self.jacobian_order {
            let j = j as usize;
            let (r, c) = self.structure.jacobian[j];
            if let (Some(o), Some(&l)) = (out.get_mut(c as usize), lambda.get(r as usize)) {
                *o += scale * self.jacobian[j] * l;
            }
        }
    }

    /// Newton's matrix into `values` from M (`mass`), the block values and
    /// Φ_q's: (1 + α), β h², γ h in `weights`.
    pub fn assemble(&mut self, mass: &[f64], (alpha1, bh2, gh): (f64, f64, f64)) {
        for ((sums, values), map) in self
            .sums
            .iter_mut()
            .zip(&self.block_values)
            .zip(&self.to_block)
        {
            sums.fill(0.0);
            for (&v, &b) in values.iter().zip(map) {
                sums[b as usize] += v;
            }
        }
        let [kq, cqd, hess] = &self.sums;
        let (block, rest) = self.values.split_at_mut(self.blocks);
        let (jac, _) = rest.split_at_mut(2 * self.jacobian.len());
        for (((v, &h), &k), &c) in block.iter_mut().zip(hess).zip(kq).zip(cqd) {
            *v = alpha1 * ((h - k) * bh2 - c * gh);
        }
        for (&b, &d) in self.diagonal.iter().zip(mass) {
            block[b as usize] += d;
        }
        for (pair, &v) in jac.chunks_exact_mut(2).zip(&self.jacobian) {
            pair[0] = v;
            pair[1] = alpha1 * v;
        }
    }

    /// The lower block's diagonal −εᵣ, εᵣ = `REGULARIZATION` · `scale` ·
    /// Σⱼ Φ_q[r, j]² / Mⱼⱼ from the last Φ_q values (as the dense path's
    /// `saddle::regularization`; a row of zero gradient gets the largest
    /// of the others), and, in the same pass over Φ_q, each row's largest
    /// |Φ_q[r, j]| into `row_max` (m; the scale of Φ's roundoff).
    pub fn regularize(&mut self, mass: &[f64], scale: f64, row_max: &mut [f64]) {
        // M is constant for most models: its inverse is taken again only
        // when it changed (n divisions were a tenth of this pass).
        if self.mass_seen.as_slice() != mass {
            self.mass_seen.clear();
            self.mass_seen.extend_from_slice(mass);
            for (i, &w) in self.inverse_mass.iter_mut().zip(mass) {
                *i = if w != 0.0 { 1.0 / w.abs() } else { 0.0 };
            }
        }
        let tail = self.values.len() - self.m;
        let (_, eps) = self.values.split_at_mut(tail);
        eps.fill(0.0);
        row_max.fill(0.0);
        for (&(r, c), &v) in self.structure.jacobian.iter().zip(&self.jacobian) {
            let w = self.inverse_mass.get(c as usize).copied().unwrap_or(0.0);
            if let (Some(e), Some(g)) = (eps.get_mut(r as usize), row_max.get_mut(r as usize)) {
                *e += v * v * w;
                *g = g.max(v.abs());
            }
        }
        let mut largest = 0.0_f64;
        for e in eps.iter_mut() {
            *e *= REGULARIZATION * scale;
            largest = largest.max(*e);
        }
        let floor = if largest > 0.0 {
            largest
        } else {
            REGULARIZATION * scale
        };
        for e in eps.iter_mut() {
            *e = if *e > 0.0 { -*e } else { -floor };
        }
    }

    /// The lower block's −E (the last `m` values, negated E as assembled)
    /// and the factors: what the monitor's inverse iteration needs.
    pub fn regularized_factors(&mut self) -> (&[f64], &mut SparseLu) {
        let tail = self.values.len() - self.m;
        (&self.values[tail..], &mut self.lu)
    }

    /// The assembled matrix written dense ((n + m)², row-major), for the
    /// dense LU that names a singular matrix's unknown.
    pub fn to_dense(&self, out: &mut [f64]) {
        let w = self.n + self.m;
        out.fill(0.0);
        for (&(r, c), &v) in self.pattern.iter().zip(&self.values) {
            if let Some(o) = out.get_mut(r as usize * w + c as usize) {
                *o = v;
            }
        }
    }

    /// The first non-finite value of Φ_q or a block matrix, named with
    /// `name` (row of Φ or coordinate → name), or `None`.
    pub fn first_non_finite(
        &self,
        equation: &dyn Fn(usize) -> String,
        coordinate: &dyn Fn(usize) -> String,
    ) -> Option<String> {
        let first = |v: &[f64]| v.iter().position(|x| !x.is_finite());
        if let Some(j) = first(&self.jacobian) {
            let (r, c) = self.structure.jacobian[j];
            return Some(format!(
                "Φ_q of `{}` by {}",
                equation(r as usize),
                coordinate(c as usize)
            ));
        }
        let lists = [
            &self.structure.applied_q,
            &self.structure.applied_qd,
            &self.structure.hessian,
        ];
        for ((values, positions), name) in self.block_values.iter().zip(lists).zip(BLOCK_NAMES) {
            if let Some(j) = first(values) {
                let (r, c) = positions[j];
                return Some(format!(
                    "{name} at ({}, {})",
                    coordinate(r as usize),
                    coordinate(c as usize)
                ));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_what_does_not_fit() {
        let ok = ForwardStructure {
            jacobian: vec![(0, 0), (0, 1)],
            applied_q: vec![(1, 1)],
            applied_qd: vec![],
            hessian: vec![(0, 0), (0, 0)],
        };
        assert!(SparseKkt::new(ok.clone(), 2, 1).is_some());
        // A row of Φ_q beyond m, a column beyond n, a repeated Φ_q entry.
        for jacobian in [vec![(1, 0)], vec![(0, 2)], vec![(0, 0), (0, 0)]] {
            let s = ForwardStructure {
                jacobian,
                ..ok.clone()
            };
            assert!(SparseKkt::new(s, 2, 1).is_none());
        }
        let s = ForwardStructure {
            applied_qd: vec![(2, 0)],
            ..ok
        };
        assert!(SparseKkt::new(s, 2, 1).is_none());
    }

    /// The assembly against the formula, entry by entry, with repeated
    /// positions adding up.
    #[test]
    fn assembles_the_newton_matrix() {
        let s = ForwardStructure {
            jacobian: vec![(0, 1), (0, 0)],
            applied_q: vec![(0, 1)],
            applied_qd: vec![(1, 1)],
            hessian: vec![(0, 0), (1, 0), (0, 0)],
        };
        let mut kkt = SparseKkt::new(s, 2, 1).expect("fits");
        kkt.jacobian.copy_from_slice(&[3.0, 5.0]);
        kkt.block_values[0].copy_from_slice(&[7.0]);
        kkt.block_values[1].copy_from_slice(&[11.0]);
        kkt.block_values[2].copy_from_slice(&[13.0, 17.0, 19.0]);
        let (a1, bh2, gh) = (0.9, 0.5, 0.25);
        kkt.assemble(&[2.0, 4.0], (a1, bh2, gh));
        let mut dense = vec![f64::NAN; 9];
        kkt.to_dense(&mut dense);
        let expected = [
            2.0 + a1 * (13.0 + 19.0) * bh2,
            a1 * (-7.0 * bh2),
            a1 * 5.0,
            a1 * 17.0 * bh2,
            4.0 - a1 * 11.0 * gh,
            a1 * 3.0,
            5.0,
            3.0,
            0.0,
        ];
        for (k, (d, e)) in dense.iter().zip(expected).enumerate() {
            assert!(
                (d - e).abs() <= 1e-15 * e.abs(),
                "entry {k}: {d} against {e}"
            );
        }
        let mut out = [1.0, 1.0];
        kkt.add_transposed_product(&[2.0], 0.5, &mut out);
        assert_eq!(out, [1.0 + 5.0, 1.0 + 3.0]);
    }
}
