//! The derivation of named points and measures (`output NAME: EXPR;`):
//! what `kinema derive` prints for them, pinned as snapshots.

use std::path::PathBuf;

fn outputs_section(file: &str) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../models")
        .join(file);
    let src = std::fs::read_to_string(&path).unwrap_or_default();
    let derivation =
        kinema_model::derive_str(&src).unwrap_or_else(|d| panic!("{}", d.render(&src, file)));
    let text = derivation.render();
    let start = text.find("\noutputs").unwrap_or(text.len());
    let end = text[start..]
        .find("\nshared program")
        .map_or(text.len(), |e| start + e);
    text[start..end].to_string()
}

#[test]
fn slider_crank_points_and_outputs() {
    insta::assert_snapshot!(outputs_section("slider_crank.kin"));
}

#[test]
fn four_bar_coupler_point_and_transmission_angle() {
    insta::assert_snapshot!(outputs_section("four_bar.kin"));
}

/// Columns come in declaration order, points before measures, a vector
/// measure as `.x`, `.y`; a time-dependent measure gets its ∂/∂t terms.
#[test]
fn columns_and_time_terms() {
    let src = "mechanism M {
        body bar { guess: (1, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-1, 0));
        driver swing: bar.phi == t;
        output lead: bar.phi - t * t;
        point bar.tip = (1, 0);
        output tip_rel: bar.tip - (t, 0);
    }";
    let d = kinema_model::derive_str(src).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = d.outputs.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(
        names,
        ["bar.tip.x", "bar.tip.y", "lead", "tip_rel.x", "tip_rel.y"]
    );
    // lead = φ − t²: lead_dot = φ̇ − 2t, c = −2 (q̈-free part), ∂/∂φ = 1.
    let lead = &d.outputs[2];
    let (q, qd, t) = ([0.0, 0.0, 0.7], [0.0, 0.0, 1.3], 0.4);
    let v = d.eval(lead.velocity, &q, &qd, t, &[]);
    assert!((v - (1.3 - 0.8)).abs() < 1e-15, "{v}");
    let c = d.eval(lead.acceleration, &q, &qd, t, &[]);
    assert!((c + 2.0).abs() < 1e-15, "{c}");
    assert_eq!(lead.jacobian.len(), 1);
    assert_eq!(lead.jacobian[0].0, 2);
}
