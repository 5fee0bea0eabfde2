//! Generator of `.kin` models from the language's grammar (kinema-model's
//! crate docs): params, bodies, points, library joints, user constraints and
//! drivers using every function of the vocabulary, with extreme numbers,
//! deep nesting, long sums and products, many bodies and (sometimes)
//! duplicate, unknown or keyword names.
//!
//! Rows are balanced per body (three each) so that most models pass the
//! DOF check and reach the derivation and the runtime.

use std::fmt::Write as _;

use super::{EXTREME, KEYWORDS};
use crate::rng::Rng;

/// One-argument scalar functions of the language (kinema-expr's table).
static FUNCS1: std::sync::LazyLock<Vec<&'static str>> = std::sync::LazyLock::new(|| {
    kinema_expr::FUNCTIONS
        .iter()
        .filter(|f| {
            matches!(
                f.kind,
                kinema_expr::FunctionKind::Unary(_) | kinema_expr::FunctionKind::Sqrt
            )
        })
        .map(|f| f.name)
        .collect()
});

/// What an expression may mention, by where it appears.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Ctx {
    /// Params, points, guesses: numbers, `pi` and earlier params.
    Constant,
    /// Joints and constraints: coordinates, no `t`.
    Kinematic,
    /// Library constraints' scalar arguments: params and `t`.
    Time,
    /// Drivers: coordinates and `t`.
    Driving,
}

/// The model under construction: names in scope.
struct Scope {
    params: Vec<String>,
    bodies: Vec<String>,
    /// (body, point name)
    points: Vec<(String, String)>,
    /// Ignore the context rules now and then, to reach the checker's errors.
    sloppy: bool,
}

/// Generation state: the random source, the scope and a node budget that
/// bounds the size of one model.
struct Gen<'a> {
    rng: &'a mut Rng,
    scope: Scope,
    budget: usize,
    /// Probability that a number literal is an extreme one.
    extreme: f64,
}

