//! `impl Dynamics` for a generated mechanism with inertia: diag M, Q_A and
//! the reactions' arms as one straight-line body (the per-step cache of
//! sin/cos and functions of time reused where the kinematic methods have
//! it), the reactions' rows and bodies as a constant table.

use kinema_model::{Derivation, RowKind};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use crate::{Method, cache, emit};

/// The impl, or nothing for a kinematic model.
pub(crate) fn dynamics_impl(
    d: &Derivation,
    name: &Ident,
    params: &[Ident],
    cache: &cache::Cache,
    rt: &syn::Path,
) -> TokenStream {
    let Some(dy) = &d.dynamics else {
        return quote!();
    };
    let nc = d.nc();
    let mut outputs: Vec<kinema_expr::ExprId> =
        dy.mass.iter().chain(&dy.applied).copied().collect();
    for r in &dy.reactions {
        outputs.extend(r.arm);
    }
    let len = outputs.len();
    let out = format_ident!("out");
    let lookup = |e| cache.lookup(e);
    let inputs = emit::Inputs {
        params,
        cached: &lookup,
    };
    let (refresh, reads_q, reads_t) = cache.refresh(&d.arena, &outputs);
    let (body, mut used) = emit::body(&d.arena, &outputs, &|k| emit::index(&out, k), &inputs);
    used.q |= reads_q;
    used.t |= reads_t;
    let method = Method {
        body: quote!(#refresh #body),
        used,
        scratch: reads_q || reads_t,
    };
    let body = method.wrap(
        &[("q", method.used.q, nc), ("qd", method.used.qd, nc)],
        &[("out", len)],
    );
    let s = Method::arg(method.scratch, "scratch");
    let t = Method::arg(method.used.t, "t");
    let specs = dy.reactions.iter().map(|r| {
        let (a, b, k) = (
            Literal::u32_unsuffixed(u32::try_from(r.rows.0).unwrap_or(u32::MAX)),
            Literal::u32_unsuffixed(u32::try_from(r.rows.1).unwrap_or(u32::MAX)),
            Literal::u32_unsuffixed(u32::try_from(r.body).unwrap_or(u32::MAX)),
        );
        quote!(#rt::ReactionSpec { rows: (#a, #b), body: #k })
    });
    let driving = d
        .rows
        .iter()
        .position(|r| r.kind == RowKind::Driving)
        .unwrap_or(d.rows.len());
    let driving = Literal::usize_unsuffixed(driving);
    let names = dy.reactions.iter().map(|r| {
        let body = d.bodies.get(r.body).cloned().unwrap_or_default();
        let text = format!("{}.{body}", r.element);
        quote!(#text)
    });
    let nr = Literal::usize_unsuffixed(dy.reactions.len());
    quote! {
        impl #name {
            /// Each reaction's `element.body`, in `Dynamics::reactions` order.
            pub const REACTION_NAMES: [&'static str; #nr] = [#(#names),*];
        }

        #[allow(clippy::approx_constant)]
        impl #rt::Dynamics for #name {
            fn reactions(&self) -> &[#rt::ReactionSpec] {
                const REACTIONS: &[#rt::ReactionSpec] = &[#(#specs),*];
                REACTIONS
            }

            fn dynamics(&self, #s: &mut Self::Scratch, q: &[f64], qd: &[f64], #t: f64, out: &mut [f64]) {
                #body
            }

            fn driving_start(&self) -> usize {
                #driving
            }
        }
    }
}
