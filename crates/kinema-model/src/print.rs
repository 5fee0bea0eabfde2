//! Prints a syntax tree as `.kin` text: the way back from the parsed form
//! to the language, for a tree another reader built (the simEngine2D
//! importer's, `kinema import`).
//!
//! The text parses back to the same tree, up to spans: the same items in
//! the same order, the same names, each expression node for node (only the
//! parentheses the tree needs are written, plus one for readability: a
//! negated operand on the right of a binary operator, `t - (-1)`), and the
//! same doc comments. Numbers are written so that they read back to the
//! same `f64` ([`number`]).
//!
//! Layout: four spaces of indent inside `mechanism Name { … }`, one item a
//! line after its `///` doc comments, and a blank line before every
//! equation, output, `gravity` and `force` (they stand alone; bodies,
//! their points, params, coordinates and curves are declarations kept
//! together).
//!
//! ```
//! use kinema_model::ParsedModel;
//! let text = "mechanism M {\n    /// the bar\n    body bar { guess: (1, 0, -0.5) }\n\n    \
//!             driver d: bar.x == 0.5 * sin(2 * t) / (1 + t) - (-2);\n}\n";
//! let parsed = ParsedModel::parse_str(text).unwrap();
//! assert_eq!(kinema_model::print::mechanism(parsed.syntax()), text);
//! ```

use std::fmt::Write as _;

use crate::syntax::{BinOp, Expr, ExprKind, Item, Mechanism};

/// The text of `mechanism` (see the module's documentation).
#[must_use]
pub fn mechanism(mechanism: &Mechanism) -> String {
    let mut out = String::new();
    docs(&mut out, "", &mechanism.docs);
    let _ = writeln!(out, "mechanism {} {{", mechanism.name);
    for item in &mechanism.items {
        item_text(&mut out, item);
    }
    out.push_str("}\n");
    out
}

/// `/// line` for each doc comment (a doc holding line breaks is one
/// comment a line).
fn docs(out: &mut String, indent: &str, docs: &[String]) {
    for line in docs.iter().flat_map(|d| d.split('\n')) {
        let line = line.strip_suffix('\r').unwrap_or(line);
        if line.is_empty() {
            let _ = writeln!(out, "{indent}///");
        } else {
            let _ = writeln!(out, "{indent}/// {line}");
        }
    }
}

fn item_text(out: &mut String, item: &Item) {
    const IN: &str = "    ";
    match item {
        Item::Param(p) => {
            docs(out, IN, &p.docs);
            match &p.value {
                Some(v) => {
                    let _ = writeln!(out, "{IN}param {} = {};", p.name, expr(v));
                }
                None => {
                    let _ = writeln!(out, "{IN}param {};", p.name);
                }
            }
        }
        Item::Body(b) => {
            docs(out, IN, &b.docs);
            let mut fields = Vec::new();
            if let Some(guess) = &b.guess {
                fields.push(format!("guess: {}", triple(guess)));
            }
            if let Some(m) = &b.mass {
                fields.push(format!("mass: {}", expr(m)));
            }
            if let Some(j) = &b.inertia {
                fields.push(format!("inertia: {}", expr(j)));
            }
            if let Some(v) = &b.velocity {
                fields.push(format!("velocity: {}", triple(&v.value)));
            }
            if fields.is_empty() {
                let _ = writeln!(out, "{IN}body {};", b.name);
            } else {
                let _ = writeln!(out, "{IN}body {} {{ {} }}", b.name, fields.join(", "));
            }
        }
        Item::Point(p) => {
            docs(out, IN, &p.docs);
            let _ = writeln!(out, "{IN}point {}.{} = {};", p.body, p.name, expr(&p.value));
        }
        Item::Equation(e) => {
            out.push('\n');
            docs(out, IN, &e.docs);
            let keyword = e.keyword.as_str();
            match &e.rhs {
                Some(rhs) => {
                    let _ = writeln!(
                        out,
                        "{IN}{keyword} {}: {} == {};",
                        e.name,
                        expr(&e.lhs),
                        expr(rhs)
                    );
                }
                None => {
                    let _ = writeln!(out, "{IN}{keyword} {}: {};", e.name, expr(&e.lhs));
                }
            }
        }
        Item::Output(o) => {
            out.push('\n');
            docs(out, IN, &o.docs);
            let _ = writeln!(out, "{IN}output {}: {};", o.name, expr(&o.value));
        }
        Item::Gravity(g) => {
            out.push('\n');
            let _ = writeln!(out, "{IN}gravity = {};", expr(&g.value));
        }
        Item::Force(f) => {
            out.push('\n');
            docs(out, IN, &f.docs);
            let _ = writeln!(out, "{IN}force {}: {};", f.name, expr(&f.call));
        }
        Item::Coord(c) => {
            docs(out, IN, &c.docs);
            match &c.guess {
                Some(g) => {
                    let _ = writeln!(out, "{IN}coord {} {{ guess: {} }}", c.name, expr(g));
                }
                None => {
                    let _ = writeln!(out, "{IN}coord {};", c.name);
                }
            }
        }
        Item::Curve(c) => {
            docs(out, IN, &c.docs);
            let _ = writeln!(
                out,
                "{IN}curve {}.{}({}) = {};",
                c.body,
                c.name,
                c.param,
                expr(&c.value)
            );
        }
    }
}

