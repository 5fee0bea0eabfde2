//! Position analysis: Newton–Raphson on Φ(q, t) = 0.

use crate::diagnose::dependency;
use crate::error::{Dependency, Error, Quantity};
use crate::linalg::{Equilibration, LinalgError, LinearSolver, scale_and_finite};
use crate::options::Options;
use crate::state::StepStats;
use crate::system::System;

/// A contraction worse than this (‖Φ‖ after / before an update) makes
/// modified Newton factor Φ_q afresh.
const CONTRACTION: f64 = 0.2;

/// Dense rank diagnoses (an SVD each) a step may spend on failed
/// factorizations and on confirming small pivot ratios. A passage's
/// refinement may fail many factorizations whose errors it discards; past
/// the budget they carry no diagnosis (the solver diagnoses the one it
/// reports). Bounds a step's diagnosis cost at O(n³) times this (a debug
/// build spent 13 s in the SVDs of one pathological passage: fuzz F12).
pub(crate) const DIAGNOSES_PER_STEP: u32 = 32;

/// Scratch vectors of one solver, allocated once.
#[derive(Debug, Clone)]
pub(crate) struct Workspace {
    /// Φ, then Φ_q⁻¹ Φ (the Newton update with its sign flipped).
    pub(crate) phi: Box<[f64]>,
    /// Nonzeros of Φ_q in pattern order.
    pub(crate) jac: Box<[f64]>,
    /// How Φ_q is handed to the linear solver.
    pub(crate) scaling: Scaling,
    /// Dense diagnoses left in this step (see [`DIAGNOSES_PER_STEP`]).
    pub(crate) diagnoses_left: u32,
    /// The residual test's per-equation scale (see [`RowTolerance`]).
    pub(crate) rows: RowTolerance,
}

impl Workspace {
    pub(crate) fn new<S: System + ?Sized>(system: &S) -> Self {
        let (n, nnz) = (system.len(), system.jacobian_pattern().len());
        Self {
            phi: vec![0.0; n].into_boxed_slice(),
            jac: vec![0.0; nnz].into_boxed_slice(),
            scaling: Scaling {
                eq: Equilibration::new(n, nnz),
                active: false,
            },
            diagnoses_left: DIAGNOSES_PER_STEP,
            rows: RowTolerance::new(system),
        }
    }
}

/// The residual test scaled to the model's size, so that a model drawn in
/// small units is solved as accurately as the same model in metres.
///
/// [`Options::residual_tolerance`] is absolute: on a slider-crank whose
/// links are 10⁻¹² long, *every* configuration has ‖Φ‖∞ below 10⁻¹², and
/// Newton took the initial guess as the solution — wrong positions and no
/// word. So each equation i gets a natural size wᵢ, measured at assembly
/// from Φ_q and the guess: with L the model's length scale (the largest
/// |x|, |y| of the guess and the largest lever arm |∂Φᵢ/∂φ| / |∂Φᵢ/∂x|
/// of an equation), wᵢ = maxⱼ |∂Φᵢ/∂qⱼ| sⱼ, sⱼ = 1 for a body's angle
/// (a coordinate named `….phi`) and L for every other coordinate. This is
/// Φᵢ's size by its units: L for a joint's position rows, 1 for an angle
/// or a driver on φ, L² for a squared distance. Equation i then passes
/// when |Φᵢ| ≤ tol · min(1, wᵢ): the test only ever tightens, so a model
/// of unit size or larger (every benchmark mechanism) runs the absolute
/// test unchanged. Where the tightened test is below what roundoff allows
/// (a tiny model far from the origin), Newton ends on its update test
/// instead ([`Options::update_tolerance`]).
#[derive(Debug, Clone)]
pub(crate) struct RowTolerance {
    /// Whether coordinate j is a body's angle.
    angle: Box<[bool]>,
    /// min(1, wᵢ) per equation (1 where wᵢ is 0 or not finite).
    weights: Box<[f64]>,
    /// Per equation: the largest |∂Φᵢ/∂φ| (scratch of `measure`).
    lever: Box<[f64]>,
    /// Whether some weight is below 1; else the test is ‖Φ‖∞ ≤ tol alone.
    active: bool,
    /// The model's length scale L capped at 1 (1 until measured).
    size: f64,
}

