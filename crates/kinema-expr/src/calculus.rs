//! Differentiation: partial derivatives, sparse Jacobians and directional
//! (tangent) derivatives, all memoized and iterative.
//!
//! One rule set serves everything: the *directional derivative* of `e` along
//! seeds `{sᵢ → ṡᵢ}` is `Σᵢ ∂e/∂sᵢ · ṡᵢ`, computed in one forward pass over the
//! DAG (forward-mode differentiation on expressions). A partial derivative is
//! the directional derivative along a single seed `s → 1`. The total time
//! derivative along velocities is the directional derivative with seeds
//! `qᵢ → q̇ᵢ, t → 1`; applying it to `Φ_q q̇` gives `(Φ_q q̇)_q q̇` without ever
//! forming a Hessian.

use rustc_hash::{FxHashMap, FxHashSet};

use crate::arena::Arena;
use crate::node::{ExprId, Factor, NodeRef, SymId, Term, UnaryOp};

kinema_index::entity! {
    /// Identifier of a registered set of seeds (see [`Arena::seeds`]).
    pub struct SeedsId; "seeds"
}

#[derive(Clone, Debug)]
struct SeedSet {
    /// Sorted by symbol, no zero tangents.
    pairs: Vec<(SymId, ExprId)>,
    /// Union of the symbols' bloom bits: a node whose mask misses it has tangent 0.
    mask: u64,
}

/// Memo tables of the calculus, owned by the arena.
#[derive(Clone, Default, Debug)]
pub(crate) struct Memo {
    seeds: Vec<SeedSet>,
    seed_lookup: FxHashMap<Vec<(SymId, ExprId)>, SeedsId>,
    tangent: FxHashMap<(ExprId, SeedsId), ExprId>,
    /// For a long product `c·Π fⱼ^pⱼ`, the products `Π_{j≠i} fⱼ^pⱼ` of all
    /// factors but one, built from shared prefix and suffix products.
    cofactors: FxHashMap<ExprId, Vec<ExprId>>,
    /// Limit on [`Arena::size`] for the calculus (see [`Arena::set_budget`]).
    budget: Option<usize>,
    /// Set when a derivative stopped at the budget.
    exhausted: bool,
}

/// The columns of a Jacobian (the symbols differentiated by), indexed once;
/// see [`Arena::jacobian_by`].
#[derive(Clone, Debug, Default)]
pub struct Columns {
    col_of: FxHashMap<SymId, u32>,
    len: usize,
}

impl Columns {
    /// Column j is the derivative by `wrt[j]`.
    #[must_use]
    pub fn new(wrt: &[SymId]) -> Self {
        Columns {
            col_of: wrt
                .iter()
                .enumerate()
                .map(|(j, &s)| (s, j as u32))
                .collect(),
            len: wrt.len(),
        }
    }
}

/// A sparse matrix of expressions: only structural nonzeros are stored.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SparseMatrix {
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
    /// Nonzero entries in row-major order (by row, then column).
    pub entries: Vec<Entry>,
}

/// One structural nonzero of a [`SparseMatrix`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Entry {
    /// Row index.
    pub row: u32,
    /// Column index.
    pub col: u32,
    /// The entry; never the number 0.
    pub expr: ExprId,
}

impl Arena {
    /// Registers seeds for [`directional`](Self::directional): the tangent of
    /// each listed symbol; every other symbol has tangent 0. Registering the
    /// same set twice returns the same id (and shares the memo).
    pub fn seeds(&mut self, pairs: &[(SymId, ExprId)]) -> SeedsId {
        let mut key: Vec<(SymId, ExprId)> = pairs
            .iter()
            .copied()
            .filter(|&(_, t)| !self.is_zero(t))
            .collect();
        key.sort_by_key(|&(s, _)| s);
        key.dedup_by_key(|&mut (s, _)| s);
        if let Some(&id) = self.calc.seed_lookup.get(&key) {
            return id;
        }
        let mask = key
            .iter()
            .fold(0u64, |m, &(s, _)| m | self.mask_of(self.sym_expr(s)));
        let id = SeedsId::new(self.calc.seeds.len());
        self.calc.seeds.push(SeedSet {
            pairs: key.clone(),
            mask,
        });
        self.calc.seed_lookup.insert(key, id);
        id
    }

    /// `∂e/∂s`, memoized per (node, symbol).
    ///
    /// ```
    /// use kinema_expr::Arena;
    /// let mut a = Arena::new();
    /// let x = a.coordinate("x", 0);
    /// let s = a.sin(x);
    /// let e = a.mul(x, s);
    /// let sx = a.symbol_of(x).unwrap();
    /// let d = a.diff(e, sx);
    /// assert_eq!(a.display(d).to_string(), "sin(x) + x*cos(x)");
    /// ```
    pub fn diff(&mut self, e: ExprId, s: SymId) -> ExprId {
        let one = self.one;
        let seeds = self.seeds(&[(s, one)]);
        self.directional(e, seeds)
    }

