//! Two faults of `--plot` figures, pinned on the SVG the binary writes:
//! tick labels printed with their floating-point noise
//! (`0.6000000000000001` on the time axis), and an empty "Driven
//! coordinates" panel on forward dynamics, which has no driver.

mod common;

use common::*;

/// The text of every `<text>` element of an SVG.
fn labels(svg: &str) -> Vec<&str> {
    svg.split("<text")
        .skip(1)
        .filter_map(|rest| {
            let body = &rest[rest.find('>')? + 1..];
            Some(body[..body.find("</text>")?].trim())
        })
        .collect()
}

/// Runs `model` with `--plot`; the SVG's text.
fn plot(dir: &TempDir, model: &str, extra: &[&str]) -> Result<String, Box<dyn std::error::Error>> {
    let svg = dir.path("figure.svg");
    let mut args = vec!["run", model, "--out", "-", "--plot", &svg];
    args.extend_from_slice(extra);
    let o = kinema(&args);
    assert_status(&o, 0);
    Ok(std::fs::read_to_string(&svg)?)
}

#[test]
fn tick_labels_are_short_decimals() -> TestResult {
    let dir = TempDir::new("ticks");
    for model in ["models/slider_crank.kin", "models/four_bar.kin"] {
        let svg = plot(&dir, model, &["--steps", "60"])?;
        let numbers: Vec<&str> = labels(&svg)
            .into_iter()
            .filter(|l| l.parse::<f64>().is_ok())
            .collect();
        assert!(numbers.len() > 20, "{model}: tick labels {numbers:?}");
        // The time axis over [0, 1] has its tenths, as written.
        for tenth in ["0.2", "0.4", "0.6", "0.8"] {
            assert!(numbers.contains(&tenth), "{model}: {tenth} in {numbers:?}");
        }
        for n in &numbers {
            let digits = n.chars().filter(char::is_ascii_digit).count();
            assert!(digits <= 6, "{model}: tick label {n} (of {numbers:?})");
        }
    }
    Ok(())
}

#[test]
fn forward_dynamics_has_no_driven_panel() -> TestResult {
    let dir = TempDir::new("no-driven");
    let model = format!("{ROOT}/crates/kinema-bench/models/fd_slider_crank.kin");
    let svg = plot(&dir, &model, &["--steps", "20", "--t-end", "0.2"])?;
    assert!(!svg.contains("Driven coordinates"), "an empty panel");
    assert!(!svg.contains("has no driver"), "an empty panel");
    // A kinematic model keeps it.
    let svg = plot(&dir, "models/slider_crank.kin", &["--steps", "20"])?;
    assert!(svg.contains("Driven coordinates"));
    Ok(())
}
