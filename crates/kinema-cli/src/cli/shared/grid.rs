//! The time grids of `kinema run` and `kinema sweep`: their defaults and
//! limits, the checks of `--t-end` and `--steps`, and the grid itself.

use kinema_adm::Analysis;

use crate::cli::Failure;
use crate::cli::output::time;

/// Default final time of a `.kin` run.
pub const DEFAULT_T_END: f64 = 1.0;
/// Default number of steps of a `.kin` run.
pub const DEFAULT_STEPS: usize = 100;
/// Most solve times a run may have (the grid is kept in memory: 9 bytes a
/// time).
pub const MAX_TIMES: usize = 10_000_000;
/// Most states kept for a plot; longer runs are thinned evenly (the last
/// state always kept).
pub const MAX_PLOT_STATES: usize = 5000;

/// The times to solve at, and which of them are outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Strictly increasing solve times, from 0.
    pub times: Vec<f64>,
    /// `output[k]`: whether `times[k]` is written out.
    pub output: Vec<bool>,
    /// What the grid is, for the summary.
    pub description: String,
}

impl Grid {
    /// `steps` equal steps from 0 to `t_end` (N + 1 times, all outputs; the
    /// last is exactly `t_end`).
    ///
    /// # Errors
    /// [`Failure::Input`] when the times do not increase: the step is below
    /// the resolution of the times (`t_end` 5e-324 in 10 steps).
    pub fn uniform(t_end: f64, steps: usize) -> Result<Grid, Failure> {
        // The runtime's grid, so that the Python package and sweeps step
        // through the same doubles.
        let times = kinema::uniform_times(t_end, steps);
        check_increasing(&times, &|| {
            format!("--t-end {t_end:e} with --steps {steps}")
        })?;
        Ok(Grid {
            output: vec![true; times.len()],
            description: format!("{steps} equal steps from t = 0 to {}", time(t_end)),
            times,
        })
    }

    /// simEngine2D's grid: outputs at the ACF's `outputSteps + 1` times,
    /// solves also every `stepSize` in between (warm starts, as the engine
    /// did).
    ///
    /// # Errors
    /// [`Failure::Input`] when the output times do not increase (`source`
    /// says where `tend` and `outputSteps` came from).
    pub fn simengine(analysis: &Analysis, source: &dyn Fn() -> String) -> Result<Grid, Failure> {
        let outputs = analysis.output_times();
        check_increasing(&outputs, source)?;
        let (times, output) = analysis.grid();
        let outputs_n = output.iter().filter(|&&o| o).count();
        Ok(Grid {
            description: format!(
                "{} outputs from t = 0 to {} (outputSteps {}), solved at {} times (stepSize {})",
                outputs_n,
                time(analysis.tend),
                analysis.output_steps,
                times.len(),
                time(analysis.step_size)
            ),
            times,
            output,
        })
    }
}

/// Checks `--t-end` and `--steps`; returns the number of steps.
pub fn check_grid_args(t_end: Option<f64>, steps: Option<i64>) -> Result<Option<usize>, Failure> {
    if let Some(t) = t_end
        && !(t.is_finite() && t > 0.0)
    {
        return Err(Failure::usage(format_args!(
            "--t-end must be a positive finite time (T > 0: the analysis runs from t = 0 to T), found {t}"
        )));
    }
    let Some(n) = steps else {
        return Ok(None);
    };
    if n < 1 {
        return Err(Failure::usage(format_args!(
            "--steps must be at least 1 (a whole number from 1 to {}), found {n}",
            MAX_TIMES - 1
        )));
    }
    match usize::try_from(n) {
        Ok(n) if n < MAX_TIMES => Ok(Some(n)),
        _ => Err(Failure::usage(format_args!(
            "--steps {n} is more than one run takes (at most {})",
            MAX_TIMES - 1
        ))),
    }
}

/// Refuses a grid whose times are not finite and strictly increasing (a
/// step below the resolution of the times: `--t-end 5e-324 --steps 10`);
/// `source` says where the values came from.
fn check_increasing(times: &[f64], source: &dyn Fn() -> String) -> Result<(), Failure> {
    let bad = times
        .windows(2)
        .position(|w| !(w[1] > w[0] && w[1].is_finite()));
    match bad {
        None if times.iter().all(|t| t.is_finite()) => Ok(()),
        _ => {
            let k = bad.unwrap_or(0);
            let (a, b) = (
                times.get(k).copied().unwrap_or(f64::NAN),
                times.get(k + 1).copied().unwrap_or(f64::NAN),
            );
            Err(Failure::usage(format_args!(
                "{}: the solve times do not increase (time {k} is {}, time {} is {}); \
                 the step is below the resolution of the times: use fewer steps or a later final time",
                source(),
                time(a),
                k + 1,
                time(b)
            )))
        }
    }
}

#[cfg(test)]
mod tests;