    /// Limits the size of the arena ([`Arena::size`]) that differentiation
    /// may reach: once a derivative would grow it past `limit`, it stops,
    /// returns 0 and [`budget_exceeded`](Self::budget_exceeded) turns true
    /// (the results are then incomplete and must be discarded). `None`, the
    /// default, sets no limit. Constructors called directly are not limited.
    pub fn set_budget(&mut self, limit: Option<usize>) {
        self.calc.budget = limit;
    }

    /// Whether a derivative stopped at the budget (see
    /// [`set_budget`](Self::set_budget)). Stays true once set.
    #[must_use]
    pub fn budget_exceeded(&self) -> bool {
        self.calc.exhausted
    }

    /// Total number of stored entries (nodes, terms of sums and factors of
    /// products): the measure of the arena's memory the budget limits.
    #[must_use]
    pub fn size(&self) -> usize {
        self.nodes.len() + self.terms.len() + self.factors.len()
    }

    /// The directional derivative `Σ ∂e/∂s · seed(s)` along registered
    /// seeds, memoized per (node, seeds). Iterative: depth is unbounded.
    ///
    /// Its size is linear in the size of `e`: a product of n factors costs
    /// O(n) new entries (shared prefix and suffix products), not O(n²).
    pub fn directional(&mut self, e: ExprId, seeds: SeedsId) -> ExprId {
        if let Some(d) = self.tangent_known(e, seeds) {
            return d;
        }
        if self.calc.exhausted {
            return self.zero;
        }
        let mut stack: Vec<(ExprId, bool)> = vec![(e, false)];
        let mut kids: Vec<ExprId> = Vec::new();
        while let Some((n, expanded)) = stack.pop() {
            if self.tangent_known(n, seeds).is_some() {
                continue;
            }
            if self.calc.budget.is_some_and(|b| self.size() > b) {
                self.calc.exhausted = true;
                return self.zero;
            }
            if expanded {
                let d = self.tangent_rule(n, seeds);
                self.calc.tangent.insert((n, seeds), d);
            } else {
                stack.push((n, true));
                kids.clear();
                self.children(n, &mut kids);
                for &c in &kids {
                    if self.tangent_known(c, seeds).is_none() {
                        stack.push((c, false));
                    }
                }
            }
        }
        self.tangent_known(e, seeds).unwrap_or(self.zero)
    }

    /// The tangent of `n` if it is already known without work.
    #[inline]
    fn tangent_known(&self, n: ExprId, seeds: SeedsId) -> Option<ExprId> {
        // The derivative of an undefined expression (the number NaN: see
        // `Arena::intern`) is undefined.
        if self.is_undefined(n) {
            return Some(n);
        }
        let set = &self.calc.seeds[seeds.index()];
        if self.mask_of(n) & set.mask == 0 {
            return Some(self.zero);
        }
        self.calc.tangent.get(&(n, seeds)).copied()
    }

    /// Tangent of a child during the pass (children are always done first).
    fn tan_of(&self, n: ExprId, seeds: SeedsId) -> ExprId {
        self.tangent_known(n, seeds).unwrap_or(self.zero)
    }

