//! Per-step caches of a generated system: sin and cos of the body angles,
//! keyed on the exact angle, and the functions of time (drivers' sin, cos,
//! …), keyed on the exact t.
//!
//! Within one step the runtime evaluates Φ and Φ_q at several iterates, then
//! ν and γ at the converged q; the next step's first iterate is that same q
//! again. Every evaluation at an angle already seen reuses its sin and cos
//! (one `sin_cos` per new angle), and the drivers' functions of t are
//! computed once per time. Values are compared bit for bit, so a cache hit
//! returns exactly what the computation would: results do not change.
//!
//! The cache is the system's `System::Scratch`, owned by the solver, not a
//! field of the parameter struct (which stays plain data). It holds nothing
//! that depends on parameters, so changing a parameter between steps never
//! makes it stale.

use std::collections::BTreeMap;

use kinema_expr::{Arena, ExprId, NodeRef, SymKind, UnaryOp};
use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use crate::emit;

/// What a generated system caches.
pub(crate) struct Cache {
    /// Coordinate index of each cached angle.
    angles: Vec<u32>,
    /// sin or cos node → (angle slot, is sin).
    trig: BTreeMap<ExprId, (usize, bool)>,
    /// Functions of t alone, in slot order.
    time: Vec<ExprId>,
    time_slot: BTreeMap<ExprId, usize>,
}

/// Angle checks in the method's own body, on `c` borrowed from its scratch
/// (nothing when there are none).
fn inline_checks(checks: &[TokenStream]) -> TokenStream {
    if checks.is_empty() {
        return quote!();
    }
    quote! {
        {
            let c = &mut *scratch;
            #(#checks)*
        }
    }
}

/// How [`Cache::refresh_split`] splits a method's angle checks.
pub(crate) struct Split<'a> {
    /// The method's name, in the functions' names.
    pub label: &'a str,
    /// Checks per function.
    pub checks: usize,
    /// The coordinate count (the length of `q`).
    pub nc: usize,
    /// The runtime's path, for the scratch type.
    pub rt: &'a syn::Path,
}

/// Which inputs a node depends on.
#[derive(Clone, Copy, Default)]
struct Deps {
    time: bool,
    other: bool,
}

impl Cache {
    /// Finds the cacheable nodes below `outputs`.
    pub(crate) fn find(arena: &Arena, outputs: &[ExprId]) -> Cache {
        let nodes = emit::reachable(arena, outputs, &|_| false);
        let mut deps = vec![Deps::default(); arena.len()];
        let mut angle_slot: BTreeMap<u32, usize> = BTreeMap::new();
        let mut trig_nodes: Vec<(ExprId, u32, bool)> = Vec::new();
        let mut time = Vec::new();
        let mut kids = Vec::new();
        for &n in &nodes {
            let mut d = Deps::default();
            match arena.node(n) {
                NodeRef::Sym(s) => match arena.symbol(s).kind {
                    SymKind::Time => d.time = true,
                    _ => d.other = true,
                },
                _ => {
                    kids.clear();
                    arena.children(n, &mut kids);
                    for k in &kids {
                        let c = deps[k.index()];
                        d.time |= c.time;
                        d.other |= c.other;
                    }
                }
            }
            deps[n.index()] = d;
            if let NodeRef::Unary(op @ (UnaryOp::Sin | UnaryOp::Cos), a) = arena.node(n)
                && let NodeRef::Sym(s) = arena.node(a)
                && let SymKind::Coordinate(i) = arena.symbol(s).kind
            {
                angle_slot.entry(i).or_insert(0);
                trig_nodes.push((n, i, op == UnaryOp::Sin));
            }
            let expensive = match arena.node(n) {
                NodeRef::Unary(op, _) => !matches!(op, UnaryOp::Abs | UnaryOp::Smooth(_)),
                NodeRef::Pow(..) | NodeRef::Atan2(..) => true,
                _ => false,
            };
            if expensive && d.time && !d.other {
                time.push(n);
            }
        }
        let angles: Vec<u32> = angle_slot.keys().copied().collect();
        for (slot, v) in angle_slot.values_mut().enumerate() {
            *v = slot;
        }
        let trig = trig_nodes
            .into_iter()
            .map(|(n, i, sin)| (n, (angle_slot[&i], sin)))
            .collect();
        let time_slot = time.iter().enumerate().map(|(k, &n)| (n, k)).collect();
        Cache {
            angles,
            trig,
            time,
            time_slot,
        }
    }

