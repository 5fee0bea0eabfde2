//! A fit's request checked against its model: the varied params' indices
//! and bounds, the target and objective columns' places among the results,
//! the unknowns and residuals — every name resolved once, every error said
//! before a design is run.

use kinema_tape::Model;

use crate::bounds::Map;
use crate::{FitError, Measure, Spec, Targets};

/// Where a result column's value is: a coordinate of q, or a result column
/// of [`Outputs`](kinema_runtime::Outputs) (named points, outputs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Column {
    Coordinate(usize),
    Output(usize),
}

/// A varied param.
#[derive(Clone, Debug)]
pub(crate) struct Varied {
    pub(crate) name: String,
    /// Its index among the model's params (declaration order).
    pub(crate) index: usize,
    /// The model's value: the first start.
    pub(crate) value: f64,
    pub(crate) map: Map,
    /// The width the starts spread over and near-duplicates are measured
    /// in: the bounds' when both are given, else the value's size.
    pub(crate) scale: f64,
    /// Where the starts are drawn from.
    pub(crate) range: [f64; 2],
}

/// An objective beside the targets.
#[derive(Clone, Debug)]
pub(crate) struct PlannedObjective {
    pub(crate) measure: Measure,
    pub(crate) name: String,
    pub(crate) column: Column,
    pub(crate) weight: f64,
}

/// The most params one fit varies (the smooth peak's gradient is a fixed
/// array of this length).
pub(crate) const MAX_VARIED: usize = 64;

/// The most grid steps one run of a design takes (prescribed times may
/// span many cycles): 2 million, about 50 MB of schedule.
pub(crate) const MAX_RUN_STEPS: usize = 2_000_000;

/// Calls `push` with the uniform grid over `span` in steps of `h` (the
/// times `span[0]`, `span[0] + h`, … below `span[1]`, accumulated), then
/// with `span[1]`.
///
/// # Errors
/// Why, where the grid would hold more than [`MAX_RUN_STEPS`] steps or a
/// step would not advance t (below its resolution): nothing is pushed
/// beyond that bound, so no run spins or exhausts memory on it.
pub(crate) fn grid(span: [f64; 2], h: f64, mut push: impl FnMut(f64)) -> Result<(), String> {
    let steps = ((span[1] - span[0]) / h).ceil();
    // NaN-safe: a comparison with NaN is false.
    if !(h > 0.0 && steps <= MAX_RUN_STEPS as f64) {
        return Err(format!(
            "a run from t = {} to t = {} in steps of {} would take {} of them (at most \
             {MAX_RUN_STEPS})",
            Short(span[0]),
            Short(span[1]),
            Short(h),
            Short(steps)
        ));
    }
    let mut t = span[0];
    while t < span[1] {
        push(t);
        let next = t + h;
        if next <= t {
            return Err(format!(
                "steps of {} do not advance t beyond {}: they are below its resolution",
                Short(h),
                Short(t)
            ));
        }
        t = next;
    }
    push(span[1]);
    Ok(())
}

/// A number in a message: plain where that is short, else in exponent
/// form (a subnormal cycle would print 300 zeros).
struct Short(f64);