    /// The derivative rule of one node, given its children's tangents.
    fn tangent_rule(&mut self, n: ExprId, seeds: SeedsId) -> ExprId {
        match self.node(n) {
            NodeRef::Num(_) => self.zero,
            NodeRef::Sym(s) => {
                let set = &self.calc.seeds[seeds.index()];
                match set.pairs.binary_search_by_key(&s, |&(k, _)| k) {
                    Ok(i) => set.pairs[i].1,
                    Err(_) => self.zero,
                }
            }
            NodeRef::Add { terms, .. } => {
                let dterms: Vec<Term> = terms
                    .iter()
                    .map(|t| Term {
                        coeff: t.coeff,
                        expr: self.tan_of(t.expr, seeds),
                    })
                    .filter(|t| !self.is_zero(t.expr))
                    .collect();
                self.linear(0.0, &dterms)
            }
            NodeRef::Mul { coeff, factors } if factors.len() > crate::build::FLATTEN_MAX + 1 => {
                // Σᵢ c·pᵢ·ḟᵢ·fᵢ^(pᵢ−1)·Π_{j≠i} fⱼ^pⱼ with the cofactors Π_{j≠i}
                // shared: each term costs O(1) instead of a copy of the product.
                let factors = factors.to_vec();
                let mut parts: Vec<ExprId> = Vec::new();
                for (i, fi) in factors.iter().enumerate() {
                    let dfi = self.tan_of(fi.base, seeds);
                    if self.is_zero(dfi) {
                        continue;
                    }
                    let others = self.cofactor(n, &factors, i);
                    let fs = [
                        Factor {
                            base: others,
                            exp: 1.0,
                        },
                        Factor {
                            base: fi.base,
                            exp: fi.exp - 1.0,
                        },
                        Factor {
                            base: dfi,
                            exp: 1.0,
                        },
                    ];
                    parts.push(self.product_of(coeff * fi.exp, &fs));
                }
                self.sum(&parts)
            }
            NodeRef::Mul { coeff, factors } => {
                let factors = factors.to_vec();
                let mut parts: Vec<ExprId> = Vec::with_capacity(factors.len());
                let mut fs: Vec<Factor> = Vec::with_capacity(factors.len() + 1);
                for (i, fi) in factors.iter().enumerate() {
                    let dfi = self.tan_of(fi.base, seeds);
                    if self.is_zero(dfi) {
                        continue;
                    }
                    // c·pᵢ·ḟᵢ·fᵢ^(pᵢ−1)·Π_{j≠i} fⱼ^pⱼ — no division by fᵢ, so the
                    // result stays defined wherever the product is.
                    fs.clear();
                    fs.extend_from_slice(&factors);
                    fs[i].exp -= 1.0;
                    fs.push(Factor {
                        base: dfi,
                        exp: 1.0,
                    });
                    parts.push(self.product_of(coeff * fi.exp, &fs));
                }
                self.sum(&parts)
            }
            NodeRef::Unary(op, a) => {
                let da = self.tan_of(a, seeds);
                if self.is_zero(da) {
                    return self.zero;
                }
                let g = self.unary_derivative(op, a, n);
                self.mul(g, da)
            }
            NodeRef::Pow(a, b) => {
                // d(a^b) = a^b·(ḃ·ln a + b·ȧ/a)
                let (da, db) = (self.tan_of(a, seeds), self.tan_of(b, seeds));
                let ln_a = self.ln(a);
                let t1 = self.mul(db, ln_a);
                let t2 = self.product_of(
                    1.0,
                    &[
                        Factor { base: b, exp: 1.0 },
                        Factor { base: da, exp: 1.0 },
                        Factor { base: a, exp: -1.0 },
                    ],
                );
                let inner = self.add(t1, t2);
                self.mul(n, inner)
            }
            NodeRef::Atan2(y, x) => {
                // d atan2(y, x) = (x·ẏ − y·ẋ)/(x² + y²)
                let (dy, dx) = (self.tan_of(y, seeds), self.tan_of(x, seeds));
                let a = self.mul(x, dy);
                let b = self.mul(y, dx);
                let num = self.sub(a, b);
                let x2 = self.powi(x, 2);
                let y2 = self.powi(y, 2);
                let den = self.add(x2, y2);
                self.div(num, den)
            }
        }
    }

    /// `Π_{j≠i} fⱼ^pⱼ` for the product `n` with these `factors`: all
    /// cofactors of `n` are built once, from prefix products `Lᵢ = Π_{j<i}`
    /// and suffix products `Rᵢ = Π_{j>i}` (each one factor more than the
    /// last; nested, not copied, beyond [`FLATTEN_MAX`](crate::FLATTEN_MAX)),
    /// so the whole set costs O(n) entries.
    fn cofactor(&mut self, n: ExprId, factors: &[Factor], i: usize) -> ExprId {
        if let Some(c) = self.calc.cofactors.get(&n) {
            return c[i];
        }
        let m = factors.len();
        let one = self.one;
        let mut prefix = Vec::with_capacity(m);
        let mut acc = one;
        for f in factors {
            prefix.push(acc);
            acc = self.product_of(
                1.0,
                &[
                    Factor {
                        base: acc,
                        exp: 1.0,
                    },
                    *f,
                ],
            );
        }
        let mut suffix = vec![one; m];
        let mut acc = one;
        for (j, f) in factors.iter().enumerate().rev() {
            suffix[j] = acc;
            acc = self.product_of(
                1.0,
                &[
                    Factor {
                        base: acc,
                        exp: 1.0,
                    },
                    *f,
                ],
            );
        }
        let all: Vec<ExprId> = prefix
            .iter()
            .zip(&suffix)
            .map(|(&l, &r)| self.mul(l, r))
            .collect();
        let c = all[i];
        self.calc.cofactors.insert(n, all);
        c
    }