impl RowTolerance {
    fn new<S: System + ?Sized>(system: &S) -> Self {
        let n = system.len();
        Self {
            angle: (0..n)
                .map(|j| system.coordinate_name(j).ends_with(".phi"))
                .collect(),
            weights: vec![1.0; n].into_boxed_slice(),
            lever: vec![0.0; n].into_boxed_slice(),
            active: false,
            size: 1.0,
        }
    }

    /// Measures the weights from the guess `q` and Φ_q's nonzeros `jac`
    /// there (pattern `pattern`); inactive if either is not finite.
    pub(crate) fn measure(&mut self, pattern: &[(u32, u32)], q: &[f64], jac: &[f64]) {
        self.active = false;
        self.size = 1.0;
        let finite = scale_and_finite(q).1 && scale_and_finite(jac).1;
        if !finite || q.len() != self.angle.len() || pattern.len() != jac.len() {
            self.weights.fill(1.0);
            return;
        }
        // Per equation, the largest |∂Φᵢ/∂(position)| goes in `weights`
        // for now, the largest |∂Φᵢ/∂φ| in `lever`.
        self.weights.fill(0.0);
        self.lever.fill(0.0);
        for (&(i, j), &v) in pattern.iter().zip(jac) {
            let (i, j) = (i as usize, j as usize);
            let (Some(&angle), Some(w), Some(l)) = (
                self.angle.get(j),
                self.weights.get_mut(i),
                self.lever.get_mut(i),
            ) else {
                self.weights.fill(1.0);
                return;
            };
            let slot = if angle { l } else { w };
            *slot = slot.max(v.abs());
        }
        let mut length = q
            .iter()
            .zip(&self.angle)
            .filter(|&(_, &angle)| !angle)
            .fold(0.0f64, |m, (x, _)| m.max(x.abs()));
        for (&w, &l) in self.weights.iter().zip(&self.lever) {
            if w > 0.0 {
                length = length.max(l / w);
            }
        }
        let measured = length > 0.0 && length.is_finite();
        if measured {
            self.size = length.min(1.0);
        }
        for (w, &l) in self.weights.iter_mut().zip(&self.lever) {
            let size = (*w * length).max(l);
            *w = if measured && size > 0.0 && size.is_finite() {
                size.min(1.0)
            } else {
                1.0
            };
        }
        self.active = self.weights.iter().any(|&w| w < 1.0);
    }

    /// The model's length scale as measured, capped at 1 (1 before, or if
    /// it could not be measured).
    pub(crate) fn size(&self) -> f64 {
        self.size
    }

    /// Whether Φ passes the residual test at tolerance `tol`, `residual`
    /// being ‖Φ‖∞ (the whole test when no weight is below 1).
    #[inline]
    pub(crate) fn satisfied(&self, phi: &[f64], residual: f64, tol: f64) -> bool {
        residual <= tol && (!self.active || self.within(phi, tol))
    }

    #[cold]
    fn within(&self, phi: &[f64], tol: f64) -> bool {
        phi.iter()
            .zip(&self.weights)
            .all(|(p, &w)| p.abs() <= tol * w)
    }

    /// maxᵢ |Φᵢ| / min(1, wᵢ): ‖Φ‖∞ in the model's size, NaN if Φ is not
    /// finite (for the tests that compare Φ with a multiple of the
    /// tolerance).
    pub(crate) fn scaled(&self, phi: &[f64]) -> f64 {
        if !self.active {
            return inf_norm(phi);
        }
        if !scale_and_finite(phi).1 {
            return f64::NAN;
        }
        phi.iter()
            .zip(&self.weights)
            .fold(0.0f64, |m, (p, &w)| m.max(p.abs() / w))
    }
}

/// Whether the linear solver factors Φ_q as it is or equilibrated, R Φ_q C.
///
/// Off at first. Switched on, for the solver's life, when the LU's
/// singularity verdict or the monitor's pivot ratio comes from the units
/// rather than from the configuration (a pendulum 10¹⁰ long: Φ_q is unit
/// triangular, but its pivots look tiny against its largest entry); then
/// every factorization scales the nonzeros by the fixed powers of two R and
/// C (O(nnz), no allocation) and every solve scales its right-hand side and
/// solution: (R Φ_q C) y = R b, x = C y.
#[derive(Debug, Clone)]
pub(crate) struct Scaling {
    pub(crate) eq: Equilibration,
    pub(crate) active: bool,
}

