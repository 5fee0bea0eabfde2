//! Hostile but valid input: a long product derives in linear size, the
//! derivation budget ends with an error at the equation, and undefined parts
//! of equations are errors at their span instead of vanishing.

use kinema_model::{DERIVATION_BUDGET, Derivation, chain::chain_kin, check_str, derive_str};

/// `n` bodies on the x axis; bodies 2..n are driven, body 1's x follows from
/// one constraint: the product of all n x coordinates is 1.
fn product_model(n: usize) -> String {
    let mut s = String::from("mechanism Product {\n");
    for i in 1..=n {
        s.push_str(&format!("    body b{i} {{ guess: (1, 0, 0) }}\n"));
    }
    for i in 1..=n {
        s.push_str(&format!(
            "    constraint y{i}: b{i}.y == 0;\n    constraint r{i}: b{i}.phi == 0;\n"
        ));
    }
    for i in 2..=n {
        s.push_str(&format!("    driver d{i}: b{i}.x == 1 + 0.001 * t;\n"));
    }
    let factors: Vec<String> = (1..=n).map(|i| format!("b{i}.x")).collect();
    s.push_str(&format!(
        "    constraint prod: {} == 1;\n}}\n",
        factors.join(" * ")
    ));
    s
}

#[test]
fn a_product_of_800_coordinates_derives_in_linear_size_with_the_closed_forms() {
    let n = 800;
    let src = product_model(n);
    let d = derive_str(&src).unwrap_or_else(|e| panic!("{}", e.render(&src, "product.kin")));
    // Everything (3n coordinates, 3n rows, all derivatives) in a few hundred
    // entries per factor; a quadratic derivation would need n² = 640 000.
    assert!(d.arena.size() < 500 * n, "arena size {}", d.arena.size());

    let row = d
        .rows
        .iter()
        .position(|r| r.name == "prod")
        .unwrap_or_else(|| panic!("no row prod"));
    let nc = d.nc();
    let q: Vec<f64> = (0..nc)
        .map(|k| {
            if k % 3 == 0 {
                1.0 + 0.0005 * (k % 17) as f64
            } else {
                0.0
            }
        })
        .collect();
    let qd: Vec<f64> = (0..nc)
        .map(|k| {
            if k % 3 == 0 {
                0.3 - 0.05 * (k % 13) as f64
            } else {
                0.0
            }
        })
        .collect();
    let x: Vec<f64> = q.iter().step_by(3).copied().collect();
    let v: Vec<f64> = qd.iter().step_by(3).copied().collect();
    let p: f64 = x.iter().product();
    let phi = d.eval(d.phi[row], &q, &qd, 0.0, &[]);
    assert!((phi - (p - 1.0)).abs() < 1e-12, "{phi} vs {}", p - 1.0);
    // Φ_q of the row: P/x_i in the x columns.
    let entries: Vec<_> = d
        .phi_q
        .entries
        .iter()
        .filter(|e| e.row as usize == row)
        .collect();
    assert_eq!(entries.len(), n);
    for e in entries {
        let i = e.col as usize / 3;
        let got = d.eval(e.expr, &q, &qd, 0.0, &[]);
        assert!((got - p / x[i]).abs() < 1e-12, "col {}: {got}", e.col);
    }
    // γ = −Σ_{i≠j} P vᵢ vⱼ/(xᵢ xⱼ) (the row does not depend on t).
    let s1: f64 = x.iter().zip(&v).map(|(x, v)| v / x).sum();
    let s2: f64 = x.iter().zip(&v).map(|(x, v)| (v / x).powi(2)).sum();
    let want = -p * (s1 * s1 - s2);
    let got = d.eval(d.gamma[row], &q, &qd, 0.0, &[]);
    assert!(
        (got - want).abs() < 1e-9 * want.abs().max(1.0),
        "{got} vs {want}"
    );
    // Its derivation text stays linear too (shared program for large entries).
    let text = d.render();
    assert!(
        text.len() < 4_000 * n,
        "derivation text of {} bytes",
        text.len()
    );
    assert!(text.contains("shared program"));
}