    /// `f'(a)` for `f = op`, where `node` is `f(a)` itself (reused by exp, tan, tanh).
    fn unary_derivative(&mut self, op: UnaryOp, a: ExprId, node: ExprId) -> ExprId {
        let one = self.one;
        match op {
            UnaryOp::Sin => self.cos(a),
            UnaryOp::Cos => {
                let s = self.sin(a);
                self.neg(s)
            }
            UnaryOp::Tan => {
                let t2 = self.powi(node, 2);
                self.add(one, t2)
            }
            UnaryOp::Asin | UnaryOp::Acos => {
                let a2 = self.powi(a, 2);
                let r = self.sub(one, a2);
                let d = self.powf(r, -0.5);
                if op == UnaryOp::Asin { d } else { self.neg(d) }
            }
            UnaryOp::Atan => {
                let a2 = self.powi(a, 2);
                let r = self.add(one, a2);
                self.powi(r, -1)
            }
            UnaryOp::Sinh => self.cosh(a),
            UnaryOp::Cosh => self.sinh(a),
            // 1/cosh²(a), not 1 − tanh²(a): tanh(a) is within an ulp of ±1
            // from |a| ≈ 9 on, where the difference would keep only its
            // rounding error (relative error 1e-8 at a = 11; 0 from a ≈ 19
            // on, where the derivative is 2e-16).
            UnaryOp::Tanh => {
                let c = self.cosh(a);
                self.powi(c, -2)
            }
            UnaryOp::Exp => node,
            UnaryOp::Ln => self.powi(a, -1),
            UnaryOp::Abs => {
                // sign(a) = a/|a|, defined exactly where |a| is differentiable.
                self.div(a, node)
            }
            UnaryOp::Smooth(k) if k < 3 => self.unary(UnaryOp::Smooth(k + 1), a),
            UnaryOp::Smooth(_) => self.zero,
        }
    }

    /// The sparse Jacobian `∂rows/∂wrt`: entry (i, j) is `∂rows[i]/∂wrt[j]`,
    /// stored only where it is not structurally zero.
    ///
    /// Each row is differentiated only with respect to the symbols it contains.
    pub fn jacobian(&mut self, rows: &[ExprId], wrt: &[SymId]) -> SparseMatrix {
        self.jacobian_by(rows, &Columns::new(wrt))
    }

    /// [`jacobian`](Self::jacobian) with the columns indexed once, for
    /// callers that differentiate rows one at a time.
    pub fn jacobian_by(&mut self, rows: &[ExprId], columns: &Columns) -> SparseMatrix {
        let col_of = &columns.col_of;
        let mut entries = Vec::new();
        let mut cols: Vec<(u32, SymId)> = Vec::new();
        for (i, &r) in rows.iter().enumerate() {
            cols.clear();
            cols.extend(
                self.free_symbols(r)
                    .into_iter()
                    .filter_map(|s| col_of.get(&s).map(|&j| (j, s))),
            );
            cols.sort_unstable();
            for &(j, s) in &cols {
                let d = self.diff(r, s);
                if self.calc.exhausted {
                    break;
                }
                if !self.is_zero(d) {
                    entries.push(Entry {
                        row: i as u32,
                        col: j,
                        expr: d,
                    });
                }
            }
        }
        SparseMatrix {
            rows: rows.len(),
            cols: columns.len,
            entries,
        }
    }

    /// The symbols `e` depends on, sorted by id.
    #[must_use]
    pub fn free_symbols(&self, e: ExprId) -> Vec<SymId> {
        let mut seen: FxHashSet<ExprId> = FxHashSet::default();
        let mut out = Vec::new();
        let mut stack = vec![e];
        while let Some(n) = stack.pop() {
            if self.mask_of(n) == 0 || !seen.insert(n) {
                continue;
            }
            if let NodeRef::Sym(s) = self.node(n) {
                out.push(s);
            }
            self.for_each_child(n, |c| stack.push(c));
        }
        out.sort_unstable();
        out
    }

    /// Whether `e` depends on the symbol `s`.
    #[must_use]
    pub fn depends_on(&self, e: ExprId, s: SymId) -> bool {
        let target = self.sym_expr(s);
        let bit = self.mask_of(target);
        let mut seen: FxHashSet<ExprId> = FxHashSet::default();
        let mut stack = vec![e];
        while let Some(n) = stack.pop() {
            if self.mask_of(n) & bit == 0 || !seen.insert(n) {
                continue;
            }
            if n == target {
                return true;
            }
            self.for_each_child(n, |c| stack.push(c));
        }
        false
    }
}
