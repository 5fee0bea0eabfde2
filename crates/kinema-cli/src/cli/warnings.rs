//! The `warning:` lines a run prints after its rows — singular
//! configurations met, kinks, equations their own arithmetic does not
//! determine — shared by kinematic and dynamic runs and by `check`.

use kinema::{SingularEvent, TapeSystem};

use super::output::{rows_at, time};

/// Most singular configurations warned about one by one; a run that meets
/// more (a mechanism that lingers near singular, one event per step) gets
/// the first ones and a count, so that stderr stays bounded.
const MAX_EVENT_WARNINGS: usize = 20;

/// One `warning:` line per singular configuration met (at most
/// [`MAX_EVENT_WARNINGS`], then a count of the rest), and one for the
/// output rows that hold branch limits instead of solves.
pub(super) fn print_singular_warnings(events: &[SingularEvent], flagged: &[f64]) {
    for e in events.iter().take(MAX_EVENT_WARNINGS) {
        eprintln!("warning: {e}");
    }
    if let Some(rest) = events.get(MAX_EVENT_WARNINGS..).filter(|r| !r.is_empty()) {
        let last = rest.last().map_or(0.0, |e| e.t);
        eprintln!(
            "warning: … and {} more singular configurations, up to t = {} (not listed; the \
             motion lingers near singular: check the model's dimensions)",
            rest.len(),
            time(last)
        );
    }
    if let (Some(first), Some(last)) = (flagged.first(), flagged.last()) {
        let s = if flagged.len() == 1 { "" } else { "s" };
        let at = if flagged.len() == 1 {
            format!("t = {}", time(*first))
        } else {
            format!("t = {} … {}", time(*first), time(*last))
        };
        let (lie, their) = if flagged.len() == 1 {
            ("lies", "its")
        } else {
            ("lie", "their")
        };
        eprintln!(
            "warning: {} row{s} at {at} {lie} within the threshold of a singular configuration: \
             {their} q̇ and q̈ are the limits along the branch, not solves",
            flagged.len()
        );
    }
}

/// One `warning:` line for the output rows with an equation that its own
/// arithmetic does not determine (named by the worst row).
pub(super) fn print_imprecision_warning(
    system: &TapeSystem,
    imprecise: &[(f64, kinema::Imprecision)],
) {
    let times: Vec<f64> = imprecise.iter().map(|r| r.0).collect();
    let (Some(at), Some((_, worst))) = (
        rows_at(&times),
        imprecise
            .iter()
            .max_by(|a, b| a.1.shift.total_cmp(&b.1.shift)),
    ) else {
        return;
    };
    let their = if times.len() == 1 { "its" } else { "their" };
    eprintln!(
        "warning: {at}: {}; {their} q, q̇ and q̈ are the rounding errors' as much as the model's",
        imprecision_clause(system, worst)
    );
}

/// What a [`kinema::Imprecision`] is, in words.
pub(super) fn imprecision_clause(system: &TapeSystem, i: &kinema::Imprecision) -> String {
    format!(
        "equation `{}` is not determined by its own arithmetic: its rounding error, up to \
         {:.1e}, moves the coordinates by up to {:.1e} against their scale {:.1e} (an argument \
         beyond f64's precision, as in sin(1e30 * t), or large numbers that cancel)",
        kinema::System::equation_name(system, i.equation),
        i.error,
        i.shift,
        i.scale,
    )
}

/// "equation `NAME`" for the equation of a kink ("an equation" when the
/// system could not tell which).
pub(super) fn equation_of(system: &TapeSystem, kink: kinema::Kink) -> String {
    kink.equation.map_or_else(
        || "an equation".to_owned(),
        |e| format!("equation `{}`", kinema::System::equation_name(system, e)),
    )
}

/// `warning: N rows at t = a … b: SUBJECT has FUNCTION where it is not
/// differentiable (…): their CONSEQUENCE`.
pub(super) fn print_kink_warning(times: &[f64], subject: &str, function: &str, consequence: &str) {
    let Some(rows) = rows_at(times) else {
        return;
    };
    let their = if times.len() == 1 { "its" } else { "their" };
    let (function, argument) = kink_function(function);
    eprintln!(
        "warning: {rows}: {subject} has {function} where it is not differentiable \
         ({argument} within roundoff): {their} {consequence}"
    );
}

/// A kink's function ([`kinema::Kink::function`]) in words, and where it
/// is not differentiable.
pub(super) fn kink_function(function: &str) -> (&str, &'static str) {
    match function {
        "atan2" => ("atan2", "its arguments are (0, 0)"),
        "acos" | "asin" => (function, "its argument is ±1"),
        "smoothstep" => ("a cubic step", "its argument is at an end of the step"),
        "power" => ("a fractional power", "its base is 0"),
        "sqrt" => ("a square root or norm", "its argument is 0"),
        other => (other, "its argument is 0"),
    }
}
