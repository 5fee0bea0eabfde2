//! Whether a model and an analysis can be run as kinematics, and what a
//! kinematic run ignores.
//!
//! Kinematic analysis needs a Kinematics analysis and NDOF = n − m = 0, with
//! n = 3·(number of bodies) coordinates and m constraint equations (Absolute*
//! elements give one row, joints and rack-pinions two). [`check_kinematic`]
//! refuses anything else with the counts, computed from the ADM itself.

use std::fmt;

use crate::acf::{Analysis, Simulation};
use crate::adm::Model;

/// The sizes of a model's kinematic problem.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Counts {
    /// Number of bodies.
    pub bodies: usize,
    /// Number of coordinates n = 3·bodies.
    pub n: usize,
    /// Number of constraint equations m (rows of Φ), drivers included.
    pub m: usize,
    /// Of the m equations, how many come from drivers (time-dependent
    /// Absolute* elements).
    pub driver_rows: usize,
}

impl Counts {
    /// The counts of a model.
    #[must_use]
    pub fn of(model: &Model) -> Counts {
        let m = model.constraints.iter().map(|c| c.kind.rows()).sum();
        let driver_rows = model
            .constraints
            .iter()
            .filter(|c| c.kind.is_driver())
            .map(|c| c.kind.rows())
            .sum();
        Counts {
            bodies: model.bodies.len(),
            n: 3 * model.bodies.len(),
            m,
            driver_rows,
        }
    }

    /// NDOF = n − m (negative when there are more equations than coordinates).
    #[must_use]
    pub fn ndof(&self) -> i64 {
        self.n as i64 - self.m as i64
    }
}

/// Why a model or analysis cannot be run as kinematics.
#[derive(Clone, Debug, PartialEq)]
pub struct Refusal {
    /// The model's name.
    pub model: String,
    /// The model's counts.
    pub counts: Counts,
    /// Whether the analysis asks for dynamics.
    pub dynamics: bool,
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = self.counts;
        let d = c.ndof();
        let s = |k: i64| if k.abs() == 1 { "" } else { "s" };
        write!(
            f,
            "model \"{}\" cannot be run as kinematics ({} bod{}: n = {} coordinates, m = {} \
             constraint equation{} of which {} from drivers, NDOF = n - m = {d})",
            self.model,
            c.bodies,
            if c.bodies == 1 { "y" } else { "ies" },
            c.n,
            c.m,
            s(c.m as i64),
            c.driver_rows,
        )?;
        let mut reasons = Vec::new();
        if self.dynamics {
            reasons.push(
                "the analysis asks for a Dynamics simulation (forward dynamics: `kinema run` \
                 integrates it), not kinematics"
                    .to_string(),
            );
        }
        if d > 0 {
            reasons.push(format!(
                "kinematic analysis needs NDOF = 0, and {d} degree{} of freedom {} not driven: \
                 add {d} driver{} (an Absolute* element whose fun depends on t); \
                 a model with free degrees of freedom and inertia (`mass`, `jbar`) runs forward \
                 dynamics under a Dynamics ACF (`--acf dynamics.acf`)",
                s(d),
                if d == 1 { "is" } else { "are" },
                s(d),
            ));
        } else if d < 0 {
            reasons.push(format!(
                "kinematic analysis needs NDOF = 0, and the model has {} more equation{} than \
                 coordinates: it is over-constrained",
                -d,
                s(d),
            ));
        }
        write!(f, ": {}", reasons.join("; and "))
    }
}

impl std::error::Error for Refusal {}

/// Checks that `model` can be run as kinematics under `analysis`.
///
/// # Errors
/// A [`Refusal`] for a Dynamics analysis or NDOF ≠ 0, with the counts.
pub fn check_kinematic(model: &Model, analysis: &Analysis) -> Result<Counts, Refusal> {
    let counts = Counts::of(model);
    let dynamics = analysis.simulation == Simulation::Dynamics;
    if dynamics || counts.ndof() != 0 {
        Err(Refusal {
            model: model.name.clone(),
            counts,
            dynamics,
        })
    } else {
        Ok(counts)
    }
}

/// What a kinematic run ignores, one line each: force elements (by name, id
/// and type) of a model without inertia, the `PointForceFile` elements of a
/// model with inertia, unknown top-level keys, and a note on mass, inertia, initial
/// velocities and gravity when the file gives them.
#[must_use]
pub fn ignored_by_kinematics(model: &Model) -> Vec<String> {
    let mut out = Vec::new();
    // A model with dynamics imports its forces but a PointForceFile (which
    // a run refuses).
    if crate::dynamics::has_dynamics(model) {
        for (name, id, mfile) in crate::dynamics::point_force_files(model) {
            out.push(format!(
                "force \"{name}\" (id {id}, PointForceFile): its force is the MATLAB function \
                 `{mfile}` ({mfile}.m), which kinema cannot run"
            ));
        }
    }
    let forces = if crate::dynamics::has_dynamics(model) {
        &[][..]
    } else {
        &model.forces[..]
    };
    for f in forces {
        out.push(format!(
            "force \"{}\" (id {}, {}): forces play no role in kinematics",
            f.name,
            f.id,
            f.kind.type_name()
        ));
    }
    for k in &model.ignored_keys {
        out.push(format!(
            "top-level key \"{k}\": not part of the model (the engine ignored it too)"
        ));
    }
    out
}
