//! The files of every kind of `kinema run` (kinematics, forward dynamics,
//! `--equilibrium`), created before the analysis starts so that a bad path
//! fails at once: the CSV — the columns `--columns` selects, then the
//! run's own (inverse dynamics, energies) — the figure (`--plot`) and the
//! animation page (`--animate`).

use kinema::lang::Derivation;

use super::columns::Selection;
use super::output::{CsvSink, Outputs};
use super::plan::OutputPlan;
use super::{Failure, animate, plot};

/// The open outputs of a run.
pub struct RunFiles {
    /// The CSV (`--out`), its header written.
    pub csv: CsvSink,
    /// The figure, when `--plot` asks for one.
    pub plot: Option<plot::Target>,
    /// The animation page, when `--animate` asks for one.
    pub page: Option<animate::Target>,
}

impl RunFiles {
    /// Creates the CSV with the header `t`, the selected quantities
    /// (values only under `--positions-only`) and then `extra`; then the
    /// figure and the page. Each is refused when it is the model, the
    /// analysis file or another output.
    ///
    /// # Errors
    /// A usage error for a bad `--columns` list or an output that cannot
    /// be created.
    pub fn create(
        plan: &OutputPlan,
        d: &Derivation,
        extra: &[String],
    ) -> Result<RunFiles, Failure> {
        let selection = Selection::of_option(plan.columns.as_deref(), d)?
            .with_positions_only(plan.positions_only);
        let mut header = selection.header(d);
        header.extend_from_slice(extra);
        let mut outputs = Outputs::new();
        outputs.input("the model", &plan.model);
        if let Some(acf) = &plan.acf {
            outputs.input("the analysis file", acf);
        }
        let csv = CsvSink::create(&mut outputs, plan.csv.clone(), &header, selection)?;
        let plot = plan
            .plot
            .as_deref()
            .map(|p| plot::Target::create(&mut outputs, p))
            .transpose()?;
        let page = plan
            .animate
            .as_deref()
            .map(|p| animate::Target::create(&mut outputs, p))
            .transpose()?;
        Ok(RunFiles { csv, plot, page })
    }

    /// Whether states must be kept for a figure or a page.
    pub fn keep_states(&self) -> bool {
        self.plot.is_some() || self.page.is_some()
    }
}
