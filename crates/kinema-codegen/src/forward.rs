//! Forward dynamics for a generated mechanism with inertia: a wrapper type
//! `{Name}Forward` (the mechanism and its per-step cache) implementing the
//! runtime's `ForwardSystem`, so `Hht` and `Accurate` integrate generated
//! code. Every matrix the integrators need — Φ, Φ_q, ν, γ, M, Q_A, ∂Q_A/∂q,
//! ∂Q_A/∂q̇ and the second derivatives of Φ behind ∂(Φ_qᵀλ)/∂q — is
//! straight-line code from the derivation, written into the dense
//! row-major outputs the trait asks for (structural zeros filled once per
//! call). The sums into ∂(Φ_qᵀλ)/∂q go in the order of the tape back end's
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

/// One generated evaluation: its method name, outputs (dense slots), the
/// inputs it takes and statements around the expressions.
struct Eval {
    name: &'static str,
    exprs: Vec<ExprId>,
    /// Dense slot of each expression in `out` (or in the local `h`).
    slots: Vec<usize>,
    out_len: usize,
    inputs: &'static [&'static str],
    /// Whether `out` is zero-filled first (a sparse matrix written dense).
    zero: bool,
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
    let (n, m) = (d.nc(), d.rows.len());
    let rt = names.rt;
    // The second derivatives of Φ: ∂(Φ_q)_{rc}/∂q_k, nonzeros only, in the
    // tape back end's order (Φ_q's entries, then k).
    let mut arena = d.arena.clone();
    let q_syms: Vec<SymId> = d.coordinates.iter().map(|c| c.sym).collect();
    let mut hess = Vec::new();
    let mut hess_slots = Vec::new();
    for e in &d.phi_q.entries {
        for (k, &s) in q_syms.iter().enumerate() {
            let x = arena.diff(e.expr, s);
            if !arena.is_zero(x) {
                hess.push((e.row as usize, x));
                hess_slots.push(e.col as usize * n + k);
            }
        }
    }
    let dense = |s: &kinema_expr::SparseMatrix| -> (Vec<ExprId>, Vec<usize>) {
        s.entries
            .iter()
            .map(|e| (e.expr, e.row as usize * n + e.col as usize))
            .unzip()
    };
    let plain = |v: &[ExprId]| (v.to_vec(), (0..v.len()).collect::<Vec<_>>());
    let (jac_e, jac_s) = dense(&d.phi_q);
    let (aq_e, aq_s) = dense(&dy.applied_q);
    let (aqd_e, aqd_s) = dense(&dy.applied_qd);
    let evals = [
        ("forward_phi", plain(&d.phi), m, &["q"][..], false),
        ("forward_jacobian", (jac_e, jac_s), m * n, &["q"], true),
        ("forward_nu", plain(&d.nu), m, &["q"], false),
        ("forward_gamma", plain(&d.gamma), m, &["q", "qd"], false),
        ("forward_mass", plain(&dy.mass), n, &["q"], false),
        (
            "forward_applied",
            plain(&dy.applied),
            n,
            &["q", "qd"],
            false,
        ),
        ("forward_applied_q", (aq_e, aq_s), n * n, &["q", "qd"], true),
        (
            "forward_applied_qd",
            (aqd_e, aqd_s),
            n * n,
            &["q", "qd"],
            true,
        ),
    ]
    .map(|(name, (exprs, slots), out_len, inputs, zero)| Eval {
        name,
        exprs,
        slots,
        out_len,
        inputs,
        zero,
    });
    let lens = Lens { n, m };
    let methods = evals
        .iter()
        .map(|e| method(&arena, e, names, cache, lens, None));
    let hess_eval = Eval {
        name: "forward_hessian",
        exprs: hess.iter().map(|h| h.1).collect(),
        slots: (0..hess.len()).collect(),
        out_len: n * n,
        inputs: &["q", "lambda"],
        zero: true,
    };
    let accumulate = hess
        .iter()
        .zip(&hess_slots)
        .enumerate()
        .map(|(k, ((row, _), slot))| {
            let (k, row, slot) = (
                Literal::usize_unsuffixed(k),
                Literal::usize_unsuffixed(*row),
                Literal::usize_unsuffixed(*slot),
            );
            quote!(out[#slot] += lambda[#row] * h[#k];)
        });
    let hess_method = method(
        &arena,
        &hess_eval,
        names,
        cache,
        lens,
        Some(quote!(#(#accumulate)*)),
    );
    let pairs = |entries: &mut dyn Iterator<Item = (usize, usize)>| {
        let v: std::collections::BTreeSet<(usize, usize)> = entries.collect();
        let items = v.into_iter().map(|(r, c)| {
            let lit = |v: usize| Literal::u32_unsuffixed(u32::try_from(v).unwrap_or(u32::MAX));
            let (r, c) = (lit(r), lit(c));
            quote!((#r, #c))
        });
        quote!(&[#(#items),*])
    };
    let jacobian = pairs(
        &mut d
            .phi_q
            .entries
            .iter()
            .map(|e| (e.row as usize, e.col as usize)),
    );
    let block = pairs(
        &mut dy
            .applied_q
            .entries
            .iter()
            .chain(&dy.applied_qd.entries)
            .map(|e| (e.row as usize, e.col as usize))
            .chain(hess_slots.iter().map(|s| (s / n.max(1), s % n.max(1)))),
    );
    let structure = quote! {
        fn structure(&self) -> ::core::option::Option<#rt::ForwardStructure> {
            const JACOBIAN: &[(u32, u32)] = #jacobian;
            const BLOCK: &[(u32, u32)] = #block;
            ::core::option::Option::Some(#rt::ForwardStructure {
                jacobian: JACOBIAN.to_vec(),
                block: BLOCK.to_vec(),
            })
        }
    };
    wrapper(names, lens, quote!(#(#methods)* #hess_method), &structure)
}

/// The counts n (coordinates) and m (rows of Φ).
#[derive(Clone, Copy)]
struct Lens {
    n: usize,
    m: usize,
}

/// One private evaluation method of the mechanism, with every argument the
/// trait's methods have (unused ones ignored), lengths checked by
/// [`Method::wrap`]. With `accumulate`, the expressions go to a local `h`
/// and those statements move them into `out`.
fn method(
    arena: &kinema_expr::Arena,
    e: &Eval,
    names: &Names<'_>,
    cache: &cache::Cache,
    lens: Lens,
    accumulate: Option<TokenStream>,
) -> TokenStream {
    let out = format_ident!("out");
    let h = format_ident!("h");
    let lookup = |x| cache.lookup(x);
    let inputs = emit::Inputs {
        params: names.params,
        cached: &lookup,
    };
    let slots = &e.slots;
    let to_out = |k: usize| emit::index(&out, slots.get(k).copied().unwrap_or(0));
    let to_h = |k: usize| emit::index(&h, k);
    let target: &dyn Fn(usize) -> TokenStream = if accumulate.is_some() { &to_h } else { &to_out };
    let (refresh, reads_q, reads_t) = cache.refresh(arena, &e.exprs);
    let (body, mut used) = emit::body(arena, &e.exprs, target, &inputs);
    used.q |= reads_q;
    used.t |= reads_t;
    let zero = e.zero.then(|| quote!(out.fill(0.0);));
    let local = accumulate.as_ref().map(|_| {
        let len = Literal::usize_unsuffixed(e.exprs.len());
        quote!(let mut h = [0.0_f64; #len];)
    });
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
    let wrapped = Method {
        body: quote!(#zero #local #refresh #body #accumulate),
        used,
        scratch: reads_q || reads_t,
    }
    .wrap(&listed, &[("out", e.out_len)]);
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
    structure: &TokenStream,
) -> TokenStream {
    let Names {
        name, scratch, rt, ..
    } = *names;
    let fwd = format_ident!("{}Forward", name);
    let (n, m) = (
        Literal::usize_unsuffixed(lens.n),
        Literal::usize_unsuffixed(lens.m),
    );
    let doc = format!(
        " The forward dynamics of [`{name}`] (`ForwardSystem`): the mechanism and its \
         evaluation cache, for the runtime's `Hht` and `Accurate` integrators."
    );
    quote! {
        #[doc = #doc]
        #[derive(Clone)]
        pub struct #fwd {
            /// The mechanism (its parameters).
            pub mechanism: #name,
            scratch: #scratch,
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
            fn phi(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
                self.mechanism.forward_phi(&mut self.scratch, q, &[], t, &[], out);
            }
            fn jacobian(&mut self, q: &[f64], t: f64, out: &mut [f64]) {
                self.mechanism.forward_jacobian(&mut self.scratch, q, &[], t, &[], out);
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
                self.mechanism.forward_applied_q(&mut self.scratch, q, qd, t, &[], out);
            }
            fn applied_qd(&mut self, q: &[f64], qd: &[f64], t: f64, out: &mut [f64]) {
                self.mechanism.forward_applied_qd(&mut self.scratch, q, qd, t, &[], out);
            }
            fn constraint_hessian(&mut self, q: &[f64], lambda: &[f64], t: f64, out: &mut [f64]) {
                self.mechanism.forward_hessian(&mut self.scratch, q, &[], t, lambda, out);
            }
            #structure
        }
    }
}
