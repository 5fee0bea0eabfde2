//! Input generators: grammar-aware generators of valid-but-extreme models
//! for each entry point, structured mutation of real model files, and
//! byte-level mutation (a minority: most byte flips die in the parser).

pub mod adm;
pub mod fun;
pub mod kin;
pub mod mutate;

use crate::rng::Rng;

/// Numbers that stress floating point: zero, the extremes of `f64`, the
/// smallest subnormal, values whose squares or products overflow or
/// underflow, and ordinary ones so that models still assemble.
pub const EXTREME: &[&str] = &[
    "0",
    "0.0",
    "1",
    "2",
    "0.5",
    "1e308",
    "1.7976931348623157e308",
    "1.7e308",
    "5e-324",
    "2.2250738585072014e-308",
    "1e-200",
    "1e200",
    "1e160",
    "1e154",
    "1e-160",
    "1e10",
    "1e-10",
    "1e16",
    "123456789012345678901234567890",
    "3.141592653589793",
    "1e999",
    "0e0",
    "1000",
    "700",
    "710",
];

/// A number literal: mostly ordinary (so that models run), sometimes
/// extreme.
pub fn number(rng: &mut Rng) -> String {
    match rng.weighted(&[6, 3, 2]) {
        0 => {
            let v = (rng.unit() * 4.0 - 2.0) * 10f64.powi(rng.range(0, 2) as i32);
            let v = (v * 1000.0).round() / 1000.0;
            format!("{}", v.abs())
        }
        1 => rng.range(0, 10).to_string(),
        _ => (*rng.pick(EXTREME)).to_string(),
    }
}

/// A number suitable for JSON (no `1e999`-style overflow most of the time,
/// but still extreme), possibly negative.
pub fn json_number(rng: &mut Rng) -> String {
    let mut n = number(rng);
    if (n == "1e999" || n.len() > 25) && rng.chance(0.97) {
        n = "1e308".to_string();
    }
    if rng.chance(0.3) { format!("-{n}") } else { n }
}

/// Identifiers that are keywords or built-in names somewhere in the
/// languages: used as names to probe the checkers.
pub const KEYWORDS: &[&str] = &[
    "t",
    "pi",
    "ground",
    "param",
    "body",
    "point",
    "joint",
    "constraint",
    "driver",
    "mechanism",
    "guess",
    "sin",
    "cos",
    "exp",
    "ln",
    "sqrt",
    "pow",
    "powi",
    "step",
    "dot",
    "cross",
    "norm",
    "rot",
    "perp",
    "x",
    "y",
    "phi",
    "revolute",
    "abs_x",
    "translational",
    "gear",
    "d",
    "cd",
    "dp1",
    "self",
    "Self",
    "fn",
    "let",
    "r#type",
    "_",
    "é",
    "NONE",
    "inf",
    "NaN",
];

/// The repository's own model files, for structured mutation.
pub const KIN_SEEDS: &[&str] = &[
    include_str!("../../../../models/slider_crank.kin"),
    include_str!("../../../../models/four_bar.kin"),
    include_str!("../../../../models/pendulum.kin"),
    include_str!("../../../../models/parabola_follower.kin"),
    include_str!("../../../../models/slider_crank_translational.kin"),
    include_str!("../../../../models/chain10.kin"),
];

/// The repository's ADM test models, for structured mutation (the real
/// simEngine2D files are added at run time: [`Seeds::with_dir`]).
pub const ADM_SEEDS: &[&str] = &[
    include_str!("../../../kinema-adm/tests/data/slider_crank.adm"),
    include_str!("../../../kinema-adm/tests/data/bad_number.adm"),
];

/// `fun` strings as the shipped models write them.
pub const FUN_SEEDS: &[&str] = &[
    "pi/4 + 2*pi*t",
    "sin(10*t)",
    "0",
    "NONE",
    "0.2",
    "-pi/2 + 0.5*sin(2*pi*t)",
    "t^2 - 3*t./2",
    "atan2(sin(t), cos(t))",
    "power(t, 2.5) + log10(t + 1)",
];

