//! The `fun` language of simEngine2D: MATLAB expressions in the variable `t`.
//!
//! Grammar (docs/src/simengine2d.md, "The `fun` language"), from the lowest
//! precedence to the highest:
//!
//! ```text
//! sum     := product (("+" | "-") product)*          left-associative
//! product := unary (("*" | "/" | ".*" | "./") unary)*  left-associative
//! unary   := ("+" | "-") unary | power               so -t^2 = -(t^2)
//! power   := primary (("^" | ".^") operand)*          left: 2^3^2 = 64
//! operand := ("+" | "-") operand | primary            so t^-2 is allowed
//! primary := number | "t" | "pi" | name "(" sum ("," sum)* ")" | "(" sum ")"
//! number  := 12 | 0.5 | .5 | 5. | 1.5e-5 | 2E+3
//! ```
//!
//! Functions: `sin cos tan asin acos atan sinh cosh tanh exp log sqrt abs`
//! (`log` is natural), and `log10`, `atan2(y, x)`, `power(x, y)`. Whitespace
//! is insignificant. The exact string `"NONE"` means "no function" ([`Fun::None`]).
//!
//! A parsed [`Expr`] evaluates in `f64` ([`Expr::eval`]) and prints in kinema's
//! expression syntax ([`Expr::to_kin`]): `log` becomes `ln`, `x^n` becomes
//! `powi(x, n)` when `n` is a constant integer and `pow(x, y)` otherwise.
//!
//! Nothing here recurses without bound: the parser limits nesting depth and
//! evaluation and printing walk a flat node list (children before parents).

use std::fmt;

use kinema_expr::{FunctionKind, UnaryOp};

mod parse;

use parse::Parser;

/// Deepest nesting of parentheses, calls and signs the parser accepts.
const MAX_DEPTH: usize = 100;

/// An error in a `fun` string: a message and the 0-based character offset in
/// the string where it was found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FunError {
    /// 0-based offset, in characters, into the expression string.
    pub offset: usize,
    /// What went wrong, saying what was expected.
    pub message: String,
}

impl fmt::Display for FunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} (at character {})", self.message, self.offset + 1)
    }
}

impl std::error::Error for FunError {}

/// A `fun` field: either the exact string `"NONE"` or an expression in `t`.
#[derive(Clone, Debug, PartialEq)]
pub enum Fun {
    /// `"NONE"`: no function.
    None,
    /// An expression in `t`.
    Expr(Expr),
}

impl Fun {
    /// Parses a `fun` string: `"NONE"` (exact, case-sensitive) or an expression.
    ///
    /// # Errors
    /// A [`FunError`] locating the first syntax error.
    pub fn parse(text: &str) -> Result<Fun, FunError> {
        if text == "NONE" {
            Ok(Fun::None)
        } else {
            Expr::parse(text).map(Fun::Expr)
        }
    }

    /// The expression, or `None` for `"NONE"`.
    #[must_use]
    pub fn expr(&self) -> Option<&Expr> {
        match self {
            Fun::None => None,
            Fun::Expr(e) => Some(e),
        }
    }
}

/// A one-argument function of the `fun` language, as one of kinema's own
/// (the engine's function table, [`kinema_expr::FUNCTIONS`]): its scalar
/// functions of one scalar under their MATLAB names (`log` is kinema's
/// `ln`) and `sqrt`; and `log10`, which kinema writes as `ln(x) / ln(10)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Func {
    /// One of the engine's scalar functions (`sin`, …, `exp`, `log`, `abs`).
    Unary(UnaryOp),
    /// `sqrt` (a power in the engine).
    Sqrt,
    /// `log10`: decimal logarithm (printed as `ln(x) / ln(10)`).
    Log10,
}

impl Func {
    /// The MATLAB name of kinema's `ln`.
    const LOG: &'static str = "log";

