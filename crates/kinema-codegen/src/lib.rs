//! Code generation: a kinema [`Derivation`] becomes specialized Rust.
//!
//! The generated item is a struct named after the mechanism, its parameters
//! as public `f64` fields with a `Default` from the declared values, that
//! implements the runtime's `System` trait with straight-line code: each
//! shared subexpression computed once, only the structural nonzeros of Φ_q
//! written, constants folded, parameters read from `self`, no allocation and
//! no panics. It also carries the derivation as text
//! (`SliderCrank::derivation()`) for snapshot tests.
//!
//! Three ways to use it: the `kinema::mechanism!` macro (through
//! [`expand`]), a build script ([`build::generate`], writing a formatted
//! `.rs` file into `OUT_DIR`), and `kinema codegen` on the command line
//! ([`generate_source`]).

mod emit;
mod macro_input;

pub mod build;

pub use macro_input::{expand_macro, expand_macro_with};

use kinema_model::Derivation;
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote};

/// How generated code refers to the runtime.
#[derive(Clone, Debug)]
pub struct Options {
    /// Path of the module holding `System`, `Solver`, `DenseLu`, `SparseLu`,
    /// `Auto`, `Options` and `Error` (default `::kinema::__private`; use
    /// `::kinema_runtime` for an app that depends on the runtime alone).
    pub runtime: syn::Path,
    /// Largest coordinate count for which `solver()` uses the statically
    /// sized dense LU; above it, the size-based automatic choice.
    pub static_dense_limit: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            runtime: syn::parse_quote!(::kinema::__private),
            static_dense_limit: 24,
        }
    }
}

