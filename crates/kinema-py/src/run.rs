//! `kinema run`'s kinematic loop for Python (as crates/kinema-cli's
//! `run`): the grid, the rows (coordinates, outputs, inverse dynamics),
//! singular configurations as data. Runs with the GIL released.

use kinema::dynamics::DynamicsColumns;
use kinema::{Auto, Options, SingularKind, Solver, System, TapeSystem};
use pyo3::prelude::*;

use super::MAX_TIMES;
use super::errors::value_error;

/// Refuses times that are not finite and strictly increasing.
pub(crate) fn check_times(times: &[f64]) -> PyResult<()> {
    if times.is_empty() {
        return Err(value_error("times is empty: give at least one time"));
    }
    if times.len() > MAX_TIMES {
        return Err(value_error(format!(
            "{} times is more than one run takes (at most {MAX_TIMES})",
            times.len()
        )));
    }
    if let Some(k) = times.iter().position(|t| !t.is_finite()) {
        return Err(value_error(format!(
            "time {k} is {}: every time must be finite",
            times[k]
        )));
    }
    if let Some(k) = times.windows(2).position(|w| w[1] <= w[0]) {
        return Err(value_error(format!(
            "the times must increase strictly: time {k} is {:e}, time {} is {:e} (a step below \
             the resolution of the times: use fewer steps or a later final time)",
            times[k],
            k + 1,
            times[k + 1]
        )));
    }
    Ok(())
}

/// A singular configuration met, as data.
pub(crate) struct Event {
    pub(crate) kind: &'static str,
    pub(crate) t: f64,
    pub(crate) equations: Vec<String>,
    pub(crate) message: String,
}

pub(crate) fn event_of(e: &kinema::SingularEvent) -> Event {
    Event {
        kind: match e.kind {
            SingularKind::Bifurcation => "bifurcation",
            SingularKind::Toggle => "toggle",
            SingularKind::LockUp => "lock-up",
            SingularKind::AtEnd => "at-end",
            _ => "other",
        },
        t: e.t,
        equations: e.dependency.equations.clone(),
        message: e.to_string(),
    }
}

/// What a kinematic run produced (the GIL released while it is made).
pub(crate) struct RunOutput {
    pub(crate) columns: Vec<String>,
    pub(crate) values: Vec<f64>,
    pub(crate) rows: usize,
    pub(crate) events: Vec<Event>,
    /// Output times within the threshold of a singular configuration.
    pub(crate) flagged: Vec<f64>,
    /// Output times at a kink of an equation, and which function.
    pub(crate) kinks: Vec<(f64, String)>,
    /// Output times at a kink of a result column: (t, column, function).
    pub(crate) output_kinks: Vec<(f64, String, String)>,
    /// Output times with an equation its own arithmetic does not
    /// determine: (t, equation, message).
    pub(crate) imprecise: Vec<(f64, String, String)>,
    /// The failure that stopped the run, if any.
    pub(crate) error: Option<String>,
    pub(crate) backend: &'static str,
}

/// Run options shared by `run` and `sweep`.
#[derive(Clone, Copy)]
pub(crate) struct RunOptions {
    pub(crate) positions_only: bool,
    pub(crate) stop_at_singular: bool,
}

impl RunOptions {
    pub(crate) fn solver_options(self) -> Options {
        Options::default()
            .with_stop_at_singular(self.stop_at_singular)
            .with_positions_only(self.positions_only)
    }
}

