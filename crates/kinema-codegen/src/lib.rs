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
//! Beside it comes `SliderCrankLu`, a sparse LU generated for the Jacobian's
//! pattern (module `lu`): the pivot order is chosen at generation time on Φ_q
//! at the initial guess, constants (the ±1 of joint and driver rows) are
//! folded, and the factorization and solves are straight-line code over
//! fixed-size arrays. Each factorization is checked against the runtime's
//! criteria (finite values, pivots above τ · scale, multipliers ≤ 10); when
//! the order does not suit the matrix, the runtime's `DenseLu<N>` (or `Auto`
//! for large systems) held inside takes over, and its partial pivoting gives
//! the singularity verdict and diagnostics. `SliderCrank::solver()` uses it.
//!
//! The struct is plain data — the parameters, nothing else: build it with a
//! struct literal (`SliderCrank { l2: 0.3, ..SliderCrank::default() }` or
//! every field), destructure it, compare it. What one step's evaluations
//! share (module `cache`: sin and cos of the body angles keyed on the exact
//! angle, and the functions of time alone — a driver's `sin(2*t)`, not
//! `sin(omega*t)`, which reads a parameter — keyed on the exact t) is the
//! `System`'s scratch, `SliderCrankCache`, which the solver owns. It never
//! changes a result.
//!
//! Three ways to use it: the `kinema::mechanism!` macro (through
//! [`expand`]), a build script ([`build::generate`], writing a formatted
//! `.rs` file into `OUT_DIR`), and `kinema codegen` on the command line
//! ([`generate_source`]).

mod cache;
mod checks;
mod dynamics;
mod emit;
mod forward;
mod lu;
mod macro_input;
mod outputs;
mod sensitivity;

pub mod build;

pub use macro_input::{expand_macro, expand_macro_with};
pub use sensitivity::SensitivityParams;

use kinema_model::Derivation;
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote};

/// How generated code refers to the runtime.
#[derive(Clone, Debug)]
pub struct Config {
    /// Path of the module holding `System`, `Solver`, `DenseLu`, `SparseLu`,
    /// `Auto`, `Options` and `Error` (default `::kinema::__private`; use
    /// `::kinema_runtime` for an app that depends on the runtime alone).
    pub runtime: syn::Path,
    /// Largest coordinate count for which `solver()` uses the statically
    /// sized dense LU; above it, the size-based automatic choice. (With
    /// [`static_lu`](Self::static_lu), the solver the generated LU falls
    /// back to.)
    pub static_dense_limit: usize,
    /// Generate a sparse LU specialized to the Jacobian's pattern (pivot
    /// order chosen at generation time, straight-line factorization and
    /// solves, runtime fallback) and make `solver()` use it.
    pub static_lu: bool,
    /// Scheduled expression nodes past which an evaluation method (Φ, Φ_q,
    /// ν, γ) or the initial guess is split into private functions of about
    /// this many nodes each, called in order; likewise, counted in
    /// floating-point operations, the generated LU's factorization and each
    /// of its solves. rustc's and LLVM's time on one function grows faster
    /// than its size, and a 1000-body chain's Φ_q as one body took half its
    /// build. The results are the same to the bit (each chunk does the same
    /// operations in the same order, values crossing between chunks through
    /// arrays).
    pub chunk_nodes: usize,
    /// The params whose sensitivities (∂q/∂p, ∂q̇/∂p, ∂q̈/∂p and the
    /// result columns') the generated code evaluates: it then implements
    /// the runtime's `SensitivitySystem` for them
    /// (`solver.sensitivities(&mut out)`) and has an index constant per
    /// param column (`PARAM_L1`, in the order chosen) and
    /// `SENSITIVITY_PARAMS`. Default: none (nothing generated). In
    /// `mechanism!`: `mechanism!(file = "…", sensitivity = ["l1", "l2"])`
    /// or `sensitivity = all`. An unknown name fails the expansion with
    /// the model's params listed.
    pub sensitivity: SensitivityParams,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            runtime: syn::parse_quote!(::kinema::__private),
            static_dense_limit: 24,
            static_lu: true,
            chunk_nodes: emit::CHUNK_NODES,
            sensitivity: SensitivityParams::None,
        }
    }
}

