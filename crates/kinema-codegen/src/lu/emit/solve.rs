//! The generated solves: forward then backward substitution, and the
//! transposed pair, straight-line or split into helper functions past a
//! budget of operations.

use std::collections::BTreeMap;

use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

use super::super::{MAX_LETS, Plan, Val};
use super::{Stmts, lit, split};

impl Plan {
    /// Forward then backward substitution on `b` (a `[f64; n]`), reading
    /// stored run-time values from `f`; past `chunk_ops` operations, in
    /// functions `__kinema_solve_{i}(b, f, y)` pushed onto `helpers`.
    pub(super) fn emit_solve(
        &self,
        stored: &BTreeMap<u32, usize>,
        helpers: &mut Vec<TokenStream>,
    ) -> TokenStream {
        let n = self.n;
        // Each of the n rows is a statement forward, backward and in the
        // copy out, plus a term per entry of L and U.
        let chunked = 3 * n + self.lower.len() + self.upper.len() > self.chunk_ops;
        // Values crossing from one function to the next are in `y`.
        let large = n > MAX_LETS / 2 || chunked;
        let read = |v: Val| -> Result<TokenStream, f64> {
            match v {
                Val::Const(c) => Err(c),
                Val::Var(x) => {
                    let slot = stored
                        .get(&x)
                        .copied()
                        .expect("every run-time value the solves read is stored (Plan::stored)");
                    let slot = Literal::usize_unsuffixed(slot);
                    Ok(quote!(f[#slot]))
                }
            }
        };
        let y = |k: usize| -> TokenStream {
            if large {
                let k = Literal::usize_unsuffixed(k);
                quote!(y[#k])
            } else {
                let id = format_ident!("y{}", k);
                quote!(#id)
            }
        };
        // Terms −Σ c·x: `- c * x`, with ±1 folded.
        let minus_terms = |terms: &[(Val, TokenStream)]| -> TokenStream {
            let mut out = TokenStream::new();
            for (c, x) in terms {
                out.extend(match read(*c) {
                    Ok(v) => quote!(- #v * #x),
                    Err(1.0) => quote!(- #x),
                    Err(-1.0) => quote!(+ #x),
                    Err(0.0) => quote!(),
                    Err(k) if k < 0.0 => {
                        let k = lit(-k);
                        quote!(+ #k * #x)
                    }
                    Err(k) => {
                        let k = lit(k);
                        quote!(- #k * #x)
                    }
                });
            }
            out
        };
        let mut l_rows: Vec<Vec<(Val, usize)>> = vec![Vec::new(); n];
        for &(i, k, l) in &self.lower {
            l_rows[i].push((l, k));
        }
        let mut u_rows: Vec<Vec<(Val, usize)>> = vec![Vec::new(); n];
        for &(k, j, u) in &self.upper {
            u_rows[k].push((u, j));
        }
        let n_lit = Literal::usize_unsuffixed(n);
        let mut out = TokenStream::new();
        if large {
            out.extend(quote!(let mut y = [0.0f64; #n_lit];));
        }
        let mut stmts = Stmts::new();
        // Forward: y_i = b[p_i] − Σ_k l_ik y_k.
        for (i, (l_row, &r)) in l_rows.iter().zip(&self.row_order).enumerate() {
            let r = Literal::usize_unsuffixed(r);
            let terms: Vec<(Val, TokenStream)> = l_row.iter().map(|&(l, k)| (l, y(k))).collect();
            let rest = minus_terms(&terms);
            let place = y(i);
            let stmt = if large {
                quote!(#place = b[#r] #rest;)
            } else {
                quote!(let #place = b[#r] #rest;)
            };
            stmts.push((stmt, 1 + terms.len()));
        }
        // Backward: x_k = (y_k − Σ_j u_kj x_j) / u_kk, into y_k.
        for k in (0..n).rev() {
            let terms: Vec<(Val, TokenStream)> =
                u_rows[k].iter().map(|&(u, j)| (u, y(j))).collect();
            let rest = minus_terms(&terms);
            let yk = y(k);
            let sum = if terms.is_empty() {
                quote!(#yk)
            } else {
                quote!((#yk #rest))
            };
            let value = match read(self.inv[k]) {
                Ok(v) => quote!(#sum * #v),
                Err(1.0) => sum,
                Err(-1.0) => quote!(-#sum),
                Err(c) => {
                    let c = lit(c);
                    quote!(#sum * #c)
                }
            };
            let ops = 1 + terms.len();
            if terms.is_empty() && matches!(self.inv[k], Val::Const(c) if c == 1.0) {
                // y_k is already x_k.
            } else if large {
                stmts.push((quote!(#yk = #value;), ops));
            } else {
                stmts.push((quote!(let #yk = #value;), ops));
            }
        }
        for k in 0..n {
            let c = Literal::usize_unsuffixed(self.col_order[k]);
            let yk = y(k);
            stmts.push((quote!(b[#c] = #yk;), 1));
        }
        let nf = Literal::usize_unsuffixed(stored.len().max(1));
        out.extend(split(
            "solve",
            stmts,
            chunked.then_some(self.chunk_ops),
            (
                &quote!(b: &mut [f64; #n_lit], f: &[f64; #nf], y: &mut [f64; #n_lit]),
                &quote!(b, f, &mut y),
            ),
            helpers,
        ));
        out
    }

    /// Aᵀ x = b on `b` with the same factors, P A Q = L U so Aᵀ = Q Uᵀ Lᵀ P:
    /// w = Qᵀ b, Uᵀ s = w (forward), Lᵀ u = s (backward), x = Pᵀ u. Used by
    /// inverse dynamics only, so it is plain array code without the
    /// inlining of [`Plan::emit_solve`]. Past `chunk_ops` operations, in
    /// functions `__kinema_solve_transpose_{i}(b, f, y)` pushed onto
    /// `helpers`.
    pub(super) fn emit_solve_transpose(
        &self,
        stored: &BTreeMap<u32, usize>,
        helpers: &mut Vec<TokenStream>,
    ) -> TokenStream {
        let n = self.n;
        // As for the solve: three statements per row and one per entry.
        let chunked = 3 * n + self.lower.len() + self.upper.len() > self.chunk_ops;
        let val = |v: Val| -> Result<TokenStream, f64> {
            match v {
                Val::Const(c) => Err(c),
                Val::Var(x) => {
                    let slot = stored
                        .get(&x)
                        .copied()
                        .expect("every run-time value the solves read is stored (Plan::stored)");
                    let slot = Literal::usize_unsuffixed(slot);
                    Ok(quote!(f[#slot]))
                }
            }
        };
        // y[a] −= c · y[b], with the constants ±1 and 0 folded.
        let update = |a: &Literal, c: Val, b: &Literal| -> TokenStream {
            match val(c) {
                Ok(v) => quote!(y[#a] -= #v * y[#b];),
                Err(0.0) => quote!(),
                Err(1.0) => quote!(y[#a] -= y[#b];),
                Err(-1.0) => quote!(y[#a] += y[#b];),
                Err(k) if k < 0.0 => {
                    let k = lit(-k);
                    quote!(y[#a] += #k * y[#b];)
                }
                Err(k) => {
                    let k = lit(k);
                    quote!(y[#a] -= #k * y[#b];)
                }
            }
        };
        let mut u_cols: Vec<Vec<(Val, usize)>> = vec![Vec::new(); n];
        for &(k, j, u) in &self.upper {
            u_cols[j].push((u, k));
        }
        let mut l_cols: Vec<Vec<(Val, usize)>> = vec![Vec::new(); n];
        for &(i, k, l) in &self.lower {
            l_cols[k].push((l, i));
        }
        let n_lit = Literal::usize_unsuffixed(n);
        let out = quote!(let mut y = [0.0f64; #n_lit];);
        let mut stmts = Stmts::new();
        for (k, &c) in self.col_order.iter().enumerate() {
            let (k, c) = (Literal::usize_unsuffixed(k), Literal::usize_unsuffixed(c));
            stmts.push((quote!(y[#k] = b[#c];), 1));
        }
        for (j, col) in u_cols.iter().enumerate() {
            let jl = Literal::usize_unsuffixed(j);
            for &(u, k) in col {
                stmts.push((update(&jl, u, &Literal::usize_unsuffixed(k)), 1));
            }
            let scale = match val(self.inv[j]) {
                Ok(v) => quote!(y[#jl] *= #v;),
                Err(1.0) => quote!(),
                Err(-1.0) => quote!(y[#jl] = -y[#jl];),
                Err(c) => {
                    let c = lit(c);
                    quote!(y[#jl] *= #c;)
                }
            };
            stmts.push((scale, 1));
        }
        for (k, col) in l_cols.iter().enumerate().rev() {
            let kl = Literal::usize_unsuffixed(k);
            for &(l, i) in col {
                stmts.push((update(&kl, l, &Literal::usize_unsuffixed(i)), 1));
            }
        }
        for (k, &r) in self.row_order.iter().enumerate() {
            let (k, r) = (Literal::usize_unsuffixed(k), Literal::usize_unsuffixed(r));
            stmts.push((quote!(b[#r] = y[#k];), 1));
        }
        let nf = Literal::usize_unsuffixed(stored.len().max(1));
        let body = split(
            "solve_transpose",
            stmts,
            chunked.then_some(self.chunk_ops),
            (
                &quote!(b: &mut [f64; #n_lit], f: &[f64; #nf], y: &mut [f64; #n_lit]),
                &quote!(b, f, &mut y),
            ),
            helpers,
        );
        quote!(#out #body)
    }
}