    /// The slot of the angle of coordinate `i`, if cached.
    pub(crate) fn angle_slot(&self, i: u32) -> Option<usize> {
        self.angles.iter().position(|&a| a == i)
    }

    /// The refresh of the angles of coordinates below `nc` that `outputs`
    /// read, for a cache filled right after a step of the system whose
    /// cache is `step` (`step`, that scratch, in scope; `c`, this one): an
    /// angle the step's cache holds (bit for bit) is copied from it, not
    /// computed again.
    pub(crate) fn refresh_after_step(
        &self,
        arena: &Arena,
        outputs: &[ExprId],
        nc: usize,
        step: &Cache,
    ) -> TokenStream {
        let reached = emit::reachable(arena, outputs, &|e| self.lookup(e).is_some());
        let slots = self.angle_slots(&reached, &|i| (i as usize) < nc);
        let checks = slots.iter().map(|&slot| {
            let angle = self.angles[slot];
            let i = Literal::usize_unsuffixed(angle as usize);
            let k = Literal::usize_unsuffixed(slot);
            let compute = quote!(q[#i].sin_cos());
            let value = match step.angle_slot(angle) {
                Some(j) => {
                    let j = Literal::usize_unsuffixed(j);
                    quote! {
                        if step.angle[#j].to_bits() == q[#i].to_bits() {
                            (step.sin[#j], step.cos[#j])
                        } else {
                            #compute
                        }
                    }
                }
                None => compute,
            };
            quote! {
                if q[#i].to_bits() != c.angle[#k].to_bits() {
                    c.angle[#k] = q[#i];
                    (c.sin[#k], c.cos[#k]) = #value;
                }
            }
        });
        let checks: Vec<TokenStream> = checks.collect();
        inline_checks(&checks)
    }

    /// The slots, in order, of the angles `reached` reads the sin or cos
    /// of, of the coordinates `angles` accepts.
    fn angle_slots(&self, reached: &[ExprId], angles: &dyn Fn(u32) -> bool) -> Vec<usize> {
        let mut slots: Vec<usize> = reached
            .iter()
            .filter_map(|e| self.trig.get(e).map(|&(slot, _)| slot))
            .filter(|&slot| angles(self.angles[slot]))
            .collect();
        slots.sort_unstable();
        slots.dedup();
        slots
    }

    /// Nothing to cache.
    pub(crate) fn is_empty(&self) -> bool {
        self.angles.is_empty() && self.time.is_empty()
    }

    /// Where a cached node's value is read, if it is cached.
    pub(crate) fn lookup(&self, e: ExprId) -> Option<TokenStream> {
        if let Some(&(slot, sin)) = self.trig.get(&e) {
            let slot = Literal::usize_unsuffixed(slot);
            return Some(if sin {
                quote!(scratch.sin[#slot])
            } else {
                quote!(scratch.cos[#slot])
            });
        }
        self.time_slot.get(&e).map(|&slot| {
            let slot = Literal::usize_unsuffixed(slot);
            quote!(scratch.time[#slot])
        })
    }

    /// Statements bringing the cache up to date for `outputs` (at the
    /// current `q` and `t`), and whether they read q and t.
    pub(crate) fn refresh(&self, arena: &Arena, outputs: &[ExprId]) -> (TokenStream, bool, bool) {
        self.refresh_where(arena, outputs, (&|_| true, true))
    }

    /// [`Cache::refresh`] of only the angles of the coordinates `angles`
    /// accepts, and of the functions of time only with `time`.
    pub(crate) fn refresh_where(
        &self,
        arena: &Arena,
        outputs: &[ExprId],
        (angles, time): (&dyn Fn(u32) -> bool, bool),
    ) -> (TokenStream, bool, bool) {
        let (mut out, checks, uses_time) = self.refresh_parts(arena, outputs, (angles, time));
        out.extend(inline_checks(&checks));
        (out, !checks.is_empty(), uses_time)
    }

    /// [`Cache::refresh`] for a method of a generated system, with the angle
    /// checks (a comparison and perhaps a `sin_cos` each, four lines of
    /// source) past `split.checks` of them split into private
    /// `#[inline(never)]` functions of that many, pushed onto `helpers`:
    /// a 1000-body chain's refresh was a 4 000-line body in each method.
    /// The checks are the same statements in the same order.
    pub(crate) fn refresh_split(
        &self,
        arena: &Arena,
        outputs: &[ExprId],
        split: &Split<'_>,
        helpers: &mut Vec<TokenStream>,
    ) -> (TokenStream, bool, bool) {
        let (mut out, checks, uses_time) = self.refresh_parts(arena, outputs, (&|_| true, true));
        if checks.len() <= split.checks {
            out.extend(inline_checks(&checks));
            return (out, !checks.is_empty(), uses_time);
        }
        let nc = Literal::usize_unsuffixed(split.nc);
        let rt = split.rt;
        for (i, run) in checks.chunks(split.checks).enumerate() {
            let name = format_ident!("__kinema_{}_angles_{}", split.label, i);
            out.extend(quote!(Self::#name(q, scratch);));
            helpers.push(quote! {
                #[inline(never)]
                fn #name(q: &[f64; #nc], c: &mut <Self as #rt::System>::Scratch) {
                    #(#run)*
                }
            });
        }
        (out, true, uses_time)
    }

    /// The refresh of the functions of time (when `outputs` read one and
    /// `time` holds), the check of each angle `outputs` read whose
    /// coordinate `angles` accepts (on `c`, the scratch), and whether they
    /// read t.
    fn refresh_parts(
        &self,
        arena: &Arena,
        outputs: &[ExprId],
        (angles, time): (&dyn Fn(u32) -> bool, bool),
    ) -> (TokenStream, Vec<TokenStream>, bool) {
        if self.is_empty() {
            return (quote!(), Vec::new(), false);
        }
        let reached = emit::reachable(arena, outputs, &|e| self.lookup(e).is_some());
        let slots = self.angle_slots(&reached, angles);
        let uses_time = reached.iter().any(|e| self.time_slot.contains_key(e));
        let mut out = TokenStream::new();
        if uses_time && time {
            out.extend(quote! {
                if t.to_bits() != scratch.t.to_bits() {
                    scratch.refresh_time(t);
                }
            });
        }
        let checks = slots
            .iter()
            .map(|&slot| {
                let i = Literal::usize_unsuffixed(self.angles[slot] as usize);
                let k = Literal::usize_unsuffixed(slot);
                quote! {
                    if q[#i].to_bits() != c.angle[#k].to_bits() {
                        c.angle[#k] = q[#i];
                        (c.sin[#k], c.cos[#k]) = q[#i].sin_cos();
                    }
                }
            })
            .collect();
        (out, checks, uses_time)
    }

    /// The cache type `name` and the field declaration for the system;
    /// its refresh of the functions of time split past `chunk_nodes`
    /// scheduled nodes ([`emit::chunks`]). With `shared` > 0, a field
    /// `shared` of that many values besides (the sensitivity stages'
    /// per-state values: `crate::sensitivity`).
    pub(crate) fn items(
        &self,
        arena: &Arena,
        (name, params): (&Ident, &[Ident]),
        chunk_nodes: usize,
        shared: usize,
    ) -> TokenStream {
        let k = Literal::usize_unsuffixed(self.angles.len());
        let m = Literal::usize_unsuffixed(self.time.len());
        let (angle_fields, angle_init) = if self.angles.is_empty() {
            (quote!(), quote!())
        } else {
            (
                quote! {
                    angle: [f64; #k],
                    sin: [f64; #k],
                    cos: [f64; #k],
                },
                quote! {
                    angle: [0.0; #k],
                    sin: [0.0; #k],
                    cos: [1.0; #k],
                },
            )
        };
        let (time_fields, time_init, time_refresh) = if self.time.is_empty() {
            (quote!(), quote!(), quote!())
        } else {
            let none = |_: ExprId| None;
            let inputs = emit::Inputs {
                params,
                cached: &none,
                split: None,
            };
            let to = |k: usize| {
                let k = Literal::usize_unsuffixed(k);
                quote!(self.time[#k])
            };
            // Past `chunk_nodes` scheduled nodes, in private functions of
            // about that many (a 1000-body chain's drivers make 2000
            // functions of time), each computing its functions with the
            // same operations as one body would.
            let ranges = emit::chunks(arena, &self.time, &|_| false, chunk_nodes);
            let (body, chunks) = if ranges.len() > 1 {
                let mut calls = TokenStream::new();
                let mut chunks = TokenStream::new();
                for (i, r) in ranges.into_iter().enumerate() {
                    let name = format_ident!("__kinema_refresh_time_{}", i);
                    let start = r.start;
                    let (body, _) = emit::body(arena, &self.time[r], &|k| to(start + k), &inputs);
                    calls.extend(quote!(self.#name(t);));
                    chunks.extend(quote! {
                        #[inline(never)]
                        fn #name(&mut self, t: f64) {
                            #body
                        }
                    });
                }
                (calls, chunks)
            } else {
                (emit::body(arena, &self.time, &to, &inputs).0, quote!())
            };
            (
                quote! {
                    t: f64,
                    time: [f64; #m],
                },
                quote! {
                    t: 0.0,
                    time: [0.0; #m],
                },
                quote! {
                    #[allow(clippy::approx_constant)]
                    impl #name {
                        /// The functions of time at `t`.
                        fn refresh_time(&mut self, t: f64) {
                            self.t = t;
                            #body
                        }

                        #chunks
                    }
                },
            )
        };
        let (shared_fields, shared_init) = if shared == 0 {
            (quote!(), quote!())
        } else {
            let n = Literal::usize_unsuffixed(shared);
            (quote!(shared: [f64; #n],), quote!(shared: [0.0; #n],))
        };
        let init = if self.time.is_empty() {
            quote!(Self { #angle_init #shared_init })
        } else {
            quote! {
                let mut cache = Self { #angle_init #time_init #shared_init };
                cache.refresh_time(0.0);
                cache
            }
        };
        let name_text = name.to_string();
        let (owner, role) = match name_text.strip_suffix("SensitivityCache") {
            Some(owner) => (owner, "`SensitivitySystem::SensitivityScratch`"),
            None => (name_text.trim_end_matches("Cache"), "`System::Scratch`"),
        };
        let doc = if shared == 0 {
            format!(
                " The scratch of [`{owner}`] (its {role}): sin and cos of {} body \
                 angles (keyed on the exact angle), {} functions of time (keyed on the exact \
                 t). It holds nothing that depends on parameters, so it never changes a result: \
                 a clone or a default is as good as the original.",
                self.angles.len(),
                self.time.len()
            )
        } else {
            format!(
                " The scratch of [`{owner}`] (its {role}): sin and cos of {} body \
                 angles (keyed on the exact angle), {} functions of time (keyed on the exact \
                 t), and {shared} values every param's stages share, written by \
                 `SensitivitySystem::prepare` at each state before the stages read them. \
                 A clone or a default is as good as the original.",
                self.angles.len(),
                self.time.len()
            )
        };
        quote! {
            #[doc = #doc]
            #[doc(hidden)]
            #[derive(Clone)]
            pub struct #name {
                #angle_fields
                #time_fields
                #shared_fields
            }

            impl ::core::default::Default for #name {
                fn default() -> Self {
                    #init
                }
            }

            impl ::core::fmt::Debug for #name {
                fn fmt(&self, f: &mut ::core::fmt::Formatter<'_>) -> ::core::fmt::Result {
                    f.write_str(stringify!(#name))
                }
            }

            #time_refresh
        }
    }
}