/// The generated items for `derivation` as tokens: the parameter struct
/// with its constants and `solver()`, the `System` impl, the per-step
/// cache and the generated LU.
#[must_use]
pub fn expand(derivation: &Derivation, options: &Config) -> TokenStream {
    let d = derivation;
    // A model with inertia may have free degrees of freedom: its generated
    // code is forward dynamics alone (no kinematic solver, which needs
    // NDOF = 0).
    let forward_only = d.rows.len() != d.nc();
    if forward_only && d.dynamics.is_none() {
        let message = format!(
            "mechanism `{}` has NDOF = {}: generated solvers need NDOF = 0",
            d.name,
            d.dof.ndof()
        );
        return quote!(::core::compile_error!(#message););
    }
    // Sensitivities are of the kinematics: a model with free degrees of
    // freedom has none to generate.
    if forward_only && options.sensitivity != SensitivityParams::None {
        let message = format!(
            "mechanism `{}` has NDOF = {}: sensitivities need NDOF = 0",
            d.name,
            d.dof.ndof()
        );
        return quote!(::core::compile_error!(#message););
    }
    // A bad name is an error beside the rest of the items (generated
    // without sensitivities), so code naming the type gets no follow-on
    // errors.
    let (chosen, sensitivity_error) = match sensitivity::choose(d, &options.sensitivity) {
        Ok(chosen) => (chosen, quote!()),
        Err(e) => {
            let message = format!("mechanism `{}`: sensitivity: {e}", d.name);
            (None, quote!(::core::compile_error!(#message);))
        }
    };
    let name = rust_ident(&type_name(&d.name));
    let params: Vec<Ident> = d.params.iter().map(|p| rust_ident(&p.name)).collect();
    let jac_exprs: Vec<_> = d.phi_q.entries.iter().map(|e| e.expr).collect();
    // sin/cos of the angles and the functions of time, cached per step.
    let everything: Vec<_> = d
        .phi
        .iter()
        .chain(&jac_exprs)
        .chain(&d.nu)
        .chain(&d.gamma)
        .copied()
        .collect();
    let cache = cache::Cache::find(&d.arena, &everything);
    let cache_name = format_ident!("{}Cache", name);
    let cache_items = if cache.is_empty() {
        quote!()
    } else {
        cache.items(&d.arena, (&cache_name, &params), options.chunk_nodes, 0)
    };
    let scratch = if cache.is_empty() {
        quote!(())
    } else {
        quote!(#cache_name)
    };
    // Forward dynamics for models with free degrees of freedom (a fully
    // driven model's motion is its kinematics).
    let forward = if forward_only {
        forward::forward_items(
            d,
            &forward::Names {
                name: &name,
                params: &params,
                scratch: &scratch,
                rt: &options.runtime,
            },
            &cache,
        )
    } else {
        quote!()
    };
    let item = struct_item(d, &name, &params);
    if forward_only {
        let inherent = inherent_items(d, &name, &quote!());
        return quote! {
            #item
            #inherent
            #forward
            #cache_items
        };
    }
    let (solver, lu_items) = solver_items(d, &name, options);
    let inherent = inherent_items(d, &name, &solver);
    let system = system_impl(d, (&name, &scratch), &params, &cache, options);
    let sensitivity_names = chosen.as_ref().map_or(&[][..], |c| c.names());
    let outputs = outputs::items(d, &name, &params, sensitivity_names, &options.runtime);
    let dynamics = dynamics::dynamics_impl(d, &name, &params, &cache, &options.runtime);
    let sensitivities = chosen.as_ref().map(|c| {
        sensitivity::items(
            c,
            (&name, &params),
            &cache,
            (&options.runtime, options.chunk_nodes),
        )
    });
    quote! {
        #sensitivity_error
        #item
        #inherent
        #system
        #outputs
        #sensitivities
        #dynamics
        #forward
        #cache_items
        #lu_items
    }
}

/// The struct: the parameters as public fields (documented from the model)
/// and `Default` from the declared values. Plain data: the per-step cache is
/// the `System`'s scratch, owned by the solver.
fn struct_item(d: &Derivation, name: &Ident, params: &[Ident]) -> TokenStream {
    // Generated items are always documented (users may deny missing_docs).
    let docs = if d.docs.is_empty() {
        doc_attrs(&[format!(
            "The mechanism `{}`, generated by kinema from its model.",
            d.name
        )])
    } else {
        doc_attrs(&d.docs)
    };
    let fields = d.params.iter().zip(params).map(|(p, f)| {
        let docs = if p.docs.is_empty() {
            doc_attrs(&[format!(
                "Parameter `{}` (declared value {}).",
                p.name, p.value
            )])
        } else {
            doc_attrs(&p.docs)
        };
        quote! { #docs pub #f: f64, }
    });
    let defaults = d.params.iter().zip(params).map(|(p, f)| {
        let v = emit::number(p.value).tokens;
        quote! { #f: #v, }
    });
    // A model without parameters has an empty struct, whose `Default` clippy
    // would rather see derived (in a build script's generated file, which
    // clippy lints, unlike the macro's output).
    let derivable = if d.params.is_empty() {
        quote!(#[allow(clippy::derivable_impls)])
    } else {
        quote!()
    };
    quote! {
        #docs
        // Field names are the model's parameter names, as the user wrote them.
        #[allow(non_snake_case)]
        #[derive(Clone, Debug, PartialEq)]
        pub struct #name {
            #(#fields)*
        }

        #derivable
        impl ::core::default::Default for #name {
            fn default() -> Self {
                Self { #(#defaults)* }
            }
        }
    }
}

/// The inherent impl: counts, names, the Jacobian pattern, the derivation
/// text, and `solver()`.
fn inherent_items(d: &Derivation, name: &Ident, solver: &TokenStream) -> TokenStream {
    let nc = d.nc();
    let nc_lit = Literal::usize_unsuffixed(nc);
    let nnz_lit = Literal::usize_unsuffixed(d.phi_q.entries.len());
    let coordinate_names = d.coordinates.iter().map(|c| c.name.as_str());
    let equation_names = d.rows.iter().map(|r| r.name.as_str());
    let nr_lit = Literal::usize_unsuffixed(d.rows.len());
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
    let nc_doc = if d.rows.len() == nc {
        format!(" Number of generalized coordinates (and equations): {nc}.")
    } else {
        format!(" Number of generalized coordinates: {nc}.")
    };
    quote! {
        // Literals are the exact values the derivation computed; some of them
        // happen to be close to named constants.
        #[allow(clippy::approx_constant)]
        impl #name {
            #[doc = #nc_doc]
            pub const COORDINATES: usize = #nc_lit;
            /// Names of the coordinates, `body.x`, `body.y`, `body.phi` per body.
            pub const COORDINATE_NAMES: [&'static str; #nc_lit] = [#(#coordinate_names),*];
            /// Names of the equations: kinematic constraints, then drivers.
            pub const EQUATION_NAMES: [&'static str; #nr_lit] = [#(#equation_names),*];
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
    }
}

/// The body of one generated `System` method and the inputs it reads.
struct Method {
    body: TokenStream,
    used: emit::Used,
    /// Whether the body reads or refreshes the scratch (the cache).
    scratch: bool,
}

impl Method {
    /// An argument's name: `name`, or `_name` when the body ignores it.
    fn arg(used: bool, name: &str) -> Ident {
        if used {
            format_ident!("{}", name)
        } else {
            format_ident!("_{}", name)
        }
    }

    /// The method's whole body. Every slice's length is checked first: a
    /// wrong one fills the outputs with NaN and returns (the trait's one
    /// behaviour for wrong lengths, so the caller sees non-finite values).
    /// Then each slice the body reads becomes a fixed-size array once, after
    /// which indexing cannot panic.
    fn wrap(&self, inputs: &[(&str, bool, usize)], outputs: &[(&str, usize)]) -> TokenStream {
        let lengths = inputs
            .iter()
            .map(|&(name, _, len)| (name, len))
            .chain(outputs.iter().copied())
            .map(|(name, len)| {
                let (n, len) = (format_ident!("{}", name), Literal::usize_unsuffixed(len));
                quote!(#n.len() != #len)
            });
        let fills = outputs.iter().map(|&(name, _)| {
            let n = format_ident!("{}", name);
            quote!(#n.fill(f64::NAN);)
        });
        let sized_outputs = outputs.iter().map(|&(name, len)| {
            let (n, len) = (format_ident!("{}", name), Literal::usize_unsuffixed(len));
            quote! { let Ok(#n) = <&mut [f64; #len]>::try_from(#n) else { return; }; }
        });
        let sized_inputs = inputs.iter().filter(|i| i.1).map(|&(name, _, len)| {
            let (n, len) = (format_ident!("{}", name), Literal::usize_unsuffixed(len));
            quote! { let Ok(#n) = <&[f64; #len]>::try_from(#n) else { return; }; }
        });
        let body = &self.body;
        quote! {
            if #(#lengths)||* {
                #(#fills)*
                return;
            }
            #(#sized_outputs)*
            #(#sized_inputs)*
            #body
        }
    }
}

/// The initial guess's statements (parameters only, no cache), writing `q`,
/// and the chunk functions they call when the guesses schedule more than
/// `chunk_nodes` nodes (a 1000-body chain's 3000 guesses were one of its
/// largest functions).
fn guess_body(
    d: &Derivation,
    params: &[Ident],
    (rt, chunk_nodes): (&syn::Path, usize),
) -> (TokenStream, Vec<TokenStream>) {
    let q = format_ident!("q");
    let no_cache = |_| None;
    let inputs = emit::Inputs {
        params,
        cached: &no_cache,
        split: None,
    };
    let guesses: Vec<_> = d.coordinates.iter().map(|c| c.guess).collect();
    let target = |k| emit::index(&q, k);
    let ranges = emit::chunks(&d.arena, &guesses, &|_| false, chunk_nodes);
    if ranges.len() > 1 {
        let nc = d.nc();
        let chunk = Chunk {
            label: "initial_guess",
            nc,
            places: &[("q", nc)],
            scratch: false,
            rt,
        };
        let (body, _, helpers) = chunk.emit(&d.arena, &guesses, &ranges, &target, &inputs);
        (body, helpers)
    } else {
        (
            emit::body(&d.arena, &guesses, &target, &inputs).0,
            Vec::new(),
        )
    }
}

/// The evaluation methods' bodies: Φ, Φ_q, both at once (one schedule, so
/// sin/cos are computed once per body), ν and γ, each refreshing the cache
/// it reads first; and the chunk functions that the bodies (and refreshes,
/// [`cache::Cache::refresh_split`]) of a large model call ([`Chunk`]; `rt`
/// is the runtime's path, for their scratch type).
fn evaluation_methods(
    d: &Derivation,
    params: &[Ident],
    cache: &cache::Cache,
    (rt, chunk_nodes): (&syn::Path, usize),
) -> ([Method; 5], Vec<TokenStream>) {
    let a = &d.arena;
    let nc = d.nc();
    let nnz = d.phi_q.entries.len();
    let out = format_ident!("out");
    let to_out = |k: usize| emit::index(&out, k);
    let jac_exprs: Vec<_> = d.phi_q.entries.iter().map(|e| e.expr).collect();
    let lookup = |e| cache.lookup(e);
    let inputs = emit::Inputs {
        params,
        cached: &lookup,
        split: None,
    };
    let method = |label: &str,
                  outputs: &[kinema_expr::ExprId],
                  target: &dyn Fn(usize) -> TokenStream,
                  places: &[(&str, usize)]| {
        // A check is about four nodes: a comparison, a store, a `sin_cos`.
        let split = cache::Split {
            label,
            checks: (chunk_nodes / 4).max(1),
            nc,
            rt,
        };
        let mut helpers = Vec::new();
        let (refresh, reads_q, reads_t) = cache.refresh_split(a, outputs, &split, &mut helpers);
        let stop = |e| cache.lookup(e).is_some();
        let ranges = emit::chunks(a, outputs, &stop, chunk_nodes);
        let scratch = reads_q || reads_t;
        let (body, mut used, chunks) = if ranges.len() > 1 {
            let chunk = Chunk {
                label,
                nc,
                places,
                scratch,
                rt,
            };
            chunk.emit(a, outputs, &ranges, target, &inputs)
        } else {
            let (body, used) = emit::body(a, outputs, target, &inputs);
            (body, used, Vec::new())
        };
        used.q |= reads_q;
        used.t |= reads_t;
        helpers.extend(chunks);
        let method = Method {
            body: quote!(#refresh #body),
            used,
            scratch,
        };
        (method, helpers)
    };
    let both_exprs: Vec<_> = d.phi.iter().chain(&jac_exprs).copied().collect();
    let (phi_name, values_name) = (format_ident!("phi"), format_ident!("values"));
    let to_both = |k: usize| {
        if k < nc {
            emit::index(&phi_name, k)
        } else {
            emit::index(&values_name, k - nc)
        }
    };
    let (phi, mut helpers) = method("phi", &d.phi, &to_out, &[("out", nc)]);
    let mut more = |(m, h): (Method, Vec<TokenStream>)| {
        helpers.extend(h);
        m
    };
    let jac = more(method("jacobian", &jac_exprs, &to_out, &[("out", nnz)]));
    let both = more(method(
        "phi_and_jacobian",
        &both_exprs,
        &to_both,
        &[("phi", nc), ("values", nnz)],
    ));
    let nu = more(method("nu", &d.nu, &to_out, &[("out", nc)]));
    let gamma = more(method("gamma", &d.gamma, &to_out, &[("out", nc)]));
    ([phi, jac, both, nu, gamma], helpers)
}

/// A large method's body split over private `#[inline(never)]` methods,
/// one per range of its outputs ([`emit::chunks`]), so that no generated
/// function is too large for LLVM's linear regime. Each chunk function
/// takes what the method's body has after [`Method::wrap`] (fixed-size
/// arrays, `t`, the scratch read-only) under the same names, so the emitted
/// statements are the same as in one body.
struct Chunk<'a> {
    /// The method's name, in the chunk functions' names.
    label: &'a str,
    nc: usize,
    /// The output arrays: (name, length).
    places: &'a [(&'a str, usize)],
    /// Whether the body reads the scratch (the cache).
    scratch: bool,
    rt: &'a syn::Path,
}

impl Chunk<'_> {
    /// The method's body (calls of the chunk functions, in order), the
    /// inputs it reads, and the chunk functions.
    fn emit(
        &self,
        a: &kinema_expr::Arena,
        outputs: &[kinema_expr::ExprId],
        ranges: &[std::ops::Range<usize>],
        target: &dyn Fn(usize) -> TokenStream,
        inputs: &emit::Inputs<'_>,
    ) -> (TokenStream, emit::Used, Vec<TokenStream>) {
        let mut used = emit::Used::default();
        let bodies: Vec<TokenStream> = ranges
            .iter()
            .map(|r| {
                let (body, u) =
                    emit::body(a, &outputs[r.clone()], &|k| target(r.start + k), inputs);
                used.q |= u.q;
                used.qd |= u.qd;
                used.t |= u.t;
                body
            })
            .collect();
        let nc = Literal::usize_unsuffixed(self.nc);
        let rt = self.rt;
        let mut params = Vec::new();
        let mut args = Vec::new();
        let mut input = |on: bool, name: &str, ty: TokenStream| {
            if on {
                let n = format_ident!("{}", name);
                params.push(quote!(#n: #ty));
                args.push(quote!(#n));
            }
        };
        input(used.q, "q", quote!(&[f64; #nc]));
        input(used.qd, "qd", quote!(&[f64; #nc]));
        input(used.t, "t", quote!(f64));
        input(
            self.scratch,
            "scratch",
            quote!(&<Self as #rt::System>::Scratch),
        );
        for &(name, len) in self.places {
            let len = Literal::usize_unsuffixed(len);
            input(true, name, quote!(&mut [f64; #len]));
        }
        let mut calls = TokenStream::new();
        let mut helpers = Vec::with_capacity(bodies.len());
        for (i, body) in bodies.iter().enumerate() {
            let name = format_ident!("__kinema_{}_{}", self.label, i);
            calls.extend(quote!(self.#name(#(#args),*);));
            helpers.push(quote! {
                #[inline(never)]
                #[allow(unused_variables, clippy::too_many_arguments)]
                fn #name(&self, #(#params),*) {
                    #body
                }
            });
        }
        (calls, used, helpers)
    }
}

/// `impl System`: the evaluation methods as straight-line code over the
/// scratch (the cache), plus names, pattern and initial guess. `types` is
/// the mechanism's type and its scratch type.
fn system_impl(
    d: &Derivation,
    types: (&Ident, &TokenStream),
    params: &[Ident],
    cache: &cache::Cache,
    options: &Config,
) -> TokenStream {
    let rt = &options.runtime;
    let (name, scratch_type) = types;
    let nc = d.nc();
    let nc_lit = Literal::usize_unsuffixed(nc);
    let nnz = d.phi_q.entries.len();
    let (guess, mut helpers) = guess_body(d, params, (rt, options.chunk_nodes));
    let ([phi, jac, both, nu, gamma], methods) =
        evaluation_methods(d, params, cache, (rt, options.chunk_nodes));
    helpers.extend(methods);
    let chunks = if helpers.is_empty() {
        quote!()
    } else {
        quote! {
            #[allow(clippy::approx_constant)]
            impl #name {
                #(#helpers)*
            }
        }
    };
    let args = |m: &Method| {
        (
            Method::arg(m.scratch, "scratch"),
            Method::arg(m.used.t, "t"),
        )
    };
    let (phi_s, phi_t) = args(&phi);
    let (jac_s, jac_t) = args(&jac);
    let (both_s, both_t) = args(&both);
    let (nu_s, nu_t) = args(&nu);
    let (gamma_s, gamma_t) = args(&gamma);
    let phi_body = phi.wrap(&[("q", phi.used.q, nc)], &[("out", nc)]);
    let jac_body = jac.wrap(&[("q", jac.used.q, nc)], &[("out", nnz)]);
    let both_body = both.wrap(&[("q", both.used.q, nc)], &[("phi", nc), ("values", nnz)]);
    let nu_body = nu.wrap(&[("q", nu.used.q, nc)], &[("out", nc)]);
    let gamma_body = gamma.wrap(
        &[("q", gamma.used.q, nc), ("qd", gamma.used.qd, nc)],
        &[("out", nc)],
    );
    let checks = checks::methods(d, params, rt);
    let scratch_fn = if cache.is_empty() {
        quote!(
            fn scratch(&self) -> Self::Scratch {}
        )
    } else {
        quote! {
            fn scratch(&self) -> Self::Scratch {
                ::core::default::Default::default()
            }
        }
    };
    quote! {
        #[allow(clippy::approx_constant)]
        impl #rt::System for #name {
            type Scratch = #scratch_type;

            #scratch_fn

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
                if q.len() != #nc_lit {
                    q.fill(f64::NAN);
                    return;
                }
                let Ok(q) = <&mut [f64; #nc_lit]>::try_from(q) else { return; };
                #guess
            }

            fn jacobian_pattern(&self) -> &[(u32, u32)] {
                &Self::JACOBIAN_PATTERN
            }

            fn phi(&self, #phi_s: &mut Self::Scratch, q: &[f64], #phi_t: f64, out: &mut [f64]) {
                #phi_body
            }

            fn jacobian(&self, #jac_s: &mut Self::Scratch, q: &[f64], #jac_t: f64, out: &mut [f64]) {
                #jac_body
            }

            fn phi_and_jacobian(&self, #both_s: &mut Self::Scratch, q: &[f64], #both_t: f64, phi: &mut [f64], values: &mut [f64]) {
                #both_body
            }

            fn nu(&self, #nu_s: &mut Self::Scratch, q: &[f64], #nu_t: f64, out: &mut [f64]) {
                #nu_body
            }

            fn gamma(&self, #gamma_s: &mut Self::Scratch, q: &[f64], qd: &[f64], #gamma_t: f64, out: &mut [f64]) {
                #gamma_body
            }

            #checks
        }

        #chunks
    }
}

/// `solver()`, the `{Name}Solver` type alias it returns, and the generated
/// LU it uses (if one is generated): the
/// generated LU when `options.static_lu` and a usable pivot order exists,
/// else a dense LU sized at compile time up to `static_dense_limit`
/// coordinates, else the runtime's automatic choice.
fn solver_items(d: &Derivation, name: &Ident, options: &Config) -> (TokenStream, TokenStream) {
    let rt = &options.runtime;
    let alias = solver_alias(name);
    let nc = d.nc();
    let nc_lit = Literal::usize_unsuffixed(nc);
    let fallback = if nc <= options.static_dense_limit {
        quote!(#rt::DenseLu<#nc_lit>)
    } else {
        quote!(#rt::Auto)
    };
    let plan = options
        .static_lu
        .then(|| static_lu_plan(d))
        .flatten()
        .map(|plan| plan.split_above(options.chunk_nodes));
    let (lu_type, lu_items, doc) = match plan {
        Some(plan) => {
            let lu_name = format_ident!("{}Lu", name);
            let items = plan.emit(&lu::Names {
                rt,
                ty: &lu_name,
                system: name,
                fallback,
            });
            let line = format!(
                " velocity and acceleration, with [`{lu_name}`], the LU generated for this"
            );
            let doc = quote! {
                #[doc = #line]
                /// Jacobian's pattern.
            };
            (quote!(#lu_name), items, doc)
        }
        None if nc <= options.static_dense_limit => (
            fallback,
            quote!(),
            quote! {
                /// velocity and acceleration, with a dense LU sized at compile time.
            },
        ),
        None => (
            fallback,
            quote!(),
            quote! {
                /// velocity and acceleration, with a sparse LU whose symbolic
                /// analysis is done once.
            },
        ),
    };
    let solver = quote! {
        /// The solver for this mechanism: Newton–Raphson position analysis,
        #doc
        ///
        /// # Errors
        /// If the runtime rejects the Jacobian pattern (it cannot for
        /// generated code).
        pub fn solver(self, options: #rt::Options) -> ::core::result::Result<#alias, #rt::Error> {
            #rt::Solver::with_options(self, options)
        }
    };
    let alias_doc =
        format!(" The solver [`{name}::solver`] returns: [`{name}`] with its linear solver.");
    let lu_items = quote! {
        #[doc = #alias_doc]
        pub type #alias = #rt::Solver<#name, #lu_type>;
        #lu_items
    };
    (solver, lu_items)
}

/// The name of the generated solver type alias: `SliderCrankSolver`.
pub(crate) fn solver_alias(name: &Ident) -> Ident {
    format_ident!("{}Solver", name)
}

/// The generated LU's plan: Φ_q's pattern, which entries are numbers, and
/// their values at the initial guess with the default parameters (t = 0).
fn static_lu_plan(d: &Derivation) -> Option<lu::Plan> {
    use kinema_expr::SymKind;
    let a = &d.arena;
    let params: Vec<f64> = d.params.iter().map(|p| p.value).collect();
    let value = |q: &[f64], s: kinema_expr::SymId| -> f64 {
        match a.symbol(s).kind {
            SymKind::Parameter(i) => *params
                .get(i as usize)
                .expect("every parameter symbol of a derivation is a declared param"),
            // Guesses read parameters only (the checker refuses coordinates
            // there), so with q = [] this arm is reached for Φ_q alone.
            SymKind::Coordinate(i) => *q
                .get(i as usize)
                .expect("guesses do not read coordinates; Φ_q reads them at the guess"),
            SymKind::Velocity(_) | SymKind::Time => 0.0,
        }
    };
    let guesses: Vec<_> = d.coordinates.iter().map(|c| c.guess).collect();
    let q = a.eval_many(&guesses, |s| value(&[], s));
    let exprs: Vec<_> = d.phi_q.entries.iter().map(|e| e.expr).collect();
    let values = a.eval_many(&exprs, |s| value(&q, s));
    let pattern: Vec<_> = d
        .phi_q
        .entries
        .iter()
        .map(|e| (e.row, e.col, a.as_num(e.expr)))
        .collect();
    lu::Plan::new(d.nc(), &pattern, &values)
}

/// The generated items as formatted Rust source (prettyplease), with a
/// header saying where they came from.
#[must_use]
pub fn generate_source(derivation: &Derivation, options: &Config) -> String {
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

/// A model name (a mechanism's, a parameter's) as a Rust identifier: as it
/// is when it is one (`crank`, or `r#type` written raw), raw when it is a
/// keyword (`type` → `r#type`), and with a trailing `_` for the few
/// keywords that cannot be raw (`self`, `Self`, `super`, `crate`, `_`).
fn rust_ident(name: &str) -> Ident {
    if let Ok(ident) = syn::parse_str::<Ident>(name) {
        return ident;
    }
    let plain = name.strip_prefix("r#").unwrap_or(name);
    let word = plain.chars().enumerate().all(|(i, c)| {
        c == '_'
            || if i == 0 {
                c.is_alphabetic()
            } else {
                c.is_alphanumeric()
            }
    });
    match plain {
        "self" | "Self" | "super" | "crate" | "_" => format_ident!("{}_", plain),
        _ if word && !plain.is_empty() => Ident::new_raw(plain, Span::call_site()),
        // Not an identifier at all (the model language never gives one):
        // every other character made `_`, so the item still compiles.
        _ => {
            let cleaned: String = plain
                .chars()
                .map(|c| if c.is_alphanumeric() { c } else { '_' })
                .collect();
            format_ident!("_{}", cleaned)
        }
    }
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

#[cfg(test)]
mod tests {
    use crate::{build::derive_source, emit};

    /// What chunking costs at run time: the nodes that two chunks of one
    /// method both compute. On the chain N = 1000 (the model chunking is
    /// for) every method is split, and the chunks together compute under
    /// 1 % more operations than the method as one body.
    #[test]
    fn chunks_of_a_long_chain_share_almost_nothing() {
        let d = derive_source(&kinema_model::chain::chain_kin(1000), "chain1000.kin")
            .expect("the chain derives");
        let jacobian: Vec<_> = d.phi_q.entries.iter().map(|e| e.expr).collect();
        let both: Vec<_> = d.phi.iter().chain(&jacobian).copied().collect();
        let everything: Vec<_> = both.iter().chain(&d.nu).chain(&d.gamma).copied().collect();
        let cache = crate::cache::Cache::find(&d.arena, &everything);
        let stop = |e| cache.lookup(e).is_some();
        // Operations: numbers and symbols are read, not computed.
        let operations = |outputs: &[kinema_expr::ExprId]| {
            emit::reachable(&d.arena, outputs, &stop)
                .into_iter()
                .filter(|&e| {
                    !stop(e)
                        && !matches!(
                            d.arena.node(e),
                            kinema_expr::NodeRef::Num(_) | kinema_expr::NodeRef::Sym(_)
                        )
                })
                .count()
        };
        for outputs in [&d.phi, &jacobian, &both, &d.nu, &d.gamma] {
            let whole = operations(outputs);
            let ranges = emit::chunks(&d.arena, outputs, &stop, emit::CHUNK_NODES);
            assert!(ranges.len() > 1, "{whole} nodes in one chunk");
            let chunked: usize = ranges.iter().map(|r| operations(&outputs[r.clone()])).sum();
            assert!(
                chunked as f64 <= 1.01 * whole as f64,
                "{chunked} nodes in {} chunks against {whole}",
                ranges.len()
            );
            let sizes = ranges
                .iter()
                .map(|r| emit::reachable(&d.arena, &outputs[r.clone()], &stop).len());
            assert!(sizes.into_iter().all(|s| s <= emit::CHUNK_NODES));
        }
    }
}
