//! Named access in generated code: index constants of the coordinates
//! (`SliderCrank::SLIDER_X`) and of the result columns
//! (`SliderCrank::OUT_CRANK_PIN_X`), and the named points and measures with
//! their derivatives: `impl Outputs` and an allocation-free `results(&state)`.

use std::collections::HashMap;

use kinema_model::Derivation;
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use crate::emit::{self, Used};

/// A model name as an upper-case constant name (`crank.pin.x` →
/// `CRANK_PIN_X`); `None` when it does not make an identifier.
fn constant_name(prefix: &str, name: &str) -> Option<Ident> {
    let mut s = String::from(prefix);
    for c in name.strip_prefix("r#").unwrap_or(name).chars() {
        match c {
            '.' => s.push('_'),
            c if c.is_alphanumeric() || c == '_' => s.extend(c.to_uppercase()),
            _ => return None,
        }
    }
    let first = s.chars().next()?;
    if !(first.is_alphabetic() || first == '_') || s == "_" {
        return None;
    }
    syn::parse_str::<Ident>(&s).ok()
}

/// Index constants, one per name, left out where two names would give the
/// same constant (or one of the type's own constants).
fn index_constants<'a>(
    prefix: &str,
    names: impl Iterator<Item = &'a str>,
    what: &str,
    taken: &mut HashMap<String, usize>,
) -> Vec<(Ident, usize, String)> {
    let named: Vec<(Option<Ident>, String)> = names
        .map(|n| (constant_name(prefix, n), n.to_string()))
        .collect();
    for (c, _) in &named {
        if let Some(c) = c {
            *taken.entry(c.to_string()).or_default() += 1;
        }
    }
    named
        .into_iter()
        .enumerate()
        .filter_map(|(k, (c, n))| {
            let c = c?;
            (taken.get(&c.to_string()) == Some(&1))
                .then(|| (c, k, format!(" Index of {what} `{n}`.")))
        })
        .collect()
}