impl std::fmt::Display for Short {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || (1e-4..1e9).contains(&a) || !a.is_finite() {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// A checked fit.
#[derive(Clone, Debug)]
pub(crate) struct Plan {
    pub(crate) vary: Vec<Varied>,
    pub(crate) targets: Targets,
    pub(crate) columns: Vec<Column>,
    /// The cycle [0, t_end]: where unknown times lie, the objectives are
    /// sampled and `--full-turn` is checked.
    pub(crate) t_end: f64,
    pub(crate) steps: usize,
    pub(crate) objectives: Vec<PlannedObjective>,
    /// The index of the `--full-turn` body's angle in q.
    pub(crate) full_turn: Option<(String, usize)>,
    /// The varied params' sensitivities, compiled once (each worker
    /// clones them).
    pub(crate) sensitivity: kinema_tape::sensitivity::Sensitivity,
}

impl Plan {
    pub(crate) fn new(model: &Model, spec: &Spec) -> Result<Plan, FitError> {
        let d = model.derivation();
        if spec.vary.is_empty() {
            return Err(FitError::Usage(
                "nothing to fit: name the params to vary (e.g. --vary l1,l2)".to_owned(),
            ));
        }
        if spec.vary.len() > MAX_VARIED {
            return Err(FitError::Usage(format!(
                "{} params to vary: a fit varies at most {MAX_VARIED}",
                spec.vary.len()
            )));
        }
        // The names, through the sensitivities' own check (what a name is
        // when it is not a param, the model's params); the compiled
        // sensitivities are kept for the workers to clone.
        let names: Vec<&str> = spec.vary.iter().map(String::as_str).collect();
        let sensitivity = model
            .sensitivity(&names)
            .map_err(|e| FitError::Usage(format!("--vary: {e}")))?;
        for b in &spec.bounds {
            if !spec.vary.contains(&b.name) {
                return Err(FitError::Usage(format!(
                    "--bounds names `{}`, which is not varied (--vary {})",
                    b.name,
                    spec.vary.join(",")
                )));
            }
        }
        let mut vary = Vec::with_capacity(spec.vary.len());
        for name in &spec.vary {
            let index = d
                .params
                .iter()
                .position(|p| &p.name == name)
                .ok_or_else(|| FitError::Usage(format!("`{name}` is not a param")))?;
            let value = d.params[index].value;
            let mut lo = None;
            let mut hi = None;
            for b in spec.bounds.iter().filter(|b| &b.name == name) {
                lo = b.lo.or(lo);
                hi = b.hi.or(hi);
            }
            if let (Some(l), Some(h)) = (lo, hi)
                && l >= h
            {
                return Err(FitError::Usage(format!(
                    "the bounds of {name} are empty: {l} is not below {h}"
                )));
            }
            let map = Map::new(lo, hi);
            if !map.contains(value) {
                return Err(FitError::Usage(format!(
                    "the model's {name} = {value} is outside its bounds {}: the first start is the model's design (edit the model's value or the bounds)",
                    crate::Bound {
                        name: name.clone(),
                        lo,
                        hi
                    }
                )));
            }
            let size = if value == 0.0 { 1.0 } else { value.abs() };
            let range = match (lo, hi) {
                (Some(l), Some(h)) => [l, h],
                (Some(l), None) => [l, l.max(value) + size],
                (None, Some(h)) => [h.min(value) - size, h],
                (None, None) => [value - 0.5 * size, value + 0.5 * size],
            };
            vary.push(Varied {
                name: name.clone(),
                index,
                value,
                map,
                scale: range[1] - range[0],
                range,
            });
        }
        let resolve = |name: &str, what: &str| -> Result<Column, FitError> {
            if let Some(i) = model.coordinate_index(name) {
                return Ok(Column::Coordinate(i));
            }
            if let Some(i) = model.output_index(name) {
                return Ok(Column::Output(i));
            }
            let base = name
                .strip_suffix("_ddot")
                .or_else(|| name.strip_suffix("_dot"));
            let hint = match base {
                Some(b)
                    if model.coordinate_index(b).is_some() || model.output_index(b).is_some() =>
                {
                    format!(
                        " (a rate of `{b}`: {what} are positions — coordinates, points, outputs)"
                    )
                }
                _ => {
                    let mut known: Vec<&str> =
                        d.coordinates.iter().map(|c| c.name.as_str()).collect();
                    known.extend(d.outputs.iter().map(|o| o.name.as_str()));
                    let shown = known.len().min(12);
                    format!(
                        "; the model's result columns are {}{}",
                        known[..shown].join(", "),
                        if known.len() > shown { ", …" } else { "" }
                    )
                }
            };
            Err(FitError::Usage(format!(
                "`{name}` is not a result column of the model{hint}"
            )))
        };
        let mut columns = Vec::with_capacity(spec.targets.columns.len());
        for (c, name) in spec.targets.columns.iter().enumerate() {
            let column = resolve(name, "targets").map_err(|e| match e {
                FitError::Usage(m) => FitError::Usage(format!(
                    "{}:{}:{}: {m}",
                    spec.targets.name, spec.targets.header_line, spec.targets.header_columns[c]
                )),
                other => other,
            })?;
            columns.push(column);
        }
        let t_end = match (spec.t_end, spec.targets.times()) {
            (Some(t), _) if !(t.is_finite() && t > 0.0) => {
                return Err(FitError::Usage(format!(
                    "--t-end {t}: the cycle's length must be a positive number"
                )));
            }
            (Some(t), _) => t,
            (None, Some(ts)) => ts.last().copied().unwrap_or(0.0).max(0.0),
            (None, None) => {
                return Err(FitError::Usage(
                    "the targets have no `t` column, so each row's time is fitted within one cycle: give the cycle's length with --t-end"
                        .to_owned(),
                ));
            }
        };
        if spec.targets.times().is_some() && t_end <= 0.0 {
            return Err(FitError::Usage(
                "the prescribed times end at or before 0: give the cycle's length with --t-end"
                    .to_owned(),
            ));
        }
        if !(4..=100_000).contains(&spec.steps) {
            return Err(FitError::Usage(format!(
                "{} steps per cycle: between 4 and 100000",
                spec.steps
            )));
        }
        // The longest run a fit makes: over the cycle and the prescribed
        // times (unknown ones stay within [−t_end, 3 t_end]); its grid
        // must advance t and stay within bounds.
        let span = match spec.targets.times() {
            Some(ts) => [
                ts.first().copied().unwrap_or(0.0).min(0.0),
                ts.last().copied().unwrap_or(0.0).max(t_end),
            ],
            None => [-t_end, 3.0 * t_end],
        };
        let h = t_end / spec.steps as f64;
        if let Err(why) = grid(span, h, |_| ()) {
            return Err(FitError::Usage(format!(
                "a cycle of {} (--t-end, or the last prescribed time) in {} steps (--steps): \
                 {why}; give a longer cycle or fewer steps",
                Short(t_end),
                spec.steps
            )));
        }
        let mut objectives = Vec::with_capacity(spec.objectives.len());
        for o in &spec.objectives {
            if !(o.weight.is_finite() && o.weight > 0.0) {
                return Err(FitError::Usage(format!(
                    "the objective {o}: its weight must be a positive number"
                )));
            }
            objectives.push(PlannedObjective {
                measure: o.measure,
                name: o.column.clone(),
                column: resolve(&o.column, "objectives")?,
                weight: o.weight,
            });
        }
        let full_turn = match &spec.full_turn {
            None => None,
            Some(body) => {
                let phi = format!("{body}.phi");
                let i = model.coordinate_index(&phi).ok_or_else(|| {
                    FitError::Usage(format!(
                        "--full-turn {body}: the model has no body `{body}` (no coordinate {phi})"
                    ))
                })?;
                Some((body.clone(), i))
            }
        };
        let plan = Plan {
            vary,
            targets: spec.targets.clone(),
            columns,
            t_end,
            steps: spec.steps,
            objectives,
            full_turn,
            sensitivity,
        };
        Ok(plan)
    }