    fn from_name(name: &str) -> Option<Func> {
        match name {
            Func::LOG => return Some(Func::Unary(UnaryOp::Ln)),
            "log10" => return Some(Func::Log10),
            // MATLAB's natural logarithm is `log`.
            "ln" => return None,
            _ => {}
        }
        match kinema_expr::function(name)?.kind {
            FunctionKind::Unary(op) => Some(Func::Unary(op)),
            FunctionKind::Sqrt => Some(Func::Sqrt),
            _ => None,
        }
    }

    /// The MATLAB name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Func::Unary(UnaryOp::Ln) => Func::LOG,
            Func::Log10 => "log10",
            Func::Unary(_) | Func::Sqrt => self.kin_name(),
        }
    }

    /// Every function of the `fun` language, in the engine table's order
    /// (`log10` after `log`).
    pub fn all() -> impl Iterator<Item = Func> {
        kinema_expr::FUNCTIONS
            .iter()
            .filter_map(|f| match f.kind {
                FunctionKind::Unary(UnaryOp::Ln) => {
                    Some([Some(Func::Unary(UnaryOp::Ln)), Some(Func::Log10)])
                }
                FunctionKind::Unary(op) => Some([Some(Func::Unary(op)), None]),
                FunctionKind::Sqrt => Some([Some(Func::Sqrt), None]),
                _ => None,
            })
            .flatten()
            .flatten()
    }

    /// The function's value at `x` (the engine's [`UnaryOp::apply`] for
    /// those it has).
    #[must_use]
    pub fn apply(self, x: f64) -> f64 {
        match self {
            Func::Unary(op) => op.apply(x),
            Func::Sqrt => x.sqrt(),
            Func::Log10 => x.log10(),
        }
    }

    /// kinema's name of the function (all the same except `log` → `ln`;
    /// `log10` is written with `ln`).
    pub(crate) fn kin_name(self) -> &'static str {
        match self {
            Func::Unary(op) => op.name(),
            Func::Sqrt => "sqrt",
            Func::Log10 => "ln",
        }
    }
}

/// A two-argument function of the `fun` language.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Func2 {
    /// `atan2(y, x)`
    Atan2,
    /// `power(x, y)` = `x^y`
    Power,
}

impl Func2 {
    fn from_name(name: &str) -> Option<Func2> {
        match name {
            "atan2" => Some(Func2::Atan2),
            "power" => Some(Func2::Power),
            _ => None,
        }
    }
}

/// A binary operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*` or `.*`
    Mul,
    /// `/` or `./`
    Div,
    /// `^` or `.^`
    Pow,
}

impl BinOp {
    /// `a op b` in IEEE arithmetic (`^` is `powf`), as the engine computed it.
    #[must_use]
    pub fn apply(self, a: f64, b: f64) -> f64 {
        match self {
            BinOp::Add => a + b,
            BinOp::Sub => a - b,
            BinOp::Mul => a * b,
            BinOp::Div => a / b,
            BinOp::Pow => a.powf(b),
        }
    }
}

/// A node of an [`Expr`]. Children are indices of earlier nodes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Node {
    /// A non-negative number literal.
    Num(f64),
    /// `pi`
    Pi,
    /// The time `t`.
    T,
    /// Unary minus.
    Neg(u32),
    /// A binary operation.
    Bin(BinOp, u32, u32),
    /// A one-argument function call.
    Call(Func, u32),
    /// A two-argument function call.
    Call2(Func2, u32, u32),
}

/// A parsed `fun` expression: a flat list of nodes in which children precede
/// their parents; the last node is the root.
#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    nodes: Vec<Node>,
    /// Per node, the character offset of its operator, function name,
    /// number or name in `text`.
    offsets: Vec<usize>,
    text: String,
}

impl fmt::Display for Expr {
    /// The expression as it was written.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl Expr {
    /// Parses an expression in `t`.
    ///
    /// # Errors
    /// A [`FunError`] locating the first syntax error.
    ///
    /// ```
    /// let e = kinema_adm::fun::Expr::parse("pi/2 + 2*pi*t").unwrap();
    /// assert_eq!(e.to_kin(), "pi / 2 + 2 * pi * t");
    /// ```
    pub fn parse(text: &str) -> Result<Expr, FunError> {
        Parser::new(text, true).run()
    }

