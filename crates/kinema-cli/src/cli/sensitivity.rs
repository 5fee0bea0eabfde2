//! `kinema run --sensitivity P1,P2`: the parameter sensitivities' columns
//! after the others (docs/src/cli.md, "Sensitivities"): for each param in
//! the order given, `d(COLUMN)/d(PARAM)` for every coordinate and result
//! column the run writes, then (with inertia) every inverse-dynamics
//! column, in the order they are written.

use kinema::dynamics_sensitivity::DynamicsSensitivity;
use kinema::lang::Derivation;
use kinema::sensitivity::Sensitivity;
use kinema::{Auto, Model, Solver, TapeSystem};

use super::Failure;
use super::columns::Selection;
use super::plan::OutputPlan;

/// The sensitivity columns of a kinematic run and their row's values.
pub struct SensitivityColumns {
    sensitivity: Sensitivity,
    /// With inverse dynamics' columns: their sensitivities.
    dynamics: Option<DynamicsSensitivity>,
    selection: Selection,
    names: Vec<String>,
    values: Vec<f64>,
}

impl SensitivityColumns {
    /// The columns for the run's selection (`--columns`) of `model`, and
    /// for `dynamics`, the run's inverse-dynamics columns (if it writes
    /// them).
    ///
    /// # Errors
    /// A bad `--columns` list (a usage error, as the CSV's own); the
    /// dynamics' derivatives too large (a usage error, as
    /// `--sensitivity`'s own).
    pub fn new(
        sensitivity: Sensitivity,
        outputs: &OutputPlan,
        model: &Model,
        dynamics: Option<&[String]>,
    ) -> Result<SensitivityColumns, Failure> {
        let d: &Derivation = model.derivation();
        let selection = Selection::of_option(outputs.columns.as_deref(), d)?
            .with_positions_only(outputs.positions_only);
        let mut header = selection.header(d);
        let dynamics = match dynamics {
            Some(columns) => {
                let ds = model
                    .dynamics_sensitivity(&sensitivity)
                    .map_err(|e| Failure::usage(format_args!("--sensitivity: {e}")))?;
                // Built from the same model as the columns: the same count.
                if let Some(ds) = &ds
                    && ds.width() == columns.len()
                {
                    header.extend_from_slice(columns);
                } else {
                    // Not expected: both come from the model's derivation.
                    return Err(Failure::analysis(format_args!(
                        "--sensitivity: the sensitivities of the model's {} inverse-dynamics \
                         columns could not be set up",
                        columns.len()
                    )));
                }
                ds
            }
            None => None,
        };
        let names: Vec<String> = sensitivity
            .params()
            .iter()
            .flat_map(|p| header.iter().map(move |c| format!("d({c})/d({p})")))
            .collect();
        Ok(SensitivityColumns {
            sensitivity,
            dynamics,
            selection,
            values: Vec::with_capacity(names.len()),
            names,
        })
    }

    /// The columns' names, in the order of [`Self::compute`]'s values.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The row's values at the solver's state (after a successful step),
    /// solved with the step's factorization. Does not allocate.
    ///
    /// # Errors
    /// As [`Sensitivity::compute`]: Φ_q singular where it had to be
    /// factored again (a row flagged near singular); as
    /// [`DynamicsSensitivity::compute`] (a non-finite sensitivity, named).
    pub fn compute(&mut self, solver: &mut Solver<TapeSystem, Auto>) -> Result<(), kinema::Error> {
        self.sensitivity.compute(solver)?;
        if let Some(ds) = &mut self.dynamics {
            ds.compute(solver, &self.sensitivity)?;
        }
        let (s, sel) = (&self.sensitivity, &self.selection);
        self.values.clear();
        for k in 0..s.params().len() {
            let orders = sel.orders();
            for (quantities, picked) in [
                (s.coordinates(k), &sel.coordinates),
                (s.outputs(k), &sel.outputs),
            ] {
                for values in &quantities[..orders] {
                    self.values.extend(
                        picked
                            .iter()
                            .map(|&j| values.get(j).copied().unwrap_or(f64::NAN)),
                    );
                }
            }
            if let Some(ds) = &self.dynamics {
                self.values.extend_from_slice(ds.columns(k));
            }
        }
        Ok(())
    }

    /// The values of the last [`Self::compute`].
    pub fn values(&self) -> &[f64] {
        &self.values
    }
}