    /// Whether the targets' times are unknowns of the fit.
    pub(crate) fn times_unknown(&self) -> bool {
        self.targets.times.is_none()
    }

    /// Params, then the unknown times.
    pub(crate) fn unknowns(&self) -> usize {
        self.vary.len()
            + if self.times_unknown() {
                self.targets.rows()
            } else {
                0
            }
    }

    pub(crate) fn target_residuals(&self) -> usize {
        self.targets.rows() * self.columns.len()
    }

    /// Targets, then each RMS objective's samples, then each peak's one.
    pub(crate) fn residuals(&self) -> usize {
        self.target_residuals()
            + self
                .objectives
                .iter()
                .map(|o| match o.measure {
                    Measure::Rms => self.objective_samples(),
                    Measure::Peak => 1,
                })
                .sum::<usize>()
    }

    /// The samples of the cycle each objective is measured on (none
    /// without objectives).
    pub(crate) fn objective_samples(&self) -> usize {
        if self.objectives.is_empty() {
            0
        } else {
            self.steps
        }
    }

    /// Sample `n`'s time: the cycle's uniform grid without its end.
    pub(crate) fn sample_time(&self, n: usize) -> f64 {
        self.t_end * n as f64 / self.steps as f64
    }

    pub(crate) fn cycle_length(&self) -> f64 {
        self.t_end
    }

