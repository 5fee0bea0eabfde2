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
//! code calls through `__private` (`linalg::scale_and_finite` on the
//! run-time inputs, then `linalg::order_accepted`): every input value finite,
//! every pivot |u_kk| > τ · maxᵢⱼ |aᵢⱼ| and every multiplier |l_ik| ≤ 1/θ,
//! where a NaN pivot or multiplier (finite inputs whose products overflow)
//! fails the test. When the static order fails
//! them at some q, the generated type factors with the runtime solver it
//! holds (`DenseLu<N>` or `Auto`), whose partial pivoting also gives the
//! singularity verdict and so the diagnostics.

use std::collections::{BTreeMap, BTreeSet};

use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

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
        let mut by_count: BTreeSet<(usize, usize)> =
            rows.iter().enumerate().map(|(r, m)| (m.len(), r)).collect();

        let mut plan = Plan {
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
        };
        let mut below: Vec<(usize, Cell)> = Vec::new();
        let mut right: Vec<(usize, Cell)> = Vec::new();
        for _ in 0..n {
            let (r, c) = choose(&rows, &cols, &by_count)?;
            let pivot = rows[r].get(&c).copied()?;
            if pivot.val == Val::Const(0.0) {
                return None;
            }
            // Take row r and column c out of the active matrix.
            by_count.remove(&(rows[r].len(), r));
            right.clear();
            right.extend(
                rows[r]
                    .iter()
                    .filter(|&(&j, _)| j != c)
                    .map(|(&j, &cell)| (j, cell)),
            );
            rows[r].clear();
            for &(j, _) in &right {
                cols[j].remove(&r);
            }
            below.clear();
            for &i in cols[c].iter().filter(|&&i| i != r) {
                if let Some(cell) = rows[i].remove(&c) {
                    by_count.remove(&(rows[i].len() + 1, i));
                    by_count.insert((rows[i].len(), i));
                    below.push((i, cell));
                }
            }
            cols[c].clear();

            let k = plan.pivots.len();
            plan.row_order.push(r);
            plan.col_order.push(c);
            plan.pivots.push(pivot.val);
            let inv = plan.recip(pivot.val);
            plan.inv.push(inv);
            let inv_num = 1.0 / pivot.num;
            for &(j, cell) in &right {
                plan.upper.push((k, j, cell.val));
            }
            for &(i, cell) in &below {
                let l = plan.mul(cell.val, inv);
                if let Val::Const(v) = l
                    && v.abs() > 1.0 / RUNTIME_THRESHOLD
                {
                    return None;
                }
                let l_num = cell.num * inv_num;
                plan.lower.push((i, k, l));
                for &(j, u) in &right {
                    let old = rows[i].get(&j).copied();
                    let old_val = old.map_or(Val::Const(0.0), |o| o.val);
                    let val = plan.update(old_val, l, u.val);
                    let num = old.map_or(0.0, |o| o.num) - l_num * u.num;
                    let num = if num.is_finite() { num } else { 0.0 };
                    if old.is_none() {
                        by_count.remove(&(rows[i].len(), i));
                        by_count.insert((rows[i].len() + 1, i));
                        cols[j].insert(i);
                    }
                    rows[i].insert(j, Cell { num, val });
                }
                if plan.vars.len() > MAX_OPERATIONS {
                    return None;
                }
            }
        }
        // L's rows and U's columns as elimination positions.
        let mut row_pos = vec![0usize; n];
        for (k, &r) in plan.row_order.iter().enumerate() {
            row_pos[r] = k;
        }
        let mut col_pos = vec![0usize; n];
        for (k, &c) in plan.col_order.iter().enumerate() {
            col_pos[c] = k;
        }
        for e in &mut plan.lower {
            e.0 = row_pos[e.0];
        }
        for e in &mut plan.upper {
            e.1 = col_pos[e.1];
        }
        Some(plan)
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

/// Names for the emitted code.
pub(crate) struct Names<'a> {
    /// The runtime path (`::kinema::__private`).
    pub rt: &'a syn::Path,
    /// The generated type.
    pub ty: &'a proc_macro2::Ident,
    /// The system type it serves.
    pub system: &'a proc_macro2::Ident,
    /// The fallback solver type.
    pub fallback: TokenStream,
}

