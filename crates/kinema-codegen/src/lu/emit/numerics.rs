//! Numerics → statements: each piece of the generated `factor` (the
//! elimination's arithmetic, the scale, the pivots' and multipliers'
//! checks, the stored values, the memo), in the order it runs.

use std::collections::{BTreeMap, BTreeSet};

use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

use super::super::{Def, MAX_LETS, MAX_UNROLLED, Plan, Product, Val};
use super::{Memo, Stmts, lit, split, table};

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
/// Numerics → statements: each piece of the generated `factor`, in the order
/// it runs.
impl Plan {
    /// Whether the factorization keeps its values in a local array `w`
    /// instead of `let`s: past [`MAX_LETS`] operations, or when it is split
    /// into functions ([`Plan::factor_chunked`]), which hand `w` on.
    pub(super) fn large(&self) -> bool {
        self.operations() > MAX_LETS || self.factor_chunked()
    }

    /// Whether the elimination is split into functions of about
    /// `chunk_ops` operations.
    fn factor_chunked(&self) -> bool {
        self.operations() > self.chunk_ops
    }

    /// How the factorization reads var `x`: an input `a[k]`, a `let` `f{x}`,
    /// or a slot `w[x]` of the work array.
    fn var(&self, x: u32) -> TokenStream {
        match &self.vars[x as usize] {
            Def::Input(k) => {
                let k = Literal::usize_unsuffixed(*k);
                quote!(a[#k])
            }
            _ if self.large() => {
                let x = Literal::usize_unsuffixed(x as usize);
                quote!(w[#x])
            }
            _ => {
                let id = format_ident!("f{}", x);
                quote!(#id)
            }
        }
    }

    /// The expression computing `def`.
    fn def_value(&self, def: &Def) -> TokenStream {
        match *def {
            Def::Input(k) => {
                let k = Literal::usize_unsuffixed(k);
                quote!(a[#k])
            }
            Def::Neg(a) => {
                let a = self.var(a);
                quote!(-#a)
            }
            Def::Scale(k, a) => {
                let (k, a) = (lit(k), self.var(a));
                quote!(#k * #a)
            }
            Def::Mul(a, b) => {
                let (a, b) = (self.var(a), self.var(b));
                quote!(#a * #b)
            }
            Def::Recip(a) => {
                let a = self.var(a);
                quote!(1.0 / #a)
            }
            Def::Sub(old, p) => self.sub_value(old, p),
        }
    }

    /// old − p as `old ∓ |k|·v`, or −p when old is 0.
    fn sub_value(&self, old: Val, p: Product) -> TokenStream {
        let (negative, p) = match p {
            Product::Const(k) => (k < 0.0, lit(k.abs())),
            Product::Scaled(k, v) if k.abs() == 1.0 => (k < 0.0, self.var(v)),
            Product::Scaled(k, v) => {
                let (k_abs, v) = (lit(k.abs()), self.var(v));
                (k < 0.0, quote!(#k_abs * #v))
            }
            Product::Mul(a, b) => {
                let (a, b) = (self.var(a), self.var(b));
                (false, quote!(#a * #b))
            }
        };
        match (old, negative) {
            (Val::Const(0.0), false) => quote!(-(#p)),
            (Val::Const(0.0), true) => p,
            (old, negative) => {
                let o = match old {
                    Val::Const(c) => lit(c),
                    Val::Var(o) => self.var(o),
                };
                if negative {
                    quote!(#o + #p)
                } else {
                    quote!(#o - #p)
                }
            }
        }
    }

    /// The elimination's arithmetic, one statement per computed value,
    /// after the declaration of the work array of large factorizations; in
    /// functions `__kinema_factor_{i}(a, w)` pushed onto `helpers` when
    /// [`Plan::factor_chunked`].
    pub(super) fn emit_elimination(&self, helpers: &mut Vec<TokenStream>) -> TokenStream {
        let large = self.large();
        let nv = Literal::usize_unsuffixed(self.vars.len());
        let mut body = if large {
            quote!(let mut w = [0.0f64; #nv];)
        } else {
            TokenStream::new()
        };
        let mut stmts = Stmts::new();
        for (x, def) in self.vars.iter().enumerate() {
            if matches!(def, Def::Input(_)) {
                continue;
            }
            let value = self.def_value(def);
            let place = self.var(x as u32);
            stmts.push((
                if large {
                    quote!(#place = #value;)
                } else {
                    quote!(let #place = #value;)
                },
                1,
            ));
        }
        let nnz = Literal::usize_unsuffixed(self.nnz);
        body.extend(split(
            "factor",
            stmts,
            self.factor_chunked().then_some(self.chunk_ops),
            (
                &quote!(a: &[f64; #nnz], w: &mut [f64; #nv]),
                &quote!(a, &mut w),
            ),
            helpers,
        ));
        body
    }

    /// `input_max` and `finite` by the runtime's own test over the run-time
    /// inputs: `linalg::scale_and_finite_array` on them gathered by value
    /// for small systems, `linalg::scale_and_finite_at` over a table of their
    /// positions for large ones.
    pub(super) fn emit_scale(&self, rt: &syn::Path) -> TokenStream {
        if self.runtime_inputs.is_empty() {
            quote!(let (input_max, finite) = (0.0f64, true);)
        } else if self.runtime_inputs.len() <= MAX_UNROLLED {
            let ks = self
                .runtime_inputs
                .iter()
                .map(|&k| Literal::usize_unsuffixed(k));
            quote! {
                let (input_max, finite) =
                    #rt::linalg::scale_and_finite_array([#(a[#ks]),*]);
            }
        } else {
            let t = table("INPUTS", &self.runtime_inputs);
            quote! {
                #t
                let (input_max, finite) = #rt::linalg::scale_and_finite_at(a, &INPUTS);
            }
        }
    }

    /// `min_pivot` (min |u_kk|, a NaN pivot winning) and `negative` (the
    /// sign of det A): the part known at generation time — the constant
    /// pivots and sign(P) sign(Q) — folded into the initial values.
    pub(super) fn emit_pivots(&self) -> TokenStream {
        let constant_pivot_min = self
            .pivots
            .iter()
            .filter_map(|p| match p {
                Val::Const(v) => Some(v.abs()),
                Val::Var(_) => None,
            })
            .fold(f64::INFINITY, f64::min);
        let mut negative = permutation_odd(&self.row_order) != permutation_odd(&self.col_order);
        for p in &self.pivots {
            if let Val::Const(v) = *p
                && v < 0.0
            {
                negative = !negative;
            }
        }
        let mut stmts = TokenStream::new();
        for p in &self.pivots {
            if let Val::Var(x) = *p {
                let v = self.var(x);
                // Not `f64::min`, which drops a NaN: a NaN pivot becomes the
                // minimum and fails the acceptance test.
                stmts.extend(quote! {{
                    let x = #v.abs();
                    if !(x >= min_pivot) {
                        min_pivot = x;
                    }
                    negative ^= #v < 0.0;
                }});
            }
        }
        let min_pivot0 = if constant_pivot_min.is_finite() {
            lit(constant_pivot_min)
        } else {
            quote!(f64::INFINITY)
        };
        if stmts.is_empty() {
            quote!(let min_pivot: f64 = #min_pivot0; let negative = #negative;)
        } else {
            quote! {
                let mut min_pivot: f64 = #min_pivot0;
                let mut negative = #negative;
                #stmts
            }
        }
    }

    /// `max_multiplier` as max |l_ik| (a NaN exceeds any bound). The
    /// constant multipliers, folded in, seed it, so the runtime's θ has the
    /// last word on them too. Multipliers that are inputs as they are (unit
    /// pivots) are bounded by the inputs' maximum when they are all of them.
    pub(super) fn emit_multipliers(&self) -> TokenStream {
        let mut identity = BTreeSet::new();
        let mut computed = BTreeSet::new();
        let mut constant = 0.0f64;
        for &(_, _, l) in &self.lower {
            match l {
                Val::Var(x) => match self.vars[x as usize] {
                    Def::Input(k) => identity.insert(k),
                    _ => computed.insert(x),
                },
                Val::Const(v) => {
                    constant = constant.max(v.abs());
                    false
                }
            };
        }
        let seed = lit(constant);
        let all_inputs = !identity.is_empty() && identity.len() == self.runtime_inputs.len();
        let start = if all_inputs {
            quote!(input_max.max(#seed))
        } else {
            quote!(#seed)
        };
        let mut stmts = TokenStream::new();
        if !all_inputs && identity.len() > MAX_UNROLLED {
            let ks: Vec<usize> = identity.iter().copied().collect();
            let t = table("MULTIPLIERS", &ks);
            stmts.extend(quote! {
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
        } else if !all_inputs {
            for &k in &identity {
                let k = Literal::usize_unsuffixed(k);
                stmts.extend(quote! {{
                    let x = a[#k].abs();
                    if x > max_multiplier {
                        max_multiplier = x;
                    }
                }});
            }
        }
        for &x in &computed {
            let v = self.var(x);
            stmts.extend(quote! {{
                let x = #v.abs();
                if !(x <= max_multiplier) {
                    max_multiplier = x;
                }
            }});
        }
        if stmts.is_empty() {
            quote!(let max_multiplier: f64 = #start;)
        } else {
            quote! {
                let mut max_multiplier: f64 = #start;
                #stmts
            }
        }
    }

    /// The values the solves read, into `f`: stored inputs (the first slots)
    /// by a loop over their positions when many, the computed values one by
    /// one.
    pub(super) fn emit_store(&self, stored: &BTreeMap<u32, usize>) -> TokenStream {
        let mut inputs_by_slot: Vec<(usize, usize)> = stored
            .iter()
            .filter_map(|(&x, &slot)| match self.vars[x as usize] {
                Def::Input(k) => Some((slot, k)),
                _ => None,
            })
            .collect();
        inputs_by_slot.sort_unstable();
        let looped = inputs_by_slot.len() > MAX_UNROLLED;
        let mut store = TokenStream::new();
        if looped {
            let ks: Vec<usize> = inputs_by_slot.iter().map(|&(_, k)| k).collect();
            let t = table("STORED", &ks);
            store.extend(quote! {
                #t
                for (d, &k) in f.iter_mut().zip(&STORED) {
                    if let Some(&x) = a.get(k) {
                        *d = x;
                    }
                }
            });
        }
        for (&x, &slot) in stored {
            if looped && matches!(self.vars[x as usize], Def::Input(_)) {
                continue;
            }
            let v = self.var(x);
            let slot = Literal::usize_unsuffixed(slot);
            store.extend(quote!(f[#slot] = #v;));
        }
        store
    }

    /// The memo of the run-time inputs, when the factorization costs at
    /// least as much as comparing them.
    pub(super) fn emit_memo(&self) -> Memo {
        let nm = self.runtime_inputs.len();
        if nm == 0 || self.operations() < nm {
            return Memo::default();
        }
        let nm_lit = Literal::usize_unsuffixed(nm);
        let pairs = || {
            self.runtime_inputs
                .iter()
                .enumerate()
                .map(|(i, &k)| (Literal::usize_unsuffixed(i), Literal::usize_unsuffixed(k)))
        };
        let same = pairs().map(|(i, k)| quote!(a[#k].to_bits() == self.memo[#i].to_bits()));
        let set = pairs().map(|(i, k)| quote!(self.memo[#i] = a[#k];));
        Memo {
            fields: quote! {
                /// Run-time inputs of the last accepted factorization, and its τ.
                memo: [f64; #nm_lit],
                memo_tolerance: f64,
                memo_valid: bool,
            },
            init: quote! {
                memo: [0.0; #nm_lit],
                memo_tolerance: 0.0,
                memo_valid: false,
            },
            check: quote! {
                if self.memo_valid
                    && singular_tolerance.to_bits() == self.memo_tolerance.to_bits()
                    && #(#same)&&*
                {
                    return Ok(());
                }
            },
            store: quote! {
                #(#set)*
                self.memo_tolerance = singular_tolerance;
                self.memo_valid = true;
            },
            invalidate: quote!(self.memo_valid = false;),
        }
    }
}
