//! The derivation as stable, readable text (what users snapshot with insta).

use std::fmt::Write as _;

use kinema_expr::{ExprId, SparseMatrix, format_number};

use crate::derive::{Derivation, RowKind};

/// Printing every entry as a tree is kept while the trees hold at most this
/// many nodes in all, or at most [`TREE_RATIO`] times the distinct nodes.
const TREE_TOTAL_MIN: u64 = 200_000;
/// See [`TREE_TOTAL_MIN`].
const TREE_RATIO: u64 = 16;
/// When trees would blow up, entries larger than this are printed once, in
/// a shared program at the end (linear in the number of distinct nodes).
const INLINE_MAX: u64 = 100;

/// Where entries too large to print as trees go.
struct Deferred {
    /// Tree size of every node, when entries are deferred at all.
    sizes: Option<Vec<u64>>,
    entries: Vec<(String, ExprId)>,
}

impl Deferred {
    /// Writes `e`, or a reference to it in the shared program.
    fn write(&mut self, d: &Derivation, out: &mut String, label: String, e: ExprId) {
        match &self.sizes {
            Some(sizes) if sizes[e.index()] > INLINE_MAX => {
                let _ = write!(out, "{label} (see the shared program below)");
                self.entries.push((label, e));
            }
            _ => {
                let _ = write!(out, "{}", d.arena.display(e));
            }
        }
    }
}

impl Derivation {
    /// The whole derivation as text: DOF report, params, coordinates, rows,
    /// Φ, Φ_q, Φ_t, Φ_qt, Φ_tt, (Φ_q q̇)_q q̇, ν, γ. Zero entries of vectors
    /// are listed as `0`; sparse matrices list their structural nonzeros.
    /// Deterministic: the same model always renders the same text.
    ///
    /// Entries are printed as trees, shared subexpressions written out at
    /// each use. When that would make the text much larger than the
    /// derivation itself (a long product, whose second derivatives share
    /// everything), the large entries are printed once each in a program
    /// with `let` bindings at the end instead, so the text stays linear in
    /// the size of the derivation.
    #[must_use]
    pub fn render(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "mechanism {}", self.name);
        for d in &self.docs {
            let _ = writeln!(out, "  /// {d}");
        }
        let _ = writeln!(out, "dof: {}", self.dof);

        let _ = writeln!(out, "\nparams:");
        if self.params.is_empty() {
            let _ = writeln!(out, "  (none)");
        }
        for p in &self.params {
            let _ = write!(out, "  {} = {}", p.name, format_number(p.value));
            if !p.docs.is_empty() {
                let _ = write!(out, "  /// {}", p.docs.join(" "));
            }
            out.push('\n');
        }

        let _ = writeln!(out, "\ncoordinates (guess):");
        for (i, c) in self.coordinates.iter().enumerate() {
            let _ = write!(
                out,
                "  q[{i}] {} = {} ({})",
                c.name,
                self.arena.display(c.guess),
                format_number(c.guess_value)
            );
            // A stated initial velocity (only then: the text of models
            // without one is unchanged).
            if let Some(v) = c.initial_velocity {
                let _ = write!(
                    out,
                    ", velocity {} ({})",
                    self.arena.display(v),
                    format_number(c.initial_velocity_value)
                );
            }
            out.push('\n');
        }

        let _ = writeln!(out, "\nequations:");
        for (i, r) in self.rows.iter().enumerate() {
            let kind = match r.kind {
                RowKind::Kinematic => "kinematic",
                RowKind::Driving => "driving",
            };
            let _ = write!(out, "  [{i}] {} ({kind}, {}", r.name, r.keyword.as_str());
            if let Some(l) = r.library {
                let _ = write!(out, " {}", l.name());
            }
            out.push(')');
            if !r.docs.is_empty() {
                let _ = write!(out, "  /// {}", r.docs.join(" "));
            }
            out.push('\n');
        }