#[test]
fn the_budget_ends_with_an_error_at_the_equation() {
    let src = product_model(200);
    let checked = check_str(&src).unwrap_or_else(|e| panic!("{}", e.render(&src, "p.kin")));
    let err = match Derivation::with_budget(&checked, 5_000) {
        Ok(_) => panic!("a product of 200 factors fits in 5 000 entries?"),
        Err(e) => e.render(&src, "product.kin"),
    };
    // The equation by name, at its line (after 200 bodies, 400 constraints
    // and 199 drivers) and column.
    assert!(
        err.contains("the derivatives of `prod` are too large"),
        "{err}"
    );
    assert!(err.contains("--> product.kin:801:16"), "{err}");
    assert!(err.contains("5000 expression entries"), "{err}");
    // The default budget is generous enough for this and for the chain of 1000.
    assert!(Derivation::new(&checked).is_ok());
    let chain = chain_kin(1000);
    let checked = check_str(&chain).unwrap_or_else(|e| panic!("{}", e.render(&chain, "c.kin")));
    let d = Derivation::new(&checked).unwrap_or_else(|e| panic!("{}", e.render(&chain, "c.kin")));
    assert_eq!(d.phi.len(), 3000);
    let budget = DERIVATION_BUDGET;
    assert!(budget >= 1_000_000, "{budget}");
}

/// A one-body model whose driver is `rhs`; the driver is on line 4.
fn driver_model(rhs: &str) -> String {
    format!(
        "mechanism M {{\n    body b {{ guess: (0, 0, 0) }}\n    constraint c: b.x == b.y;\n    driver d: {rhs};\n    constraint e: b.y == 0;\n}}\n"
    )
}

fn errors(src: &str) -> String {
    match check_str(src) {
        Ok(_) => panic!("accepted:\n{src}"),
        Err(e) => e.render(src, "m.kin"),
    }
}

#[test]
fn undefined_values_are_errors_at_their_span() {
    // `(0 / 0) * t + t`: the divisor `0`.
    let e = errors(&driver_model("b.phi == (0 / 0) * t + t"));
    assert!(e.contains("division by zero: this divisor is zero"), "{e}");
    assert!(e.contains("--> m.kin:4:29"), "{e}");
    // `t + (b.x - b.x) / (b.y - b.y)`: the divisor is identically zero.
    let e = errors(&driver_model("b.phi == t + (b.x - b.x) / (b.y - b.y)"));
    assert!(
        e.contains("division by zero: this divisor is identically zero"),
        "{e}"
    );
    assert!(e.contains("--> m.kin:4:43"), "{e}");
    // `t + 0 * (1e308 * 1e308)`: the overflowing product.
    let e = errors(&driver_model("b.phi == t + 0 * (1e308 * 1e308)"));
    assert!(e.contains("this constant is infinite"), "{e}");
    assert!(e.contains("--> m.kin:4:33"), "{e}");
    // A function with no value anywhere.
    let e = errors(&driver_model("b.phi == t + 0 * ln(b.x - b.x)"));
    assert!(e.contains("undefined whatever the coordinates"), "{e}");
    assert!(e.contains("--> m.kin:4:32"), "{e}");
    // In a library call's argument as well (params are symbols: `k - k`
    // is zero for every value of `k`).
    let src = "mechanism M {\n    param k = 2;\n    body b { guess: (0, 0, 0) }\n    constraint c: b.x == b.y;\n    driver d: abs_angle(b, t / (k - k));\n    constraint e: b.y == 0;\n}\n";
    let e = errors(src);
    assert!(e.contains("identically zero"), "{e}");
    assert!(e.contains("--> m.kin:5:33"), "{e}");
    // Defined expressions are untouched: x/x, 0·x, a zero that is a value.
    for ok in [
        "b.phi == t * (b.x + 1) / (b.x + 1)",
        "b.phi == t + 0 * b.x",
        "b.phi == t + (b.x - b.x)",
        "b.phi == t / 2",
    ] {
        let src = driver_model(ok);
        assert!(derive_str(&src).is_ok(), "{ok}: {}", errors(&src));
    }
}