/// `x` as a literal (finite by construction), negative ones parenthesized.
/// Whether the permutation (images of 0..n) is odd.
fn permutation_odd(perm: &[usize]) -> bool {
    let mut p = perm.to_vec();
    let mut odd = false;
    for i in 0..p.len() {
        while p[i] != i && p[i] < p.len() && p[p[i]] != p[i] {
            let j = p[i];
            p.swap(i, j);
            odd = !odd;
        }
    }
    odd
}

fn lit(x: f64) -> TokenStream {
    if !x.is_finite() {
        // A folded constant that overflowed (`pow(8, 7)` squared into a
        // length): spelled as the runtime's value, since a literal cannot be.
        let t = crate::emit::number(x).tokens;
        return quote!((#t));
    }
    let l = Literal::f64_unsuffixed(x.abs());
    if x < 0.0 { quote!((-#l)) } else { quote!(#l) }
}

impl Plan {
    /// The generated type and its `LinearSolver` impl.
    pub(crate) fn emit(&self, names: &Names<'_>) -> TokenStream {
        let Names {
            rt,
            ty,
            system,
            fallback,
        } = names;
        let n = self.n;
        let n_lit = Literal::usize_unsuffixed(n);
        let nnz_lit = Literal::usize_unsuffixed(self.nnz);
        let stored = self.stored();
        let nf = stored.len();
        let nf_lit = Literal::usize_unsuffixed(nf.max(1));
        let large = self.operations() > MAX_LETS;

        // How the factorization reads var x.
        let var = |x: u32| -> TokenStream {
            match &self.vars[x as usize] {
                Def::Input(k) => {
                    let k = Literal::usize_unsuffixed(*k);
                    quote!(a[#k])
                }
                _ if large => {
                    let x = Literal::usize_unsuffixed(x as usize);
                    quote!(w[#x])
                }
                _ => {
                    let id = format_ident!("f{}", x);
                    quote!(#id)
                }
            }
        };
        let mut body = TokenStream::new();
        for (x, def) in self.vars.iter().enumerate() {
            let value = match def {
                Def::Input(_) => continue,
                Def::Neg(a) => {
                    let a = var(*a);
                    quote!(-#a)
                }
                Def::Scale(k, a) => {
                    let (k, a) = (lit(*k), var(*a));
                    quote!(#k * #a)
                }
                Def::Mul(a, b) => {
                    let (a, b) = (var(*a), var(*b));
                    quote!(#a * #b)
                }
                Def::Recip(a) => {
                    let a = var(*a);
                    quote!(1.0 / #a)
                }
                Def::Sub(old, p) => {
                    // old − p as `old ∓ |k|·v`, or −p when old is 0.
                    let (negative, p) = match *p {
                        Product::Const(k) => (k < 0.0, lit(k.abs())),
                        Product::Scaled(k, v) if k.abs() == 1.0 => (k < 0.0, var(v)),
                        Product::Scaled(k, v) => {
                            let (k_abs, v) = (lit(k.abs()), var(v));
                            (k < 0.0, quote!(#k_abs * #v))
                        }
                        Product::Mul(a, b) => {
                            let (a, b) = (var(a), var(b));
                            (false, quote!(#a * #b))
                        }
                    };
                    match (*old, negative) {
                        (Val::Const(0.0), false) => quote!(-(#p)),
                        (Val::Const(0.0), true) => p,
                        (old, negative) => {
                            let o = match old {
                                Val::Const(c) => lit(c),
                                Val::Var(o) => var(o),
                            };
                            if negative {
                                quote!(#o + #p)
                            } else {
                                quote!(#o - #p)
                            }
                        }
                    }
                }
            };
            let place = var(x as u32);
            body.extend(if large {
                quote!(#place = #value;)
            } else {
                quote!(let #place = #value;)
            });
        }
        let scratch = if large {
            let nv = Literal::usize_unsuffixed(self.vars.len());
            quote!(let mut w = [0.0f64; #nv];)
        } else {
            quote!()
        };

        // Checks over the run-time inputs (a loop over a table of their
        // positions: compact for large systems, unrolled for small ones), four
        // lanes: Σ|a| (finite iff every input is; an overflowing sum only
        // sends a finite matrix to the fallback) and max |a| (the scale; NaNs,
        // caught by the sum, never win a comparison).
        let table = |name: &proc_macro2::Ident, ks: &[usize]| -> TokenStream {
            let len = Literal::usize_unsuffixed(ks.len());
            let ks = ks.iter().map(|&k| Literal::usize_unsuffixed(k));
            quote!(const #name: [usize; #len] = [#(#ks),*];)
        };
        // The runtime's finiteness and scale test (`linalg::scale_and_finite`)
        // over the run-time inputs, gathered into an array (straight-line for
        // small systems, by a loop over a table of positions for large ones).
        let scale_and_finite = quote!(#rt::linalg::scale_and_finite);
        let nm_inputs = Literal::usize_unsuffixed(self.runtime_inputs.len());
        let scale_stmts = if self.runtime_inputs.is_empty() {
            quote! {
                let (input_max, finite) = (0.0f64, true);
            }
        } else if self.runtime_inputs.len() <= MAX_UNROLLED {
            let ks = self
                .runtime_inputs
                .iter()
                .map(|&k| Literal::usize_unsuffixed(k));
            quote! {
                let inputs: [f64; #nm_inputs] = [#(a[#ks]),*];
                let (input_max, finite) = #scale_and_finite(&inputs);
            }
        } else {
            let t = table(&format_ident!("INPUTS"), &self.runtime_inputs);
            quote! {
                #t
                let mut inputs = [0.0f64; #nm_inputs];
                for (x, &k) in inputs.iter_mut().zip(&INPUTS) {
                    if let Some(&v) = a.get(k) {
                        *x = v;
                    }
                }
                let (input_max, finite) = #scale_and_finite(&inputs);
            }
        };
        let constant_pivot_min = self
            .pivots
            .iter()
            .filter_map(|p| match p {
                Val::Const(v) => Some(v.abs()),
                Val::Var(_) => None,
            })
            .fold(f64::INFINITY, f64::min);
        // sign(P) sign(Q) ∏ sign(constant pivots): the part of det A's sign
        // known at generation time.
        let static_negative = {
            let mut negative = permutation_odd(&self.row_order) != permutation_odd(&self.col_order);
            for p in &self.pivots {
                if let Val::Const(v) = *p
                    && v < 0.0
                {
                    negative = !negative;
                }
            }
            negative
        };
        let mut pivot_stmts = TokenStream::new();
        for p in &self.pivots {
            if let Val::Var(x) = *p {
                let v = var(x);
                // Not `f64::min`, which drops a NaN: a NaN pivot becomes the
                // minimum and fails the test below.
                pivot_stmts.extend(quote! {{
                    let x = #v.abs();
                    if !(x >= min_pivot) {
                        min_pivot = x;
                    }
                    negative ^= #v < 0.0;
                }});
            }
        }
        // Multipliers as |bits| maxima (a NaN exceeds any bound). Those that
        // are inputs as they are (unit pivots) are bounded by the inputs'
        // maximum when they are all of them.
        let mut identity = BTreeSet::new();
        let mut computed = BTreeSet::new();
        for &(_, _, l) in &self.lower {
            if let Val::Var(x) = l {
                match self.vars[x as usize] {
                    Def::Input(k) => identity.insert(k),
                    _ => computed.insert(x),
                };
            }
        }
        let all_inputs = identity.len() == self.runtime_inputs.len();
        // The constant multipliers, folded in: checked at run time too, so
        // the runtime's rule (not generation's copy of θ) has the last word.
        let constant_multiplier = self
            .lower
            .iter()
            .filter_map(|&(_, _, l)| match l {
                Val::Const(v) => Some(v.abs()),
                Val::Var(_) => None,
            })
            .fold(0.0f64, f64::max);
        let seed = lit(constant_multiplier);
        let mut multiplier_stmts = if all_inputs && !identity.is_empty() {
            quote!(let mut max_multiplier = input_max.max(#seed);)
        } else {
            quote!(let mut max_multiplier: f64 = #seed;)
        };
        if !all_inputs && !identity.is_empty() && identity.len() <= MAX_UNROLLED {
            for &k in &identity {
                let k = Literal::usize_unsuffixed(k);
                multiplier_stmts.extend(quote! {{
                    let x = a[#k].abs();
                    if x > max_multiplier {
                        max_multiplier = x;
                    }
                }});
            }
        } else if !all_inputs && !identity.is_empty() {
            let ks: Vec<usize> = identity.iter().copied().collect();
            let t = table(&format_ident!("MULTIPLIERS"), &ks);
            multiplier_stmts.extend(quote! {
                #t
                for &k in &MULTIPLIERS {
                    if let Some(x) = a.get(k) {
                        let x = x.abs();
                        if x > max_multiplier {
                            max_multiplier = x;
                        }
                    }
                }
            });
        }
        for &x in &computed {
            let v = var(x);
            multiplier_stmts.extend(quote! {{
                let x = #v.abs();
                if !(x <= max_multiplier) {
                    max_multiplier = x;
                }
            }});
        }
        let multiplier_stmts = if (all_inputs || identity.is_empty()) && computed.is_empty() {
            if all_inputs && !identity.is_empty() {
                quote!(let max_multiplier = input_max.max(#seed);)
            } else {
                quote!(let max_multiplier: f64 = #seed;)
            }
        } else {
            multiplier_stmts
        };
        let constant_scale = lit(self.constant_scale);
        let min_pivot0 = if constant_pivot_min.is_finite() {
            lit(constant_pivot_min)
        } else {
            quote!(f64::INFINITY)
        };
        let pivot_decl = if pivot_stmts.is_empty() {
            quote!(let min_pivot: f64 = #min_pivot0; let negative = #static_negative;)
        } else {
            quote!(let mut min_pivot: f64 = #min_pivot0; let mut negative = #static_negative;)
        };

        // Stored inputs (the first slots) by a loop over their positions, the
        // computed values one by one.
        let stored_inputs: Vec<usize> = stored
            .keys()
            .filter_map(|&x| match self.vars[x as usize] {
                Def::Input(k) => Some(k),
                _ => None,
            })
            .collect();
        let mut store = TokenStream::new();
        if stored_inputs.len() > MAX_UNROLLED {
            let mut by_slot: Vec<(usize, usize)> = stored
                .iter()
                .filter_map(|(&x, &slot)| match self.vars[x as usize] {
                    Def::Input(k) => Some((slot, k)),
                    _ => None,
                })
                .collect();
            by_slot.sort_unstable();
            let ks: Vec<usize> = by_slot.iter().map(|&(_, k)| k).collect();
            let t = table(&format_ident!("STORED"), &ks);
            store.extend(quote! {
                #t
                for (d, &k) in f.iter_mut().zip(&STORED) {
                    if let Some(&x) = a.get(k) {
                        *d = x;
                    }
                }
            });
        }
        for (&x, &slot) in &stored {
            if stored_inputs.len() > MAX_UNROLLED && matches!(self.vars[x as usize], Def::Input(_))
            {
                continue;
            }
            let v = var(x);
            let slot = Literal::usize_unsuffixed(slot);
            store.extend(quote!(f[#slot] = #v;));
        }

        // Memo: the run-time inputs of the last accepted factorization.
        let nm = self.runtime_inputs.len();
        let memo = self.operations() >= nm && nm > 0;
        let nm_lit = Literal::usize_unsuffixed(nm);
        let memo_check = if memo {
            let same = self.runtime_inputs.iter().enumerate().map(|(i, &k)| {
                let (i, k) = (Literal::usize_unsuffixed(i), Literal::usize_unsuffixed(k));
                quote!(a[#k].to_bits() == self.memo[#i].to_bits())
            });
            quote! {
                if self.memo_valid
                    && singular_tolerance.to_bits() == self.memo_tolerance.to_bits()
                    && #(#same)&&*
                {
                    return Ok(());
                }
            }
        } else {
            quote!()
        };
        let memo_store = if memo {
            let st = self.runtime_inputs.iter().enumerate().map(|(i, &k)| {
                let (i, k) = (Literal::usize_unsuffixed(i), Literal::usize_unsuffixed(k));
                quote!(self.memo[#i] = a[#k];)
            });
            quote! {
                #(#st)*
                self.memo_tolerance = singular_tolerance;
                self.memo_valid = true;
            }
        } else {
            quote!()
        };

        let (memo_fields, memo_init, memo_invalidate) = if memo {
            (
                quote! {
                    /// Run-time inputs of the last accepted factorization, and its τ.
                    memo: [f64; #nm_lit],
                    memo_tolerance: f64,
                    memo_valid: bool,
                },
                quote! {
                    memo: [0.0; #nm_lit],
                    memo_tolerance: 0.0,
                    memo_valid: false,
                },
                quote!(self.memo_valid = false;),
            )
        } else {
            (quote!(), quote!(), quote!())
        };
        let solve = self.emit_solve(&stored);
        let doc = format!(
            " The LU of [`{system}`]'s Jacobian, generated for its pattern: a pivot order \
             chosen at generation time, {} floating-point operations per factorization, \
             straight-line solves; the runtime's `{}` takes over when that order does not \
             suit the matrix (see the `LinearSolver` trait for the contract). The \
             Jacobian's constant entries are folded in and never read from `values`: \
             this type factors that Jacobian, not any matrix of its pattern.",
            self.operations(),
            fallback
                .to_string()
                .replace(' ', "")
                .rsplit("::")
                .next()
                .unwrap_or_default()
        );
        quote! {
            #[doc = #doc]
            #[derive(Debug)]
            pub struct #ty {
                /// Run-time values of L, U and 1/u_kk read by the solves.
                f: [f64; #nf_lit],
                #memo_fields
                /// False when analysed for another pattern: the fallback does everything.
                fits: bool,
                /// Which factorization the solves use: `NONE`, `STATIC` or `FALLBACK`.
                active: u8,
                /// Factorizations done by the fallback.
                fallbacks: u64,
                /// minₖ |u_kk| / maxᵢⱼ |aᵢⱼ| and the sign of det A, of the last static factorization.
                report: #rt::PivotReport,
                fallback: #fallback,
            }

            #[allow(
                clippy::approx_constant,
                clippy::excessive_precision,
                clippy::unreadable_literal,
                unused_parens
            )]
            impl #rt::LinearSolver for #ty {
                fn analyze(n: usize, pattern: &[(u32, u32)]) -> ::core::result::Result<Self, #rt::LinalgError> {
                    let fallback = <#fallback as #rt::LinearSolver>::analyze(n, pattern)?;
                    Ok(Self {
                        f: [0.0; #nf_lit],
                        #memo_init
                        fits: n == #n_lit && pattern == &<#system>::JACOBIAN_PATTERN[..],
                        active: Self::NONE,
                        fallbacks: 0,
                        report: #rt::PivotReport { ratio: 0.0, det_sign: 1.0 },
                        fallback,
                    })
                }

                fn dim(&self) -> usize {
                    #n_lit
                }

                fn factor(&mut self, values: &[f64], singular_tolerance: f64) -> ::core::result::Result<(), #rt::LinalgError> {
                    let a = match <&[f64; #nnz_lit]>::try_from(values) {
                        Ok(a) if self.fits => a,
                        _ => return self.factor_fallback(values, singular_tolerance),
                    };
                    #memo_check
                    #scale_stmts
                    let scale = input_max.max(#constant_scale);
                    #scratch
                    #body
                    #pivot_decl
                    #pivot_stmts
                    #multiplier_stmts
                    let accept = #rt::linalg::order_accepted(finite, max_multiplier, min_pivot, singular_tolerance, scale);
                    if !accept {
                        return self.factor_fallback(values, singular_tolerance);
                    }
                    let f = &mut self.f;
                    #store
                    #memo_store
                    self.report = #rt::PivotReport {
                        ratio: if scale > 0.0 { min_pivot / scale } else { 0.0 },
                        det_sign: if negative { -1.0 } else { 1.0 },
                    };
                    self.active = Self::STATIC;
                    Ok(())
                }

                fn solve_in_place(&mut self, rhs: &mut [f64]) -> ::core::result::Result<(), #rt::LinalgError> {
                    match self.active {
                        Self::STATIC => {}
                        Self::FALLBACK => return #rt::LinearSolver::solve_in_place(&mut self.fallback, rhs),
                        _ => return Err(#rt::LinalgError::NotFactored),
                    }
                    let found = rhs.len();
                    let Ok(b) = <&mut [f64; #n_lit]>::try_from(rhs) else {
                        return Err(#rt::LinalgError::Dimension { what: "right-hand side", expected: #n_lit, found });
                    };
                    let f = &self.f;
                    #solve
                    Ok(())
                }

                fn pivot_report(&self) -> ::core::option::Option<#rt::PivotReport> {
                    match self.active {
                        Self::STATIC => ::core::option::Option::Some(self.report),
                        Self::FALLBACK => #rt::LinearSolver::pivot_report(&self.fallback),
                        _ => ::core::option::Option::None,
                    }
                }
            }

            // Only for the system whose constants are folded in (and borrows of it).
            impl #rt::LinearSolverFor<#system> for #ty {}
            impl #rt::LinearSolverFor<&#system> for #ty {}
            impl #rt::LinearSolverFor<&mut #system> for #ty {}

            impl #ty {
                const NONE: u8 = 0;
                const STATIC: u8 = 1;
                const FALLBACK: u8 = 2;

                /// How many factorizations the runtime's solver did because the
                /// generated pivot order did not suit the matrix (or it failed).
                #[must_use]
                pub fn fallback_count(&self) -> u64 {
                    self.fallbacks
                }

                /// Factors with the runtime's solver (pivot order of its own).
                #[cold]
                fn factor_fallback(&mut self, values: &[f64], singular_tolerance: f64) -> ::core::result::Result<(), #rt::LinalgError> {
                    self.active = Self::NONE;
                    #memo_invalidate
                    self.fallbacks += 1;
                    #rt::LinearSolver::factor(&mut self.fallback, values, singular_tolerance)?;
                    self.active = Self::FALLBACK;
                    Ok(())
                }
            }
        }
    }

    /// Forward then backward substitution on `b` (a `[f64; n]`), reading
    /// stored run-time values from `f`.
    fn emit_solve(&self, stored: &BTreeMap<u32, usize>) -> TokenStream {
        let n = self.n;
        let large = n > MAX_LETS / 2;
        let read = |v: Val| -> Result<TokenStream, f64> {
            match v {
                Val::Const(c) => Err(c),
                Val::Var(x) => {
                    let slot = Literal::usize_unsuffixed(stored.get(&x).copied().unwrap_or(0));
                    Ok(quote!(f[#slot]))
                }
            }
        };
        let y = |k: usize| -> TokenStream {
            if large {
                let k = Literal::usize_unsuffixed(k);
                quote!(y[#k])
            } else {
                let id = format_ident!("y{}", k);
                quote!(#id)
            }
        };
        // Terms −Σ c·x: `- c * x`, with ±1 folded.
        let minus_terms = |terms: &[(Val, TokenStream)]| -> TokenStream {
            let mut out = TokenStream::new();
            for (c, x) in terms {
                out.extend(match read(*c) {
                    Ok(v) => quote!(- #v * #x),
                    Err(1.0) => quote!(- #x),
                    Err(-1.0) => quote!(+ #x),
                    Err(0.0) => quote!(),
                    Err(k) if k < 0.0 => {
                        let k = lit(-k);
                        quote!(+ #k * #x)
                    }
                    Err(k) => {
                        let k = lit(k);
                        quote!(- #k * #x)
                    }
                });
            }
            out
        };
        let mut l_rows: Vec<Vec<(Val, usize)>> = vec![Vec::new(); n];
        for &(i, k, l) in &self.lower {
            l_rows[i].push((l, k));
        }
        let mut u_rows: Vec<Vec<(Val, usize)>> = vec![Vec::new(); n];
        for &(k, j, u) in &self.upper {
            u_rows[k].push((u, j));
        }
        let mut out = TokenStream::new();
        if large {
            let n_lit = Literal::usize_unsuffixed(n);
            out.extend(quote!(let mut y = [0.0f64; #n_lit];));
        }
        // Forward: y_i = b[p_i] − Σ_k l_ik y_k.
        for (i, (l_row, &r)) in l_rows.iter().zip(&self.row_order).enumerate() {
            let r = Literal::usize_unsuffixed(r);
            let terms: Vec<(Val, TokenStream)> = l_row.iter().map(|&(l, k)| (l, y(k))).collect();
            let rest = minus_terms(&terms);
            let place = y(i);
            out.extend(if large {
                quote!(#place = b[#r] #rest;)
            } else {
                quote!(let #place = b[#r] #rest;)
            });
        }
        // Backward: x_k = (y_k − Σ_j u_kj x_j) / u_kk, into y_k.
        for k in (0..n).rev() {
            let terms: Vec<(Val, TokenStream)> =
                u_rows[k].iter().map(|&(u, j)| (u, y(j))).collect();
            let rest = minus_terms(&terms);
            let yk = y(k);
            let sum = if terms.is_empty() {
                quote!(#yk)
            } else {
                quote!((#yk #rest))
            };
            let value = match read(self.inv[k]) {
                Ok(v) => quote!(#sum * #v),
                Err(1.0) => sum,
                Err(-1.0) => quote!(-#sum),
                Err(c) => {
                    let c = lit(c);
                    quote!(#sum * #c)
                }
            };
            if large {
                out.extend(quote!(#yk = #value;));
            } else if terms.is_empty() && matches!(self.inv[k], Val::Const(c) if c == 1.0) {
                // y_k is already x_k.
            } else {
                out.extend(quote!(let #yk = #value;));
            }
        }
        for k in 0..n {
            let c = Literal::usize_unsuffixed(self.col_order[k]);
            let yk = y(k);
            out.extend(quote!(b[#c] = #yk;));
        }
        out
    }
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
