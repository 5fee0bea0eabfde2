//! Straight-line Rust from a schedule: every shared subexpression is bound
//! once with `let`, single-use ones are inlined up to a depth limit.

use std::collections::{BTreeMap, BTreeSet};

use kinema_expr::{Arena, ExprId, Factor, NodeRef, Schedule, SymKind, UnaryOp};
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::{format_ident, quote};

/// `name[k]` as tokens.
pub(crate) fn index(name: &Ident, k: usize) -> TokenStream {
    let k = Literal::usize_unsuffixed(k);
    quote!(#name[#k])
}

/// Inlined expressions deeper than this are bound to a `let` instead, so that
/// the token trees handed to rustc stay shallow however deep the model.
const MAX_INLINE_DEPTH: u32 = 8;

/// Most operands one emitted sum or product chains together. A longer one
/// is split into partial results bound in turn (`v1 = v0 + a + b + …`),
/// which keeps the left-to-right order of the operations — so the same
/// bits — while every statement stays a shallow expression: rustc and
/// prettyplease recurse on the nesting of a binary-operator chain, and a
/// 20 000-term sum emitted as one expression overflows their stacks.
const MAX_CHAIN: usize = 32;

/// Operator precedence of an emitted expression, for minimal parentheses.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Debug)]
enum Prec {
    /// `a + b`, `a - b`
    Add,
    /// `a * b`, `a / b`, `-a`
    Mul,
    /// literals, names, indexing, method calls: usable as a method receiver
    Atom,
}

#[derive(Clone)]
pub(crate) struct Code {
    pub(crate) tokens: TokenStream,
    prec: Prec,
    depth: u32,
}

impl Code {
    fn atom(tokens: TokenStream) -> Code {
        Code {
            tokens,
            prec: Prec::Atom,
            depth: 0,
        }
    }

    /// The tokens, parenthesized unless their precedence is at least `min`.
    fn at(&self, min: Prec) -> TokenStream {
        let t = &self.tokens;
        if self.prec >= min {
            t.clone()
        } else {
            quote!((#t))
        }
    }
}

/// Where the inputs of the function being generated come from.
pub(crate) struct Inputs<'a> {
    /// Names of the parameters (read as `self.name`).
    pub params: &'a [Ident],
    /// Nodes whose value is read from somewhere else (a per-step cache):
    /// emitted as the given tokens, their operands not visited.
    pub cached: &'a dyn Fn(ExprId) -> Option<TokenStream>,
    /// Products computed in part somewhere else: for a product node, the
    /// tokens reading the value of its coefficient times some of its
    /// factors, and the factors left — emitted as that value times them.
    /// (Its other factors are still scheduled, and left unread.)
    pub split: Option<&'a SplitProduct<'a>>,
}

/// [`Inputs::split`]: a product node → the tokens of its part computed
/// elsewhere and its factors left.
pub(crate) type SplitProduct<'a> = dyn Fn(ExprId) -> Option<(TokenStream, Vec<Factor>)> + 'a;

/// Which inputs a generated body reads: decides whether a function argument
/// is named `q` or `_q`.
#[derive(Default, Clone, Copy)]
pub(crate) struct Used {
    pub q: bool,
    pub qd: bool,
    pub t: bool,
}

/// The `let` bindings of one generated body: named locals `v0, v1, …`, or,
/// past [`crate::lu::MAX_LETS`] of them, slots of one local array `v`.
struct Binder {
    statements: Vec<TokenStream>,
    large: bool,
    /// Fractional powers `base.powf(p)` that several products of the body
    /// read ([`repeated_powers`]), and where each is bound once computed:
    /// a product's factors are not nodes of their own, so without this
    /// each product called `powf` again (a distance's derivatives divide
    /// by its square's 1.5th power in many entries). The same operation
    /// on the same value: the same bits.
    repeated: BTreeSet<(ExprId, u64)>,
    powers: BTreeMap<(ExprId, u64), Code>,
}

impl Binder {
    /// `base^p` (p > 0): bound once and reused when it is a repeated
    /// fractional power, else [`raise`] inline.
    fn power(&mut self, base: ExprId, code: &Code, p: f64) -> Code {
        let key = (base, p.to_bits());
        if !self.repeated.contains(&key) {
            return raise(code, p);
        }
        if let Some(c) = self.powers.get(&key) {
            return c.clone();
        }
        let c = self.bind(&raise(code, p).tokens);
        self.powers.insert(key, c.clone());
        c
    }

    /// Binds `value` and returns the place that now holds it.
    fn bind(&mut self, value: &TokenStream) -> Code {
        let k = self.statements.len();
        let place = if self.large {
            let k = Literal::usize_unsuffixed(k);
            quote!(v[#k])
        } else {
            let name = format_ident!("v{}", k);
            quote!(#name)
        };
        self.statements.push(if self.large {
            quote! { #place = #value; }
        } else {
            quote! { let #place = #value; }
        });
        Code::atom(place)
    }

    /// The bindings as statements (with the array's declaration first when
    /// they live in one).
    fn into_statements(self) -> TokenStream {
        let mut stmts = TokenStream::new();
        if self.large {
            let k = Literal::usize_unsuffixed(self.statements.len());
            stmts.extend(quote! { let mut v = [0.0f64; #k]; });
        }
        stmts.extend(self.statements);
        stmts
    }
}

/// An operator chain `a ∘ b ∘ c …` built operand by operand, at most
/// [`MAX_CHAIN`] operands per emitted expression: when a chain is full, it
/// is bound and the binding becomes the first operand of the rest.
struct Chain {
    tokens: TokenStream,
    operands: usize,
}

impl Chain {
    fn new() -> Self {
        Chain {
            tokens: TokenStream::new(),
            operands: 0,
        }
    }

    /// Appends one operand with its operator (`op` is empty for the first
    /// operand of the chain, e.g. a leading coefficient).
    fn push(&mut self, op: TokenStream, operand: TokenStream, binder: &mut Binder) {
        if self.operands == MAX_CHAIN {
            let partial = binder.bind(&self.tokens);
            self.tokens = partial.tokens;
            self.operands = 1;
        }
        self.tokens.extend(op);
        self.tokens.extend(operand);
        self.operands += 1;
    }

    fn is_empty(&self) -> bool {
        self.operands == 0
    }
}

/// Emits statements computing `outputs` and writing each into the place
/// `target(k)` names (e.g. `out[k]`). Returns the statements and the inputs
/// they read.
pub(crate) fn body(
    arena: &Arena,
    outputs: &[ExprId],
    target: &dyn Fn(usize) -> TokenStream,
    inputs: &Inputs<'_>,
) -> (TokenStream, Used) {
    let schedule = arena.schedule_until(outputs, |e| (inputs.cached)(e).is_some());
    let nodes = schedule.nodes();
    let mut code: Vec<Code> = Vec::with_capacity(nodes.len());
    let mut used = Used::default();
    // Past `MAX_LETS` bindings, values live in one local array (see
    // `lu::MAX_LETS`); decided up front from the binding count.
    let repeated = repeated_powers(arena, &schedule, inputs);
    let mut binder = Binder {
        statements: Vec::new(),
        large: count_bindings(arena, &schedule, inputs) + repeated.len() > crate::lu::MAX_LETS,
        repeated,
        powers: BTreeMap::new(),
    };
    for (i, &n) in nodes.iter().enumerate() {
        if let Some(tokens) = (inputs.cached)(n) {
            code.push(Code::atom(tokens));
            continue;
        }
        let c = {
            let child = |e: ExprId| -> &Code {
                let p = schedule
                    .position(e)
                    .expect("children precede their parents in a schedule");
                &code[p]
            };
            node(arena, n, &child, inputs, &mut used, &mut binder)
        };
        let uses = schedule.parent_uses()[i] + schedule.output_uses()[i];
        let leaf = matches!(arena.node(n), NodeRef::Num(_) | NodeRef::Sym(_));
        let bind = !leaf && (uses > 1 || c.depth > MAX_INLINE_DEPTH);
        code.push(if bind { binder.bind(&c.tokens) } else { c });
    }
    let mut stmts = binder.into_statements();
    for (k, &o) in outputs.iter().enumerate() {
        let p = schedule.position(o).expect("every output is scheduled");
        let value = &code[p].tokens;
        let place = target(k);
        stmts.extend(quote! { #place = #value; });
    }
    (stmts, used)
}

/// Scheduled nodes past which a generated function's outputs are split
/// over several functions ([`chunks`]). LLVM's optimisation time grows
/// faster than linearly in a function's size, so a 1000-body model's Φ_q as
/// one function body dominated its compile time; chunks of this size keep
/// every function in the linear regime while calls between them cost
/// nothing measurable.
pub(crate) const CHUNK_NODES: usize = 2000;

/// `outputs` split into consecutive ranges whose bodies schedule at most
/// about `budget` nodes and stores each (a single output larger than that
/// is a chunk of its own), not descending below nodes for which `stop`
/// holds. One range when the whole fits. Each output's store counts as a
/// node: thousands of outputs that are shared constants or values already
/// computed (a Jacobian's ±1, ν's zeros) schedule nothing new, yet each is a
/// statement of the chunk. A node shared by two chunks is computed in
/// each: outputs are taken in order, and the derivation's rows follow the
/// model's bodies, so neighbouring outputs share most of what they read.
pub(crate) fn chunks(
    arena: &Arena,
    outputs: &[ExprId],
    stop: &dyn Fn(ExprId) -> bool,
    budget: usize,
) -> Vec<std::ops::Range<usize>> {
    // The chunk that last counted each node (0: none yet).
    let mut mark: Vec<u32> = vec![0; arena.len()];
    let mut stack: Vec<ExprId> = Vec::new();
    let mut count_new = |root: ExprId, chunk: u32| -> usize {
        let mut added = 0;
        stack.push(root);
        while let Some(e) = stack.pop() {
            if mark[e.index()] == chunk {
                continue;
            }
            mark[e.index()] = chunk;
            added += 1;
            if !stop(e) {
                arena.for_each_child(e, |c| stack.push(c));
            }
        }
        added
    };
    let mut ranges = Vec::new();
    let (mut start, mut size, mut chunk) = (0, 0, 1u32);
    for (k, &o) in outputs.iter().enumerate() {
        let added = count_new(o, chunk) + 1;
        if size > 0 && size + added > budget {
            ranges.push(start..k);
            start = k;
            chunk += 1;
            size = count_new(o, chunk) + 1;
        } else {
            size += added;
        }
    }
    ranges.push(start..outputs.len());
    ranges
}

/// The fractional powers (base, exponent's bits; not integers, not ½,
/// which are `powi` and `sqrt`) that more than one product emitted from
/// `schedule` raises a base to.
fn repeated_powers(
    arena: &Arena,
    schedule: &Schedule,
    inputs: &Inputs<'_>,
) -> BTreeSet<(ExprId, u64)> {
    let mut seen = BTreeSet::new();
    let mut repeated = BTreeSet::new();
    for &n in schedule.nodes() {
        if (inputs.cached)(n).is_some() {
            continue;
        }
        if let NodeRef::Mul { factors, .. } = arena.node(n) {
            for f in factors {
                let p = f.exp.abs();
                if p.fract() == 0.0 || p == 0.5 || !p.is_finite() {
                    continue;
                }
                let key = (f.base, p.to_bits());
                if !seen.insert(key) {
                    repeated.insert(key);
                }
            }
        }
    }
    repeated
}

/// How many values [`body`] binds for `schedule`: the shared ones (the
/// depth limit adds a few more, which `MAX_LETS` leaves room for).
fn count_bindings(arena: &Arena, schedule: &Schedule, inputs: &Inputs<'_>) -> usize {
    let uses = schedule
        .parent_uses()
        .iter()
        .zip(schedule.output_uses())
        .map(|(p, o)| p + o);
    schedule
        .nodes()
        .iter()
        .zip(uses)
        .filter(|&(&n, uses)| {
            uses > 1
                && !matches!(arena.node(n), NodeRef::Num(_) | NodeRef::Sym(_))
                && (inputs.cached)(n).is_none()
        })
        .count()
}

/// The nodes below `outputs` (outputs included), each once, in schedule
/// order, not descending below nodes for which `stop` holds.
pub(crate) fn reachable(
    arena: &Arena,
    outputs: &[ExprId],
    stop: &dyn Fn(ExprId) -> bool,
) -> Vec<ExprId> {
    arena.schedule_until(outputs, stop).nodes().to_vec()
}

/// A finite number as a literal (negation emitted separately), or a named
/// constant of `core::f64::consts` when it is exactly one.
pub(crate) fn number(v: f64) -> Code {
    if !v.is_finite() {
        let t = if v.is_nan() {
            quote!(f64::NAN)
        } else if v > 0.0 {
            quote!(f64::INFINITY)
        } else {
            quote!(f64::NEG_INFINITY)
        };
        return Code::atom(t);
    }
    let magnitude = match named_constant(v.abs()) {
        Some(name) => {
            let name = Ident::new(name, Span::call_site());
            quote!(::core::f64::consts::#name)
        }
        None => {
            let lit = Literal::f64_unsuffixed(v.abs());
            quote!(#lit)
        }
    };
    if v < 0.0 {
        Code {
            tokens: quote!(-#magnitude),
            prec: Prec::Mul,
            depth: 0,
        }
    } else {
        Code::atom(magnitude)
    }
}

/// The name of `v` in `core::f64::consts`, if it is exactly one of them.
fn named_constant(v: f64) -> Option<&'static str> {
    use std::f64::consts as c;
    [
        (c::PI, "PI"),
        (c::TAU, "TAU"),
        (c::FRAC_PI_2, "FRAC_PI_2"),
        (c::FRAC_PI_3, "FRAC_PI_3"),
        (c::FRAC_PI_4, "FRAC_PI_4"),
        (c::FRAC_PI_6, "FRAC_PI_6"),
        (c::FRAC_PI_8, "FRAC_PI_8"),
        (c::FRAC_1_PI, "FRAC_1_PI"),
        (c::FRAC_2_PI, "FRAC_2_PI"),
        (c::FRAC_2_SQRT_PI, "FRAC_2_SQRT_PI"),
        (c::SQRT_2, "SQRT_2"),
        (c::FRAC_1_SQRT_2, "FRAC_1_SQRT_2"),
        (c::E, "E"),
        (c::LN_2, "LN_2"),
        (c::LN_10, "LN_10"),
        (c::LOG2_E, "LOG2_E"),
        (c::LOG10_E, "LOG10_E"),
    ]
    .into_iter()
    .find(|&(k, _)| k == v)
    .map(|(_, name)| name)
}

fn depth_of<'c>(children: impl IntoIterator<Item = &'c Code>) -> u32 {
    1 + children.into_iter().map(|c| c.depth).max().unwrap_or(0)
}

fn node<'c>(
    arena: &Arena,
    n: ExprId,
    child: &dyn Fn(ExprId) -> &'c Code,
    inputs: &Inputs<'_>,
    used: &mut Used,
    binder: &mut Binder,
) -> Code {
    match arena.node(n) {
        NodeRef::Num(v) => number(v),
        NodeRef::Sym(s) => Code::atom(match arena.symbol(s).kind {
            SymKind::Coordinate(i) => {
                used.q = true;
                let i = Literal::usize_unsuffixed(i as usize);
                quote!(q[#i])
            }
            SymKind::Velocity(i) => {
                used.qd = true;
                let i = Literal::usize_unsuffixed(i as usize);
                quote!(qd[#i])
            }
            SymKind::Parameter(i) => {
                let name = inputs
                    .params
                    .get(i as usize)
                    .expect("every parameter symbol of a derivation has a field");
                quote!(self.#name)
            }
            SymKind::Time => {
                used.t = true;
                quote!(t)
            }
        }),
        NodeRef::Add { constant, terms } => sum(constant, terms, child, binder),
        NodeRef::Mul { coeff, factors } => match inputs.split.and_then(|split| split(n)) {
            Some((lead, rest)) => product(Some(Code::atom(lead)), 1.0, &rest, child, binder),
            None => product(None, coeff, factors, child, binder),
        },
        NodeRef::Unary(op, a) => {
            let c = child(a);
            let depth = c.depth + 1;
            let x = c.at(Prec::Atom);
            let tokens = if let UnaryOp::Smooth(k) = op {
                smooth(k, &c.tokens)
            } else {
                let method = op
                    .rust_method()
                    .expect("every UnaryOp but Smooth(k) is an f64 method");
                let method = Ident::new(method, Span::call_site());
                quote!(#x.#method())
            };
            Code {
                tokens,
                prec: Prec::Atom,
                depth,
            }
        }
        NodeRef::Pow(a, b) => {
            let (ca, cb) = (child(a), child(b));
            let x = ca.at(Prec::Atom);
            let y = &cb.tokens;
            Code {
                tokens: quote!(#x.powf(#y)),
                prec: Prec::Atom,
                depth: depth_of([ca, cb]),
            }
        }
        NodeRef::Atan2(y, x) => {
            let (cy, cx) = (child(y), child(x));
            let yt = cy.at(Prec::Atom);
            let xt = &cx.tokens;
            Code {
                tokens: quote!(#yt.atan2(#xt)),
                prec: Prec::Atom,
                depth: depth_of([cy, cx]),
            }
        }
    }
}

/// `±k₁ t₁ ± k₂ t₂ … ± c`, left to right, in chains of at most
/// [`MAX_CHAIN`] operands.
fn sum<'c>(
    constant: f64,
    terms: &[kinema_expr::Term],
    child: &dyn Fn(ExprId) -> &'c Code,
    binder: &mut Binder,
) -> Code {
    let mut chain = Chain::new();
    let depth = depth_of(terms.iter().map(|t| child(t.expr)));
    for (i, term) in terms.iter().enumerate() {
        let c = child(term.expr);
        let (neg, k) = (term.coeff < 0.0, term.coeff.abs());
        let value = if k == 1.0 {
            // The right operand of `-` must bind tighter than `+`.
            c.at(if neg && i > 0 { Prec::Mul } else { Prec::Add })
        } else {
            let k = number(k).tokens;
            let v = c.at(Prec::Mul);
            quote!(#k * #v)
        };
        let (op, operand) = match (i, neg) {
            (0, false) => (quote!(), value),
            (0, true) if k == 1.0 => {
                let v = c.at(Prec::Mul);
                (quote!(), quote!(-#v))
            }
            (0, true) => (quote!(), quote!(-#value)),
            (_, false) => (quote!(+), value),
            (_, true) => (quote!(-), value),
        };
        chain.push(op, operand, binder);
    }
    if constant != 0.0 {
        let k = number(constant.abs()).tokens;
        let op = if constant < 0.0 { quote!(-) } else { quote!(+) };
        chain.push(op, k, binder);
    }
    Code {
        tokens: chain.tokens,
        prec: Prec::Add,
        depth,
    }
}

/// `±k · n₁ · n₂ … / (d₁ · d₂ …)`, left to right, in chains of at most
/// [`MAX_CHAIN`] operands.
/// With `lead`, a value the numerator starts with.
fn product<'c>(
    lead: Option<Code>,
    coeff: f64,
    factors: &[Factor],
    child: &dyn Fn(ExprId) -> &'c Code,
    binder: &mut Binder,
) -> Code {
    let depth = depth_of(factors.iter().map(|f| child(f.base)));
    let mut power = |f: &Factor, p: f64| -> Code { binder.power(f.base, child(f.base), p) };
    let num: Vec<Code> = lead
        .into_iter()
        .chain(
            factors
                .iter()
                .filter(|f| f.exp > 0.0)
                .map(|f| power(f, f.exp)),
        )
        .collect();
    let den: Vec<Code> = factors
        .iter()
        .filter(|f| f.exp < 0.0)
        .map(|f| power(f, -f.exp))
        .collect();
    let k = coeff.abs();
    let mut chain = Chain::new();
    if k != 1.0 || num.is_empty() {
        chain.push(quote!(), number(k).tokens, binder);
    }
    for c in &num {
        let op = if chain.is_empty() {
            quote!()
        } else {
            quote!(*)
        };
        chain.push(op, c.at(Prec::Mul), binder);
    }
    match den.as_slice() {
        [] => {}
        [d] => chain.push(quote!(/), d.at(Prec::Atom), binder),
        _ => {
            let mut group = Chain::new();
            for d in &den {
                let op = if group.is_empty() {
                    quote!()
                } else {
                    quote!(*)
                };
                group.push(op, d.at(Prec::Mul), binder);
            }
            let g = group.tokens;
            chain.push(quote!(/), quote!((#g)), binder);
        }
    }
    let single = num.len() == 1 && den.is_empty() && k == 1.0;
    let prec = if single { num[0].prec } else { Prec::Mul };
    let code = Code {
        tokens: chain.tokens,
        prec,
        depth,
    };
    if coeff < 0.0 {
        let v = code.at(Prec::Mul);
        Code {
            tokens: quote!(-#v),
            prec: Prec::Mul,
            depth,
        }
    } else {
        code
    }
}

/// `base^p` for a constant `p > 0`.
fn raise(base: &Code, p: f64) -> Code {
    if p == 1.0 {
        return base.clone();
    }
    let x = base.at(Prec::Atom);
    let tokens = if p == 0.5 {
        quote!(#x.sqrt())
    } else if p.fract() == 0.5 && p < 64.0 {
        // x^(k + ½) as x^k √x: a square root and multiplications, several
        // times cheaper than `powf` (a distance's derivatives divide by
        // |d|³ and |d|⁵), within an ulp or two of it. A product: the
        // caller parenthesizes it where its precedence asks.
        let k = (p - 0.5) as i32;
        let tokens = if k == 1 {
            quote!(#x * #x.sqrt())
        } else {
            let n = Literal::i32_unsuffixed(k);
            quote!(#x.powi(#n) * #x.sqrt())
        };
        return Code {
            tokens,
            prec: Prec::Mul,
            depth: base.depth + 1,
        };
    } else if p.fract() == 0.0 && p <= f64::from(i32::MAX) {
        let n = Literal::i32_unsuffixed(p as i32);
        quote!(#x.powi(#n))
    } else {
        // `number` spells a non-finite exponent (merged exponents can
        // overflow) as `f64::INFINITY`, which a literal cannot be.
        let p = number(p).tokens;
        quote!(#x.powf(#p))
    };
    Code {
        tokens,
        prec: Prec::Atom,
        depth: base.depth + 1,
    }
}

/// The k-th derivative of the unit cubic step at `u`, inline (no runtime
/// dependency): 0 before 0, 1 (k = 0) or 0 after 1, the cubic in between.
fn smooth(k: u8, u: &TokenStream) -> TokenStream {
    let inside = match k {
        0 => quote!(u * u * (3.0 - 2.0 * u)),
        1 => quote!(6.0 * u * (1.0 - u)),
        2 => quote!(6.0 - 12.0 * u),
        _ => quote!(-12.0),
    };
    let after = if k == 0 { quote!(1.0) } else { quote!(0.0) };
    quote! {{
        let u: f64 = #u;
        if u <= 0.0 { 0.0 } else if u >= 1.0 { #after } else { #inside }
    }}
}
