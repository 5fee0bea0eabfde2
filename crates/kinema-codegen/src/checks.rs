//! The runtime's checks on generated code: `System::kink` and
//! `System::phi_error_bounds` as straight-line code over the runtime's
//! `roundoff::Bounded` (each value with its first-order error bound, the
//! tape back end's rules), and `System::equation_reads_time`.
//!
//! The kink check evaluates only the subexpressions of Φ that hold a
//! function with a kink (as the tape back end's kink tape does), in the
//! schedule's order, testing each function's argument before applying it;
//! the equation reported is the first that holds the function.

use kinema_expr::{Arena, ExprId, NodeRef, SymKind, UnaryOp};
use kinema_model::Derivation;
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use crate::emit;

/// Scheduled nodes above which a check is not generated (the system then
/// answers that it cannot tell, the trait's default): a check is one
/// function, not cut into chunks as Φ is, so it stays within the size
/// that keeps LLVM's time linear ([`emit::CHUNK_NODES`]).
const MAX_NODES: usize = emit::CHUNK_NODES;

/// The `kink`, `phi_error_bounds` and `equation_reads_time` methods of the
/// `System` impl.
pub(crate) fn methods(d: &Derivation, params: &[Ident], rt: &syn::Path) -> TokenStream {
    let n = Literal::usize_unsuffixed(d.nc());
    let reads_time = d.phi.iter().map(|&e| d.arena.depends_on(e, d.time));
    let mut out = quote! {
        fn equation_reads_time(&self, i: usize) -> bool {
            const READS_TIME: [bool; #n] = [#(#reads_time),*];
            READS_TIME.get(i).copied().unwrap_or(false)
        }
    };
    let found = |equation: &Literal, function: &TokenStream| quote!(#rt::Kink { equation: ::core::option::Option::Some(#equation), function: #function });
    if let Some(body) = kink_body(&d.arena, &d.phi, (params, rt, false), &found) {
        out.extend(quote! {
            #[allow(unused_variables, clippy::approx_constant, clippy::too_many_lines)]
            fn kink(
                &self,
                _scratch: &mut Self::Scratch,
                q: &[f64],
                uncertainty: f64,
                size: f64,
                t: f64,
            ) -> ::core::option::Option<#rt::Kink> {
                let ::core::result::Result::Ok(q) = <&[f64; #n]>::try_from(q) else {
                    return ::core::option::Option::None;
                };
                #body
                ::core::option::Option::None
            }
        });
    }
    if let Some(body) = bounds_body(d, params, rt) {
        out.extend(quote! {
            #[allow(unused_variables, clippy::approx_constant, clippy::too_many_lines)]
            fn phi_error_bounds(
                &self,
                _scratch: &mut Self::Scratch,
                q: &[f64],
                t: f64,
                uncertainty: f64,
                size: f64,
                errors: &mut [f64],
            ) -> bool {
                let (::core::result::Result::Ok(q), ::core::result::Result::Ok(errors)) =
                    (<&[f64; #n]>::try_from(q), <&mut [f64; #n]>::try_from(errors))
                else {
                    return false;
                };
                #body
                true
            }
        });
    }
    out
}

/// The kink check's statements over `roots` (Φ's equations, or the
/// results' values), returning `found(root, function)` at the first
/// function at its kink; `None` when no root has a function with a kink
/// (the default `None` is then right) or past [`MAX_NODES`]. Velocities
/// read `qd` when `qd` (results), else are 0 (Φ).
fn kink_body(
    arena: &Arena,
    roots: &[ExprId],
    (params, rt, qd): (&[Ident], &syn::Path, bool),
    found: &dyn Fn(&Literal, &TokenStream) -> TokenStream,
) -> Option<TokenStream> {
    // The kink nodes, each with the first root that holds it.
    let mut seen = vec![false; arena.len()];
    let mut owner = vec![usize::MAX; arena.len()];
    let mut nodes = Vec::new();
    let mut stack = Vec::new();
    for (r, &root) in roots.iter().enumerate() {
        stack.push(root);
        while let Some(e) = stack.pop() {
            if std::mem::replace(&mut seen[e.index()], true) {
                continue;
            }
            owner[e.index()] = r;
            if arena.applies_kink(e) {
                nodes.push(e);
            }
            arena.for_each_child(e, |c| {
                if !seen[c.index()] {
                    stack.push(c);
                }
            });
        }
    }
    let mut has_site = false;
    let inputs = Leaves { params, qd };
    let body = bounded(arena, &nodes, &inputs, rt, &mut |n, site| {
        has_site = true;
        let root = Literal::usize_unsuffixed(owner[n.index()]);
        let (f, x, y) = site;
        let function = quote!(#rt::roundoff::KinkFunction::#f);
        let result = found(&root, &quote!(#function.name()));
        quote! {
            if #function.at(#x, #y) {
                return ::core::option::Option::Some(#result);
            }
        }
    })?;
    has_site.then_some(body.0)
}

/// The `output_kink` method of the `Outputs` impl (nothing when the
/// results have no function with a kink: the default `None` is right).
pub(crate) fn output_kink(d: &Derivation, params: &[Ident], rt: &syn::Path) -> TokenStream {
    let n = Literal::usize_unsuffixed(d.nc());
    let values: Vec<ExprId> = d.outputs.iter().map(|o| o.value).collect();
    let found = |column: &Literal, function: &TokenStream| quote!(#rt::OutputKink { column: #column, function: #function });
    let Some(body) = kink_body(&d.arena, &values, (params, rt, true), &found) else {
        return quote!();
    };
    quote! {
        #[allow(unused_variables, clippy::approx_constant, clippy::too_many_lines)]
        fn output_kink(
            &self,
            _scratch: &mut Self::Scratch,
            state: &#rt::State,
            size: f64,
        ) -> ::core::option::Option<#rt::OutputKink> {
            let (t, uncertainty) = (state.t(), state.stats().residual);
            let (::core::result::Result::Ok(q), ::core::result::Result::Ok(qd)) =
                (<&[f64; #n]>::try_from(state.q()), <&[f64; #n]>::try_from(state.qd()))
            else {
                return ::core::option::Option::None;
            };
            #body
            ::core::option::Option::None
        }
    }
}

/// Φ's error bounds into `errors`, or `None` past [`MAX_NODES`].
fn bounds_body(d: &Derivation, params: &[Ident], rt: &syn::Path) -> Option<TokenStream> {
    let inputs = Leaves { params, qd: false };
    let (mut body, places) = bounded(&d.arena, &d.phi, &inputs, rt, &mut |_, _| quote!())?;
    for (i, place) in places.iter().enumerate() {
        let i = Literal::usize_unsuffixed(i);
        body.extend(quote! { errors[#i] = #place.error; });
    }
    Some(body)
}

/// Where the leaves of a bounded body come from: the parameters' fields,
/// and whether velocities are read from `qd` (else 0).
struct Leaves<'a> {
    params: &'a [Ident],
    qd: bool,
}

/// A kink site: the function's variant name in `KinkFunction`, its
/// argument and (for atan2) its ordinate.
type Site = (Ident, TokenStream, TokenStream);

/// Statements binding each scheduled node below `roots` to its `Bounded`
/// value (in `let`s, or slots of one array past [`crate::lu::MAX_LETS`]),
/// with `check(node, site)` emitted before each function that can have a
/// kink; and the place of each root. `None` past [`MAX_NODES`].
fn bounded(
    arena: &Arena,
    roots: &[ExprId],
    leaves: &Leaves<'_>,
    rt: &syn::Path,
    check: &mut dyn FnMut(ExprId, Site) -> TokenStream,
) -> Option<(TokenStream, Vec<TokenStream>)> {
    let schedule = arena.schedule(roots);
    let nodes = schedule.nodes();
    if nodes.len() > MAX_NODES {
        return None;
    }
    let large = nodes.len() > crate::lu::MAX_LETS;
    let place = |i: usize| -> TokenStream {
        if large {
            let k = Literal::usize_unsuffixed(i);
            quote!(b[#k])
        } else {
            let name = format_ident!("b{}", i);
            quote!(#name)
        }
    };
    let at = |e: ExprId| -> TokenStream {
        place(
            schedule
                .position(e)
                .expect("children precede their parents in a schedule"),
        )
    };
    let b = quote!(Bounded);
    let mut stmts = quote! { use #rt::roundoff::Bounded; };
    if large {
        let len = Literal::usize_unsuffixed(nodes.len());
        stmts.extend(quote! { let mut b = [#b::exact(0.0); #len]; });
    }
    let site = |f: &str, x: TokenStream, y: TokenStream| -> Site { (format_ident!("{}", f), x, y) };
    for (i, &n) in nodes.iter().enumerate() {
        let value = match arena.node(n) {
            NodeRef::Num(v) => {
                let v = emit::number(v).tokens;
                quote!(#b::exact(#v))
            }
            NodeRef::Sym(s) => match arena.symbol(s).kind {
                SymKind::Coordinate(k) => {
                    let k = Literal::usize_unsuffixed(k as usize);
                    quote!(#b::coordinate(q[#k], uncertainty, size))
                }
                SymKind::Velocity(k) if leaves.qd => {
                    let k = Literal::usize_unsuffixed(k as usize);
                    quote!(#b::exact(qd[#k]))
                }
                SymKind::Velocity(_) => quote!(#b::exact(0.0)),
                SymKind::Parameter(k) => {
                    let name = leaves
                        .params
                        .get(k as usize)
                        .expect("every parameter symbol of a derivation has a field");
                    quote!(#b::exact(self.#name))
                }
                SymKind::Time => quote!(#b::exact(t)),
            },
            NodeRef::Add { constant, terms } => {
                let c = emit::number(constant).tokens;
                let terms = terms.iter().map(|term| {
                    let k = emit::number(term.coeff).tokens;
                    let v = at(term.expr);
                    quote!((#k, #v))
                });
                quote!(#b::sum(#c, &[#(#terms),*]))
            }
            NodeRef::Mul { coeff, factors } => {
                for f in factors {
                    if let Some(kind) = power_kink(f.exp.abs()) {
                        let x = at(f.base);
                        stmts.extend(check(n, site(kind, x.clone(), x)));
                    }
                }
                let c = emit::number(coeff).tokens;
                let factors = factors.iter().map(|f| {
                    let e = emit::number(f.exp).tokens;
                    let v = at(f.base);
                    quote!((#v, #e))
                });
                quote!(#b::product(#c, &[#(#factors),*]))
            }
            NodeRef::Unary(op, a) => {
                let x = at(a);
                let kind = match op {
                    UnaryOp::Abs => Some("Abs"),
                    UnaryOp::Asin => Some("Asin"),
                    UnaryOp::Acos => Some("Acos"),
                    UnaryOp::Ln => Some("Ln"),
                    UnaryOp::Smooth(_) => Some("Smoothstep"),
                    _ => None,
                };
                if let Some(kind) = kind {
                    stmts.extend(check(n, site(kind, x.clone(), x.clone())));
                }
                if let UnaryOp::Smooth(k) = op {
                    let k = Literal::u8_unsuffixed(k);
                    quote!(#x.smooth(#k))
                } else {
                    let method = format_ident!(
                        "{}",
                        op.rust_method()
                            .expect("every UnaryOp but Smooth(k) is an f64 method")
                    );
                    quote!(#x.#method())
                }
            }
            NodeRef::Pow(a, e) => {
                let (x, y) = (at(a), at(e));
                stmts.extend(check(n, site("Power", x.clone(), x.clone())));
                quote!(#x.pow(#y))
            }
            NodeRef::Atan2(y, x) => {
                let (y, x) = (at(y), at(x));
                stmts.extend(check(n, site("Atan2", x.clone(), y.clone())));
                quote!(#y.atan2(#x))
            }
        };
        let p = place(i);
        stmts.extend(if large {
            quote! { #p = #value; }
        } else {
            quote! { let #p = #value; }
        });
    }
    let places = roots.iter().map(|&r| at(r)).collect();
    Some((stmts, places))
}

/// The kink of a factor's power p (the exponent's magnitude) as the tape
/// compiles it: √ for ½, a real power below 2; none for integers.
fn power_kink(p: f64) -> Option<&'static str> {
    if p == 0.5 {
        Some("Sqrt")
    } else if p.fract() != 0.0 && p < 2.0 {
        Some("Power")
    } else {
        None
    }
}
