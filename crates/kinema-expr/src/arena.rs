//! The hash-consed arena: node storage, interning, symbols and the canonical order.

use std::cmp::Ordering;

use rustc_hash::FxHashMap;

use crate::node::{ExprId, Factor, Node, NodeRef, SymId, SymKind, Symbol, Term, UnaryOp};

/// No node: end of an interning chain.
const NONE: u32 = u32::MAX;

/// An arena of hash-consed expressions.
///
/// Every constructor canonicalizes (see the crate docs) and then interns, so
/// building the same expression twice yields the same [`ExprId`]. Nodes are
/// never removed; children always have smaller ids than their parents.
///
/// ```
/// use kinema_expr::Arena;
/// let mut a = Arena::new();
/// let x = a.coordinate("x", 0);
/// let y = a.coordinate("y", 1);
/// let s1 = a.add(x, y);
/// let s2 = a.add(y, x);
/// assert_eq!(s1, s2);
/// assert_eq!(a.display(s1).to_string(), "x + y");
/// ```
#[derive(Clone)]
pub struct Arena {
    pub(crate) nodes: Vec<Node>,
    /// Structural hash of every node: depends only on the expression, never on
    /// ids or construction order. Drives interning and the canonical order.
    pub(crate) shash: Vec<u64>,
    /// Bloom mask of the symbols each node depends on (bit = symbol index mod 64).
    pub(crate) mask: Vec<u64>,
    /// Whether each node contains an undefined constant: a number that is not
    /// finite, or a fold that would not be (a power of the number 0 with a
    /// negative exponent, `ln 0`, …). See [`Arena::is_undefined`].
    undefined: Vec<bool>,
    /// Sort keys of the first symbol each node depends on (`u64::MAX` for
    /// constants): `[in sums, in products]`. In sums coordinates come first so
    /// that terms group by body; in products parameters come first, as
    /// coefficients are written.
    lead: Vec<[u64; 2]>,
    pub(crate) terms: Vec<Term>,
    pub(crate) factors: Vec<Factor>,
    /// Structural hash → first node with that hash; collisions chain via `next`.
    intern: FxHashMap<u64, u32>,
    next: Vec<u32>,
    pub(crate) symbols: Vec<Symbol>,
    pub(crate) sym_node: Vec<ExprId>,
    sym_lookup: FxHashMap<SymKind, SymId>,
    pub(crate) zero: ExprId,
    pub(crate) one: ExprId,
    pub(crate) calc: crate::calculus::Memo,
    /// Reusable buffers of the constructors (taken and put back, so nested
    /// calls simply get a fresh one).
    pub(crate) scratch_terms: Vec<Term>,
    pub(crate) scratch_factors: Vec<Factor>,
    /// The factors of a product as given, and the wide fold's copy of them
    /// (see `product_from`).
    pub(crate) scratch_numbers: Vec<Factor>,
    pub(crate) scratch_wide: Vec<Factor>,
}

impl Default for Arena {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for Arena {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Arena")
            .field("nodes", &self.nodes.len())
            .field("symbols", &self.symbols.len())
            .finish_non_exhaustive()
    }
}

// ---------------------------------------------------------------- hashing

const TAG_NUM: u64 = 0x6e75_6d00;
const TAG_SYM: u64 = 0x7379_6d00;
const TAG_ADD: u64 = 0x6164_6400;
const TAG_MUL: u64 = 0x6d75_6c00;
const TAG_UN: u64 = 0x756e_0000;
const TAG_POW: u64 = 0x706f_7700;
const TAG_ATAN2: u64 = 0x6174_6e32;