/// `kinema run`'s kinematic loop: steps through `times`, writes a row at
/// each output time.
pub(crate) fn run_kinematics(
    system: TapeSystem,
    selection: &kinema::columns::Selection,
    header: Vec<String>,
    (times, outputs): (&[f64], &[bool]),
    options: RunOptions,
    adm: bool,
    (rows_n, nc): (usize, usize),
) -> Result<RunOutput, String> {
    let mut dynamics =
        DynamicsColumns::new(&system, rows_n, adm).filter(|_| !options.positions_only);
    let mut columns = vec!["t".to_owned()];
    columns.extend(header);
    if let Some(d) = &dynamics {
        columns.extend(d.names().iter().cloned());
    }
    let mut solver = Solver::<TapeSystem, Auto>::with_options(system, options.solver_options())
        .map_err(|e| format!("cannot set up the solver: {e}"))?;
    let m = kinema::Outputs::output_len(solver.system());
    let mut results = [vec![0.0; m], vec![0.0; m], vec![0.0; m]];
    let mut scratch = System::scratch(solver.system());
    let n_out = outputs.iter().filter(|&&o| o).count();
    let mut values: Vec<f64> = Vec::with_capacity(n_out * columns.len());
    // Whether the selection takes every coordinate and every result in
    // order (then each block is one copy).
    let whole = (
        is_whole(&selection.coordinates, nc),
        is_whole(&selection.outputs, m),
    );
    let mut out = RunOutput {
        columns,
        values: Vec::new(),
        rows: 0,
        events: Vec::new(),
        flagged: Vec::new(),
        kinks: Vec::new(),
        output_kinks: Vec::new(),
        imprecise: Vec::new(),
        error: None,
        backend: "tape",
    };
    let orders = selection.orders();
    let mut checked_all = false;
    for (&t, &is_output) in times.iter().zip(outputs) {
        if let Err(e) = solver.step(t) {
            out.events = solver
                .events()
                .iter()
                .filter(|e| e.kind != SingularKind::LockUp)
                .map(event_of)
                .collect();
            out.error = Some(e.to_string());
            break;
        }
        if !is_output {
            continue;
        }
        let Some(state) = solver.state() else {
            continue;
        };
        let size = solver.model_size();
        if state.near_singular() {
            out.flagged.push(state.t());
        }
        if let Some(kink) = state.kink() {
            let eq = kink.equation.map_or_else(
                || "an equation".to_owned(),
                |e| format!("equation `{}`", solver.system().equation_name(e)),
            );
            out.kinks
                .push((state.t(), format!("{} in {eq}", kink.function)));
        }
        let scope = if std::mem::replace(&mut checked_all, true) {
            kinema::PrecisionScope::Timed
        } else {
            kinema::PrecisionScope::All
        };
        if let Some(i) = solver
            .system()
            .imprecision(&mut scratch, state, size, scope)
        {
            let name = solver.system().equation_name(i.equation).to_owned();
            let message = format!(
                "equation `{name}` is not determined by its own arithmetic: its rounding error, \
                 up to {:.1e}, moves the coordinates by up to {:.1e} against their scale {:.1e}",
                i.error, i.shift, i.scale
            );
            out.imprecise.push((state.t(), name, message));
        }
        let extra: &[f64] = match &mut dynamics {
            Some(d) => match d.compute(&mut solver) {
                Ok(v) => v,
                Err(e) => {
                    out.error = Some(format!("inverse dynamics: {e}"));
                    break;
                }
            },
            None => &[],
        };
        let Some(state) = solver.state() else {
            continue;
        };
        if !selection.outputs.is_empty() {
            kinema::Outputs::outputs_of(solver.system(), &mut scratch, state, &mut results);
            if !options.positions_only
                && let Some(kink) =
                    solver
                        .system()
                        .output_kink(&mut scratch, state, solver.model_size())
            {
                let name = kinema::Outputs::output_name(solver.system(), kink.column).to_owned();
                out.output_kinks
                    .push((state.t(), name, kink.function.to_owned()));
            }
        }
        // The row straight into the table (one copy per block when the
        // selection is whole, as by default).
        let start = values.len();
        values.push(state.t());
        let states = [state.q(), state.qd(), state.qdd()];
        for v in &states[..orders] {
            push_selected(&mut values, v, &selection.coordinates, whole.0);
        }
        for v in &results[..orders] {
            push_selected(&mut values, v, &selection.outputs, whole.1);
        }
        values.extend_from_slice(extra);
        // Never a silent NaN or ∞ (as the CLI's CSV).
        if let Some(j) = first_non_finite(&values[start..]) {
            out.error = Some(format!(
                "at t = {t}: column `{}` is {} (it overflowed)",
                out.columns[j],
                values[start + j]
            ));
            values.truncate(start);
            break;
        }
        out.rows += 1;
    }
    if out.error.is_none() {
        out.events = solver.close_events().iter().map(event_of).collect();
    }
    out.backend = backend_name(solver.system());
    out.values = values;
    Ok(out)
}

/// The back end a system runs on.
pub(crate) fn backend_name(system: &TapeSystem) -> &'static str {
    match system.backend() {
        kinema::Backend::Jit => "jit",
        kinema::Backend::Tape => "tape",
    }
}

/// Whether `picked` is 0, 1, …, `len` − 1: a whole block.
pub(crate) fn is_whole(picked: &[usize], len: usize) -> bool {
    picked.len() == len && picked.iter().enumerate().all(|(i, &k)| i == k)
}

/// Appends the entries `picked` of `source` to `row` (NaN for one out of
/// range), or all of `source` by one copy when `whole`.
pub(crate) fn push_selected(row: &mut Vec<f64>, source: &[f64], picked: &[usize], whole: bool) {
    if whole {
        row.extend_from_slice(source);
    } else {
        row.extend(
            picked
                .iter()
                .map(|&k| source.get(k).copied().unwrap_or(f64::NAN)),
        );
    }
}

/// The first entry of `row` that is NaN or ±∞: a check of the whole row
/// first that needs no branch per entry (it vectorizes), the search only
/// when it fails.
pub(crate) fn first_non_finite(row: &[f64]) -> Option<usize> {
    if row.iter().fold(false, |bad, v| bad | !v.is_finite()) {
        row.iter().position(|v| !v.is_finite())
    } else {
        None
    }
}
