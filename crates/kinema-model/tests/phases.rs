//! The phases of kinema-model only point down: syntax ← check ← derive.
//!
//! This test reads the crate's own sources under `src/syntax*` and
//! `src/check/`, parses them with syn and resolves every path that names a
//! module of this crate (`use crate::…`, `super::…`, `self::…`, written in
//! an import, an expression, a type or a macro's tokens). Each phase may
//! name only itself, the phases below it and the shared infrastructure:
//!
//! - syntax: `syntax`, `span`, `diagnostic`, `source` and `idx` (the
//!   crate's index conversion, in lib.rs);
//! - check: the above and `check`, `ctxt` (the error collector) and
//!   `algebra` (vector algebra over the arena, phase-neutral).
//!
//! Everything else is the derivation (`derive`, `dynamics`, `outputs`,
//! `follower`, `library`, `linkage`, `render`, …) or a name the crate root
//! re-exports from it (`crate::Derivation`), and is refused: an allow
//! list, so a new module is below the checker only once it is added here.
//! Comments are not code: a doc link to a later phase is allowed.

use std::path::{Path, PathBuf};

use proc_macro2::{TokenStream, TokenTree};
use syn::visit::Visit;

/// What each phase may name at the crate's top level.
const SYNTAX_MAY_USE: &[&str] = &["syntax", "span", "diagnostic", "source", "idx"];
const CHECK_MAY_USE: &[&str] = &[
    "syntax",
    "span",
    "diagnostic",
    "source",
    "check",
    "ctxt",
    "algebra",
    "idx",
];

/// A path of this crate named by a file: the top-level name it resolves to
/// (`*` for a glob of the crate root) and the line it is written on.
#[derive(Debug, PartialEq)]
struct Use {
    top: String,
    line: usize,
}

/// Collects the top-level names of this crate that a file's code names.
struct Collector {
    /// The module the code being visited is in (`["check", "coord"]`),
    /// inline modules included.
    module: Vec<String>,
    found: Vec<Use>,
}

impl Collector {
    /// Records `segments` (a path as written, glob as `*`) if it starts in
    /// this crate (`crate`, `super`, `self`).
    fn record(&mut self, segments: &[String], line: usize) {
        let mut base: Vec<String>;
        let rest: &[String];
        match segments.first().map(String::as_str) {
            Some("crate") => {
                base = Vec::new();
                rest = &segments[1..];
            }
            Some("self" | "super") => {
                base = self.module.clone();
                let mut k = 0;
                if segments[0] == "self" {
                    k = 1;
                }
                while segments.get(k).map(String::as_str) == Some("super") {
                    base.pop();
                    k += 1;
                }
                rest = &segments[k..];
            }
            // An extern crate, a local name, a std path.
            _ => return,
        }
        base.extend(rest.iter().cloned());
        // `pub(crate)`, `use super::{self}`: names no module of the crate.
        if let Some(top) = base.first() {
            self.found.push(Use {
                top: top.clone(),
                line,
            });
        }
    }

    /// Every path of a `use` tree, flattened.
    fn use_tree(&mut self, prefix: &mut Vec<String>, tree: &syn::UseTree) {
        match tree {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                self.use_tree(prefix, &p.tree);
                prefix.pop();
            }
            syn::UseTree::Name(n) => self.leaf(prefix, n.ident.to_string(), line(&n.ident)),
            syn::UseTree::Rename(r) => self.leaf(prefix, r.ident.to_string(), line(&r.ident)),
            syn::UseTree::Glob(g) => {
                self.leaf(prefix, "*".to_string(), g.star_token.span.start().line);
            }
            syn::UseTree::Group(g) => {
                for t in &g.items {
                    self.use_tree(prefix, t);
                }
            }
        }
    }

    fn leaf(&mut self, prefix: &mut Vec<String>, last: String, line: usize) {
        // `use super::{self, x}` names the prefix itself.
        if last != "self" {
            prefix.push(last);
            self.record(prefix, line);
            prefix.pop();
        } else {
            self.record(prefix, line);
        }
    }

    /// `crate :: a :: b` (and `super`, `self`) in a macro's tokens, which
    /// syn does not parse as paths.
    fn tokens(&mut self, tokens: TokenStream) {
        let trees: Vec<TokenTree> = tokens.into_iter().collect();
        let mut k = 0;
        while k < trees.len() {
            if let TokenTree::Group(g) = &trees[k] {
                self.tokens(g.stream());
                k += 1;
                continue;
            }
            let starts = matches!(&trees[k], TokenTree::Ident(i)
                if (i == "crate" || i == "super" || i == "self") && !after_colons(&trees, k));
            if !starts {
                k += 1;
                continue;
            }
            let line = trees[k].span().start().line;
            let mut segments = vec![trees[k].to_string()];
            let mut j = k + 1;
            while colons(&trees, j) {
                match trees.get(j + 2) {
                    Some(TokenTree::Ident(i)) => segments.push(i.to_string()),
                    _ => break,
                }
                j += 3;
            }
            self.record(&segments, line);
            k = j.max(k + 1);
        }
    }
}

/// Whether `trees[j]`, `trees[j + 1]` are the two colons of `::`.
fn colons(trees: &[TokenTree], j: usize) -> bool {
    let colon =
        |t: Option<&TokenTree>| matches!(t, Some(TokenTree::Punct(p)) if p.as_char() == ':');
    colon(trees.get(j)) && colon(trees.get(j + 1))
}

