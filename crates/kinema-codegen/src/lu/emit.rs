//! Emission of a [`Plan`]: the generated LU type, its `factor` built from
//! the plan's numerics piece by piece (the elimination's arithmetic, the
//! runtime's scale and acceptance tests through `__private::linalg`, the
//! memo, the stored values), its solves, and the impls that bind it to its
//! system.
//!
//! Here the names, the shared helpers and the type with its impls; the
//! `factor`'s pieces are built from the numerics in `numerics`, the
//! solves in `solve`.

mod numerics;
mod solve;

use std::collections::BTreeMap;

use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

use super::Plan;

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
/// Emission: the generated type and its impls around the numerics (in
/// `numerics`).
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