impl Gen<'_> {
    fn param(&mut self) -> Option<String> {
        if self.scope.params.is_empty() {
            None
        } else {
            Some(self.rng.pick(&self.scope.params).clone())
        }
    }

    fn body(&mut self) -> String {
        if self.scope.bodies.is_empty() || self.rng.chance(0.02) {
            return "ground".to_string();
        }
        self.rng.pick(&self.scope.bodies).clone()
    }

    fn number(&mut self) -> String {
        if self.rng.chance(self.extreme) {
            let n = *self.rng.pick(EXTREME);
            // Literals that do not fit an f64 stop at the parser: rarely.
            if (n == "1e999" || n.len() > 25) && self.rng.chance(0.8) {
                return "1e308".to_string();
            }
            return n.to_string();
        }
        if self.rng.chance(0.4) {
            return self.rng.range(0, 5).to_string();
        }
        let v = (self.rng.unit() * 4.0 - 2.0).abs();
        format!("{}", (v * 1000.0).round() / 1000.0)
    }

    fn leaf(&mut self, ctx: Ctx) -> String {
        let ctx = if self.scope.sloppy && self.rng.chance(0.05) {
            Ctx::Driving
        } else {
            ctx
        };
        let choice = self.rng.weighted(&[6, 2, 3, 4, 5]);
        match choice {
            1 => "pi".to_string(),
            2 => self.param().unwrap_or_else(|| "1".to_string()),
            3 if matches!(ctx, Ctx::Driving | Ctx::Time) => "t".to_string(),
            4 if matches!(ctx, Ctx::Kinematic | Ctx::Driving) && !self.scope.bodies.is_empty() => {
                let b = self.rng.pick(&self.scope.bodies).clone();
                let c = *self.rng.pick(&["x", "y", "phi"]);
                format!("{b}.{c}")
            }
            _ => self.number(),
        }
    }

    /// A scalar expression of at most `depth` levels.
    fn scalar(&mut self, ctx: Ctx, depth: usize) -> String {
        if depth == 0 || self.budget == 0 {
            return self.leaf(ctx);
        }
        self.budget -= 1;
        let d = depth - 1;
        match self
            .rng
            .weighted(&[8, 4, 4, 4, 4, 2, 5, 1, 1, 1, 1, 2, 2, 1, 1, 1, 2])
        {
            0 => self.leaf(ctx),
            1 => format!("{} + {}", self.scalar(ctx, d), self.scalar(ctx, d)),
            2 => format!("{} - {}", self.scalar(ctx, d), self.scalar(ctx, d)),
            3 => format!("{} * {}", self.scalar(ctx, d), self.scalar(ctx, d)),
            4 => format!("{} / {}", self.scalar(ctx, d), self.scalar(ctx, d)),
            5 => format!("-{}", self.scalar(ctx, d)),
            6 => {
                let f = *self.rng.pick(&FUNCS1);
                format!("{f}({})", self.scalar(ctx, d))
            }
            7 => format!("atan2({}, {})", self.scalar(ctx, d), self.scalar(ctx, d)),
            8 => format!("pow({}, {})", self.scalar(ctx, d), self.scalar(ctx, d)),
            9 => {
                let n = *self
                    .rng
                    .pick(&["0", "1", "2", "3", "-1", "-2", "7", "1000", "-1075"]);
                format!("powi({}, {n})", self.scalar(ctx, d))
            }
            10 => format!(
                "step({}, {}, {}, {}, {})",
                self.scalar(ctx, d),
                self.scalar(ctx, d),
                self.scalar(ctx, d),
                self.scalar(ctx, d),
                self.scalar(ctx, d)
            ),
            11 if matches!(ctx, Ctx::Kinematic | Ctx::Driving) => {
                let f = *self.rng.pick(&["dot", "cross"]);
                format!("{f}({}, {})", self.vector(ctx, d), self.vector(ctx, d))
            }
            12 if matches!(ctx, Ctx::Kinematic | Ctx::Driving) => {
                format!("norm({})", self.vector(ctx, d))
            }
            13 if matches!(ctx, Ctx::Kinematic | Ctx::Driving) => {
                let c = *self.rng.pick(&["x", "y"]);
                format!("({}).{c}", self.vector(ctx, d))
            }
            14 => self.long(ctx, " + "),
            15 => self.long(ctx, " * "),
            _ => format!("({})", self.scalar(ctx, d)),
        }
    }

    /// A long sum or product of leaves (coordinates make products costly to
    /// differentiate, so their length stays moderate).
    fn long(&mut self, ctx: Ctx, op: &str) -> String {
        let n = if self.rng.chance(0.1) {
            self.rng.range(50, 120)
        } else {
            self.rng.range(2, 20)
        };
        self.budget = self.budget.saturating_sub(n / 4);
        let terms: Vec<String> = (0..n).map(|_| self.leaf(ctx)).collect();
        format!("({})", terms.join(op))
    }

    /// A point: `B(sx, sy)`, a named point, or `ground(x, y)`.
    fn point(&mut self, body: &str) -> String {
        if body != "ground" && self.rng.chance(0.2) {
            let named: Vec<&(String, String)> = self
                .scope
                .points
                .iter()
                .filter(|(b, _)| b == body)
                .collect();
            if !named.is_empty() {
                let (b, p) = *self.rng.pick(&named);
                return format!("{b}.{p}");
            }
        }
        let (x, y) = (self.constant(), self.constant());
        format!("{body}({x}, {y})")
    }

    fn vector(&mut self, ctx: Ctx, depth: usize) -> String {
        if depth == 0 || self.budget == 0 {
            let b = self.body();
            return self.point(&b);
        }
        self.budget -= 1;
        let d = depth - 1;
        match self.rng.weighted(&[6, 3, 2, 2, 1, 2, 1, 1, 1, 1]) {
            0 => {
                let b = self.body();
                self.point(&b)
            }
            1 => format!("({}, {})", self.scalar(ctx, d), self.scalar(ctx, d)),
            2 => format!("{} + {}", self.vector(ctx, d), self.vector(ctx, d)),
            3 => format!("{} - {}", self.vector(ctx, d), self.vector(ctx, d)),
            4 => format!("-{}", self.vector(ctx, d)),
            5 => format!("{} * {}", self.scalar(ctx, d), self.vector(ctx, d)),
            6 => format!("{} * {}", self.vector(ctx, d), self.scalar(ctx, d)),
            7 => format!("{} / {}", self.vector(ctx, d), self.scalar(ctx, d)),
            8 => format!("rot({}, {})", self.scalar(ctx, d), self.vector(ctx, d)),
            _ => format!("perp({})", self.vector(ctx, d)),
        }
    }

    /// A driving function f(t) of params and `t`: the vocabulary with
    /// extreme numbers.
    fn drive(&mut self) -> String {
        let depth = self.rng.range(0, 4);
        let f = self.scalar(Ctx::Time, depth);
        if self.rng.chance(0.5) {
            format!("{f} + t")
        } else {
            f
        }
    }

    /// A constant: usually a literal or a param, sometimes an expression.
    fn constant(&mut self) -> String {
        let depth = usize::from(self.rng.chance(0.2));
        self.scalar(Ctx::Constant, depth)
    }

    fn vec_lit(&mut self) -> String {
        let x = self.constant();
        let y = self.constant();
        format!("({x}, {y})")
    }
}