impl Scaling {
    /// Overwrites `rhs` = b with Φ_q⁻¹ b from the last factorization.
    #[inline]
    pub(crate) fn solve<L: LinearSolver>(
        &self,
        lu: &mut L,
        rhs: &mut [f64],
    ) -> Result<(), LinalgError> {
        if !self.active {
            return lu.solve_in_place(rhs);
        }
        self.solve_scaled(lu, rhs)
    }

    /// [`solve`](Self::solve) in the equilibrated form. Out of line: the
    /// plain solve, nearly every one, stays small enough to inline.
    #[inline(never)]
    fn solve_scaled<L: LinearSolver>(
        &self,
        lu: &mut L,
        rhs: &mut [f64],
    ) -> Result<(), LinalgError> {
        for (x, &r) in rhs.iter_mut().zip(self.eq.row.iter()) {
            *x *= r;
        }
        lu.solve_in_place(rhs)?;
        for (x, &c) in rhs.iter_mut().zip(self.eq.col.iter()) {
            *x *= c;
        }
        Ok(())
    }

    /// Overwrites `rhs` = b with Φ_q⁻ᵀ b from the last factorization:
    /// (R Φ_q C)ᵀ y = C b, x = R y.
    #[inline]
    pub(crate) fn solve_transpose<L: LinearSolver>(
        &self,
        lu: &mut L,
        rhs: &mut [f64],
    ) -> Result<(), LinalgError> {
        if !self.active {
            return lu.solve_transpose_in_place(rhs);
        }
        for (x, &c) in rhs.iter_mut().zip(self.eq.col.iter()) {
            *x *= c;
        }
        lu.solve_transpose_in_place(rhs)?;
        for (x, &r) in rhs.iter_mut().zip(self.eq.row.iter()) {
            *x *= r;
        }
        Ok(())
    }

    /// Switches to the equilibrated form, with factors computed from `jac`
    /// (the caller factors again).
    pub(crate) fn switch_on(&mut self, pattern: &[(u32, u32)], jac: &[f64]) {
        self.eq.compute(pattern, jac);
        self.active = true;
    }
}

/// The factorization the linear solver holds, as far as Newton cares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Factorization {
    /// None usable (nothing factored yet, or the last attempt failed).
    None,
    /// Φ_q at some earlier q: good enough for modified Newton.
    Stale,
}

/// How far Newton's updates moved q from the guess (a bound on the
/// distance: q − guess = −Σ Δqₖ).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Travel {
    /// ‖Δq₁‖∞ (0 when no update was taken).
    pub(crate) first: f64,
    /// Σₖ≥₂ ‖Δqₖ‖∞.
    pub(crate) later: f64,
}

/// A system with the scratch its evaluations keep.
pub(crate) struct Eval<'a, S: System> {
    pub(crate) system: &'a S,
    pub(crate) scratch: &'a mut S::Scratch,
}

/// The linear solver of Φ_q with what its factorization holds.
pub(crate) struct Lu<'a, L> {
    pub(crate) lu: &'a mut L,
    pub(crate) factorization: &'a mut Factorization,
}

/// Where a position solve writes what it took (on success only).
///
/// (Written in place rather than returned: a returned struct is stored
/// field by field and then copied in wider pieces, and such a load waits for
/// the stores to reach the cache instead of taking their values in flight —
/// measured: 2 % of the chain N = 2's generated step.)
pub(crate) struct Took<'a> {
    pub(crate) stats: &'a mut StepStats,
    pub(crate) travel: &'a mut Travel,
}

