//! Parameter sensitivities in generated code (issue 40): for the params
//! chosen in [`Config::sensitivity`](crate::Config::sensitivity), the
//! runtime's `SensitivitySystem` as straight-line code — per param and
//! stage one private method evaluating kinema-model's derived right-hand
//! sides ([`kinema_model::sensitivity`]) on the augmented inputs [q; s],
//! [q̇; ṡ] — so that `Solver::sensitivities` solves them with the step's
//! factorization; and the index constants of the parameter columns
//! (`SliderCrank::PARAM_L1`), in the order chosen.

use std::collections::BTreeMap;

use kinema_expr::{Arena, ExprId, Factor, NodeRef, SymKind};
use kinema_model::{Derivation, SensitivityError};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use crate::cache::Cache;
use crate::emit;

/// Which params' sensitivities generated code evaluates.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum SensitivityParams {
    /// None: no `SensitivitySystem` impl, no parameter constants (the
    /// default: the code and its build time stay those of the kinematics).
    #[default]
    None,
    /// Every param of the model, in declaration order.
    All,
    /// These params, in this order (their columns' order).
    Named(Vec<String>),
}

/// One param's expressions, as the stages evaluate them.
struct Param {
    /// −Φ_p (n).
    position: Vec<ExprId>,
    /// The velocity right-hand side (n), then y_p (m).
    velocity: Vec<ExprId>,
    /// The acceleration right-hand side without q̈ (n), ẏ_p (m), ÿ_p's
    /// rest (m), then W's entries, then the (y_p)_q entries.
    acceleration: Vec<ExprId>,
    /// (row, coordinate) of W's entries.
    w: Vec<(usize, usize)>,
    /// (result column, coordinate) of the (y_p)_q entries.
    qdd: Vec<(usize, usize)>,
}

/// The derivation with the chosen params' sensitivities derived into its
/// arena, and what the stages evaluate.
pub(crate) struct Chosen {
    d: Derivation,
    names: Vec<String>,
    params: Vec<Param>,
}

impl Chosen {
    /// The chosen params' names, in column order.
    pub(crate) fn names(&self) -> &[String] {
        &self.names
    }
}

/// Derives the sensitivities `which` asks for (`Ok(None)` for none).
///
/// # Errors
/// A name that is not a param, or is repeated; derivatives too large.
pub(crate) fn choose(
    derivation: &Derivation,
    which: &SensitivityParams,
) -> Result<Option<Chosen>, SensitivityError> {
    let names: Vec<String> = match which {
        SensitivityParams::None => return Ok(None),
        SensitivityParams::All => derivation.params.iter().map(|p| p.name.clone()).collect(),
        SensitivityParams::Named(names) => names.clone(),
    };
    let mut d = derivation.clone();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let s = d.sensitivities(&refs)?;
    let n = d.phi.len();
    let params = s
        .params
        .iter()
        .map(|p| {
            let position = p.phi_p.iter().map(|&e| d.arena.neg(e)).collect();
            let mut velocity = p.velocity_rhs.clone();
            velocity.extend(p.outputs.iter().map(|o| o.value));
            let mut acceleration = p.acceleration_rhs.clone();
            acceleration.extend(p.outputs.iter().map(|o| o.velocity));
            acceleration.extend(p.outputs.iter().map(|o| o.acceleration));
            let mut w = Vec::with_capacity(p.acceleration_qdd.entries.len());
            for e in &p.acceleration_qdd.entries {
                acceleration.push(e.expr);
                w.push((e.row as usize, e.col as usize));
            }
            let mut qdd = Vec::new();
            for (i, o) in p.outputs.iter().enumerate() {
                for &(col, e) in &o.qdd {
                    acceleration.push(e);
                    qdd.push((i, col as usize));
                }
            }
            debug_assert!(p.phi_p.len() == n);
            Param {
                position,
                velocity,
                acceleration,
                w,
                qdd,
            }
        })
        .collect();
    Ok(Some(Chosen {
        d,
        names: s.params.iter().map(|p| p.name.clone()).collect(),
        params,
    }))
}