/// Seed inputs per target: the embedded ones plus files read at start.
#[derive(Clone, Debug, Default)]
pub struct Seeds {
    /// `.kin` texts.
    pub kin: Vec<String>,
    /// ADM texts (and ACF texts, which mutate into the ADM target's
    /// analysis part).
    pub adm: Vec<String>,
    /// ACF texts.
    pub acf: Vec<String>,
    /// `fun` strings.
    pub fun: Vec<String>,
}

impl Seeds {
    /// The embedded seeds.
    #[must_use]
    pub fn embedded() -> Seeds {
        let own = |v: &[&str]| v.iter().map(|s| (*s).to_string()).collect();
        Seeds {
            kin: own(KIN_SEEDS),
            adm: own(ADM_SEEDS),
            acf: Vec::new(),
            fun: own(FUN_SEEDS),
        }
    }

    /// Adds the `.kin`, `.adm` and `.acf` files of `dir` (not recursive),
    /// in name order so that runs are reproducible; the `fun` strings of the
    /// ADM files join the `fun` seeds. A missing directory adds nothing.
    #[must_use]
    pub fn with_dir(mut self, dir: &std::path::Path) -> Seeds {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return self;
        };
        let mut paths: Vec<std::path::PathBuf> = entries.flatten().map(|e| e.path()).collect();
        paths.sort();
        for path in paths {
            let ext = path
                .extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase());
            let Ok(text) = std::fs::read_to_string(&path) else {
                continue;
            };
            match ext.as_deref() {
                Some("kin") => self.kin.push(text),
                Some("adm") => {
                    for line in text.lines() {
                        if let Some(rest) = line.trim().strip_prefix("\"fun\":") {
                            let f = rest.trim().trim_end_matches(',').trim_matches('"');
                            self.fun.push(f.to_string());
                        }
                    }
                    self.adm.push(text);
                }
                Some("acf") => self.acf.push(text),
                _ => {}
            }
        }
        self
    }
}

/// One input for `target`: from the grammar (about 60 %), by structured
/// mutation of a seed (30 %) or by byte-level mutation of a seed or of a
/// generated input (10 %).
pub fn input(target: crate::Target, rng: &mut Rng, seeds: &Seeds) -> Vec<u8> {
    use crate::Target;
    let target = match target {
        // The program reads both formats: half each.
        Target::Cli if rng.chance(0.5) => Target::Kin,
        Target::Cli => Target::Adm,
        t => t,
    };
    let mode = rng.weighted(&[6, 3, 1]);
    let pool = match target {
        Target::Kin => &seeds.kin,
        Target::Adm | Target::Cli => &seeds.adm,
        Target::Fun => &seeds.fun,
    };
    let fresh = |rng: &mut Rng| match target {
        Target::Kin => kin::generate(rng),
        Target::Adm | Target::Cli => adm::generate(rng),
        Target::Fun => fun::generate(rng),
    };
    match mode {
        0 => fresh(rng).into_bytes(),
        1 if !pool.is_empty() => {
            let seed = rng.pick(pool).clone();
            let mut splice = |rng: &mut Rng| match target {
                Target::Kin => format!("({})", kin::time_expr(rng)),
                Target::Adm if rng.chance(0.6) => json_number(rng),
                Target::Adm | Target::Fun | Target::Cli => fun::generate(rng),
            };
            let mut out = mutate::structured(rng, &seed, &mut splice);
            if target == Target::Adm && rng.chance(0.3) {
                out.push('\0');
                if !seeds.acf.is_empty() && rng.chance(0.5) {
                    let acf = rng.pick(&seeds.acf).clone();
                    out.push_str(&mutate::structured(rng, &acf, &mut splice));
                } else {
                    out.push_str(&adm::acf(rng));
                }
            }
            out.into_bytes()
        }
        _ => {
            let base = if !pool.is_empty() && rng.chance(0.5) {
                rng.pick(pool).clone().into_bytes()
            } else {
                fresh(rng).into_bytes()
            };
            mutate::bytes(rng, &base)
        }
    }
}