/// `(a, b, c)`.
fn triple(parts: &[Expr; 3]) -> String {
    format!(
        "({}, {}, {})",
        expr(&parts[0]),
        expr(&parts[1]),
        expr(&parts[2])
    )
}

const PREC_SUM: u8 = 1;
const PREC_PRODUCT: u8 = 2;
const PREC_UNARY: u8 = 3;
const PREC_POSTFIX: u8 = 4;

/// How tightly a node binds as printed: a node printed where a tighter one
/// is required gets parentheses.
fn precedence(kind: &ExprKind) -> u8 {
    match kind {
        ExprKind::Binary(BinOp::Add | BinOp::Sub, ..) => PREC_SUM,
        ExprKind::Binary(BinOp::Mul | BinOp::Div, ..) => PREC_PRODUCT,
        ExprKind::Neg(_) => PREC_UNARY,
        // A negative literal (the parser makes `-` of a magnitude; a tree
        // built elsewhere may hold one) prints with its sign.
        ExprKind::Num { value, .. } if value.is_sign_negative() && *value != 0.0 => PREC_UNARY,
        ExprKind::Num { .. }
        | ExprKind::Ident(_)
        | ExprKind::Field(..)
        | ExprKind::Call(..)
        | ExprKind::Tuple(_) => PREC_POSTFIX,
    }
}

/// The text of one expression, with only the parentheses its tree needs
/// (see the module's documentation). Iterative: a deep tree does not
/// recurse.
#[must_use]
pub fn expr(e: &Expr) -> String {
    let mut out = String::new();
    let mut stack = vec![Task::Node(e.root, 0)];
    while let Some(task) = stack.pop() {
        let (id, required) = match task {
            Task::Text(s) => {
                out.push_str(s);
                continue;
            }
            Task::Name(s) => {
                out.push_str(s);
                continue;
            }
            Task::Node(id, required) => (id, required),
        };
        let Some(node) = e.nodes.get(id as usize) else {
            continue;
        };
        if precedence(&node.kind) < required {
            out.push('(');
            stack.push(Task::Text(")"));
        }
        // What the right operand of an operator of precedence `q` must
        // bind: tighter than `q` (left-associative), and a negation is
        // parenthesised for readability.
        let right = |child: u32, q: u8| -> u8 {
            match e.nodes.get(child as usize).map(|n| precedence(&n.kind)) {
                Some(PREC_UNARY) => PREC_POSTFIX,
                _ => q + 1,
            }
        };
        match &node.kind {
            ExprKind::Num { value, suffix } => {
                out.push_str(&number(*value));
                out.push_str(suffix);
            }
            ExprKind::Ident(name) => out.push_str(name.as_str()),
            ExprKind::Field(base, field) => {
                stack.push(Task::Name(field.as_str()));
                stack.push(Task::Text("."));
                stack.push(Task::Node(*base, PREC_POSTFIX));
            }
            ExprKind::Call(name, args) => {
                out.push_str(name.as_str());
                out.push('(');
                stack.push(Task::Text(")"));
                push_list(&mut stack, args);
            }
            ExprKind::Tuple(parts) => {
                out.push('(');
                stack.push(Task::Text(")"));
                push_list(&mut stack, parts);
            }
            ExprKind::Neg(a) => {
                out.push('-');
                stack.push(Task::Node(*a, PREC_POSTFIX));
            }
            ExprKind::Binary(op, a, b) => {
                let (q, symbol) = match op {
                    BinOp::Add => (PREC_SUM, " + "),
                    BinOp::Sub => (PREC_SUM, " - "),
                    BinOp::Mul => (PREC_PRODUCT, " * "),
                    BinOp::Div => (PREC_PRODUCT, " / "),
                };
                stack.push(Task::Node(*b, right(*b, q)));
                stack.push(Task::Text(symbol));
                stack.push(Task::Node(*a, q));
            }
        }
    }
    out
}