    /// Parses and evaluates a constant expression (no `t`): the arithmetic the
    /// engine's JSON reader accepted where a number is expected (`187/255`).
    ///
    /// # Errors
    /// A [`FunError`] on a syntax error, a use of `t`, or a result that is not
    /// a finite number.
    pub fn parse_constant(text: &str) -> Result<f64, FunError> {
        let e = Parser::new(text, false).run()?;
        let v = e.eval(0.0);
        if v.is_finite() {
            Ok(v)
        } else {
            Err(FunError {
                offset: 0,
                message: format!(
                    "`{}` is not a finite number (it evaluates to {v})",
                    text.trim()
                ),
            })
        }
    }

    /// The text the expression was parsed from.
    #[must_use]
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The nodes, children before parents; the last one is the root.
    #[must_use]
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The 0-based character offset in [`text`](Self::text) of node `i`'s
    /// operator, function name, number or name (0 for an index out of range).
    #[must_use]
    pub fn offset_of(&self, i: usize) -> usize {
        self.offsets.get(i).copied().unwrap_or(0)
    }

    /// Whether the expression mentions `t` (then it is a driver).
    #[must_use]
    pub fn mentions_t(&self) -> bool {
        self.nodes.iter().any(|n| matches!(n, Node::T))
    }

    /// The value at time `t`, with MATLAB's real semantics where they agree
    /// with `f64` (out-of-domain arguments give NaN).
    #[must_use]
    pub fn eval(&self, t: f64) -> f64 {
        self.values(t).last().copied().unwrap_or(f64::NAN)
    }

    /// The value of every node at time `t`.
    fn values(&self, t: f64) -> Vec<f64> {
        let mut v: Vec<f64> = Vec::with_capacity(self.nodes.len());
        for node in &self.nodes {
            let get = |i: u32| v.get(i as usize).copied().unwrap_or(f64::NAN);
            let x = match *node {
                Node::Num(x) => x,
                Node::Pi => std::f64::consts::PI,
                Node::T => t,
                Node::Neg(a) => -get(a),
                Node::Bin(op, a, b) => op.apply(get(a), get(b)),
                Node::Call(f, a) => f.apply(get(a)),
                Node::Call2(Func2::Atan2, a, b) => get(a).atan2(get(b)),
                Node::Call2(Func2::Power, a, b) => get(a).powf(get(b)),
            };
            v.push(x);
        }
        v
    }

    /// The expression in kinema's syntax: the tree kinema-adm builds for it
    /// ([`crate::build()`]) as kinema-model prints it
    /// ([`kinema_model::print::expr`]), with only the parentheses the tree
    /// needs (the printed text parses back to the same tree, so it
    /// evaluates identically). A negative operand on the right of a binary
    /// operator is parenthesised for readability: `t - (-1)`.
    ///
    /// `x^n` with `n` a constant integer becomes `powi(x, n)`, other powers
    /// `pow(x, y)`; `log` becomes `ln`; `log10(x)` becomes `ln(x) / ln(10)`.
    #[must_use]
    pub fn to_kin(&self) -> String {
        if self.nodes.is_empty() {
            return String::new();
        }
        kinema_model::print::expr(&crate::build::fun_expr(self))
    }

    /// Per node, its value as an integer exponent: `Some(n)` for a
    /// t-free expression whose value is an exact integer of moderate size
    /// (|n| ≤ 10⁶), so `x^n` is `powi(x, n)` rather than `pow(x, y)`.
    pub(crate) fn int_exponents(&self) -> Vec<Option<i64>> {
        let consts = self.values(0.0);
        let mut has_t: Vec<bool> = Vec::with_capacity(self.nodes.len());
        for node in &self.nodes {
            let h = |i: u32| has_t.get(i as usize).copied().unwrap_or(true);
            let x = match *node {
                Node::T => true,
                Node::Num(_) | Node::Pi => false,
                Node::Neg(a) | Node::Call(_, a) => h(a),
                Node::Bin(_, a, b) | Node::Call2(_, a, b) => h(a) || h(b),
            };
            has_t.push(x);
        }
        consts
            .iter()
            .zip(&has_t)
            .map(|(&v, &t)| {
                (!t && v.is_finite() && v.fract() == 0.0 && v.abs() <= 1e6).then_some(v as i64)
            })
            .collect()
    }
}