/// The index constants of the coordinates and of the result columns (a
/// result's also carries its declaration's doc comment), none that would
/// clash with the type's own constants or with each other.
fn constants(d: &Derivation, sensitivity: &[String]) -> Vec<TokenStream> {
    let mut taken: HashMap<String, usize> = [
        "COORDINATES",
        "COORDINATE_NAMES",
        "EQUATION_NAMES",
        "BODY_NAMES",
        "JACOBIAN_PATTERN",
        "DERIVATION",
        "OUTPUTS",
        "OUTPUT_NAMES",
        "SENSITIVITY_PARAMS",
    ]
    .into_iter()
    .map(|s| (s.to_string(), 1))
    .collect();
    let coordinates = index_constants(
        "",
        d.coordinates.iter().map(|c| c.name.as_str()),
        "the coordinate",
        &mut taken,
    );
    let results = index_constants(
        "OUT_",
        d.outputs.iter().map(|o| o.name.as_str()),
        "the result column",
        &mut taken,
    );
    // A result's constant also carries its declaration's doc comment
    // (units, as for params).
    let results: Vec<(Ident, usize, String)> = results
        .into_iter()
        .map(
            |(c, k, doc)| match d.outputs.get(k).filter(|o| !o.docs.is_empty()) {
                Some(o) => (
                    c,
                    k,
                    format!("{}: {}", doc.trim_end_matches('.'), o.docs.join(" ").trim()),
                ),
                None => (c, k, doc),
            },
        )
        .collect();
    // The columns of the sensitivities (`Sensitivities::coordinates(k)`),
    // in the order the params were chosen.
    let params = index_constants(
        "PARAM_",
        sensitivity.iter().map(String::as_str),
        "the sensitivities' column of the param",
        &mut taken,
    );
    coordinates
        .iter()
        .chain(&results)
        .chain(&params)
        .map(|(c, k, doc)| {
            let k = Literal::usize_unsuffixed(*k);
            quote! { #[doc = #doc] pub const #c: usize = #k; }
        })
        .collect()
}

/// The body of `write_results`: y, ẏ and c into the outputs and the y_q
/// entries into a local `j`, from one schedule; then ÿ = c + Σ y_q q̈ in the
/// order of the entries (as the tape does). With the inputs it reads and
/// the number of y_q entries.
fn results_body(d: &Derivation, params: &[Ident]) -> (TokenStream, Used, usize) {
    let m = d.outputs.len();
    let mut exprs = Vec::with_capacity(3 * m);
    exprs.extend(d.outputs.iter().map(|o| o.value));
    exprs.extend(d.outputs.iter().map(|o| o.velocity));
    exprs.extend(d.outputs.iter().map(|o| o.acceleration));
    let mut sums = Vec::new();
    for (i, o) in d.outputs.iter().enumerate() {
        for &(k, e) in &o.jacobian {
            sums.push((i, k as usize, exprs.len() - 3 * m));
            exprs.push(e);
        }
    }
    let (y, yd, ydd, j) = (
        format_ident!("y"),
        format_ident!("yd"),
        format_ident!("ydd"),
        format_ident!("j"),
    );
    let target = |k: usize| match k / m.max(1) {
        _ if k >= 3 * m => emit::index(&j, k - 3 * m),
        0 => emit::index(&y, k),
        1 => emit::index(&yd, k - m),
        _ => emit::index(&ydd, k - 2 * m),
    };
    let no_cache = |_| None;
    let inputs = emit::Inputs {
        params,
        cached: &no_cache,
        split: None,
    };
    let (body, used) = emit::body(&d.arena, &exprs, &target, &inputs);
    let accumulate = sums.iter().map(|&(i, k, jk)| {
        let (i, k, jk) = (
            Literal::usize_unsuffixed(i),
            Literal::usize_unsuffixed(k),
            Literal::usize_unsuffixed(jk),
        );
        quote! { ydd[#i] += j[#jk] * qdd[#k]; }
    });
    let body = quote! { #body #(#accumulate)* };
    (body, used, sums.len())
}

/// `fn write_results`: the arguments it does not read prefixed `_`, the
/// slices it reads converted once to arrays of n (a wrong length leaves
/// the outputs as they are: NaN), the body of [`results_body`].
fn write_results(d: &Derivation, params: &[Ident]) -> TokenStream {
    let (body, used, nj) = results_body(d, params);
    let m_lit = Literal::usize_unsuffixed(d.outputs.len());
    let nc_lit = Literal::usize_unsuffixed(d.nc());
    let arg = |used: bool, n: &str| {
        if used {
            format_ident!("{}", n)
        } else {
            format_ident!("_{}", n)
        }
    };
    let (q_arg, qd_arg, t_arg) = (arg(used.q, "q"), arg(used.qd, "qd"), arg(used.t, "t"));
    let qdd_arg = arg(nj > 0, "qdd");
    let sized = |n: &Ident, used: bool| {
        if used {
            quote! { let Ok(#n) = <&[f64; #nc_lit]>::try_from(#n) else { return; }; }
        } else {
            quote!()
        }
    };
    let (q_sized, qd_sized, qdd_sized) = (
        sized(&q_arg, used.q),
        sized(&qd_arg, used.qd),
        sized(&qdd_arg, nj > 0),
    );
    let nj_lit = Literal::usize_unsuffixed(nj);
    let j_decl = if nj > 0 {
        quote! { let mut j = [0.0f64; #nj_lit]; }
    } else {
        quote!()
    };
    quote! {
        #[allow(clippy::too_many_arguments, unused_variables)]
        fn write_results(
            &self,
            #t_arg: f64,
            #q_arg: &[f64],
            #qd_arg: &[f64],
            #qdd_arg: &[f64],
            y: &mut [f64; #m_lit],
            yd: &mut [f64; #m_lit],
            ydd: &mut [f64; #m_lit],
        ) {
            #q_sized
            #qd_sized
            #qdd_sized
            #j_decl
            #body
        }
    }
}

/// The constants, `results` and the `Outputs` impl of the mechanism `name`.
pub(crate) fn items(
    d: &Derivation,
    name: &Ident,
    params: &[Ident],
    sensitivity: &[String],
    rt: &syn::Path,
) -> TokenStream {
    let m = d.outputs.len();
    let m_lit = Literal::usize_unsuffixed(m);
    let nc_lit = Literal::usize_unsuffixed(d.nc());
    let consts = constants(d, sensitivity);
    let output_names = d.outputs.iter().map(|o| o.name.as_str());
    let write_results = write_results(d, params);
    let output_kink = crate::checks::output_kink(d, params, rt);
    let m_doc =
        format!(" Number of result columns (named points' components, then measures): {m}.");
    quote! {
        impl #name {
            #(#consts)*
            #[doc = #m_doc]
            pub const OUTPUTS: usize = #m_lit;
            /// Names of the result columns: `body.point.x`, `body.point.y`
            /// per named point, then the measures (`name`, or `name.x`,
            /// `name.y`); the derivatives' columns add `_dot`, `_ddot`.
            pub const OUTPUT_NAMES: [&'static str; #m_lit] = [#(#output_names),*];

            /// The result columns at a solved state: `[y, ẏ, ÿ]`, indexed by
            /// the `OUT_…` constants. No allocation.
            #[must_use]
            pub fn results(&self, state: &#rt::State) -> [[f64; #m_lit]; 3] {
                let mut out = [[f64::NAN; #m_lit]; 3];
                let [y, yd, ydd] = &mut out;
                self.write_results(state.t(), state.q(), state.qd(), state.qdd(), y, yd, ydd);
                out
            }

            #write_results
        }

        impl #rt::Outputs for #name {
            fn output_len(&self) -> usize {
                #m_lit
            }

            #output_kink

            fn output_name(&self, i: usize) -> &str {
                Self::OUTPUT_NAMES.get(i).copied().unwrap_or("")
            }

            fn outputs(
                &self,
                _scratch: &mut Self::Scratch,
                at: #rt::Motion<'_>,
                out: [&mut [f64]; 3],
            ) {
                let #rt::Motion { t, q, qd, qdd } = at;
                let [y, yd, ydd] = out;
                y.fill(f64::NAN);
                yd.fill(f64::NAN);
                ydd.fill(f64::NAN);
                let (Ok(y), Ok(yd), Ok(ydd)) = (
                    <&mut [f64; #m_lit]>::try_from(y),
                    <&mut [f64; #m_lit]>::try_from(yd),
                    <&mut [f64; #m_lit]>::try_from(ydd),
                ) else {
                    return;
                };
                if q.len() != #nc_lit || qd.len() != #nc_lit || qdd.len() != #nc_lit {
                    return;
                }
                self.write_results(t, q, qd, qdd, y, yd, ydd);
            }
        }
    }
}