/// What is left to print: a node (with the precedence its place
/// requires) or text.
#[derive(Clone, Copy)]
enum Task<'a> {
    Node(u32, u8),
    Text(&'static str),
    Name(&'a str),
}

/// Pushes the nodes `items`, `, ` between them, so that they pop in order.
fn push_list(stack: &mut Vec<Task<'_>>, items: &[u32]) {
    for (k, &item) in items.iter().enumerate().rev() {
        stack.push(Task::Node(item, 0));
        if k > 0 {
            stack.push(Task::Text(", "));
        }
    }
}

/// A number that reads back to the same `f64`: integers of moderate size
/// without a decimal point (`2`), others in Rust's shortest round-trip
/// form (`0.1`, `1.5e-5`); a negative number with its `-`. (A number that
/// is not finite has no literal: it prints as `inf` or `NaN`, which the
/// checker refuses as unknown names.)
#[must_use]
pub fn number(x: f64) -> String {
    if x == 0.0 {
        return "0".to_string();
    }
    if x.fract() == 0.0 && x.abs() < 1e15 {
        return format!("{}", x as i64);
    }
    format!("{x:?}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ParsedModel;

    /// Every item kind, in the printer's own layout: printed as written.
    const EVERY_ITEM: &str = "/// a model with every kind of item
mechanism Every {
    /// length [m]
    param L = 2;
    param k;
    /// the crank
    body crank { guess: (0, 0, pi / 4), mass: 1, inertia: 0.5, velocity: (0, 0, -1) }
    body slider;
    point crank.tip = (L, 0);
    coord a { guess: -pi / 2 }
    coord b;
    curve crank.rim(u) = (cos(u), sin(u)) * (1 + 0.1 * u);

    joint pivot: revolute(crank(0, 0), ground(0, 0));

    constraint level: slider.y - (-1) == -(crank.tip.y - 2 * (3 - t)) / (k + 1);

    driver spin: abs_angle(crank, 2 * pi * t - -1.5 * t / 4);

    output gap: crank.tip - slider.o;

    gravity = (0, -9.81);

    /// a motor
    force motor: torque(crank, 1e-5 * sin(t) + 1.5e300);
}
";

    #[test]
    fn every_item_prints_as_written() {
        let parsed = ParsedModel::parse_str(EVERY_ITEM)
            .unwrap_or_else(|d| panic!("{}", d.render(EVERY_ITEM, "every.kin")));
        assert_eq!(mechanism(parsed.syntax()), EVERY_ITEM);
    }

    /// Parentheses: only where the tree needs them, and around a negated
    /// right operand.
    #[test]
    fn parentheses() {
        let cases = [
            ("(a + b) * c", "(a + b) * c"),
            ("a - (b - c)", "a - (b - c)"),
            ("(a - b) - c", "a - b - c"),
            ("a / (b * c)", "a / (b * c)"),
            ("a - -b", "a - (-b)"),
            ("-(-a)", "-(-a)"),
            ("-(a * b)", "-(a * b)"),
            ("(-a) * b", "-a * b"),
            ("(a + b).x", "(a + b).x"),
            ("f((a, b), -(1))", "f((a, b), -1)"),
            ("0.1 + 100000000000000000000.0 + 2.", "0.1 + 1e20 + 2"),
        ];
        for (text, printed) in cases {
            let e: Expr = syn::parse_str(text).unwrap_or_else(|e| panic!("{text}: {e}"));
            assert_eq!(expr(&e), printed, "{text}");
        }
    }

    /// The shipped models print to text that parses, checks and derives to
    /// the same equations; printing that text again gives it back.
    #[test]
    fn shipped_models_round_trip() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        let mut paths = Vec::new();
        for dir in [root.clone(), root.join("iftomm")] {
            let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{dir:?}: {e}"));
            paths.extend(
                entries
                    .map(|e| e.unwrap_or_else(|e| panic!("{e}")).path())
                    .filter(|p| p.extension().is_some_and(|x| x == "kin")),
            );
        }
        assert!(paths.len() >= 10, "{paths:?}");
        let derive = |text: &str, name: &str| {
            crate::Derived::from_source(crate::Source::new(name, text))
                .unwrap_or_else(|r| panic!("{r}"))
                .into_parts()
                .1
        };
        for path in paths {
            let name = path.display().to_string();
            let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
            let parsed = ParsedModel::parse_str(&text).unwrap_or_else(|d| panic!("{d}"));
            let printed = mechanism(parsed.syntax());
            let again = ParsedModel::parse_str(&printed)
                .unwrap_or_else(|d| panic!("{name}: printed:\n{}", d.render(&printed, &name)));
            assert_eq!(mechanism(again.syntax()), printed, "{name}");
            let (before, after) = (derive(&text, &name), derive(&printed, &name));
            assert_eq!(before.render(), after.render(), "{name}");
        }
    }
}
