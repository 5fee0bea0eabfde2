//! The derivation as stable, readable text (what users snapshot with insta).

use std::fmt::Write as _;

use kinema_expr::{ExprId, SparseMatrix, format_number};

use crate::derive::{Derivation, RowKind};

impl Derivation {
    /// The whole derivation as text: DOF report, params, coordinates, rows,
    /// Φ, Φ_q, Φ_t, Φ_qt, Φ_tt, (Φ_q q̇)_q q̇, ν, γ. Zero entries of vectors
    /// are listed as `0`; sparse matrices list their structural nonzeros.
    /// Deterministic: the same model always renders the same text.
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
            let _ = writeln!(
                out,
                "  q[{i}] {} = {} ({})",
                c.name,
                self.arena.display(c.guess),
                format_number(c.guess_value)
            );
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

        self.vector(&mut out, "Phi", &self.phi);
        self.matrix(&mut out, "Phi_q", &self.phi_q);
        self.vector(&mut out, "Phi_t", &self.phi_t);
        self.matrix(&mut out, "Phi_qt", &self.phi_qt);
        self.vector(&mut out, "Phi_tt", &self.phi_tt);
        self.vector(&mut out, "(Phi_q qdot)_q qdot", &self.phi_q_qdot_q_qdot);
        self.vector(&mut out, "nu", &self.nu);
        self.vector(&mut out, "gamma", &self.gamma);
        out
    }

    fn vector(&self, out: &mut String, title: &str, v: &[ExprId]) {
        let _ = writeln!(out, "\n{title}:");
        if v.iter().all(|&e| self.arena.is_zero(e)) {
            let _ = writeln!(out, "  (all zero)");
            return;
        }
        for (i, &e) in v.iter().enumerate() {
            let name = self.rows.get(i).map_or("?", |r| r.name.as_str());
            let _ = writeln!(out, "  [{i}] {name}: {}", self.arena.display(e));
        }
    }

    fn matrix(&self, out: &mut String, title: &str, m: &SparseMatrix) {
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
            let _ = writeln!(
                out,
                "  [{}, {}] {row} / {col}: {}",
                en.row,
                en.col,
                self.arena.display(en.expr)
            );
        }
    }
}
