//! What `kinema::mechanism!` does, as ordinary functions on `proc_macro2`
//! tokens (the proc-macro crate only forwards here, so all of it is testable
//! without rustc).
//!
//! Two forms:
//! ```text
//! mechanism! { mechanism SliderCrank { … } }      // the model inline
//! mechanism!(file = "models/slider_crank.kin")     // a model file (see `resolve`)
//! mechanism!(file = "models/slider_crank.kin", sensitivity = ["l1", "l2"])
//! mechanism!(file = "models/slider_crank.kin", sensitivity = all)
//! ```
//!
//! `sensitivity` (file form) chooses the params whose sensitivities the
//! generated code evaluates ([`Config::sensitivity`]).
//! Errors become `compile_error!`s — all of them, each at its span (inline
//! form) or at the file literal with the rendered `file:line:col` snippet
//! (file form) — followed by a stub of the mechanism's type so that the
//! user's code that names it does not add follow-on errors.

use std::path::PathBuf;

use kinema_model::{Derived, Parsed, Severity, Source};
use proc_macro2::{Span, TokenStream, TokenTree};
use quote::quote;

use crate::{Config, SensitivityParams, expand};

/// Expands the macro input. Never fails: errors are returned as
/// `compile_error!` tokens.
#[must_use]
pub fn expand_macro(input: TokenStream) -> TokenStream {
    expand_macro_with(input, &Config::default())
}

/// [`expand_macro`] with explicit [`Config`].
#[must_use]
pub fn expand_macro_with(input: TokenStream, options: &Config) -> TokenStream {
    match file_form(&input) {
        Some(Ok(form)) => {
            let mut options = options.clone();
            if let Some(sensitivity) = form.sensitivity {
                options.sensitivity = sensitivity;
            }
            expand_file(&form.path, form.span, &options)
        }
        Some(Err(e)) => e.to_compile_error(),
        None => expand_inline(input, options),
    }
}

/// The file form's arguments.
struct FileForm {
    path: String,
    span: Span,
    sensitivity: Option<SensitivityParams>,
}

impl syn::parse::Parse for FileForm {
    fn parse(input: syn::parse::ParseStream<'_>) -> syn::Result<Self> {
        let lit: syn::LitStr = input.parse().map_err(|e| {
            syn::Error::new(
                e.span(),
                "expected a string literal: `mechanism!(file = \"models/my_model.kin\")`",
            )
        })?;
        let mut sensitivity = None;
        while !input.is_empty() {
            input.parse::<syn::Token![,]>()?;
            if input.is_empty() {
                break;
            }
            let key: syn::Ident = input.parse()?;
            input.parse::<syn::Token![=]>()?;
            if key != "sensitivity" || sensitivity.is_some() {
                return Err(syn::Error::new(
                    key.span(),
                    format!(
                        "unexpected `{key}`: the file form takes `file = \"…\"` and \
                         optionally `sensitivity = [\"p1\", \"p2\"]` or `sensitivity = all`, once"
                    ),
                ));
            }
            sensitivity = Some(if input.peek(syn::token::Bracket) {
                let content;
                syn::bracketed!(content in input);
                let names = content
                    .parse_terminated(<syn::LitStr as syn::parse::Parse>::parse, syn::Token![,])?;
                SensitivityParams::Named(names.iter().map(syn::LitStr::value).collect())
            } else {
                let all: syn::Ident = input.parse()?;
                if all != "all" {
                    return Err(syn::Error::new(
                        all.span(),
                        "expected `all` or a list of param names: `sensitivity = [\"l1\", \"l2\"]`",
                    ));
                }
                SensitivityParams::All
            });
        }
        Ok(FileForm {
            path: lit.value(),
            span: lit.span(),
            sensitivity,
        })
    }
}

/// `file = "…"` (and its options) if that is the input's form.
fn file_form(input: &TokenStream) -> Option<syn::Result<FileForm>> {
    let mut it = input.clone().into_iter();
    match (it.next(), it.next()) {
        (Some(TokenTree::Ident(i)), Some(TokenTree::Punct(p)))
            if i == "file" && p.as_char() == '=' => {}
        _ => return None,
    }
    let rest: TokenStream = it.collect();
    Some(syn::parse2::<FileForm>(rest))
}

