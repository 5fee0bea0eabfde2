//! `impl Dynamics` for a generated mechanism with inertia: diag M, Q_A and
//! the reactions' arms as one straight-line body (the per-step cache of
//! sin/cos and functions of time reused where the kinematic methods have
//! it), the reactions' rows and bodies as a constant table.

use kinema_index::{Body, Coord, u32_of};
use kinema_model::{Derivation, DynamicsDerivation, RowKind};
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
        split: None,
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
            Literal::u32_unsuffixed(u32_of(r.rows.start, "a reaction's row")),
            Literal::u32_unsuffixed(u32_of(r.rows.end, "a reaction's row")),
            Literal::u32_unsuffixed(u32_of(r.body, "a reaction's body")),
        );
        quote!(#rt::ReactionSpec {
            rows: #rt::RowRange { start: #a, end: #b },
            body: #rt::Body::from_u32(#k),
        })
    });
    let driving = Literal::usize_unsuffixed(driving_pos(d));
    let names = dy.reactions.iter().map(|r| {
        let body = d.bodies.get(r.body).cloned().unwrap_or_default();
        let text = format!("{}.{body}", r.element);
        quote!(#text)
    });
    let nr = Literal::usize_unsuffixed(dy.reactions.len());
    let reactions_fn = reactions_method(d, dy, driving_pos(d));
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

            #reactions_fn
        }
    }
}

/// The first driving row (the row count when there is none).
fn driving_pos(d: &Derivation) -> usize {
    d.rows
        .iter()
        .position(|r| r.kind == RowKind::Driving)
        .unwrap_or(d.rows.len())
}

/// `Dynamics::reactions_and_efforts` as straight-line code: each reaction's
/// components as −Σ Φ_q[k] λ[row] over its entries in pattern order (from
/// 0.0, as the runtime's sum goes), the torque moved to the element's point
/// (terms of an arm that is identically zero, or of a component without
/// entries, left out), each effort −λ; returns the sum of the components.
fn reactions_method(d: &Derivation, dy: &DynamicsDerivation, driving: usize) -> TokenStream {
    let n = d.nc();
    let nnz = d.phi_q.entries.len();
    let nr = dy.reactions.len();
    let ne = n.saturating_sub(driving);
    let lit = Literal::usize_unsuffixed;
    let mut statements = Vec::with_capacity(nr + ne);
    for (i, r) in dy.reactions.iter().enumerate() {
        let mut comps = [Vec::new(), Vec::new(), Vec::new()];
        for (k, e) in d.phi_q.entries.iter().enumerate() {
            let (row, col) = (e.row as usize, Coord::of_index(e.col as usize));
            if r.rows.contains(&row) && col.body == Body::new(r.body) {
                let (k, row) = (lit(k), lit(row));
                comps[col.axis.index()].push(quote!(- jac[#k] * lambda[#row]));
            }
        }
        let has = [0, 1, 2].map(|c| !comps[c].is_empty());
        let value = |c: usize| {
            let terms = &comps[c];
            if terms.is_empty() {
                quote!(0.0)
            } else {
                quote!(0.0 #(#terms)*)
            }
        };
        let (fx, fy, t) = (value(0), value(1), value(2));
        // B s'P · F = −arm.y fx + arm.x fy, the terms that can be nonzero.
        let (ax, ay) = (lit(2 * i), lit(2 * i + 1));
        let arm_x = !d.arena.is_zero(r.arm[0]) && has[1];
        let arm_y = !d.arena.is_zero(r.arm[1]) && has[0];
        let torque = match (arm_y, arm_x) {
            (true, true) => quote!(t - (-arms[#ay] * fx + arms[#ax] * fy)),
            (true, false) => quote!(t - (-arms[#ay] * fx)),
            (false, true) => quote!(t - arms[#ax] * fy),
            (false, false) => quote!(t),
        };
        let sum = [("fx", has[0]), ("fy", has[1]), ("torque", true)]
            .into_iter()
            .filter(|c| c.1)
            .map(|(c, _)| {
                let c = format_ident!("{}", c);
                quote!(sum += #c;)
            });
        let i = lit(i);
        // One block per reaction: its `let`s do not nest the scopes of
        // the next (thousands on a long chain).
        statements.push(quote! {
            {
                let fx = #fx;
                let fy = #fy;
                let t = #t;
                let torque = #torque;
                reactions[#i] = [fx, fy, torque];
                #(#sum)*
            }
        });
    }
    for k in 0..ne {
        let (e, row) = (lit(k), lit(driving + k));
        statements.push(quote!(efforts[#e] = -lambda[#row];));
    }
    let (n, nnz, nr2, nr, ne) = (lit(n), lit(nnz), lit(2 * nr), lit(nr), lit(ne));
    quote! {
        #[allow(unused_variables, unused_mut, clippy::neg_multiply)]
        fn reactions_and_efforts(
            &self,
            jac: &[f64],
            lambda: &[f64],
            arms: &[f64],
            reactions: &mut [[f64; 3]],
            efforts: &mut [f64],
        ) -> ::core::option::Option<f64> {
            let (Ok(jac), Ok(lambda), Ok(arms), Ok(reactions), Ok(efforts)) = (
                <&[f64; #nnz]>::try_from(jac),
                <&[f64; #n]>::try_from(lambda),
                <&[f64; #nr2]>::try_from(arms),
                <&mut [[f64; 3]; #nr]>::try_from(reactions),
                <&mut [f64; #ne]>::try_from(efforts),
            ) else {
                return ::core::option::Option::None;
            };
            let mut sum = 0.0_f64;
            #(#statements)*
            ::core::option::Option::Some(sum)
        }
    }
}