/// What the stages share at a state, evaluated once per state by
/// `prepare` into the scratch's `shared` instead of once per param and
/// stage: the largest subexpressions of the stages that read no s or ṡ
/// (nor only a value cached per state, which they read as it is), and the
/// part of a product that reads neither (its coefficient and such factors,
/// when there are two or more or one is a power: a product's factors are
/// not nodes of their own) — each if stage evaluations read it more than
/// once per state. For the slider-crank's `reach` = |d|, the powers of |d|
/// were computed again by every param's velocity and acceleration stages
/// (`l1 cos φ1 q̇3 / |d|³ · s…`), and the y_q entries once per param; a
/// subexpression only one stage of one param reads (a row of −Φ_p) stays
/// where it is, as moving it would only add a store and a load.
struct Shared {
    /// The arena with the products' parts added.
    arena: Arena,
    /// The values, in slot order.
    nodes: Vec<ExprId>,
    /// Value → its slot in `shared`.
    slot: BTreeMap<ExprId, usize>,
    /// Product → the slot of its shared part and its other factors.
    split: BTreeMap<ExprId, (usize, Vec<Factor>)>,
}

impl Shared {
    /// `bodies`: each stage's outputs and how many times per state it is
    /// evaluated; a symbol of coordinate or velocity index ≥ `nc` is s or
    /// ṡ. Walks the DAG with stacks (no recursion: a large model's
    /// expressions are deep).
    fn find(
        arena: &Arena,
        bodies: &[(&[ExprId], usize)],
        nc: usize,
        cached: &dyn Fn(ExprId) -> bool,
    ) -> Shared {
        let mut arena = arena.clone();
        let roots: Vec<ExprId> = bodies.iter().flat_map(|(r, _)| r.iter().copied()).collect();
        let schedule = arena.schedule_until(&roots, cached);
        let nodes = schedule.nodes();
        let augmented = |a: &Arena, e: ExprId| match a.node(e) {
            NodeRef::Sym(s) => match a.symbol(s).kind {
                SymKind::Coordinate(i) | SymKind::Velocity(i) => i as usize >= nc,
                SymKind::Parameter(_) | SymKind::Time => false,
            },
            _ => false,
        };
        let position = |e: ExprId| {
            schedule
                .position(e)
                .expect("every node below the roots is scheduled")
        };
        // Whether each scheduled node reads s or ṡ (children first).
        let mut reads = vec![false; nodes.len()];
        let mut kids = Vec::new();
        for (i, &n) in nodes.iter().enumerate() {
            kids.clear();
            arena.children(n, &mut kids);
            reads[i] = if cached(n) {
                // A cached sin or cos of an augmented symbol (never
                // derived, but then it is the param's own).
                kids.iter().any(|&k| augmented(&arena, k))
            } else if let NodeRef::Sym(_) = arena.node(n) {
                augmented(&arena, n)
            } else {
                kids.iter().any(|&k| reads[position(k)])
            };
        }
        let trivial = |a: &Arena, e: ExprId| {
            matches!(a.node(e), NodeRef::Num(_) | NodeRef::Sym(_)) || cached(e)
        };
        // Evaluations per state of each candidate, over the bodies: the
        // maximal subexpressions (by schedule position) and the products'
        // parts (by node).
        let mut evaluations = vec![0usize; nodes.len()];
        let mut parts: BTreeMap<ExprId, usize> = BTreeMap::new();
        let mut part_of: BTreeMap<ExprId, (ExprId, Vec<Factor>)> = BTreeMap::new();
        let mut seen = vec![usize::MAX; nodes.len()];
        let mut stack: Vec<ExprId> = Vec::new();
        for (b, &(body, times)) in bodies.iter().enumerate() {
            stack.extend_from_slice(body);
            while let Some(e) = stack.pop() {
                let p = position(e);
                if std::mem::replace(&mut seen[p], b) == b || trivial(&arena, e) {
                    continue;
                }
                if !reads[p] {
                    evaluations[p] += times;
                    continue;
                }
                if let NodeRef::Mul { coeff, factors } = arena.node(e) {
                    let (free, rest): (Vec<Factor>, Vec<Factor>) =
                        factors.iter().partition(|f| !reads[position(f.base)]);
                    if free.len() >= 2 || free.iter().any(|f| f.exp != 1.0) {
                        let part = match part_of.get(&e) {
                            Some(&(part, _)) => part,
                            None => {
                                let part = arena.product_of(coeff, &free);
                                stack.extend(rest.iter().map(|f| f.base));
                                part_of.insert(e, (part, rest));
                                *parts.entry(part).or_default() += times;
                                continue;
                            }
                        };
                        *parts.entry(part).or_default() += times;
                        stack.extend(part_of[&e].1.iter().map(|f| f.base));
                        continue;
                    }
                }
                kids.clear();
                arena.children(e, &mut kids);
                stack.extend_from_slice(&kids);
            }
        }
        let mut values: Vec<ExprId> = nodes
            .iter()
            .zip(&evaluations)
            .filter(|&(_, &n)| n > 1)
            .map(|(&e, _)| e)
            .collect();
        let mut slot: BTreeMap<ExprId, usize> =
            values.iter().enumerate().map(|(i, &e)| (e, i)).collect();
        let mut split = BTreeMap::new();
        for (product, (part, rest)) in part_of {
            if parts[&part] < 2 {
                continue;
            }
            let k = *slot.entry(part).or_insert_with(|| {
                values.push(part);
                values.len() - 1
            });
            split.insert(product, (k, rest));
        }
        Shared {
            arena,
            nodes: values,
            slot,
            split,
        }
    }
}