/// The generated items for `derivation` as tokens.
#[must_use]
pub fn expand(derivation: &Derivation, options: &Options) -> TokenStream {
    let d = derivation;
    let rt = &options.runtime;
    let name = Ident::new(&type_name(&d.name), Span::call_site());
    let nc = d.nc();
    let nnz = d.phi_q.entries.len();
    let nc_lit = Literal::usize_unsuffixed(nc);
    let nnz_lit = Literal::usize_unsuffixed(nnz);

    let docs = doc_attrs(&d.docs);
    let params: Vec<Ident> = d.params.iter().map(|p| field_name(&p.name)).collect();
    let fields = d.params.iter().zip(&params).map(|(p, f)| {
        let docs = doc_attrs(&p.docs);
        quote! { #docs pub #f: f64, }
    });
    let defaults = d.params.iter().zip(&params).map(|(p, f)| {
        let v = emit::number(p.value).tokens;
        quote! { #f: #v, }
    });

    let coordinate_names = d.coordinates.iter().map(|c| c.name.as_str());
    let equation_names = d.rows.iter().map(|r| r.name.as_str());
    let body_names = d.bodies.iter().map(String::as_str);
    let nb = Literal::usize_unsuffixed(d.bodies.len());
    let pattern = d.phi_q.entries.iter().map(|e| {
        let (r, c) = (
            Literal::u32_unsuffixed(e.row),
            Literal::u32_unsuffixed(e.col),
        );
        quote!((#r, #c))
    });
    let derivation_text = d.render();

    let inputs = emit::Inputs { params: &params };
    let a = &d.arena;
    let out = format_ident!("out");
    let to_out = |k: usize| emit::index(&out, k);
    let jac_exprs: Vec<_> = d.phi_q.entries.iter().map(|e| e.expr).collect();
    let guess_exprs: Vec<_> = d.coordinates.iter().map(|c| c.guess).collect();

    let q_name = format_ident!("q");
    let (guess_body, _) = emit::body(a, &guess_exprs, &|k| emit::index(&q_name, k), &inputs);
    let (phi_body, phi_used) = emit::body(a, &d.phi, &to_out, &inputs);
    let (jac_body, jac_used) = emit::body(a, &jac_exprs, &to_out, &inputs);
    let (nu_body, nu_used) = emit::body(a, &d.nu, &to_out, &inputs);
    let (gamma_body, gamma_used) = emit::body(a, &d.gamma, &to_out, &inputs);
    // Φ and Φ_q together: one schedule, so sin/cos are computed once per body.
    let both: Vec<_> = d.phi.iter().chain(&jac_exprs).copied().collect();
    let (phi_name, values_name) = (format_ident!("phi"), format_ident!("values"));
    let to_both = |k: usize| {
        if k < nc {
            emit::index(&phi_name, k)
        } else {
            emit::index(&values_name, k - nc)
        }
    };
    let (both_body, both_used) = emit::body(a, &both, &to_both, &inputs);

    let arg = |used: bool, name: &str| {
        if used {
            format_ident!("{}", name)
        } else {
            format_ident!("_{}", name)
        }
    };
    let sized = |used: bool, name: &str, len: &Literal, mutable: bool| -> TokenStream {
        let n = format_ident!("{}", name);
        match (used, mutable) {
            (false, _) => quote!(),
            (true, false) => quote! { let Ok(#n) = <&[f64; #len]>::try_from(#n) else { return; }; },
            (true, true) => quote! { let Ok(#n) = <&mut [f64; #len]>::try_from(#n) else { return; }; },
        }
    };
    let phi_q = arg(phi_used.q, "q");
    let phi_t = arg(phi_used.t, "t");
    let phi_q_check = sized(phi_used.q, "q", &nc_lit, false);
    let jac_q = arg(jac_used.q, "q");
    let jac_t = arg(jac_used.t, "t");
    let jac_q_check = sized(jac_used.q, "q", &nc_lit, false);
    let both_q = arg(both_used.q, "q");
    let both_t = arg(both_used.t, "t");
    let both_q_check = sized(both_used.q, "q", &nc_lit, false);
    let nu_q = arg(nu_used.q, "q");
    let nu_t = arg(nu_used.t, "t");
    let nu_q_check = sized(nu_used.q, "q", &nc_lit, false);
    let gamma_q = arg(gamma_used.q, "q");
    let gamma_qd = arg(gamma_used.qd, "qd");
    let gamma_t = arg(gamma_used.t, "t");
    let gamma_q_check = sized(gamma_used.q, "q", &nc_lit, false);
    let gamma_qd_check = sized(gamma_used.qd, "qd", &nc_lit, false);

    let solver = if nc <= options.static_dense_limit {
        quote! {
            /// The solver for this mechanism: Newton–Raphson position analysis,
            /// velocity and acceleration, with a dense LU sized at compile time.
            ///
            /// # Errors
            /// If the runtime rejects the Jacobian pattern (it cannot for
            /// generated code).
            pub fn solver(self, options: #rt::Options) -> ::core::result::Result<#rt::Solver<Self, #rt::DenseLu<#nc_lit>>, #rt::Error> {
                #rt::Solver::with_options(self, options)
            }
        }
    } else {
        quote! {
            /// The solver for this mechanism: Newton–Raphson position analysis,
            /// velocity and acceleration, with a sparse LU whose symbolic
            /// analysis is done once.
            ///
            /// # Errors
            /// If the runtime rejects the Jacobian pattern (it cannot for
            /// generated code).
            pub fn solver(self, options: #rt::Options) -> ::core::result::Result<#rt::Solver<Self, #rt::Auto>, #rt::Error> {
                #rt::Solver::with_options(self, options)
            }
        }
    };

    let nc_doc = format!(" Number of generalized coordinates (and equations): {nc}.");
    quote! {
        #docs
        #[derive(Clone, Debug, PartialEq)]
        pub struct #name {
            #(#fields)*
        }

        impl ::core::default::Default for #name {
            fn default() -> Self {
                Self { #(#defaults)* }
            }
        }

        // Literals are the exact values the derivation computed; some of them
        // happen to be close to named constants.
        #[allow(clippy::approx_constant)]
        impl #name {
            #[doc = #nc_doc]
            pub const COORDINATES: usize = #nc_lit;
            /// Names of the coordinates, `body.x`, `body.y`, `body.phi` per body.
            pub const COORDINATE_NAMES: [&'static str; #nc_lit] = [#(#coordinate_names),*];
            /// Names of the equations: kinematic constraints, then drivers.
            pub const EQUATION_NAMES: [&'static str; #nc_lit] = [#(#equation_names),*];
            /// Names of the bodies; body k owns coordinates 3k, 3k + 1, 3k + 2.
            pub const BODY_NAMES: [&'static str; #nb] = [#(#body_names),*];
            /// (row, column) of each structural nonzero of Φ_q.
            pub const JACOBIAN_PATTERN: [(u32, u32); #nnz_lit] = [#(#pattern),*];
            /// The derivation this code was generated from: Φ, Φ_q, Φ_t, Φ_qt,
            /// Φ_tt, (Φ_q q̇)_q q̇, ν and γ, as stable text for snapshot tests.
            pub const DERIVATION: &'static str = #derivation_text;

            /// The derivation as text; see [`Self::DERIVATION`].
            #[must_use]
            pub fn derivation() -> &'static str {
                Self::DERIVATION
            }

            #solver
        }

        #[allow(clippy::approx_constant)]
        impl #rt::System for #name {
            fn len(&self) -> usize {
                #nc_lit
            }

            fn coordinate_name(&self, i: usize) -> &str {
                Self::COORDINATE_NAMES.get(i).copied().unwrap_or("")
            }

            fn equation_name(&self, i: usize) -> &str {
                Self::EQUATION_NAMES.get(i).copied().unwrap_or("")
            }

            fn initial_guess(&self, q: &mut [f64]) {
                let Ok(q) = <&mut [f64; #nc_lit]>::try_from(q) else { return; };
                #guess_body
            }

            fn jacobian_pattern(&self) -> &[(u32, u32)] {
                &Self::JACOBIAN_PATTERN
            }

            fn phi(&mut self, #phi_q: &[f64], #phi_t: f64, out: &mut [f64]) {
                #phi_q_check
                let Ok(out) = <&mut [f64; #nc_lit]>::try_from(out) else { return; };
                #phi_body
            }

            fn jacobian(&mut self, #jac_q: &[f64], #jac_t: f64, out: &mut [f64]) {
                #jac_q_check
                let Ok(out) = <&mut [f64; #nnz_lit]>::try_from(out) else { return; };
                #jac_body
            }

            fn phi_and_jacobian(&mut self, #both_q: &[f64], #both_t: f64, phi: &mut [f64], values: &mut [f64]) {
                #both_q_check
                let Ok(phi) = <&mut [f64; #nc_lit]>::try_from(phi) else { return; };
                let Ok(values) = <&mut [f64; #nnz_lit]>::try_from(values) else { return; };
                #both_body
            }

            fn nu(&mut self, #nu_q: &[f64], #nu_t: f64, out: &mut [f64]) {
                #nu_q_check
                let Ok(out) = <&mut [f64; #nc_lit]>::try_from(out) else { return; };
                #nu_body
            }

            fn gamma(&mut self, #gamma_q: &[f64], #gamma_qd: &[f64], #gamma_t: f64, out: &mut [f64]) {
                #gamma_q_check
                #gamma_qd_check
                let Ok(out) = <&mut [f64; #nc_lit]>::try_from(out) else { return; };
                #gamma_body
            }
        }
    }
}

/// The generated items as formatted Rust source (prettyplease), with a
/// header saying where they came from.
#[must_use]
pub fn generate_source(derivation: &Derivation, options: &Options) -> String {
    let tokens = expand(derivation, options);
    let body = match syn::parse2::<syn::File>(tokens.clone()) {
        Ok(file) => prettyplease::unparse(&file),
        // Cannot happen for well-formed output; keep the raw tokens readable.
        Err(_) => tokens.to_string(),
    };
    format!(
        "// Generated by kinema-codegen from mechanism `{}`. Do not edit: edit the model.\n\n{body}",
        derivation.name
    )
}

/// The mechanism's name as a Rust type name (it already is an identifier).
fn type_name(name: &str) -> String {
    name.to_owned()
}

/// A parameter's name as a field name (raw identifier if it is a keyword).
fn field_name(name: &str) -> Ident {
    syn::parse_str::<Ident>(name).unwrap_or_else(|_| Ident::new_raw(name, Span::call_site()))
}

/// `#[doc]` attributes; each line gets the leading space `///` would have.
fn doc_attrs(docs: &[String]) -> TokenStream {
    docs.iter()
        .map(|d| {
            let line = if d.starts_with(' ') || d.is_empty() {
                d.clone()
            } else {
                format!(" {d}")
            };
            quote!(#[doc = #line])
        })
        .collect()
}
