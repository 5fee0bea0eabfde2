//! Static equilibrium of a system with inertia: the runtime's descent
//! ([`kinema_runtime::equilibrium`]) over any
//! [`ForwardSystem`](crate::ForwardSystem) — a generated one
//! (`Name::default().forward()`, see [`equilibrium_from_start`]) or a model
//! file's ([`Model::equilibrium`], with the feature `model`).

use kinema_model::Derivation;

pub use kinema_runtime::equilibrium::{
    Equilibrium, EquilibriumError, Stability, equilibrium, equilibrium_from_start,
};

use crate::Model;
use crate::forward::TapeForward;

impl Model {
    /// The stable static equilibrium reached from the model's initial
    /// guess at time `t0` (drivers, if any, held at their value there),
    /// with the default parameters; see [`kinema_runtime::equilibrium`].
    ///
    /// # Errors
    /// [`EquilibriumError`]: no dynamics, singular constraints, no
    /// convergence, non-finite values.
    pub fn equilibrium(&self, t0: f64) -> Result<Equilibrium, EquilibriumError> {
        let d = self.derivation();
        let mut guess = vec![0.0; d.nc()];
        kinema_runtime::System::initial_guess(&self.system(), &mut guess);
        equilibrium_from(d, &d.param_values(), &guess, t0)
    }
}

/// [`Model::equilibrium`] from a given configuration and parameters.
///
/// # Errors
/// As [`Model::equilibrium`].
pub fn equilibrium_from(
    d: &Derivation,
    params: &[f64],
    start: &[f64],
    t0: f64,
) -> Result<Equilibrium, EquilibriumError> {
    let mut system = TapeForward::new(d, params).ok_or(EquilibriumError::NoDynamics)?;
    kinema_runtime::equilibrium::equilibrium(&mut system, start, t0)
}
