//! Emission of a [`Plan`]: the generated LU type, its `factor` built from
//! the plan's numerics piece by piece (the elimination's arithmetic, the
//! runtime's scale and acceptance tests through `__private::linalg`, the
//! memo, the stored values), its solves, and the impls that bind it to its
//! system.

use std::collections::{BTreeMap, BTreeSet};

use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

use super::{Def, MAX_LETS, MAX_UNROLLED, Plan, Product, Val};

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

/// `x` as a literal, negative ones parenthesized (a folded constant that
/// overflowed as the runtime's value).
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

/// `const NAME: [usize; len] = [...];`: a table of positions the generated
/// code loops over.
fn table(name: &str, ks: &[usize]) -> TokenStream {
    let name = format_ident!("{}", name);
    let len = Literal::usize_unsuffixed(ks.len());
    let ks = ks.iter().map(|&k| Literal::usize_unsuffixed(k));
    quote!(const #name: [usize; #len] = [#(#ks),*];)
}

/// Statements of one emitted function in the order they run, each with the
/// floating-point operations it does (at least 1).
type Stmts = Vec<(TokenStream, usize)>;

/// `stmts` inline (`budget` is `None`), or split into consecutive runs of
/// about `budget` operations, each a private `#[inline(never)]` associated
/// function `__kinema_{label}_{i}(params)` pushed onto `helpers`, and the
/// calls of them in order (with `args`). The statements touch only what
/// `params` names, under the same names, so each computes in a run exactly
/// what it computed inline: the results are the same to the bit. Values
/// cross from one run to the next through the arrays in `params`.
fn split(
    label: &str,
    stmts: Stmts,
    budget: Option<usize>,
    (params, args): (&TokenStream, &TokenStream),
    helpers: &mut Vec<TokenStream>,
) -> TokenStream {
    let Some(budget) = budget else {
        return stmts.into_iter().map(|(stmt, _)| stmt).collect();
    };
    let mut runs: Vec<TokenStream> = Vec::new();
    let mut size = 0;
    for (stmt, ops) in stmts {
        match runs.last_mut() {
            Some(run) if size + ops <= budget => run.extend(stmt),
            _ => {
                runs.push(stmt);
                size = 0;
            }
        }
        size += ops;
    }
    let mut calls = TokenStream::new();
    for (i, run) in runs.into_iter().enumerate() {
        let name = format_ident!("__kinema_{}_{}", label, i);
        calls.extend(quote!(Self::#name(#args);));
        helpers.push(quote! {
            // `y[k] = (y[k] - …) * f[…]` is the shape of the inline solve's
            // statements, which clippy would rather see as `-=` when there
            // is one term.
            #[inline(never)]
            #[allow(
                unused_variables,
                clippy::assign_op_pattern,
                clippy::approx_constant,
                clippy::excessive_precision,
                clippy::unreadable_literal,
                unused_parens
            )]
            fn #name(#params) {
                #run
            }
        });
    }
    calls
}

/// The memo of the last accepted factorization's run-time inputs: fields,
/// their initial values, the early return when the inputs repeat, the
/// update after an accepted factorization, and its invalidation. All empty
/// when a memo would not pay.
#[derive(Default)]
struct Memo {
    fields: TokenStream,
    init: TokenStream,
    check: TokenStream,
    store: TokenStream,
    invalidate: TokenStream,
}