/// The stages' shared signature: every input, as fixed-size arrays.
struct Sizes {
    nc: Literal,
    nc2: Literal,
    m: Literal,
}

impl Sizes {
    fn inputs(&self, rt: &syn::Path) -> TokenStream {
        let Sizes { nc, nc2, .. } = self;
        quote!(q: &[f64; #nc2], qd: &[f64; #nc2], qdd: &[f64; #nc], t: f64, scratch: &mut <Self as #rt::SensitivitySystem>::SensitivityScratch)
    }
}

/// `SENSITIVITY_PARAMS`, the helper methods and `impl SensitivitySystem`
/// for the mechanism `name` (`params`: its param fields).
///
/// `step`: the system's own cache (its `System::Scratch`), which `prepare`
/// takes the angles' sin and cos from right after a step.
pub(crate) fn items(
    chosen: &Chosen,
    (name, params): (&Ident, &[Ident]),
    step: &Cache,
    (rt, chunk_nodes): (&syn::Path, usize),
) -> TokenStream {
    let d = &chosen.d;
    let a = &d.arena;
    // sin and cos of the angles and the functions of time, cached in the
    // scratch keyed on the exact values as the system's own cache is: every
    // stage of every param reads the same state, so each is computed once
    // per state, not once per stage and param (they were most of the cost).
    let everything: Vec<ExprId> = chosen
        .params
        .iter()
        .flat_map(|p| p.position.iter().chain(&p.velocity).chain(&p.acceleration))
        .copied()
        .chain(
            d.outputs
                .iter()
                .flat_map(|o| o.jacobian.iter().map(|&(_, e)| e)),
        )
        .collect();
    let cache = Cache::find(a, &everything);
    let nc = d.nc();
    let jac: Vec<ExprId> = d
        .outputs
        .iter()
        .flat_map(|o| o.jacobian.iter().map(|&(_, e)| e))
        .collect();
    // Each param's three stages once per state; the outputs' stage (y_q)
    // once per param.
    let bodies: Vec<(&[ExprId], usize)> = chosen
        .params
        .iter()
        .flat_map(|p| [&p.position[..], &p.velocity, &p.acceleration].map(|b| (b, 1)))
        .chain([(&jac[..], chosen.params.len())])
        .collect();
    let shared = Shared::find(a, &bodies, nc, &|e| cache.lookup(e).is_some());
    // From here on, the arena with the products' shared parts.
    let a = &shared.arena;
    let cache_name = format_ident!("{}SensitivityCache", name);
    let prepared = !(cache.is_empty() && shared.nodes.is_empty());
    let (scratch_type, cache_items, new_scratch) = if prepared {
        (
            quote!(#cache_name),
            cache.items(a, (&cache_name, params), chunk_nodes, shared.nodes.len()),
            quote!(::core::default::Default::default()),
        )
    } else {
        (quote!(()), quote!(), quote!())
    };
    let lookup = |e: ExprId| {
        cache.lookup(e).or_else(|| {
            shared.slot.get(&e).map(|&i| {
                let i = Literal::usize_unsuffixed(i);
                quote!(scratch.shared[#i])
            })
        })
    };
    let split = |e: ExprId| {
        shared.split.get(&e).map(|(k, rest)| {
            let k = Literal::usize_unsuffixed(*k);
            (quote!(scratch.shared[#k]), rest.clone())
        })
    };
    // `prepare` refreshed the cache at this state (but for angles of s,
    // never derived); then the statements of `outputs`.
    let emit_body = |outputs: &[ExprId], target: &dyn Fn(usize) -> TokenStream| {
        let (refresh, _, _) = cache.refresh_where(a, outputs, (&|i: u32| i as usize >= nc, false));
        let inputs = emit::Inputs {
            params,
            cached: &lookup,
            split: Some(&split),
        };
        let (body, _) = emit::body(a, outputs, target, &inputs);
        quote!(#refresh #body)
    };
    let (n, m) = (d.phi.len(), d.outputs.len());
    let sizes = Sizes {
        nc: Literal::usize_unsuffixed(nc),
        nc2: Literal::usize_unsuffixed(2 * nc),
        m: Literal::usize_unsuffixed(m),
    };
    let input_args = sizes.inputs(rt);
    let Sizes {
        nc: nc_lit,
        nc2: nc2_lit,
        m: m_lit,
    } = &sizes;
    // `at`'s slices as fixed-size arrays (a wrong length: return).
    let sized_inputs = quote! {
        let (Ok(q), Ok(qd), Ok(qdd)) = (
            <&[f64; #nc2_lit]>::try_from(q),
            <&[f64; #nc2_lit]>::try_from(qd),
            <&[f64; #nc_lit]>::try_from(qdd),
        ) else {
            return;
        };
    };
    let (rhs, dy, dyd, dydd, w, c, j) = (
        format_ident!("rhs"),
        format_ident!("dy"),
        format_ident!("dyd"),
        format_ident!("dydd"),
        format_ident!("w"),
        format_ident!("c"),
        format_ident!("j"),
    );
    let mut helpers = Vec::new();
    let mut arms: [Vec<TokenStream>; 3] = Default::default();
    for (k, p) in chosen.params.iter().enumerate() {
        let kl = Literal::usize_unsuffixed(k);
        // Position: rhs = −Φ_p.
        let body = emit_body(&p.position, &|i| emit::index(&rhs, i));
        let f = format_ident!("__kinema_sensitivity_position_{}", k);
        helpers.push(quote! {
            fn #f(&self, #input_args, rhs: &mut [f64; #nc_lit]) {
                #body
            }
        });
        arms[0].push(quote!(#kl => self.#f(q, qd, qdd, t, scratch, rhs),));
        // Velocity: rhs, then y_p.
        let target = |i: usize| {
            if i < n {
                emit::index(&rhs, i)
            } else {
                emit::index(&dy, i - n)
            }
        };
        let body = emit_body(&p.velocity, &target);
        let f = format_ident!("__kinema_sensitivity_velocity_{}", k);
        helpers.push(quote! {
            fn #f(&self, #input_args, rhs: &mut [f64; #nc_lit], dy: &mut [f64; #m_lit]) {
                #body
            }
        });
        arms[1].push(quote!(#kl => self.#f(q, qd, qdd, t, scratch, rhs, dy),));
        // Acceleration: rhs without q̈, ẏ_p, ÿ_p's rest, W into `w`, the
        // (y_p)_q into `c`; then the q̈ terms, in the entries' order.
        let nw = p.w.len();
        let target = |i: usize| {
            if i < n {
                emit::index(&rhs, i)
            } else if i < n + m {
                emit::index(&dyd, i - n)
            } else if i < n + 2 * m {
                emit::index(&dydd, i - n - m)
            } else if i < n + 2 * m + nw {
                emit::index(&w, i - n - 2 * m)
            } else {
                emit::index(&c, i - n - 2 * m - nw)
            }
        };
        let body = emit_body(&p.acceleration, &target);
        let locals = [(&w, nw), (&c, p.qdd.len())].map(|(name, len)| {
            if len == 0 {
                quote!()
            } else {
                let len = Literal::usize_unsuffixed(len);
                quote!(let mut #name = [0.0f64; #len];)
            }
        });
        let w_terms = p.w.iter().enumerate().map(|(e, &(row, col))| {
            let (e, row, col) = (
                Literal::usize_unsuffixed(e),
                Literal::usize_unsuffixed(row),
                Literal::usize_unsuffixed(col),
            );
            quote!(rhs[#row] -= w[#e] * qdd[#col];)
        });
        let c_terms = p.qdd.iter().enumerate().map(|(e, &(i, col))| {
            let (e, i, col) = (
                Literal::usize_unsuffixed(e),
                Literal::usize_unsuffixed(i),
                Literal::usize_unsuffixed(col),
            );
            quote!(dydd[#i] += c[#e] * qdd[#col];)
        });
        let f = format_ident!("__kinema_sensitivity_acceleration_{}", k);
        helpers.push(quote! {
            fn #f(
                &self,
                #input_args,
                rhs: &mut [f64; #nc_lit],
                dyd: &mut [f64; #m_lit],
                dydd: &mut [f64; #m_lit],
            ) {
                #(#locals)*
                #body
                #(#w_terms)*
                #(#c_terms)*
            }
        });
        arms[2].push(quote!(#kl => self.#f(q, qd, qdd, t, scratch, rhs, dyd, dydd),));
    }
    // The s̈ terms of ÿ_p: y_q s̈, the same for every param.
    let mut jac = Vec::new();
    let mut sums = Vec::new();
    for (i, o) in d.outputs.iter().enumerate() {
        for &(col, e) in &o.jacobian {
            sums.push((i, col as usize, jac.len()));
            jac.push(e);
        }
    }
    let body = emit_body(&jac, &|i| emit::index(&j, i));
    let j_decl = if jac.is_empty() {
        quote!()
    } else {
        let len = Literal::usize_unsuffixed(jac.len());
        quote!(let mut j = [0.0f64; #len];)
    };
    let s_terms = sums.iter().map(|&(i, col, e)| {
        let (i, col, e) = (
            Literal::usize_unsuffixed(i),
            Literal::usize_unsuffixed(col),
            Literal::usize_unsuffixed(e),
        );
        quote!(dydd[#i] += j[#e] * sdd[#col];)
    });
    helpers.push(quote! {
        fn __kinema_sensitivity_outputs(
            &self,
            #input_args,
            sdd: &[f64; #nc_lit],
            dydd: &mut [f64; #m_lit],
        ) {
            #j_decl
            #body
            #(#s_terms)*
        }
    });

    // `prepare`: the cache brought to this state (the angles of q, the
    // functions of time), then the shared values — past `chunk_nodes`
    // scheduled nodes in private functions of about that many, as the
    // system's own large bodies are.
    let prepare = if prepared {
        let (refresh, _, _) =
            cache.refresh_where(a, &everything, (&|i: u32| (i as usize) < nc, true));
        let cache_only = |e: ExprId| cache.lookup(e);
        let inputs = emit::Inputs {
            params,
            cached: &cache_only,
            split: None,
        };
        let ranges = if shared.nodes.is_empty() {
            Vec::new()
        } else {
            emit::chunks(
                a,
                &shared.nodes,
                &|e| cache.lookup(e).is_some(),
                chunk_nodes,
            )
        };
        let split = ranges.len() > 1;
        let mut calls = TokenStream::new();
        for (i, r) in ranges.into_iter().enumerate() {
            let start = r.start;
            let to = |k: usize| {
                let k = Literal::usize_unsuffixed(start + k);
                quote!(scratch.shared[#k])
            };
            let (body, _) = emit::body(a, &shared.nodes[r], &to, &inputs);
            let f = format_ident!("__kinema_sensitivity_prepare_{}", i);
            let inline = if split {
                quote!(#[inline(never)])
            } else {
                quote!()
            };
            helpers.push(quote! {
                #inline
                fn #f(&self, #input_args) {
                    #body
                }
            });
            calls.extend(quote!(self.#f(q, qd, qdd, t, scratch);));
        }
        let inputs = quote! {
            let #rt::Augmented { t, q, qd, qdd } = at;
            #sized_inputs
        };
        // Right after the system's own step, the angles from its cache.
        let after_step = if step.is_empty() || cache.is_empty() {
            quote!()
        } else {
            let (time, _, _) = cache.refresh_where(a, &everything, (&|_| false, true));
            let angles = cache.refresh_after_step(a, &everything, nc, step);
            quote! {
                #[allow(unused_variables)]
                fn prepare_after_step(
                    &self,
                    scratch: &mut Self::SensitivityScratch,
                    at: #rt::Augmented<'_>,
                    step: &<Self as #rt::System>::Scratch,
                ) where
                    Self: #rt::System,
                {
                    #inputs
                    #time
                    #angles
                    #calls
                }
            }
        };
        quote! {
            #[allow(unused_variables)]
            fn prepare(&self, scratch: &mut Self::SensitivityScratch, at: #rt::Augmented<'_>) {
                #inputs
                #refresh
                #calls
            }

            #after_step
        }
    } else {
        quote!()
    };

    let count = Literal::usize_unsuffixed(chosen.names.len());
    let names = chosen.names.iter().map(String::as_str);
    let [position_arms, velocity_arms, acceleration_arms] = &arms;
    // Every input and output's length checked first (a wrong one: NaN
    // out), then each made a fixed-size array once.
    let prelude = |outputs: &[&Ident]| {
        let checks = outputs.iter().map(|o| {
            let len = if *o == &rhs { nc_lit } else { m_lit };
            quote!(|| #o.len() != #len)
        });
        let fills = outputs.iter().map(|o| quote!(#o.fill(f64::NAN);));
        let sized = outputs.iter().map(|o| {
            let len = if *o == &rhs { nc_lit } else { m_lit };
            quote!(let Ok(#o) = <&mut [f64; #len]>::try_from(#o) else { return; };)
        });
        quote! {
            let #rt::Augmented { t, q, qd, qdd } = at;
            if k >= #count || q.len() != #nc2_lit || qd.len() != #nc2_lit || qdd.len() != #nc_lit
                #(#checks)*
            {
                #(#fills)*
                return;
            }
            #sized_inputs
            #(#sized)*
        }
    };
    let position = prelude(&[&rhs]);
    let velocity = prelude(&[&rhs, &dy]);
    let acceleration = prelude(&[&rhs, &dyd, &dydd]);
    let outputs = prelude(&[&dydd]);
    let count_doc = format!(
        " The params whose sensitivities [`{name}`] evaluates (its \
         `SensitivitySystem`), in the order of their columns (the `PARAM_…` \
         constants): {}.",
        chosen.names.join(", ")
    );
    quote! {
        #[allow(clippy::approx_constant)]
        impl #name {
            #[doc = #count_doc]
            pub const SENSITIVITY_PARAMS: [&'static str; #count] = [#(#names),*];

            #(
                #[allow(unused_variables, clippy::too_many_arguments, clippy::approx_constant)]
                #helpers
            )*
        }

        #[allow(clippy::approx_constant)]
        impl #rt::SensitivitySystem for #name {
            type SensitivityScratch = #scratch_type;

            fn sensitivity_scratch(&self) -> Self::SensitivityScratch {
                #new_scratch
            }

            fn param_count(&self) -> usize {
                #count
            }

            fn param_name(&self, k: usize) -> &str {
                Self::SENSITIVITY_PARAMS.get(k).copied().unwrap_or("")
            }

            fn coordinate_count(&self) -> usize {
                #nc_lit
            }

            fn result_count(&self) -> usize {
                #m_lit
            }

            #prepare

            fn position_rhs(
                &self,
                scratch: &mut Self::SensitivityScratch,
                k: usize,
                at: #rt::Augmented<'_>,
                rhs: &mut [f64],
            ) {
                #position
                match k {
                    #(#position_arms)*
                    _ => {}
                }
            }

            fn velocity_rhs(
                &self,
                scratch: &mut Self::SensitivityScratch,
                k: usize,
                at: #rt::Augmented<'_>,
                rhs: &mut [f64],
                dy: &mut [f64],
            ) {
                #velocity
                match k {
                    #(#velocity_arms)*
                    _ => {}
                }
            }

            fn acceleration_rhs(
                &self,
                scratch: &mut Self::SensitivityScratch,
                k: usize,
                at: #rt::Augmented<'_>,
                rhs: &mut [f64],
                dyd: &mut [f64],
                dydd: &mut [f64],
            ) {
                #acceleration
                match k {
                    #(#acceleration_arms)*
                    _ => {}
                }
            }

            fn acceleration_outputs(
                &self,
                scratch: &mut Self::SensitivityScratch,
                k: usize,
                at: #rt::Augmented<'_>,
                sdd: &[f64],
                dydd: &mut [f64],
            ) {
                if sdd.len() != #nc_lit {
                    dydd.fill(f64::NAN);
                    return;
                }
                #outputs
                let Ok(sdd) = <&[f64; #nc_lit]>::try_from(sdd) else { return; };
                self.__kinema_sensitivity_outputs(q, qd, qdd, t, scratch, sdd, dydd);
            }
        }

        #cache_items
    }
}