/// Solves Φ(q, t) = 0 by Newton–Raphson from the guess in `q`, as described
/// in [`Options`]. On success `q` holds the solution, `took` what it took,
/// and the result says whether `ws.jac` holds Φ_q at that q; on failure
/// `took` is untouched.
pub(crate) fn solve_position<S: System, L: LinearSolver>(
    eval: Eval<'_, S>,
    lu: Lu<'_, L>,
    q: &mut [f64],
    t: f64,
    options: &Options,
    ws: &mut Workspace,
    took: Took<'_>,
) -> Result<bool, Error> {
    let Eval { system, scratch } = eval;
    let Lu { lu, factorization } = lu;
    let Took {
        stats: stats_out,
        travel: travel_out,
    } = took;
    let full = !options.modified_newton;
    let mut stats = StepStats::default();
    let mut have_lu = !full && *factorization == Factorization::Stale;
    let mut previous_residual = f64::INFINITY;
    let mut small_update = false;
    let mut travel = Travel::default();
    loop {
        if full {
            // Φ_q's values are checked for finiteness by the factorization
            // (see `factor`).
            system.phi_and_jacobian(scratch, q, t, &mut ws.phi, &mut ws.jac);
            stats.jacobian_evaluations += 1;
        } else {
            system.phi(scratch, q, t, &mut ws.phi);
        }
        // ‖Φ‖∞ and the finiteness check in one pass.
        let (residual, finite) = scale_and_finite(&ws.phi);
        if !finite {
            check_equations(system, t, Quantity::Phi, &ws.phi)?;
        }
        stats.residual = residual;
        if ws
            .rows
            .satisfied(&ws.phi, residual, options.residual_tolerance)
            || small_update
        {
            *stats_out = stats;
            *travel_out = travel;
            return Ok(full);
        }
        if stats.iterations >= options.max_iterations {
            return Err(Error::NoConvergence {
                t,
                iterations: stats.iterations,
                residual,
                worst_equation: worst_equation(system, &ws.phi),
            });
        }
        if full || !have_lu || residual > CONTRACTION * previous_residual {
            if !full {
                system.jacobian(scratch, q, t, &mut ws.jac);
                stats.jacobian_evaluations += 1;
            }
            *factorization = Factorization::None;
            factor(
                system,
                lu,
                t,
                &ws.jac,
                &mut ws.scaling,
                options.singular_tolerance,
                &mut ws.diagnoses_left,
            )?;
            stats.factorizations += 1;
            *factorization = Factorization::Stale;
            have_lu = true;
        }
        previous_residual = residual;
        // Δq = −Φ_q⁻¹ Φ: Φ_q⁻¹ Φ is solved for in place and subtracted. The
        // solves are linear and IEEE rounding is symmetric, so this is
        // q + Δq to the bit, without a negated copy of Φ.
        ws.scaling.solve(lu, &mut ws.phi)?;
        let (step, finite) = subtract_and_scale(q, &ws.phi);
        if !finite {
            // q is scratch on failure (the solver keeps its last state).
            check_coordinates(system, t, Quantity::Position, &ws.phi)?;
        }
        if stats.iterations == 0 {
            travel.first = step;
        } else {
            travel.later += step;
        }
        stats.iterations += 1;
        small_update = is_small_update(step, options.update_tolerance, q);
    }
}

/// q −= d, and (max |d|, whether d is finite) from [`scale_and_finite`]
/// (two passes that vectorize).
#[inline]
fn subtract_and_scale(q: &mut [f64], d: &[f64]) -> (f64, bool) {
    let scale = scale_and_finite(d);
    for (x, &v) in q.iter_mut().zip(d) {
        *x -= v;
    }
    scale
}

/// ‖Δq‖∞ ≤ tol · (1 + ‖q‖∞). With tol = 0 (the peers' loop) a nonzero step
/// never passes (the right side is 0, or NaN for a non-finite q), so ‖q‖∞ is
/// not computed.
#[inline]
fn is_small_update(step: f64, tol: f64, q: &[f64]) -> bool {
    if tol == 0.0 && step > 0.0 {
        return false;
    }
    step <= tol * (1.0 + inf_norm(q))
}

/// Factors Φ_q (nonzeros `jac`); a singular matrix becomes
/// [`Error::Singular`] with the rank-revealing diagnosis, or
/// [`Error::NonFinite`] if a value is not finite. (Every solver refuses
/// non-finite values: the recorded replay checks them and repivots, and
/// partial pivoting cannot accept a NaN or infinite pivot. So the hot path
/// checks the values once, inside the factorization.)
///
/// The singularity verdict is the equilibrated matrix's: when the LU refuses
/// Φ_q as it is, it is equilibrated (see [`Scaling`]) and factored again
/// before being declared singular.
#[inline]
pub(crate) fn factor<S: System, L: LinearSolver>(
    system: &S,
    lu: &mut L,
    t: f64,
    jac: &[f64],
    scaling: &mut Scaling,
    singular_tolerance: f64,
    diagnoses_left: &mut u32,
) -> Result<(), Error> {
    let result = if scaling.active {
        scaling.eq.apply(system.jacobian_pattern(), jac);
        lu.factor(&scaling.eq.values, singular_tolerance)
    } else {
        lu.factor_as_written(jac, singular_tolerance)
    };
    match result {
        Ok(()) => Ok(()),
        Err(e) => factor_equilibrated(
            system,
            lu,
            t,
            jac,
            scaling,
            (singular_tolerance, diagnoses_left),
            e,
        ),
    }
}