fn expand_inline(input: TokenStream, options: &Config) -> TokenStream {
    match Parsed::from_tokens(input.clone()).and_then(Parsed::derive_at_tokens) {
        Ok(derived) => expand(derived.derivation(), options),
        Err(diagnostics) => {
            let errors: TokenStream = diagnostics
                .iter()
                .filter(|d| d.severity == Severity::Error)
                .map(|d| d.to_syn_error().to_compile_error())
                .collect();
            let stub = stub(mechanism_name(&input), options);
            quote! { #errors #stub }
        }
    }
}

fn expand_file(path: &str, span: Span, options: &Config) -> TokenStream {
    let full = resolve(path, span);
    // Messages name the file as written in the macro call.
    let source = match Source::read_as(&full, path) {
        Ok(source) => source,
        Err(report) => {
            let rendered = report.render_each().join("\n");
            return syn::Error::new(span, rendered.trim_end()).to_compile_error();
        }
    };
    // Rebuild whenever the model file changes.
    let full_str = full.display().to_string();
    let track = quote! { const _: &[u8] = ::core::include_bytes!(#full_str); };
    // Inside a proc macro, text parsed by proc-macro2 would get compiler spans
    // that all point at the macro call. The fallback implementation keeps
    // the file's own lines and columns, which is what the messages need;
    // only strings and the span-free derivation leave this block.
    proc_macro2::fallback::force();
    let name = source
        .text()
        .parse::<TokenStream>()
        .ok()
        .and_then(|t| mechanism_name(&t))
        .map(|i| i.to_string());
    let outcome = match Derived::from_source(source) {
        Ok(derived) => Ok(derived.into_parts().1),
        Err(report) => {
            let renderer = report.renderer();
            let mut messages: Vec<String> = report
                .entries()
                .iter()
                .filter(|d| d.severity == Severity::Error)
                .map(|d| {
                    let rendered = renderer.render(d);
                    // rustc prints its own "error: " before the message.
                    rendered
                        .strip_prefix("error: ")
                        .map_or(rendered.clone(), str::to_owned)
                })
                .collect();
            let kept = messages.len();
            let total = report.error_count();
            if total > kept {
                messages.push(format!(
                    "… and {} more errors in `{path}` not shown",
                    total - kept
                ));
            }
            Err(messages)
        }
    };
    proc_macro2::fallback::unforce();
    match outcome {
        Ok(derivation) => {
            let items = expand(&derivation, options);
            quote! { #track #items }
        }
        Err(messages) => {
            let errors: TokenStream = messages
                .iter()
                .map(|m| syn::Error::new(span, m).to_compile_error())
                .collect();
            let name = name.and_then(|n| syn::parse_str::<syn::Ident>(&n).ok());
            let stub = stub(name, options);
            quote! { #track #errors #stub }
        }
    }
}

/// The model file: relative to the crate root (`CARGO_MANIFEST_DIR`), or,
/// if no such file exists, relative to the directory of the source file that
/// invokes the macro (as `include_str!` resolves paths). Absolute either
/// way: the generated `include_bytes!` that tracks the file resolves a
/// relative path against the invoking source file, while
/// [`Span::local_file`] is relative to the compiler's working directory.
fn resolve(path: &str, span: Span) -> PathBuf {
    let root =
        std::env::var_os("CARGO_MANIFEST_DIR").map_or_else(|| PathBuf::from("."), PathBuf::from);
    let from_root = root.join(path);
    if from_root.exists() {
        return from_root;
    }
    span.local_file()
        .and_then(|f| f.parent().map(|dir| dir.join(path)))
        .filter(|p| p.exists())
        .map(|p| std::path::absolute(&p).unwrap_or(p))
        .unwrap_or(from_root)
}

/// The identifier after the leading `mechanism` keyword, if any.
fn mechanism_name(input: &TokenStream) -> Option<syn::Ident> {
    let mut it = input
        .clone()
        .into_iter()
        .skip_while(|t| !matches!(t, TokenTree::Ident(i) if i == "mechanism"));
    it.next()?;
    match it.next() {
        Some(TokenTree::Ident(i)) => Some(i),
        _ => None,
    }
}

/// A stand-in for the mechanism's type when the model has errors: it has the
/// generated type's API, so the user sees the model's errors and not a
/// cascade of "cannot find type" errors.
fn stub(name: Option<syn::Ident>, options: &Config) -> TokenStream {
    let Some(name) = name else {
        return TokenStream::new();
    };
    let rt = &options.runtime;
    let alias = crate::solver_alias(&name);
    quote! {
        #[derive(Clone, Debug, Default, PartialEq)]
        pub struct #name {}
        pub type #alias = #rt::Solver<#name, #rt::Auto>;
        impl #name {
            pub const DERIVATION: &'static str = "";
            pub fn derivation() -> &'static str { "" }
            pub fn solver(self, options: #rt::Options) -> ::core::result::Result<#alias, #rt::Error> {
                #rt::Solver::with_options(self, options)
            }
        }
        impl #rt::System for #name {
            type Scratch = ();
            fn scratch(&self) {}
            fn len(&self) -> usize { 0 }
            fn coordinate_name(&self, _i: usize) -> &str { "" }
            fn equation_name(&self, _i: usize) -> &str { "" }
            fn initial_guess(&self, _q: &mut [f64]) {}
            fn jacobian_pattern(&self) -> &[(u32, u32)] { &[] }
            fn phi(&self, _scratch: &mut (), _q: &[f64], _t: f64, _out: &mut [f64]) {}
            fn jacobian(&self, _scratch: &mut (), _q: &[f64], _t: f64, _out: &mut [f64]) {}
            fn nu(&self, _scratch: &mut (), _q: &[f64], _t: f64, _out: &mut [f64]) {}
            fn gamma(&self, _scratch: &mut (), _q: &[f64], _qd: &[f64], _t: f64, _out: &mut [f64]) {}
        }
    }
}