/// What a unit of rows constrains, so that a body's three rows are mostly
/// independent.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Role {
    Two,
    X,
    Y,
    Angle,
    Any,
}

/// A unit of rows: equations on body `b` (attached to `other`) whose rows
/// add up to `rows`.
fn unit(g: &mut Gen<'_>, b: &str, other: &str, name: &str, role: Role, out: &mut String) -> usize {
    let pi = g.point(b);
    let pj = g.point(other);
    let kin = if g.rng.chance(0.5) {
        "joint"
    } else {
        "constraint"
    };
    match role {
        Role::Two => {
            let call = match g.rng.weighted(&[6, 3, 1, 1]) {
                0 => format!("revolute({pi}, {pj})"),
                1 => {
                    let (vi, vj) = (g.vec_lit(), g.vec_lit());
                    format!("translational({pi}, {vi}, {pj}, {vj})")
                }
                2 => {
                    let v = g.vec_lit();
                    let r = g.scalar(Ctx::Constant, 1);
                    let c = g.scalar(Ctx::Constant, 1);
                    format!("rack_pinion({pi}, {v}, {pj}, {r}, {c})")
                }
                _ => {
                    let e = g.vector(Ctx::Kinematic, 2);
                    format!("{pi} == {e}")
                }
            };
            let _ = writeln!(out, "    {kin} {name}: {call};");
            2
        }
        _ => {
            let driving = g.rng.chance(0.5);
            let (kw, ctx) = if driving {
                ("driver", Ctx::Driving)
            } else {
                (kin, Ctx::Kinematic)
            };
            let f = if driving {
                g.drive()
            } else {
                g.scalar(Ctx::Constant, 1)
            };
            let user = |g: &mut Gen<'_>, c: &str| {
                let lhs = if g.rng.chance(0.7) {
                    format!("{b}.{c}")
                } else {
                    let e = g.scalar(ctx, 2);
                    format!("{b}.{c} + {e}")
                };
                format!("{lhs} == {f}")
            };
            let call = match role {
                Role::X => match g.rng.below(3) {
                    0 => format!("abs_x({pi}, {f})"),
                    1 => format!("rel_x({pj}, {pi}, {f})"),
                    _ => user(g, "x"),
                },
                Role::Y => match g.rng.below(3) {
                    0 => format!("abs_y({pi}, {f})"),
                    1 => format!("rel_y({pj}, {pi}, {f})"),
                    _ => user(g, "y"),
                },
                Role::Angle => match g.rng.below(4) {
                    0 => format!("abs_angle({b}, {f})"),
                    1 => format!("rel_angle({other}, {b}, {f})"),
                    2 => {
                        let (ai, aj) = (g.vec_lit(), g.vec_lit());
                        format!("dp1({other}, {ai}, {b}, {aj}, {f})")
                    }
                    _ => user(g, "phi"),
                },
                Role::Any | Role::Two => match g.rng.below(9) {
                    0 => format!("abs_distance({pi}, {}, {f})", g.vec_lit()),
                    1 => format!("rel_distance({pj}, {pi}, {f})"),
                    2 => format!("revolute_revolute({pj}, {pi}, {f})"),
                    3 => format!("revolute_translational({pj}, {}, {pi}, {f})", g.vec_lit()),
                    4 => {
                        let (ri, rj) = (g.scalar(Ctx::Constant, 0), g.scalar(Ctx::Constant, 0));
                        format!("gear({pj}, {pi}, {ri}, {rj}, {f}, 0)")
                    }
                    5 => format!("translational_distance({pj}, {}, {pi}, {f})", g.vec_lit()),
                    6 => format!("dp2({pj}, {}, {pi}, {f})", g.vec_lit()),
                    7 => format!("cd({}, {pj}, {pi}, {f})", g.vec_lit()),
                    _ => {
                        let e = g.scalar(ctx, 3);
                        format!("{e} == {f}")
                    }
                },
            };
            let _ = writeln!(out, "    {kw} {name}: {call};");
            1
        }
    }
}

