//! Forward dynamics for a generated mechanism with inertia: a wrapper type
//! `{Name}Forward` (the mechanism and its per-step cache) implementing the
//! runtime's `ForwardSystem`, so `Hht` and `Accurate` integrate generated
//! code. Every matrix the integrators need — Φ, Φ_q, ν, γ, M, Q_A, ∂Q_A/∂q,
//! ∂Q_A/∂q̇ and the second derivatives of Φ behind ∂(Φ_qᵀλ)/∂q — is
//! straight-line code from the derivation. The sparse matrices are written
//! as values in the order of the system's `structure()` (the `*_values`
//! methods HHT's sparse Newton matrix reads); the dense methods scatter
//! those values (structural zeros filled once per call). The terms of
//! ∂(Φ_qᵀλ)/∂q are listed in the tape back end's order
//! (`kinema::forward::TapeForward`), so the two agree to rounding of the
//! entries alone.

use kinema_expr::{ExprId, SymId};
use kinema_model::Derivation;
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use crate::{Method, cache, emit};

/// The names and types the forward items refer to.
pub(crate) struct Names<'a> {
    /// The mechanism's struct.
    pub name: &'a Ident,
    /// Its parameters (fields).
    pub params: &'a [Ident],
    /// The scratch (cache) type, `()` without a cache.
    pub scratch: &'a TokenStream,
    /// The runtime's path.
    pub rt: &'a syn::Path,
}

/// One generated evaluation: its method name, the expressions it writes to
/// `out` in order, the inputs it takes and the statements after them.
struct Eval {
    name: &'static str,
    exprs: Vec<ExprId>,
    inputs: &'static [&'static str],
    /// Statements run after the expressions are written.
    then: TokenStream,
}

/// A sparse matrix as the generated code lists it: its entries'
/// expressions and (row, column) positions, in one order.
struct Sparse {
    exprs: Vec<ExprId>,
    positions: Vec<(usize, usize)>,
}

impl Sparse {
    fn of(s: &kinema_expr::SparseMatrix) -> Sparse {
        let (exprs, positions) = s
            .entries
            .iter()
            .map(|e| (e.expr, (e.row as usize, e.col as usize)))
            .unzip();
        Sparse { exprs, positions }
    }
}

/// The terms of ∂(Φ_qᵀλ)/∂q: for every entry (r, c) of Φ_q and coordinate
/// k with ∂(Φ_q)_{rc}/∂q_k not zero, that derivative, its row r of Φ and
/// its position (c, k) — in the tape back end's order (Φ_q's entries, then
/// k). Differentiates in a copy of the arena, returned with them.
fn hessian_terms(d: &Derivation) -> (kinema_expr::Arena, Sparse, Vec<usize>) {
    let mut arena = d.arena.clone();
    let q_syms: Vec<SymId> = d.coordinates.iter().map(|c| c.sym).collect();
    let mut terms = Sparse {
        exprs: Vec::new(),
        positions: Vec::new(),
    };
    let mut rows = Vec::new();
    for e in &d.phi_q.entries {
        for (k, &s) in q_syms.iter().enumerate() {
            let x = arena.diff(e.expr, s);
            if !arena.is_zero(x) {
                terms.exprs.push(x);
                terms.positions.push((e.col as usize, k));
                rows.push(e.row as usize);
            }
        }
    }
    (arena, terms, rows)
}