/// Combines a value into a running hash (fixed function: output is the same on
/// every platform and every run).
#[inline]
pub(crate) fn mix(h: u64, v: u64) -> u64 {
    let x = (h ^ v).wrapping_add(0x9e37_79b9_7f4a_7c15);
    let x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    let x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

fn hash_str(s: &str) -> u64 {
    // FNV-1a, then mixed.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in s.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    mix(h, s.len() as u64)
}

fn num_bits(v: f64) -> u64 {
    // 0.0 and -0.0 are one number.
    if v == 0.0 { 0 } else { v.to_bits() }
}

fn kind_hash(kind: SymKind) -> u64 {
    match kind {
        SymKind::Parameter(i) => mix(1, u64::from(i)),
        SymKind::Coordinate(i) => mix(2, u64::from(i)),
        SymKind::Velocity(i) => mix(3, u64::from(i)),
        SymKind::Time => 4,
    }
}

impl Arena {
    /// An empty arena (holding only the numbers 0 and 1).
    #[must_use]
    pub fn new() -> Self {
        Self::with_capacity(0)
    }

    /// An empty arena with room for about `nodes` nodes before it reallocates.
    #[must_use]
    pub fn with_capacity(nodes: usize) -> Self {
        let mut arena = Arena {
            nodes: Vec::with_capacity(nodes),
            shash: Vec::with_capacity(nodes),
            mask: Vec::with_capacity(nodes),
            undefined: Vec::with_capacity(nodes),
            lead: Vec::with_capacity(nodes),
            terms: Vec::with_capacity(nodes),
            factors: Vec::with_capacity(nodes),
            intern: FxHashMap::with_capacity_and_hasher(nodes, Default::default()),
            next: Vec::with_capacity(nodes),
            symbols: Vec::new(),
            sym_node: Vec::new(),
            sym_lookup: FxHashMap::default(),
            zero: ExprId(0),
            one: ExprId(0),
            calc: crate::calculus::Memo::default(),
            scratch_terms: Vec::new(),
            scratch_factors: Vec::new(),
            scratch_numbers: Vec::new(),
            scratch_wide: Vec::new(),
        };
        arena.zero = arena.num(0.0);
        arena.one = arena.num(1.0);
        arena
    }

    /// Number of nodes in the arena.
    #[must_use]
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the arena is empty (it never is: 0 and 1 are always present).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The number 0.
    #[must_use]
    pub fn zero(&self) -> ExprId {
        self.zero
    }

    /// The number 1.
    #[must_use]
    pub fn one(&self) -> ExprId {
        self.one
    }

    // ------------------------------------------------------------ symbols

    fn symbol_expr(&mut self, name: &str, kind: SymKind) -> ExprId {
        if let Some(&s) = self.sym_lookup.get(&kind) {
            return self.sym_node[s.index()];
        }
        let s = SymId::new(self.symbols.len());
        self.symbols.push(Symbol {
            name: name.to_owned(),
            kind,
        });
        self.sym_lookup.insert(kind, s);
        let h = mix(mix(TAG_SYM, kind_hash(kind)), hash_str(name));
        let id = self.insert(Node::Sym(s), h, 1u64 << (s.0 % 64));
        self.sym_node.push(id);
        id
    }

    /// The generalized coordinate `q[index]`, named `name` (the first name
    /// given for an index is kept).
    pub fn coordinate(&mut self, name: &str, index: u32) -> ExprId {
        self.symbol_expr(name, SymKind::Coordinate(index))
    }

    /// The velocity `q̇[index]`, named `name`.
    pub fn velocity(&mut self, name: &str, index: u32) -> ExprId {
        self.symbol_expr(name, SymKind::Velocity(index))
    }

    /// The parameter `params[index]`, named `name`: a run-time value that
    /// is never folded.
    pub fn parameter(&mut self, name: &str, index: u32) -> ExprId {
        self.symbol_expr(name, SymKind::Parameter(index))
    }

    /// Time `t`.
    pub fn time(&mut self) -> ExprId {
        self.symbol_expr("t", SymKind::Time)
    }

    /// The symbol of a kind, if it has been created.
    #[must_use]
    pub fn lookup(&self, kind: SymKind) -> Option<SymId> {
        self.sym_lookup.get(&kind).copied()
    }

    /// The symbol a leaf stands for, or `None` if `e` is not a symbol.
    #[must_use]
    pub fn symbol_of(&self, e: ExprId) -> Option<SymId> {
        match self.nodes[e.index()] {
            Node::Sym(s) => Some(s),
            _ => None,
        }
    }

    /// A symbol's name and kind.
    #[must_use]
    pub fn symbol(&self, s: SymId) -> &Symbol {
        &self.symbols[s.index()]
    }

    /// The expression that is the symbol `s`.
    #[must_use]
    pub fn sym_expr(&self, s: SymId) -> ExprId {
        self.sym_node[s.index()]
    }

    /// All symbols, in creation order.
    pub fn symbols(&self) -> impl ExactSizeIterator<Item = (SymId, &Symbol)> {
        self.symbols
            .iter()
            .enumerate()
            .map(|(i, s)| (SymId::new(i), s))
    }

    // ------------------------------------------------------------ views

    /// Whether node `e` applies a function that can have a kink (a
    /// superset of the sites [`Tape::kink`](crate::Tape::kink) checks:
    /// every fractional power): the nodes a kink check must evaluate,
    /// which the tape back end and generated code both select with this.
    #[must_use]
    pub fn applies_kink(&self, e: ExprId) -> bool {
        match self.node(e) {
            NodeRef::Unary(op, _) => matches!(
                op,
                UnaryOp::Abs | UnaryOp::Asin | UnaryOp::Acos | UnaryOp::Ln | UnaryOp::Smooth(_)
            ),
            NodeRef::Atan2(..) | NodeRef::Pow(..) => true,
            NodeRef::Mul { factors, .. } => factors.iter().any(|f| f.exp.fract() != 0.0),
            NodeRef::Num(_) | NodeRef::Sym(_) | NodeRef::Add { .. } => false,
        }
    }

    /// A view of the node `e`.
    #[must_use]
    pub fn node(&self, e: ExprId) -> NodeRef<'_> {
        match self.nodes[e.index()] {
            Node::Num(v) => NodeRef::Num(v),
            Node::Sym(s) => NodeRef::Sym(s),
            Node::Add {
                constant,
                start,
                len,
            } => NodeRef::Add {
                constant,
                terms: &self.terms[start as usize..(start + len) as usize],
            },
            Node::Mul { coeff, start, len } => NodeRef::Mul {
                coeff,
                factors: &self.factors[start as usize..(start + len) as usize],
            },
            Node::Unary(op, a) => NodeRef::Unary(op, a),
            Node::Pow(a, b) => NodeRef::Pow(a, b),
            Node::Atan2(y, x) => NodeRef::Atan2(y, x),
        }
    }

    /// The value of `e` if it is a number.
    #[must_use]
    pub fn as_num(&self, e: ExprId) -> Option<f64> {
        match self.nodes[e.index()] {
            Node::Num(v) => Some(v),
            _ => None,
        }
    }

    /// Whether `e` is the number 0.
    #[must_use]
    pub fn is_zero(&self, e: ExprId) -> bool {
        e == self.zero
    }

    /// Appends the children of `e` (its operands) to `out`, in canonical
    /// order: what a walk over the expression graph visits below `e`.
    pub fn children(&self, e: ExprId, out: &mut Vec<ExprId>) {
        match self.node(e) {
            NodeRef::Num(_) | NodeRef::Sym(_) => {}
            NodeRef::Add { terms, .. } => out.extend(terms.iter().map(|t| t.expr)),
            NodeRef::Mul { factors, .. } => out.extend(factors.iter().map(|f| f.base)),
            NodeRef::Unary(_, a) => out.push(a),
            NodeRef::Pow(a, b) | NodeRef::Atan2(a, b) => {
                out.push(a);
                out.push(b);
            }
        }
    }

    /// Calls `f` on each child of `e`.
    #[inline]
    pub fn for_each_child(&self, e: ExprId, f: impl FnMut(ExprId)) {
        self.for_each_child_of(&self.nodes[e.index()], f);
    }

    #[inline]
    fn for_each_child_of(&self, node: &Node, mut f: impl FnMut(ExprId)) {
        match *node {
            Node::Num(_) | Node::Sym(_) => {}
            Node::Add { start, len, .. } => {
                for t in &self.terms[start as usize..(start + len) as usize] {
                    f(t.expr);
                }
            }
            Node::Mul { start, len, .. } => {
                for t in &self.factors[start as usize..(start + len) as usize] {
                    f(t.base);
                }
            }
            Node::Unary(_, a) => f(a),
            Node::Pow(a, b) | Node::Atan2(a, b) => {
                f(a);
                f(b);
            }
        }
    }

    // ------------------------------------------------------------ order

    /// The canonical order of the terms of a sum: numbers first (by value);
    /// then by the first symbol each term depends on, in the order
    /// coordinates, velocities, time, parameters (each by index), so that
    /// printed sums group their terms by coordinate; then by node kind
    /// (symbols, functions, powers, products, sums); then symbols by name and
    /// compound nodes by structural hash.
    ///
    /// Like [`factor_cmp`](Self::factor_cmp), it depends only on the
    /// expressions compared, never on how or in which order they were built.
    #[must_use]
    pub fn term_cmp(&self, a: ExprId, b: ExprId) -> Ordering {
        self.canonical_cmp(a, b, 0)
    }

    /// The canonical order of the factors of a product: as
    /// [`term_cmp`](Self::term_cmp) but with parameters first among symbols
    /// (`l1*cos(phi1)`, as coefficients are written).
    #[must_use]
    pub fn factor_cmp(&self, a: ExprId, b: ExprId) -> Ordering {
        self.canonical_cmp(a, b, 1)
    }

    fn canonical_cmp(&self, a: ExprId, b: ExprId, which: usize) -> Ordering {
        if a == b {
            return Ordering::Equal;
        }
        let (na, nb) = (&self.nodes[a.index()], &self.nodes[b.index()]);
        let num = |n: &Node| !matches!(n, Node::Num(_));
        num(na)
            .cmp(&num(nb))
            .then_with(|| self.lead[a.index()][which].cmp(&self.lead[b.index()][which]))
            .then_with(|| na.rank().cmp(&nb.rank()))
            .then_with(|| match (na, nb) {
                (Node::Num(x), Node::Num(y)) => x.total_cmp(y),
                (Node::Sym(x), Node::Sym(y)) => self.symbols[x.index()]
                    .name
                    .cmp(&self.symbols[y.index()].name),
                // Equal structural hashes of distinct nodes (a 64-bit collision)
                // fall back to the id: the only place construction order could show.
                _ => self.shash[a.index()]
                    .cmp(&self.shash[b.index()])
                    .then(a.cmp(&b)),
            })
    }

    // ------------------------------------------------------------ interning

    /// Interns a node whose operands are already canonical. For sums and
    /// products the operands are the last `len` entries of the pool (they are
    /// popped again if an equal node exists).
    pub(crate) fn intern(&mut self, node: Node) -> ExprId {
        // Every undefined expression is one node, the number NaN: its value
        // is undefined wherever it is evaluated, and one spelling keeps the
        // canonical form independent of the order of construction (x·∞·0⁻¹
        // built either way). [`is_undefined`](Self::is_undefined) of every
        // expression is unchanged: undefinedness propagates to every node
        // that contains an undefined operand.
        let canonical_nan = matches!(node, Node::Num(v) if v.to_bits() == f64::NAN.to_bits());
        if !canonical_nan && self.node_undefined(&node) {
            Self::drop_operands(&mut self.terms, &mut self.factors, &node);
            return self.intern(Node::Num(f64::NAN));
        }
        let (h, m) = self.hash_and_mask(&node);
        let mut cur = self.intern.get(&h).copied().unwrap_or(NONE);
        while cur != NONE {
            if self.same(&self.nodes[cur as usize], &node) {
                // The operands just pushed for this node are a copy.
                Self::drop_operands(&mut self.terms, &mut self.factors, &node);
                return ExprId(cur);
            }
            cur = self.next[cur as usize];
        }
        self.insert(node, h, m)
    }

    /// Drops the operands pushed for `node` (the last ones of `terms` or
    /// `factors`) when it is not inserted.
    fn drop_operands(terms: &mut Vec<Term>, factors: &mut Vec<Factor>, node: &Node) {
        match *node {
            Node::Add { start, .. } => terms.truncate(start as usize),
            Node::Mul { start, .. } => factors.truncate(start as usize),
            _ => {}
        }
    }

    fn insert(&mut self, node: Node, h: u64, m: u64) -> ExprId {
        let lead = match node {
            Node::Num(_) => [u64::MAX; 2],
            Node::Sym(s) => {
                let kind = self.symbols[s.index()].kind;
                let (rank, index) = kind.rank();
                let in_sums = match kind {
                    SymKind::Parameter(_) => 3,
                    _ => rank - 1,
                };
                let key = |r: u8| (u64::from(r) << 32) | u64::from(index);
                [key(in_sums), key(rank)]
            }
            _ => {
                let mut lead = [u64::MAX; 2];
                self.for_each_child_of(&node, |c| {
                    let l = self.lead[c.index()];
                    lead = [lead[0].min(l[0]), lead[1].min(l[1])];
                });
                lead
            }
        };
        let e = ExprId::new(self.nodes.len());
        // u32::MAX is the intern chains' end marker: it is never an id.
        assert!(
            e.0 != NONE,
            "ExprId index {NONE} does not fit: the arena is full"
        );
        let id = e.0;
        let prev = self.intern.insert(h, id).unwrap_or(NONE);
        self.nodes.push(node);
        self.shash.push(h);
        self.mask.push(m);
        let undefined = self.node_undefined(&node);
        self.undefined.push(undefined);
        self.lead.push(lead);
        self.next.push(prev);
        e
    }

    fn hash_and_mask(&self, node: &Node) -> (u64, u64) {
        match *node {
            Node::Num(v) => (mix(TAG_NUM, num_bits(v)), 0),
            Node::Sym(s) => {
                let kind = self.symbols[s.index()].kind;
                (
                    mix(
                        mix(TAG_SYM, kind_hash(kind)),
                        hash_str(&self.symbols[s.index()].name),
                    ),
                    1u64 << (s.0 % 64),
                )
            }
            Node::Add {
                constant,
                start,
                len,
            } => {
                let mut h = mix(TAG_ADD, num_bits(constant));
                let mut m = 0;
                for t in &self.terms[start as usize..(start + len) as usize] {
                    h = mix(mix(h, num_bits(t.coeff)), self.shash[t.expr.index()]);
                    m |= self.mask[t.expr.index()];
                }
                (h, m)
            }
            Node::Mul { coeff, start, len } => {
                let mut h = mix(TAG_MUL, num_bits(coeff));
                let mut m = 0;
                for f in &self.factors[start as usize..(start + len) as usize] {
                    h = mix(mix(h, num_bits(f.exp)), self.shash[f.base.index()]);
                    m |= self.mask[f.base.index()];
                }
                (h, m)
            }
            Node::Unary(op, a) => (
                mix(mix(TAG_UN, op.tag()), self.shash[a.index()]),
                self.mask[a.index()],
            ),
            Node::Pow(a, b) => (
                mix(mix(TAG_POW, self.shash[a.index()]), self.shash[b.index()]),
                self.mask[a.index()] | self.mask[b.index()],
            ),
            Node::Atan2(a, b) => (
                mix(mix(TAG_ATAN2, self.shash[a.index()]), self.shash[b.index()]),
                self.mask[a.index()] | self.mask[b.index()],
            ),
        }
    }

    fn same(&self, a: &Node, b: &Node) -> bool {
        match (*a, *b) {
            (Node::Num(x), Node::Num(y)) => num_bits(x) == num_bits(y),
            (Node::Sym(x), Node::Sym(y)) => x == y,
            (
                Node::Add {
                    constant: c1,
                    start: s1,
                    len: l1,
                },
                Node::Add {
                    constant: c2,
                    start: s2,
                    len: l2,
                },
            ) => {
                num_bits(c1) == num_bits(c2)
                    && l1 == l2
                    && self.terms[s1 as usize..(s1 + l1) as usize]
                        .iter()
                        .zip(&self.terms[s2 as usize..(s2 + l2) as usize])
                        .all(|(p, q)| p.expr == q.expr && num_bits(p.coeff) == num_bits(q.coeff))
            }
            (
                Node::Mul {
                    coeff: c1,
                    start: s1,
                    len: l1,
                },
                Node::Mul {
                    coeff: c2,
                    start: s2,
                    len: l2,
                },
            ) => {
                num_bits(c1) == num_bits(c2)
                    && l1 == l2
                    && self.factors[s1 as usize..(s1 + l1) as usize]
                        .iter()
                        .zip(&self.factors[s2 as usize..(s2 + l2) as usize])
                        .all(|(p, q)| p.base == q.base && num_bits(p.exp) == num_bits(q.exp))
            }
            (Node::Unary(o1, a1), Node::Unary(o2, a2)) => o1 == o2 && a1 == a2,
            (Node::Pow(a1, b1), Node::Pow(a2, b2)) | (Node::Atan2(a1, b1), Node::Atan2(a2, b2)) => {
                a1 == a2 && b1 == b2
            }
            _ => false,
        }
    }

    /// Whether `e` contains an undefined constant: a number that is not
    /// finite (an overflowed fold such as `1e308 * 1e308`), or a constant
    /// operation the constructors could not fold to a finite number (a
    /// division by an expression that is identically zero, `ln 0`, …).
    ///
    /// The constructors never simplify such a part away (`0 · u`, `u − u`,
    /// `u / u` stay undefined, as NaN), so an expression whose value is
    /// undefined everywhere never looks defined.
    #[must_use]
    pub fn is_undefined(&self, e: ExprId) -> bool {
        self.undefined[e.index()]
    }

    fn node_undefined(&self, node: &Node) -> bool {
        let num = |e: ExprId| matches!(self.nodes[e.index()], Node::Num(_));
        match *node {
            Node::Num(v) => !v.is_finite(),
            Node::Sym(_) => false,
            Node::Add {
                constant,
                start,
                len,
            } => {
                !constant.is_finite()
                    || self.terms[start as usize..(start + len) as usize]
                        .iter()
                        .any(|t| self.undefined[t.expr.index()])
            }
            // A number left as a factor is a power whose fold was not finite
            // (0^-1, an overflowed coefficient), or one that would have
            // underflowed (defined: its power is finite).
            Node::Mul { coeff, start, len } => {
                !coeff.is_finite()
                    || self.factors[start as usize..(start + len) as usize]
                        .iter()
                        .any(|f| {
                            self.undefined[f.base.index()]
                                || matches!(self.nodes[f.base.index()], Node::Num(v)
                                    if !crate::build::number_power_defined(v, f.exp))
                        })
            }
            // A function of a number is left unfolded only when its value is not finite.
            Node::Unary(_, a) => self.undefined[a.index()] || num(a),
            Node::Pow(a, b) => self.undefined[a.index()] || self.undefined[b.index()],
            Node::Atan2(a, b) => {
                self.undefined[a.index()] || self.undefined[b.index()] || (num(a) && num(b))
            }
        }
    }

    /// Bloom mask of the symbols `e` may depend on.
    #[inline]
    pub(crate) fn mask_of(&self, e: ExprId) -> u64 {
        self.mask[e.index()]
    }

    /// Structural hash of `e`: a function of the expression alone.
    #[must_use]
    pub fn structural_hash(&self, e: ExprId) -> u64 {
        self.shash[e.index()]
    }
}