/// A deeply nested expression: parentheses, calls or unary minus, to probe
/// the nesting limits (and, without them, the stack).
fn deep(rng: &mut Rng) -> String {
    let n = *rng.pick(&[30, 64, 100, 127, 128, 129, 200, 256, 1000, 5000]);
    let (open, close) = match rng.below(4) {
        0 => ("(".to_string(), ")"),
        1 => ("sin(".to_string(), ")"),
        2 => ("-".to_string(), ""),
        _ => ("(1 + ".to_string(), ")"),
    };
    let mut s = open.repeat(n);
    s.push('t');
    s.push_str(&close.repeat(n));
    s
}

/// A `.kin` model from the grammar.
pub fn generate(rng: &mut Rng) -> String {
    let sloppy = rng.chance(0.15);
    let mut g = Gen {
        rng,
        scope: Scope {
            params: Vec::new(),
            bodies: Vec::new(),
            points: Vec::new(),
            sloppy,
        },
        budget: 400,
        extreme: 0.0,
    };
    g.extreme = *g.rng.pick(&[0.0, 0.0, 0.02, 0.1, 0.3]);
    let mut out = String::new();
    if g.rng.chance(0.3) {
        out.push_str("/// A generated mechanism.\n");
    }
    let name = if g.rng.chance(0.05) {
        (*g.rng.pick(KEYWORDS)).to_string()
    } else {
        "Fuzz".to_string()
    };
    let _ = writeln!(out, "mechanism {name} {{");

    let nparams = g.rng.range(0, 4);
    for i in 0..nparams {
        let depth = g.rng.range(0, 3);
        let v = g.scalar(Ctx::Constant, depth);
        let pname = name_for(g.rng, sloppy, &format!("p{i}"));
        if g.rng.chance(0.2) {
            let _ = writeln!(out, "    /// a length [m]");
        }
        let _ = writeln!(out, "    param {pname} = {v};");
        g.scope.params.push(pname);
    }

    let nbodies = match g.rng.weighted(&[10, 6, 2, 1]) {
        0 => 1,
        1 => g.rng.range(2, 4),
        2 => g.rng.range(5, 12),
        _ => g.rng.range(20, 40),
    };
    for i in 0..nbodies {
        let bname = name_for(g.rng, sloppy, &format!("b{i}"));
        if g.rng.chance(0.2) {
            let _ = writeln!(out, "    body {bname};");
        } else {
            let x = g.constant();
            let y = g.constant();
            let phi = g.constant();
            let _ = writeln!(out, "    body {bname} {{ guess: ({x}, {y}, {phi}) }}");
        }
        g.scope.bodies.push(bname);
    }
    let npoints = g.rng.range(0, 3);
    for i in 0..npoints {
        let b = g.rng.pick(&g.scope.bodies).clone();
        let p = name_for(g.rng, sloppy, &format!("o{i}"));
        let v = g.vec_lit();
        let _ = writeln!(out, "    point {b}.{p} = {v};");
        g.scope.points.push((b, p));
    }

    let bodies = g.scope.bodies.clone();
    let mut eq = 0;
    for (i, b) in bodies.iter().enumerate() {
        let other = if i == 0 || g.rng.chance(0.3) {
            "ground".to_string()
        } else {
            bodies[g.rng.below(i)].clone()
        };
        let roles: &[Role] = match g.rng.weighted(&[6, 3, 2, 1]) {
            0 => &[Role::Two, Role::Angle],
            1 => &[Role::X, Role::Y, Role::Angle],
            2 => &[Role::Two, Role::Any],
            _ => &[Role::Any, Role::Any, Role::Any],
        };
        for &role in roles {
            let ename = name_for(g.rng, sloppy, &format!("e{eq}"));
            eq += 1;
            unit(&mut g, b, &other, &ename, role, &mut out);
        }
    }
    // Now and then: something deep, something extra, something missing.
    if g.rng.chance(0.08) {
        let b = g.rng.pick(&bodies).clone();
        let _ = writeln!(out, "    driver deep: {b}.x == {};", deep(g.rng));
    }
    if sloppy && g.rng.chance(0.5) {
        let b = g.rng.pick(&bodies).clone();
        let f = g.drive();
        let _ = writeln!(out, "    driver extra: {b}.phi == {f};");
    }
    out.push_str("}\n");
    if sloppy && g.rng.chance(0.3) {
        drop_a_line(g.rng, &out)
    } else {
        out
    }
}