/// The `{Name}Forward` type, `{Name}::forward()` and the `ForwardSystem`
/// impl, or nothing for a model without inertia.
pub(crate) fn forward_items(
    d: &Derivation,
    names: &Names<'_>,
    cache: &cache::Cache,
) -> TokenStream {
    let Some(dy) = &d.dynamics else {
        return quote!();
    };
    let lens = Lens {
        n: d.nc(),
        m: d.rows.len(),
    };
    let (mut arena, hessian, hessian_rows) = hessian_terms(d);
    // The stated initial velocities, zero where none is stated.
    let zero = arena.num(0.0);
    let velocities: Vec<ExprId> = d
        .coordinates
        .iter()
        .map(|c| c.initial_velocity.unwrap_or(zero))
        .collect();
    let sparse = [
        Sparse::of(&d.phi_q),
        Sparse::of(&dy.applied_q),
        Sparse::of(&dy.applied_qd),
        hessian,
    ];
    let mut evals = evaluations(d, &sparse, &hessian_rows);
    evals.push(Eval {
        name: "forward_initial_configuration",
        exprs: d.coordinates.iter().map(|c| c.guess).collect(),
        inputs: &[],
        then: quote!(),
    });
    evals.push(Eval {
        name: "forward_initial_velocity",
        exprs: velocities,
        inputs: &[],
        then: quote!(),
    });
    let methods = evals.iter().map(|e| method(&arena, e, names, cache, lens));
    let positions = position_consts(&sparse);
    wrapper(names, lens, quote!(#(#methods)*), &positions)
}

/// The evaluations of the mechanism behind the trait's methods: the
/// vectors (Φ, ν, γ, M, Q_A) and the sparse matrices' values (`sparse`:
/// Φ_q, ∂Q_A/∂q, ∂Q_A/∂q̇, the terms of ∂(Φ_qᵀλ)/∂q, each term times λ
/// of its row in `hessian_rows`).
fn evaluations(d: &Derivation, sparse: &[Sparse; 4], hessian_rows: &[usize]) -> Vec<Eval> {
    let Some(dy) = &d.dynamics else {
        return Vec::new();
    };
    let scale = hessian_rows.iter().enumerate().map(|(k, &row)| {
        let (k, row) = (Literal::usize_unsuffixed(k), Literal::usize_unsuffixed(row));
        quote!(out[#k] *= lambda[#row];)
    });
    let scale = quote!(#(#scale)*);
    let eval = |name, exprs: &[ExprId], inputs, then: &TokenStream| Eval {
        name,
        exprs: exprs.to_vec(),
        inputs,
        then: then.clone(),
    };
    let none = quote!();
    let [jac, aq, aqd, hess] = sparse;
    vec![
        eval("forward_phi", &d.phi, &["q"], &none),
        eval("forward_nu", &d.nu, &["q"], &none),
        eval("forward_gamma", &d.gamma, &["q", "qd"], &none),
        eval("forward_mass", &dy.mass, &["q"], &none),
        eval("forward_applied", &dy.applied, &["q", "qd"], &none),
        eval("forward_jacobian_values", &jac.exprs, &["q"], &none),
        eval("forward_applied_q_values", &aq.exprs, &["q", "qd"], &none),
        eval("forward_applied_qd_values", &aqd.exprs, &["q", "qd"], &none),
        eval(
            "forward_hessian_values",
            &hess.exprs,
            &["q", "lambda"],
            &scale,
        ),
    ]
}

/// The positions of the sparse matrices' values, as associated constants
/// of the wrapper (`JACOBIAN`, `APPLIED_Q`, `APPLIED_QD`, `HESSIAN`).
fn position_consts(sparse: &[Sparse; 4]) -> TokenStream {
    let names = ["JACOBIAN", "APPLIED_Q", "APPLIED_QD", "HESSIAN"];
    let consts = sparse.iter().zip(names).map(|(s, name)| {
        let items = s.positions.iter().map(|&(r, c)| {
            let lit = |v: usize| {
                Literal::u32_unsuffixed(kinema_index::u32_of(v, "a sparse pattern's row or column"))
            };
            let (r, c) = (lit(r), lit(c));
            quote!((#r, #c))
        });
        let name = format_ident!("{}", name);
        quote!(const #name: &'static [(u32, u32)] = &[#(#items),*];)
    });
    quote!(#(#consts)*)
}

/// The counts n (coordinates) and m (rows of Φ).
#[derive(Clone, Copy)]
struct Lens {
    n: usize,
    m: usize,
}

/// One private evaluation method of the mechanism, with every argument the
/// trait's methods have (unused ones ignored), lengths checked by
/// [`Method::wrap`]: the expressions into `out` in order, then the
/// evaluation's closing statements.
fn method(
    arena: &kinema_expr::Arena,
    e: &Eval,
    names: &Names<'_>,
    cache: &cache::Cache,
    lens: Lens,
) -> TokenStream {
    let out = format_ident!("out");
    let lookup = |x| cache.lookup(x);
    let inputs = emit::Inputs {
        params: names.params,
        cached: &lookup,
        split: None,
    };
    let target = |k: usize| emit::index(&out, k);
    let (refresh, reads_q, reads_t) = cache.refresh(arena, &e.exprs);
    let (body, mut used) = emit::body(arena, &e.exprs, &target, &inputs);
    used.q |= reads_q;
    used.t |= reads_t;
    let reads = |name: &str| match name {
        "q" => used.q,
        "qd" => used.qd,
        _ => true,
    };
    let listed: Vec<(&str, bool, usize)> = e
        .inputs
        .iter()
        .map(|&i| (i, reads(i), if i == "lambda" { lens.m } else { lens.n }))
        .collect();
    let then = &e.then;
    let wrapped = Method {
        body: quote!(#refresh #body #then),
        used,
        scratch: reads_q || reads_t,
    }
    .wrap(&listed, &[("out", e.exprs.len())]);
    let fname = format_ident!("{}", e.name);
    let scratch = names.scratch;
    quote! {
        #[allow(unused_variables, clippy::too_many_arguments, clippy::approx_constant)]
        #[inline]
        fn #fname(
            &self,
            scratch: &mut #scratch,
            q: &[f64],
            qd: &[f64],
            t: f64,
            lambda: &[f64],
            out: &mut [f64],
        ) {
            #wrapped
        }
    }
}

/// `{Name}Forward`, `{Name}::forward()` and the trait impl delegating to
/// the evaluation methods.
fn wrapper(
    names: &Names<'_>,
    lens: Lens,
    methods: TokenStream,
    positions: &TokenStream,
) -> TokenStream {
    let Names { name, scratch, .. } = *names;
    let fwd = format_ident!("{}Forward", name);
    let doc = format!(
        " The forward dynamics of [`{name}`] (`ForwardSystem`): the mechanism and its \
         evaluation cache, for the runtime's `Hht` and `Accurate` integrators."
    );
    let system = system_impl(names, lens, &fwd);
    quote! {
        #[doc = #doc]
        #[derive(Clone)]
        pub struct #fwd {
            /// The mechanism (its parameters).
            pub mechanism: #name,
            scratch: #scratch,
        }

        impl #fwd {
            #positions
        }

        impl #name {
            /// This mechanism's forward dynamics, for `Hht::new` and
            /// `Accurate::new`.
            #[must_use]
            pub fn forward(self) -> #fwd {
                #fwd {
                    mechanism: self,
                    scratch: ::core::default::Default::default(),
                }
            }

            #methods
        }

        #system
    }
}

/// The `ForwardSystem` impl of `fwd`: the vectors and the sparse values
/// straight from the evaluation methods, the dense matrices as those values
/// scattered.
fn system_impl(names: &Names<'_>, lens: Lens, fwd: &Ident) -> TokenStream {
    let Names { name, rt, .. } = *names;
    let (n, m) = (
        Literal::usize_unsuffixed(lens.n),
        Literal::usize_unsuffixed(lens.m),
    );
    // A dense method: the values into a local array, scattered into `out`.
    let dense = |eval: &str, positions: &str, rows: &Literal, args: TokenStream| {
        let (eval, positions) = (format_ident!("{}", eval), format_ident!("{}", positions));
        quote! {
            let mut values = [0.0_f64; #fwd::#positions.len()];
            self.mechanism.#eval(&mut self.scratch, #args, &mut values);
            #rt::DenseScratch::scatter(&values, Self::#positions, (#rows, #n), out);
        }
    };
    let jacobian = dense(
        "forward_jacobian_values",
        "JACOBIAN",
        &m,
        quote!(q, &[], t, &[]),
    );
    let applied_q = dense(
        "forward_applied_q_values",
        "APPLIED_Q",
        &n,
        quote!(q, qd, t, &[]),
    );
    let applied_qd = dense(
        "forward_applied_qd_values",
        "APPLIED_QD",
        &n,
        quote!(q, qd, t, &[]),
    );
    let hessian = dense(
        "forward_hessian_values",
        "HESSIAN",
        &n,
        quote!(q, &[], t, lambda),
    );
    let values = values_methods(rt);
    quote! {
        impl #rt::ForwardSystem for #fwd {
            fn coords(&self) -> usize {
                #n
            }
            fn rows(&self) -> usize {
                #m
            }
            fn coordinate_name(&self, i: usize) -> &str {
                #name::COORDINATE_NAMES.get(i).copied().unwrap_or("?")
            }
            fn equation_name(&self, i: usize) -> &str {
                #name::EQUATION_NAMES.get(i).copied().unwrap_or("?")
            }
            fn initial_state(&mut self, q: &mut [f64], qd: &mut [f64]) {
                self.mechanism.forward_initial_configuration(&mut self.scratch, &[], &[], 0.0, &[], q);
                self.mechanism.forward_initial_velocity(&mut self.scratch, &[], &[], 0.0, &[], qd);
            }
            fn phi(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
                self.mechanism.forward_phi(&mut self.scratch, q, &[], t, &[], out);
            }
            fn jacobian(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
                #jacobian
            }
            fn nu(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
                self.mechanism.forward_nu(&mut self.scratch, q, &[], t, &[], out);
            }
            fn gamma(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
                self.mechanism.forward_gamma(&mut self.scratch, q, qd, t, &[], out);
            }
            fn mass(&mut self, q: &[f64], out: &mut [f64]) {
                self.mechanism.forward_mass(&mut self.scratch, q, &[], 0.0, &[], out);
            }
            fn applied(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
                self.mechanism.forward_applied(&mut self.scratch, q, qd, t, &[], out);
            }
            fn applied_q(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
                #applied_q
            }
            fn applied_qd(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
                #applied_qd
            }
            fn constraint_hessian(&mut self, q: &[f64], lambda: &[f64], t: f64, out: &mut [f64]) {
                #hessian
            }
            fn structure(&self) -> ::core::option::Option<#rt::ForwardStructure> {
                ::core::option::Option::Some(#rt::ForwardStructure {
                    jacobian: Self::JACOBIAN.to_vec(),
                    applied_q: Self::APPLIED_Q.to_vec(),
                    applied_qd: Self::APPLIED_QD.to_vec(),
                    hessian: Self::HESSIAN.to_vec(),
                })
            }
            #values
        }
    }
}

/// The trait's `*_values` methods: the evaluation methods writing the
/// sparse values straight into `out` (the dense scratch unused).
fn values_methods(rt: &syn::Path) -> TokenStream {
    quote! {
            fn jacobian_values(
                &mut self,
                q: &[f64],
                t: f64,
                _dense: #rt::DenseScratch<'_>,
                out: &mut [f64],
            ) {
                self.mechanism.forward_jacobian_values(&mut self.scratch, q, &[], t, &[], out);
            }
            fn applied_q_values(
                &mut self,
                q: &[f64],
                qd: &[f64],
                t: f64,
                _dense: #rt::DenseScratch<'_>,
                out: &mut [f64],
            ) {
                self.mechanism.forward_applied_q_values(&mut self.scratch, q, qd, t, &[], out);
            }
            fn applied_qd_values(
                &mut self,
                q: &[f64],
                qd: &[f64],
                t: f64,
                _dense: #rt::DenseScratch<'_>,
                out: &mut [f64],
            ) {
                self.mechanism.forward_applied_qd_values(&mut self.scratch, q, qd, t, &[], out);
            }
            fn constraint_hessian_values(
                &mut self,
                q: &[f64],
                lambda: &[f64],
                t: f64,
                _dense: #rt::DenseScratch<'_>,
                out: &mut [f64],
            ) {
                self.mechanism.forward_hessian_values(&mut self.scratch, q, &[], t, lambda, out);
            }
    }
}