/// After a refused factorization: equilibrate Φ_q afresh and try once more
/// (out of line: the hot path only tests for success).
#[cold]
#[inline(never)]
fn factor_equilibrated<S: System, L: LinearSolver>(
    system: &S,
    lu: &mut L,
    t: f64,
    jac: &[f64],
    scaling: &mut Scaling,
    (singular_tolerance, diagnoses_left): (f64, &mut u32),
    e: LinalgError,
) -> Result<(), Error> {
    if matches!(e, LinalgError::Singular { .. }) && scale_and_finite(jac).1 {
        scaling.switch_on(system.jacobian_pattern(), jac);
        if lu.factor(&scaling.eq.values, singular_tolerance).is_ok() {
            return Ok(());
        }
    }
    Err(factor_error(
        system,
        t,
        jac,
        (singular_tolerance, diagnoses_left),
        e,
    ))
}

/// The error for a failed factorization (out of line: the hot path only
/// tests for success).
#[cold]
#[inline(never)]
fn factor_error<S: System>(
    system: &S,
    t: f64,
    jac: &[f64],
    (singular_tolerance, diagnoses_left): (f64, &mut u32),
    e: LinalgError,
) -> Error {
    match e {
        LinalgError::Singular { .. } => match check_jacobian(system, t, jac) {
            Err(non_finite) => non_finite,
            Ok(()) => Error::Singular {
                t,
                dependency: if *diagnoses_left > 0 {
                    *diagnoses_left -= 1;
                    dependency(system, jac, singular_tolerance)
                } else {
                    Dependency::undiagnosed(system.len())
                },
            },
        },
        e => e.into(),
    }
}

/// ‖x‖∞ (NaN if x is not finite).
#[inline]
pub(crate) fn inf_norm(x: &[f64]) -> f64 {
    match scale_and_finite(x) {
        (norm, true) => norm,
        (_, false) => f64::NAN,
    }
}

#[inline]
fn first_non_finite(x: &[f64]) -> Option<usize> {
    if scale_and_finite(x).1 {
        None
    } else {
        x.iter().position(|v| !v.is_finite())
    }
}

/// Fails with [`Error::NonFinite`] naming the equation of the first
/// non-finite entry of `x` (one entry per equation).
#[inline]
pub(crate) fn check_equations<S: System + ?Sized>(
    system: &S,
    t: f64,
    quantity: Quantity,
    x: &[f64],
) -> Result<(), Error> {
    match first_non_finite(x) {
        None => Ok(()),
        Some(i) => Err(Error::NonFinite {
            t,
            quantity,
            name: system.equation_name(i).to_owned(),
        }),
    }
}

/// Fails with [`Error::NonFinite`] naming the coordinate of the first
/// non-finite entry of `x` (one entry per coordinate).
#[inline]
pub(crate) fn check_coordinates<S: System + ?Sized>(
    system: &S,
    t: f64,
    quantity: Quantity,
    x: &[f64],
) -> Result<(), Error> {
    match first_non_finite(x) {
        None => Ok(()),
        Some(i) => Err(Error::NonFinite {
            t,
            quantity,
            name: system.coordinate_name(i).to_owned(),
        }),
    }
}

/// Fails with [`Error::NonFinite`] naming "equation / coordinate" of the
/// first non-finite Jacobian nonzero.
#[inline]
pub(crate) fn check_jacobian<S: System + ?Sized>(
    system: &S,
    t: f64,
    jac: &[f64],
) -> Result<(), Error> {
    match first_non_finite(jac) {
        None => Ok(()),
        Some(k) => {
            let (r, c) = system.jacobian_pattern().get(k).copied().unwrap_or((0, 0));
            Err(Error::NonFinite {
                t,
                quantity: Quantity::Jacobian,
                name: format!(
                    "∂{}/∂{}",
                    system.equation_name(r as usize),
                    system.coordinate_name(c as usize)
                ),
            })
        }
    }
}

fn worst_equation<S: System + ?Sized>(system: &S, phi: &[f64]) -> String {
    let mut worst = 0;
    for (i, v) in phi.iter().enumerate() {
        if v.abs() > phi[worst].abs() {
            worst = i;
        }
    }
    if phi.is_empty() {
        String::new()
    } else {
        system.equation_name(worst).to_owned()
    }
}
