//! Generator of simEngine2D ADM models (JSON) and ACF analyses: bodies with
//! odd names and extreme coordinates, every constraint type with rows
//! balanced so that most models are kinematic (NDOF = 0), `fun` strings from
//! the `fun` generator, force elements and drawing data now and then.

use std::fmt::Write as _;

use super::{fun, json_number};
use crate::rng::Rng;

const NAMES: &[&str] = &[
    "crank",
    "Long Rod",
    "1st",
    "rod",
    "revolute",
    "ground",
    "t",
    "pi",
    "",
    "  ",
    "b-1",
    "é",
    "crank",
    "a\\\"b",
    "x.y",
    "mechanism",
];

fn vec2(rng: &mut Rng) -> String {
    format!("[{}, {}]", json_number(rng), json_number(rng))
}

/// A direction: usually ordinary, sometimes tiny, huge or zero.
fn direction(rng: &mut Rng) -> String {
    if rng.chance(0.9) {
        (*rng.pick(&["[1, 0]", "[0, 1]", "[2, 0]", "[1, 1]", "[-1, 0.5]"])).to_string()
    } else {
        (*rng.pick(&[
            "[1e-200, 1e-200]",
            "[5e-324, 0]",
            "[1e200, 1e200]",
            "[0, 0]",
            "[1e308, 1e308]",
            "[1e-320, 1e-320]",
            "[-0.0, 0]",
        ]))
        .to_string()
    }
}

/// A `mass` or `jbar`: ≥ 0, as a model needs (the reader refuses a
/// negative one at its field: pinned by kinema-adm's tests and
/// `corpus/adm/negative_inertia.adm`). The same draws as any JSON number,
/// so the generator's sequence is unchanged.
fn inertia(rng: &mut Rng) -> String {
    json_number(rng).trim_start_matches('-').to_owned()
}

fn small_fun(rng: &mut Rng, driving: bool) -> String {
    let f = if driving && rng.chance(0.08) {
        fun::generate(rng)
    } else if driving {
        let depth = rng.range(0, 3);
        let f = fun::tame(rng, depth);
        if f.contains('t') {
            f
        } else {
            format!("{f} + t")
        }
    } else {
        json_number(rng)
    };
    json_string(&f)
}

/// `s` as a JSON string literal.
pub fn json_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// An ADM model, optionally followed by a NUL byte and an ACF analysis (the
/// `adm` target's input format).
pub fn generate(rng: &mut Rng) -> String {
    let nbodies = match rng.weighted(&[6, 6, 2, 1]) {
        0 => 1,
        1 => rng.range(2, 4),
        2 => rng.range(5, 10),
        _ => rng.range(20, 60),
    };
    let odd_names = rng.chance(0.2);
    let mut out = String::from("{\n  \"name\": \"Fuzz\",\n  \"gravity\": [0, -9.81],\n");
    if rng.chance(0.3) {
        let _ = writeln!(
            out,
            "  \"vis\": {{ \"bgRGB\": [0.6, 0.7, 0.8], \"xlim\": {}, \"ylim\": {} }},",
            vec2(rng),
            vec2(rng)
        );
    }
    out.push_str("  \"bodies\": [\n");
    for i in 0..nbodies {
        body_line(rng, &mut out, i, nbodies, odd_names);
    }
    out.push_str("  ],\n  \"constraints\": [\n");
    let items = constraint_items(rng, nbodies, odd_names);
    out.push_str(&items.join(",\n"));
    out.push_str("\n  ]");
    if rng.chance(0.15) {
        let _ = write!(
            out,
            ",\n  \"forces\": [ {{ \"name\": \"f\", \"id\": 1, \"type\": \"PointForce\", \"body1\": 1, \"sP1\": [0, 0], \"frame\": \"GRF\", \"funX\": {}, \"funY\": \"0\" }} ]",
            json_string(&fun::generate(rng))
        );
    }
    out.push_str("\n}\n");
    if rng.chance(0.3) {
        out.push('\0');
        out.push_str(&acf(rng));
    }
    out
}

/// Body `i` of `nbodies` as one line of the `bodies` array.
fn body_line(rng: &mut Rng, out: &mut String, i: usize, nbodies: usize, odd_names: bool) {
    let name = if odd_names {
        (*rng.pick(NAMES)).to_string()
    } else {
        format!("body{i}")
    };
    let q0 = if rng.chance(0.7) {
        format!("[{}, 0, 0]", i)
    } else {
        format!(
            "[{}, {}, {}]",
            json_number(rng),
            json_number(rng),
            json_number(rng)
        )
    };
    let vis = if rng.chance(0.3) {
        format!(
            ", \"vis\": {{ \"RGB\": [0.8, 0.3, 0.4], \"shapes\": [{{ \"loc\": {}, \"size\": {} }}], \"points\": [{}] }}",
            vec2(rng),
            vec2(rng),
            vec2(rng)
        )
    } else {
        String::new()
    };
    let sep = if i + 1 < nbodies { "," } else { "" };
    let _ = writeln!(
        out,
        "    {{ \"name\": {}, \"id\": {}, \"mass\": {}, \"jbar\": {}, \"q0\": {q0}, \"qd0\": [0, 0, 0]{vis} }}{sep}",
        json_string(&name),
        i + 1,
        inertia(rng),
        inertia(rng)
    );
}