        let mut deferred = Deferred {
            sizes: self.tree_blowup(),
            entries: Vec::new(),
        };
        let d = &mut deferred;
        self.vector(&mut out, d, "Phi", &self.phi);
        self.matrix(&mut out, d, "Phi_q", &self.phi_q);
        self.vector(&mut out, d, "Phi_t", &self.phi_t);
        self.matrix(&mut out, d, "Phi_qt", &self.phi_qt);
        self.vector(&mut out, d, "Phi_tt", &self.phi_tt);
        self.vector(&mut out, d, "(Phi_q qdot)_q qdot", &self.phi_q_qdot_q_qdot);
        self.vector(&mut out, d, "nu", &self.nu);
        self.vector(&mut out, d, "gamma", &self.gamma);
        self.outputs_section(&mut out, d);
        self.shared_program(&mut out, &deferred);
        out
    }

    /// The sensitivities ([`Derivation::sensitivities`]) as text, one
    /// section per param: Φ_p, the velocity right-hand side, the
    /// acceleration right-hand side (its q̈-free part and W, the q̈ terms
    /// being −W q̈), and each result's y_p, ẏ_p, ÿ_p. `∂B.x` is ∂(B.x)/∂p
    /// for the section's param p, `∂B.x_dot` and `∂B.x_ddot` its velocity
    /// and acceleration. Deterministic, and linear in the size of the
    /// derivation as [`Derivation::render`] is.
    #[must_use]
    pub fn render_sensitivities(&self, s: &crate::sensitivity::Sensitivities) -> String {
        let mut out = String::new();
        let _ = writeln!(
            out,
            "sensitivities of {} (for each param p: Phi_q ∂q = -Phi_p, \
             Phi_q ∂qdot = velocity rhs, Phi_q ∂qddot = acceleration rhs - W qddot; \
             ∂B.x is ∂(B.x)/∂p)",
            self.name
        );
        let mut roots: Vec<ExprId> = Vec::new();
        for p in &s.params {
            roots.extend_from_slice(&p.phi_p);
            roots.extend_from_slice(&p.velocity_rhs);
            roots.extend_from_slice(&p.acceleration_rhs);
            roots.extend(p.acceleration_qdd.entries.iter().map(|en| en.expr));
            for o in &p.outputs {
                roots.extend([o.value, o.velocity, o.acceleration]);
                roots.extend(o.qdd.iter().map(|&(_, e)| e));
            }
            if let Some(dy) = &p.dynamics {
                roots.extend(dy.mass.iter().chain(&dy.applied));
                roots.extend(dy.arms.iter().flatten());
            }
        }
        let mut deferred = Deferred {
            sizes: self.blowup_of(&roots),
            entries: Vec::new(),
        };
        let d = &mut deferred;
        for p in &s.params {
            let _ = writeln!(
                out,
                "
with respect to {}:",
                p.name
            );
            let name = &p.name;
            self.vector(&mut out, d, &format!("Phi_p (p = {name})"), &p.phi_p);
            let title = format!("velocity rhs (p = {name})");
            self.vector(&mut out, d, &title, &p.velocity_rhs);
            let title = format!("acceleration rhs without its qddot terms (p = {name})");
            self.vector(&mut out, d, &title, &p.acceleration_rhs);
            let title =
                format!("W, the acceleration rhs's qddot terms being -W qddot (p = {name})");
            self.matrix(&mut out, d, &title, &p.acceleration_qdd);
            if !p.outputs.is_empty() {
                let _ = writeln!(out, "\noutputs (p = {name}):");
            }
            for (o, column) in p.outputs.iter().zip(&self.outputs) {
                let _ = write!(out, "  ∂{}: ", o.name);
                d.write(self, &mut out, format!("∂{} (p = {name})", o.name), o.value);
                let _ = write!(out, "\n  ∂{}_dot: ", o.name);
                d.write(
                    self,
                    &mut out,
                    format!("∂{}_dot (p = {name})", o.name),
                    o.velocity,
                );
                let _ = write!(out, "\n  ∂{}_ddot: ", o.name);
                let label = format!("∂{}_ddot (p = {name})", o.name);
                let mut first = true;
                for (prefix, terms) in [("∂", column.jacobian.as_slice()), ("", o.qdd.as_slice())]
                {
                    self.qdd_terms(&mut out, d, &label, prefix, terms, &mut first);
                }
                if first || !self.arena.is_zero(o.acceleration) {
                    if !first {
                        out.push_str(" + ");
                    }
                    d.write(
                        self,
                        &mut out,
                        format!("{label} - qddot terms"),
                        o.acceleration,
                    );
                }
                out.push('\n');
            }
            if let Some(dy) = &p.dynamics {
                self.dynamics_sensitivity(&mut out, d, name, dy);
            }
        }
        self.shared_program(&mut out, &deferred);
        out
    }

    /// The dynamics part of one param's section: ∂M/∂p (nonzero entries)
    /// and dQ_A/dp, per coordinate.
    fn dynamics_sensitivity(
        &self,
        out: &mut String,
        d: &mut Deferred,
        name: &str,
        dy: &crate::sensitivity::DynamicsSensitivity,
    ) {
        let _ = writeln!(
            out,
            "\ndynamics (p = {name}; Phi_q^T ∂lambda = dQ_A/dp - (dM/dp) qddot - M ∂qddot - W^T lambda):"
        );
        for (title, v) in [("dM/dp", &dy.mass), ("dQ_A/dp", &dy.applied)] {
            let _ = write!(out, "  {title}:");
            if v.iter().all(|&e| self.arena.is_zero(e)) {
                let _ = writeln!(out, " (all zero)");
                continue;
            }
            out.push('\n');
            for (k, &e) in v.iter().enumerate() {
                if self.arena.is_zero(e) {
                    continue;
                }
                let q = self.coordinates.get(k).map_or("?", |c| c.name.as_str());
                let _ = write!(out, "    [{k}] {q}: ");
                d.write(self, out, format!("{title}[{k}] (p = {name})"), e);
                out.push('\n');
            }
        }
        // The reactions' arms (their torques are about the element's
        // point): only those that move with p.
        let reactions = self.dynamics.as_ref().map_or(&[][..], |dd| &dd.reactions);
        let moving: Vec<_> = reactions
            .iter()
            .zip(&dy.arms)
            .filter(|(_, a)| a.iter().any(|&e| !self.arena.is_zero(e)))
            .collect();
        let _ = write!(out, "  d(arm)/dp, the reactions' arms (element.body):");
        if moving.is_empty() {
            let _ = writeln!(out, " (all zero)");
            return;
        }
        out.push('\n');
        for (r, arm) in moving {
            let body = self.bodies.get(r.body).map_or("?", String::as_str);
            for (c, &e) in ["x", "y"].iter().zip(arm) {
                let label = format!("d(arm)/dp {}.{body}.{c}", r.element);
                let _ = write!(out, "    {}.{body}.{c}: ", r.element);
                d.write(self, out, format!("{label} (p = {name})"), e);
                out.push('\n');
            }
        }
    }

    /// Writes `Σ coefficient·{prefix}{q}_ddot` for the (coordinate,
    /// coefficient) `terms`, a coefficient 1 as the bare acceleration.
    fn qdd_terms(
        &self,
        out: &mut String,
        d: &mut Deferred,
        label: &str,
        prefix: &str,
        terms: &[(u32, ExprId)],
        first: &mut bool,
    ) {
        for &(k, e) in terms {
            let q = self
                .coordinates
                .get(k as usize)
                .map_or("?", |c| c.name.as_str());
            if !*first {
                out.push_str(" + ");
            }
            *first = false;
            if self.arena.as_num(e) == Some(1.0) {
                let _ = write!(out, "{prefix}{q}_ddot");
            } else {
                out.push('(');
                d.write(self, out, format!("{label} / {prefix}{q}_ddot"), e);
                let _ = write!(out, ")*{prefix}{q}_ddot");
            }
        }
    }

    /// The program of the entries too large to print as trees, if any.
    fn shared_program(&self, out: &mut String, deferred: &Deferred) {
        if deferred.entries.is_empty() {
            return;
        }
        let _ = writeln!(
            out,
            "\nshared program (entries too large to print as trees; `v0`, `v1`, … name \
             subexpressions used more than once):"
        );
        let outputs: Vec<(&str, ExprId)> = deferred
            .entries
            .iter()
            .map(|(l, e)| (l.as_str(), *e))
            .collect();
        out.push_str(&self.arena.display_program(&outputs));
    }

    /// The tree size of every node when printing every entry as a tree
    /// would blow up (see [`TREE_TOTAL_MIN`]); `None` when it would not.
    fn tree_blowup(&self) -> Option<Vec<u64>> {
        let mut roots: Vec<ExprId> = Vec::new();
        for v in [
            &self.phi,
            &self.phi_t,
            &self.phi_tt,
            &self.phi_q_qdot_q_qdot,
            &self.nu,
            &self.gamma,
        ] {
            roots.extend_from_slice(v);
        }
        for m in [&self.phi_q, &self.phi_qt] {
            roots.extend(m.entries.iter().map(|en| en.expr));
        }
        for o in &self.outputs {
            roots.extend([o.value, o.velocity, o.acceleration]);
            roots.extend(o.jacobian.iter().map(|&(_, e)| e));
        }
        self.blowup_of(&roots)
    }

    /// [`Derivation::tree_blowup`] of the entries `roots`.
    fn blowup_of(&self, roots: &[ExprId]) -> Option<Vec<u64>> {
        let sizes = self.arena.tree_sizes();
        let total = roots
            .iter()
            .fold(0u64, |acc, e| acc.saturating_add(sizes[e.index()]));
        let dag = self.arena.dag_size(roots) as u64;
        (total > TREE_TOTAL_MIN && total > TREE_RATIO.saturating_mul(dag)).then_some(sizes)
    }

    fn vector(&self, out: &mut String, d: &mut Deferred, title: &str, v: &[ExprId]) {
        let _ = writeln!(out, "\n{title}:");
        if v.iter().all(|&e| self.arena.is_zero(e)) {
            let _ = writeln!(out, "  (all zero)");
            return;
        }
        for (i, &e) in v.iter().enumerate() {
            let name = self.rows.get(i).map_or("?", |r| r.name.as_str());
            let _ = write!(out, "  [{i}] {name}: ");
            d.write(self, out, format!("{title}[{i}]"), e);
            out.push('\n');
        }
    }

    /// Named points and measures: value, `_dot` and `_ddot`, the last as
    /// Σ (∂y/∂q_k) q̈_k + c with the q̈ written `B.x_ddot` (docs once per
    /// declaration).
    fn outputs_section(&self, out: &mut String, d: &mut Deferred) {
        if self.outputs.is_empty() {
            return;
        }
        let _ = writeln!(out, "\noutputs (named points, then measures):");
        let mut previous: Option<&str> = None;
        for o in &self.outputs {
            if previous != Some(o.declared.as_str()) && !o.docs.is_empty() {
                let _ = writeln!(out, "  /// {}", o.docs.join(" "));
            }
            previous = Some(o.declared.as_str());
            let _ = write!(out, "  {}: ", o.name);
            d.write(self, out, o.name.clone(), o.value);
            let _ = write!(out, "\n  {}_dot: ", o.name);
            d.write(self, out, format!("{}_dot", o.name), o.velocity);
            let _ = write!(out, "\n  {}_ddot: ", o.name);
            let mut first = true;
            for &(k, e) in &o.jacobian {
                let q = self
                    .coordinates
                    .get(k as usize)
                    .map_or("?", |c| c.name.as_str());
                if !first {
                    out.push_str(" + ");
                }
                first = false;
                if self.arena.as_num(e) == Some(1.0) {
                    let _ = write!(out, "{q}_ddot");
                } else {
                    out.push('(');
                    d.write(self, out, format!("{}_ddot / {q}_ddot", o.name), e);
                    let _ = write!(out, ")*{q}_ddot");
                }
            }
            if first || !self.arena.is_zero(o.acceleration) {
                if !first {
                    out.push_str(" + ");
                }
                d.write(
                    self,
                    out,
                    format!("{}_ddot - q̈ terms", o.name),
                    o.acceleration,
                );
            }
            out.push('\n');
        }
    }

    fn matrix(&self, out: &mut String, d: &mut Deferred, title: &str, m: &SparseMatrix) {
        let _ = writeln!(out, "\n{title}: {} nonzeros", m.entries.len());
        for en in &m.entries {
            let row = self
                .rows
                .get(en.row as usize)
                .map_or("?", |r| r.name.as_str());
            let col = self
                .coordinates
                .get(en.col as usize)
                .map_or("?", |c| c.name.as_str());
            let _ = write!(out, "  [{}, {}] {row} / {col}: ", en.row, en.col);
            d.write(
                self,
                out,
                format!("{title}[{}, {}]", en.row, en.col),
                en.expr,
            );
            out.push('\n');
        }
    }
}