/// A name: usually `fallback`, in a sloppy model sometimes a keyword or a
/// duplicate.
fn name_for(rng: &mut Rng, sloppy: bool, fallback: &str) -> String {
    if sloppy && rng.chance(0.1) {
        (*rng.pick(KEYWORDS)).to_string()
    } else if sloppy && rng.chance(0.05) {
        "dup".to_string()
    } else {
        fallback.to_string()
    }
}

fn drop_a_line(rng: &mut Rng, text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let k = rng.below(lines.len());
    let mut out = String::new();
    for (i, l) in lines.iter().enumerate() {
        if i != k {
            out.push_str(l);
            out.push('\n');
        }
    }
    out
}

/// A model whose single driver is `f`, on a free body whose other
/// coordinates are fixed: `b.x` must then equal f(t) (the `fun` target's
/// differential oracle).
#[must_use]
pub fn driver_model(f: &str) -> String {
    format!(
        "mechanism Fun {{\n    body b;\n    constraint fy: b.y == 0;\n    \
         constraint fphi: b.phi == 0;\n    driver f: b.x == {f};\n}}\n"
    )
}

/// A scalar expression of `t` alone (for splicing into seed models).
pub fn time_expr(rng: &mut Rng) -> String {
    let mut g = Gen {
        rng,
        scope: Scope {
            params: Vec::new(),
            bodies: Vec::new(),
            points: Vec::new(),
            sloppy: false,
        },
        budget: 100,
        extreme: 0.2,
    };
    let depth = g.rng.range(0, 3);
    g.scalar(Ctx::Time, depth)
}