/// Formats a number so that it reads back to the same `f64`: integers of
/// moderate size without a decimal point (`2`), others with Rust's shortest
/// round-trip form (`0.1`, `1.5e-5`). Negative numbers get a leading `-`.
#[must_use]
pub fn format_number(x: f64) -> String {
    kinema_model::print::number(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `fun` functions are kinema's table under MATLAB's names: the same
    /// fourteen as before the table, in the same order, `ln` refused
    /// (MATLAB writes `log`), and each with the value of its `std` function.
    #[test]
    fn functions_are_the_engines_under_matlab_names() {
        let names: Vec<&str> = Func::all().map(Func::name).collect();
        assert_eq!(
            names,
            [
                "sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh", "exp", "log",
                "log10", "sqrt", "abs"
            ]
        );
        for f in Func::all() {
            assert_eq!(Func::from_name(f.name()), Some(f));
        }
        assert_eq!(Func::from_name("ln"), None);
        assert_eq!(Func::from_name("atan2"), None);
        let x: f64 = 0.37;
        let want = [
            x.sin(),
            x.cos(),
            x.tan(),
            x.asin(),
            x.acos(),
            x.atan(),
            x.sinh(),
            x.cosh(),
            x.tanh(),
            x.exp(),
            x.ln(),
            x.log10(),
            x.sqrt(),
            x.abs(),
        ];
        for (f, w) in Func::all().zip(want) {
            assert_eq!(f.apply(x).to_bits(), w.to_bits(), "{}", f.name());
            let e = Expr::parse(&format!("{}(t)", f.name())).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(e.eval(x).to_bits(), w.to_bits(), "{}", f.name());
        }
    }

    fn eval(s: &str, t: f64) -> f64 {
        Expr::parse(s)
            .map(|e| e.eval(t))
            .unwrap_or_else(|e| panic!("{s}: {e}"))
    }

    fn kin(s: &str) -> String {
        Expr::parse(s)
            .map(|e| e.to_kin())
            .unwrap_or_else(|e| panic!("{s}: {e}"))
    }

    fn err(s: &str) -> FunError {
        match Expr::parse(s) {
            Ok(e) => panic!("{s} parsed as {e:?}"),
            Err(e) => e,
        }
    }

    #[test]
    fn numbers() {
        assert_eq!(eval("12", 0.0), 12.0);
        assert_eq!(eval("0.5", 0.0), 0.5);
        assert_eq!(eval(".5", 0.0), 0.5);
        assert_eq!(eval("5.", 0.0), 5.0);
        assert_eq!(eval("1.5e-5", 0.0), 1.5e-5);
        assert_eq!(eval("2E+3", 0.0), 2000.0);
        assert_eq!(eval("5.e1", 0.0), 50.0);
        assert_eq!(eval("0.1", 0.0), 0.1);
        assert_eq!(eval("2.356194490192345", 0.0), 2.356194490192345);
    }

    #[test]
    fn precedence() {
        assert_eq!(eval("2^3^2", 0.0), 64.0);
        assert_eq!(eval("-t^2", 3.0), -9.0);
        assert_eq!(eval("t^-2", 2.0), 0.25);
        assert_eq!(eval("2^-1^2", 0.0), 0.25); // (2^-1)^2, left to right
        assert_eq!(eval("-2^2", 0.0), -4.0);
        assert_eq!(eval("1 - 2 - 3", 0.0), -4.0);
        assert_eq!(eval("8 / 4 / 2", 0.0), 1.0);
        assert_eq!(eval("2 + 3 * 4", 0.0), 14.0);
        assert_eq!(eval("(2 + 3) * 4", 0.0), 20.0);
        assert_eq!(eval("2*-3", 0.0), -6.0);
        assert_eq!(eval("- - 2", 0.0), 2.0);
        assert_eq!(eval("+t", 1.5), 1.5);
        assert_eq!(eval("-9.81 * 2", 0.0), -19.62);
    }

    #[test]
    fn element_wise_operators() {
        assert_eq!(eval("2.*t", 3.0), 6.0);
        assert_eq!(eval("5.*t", 2.0), 10.0); // 5 .* t
        assert_eq!(eval("t./2", 3.0), 1.5);
        assert_eq!(eval("t.^2", 3.0), 9.0);
        assert_eq!(eval("2.^3", 0.0), 8.0);
    }

    #[test]
    fn functions_and_constants() {
        let t = 0.3;
        assert_eq!(eval("sin(10*t)", t), (10.0 * t).sin());
        assert_eq!(
            eval("pi/2 + 2*pi*t", t),
            std::f64::consts::PI / 2.0 + 2.0 * std::f64::consts::PI * t
        );
        assert_eq!(eval("log(exp(2))", t), 2.0);
        assert_eq!(eval("sqrt(abs(-4))", t), 2.0);
        assert_eq!(eval("atan2(1, 1)", t), std::f64::consts::FRAC_PI_4);
        assert_eq!(eval("power(t, 2)", t), t.powf(2.0));
        assert_eq!(eval("log10(100)", t), 2.0);
        for f in [
            "sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh", "exp", "log",
            "sqrt", "abs",
        ] {
            assert!(eval(&format!("{f}(t)"), t).is_finite(), "{f}");
        }
    }

    #[test]
    fn fun_none_and_mentions_t() {
        assert_eq!(Fun::parse("NONE"), Ok(Fun::None));
        assert!(err("none").message.contains("unknown name"));
        assert!(err("NONE + 1").message.contains("exactly"));
        assert!(Expr::parse("15*t").is_ok_and(|e| e.mentions_t()));
        assert!(Expr::parse("0.0").is_ok_and(|e| !e.mentions_t()));
        assert!(Expr::parse("-500").is_ok_and(|e| !e.mentions_t()));
    }

    #[test]
    fn printing_in_kinema_syntax() {
        assert_eq!(kin("t^2"), "powi(t, 2)");
        assert_eq!(kin("-t^2"), "-powi(t, 2)");
        assert_eq!(kin("t^-2"), "powi(t, -2)");
        assert_eq!(kin("2^3^2"), "powi(powi(2, 3), 2)");
        assert_eq!(kin("t^0.5"), "pow(t, 0.5)");
        assert_eq!(kin("t^(1/2)"), "pow(t, 1 / 2)");
        assert_eq!(kin("t^(4/2)"), "powi(t, 2)");
        assert_eq!(kin("2^t"), "pow(2, t)");
        assert_eq!(kin("log(t)"), "ln(t)");
        assert_eq!(kin("log10(t)"), "ln(t) / ln(10)");
        assert_eq!(kin("2*log10(t)"), "2 * (ln(t) / ln(10))");
        assert_eq!(kin("pi/2 + 2*pi*t"), "pi / 2 + 2 * pi * t");
        assert_eq!(kin("t + pi/6"), "t + pi / 6");
        assert_eq!(kin("1 - (2 - t)"), "1 - (2 - t)");
        assert_eq!(kin("(1 - 2) - t"), "1 - 2 - t");
        assert_eq!(kin("1 + (2 + t)"), "1 + (2 + t)");
        assert_eq!(kin("2 / (3 * t)"), "2 / (3 * t)");
        assert_eq!(kin("-(2*t)"), "-(2 * t)");
        assert_eq!(kin("-2*t"), "-2 * t");
        assert_eq!(kin("t - -1"), "t - (-1)");
        assert_eq!(kin("2*-t"), "2 * (-t)");
        assert_eq!(kin("- -t"), "-(-t)");
        assert_eq!(kin("0.0"), "0");
        assert_eq!(kin("-0.04"), "-0.04");
        assert_eq!(kin("1.5e-5*t"), "1.5e-5 * t");
        assert_eq!(kin("sin(10*t)"), "sin(10 * t)");
        assert_eq!(kin("atan2(t, 1)"), "atan2(t, 1)");
        assert_eq!(kin("power(t, 3)"), "powi(t, 3)");
        assert_eq!(kin("(((t)))"), "t");
    }

    #[test]
    fn printing_keeps_the_value() {
        let cases = [
            "1 - (2 - t)",
            "2^3^2",
            "-t^2 + t^-2",
            "t/(1+t)/3",
            "2*-t^0.5",
            "exp(-t)*sin(10*t)",
            "1e-3*t^3 - 0.5*t^2 + t - 7",
            "log10(t) * 2",
            "-(t - 1)^3",
        ];
        for s in cases {
            let e = Expr::parse(s).expect("parses");
            let back = Expr::parse(
                &e.to_kin()
                    .replace("powi(", "power(")
                    .replace("pow(", "power(")
                    .replace("ln(", "log("),
            )
            .unwrap_or_else(|err| panic!("{s} -> {}: {err}", e.to_kin()));
            for t in [0.25, 0.7, 1.9] {
                let (a, b) = (e.eval(t), back.eval(t));
                assert!(
                    (a - b).abs() <= 1e-15 * a.abs().max(1.0),
                    "{s}: {a} vs {b} at t = {t}"
                );
            }
        }
    }

    #[test]
    fn errors_point_into_the_string() {
        let e = err("sin(10*t");
        assert_eq!(e.offset, 8);
        assert!(
            e.message
                .contains("expected `)` to close the `(` at character 4"),
            "{}",
            e.message
        );
        let e = err("2*x");
        assert_eq!(e.offset, 2);
        assert!(e.message.contains("unknown name `x`"));
        let e = err("2*e");
        assert!(e.message.contains("exp(1)"));
        let e = err("2e");
        assert!(e.message.contains("exponent"));
        let e = err("foo(t)");
        assert!(e.message.contains("unknown function `foo`"));
        let e = err("sin");
        assert!(e.message.contains("is a function"));
        let e = err("sin(1, 2)");
        assert!(e.message.contains("takes 1 argument"));
        let e = err("2 t");
        assert_eq!(e.offset, 2);
        assert!(err("").message.contains("empty"));
        assert!(err("1 +").message.contains("end of the expression"));
        assert!(err("t \\ 2").message.contains("left division"));
        assert!(err("t'").message.contains("transpose"));
        assert!(err("t # 2").message.contains("unexpected character"));
        assert!(err("1e999").message.contains("out of range"));
        assert_eq!(err("(t))").offset, 3);
    }

    #[test]
    fn deep_input_is_an_error_not_a_crash() {
        let deep = format!("{}t{}", "(".repeat(5000), ")".repeat(5000));
        assert!(err(&deep).message.contains("nested too deeply"));
        let signs = format!("{}t", "-".repeat(5000));
        assert!(err(&signs).message.contains("nested too deeply"));
        // Long flat sums are fine and evaluate and print without recursion.
        let long = vec!["t"; 200_000].join(" + ");
        let e = Expr::parse(&long).expect("parses");
        assert_eq!(e.eval(1.0), 200_000.0);
        assert_eq!(e.to_kin().len(), long.len());
    }

    #[test]
    fn constants() {
        assert_eq!(Expr::parse_constant("187/255"), Ok(187.0 / 255.0));
        assert_eq!(
            Expr::parse_constant(" 2*pi "),
            Ok(2.0 * std::f64::consts::PI)
        );
        assert!(Expr::parse_constant("t").is_err());
        assert!(Expr::parse_constant("1/0").is_err());
    }
}
