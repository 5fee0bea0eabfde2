//! Generator of simEngine2D `fun` strings from their grammar (kinema-adm's
//! `fun` module): every function, both operator spellings (`*`/`.*`),
//! signs in exponents, number forms (`.5`, `5.`, `2E+3`), extreme values,
//! deep nesting and long sums and products.

use super::EXTREME;
use crate::rng::Rng;

/// One-argument functions of `fun` (kinema-adm's table).
static FUNCS1: std::sync::LazyLock<Vec<&'static str>> =
    std::sync::LazyLock::new(|| kinema_adm::fun::Func::all().map(|f| f.name()).collect());

fn number(rng: &mut Rng) -> String {
    match rng.weighted(&[4, 2, 3]) {
        0 => rng.range(0, 20).to_string(),
        1 => (*rng.pick(&[".5", "5.", "2E+3", "1.5e-5", "0.25", "1e-3", "3.0"])).to_string(),
        _ => {
            let n = *rng.pick(EXTREME);
            if n == "1e999" && rng.chance(0.8) {
                "1e308".to_string()
            } else {
                n.to_string()
            }
        }
    }
}

fn leaf(rng: &mut Rng) -> String {
    match rng.weighted(&[4, 4, 1]) {
        0 => number(rng),
        1 => "t".to_string(),
        _ => "pi".to_string(),
    }
}

/// A `fun` expression of at most `depth` levels.
pub fn expr(rng: &mut Rng, depth: usize) -> String {
    expr_in(rng, depth, true)
}

/// A `fun` expression that the ADM reader accepts more often: no deep
/// nesting, no long runs, no undefined forms (extreme numbers stay).
pub fn tame(rng: &mut Rng, depth: usize) -> String {
    expr_in(rng, depth, false)
}

fn expr_in(rng: &mut Rng, depth: usize, wild: bool) -> String {
    if depth == 0 {
        return leaf(rng);
    }
    let d = depth - 1;
    let w = u32::from(wild);
    match rng.weighted(&[5, 3, 3, 3, 3, 2, 2, 5, 1, 1, 2, w, w, w]) {
        0 => leaf(rng),
        1 => format!("{} + {}", expr_in(rng, d, wild), expr_in(rng, d, wild)),
        2 => format!("{} - {}", expr_in(rng, d, wild), expr_in(rng, d, wild)),
        3 => {
            let op = *rng.pick(&["*", ".*"]);
            format!("{}{op}{}", expr_in(rng, d, wild), expr_in(rng, d, wild))
        }
        4 => {
            let op = *rng.pick(&["/", "./"]);
            format!("{} {op} {}", expr_in(rng, d, wild), expr_in(rng, d, wild))
        }
        5 => {
            let op = *rng.pick(&["^", ".^"]);
            let sign = *rng.pick(&["", "-", "+", "--"]);
            format!("{}{op}{sign}{}", expr_in(rng, d, wild), leaf(rng))
        }
        6 => format!("-{}", expr_in(rng, d, wild)),
        7 => {
            let f = *rng.pick(&FUNCS1);
            format!("{f}({})", expr_in(rng, d, wild))
        }
        8 => format!(
            "atan2({}, {})",
            expr_in(rng, d, wild),
            expr_in(rng, d, wild)
        ),
        9 => format!(
            "power({}, {})",
            expr_in(rng, d, wild),
            expr_in(rng, d, wild)
        ),
        10 => format!("({})", expr_in(rng, d, wild)),
        11 => {
            let hi = if rng.chance(0.1) { 400 } else { 20 };
            let n = rng.range(2, hi);
            let op = *rng.pick(&[" + ", "*", " - ", "/"]);
            let terms: Vec<String> = (0..n).map(|_| leaf(rng)).collect();
            format!("({})", terms.join(op))
        }
        12 => {
            let n = *rng.pick(&[50, 99, 100, 101, 150, 1000]);
            let open = *rng.pick(&["(", "sin(", "-", "+", "abs("]);
            let close = if open.ends_with('(') { ")" } else { "" };
            format!("{}t{}", open.repeat(n), close.repeat(n))
        }
        _ => {
            // Forms whose value is undefined or overflows, hidden in a sum.
            let bad = *rng.pick(&[
                "0/0",
                "1/0",
                "log(0)",
                "log(-1)",
                "sqrt(-1)",
                "asin(2)",
                "1e308*1e308",
                "exp(1000)",
                "0*(1/0)",
                "(t-t)/(t-t)",
                "0^-1",
                "(-8)^(1/3)",
                "power(0, 0)",
                "tan(pi/2)",
            ]);
            format!("{bad} + {}", expr_in(rng, d, wild))
        }
    }
}

/// A `fun` string: mostly expressions, sometimes the special forms.
pub fn generate(rng: &mut Rng) -> String {
    match rng.weighted(&[30, 1, 1, 1]) {
        0 => {
            let depth = rng.range(0, 5);
            expr(rng, depth)
        }
        1 => "NONE".to_string(),
        2 => (*rng.pick(&[
            "", " ", "none", "t t", "()", "sin()", "atan2(t)", "1e", "t^", "+",
        ]))
        .to_string(),
        _ => format!("  {}\t", expr(rng, 2)),
    }
}