/// Numerics → statements: each piece of the generated `factor`, in the order
/// it runs.
impl Plan {
    /// Whether the factorization keeps its values in a local array `w`
    /// instead of `let`s: past [`MAX_LETS`] operations, or when it is split
    /// into functions ([`Plan::factor_chunked`]), which hand `w` on.
    fn large(&self) -> bool {
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
    fn emit_elimination(&self, helpers: &mut Vec<TokenStream>) -> TokenStream {
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
    fn emit_scale(&self, rt: &syn::Path) -> TokenStream {
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
    fn emit_pivots(&self) -> TokenStream {
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
    fn emit_multipliers(&self) -> TokenStream {
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
    fn emit_store(&self, stored: &BTreeMap<u32, usize>) -> TokenStream {
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
    fn emit_memo(&self) -> Memo {
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

/// Emission: the generated type and its impls around the numerics above.
impl Plan {
    /// The generated type, its `LinearSolver` impl (factorization checked by
    /// the runtime's rule, fallback to the runtime's solver), and the
    /// `LinearSolverFor` impls that bind it to its system.
    pub(crate) fn emit(&self, names: &Names<'_>) -> TokenStream {
        let Names {
            rt,
            ty,
            system,
            fallback,
        } = names;
        let stored = self.stored();
        let memo = self.emit_memo();
        let definition = self.emit_struct(names, stored.len(), &memo.fields);
        // The functions that large factorizations and solves are split into.
        let mut helpers = Vec::new();
        let factor = self.emit_factor(rt, &stored, &memo, &mut helpers);
        let n_lit = Literal::usize_unsuffixed(self.n);
        let nf_lit = Literal::usize_unsuffixed(stored.len().max(1));
        let memo_init = &memo.init;
        let solve = self.emit_solve(&stored, &mut helpers);
        let solve = self.emit_solve_fn(rt, quote!(solve_in_place), solve);
        let solve_transpose = self.emit_solve_transpose(&stored, &mut helpers);
        let solve_transpose =
            self.emit_solve_fn(rt, quote!(solve_transpose_in_place), solve_transpose);
        let inherent = emit_inherent(rt, ty, &memo.invalidate, &helpers);
        // `!(x >= min_pivot)` is meant: a NaN pivot or multiplier must fail
        // the acceptance test (`emit_pivots`, `emit_multipliers`).
        quote! {
            #definition

            #[allow(
                clippy::approx_constant,
                clippy::excessive_precision,
                clippy::neg_cmp_op_on_partial_ord,
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
                        pivots: (0.0, 1.0, false),
                        fallback,
                    })
                }

                fn dim(&self) -> usize {
                    #n_lit
                }

                #factor

                #solve

                #solve_transpose

                fn pivot_report(&self) -> ::core::option::Option<#rt::PivotReport> {
                    match self.active {
                        Self::STATIC => {
                            let (min_pivot, scale, negative) = self.pivots;
                            ::core::option::Option::Some(#rt::PivotReport {
                                ratio: if scale > 0.0 { min_pivot / scale } else { 0.0 },
                                det_sign: if negative { -1.0 } else { 1.0 },
                            })
                        }
                        Self::FALLBACK => #rt::LinearSolver::pivot_report(&self.fallback),
                        _ => ::core::option::Option::None,
                    }
                }
            }

            // Only for the system whose constants are folded in (and borrows of it).
            impl #rt::LinearSolverFor<#system> for #ty {}
            impl #rt::LinearSolverFor<&#system> for #ty {}
            impl #rt::LinearSolverFor<&mut #system> for #ty {}

            #inherent
        }
    }

    /// The generated type: the stored factors, the memo's fields, the
    /// bookkeeping of which factorization is active, and the fallback.
    fn emit_struct(
        &self,
        names: &Names<'_>,
        stored: usize,
        memo_fields: &TokenStream,
    ) -> TokenStream {
        let Names {
            ty,
            system,
            fallback,
            ..
        } = names;
        let nf_lit = Literal::usize_unsuffixed(stored.max(1));
        let doc = self.type_doc(system, fallback);
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
                /// minₖ |u_kk|, maxᵢⱼ |aᵢⱼ| and whether det A < 0, of the last static
                /// factorization: the pivot report, formed only when asked for.
                pivots: (f64, f64, bool),
                fallback: #fallback,
            }
        }
    }