/// Whether `trees[k]` follows a `::` (a segment inside a longer path).
fn after_colons(trees: &[TokenTree], k: usize) -> bool {
    k >= 2 && colons(trees, k - 2)
}

fn line(ident: &proc_macro2::Ident) -> usize {
    ident.span().start().line
}

impl<'ast> Visit<'ast> for Collector {
    fn visit_item_mod(&mut self, i: &'ast syn::ItemMod) {
        self.module.push(i.ident.to_string());
        syn::visit::visit_item_mod(self, i);
        self.module.pop();
    }

    fn visit_item_use(&mut self, i: &'ast syn::ItemUse) {
        self.use_tree(&mut Vec::new(), &i.tree);
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        let segments: Vec<String> = p.segments.iter().map(|s| s.ident.to_string()).collect();
        let line = p.segments.first().map_or(0, |s| line(&s.ident));
        self.record(&segments, line);
        syn::visit::visit_path(self, p);
    }

    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        self.tokens(m.tokens.clone());
        syn::visit::visit_macro(self, m);
    }

    // Doc comments are attributes: a link to a later phase is not a use.
    fn visit_attribute(&mut self, _: &'ast syn::Attribute) {}
}

/// The crate-level names the source of module `module` uses.
fn uses(module: &[&str], source: &str) -> Vec<Use> {
    let file = syn::parse_file(source).unwrap_or_else(|e| panic!("{module:?}: {e}"));
    let mut c = Collector {
        module: module.iter().map(ToString::to_string).collect(),
        found: Vec::new(),
    };
    c.visit_file(&file);
    // `use crate::follower::{CoordDecl, CurveDecl}` is one use.
    c.found.dedup();
    c.found
}

/// The uses of `source` (module `module`) that `allowed` does not allow, as
/// messages.
fn violations(file: &str, module: &[&str], source: &str, allowed: &[&str]) -> Vec<String> {
    uses(module, source)
        .into_iter()
        .filter(|u| !allowed.contains(&u.top.as_str()))
        .map(|u| {
            format!(
                "{file}:{}: `{}` names `crate::{}`, which is not below it (it may name only {})",
                u.line,
                module.join("::"),
                u.top,
                allowed.join(", ")
            )
        })
        .collect()
}

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a file under `src` (`check/mod.rs` is `check`).
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).expect("a file under src");
    let mut parts: Vec<String> = rel
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

#[test]
fn syntax_and_check_name_no_later_phase() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = vec![src.join("syntax.rs")];
    rust_files(&src.join("syntax"), &mut files);
    let syntax_files = files.len();
    rust_files(&src.join("check"), &mut files);
    let mut errors = Vec::new();
    let mut seen = 0;
    for (k, file) in files.iter().enumerate() {
        let source =
            std::fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let module = module_of(&src, file);
        let module: Vec<&str> = module.iter().map(String::as_str).collect();
        let allowed = if k < syntax_files {
            SYNTAX_MAY_USE
        } else {
            CHECK_MAY_USE
        };
        let name = file
            .strip_prefix(&src)
            .unwrap_or(file)
            .display()
            .to_string();
        seen += uses(&module, &source).len();
        errors.extend(violations(&name, &module, &source, allowed));
    }
    // Not vacuous: the files were found and their paths read.
    assert!(files.len() > 15, "found only {files:?}");
    assert!(seen > 100, "only {seen} paths of the crate found");
    assert!(
        errors.is_empty(),
        "phases must only point down (syntax ← check ← derive):\n{}",
        errors.join("\n")
    );
}

/// The rule fails on each way a later phase can be named.
#[test]
fn the_rule_refuses_each_way_of_naming_a_later_phase() {
    let check_file = r#"
        use crate::derive::Row;
        use crate::{span::Span, follower::rows};
        use super::super::outputs::Along;
        use super::lower::Lowerer;
        /// A link to [`crate::derive::Derivation`] is documentation, not a use.
        fn f(lo: &crate::check::lower::Lowerer<'_>) {
            let d: crate::Derivation = Default::default();
            crate::dynamics::derive(lo);
            let v = vec![crate::library::rows(lo)];
        }
        mod tests {
            use super::*;
            use super::super::super::render;
        }
    "#;
    let found = violations("x.rs", &["check", "coord"], check_file, CHECK_MAY_USE);
    let names: Vec<&str> = found
        .iter()
        .map(|m| m.split('`').nth(3).unwrap_or(""))
        .collect();
    assert_eq!(
        names,
        [
            "crate::derive",
            "crate::follower",
            "crate::outputs",
            "crate::Derivation",
            "crate::dynamics",
            "crate::library",
            "crate::render",
        ],
        "{found:#?}"
    );
    // The checker's own modules and shared ones are allowed; syntax may not
    // name the checker.
    let syntax_file = "use crate::check::BodyRef; use super::Expr; use crate::span::Span;";
    let found = violations("y.rs", &["syntax", "coord"], syntax_file, SYNTAX_MAY_USE);
    assert_eq!(found.len(), 1, "{found:#?}");
    assert!(found[0].starts_with("y.rs:1: `syntax::coord` names `crate::check`"));
    // `super` of a directory's module is the crate root.
    let found = violations("z.rs", &["check"], "use super::derive::Row;", CHECK_MAY_USE);
    assert_eq!(found.len(), 1, "{found:#?}");
}