    /// Row `i`, column `c`'s target value.
    pub(crate) fn target(&self, i: usize, c: usize) -> f64 {
        self.targets.values[i * self.columns.len() + c]
    }

    /// The span a design is run over while it is fitted: from the cycle's
    /// start (or the first target, if earlier) to the last target or, with
    /// objectives or `--full-turn`, the cycle's end.
    pub(crate) fn fit_span(&self, times: &[f64]) -> [f64; 2] {
        let first = times.iter().copied().fold(f64::INFINITY, f64::min);
        let last = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let lo = first.min(0.0);
        let hi = if self.objectives.is_empty() && self.full_turn.is_none() {
            last
        } else {
            last.max(self.t_end)
        };
        [lo, hi.max(lo)]
    }

    /// Where a fitted design may meet no singular configuration: between
    /// its first and last targets, or with `--full-turn` anywhere in its
    /// run (`span`).
    pub(crate) fn singular_window(&self, times: &[f64], span: [f64; 2]) -> [f64; 2] {
        if self.full_turn.is_some() {
            return span;
        }
        let first = times.iter().copied().fold(f64::INFINITY, f64::min);
        let last = times.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        [first, last]
    }

    /// The span a design's defects are checked over: the fit's and the
    /// whole cycle.
    pub(crate) fn check_span(&self, times: &[f64]) -> [f64; 2] {
        let [lo, hi] = self.fit_span(times);
        [lo, hi.max(self.t_end)]
    }
}

#[cfg(test)]
mod tests {
    use super::{MAX_RUN_STEPS, grid};

    fn times(span: [f64; 2], h: f64) -> Result<Vec<f64>, String> {
        let mut out = Vec::new();
        grid(span, h, |t| out.push(t)).map(|()| out)
    }

    #[test]
    fn a_grid_is_the_accumulated_steps_then_the_end() {
        let got = times([0.0, 1.0], 0.3).unwrap_or_default();
        assert_eq!(got, vec![0.0, 0.3, 0.6, 0.3 + 0.3 + 0.3, 1.0]);
        assert_eq!(times([2.0, 2.0], 0.5), Ok(vec![2.0]));
    }

    #[test]
    fn a_grid_that_cannot_be_run_is_refused_with_nothing_spun() {
        // A step of 0 (a subnormal cycle over 360 steps), NaN, too many
        // steps, and steps below the resolution of t near 1e17.
        for (span, h, says) in [
            ([0.0, 1e-323], 1e-323 / 360.0, "at most"),
            ([0.0, 1.0], f64::NAN, "at most"),
            ([0.0, 1.0], 1.0 / (2.0 * MAX_RUN_STEPS as f64), "at most"),
            ([1e17, 1e17 + 64.0], 4.0, "below its resolution"),
        ] {
            let got = times(span, h);
            assert!(
                matches!(&got, Err(why) if why.contains(says)),
                "{span:?} by {h:e}: {got:?}"
            );
        }
    }
}