    /// One of the `LinearSolver` solves (`method`: `solve_in_place` or
    /// `solve_transpose_in_place`): the fallback's when it is active, else
    /// `body` on the right-hand side as a fixed-size array `b` and the
    /// stored factors `f`.
    fn emit_solve_fn(&self, rt: &syn::Path, method: TokenStream, body: TokenStream) -> TokenStream {
        let n_lit = Literal::usize_unsuffixed(self.n);
        quote! {
            fn #method(&mut self, rhs: &mut [f64]) -> ::core::result::Result<(), #rt::LinalgError> {
                match self.active {
                    Self::STATIC => {}
                    Self::FALLBACK => return #rt::LinearSolver::#method(&mut self.fallback, rhs),
                    _ => return Err(#rt::LinalgError::NotFactored),
                }
                let found = rhs.len();
                let Ok(b) = <&mut [f64; #n_lit]>::try_from(rhs) else {
                    return Err(#rt::LinalgError::Dimension { what: "right-hand side", expected: #n_lit, found });
                };
                let f = &self.f;
                #body
                Ok(())
            }
        }
    }

    /// `LinearSolver::factor`: the static order's factorization, accepted by
    /// the runtime's rule or handed to the fallback (its elimination's
    /// functions, when split, pushed onto `helpers`).
    fn emit_factor(
        &self,
        rt: &syn::Path,
        stored: &BTreeMap<u32, usize>,
        memo: &Memo,
        helpers: &mut Vec<TokenStream>,
    ) -> TokenStream {
        let nnz_lit = Literal::usize_unsuffixed(self.nnz);
        let constant_scale = lit(self.constant_scale);
        let scale = self.emit_scale(rt);
        let elimination = self.emit_elimination(helpers);
        let pivots = self.emit_pivots();
        let multipliers = self.emit_multipliers();
        let store = self.emit_store(stored);
        let (memo_check, memo_store) = (&memo.check, &memo.store);
        quote! {
        fn factor(&mut self, values: &[f64], singular_tolerance: f64) -> ::core::result::Result<(), #rt::LinalgError> {
            let a = match <&[f64; #nnz_lit]>::try_from(values) {
                Ok(a) if self.fits => a,
                _ => return self.factor_fallback(values, singular_tolerance),
            };
            #memo_check
            #scale
            let scale = input_max.max(#constant_scale);
            #elimination
            #pivots
            #multipliers
            let accept = #rt::linalg::order_accepted(finite, max_multiplier, min_pivot, singular_tolerance, scale);
            if !accept {
                return self.factor_fallback(values, singular_tolerance);
            }
            let f = &mut self.f;
            #store
            #memo_store
            self.pivots = (min_pivot, scale, negative);
            self.active = Self::STATIC;
            Ok(())
        }
        }
    }

    /// The generated type's doc comment.
    fn type_doc(&self, system: &proc_macro2::Ident, fallback: &TokenStream) -> String {
        let fallback = fallback.to_string().replace(' ', "");
        let fallback = fallback.rsplit("::").next().unwrap_or(&fallback);
        format!(
            " The LU of [`{system}`]'s Jacobian, generated for its pattern: a pivot order \
             chosen at generation time, {} floating-point operations per factorization, \
             straight-line solves; the runtime's `{fallback}` takes over when that order does \
             not suit the matrix (see the `LinearSolver` trait for the contract). The \
             Jacobian's constant entries are folded in and never read from `values`: \
             this type factors that Jacobian, not any matrix of its pattern, and only \
             a solver of [`{system}`] accepts it.",
            self.operations(),
        )
    }

    /// Forward then backward substitution on `b` (a `[f64; n]`), reading
    /// stored run-time values from `f`; past `chunk_ops` operations, in
    /// functions `__kinema_solve_{i}(b, f, y)` pushed onto `helpers`.
    fn emit_solve(
        &self,
        stored: &BTreeMap<u32, usize>,
        helpers: &mut Vec<TokenStream>,
    ) -> TokenStream {
        let n = self.n;
        // Each of the n rows is a statement forward, backward and in the
        // copy out, plus a term per entry of L and U.
        let chunked = 3 * n + self.lower.len() + self.upper.len() > self.chunk_ops;
        // Values crossing from one function to the next are in `y`.
        let large = n > MAX_LETS / 2 || chunked;
        let read = |v: Val| -> Result<TokenStream, f64> {
            match v {
                Val::Const(c) => Err(c),
                Val::Var(x) => {
                    let slot = stored
                        .get(&x)
                        .copied()
                        .expect("every run-time value the solves read is stored (Plan::stored)");
                    let slot = Literal::usize_unsuffixed(slot);
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
        let n_lit = Literal::usize_unsuffixed(n);
        let mut out = TokenStream::new();
        if large {
            out.extend(quote!(let mut y = [0.0f64; #n_lit];));
        }
        let mut stmts = Stmts::new();
        // Forward: y_i = b[p_i] − Σ_k l_ik y_k.
        for (i, (l_row, &r)) in l_rows.iter().zip(&self.row_order).enumerate() {
            let r = Literal::usize_unsuffixed(r);
            let terms: Vec<(Val, TokenStream)> = l_row.iter().map(|&(l, k)| (l, y(k))).collect();
            let rest = minus_terms(&terms);
            let place = y(i);
            let stmt = if large {
                quote!(#place = b[#r] #rest;)
            } else {
                quote!(let #place = b[#r] #rest;)
            };
            stmts.push((stmt, 1 + terms.len()));
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
            let ops = 1 + terms.len();
            if terms.is_empty() && matches!(self.inv[k], Val::Const(c) if c == 1.0) {
                // y_k is already x_k.
            } else if large {
                stmts.push((quote!(#yk = #value;), ops));
            } else {
                stmts.push((quote!(let #yk = #value;), ops));
            }
        }
        for k in 0..n {
            let c = Literal::usize_unsuffixed(self.col_order[k]);
            let yk = y(k);
            stmts.push((quote!(b[#c] = #yk;), 1));
        }
        let nf = Literal::usize_unsuffixed(stored.len().max(1));
        out.extend(split(
            "solve",
            stmts,
            chunked.then_some(self.chunk_ops),
            (
                &quote!(b: &mut [f64; #n_lit], f: &[f64; #nf], y: &mut [f64; #n_lit]),
                &quote!(b, f, &mut y),
            ),
            helpers,
        ));
        out
    }

    /// Aᵀ x = b on `b` with the same factors, P A Q = L U so Aᵀ = Q Uᵀ Lᵀ P:
    /// w = Qᵀ b, Uᵀ s = w (forward), Lᵀ u = s (backward), x = Pᵀ u. Used by
    /// inverse dynamics only, so it is plain array code without the
    /// inlining of [`Plan::emit_solve`]. Past `chunk_ops` operations, in
    /// functions `__kinema_solve_transpose_{i}(b, f, y)` pushed onto
    /// `helpers`.
    fn emit_solve_transpose(
        &self,
        stored: &BTreeMap<u32, usize>,
        helpers: &mut Vec<TokenStream>,
    ) -> TokenStream {
        let n = self.n;
        // As for the solve: three statements per row and one per entry.
        let chunked = 3 * n + self.lower.len() + self.upper.len() > self.chunk_ops;
        let val = |v: Val| -> Result<TokenStream, f64> {
            match v {
                Val::Const(c) => Err(c),
                Val::Var(x) => {
                    let slot = stored
                        .get(&x)
                        .copied()
                        .expect("every run-time value the solves read is stored (Plan::stored)");
                    let slot = Literal::usize_unsuffixed(slot);
                    Ok(quote!(f[#slot]))
                }
            }
        };
        // y[a] −= c · y[b], with the constants ±1 and 0 folded.
        let update = |a: &Literal, c: Val, b: &Literal| -> TokenStream {
            match val(c) {
                Ok(v) => quote!(y[#a] -= #v * y[#b];),
                Err(0.0) => quote!(),
                Err(1.0) => quote!(y[#a] -= y[#b];),
                Err(-1.0) => quote!(y[#a] += y[#b];),
                Err(k) if k < 0.0 => {
                    let k = lit(-k);
                    quote!(y[#a] += #k * y[#b];)
                }
                Err(k) => {
                    let k = lit(k);
                    quote!(y[#a] -= #k * y[#b];)
                }
            }
        };
        let mut u_cols: Vec<Vec<(Val, usize)>> = vec![Vec::new(); n];
        for &(k, j, u) in &self.upper {
            u_cols[j].push((u, k));
        }
        let mut l_cols: Vec<Vec<(Val, usize)>> = vec![Vec::new(); n];
        for &(i, k, l) in &self.lower {
            l_cols[k].push((l, i));
        }
        let n_lit = Literal::usize_unsuffixed(n);
        let out = quote!(let mut y = [0.0f64; #n_lit];);
        let mut stmts = Stmts::new();
        for (k, &c) in self.col_order.iter().enumerate() {
            let (k, c) = (Literal::usize_unsuffixed(k), Literal::usize_unsuffixed(c));
            stmts.push((quote!(y[#k] = b[#c];), 1));
        }
        for (j, col) in u_cols.iter().enumerate() {
            let jl = Literal::usize_unsuffixed(j);
            for &(u, k) in col {
                stmts.push((update(&jl, u, &Literal::usize_unsuffixed(k)), 1));
            }
            let scale = match val(self.inv[j]) {
                Ok(v) => quote!(y[#jl] *= #v;),
                Err(1.0) => quote!(),
                Err(-1.0) => quote!(y[#jl] = -y[#jl];),
                Err(c) => {
                    let c = lit(c);
                    quote!(y[#jl] *= #c;)
                }
            };
            stmts.push((scale, 1));
        }
        for (k, col) in l_cols.iter().enumerate().rev() {
            let kl = Literal::usize_unsuffixed(k);
            for &(l, i) in col {
                stmts.push((update(&kl, l, &Literal::usize_unsuffixed(i)), 1));
            }
        }
        for (k, &r) in self.row_order.iter().enumerate() {
            let (k, r) = (Literal::usize_unsuffixed(k), Literal::usize_unsuffixed(r));
            stmts.push((quote!(b[#r] = y[#k];), 1));
        }
        let nf = Literal::usize_unsuffixed(stored.len().max(1));
        let body = split(
            "solve_transpose",
            stmts,
            chunked.then_some(self.chunk_ops),
            (
                &quote!(b: &mut [f64; #n_lit], f: &[f64; #nf], y: &mut [f64; #n_lit]),
                &quote!(b, f, &mut y),
            ),
            helpers,
        );
        quote!(#out #body)
    }
}

/// The generated type's own items: the active-factorization constants, the
/// fallback count, the fallback factorization (out of the hot path), and
/// the functions a large factorization and solves are split into.
fn emit_inherent(
    rt: &syn::Path,
    ty: &proc_macro2::Ident,
    memo_invalidate: &TokenStream,
    helpers: &[TokenStream],
) -> TokenStream {
    quote! {
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

            #(#helpers)*
        }
    }
}
