//! `kinema sweep`'s variant loop for Python (as crates/kinema-cli's
//! `sweep`). Runs with the GIL released.

use kinema::{System, TapeSystem};

use super::run::RunOptions;

/// The result of a sweep (the GIL released while it is made).
pub(crate) struct SweepOutput {
    pub(crate) values: Vec<f64>,
    pub(crate) rows: usize,
    /// (variant index from 0, error message).
    pub(crate) failures: Vec<(usize, String)>,
    /// (variant index from 0, what was flagged).
    pub(crate) flagged: Vec<(usize, String)>,
}

/// `kinema sweep`'s variant loop over rows `rows` (each the values of the
/// swept parameters, `indices` into the model's parameters); variant
/// numbers in the table start at `first + 1`.
pub(crate) fn run_sweep(
    system: TapeSystem,
    indices: Vec<usize>,
    table: &[Vec<f64>],
    first: usize,
    times: &[f64],
    options: RunOptions,
    threads: Option<usize>,
) -> SweepOutput {
    let width = indices.len();
    let set = move |s: &mut TapeSystem, row: &[f64]| {
        for (&i, &v) in indices.iter().zip(row) {
            // `indices` are positions of the model's own parameters,
            // resolved from their names before the sweep starts.
            let _ = s.set_param_at(i, v);
        }
    };
    let mut sweep = kinema::sweep::Sweep::new(system, set)
        .with_row_width(width)
        .with_options(options.solver_options());
    if let Some(n) = threads {
        sweep = sweep.with_threads(n);
    }
    let orders = if options.positions_only { 1 } else { 3 };
    let done = sweep.map(table, |k, solver| {
        let row = &table[k];
        let mut values: Vec<f64> = Vec::new();
        let m = kinema::Outputs::output_len(solver.system());
        let mut scratch = System::scratch(solver.system());
        let mut results = [vec![0.0; m], vec![0.0; m], vec![0.0; m]];
        let mut notes: Vec<String> = Vec::new();
        let (mut near, mut kinks) = (0usize, 0usize);
        let mut n = 0;
        let mut failure = None;
        for &t in times {
            if let Err(e) = solver.step(t) {
                failure = Some(e.to_string());
                break;
            }
            let Some(state) = solver.state() else { break };
            kinema::Outputs::outputs_of(solver.system(), &mut scratch, state, &mut results);
            near += usize::from(state.near_singular());
            kinks += usize::from(state.kink().is_some());
            values.push((first + k + 1) as f64);
            values.extend_from_slice(row);
            values.push(state.t());
            let states = [state.q(), state.qd(), state.qdd()];
            values.extend(states[..orders].iter().flat_map(|v| v.iter()));
            values.extend(results[..orders].iter().flatten());
            n += 1;
        }
        let events = if failure.is_some() {
            solver.events()
        } else {
            solver.close_events()
        };
        for e in events {
            notes.push(format!("{} at t = {}", e.kind, e.t));
        }
        if near > 0 {
            notes.push(format!(
                "{near} rows within the threshold of a singular configuration (q̇ and q̈ are the \
                 branch's limits, not solves)"
            ));
        }
        if kinks > 0 {
            notes.push(format!(
                "{kinks} rows at a kink of an equation (q̇ and q̈ are not determined)"
            ));
        }
        Ok((values, n, failure, notes))
    });
    let mut out = SweepOutput {
        values: Vec::new(),
        rows: 0,
        failures: Vec::new(),
        flagged: Vec::new(),
    };
    for (k, result) in done.into_iter().enumerate() {
        match result {
            Ok((values, n, failure, notes)) => {
                out.values.extend_from_slice(&values);
                out.rows += n;
                if let Some(f) = failure {
                    out.failures.push((first + k, f));
                }
                if !notes.is_empty() {
                    out.flagged.push((first + k, notes.join("; ")));
                }
            }
            Err(e) => out.failures.push((first + k, e.to_string())),
        }
    }
    out
}