/// The constraints: for each body a two-row joint to an earlier body or
/// absolute constraints, enough rows (or not) for a model to check.
fn constraint_items(rng: &mut Rng, nbodies: usize, odd_names: bool) -> Vec<String> {
    let mut items = Vec::new();
    for i in 0..nbodies {
        let b = i + 1;
        let other = if i == 0 { None } else { Some(rng.range(1, i)) };
        // Units: 2 = a two-row joint; 0, 1, 2 + 10 = AbsoluteX, Y, Angle.
        let units: &[usize] = match (other.is_some(), rng.weighted(&[6, 3, 1])) {
            (true, 0) => &[2, 12],
            (_, 1) | (false, 0) => &[10, 11, 12],
            (true, _) => &[2, 10 + rng.below(3)],
            (false, _) => &[10 + rng.below(3), 10 + rng.below(3), 12],
        };
        for &unit in units {
            let id = items.len() + 1;
            let item = if let (2, Some(o)) = (unit, other) {
                match rng.weighted(&[5, 2, 1]) {
                    0 => format!(
                        "\"type\": \"RevoluteJoint\", \"body1\": {o}, \"sP1\": {}, \"body2\": {b}, \"sP2\": {}, \"fun\": \"NONE\"",
                        vec2(rng),
                        vec2(rng)
                    ),
                    1 => format!(
                        "\"type\": \"TranslationalJoint\", \"body1\": {o}, \"sP1\": {}, \"vP1\": {}, \"body2\": {b}, \"sP2\": {}, \"vP2\": {}, \"fun\": \"NONE\"",
                        vec2(rng),
                        direction(rng),
                        vec2(rng),
                        direction(rng)
                    ),
                    _ => format!(
                        "\"type\": \"RackPinion\", \"body1\": {o}, \"body2\": {b}, \"sP1\": {}, \"sQ1\": {}, \"sP2\": {}, \"theta1\": {}, \"theta2\": {}, \"R2\": {}, \"fun\": \"0\"",
                        vec2(rng),
                        direction(rng),
                        vec2(rng),
                        json_number(rng),
                        json_number(rng),
                        json_number(rng)
                    ),
                }
            } else {
                let driving = rng.chance(0.4);
                match unit % 10 {
                    0 => format!(
                        "\"type\": \"AbsoluteX\", \"body1\": {b}, \"sP1\": {}, \"fun\": {}",
                        vec2(rng),
                        small_fun(rng, driving)
                    ),
                    1 => format!(
                        "\"type\": \"AbsoluteY\", \"body1\": {b}, \"sP1\": {}, \"fun\": {}",
                        vec2(rng),
                        small_fun(rng, driving)
                    ),
                    _ => format!(
                        "\"type\": \"AbsoluteAngle\", \"body1\": {b}, \"fun\": {}",
                        small_fun(rng, driving)
                    ),
                }
            };
            let name = if odd_names {
                (*rng.pick(NAMES)).to_string()
            } else {
                format!("c{id}")
            };
            items.push(format!(
                "    {{ \"name\": {}, \"id\": {id}, {item} }}",
                json_string(&name)
            ));
        }
    }
    items
}

/// An ACF analysis, JSON or the plain `key: value` form, with extreme
/// values now and then.
pub fn acf(rng: &mut Rng) -> String {
    let sim = if rng.chance(0.9) {
        "Kinematics"
    } else {
        *rng.pick(&["Dynamics", "Equilibrium", "kinematics", ""])
    };
    let tend = *rng.pick(&[
        "1", "5.0", "0.1", "1e-300", "5e-324", "1e300", "1e6", "0", "-1",
    ]);
    let step = *rng.pick(&["0.01", "0.1", "1", "1e-300", "5e-324", "1e300", "0.5"]);
    // A valid analysis with 10⁵ … 10⁷ solves (tend 1e6, stepSize 1) is a
    // long job, not a hang: kept to 10⁴ solves so that the 10 s limit
    // judges kinema, not the size of the work asked for. Beyond 10⁷ kinema
    // must refuse at once, so those stay.
    let (t, h): (f64, f64) = (tend.parse().unwrap_or(0.0), step.parse().unwrap_or(0.0));
    let long = t > 0.0 && h > 0.0 && (1e5..=1e7).contains(&(t / h));
    let bounded = format!("{:e}", t / 1e4);
    let step = if long { bounded.as_str() } else { step };
    let steps = *rng.pick(&[
        "10",
        "5",
        "1",
        "0",
        "100",
        "1000000000000",
        "18446744073709551615",
        "1e3",
        "2.5",
    ]);
    if rng.chance(0.5) {
        format!(
            "{{\n\"simulation\": \"{sim}\",\n\"tend\": {tend},\n\"stepSize\": {step},\n\"outputSteps\": {steps}\n}}\n"
        )
    } else {
        format!("simulation: {sim}\ntend: {tend}\nstepSize: {step}\noutputSteps: {steps}\n")
    }
}
