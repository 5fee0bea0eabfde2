//! The tape back end: a model read at run time, derived, compiled to tapes,
//! and run through the same runtime as generated code.

use std::path::Path;

use kinema_expr::{ExprId, NodeRef, Tape, TapeInputs};
use kinema_model::{Derivation, Derived, Report, Source};
use kinema_runtime::{Auto, Error, Options, Solver};

use crate::file::ModelFile;

mod system;

/// A mechanism read from model text and derived, ready to run without a
/// compile step.
///
/// ```
/// let model = kinema::Model::from_source(
///     "mechanism Pendulum {
///         param l = 1.0;
///         body bar { guess: (0.5, 0.8, 1.0) }
///         joint pin: revolute(ground(0, 0), bar(-l, 0));
///         driver swing: bar.phi == 4 * t * t;
///     }",
///     "pendulum.kin",
/// )?;
/// let mut solver = model.solver(kinema::Options::default())?;
/// let state = solver.step(0.5)?;
/// assert!((state.q()[0] - 1f64.cos()).abs() < 1e-12);
/// # Ok::<(), kinema::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct Model {
    derivation: Derivation,
    warnings: Report,
    backend: Backend,
}

/// How a model's equations are evaluated at run time (see
/// [`Model::with_backend`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Backend {
    /// Compiled to native code when the system is built (Cranelift, the
    /// `jit` feature): the default. Where that is not possible (the feature
    /// is off, Cranelift cannot target the host, or the model is too large
    /// to compile quickly) the system runs on the tape and says why
    /// ([`TapeSystem::jit_fallback`]).
    #[default]
    Jit,
    /// The tape interpreter: no code generation at all.
    Tape,
}

impl Model {
    /// Parses, checks and derives model text; `file` names it in messages.
    ///
    /// # Errors
    /// A [`Report`] with every error found (and the warnings).
    pub fn from_source(source: &str, file: &str) -> Result<Model, Report> {
        Derived::from_source(Source::new(file, source)).map(Model::from_derived)
    }

    /// Reads a model file — kinema's language, or a simEngine2D `.adm` model
    /// (by its extension; see [`ModelFile`]) — and derives it.
    ///
    /// # Errors
    /// A [`Report`]: the file cannot be read, or the model has errors.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Model, Report> {
        ModelFile::read(path.as_ref())?.into_model()
    }

    /// A model from a derived model made elsewhere (the front door's last
    /// step, [`kinema_model::Checked::derive`]).
    #[must_use]
    pub fn from_derived(derived: Derived) -> Model {
        let (_, derivation, warnings) = derived.into_parts();
        Model::from_parts(derivation, warnings)
    }

    pub(crate) fn from_parts(derivation: Derivation, warnings: Report) -> Model {
        Model {
            derivation,
            warnings,
            backend: Backend::default(),
        }
    }

    /// The model with its systems evaluated by `backend` (default
    /// [`Backend::Jit`]).
    #[must_use]
    pub fn with_backend(mut self, backend: Backend) -> Model {
        self.backend = backend;
        self
    }

    /// Sets the back end of the systems built from now on (see
    /// [`with_backend`](Self::with_backend)).
    pub fn set_backend(&mut self, backend: Backend) {
        self.backend = backend;
    }

    /// The back end asked for (what [`system`](Self::system) tries).
    #[must_use]
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// The derivation: Φ, Φ_q, ν, γ and the rest, as expressions.
    #[must_use]
    pub fn derivation(&self) -> &Derivation {
        &self.derivation
    }

    /// The warnings found while checking the model (a report without
    /// errors, empty when there are none).
    #[must_use]
    pub fn warnings(&self) -> &Report {
        &self.warnings
    }

    /// The name messages give the model (the file as given).
    #[must_use]
    pub fn file(&self) -> &str {
        self.warnings.source().name()
    }

    /// The derivation as stable text (what `kinema derive` prints).
    #[must_use]
    pub fn derivation_text(&self) -> String {
        self.derivation.render()
    }

    /// The generated Rust source for this model (what `kinema codegen` prints).
    #[must_use]
    pub fn rust_source(&self) -> String {
        kinema_codegen::generate_source(&self.derivation, &kinema_codegen::Config::default())
    }

    /// A parameter sweep of this model: each row gives values for the
    /// parameters `names`, in that order (the others keep their declared
    /// values). The tapes are compiled once, here.
    ///
    /// # Errors
    /// [`ParamError`](crate::sweep::ParamError) for a name the model does
    /// not have, or one named twice.
    #[cfg(feature = "parallel")]
    pub fn sweep<N: AsRef<str>>(
        &self,
        names: &[N],
    ) -> Result<crate::sweep::ModelSweep, crate::sweep::ParamError> {
        use crate::sweep::{ParamError, Sweep, TapeParams};
        let system = self.system();
        let mut indices: Vec<usize> = Vec::with_capacity(names.len());
        for name in names {
            let name = name.as_ref();
            let Some(i) = system.param_names.iter().position(|p| p == name) else {
                return Err(ParamError::Unknown {
                    name: name.to_owned(),
                    known: system.param_names.clone(),
                });
            };
            if indices.contains(&i) {
                return Err(ParamError::Duplicate {
                    name: name.to_owned(),
                });
            }
            indices.push(i);
        }
        let width = indices.len();
        Ok(Sweep::new(system, TapeParams { indices }).with_row_width(width))
    }

    /// Compiles the derivation to tapes, and to native code with
    /// [`Backend::Jit`]: a [`System`] for the runtime, with the parameters
    /// at their declared values.
    #[must_use]
    pub fn system(&self) -> TapeSystem {
        TapeSystem::with_backend(&self.derivation, self.backend)
    }

    /// The solver for this model, as a generated mechanism's `solver()`:
    /// the tapes of [`system`](Self::system) with the linear solver chosen by
    /// size ([`Auto`]).
    ///
    /// # Errors
    /// A model with free degrees of freedom (NDOF > 0, allowed with inertia:
    /// see [`crate::equilibrium`]); otherwise none for a derived model.
    pub fn solver(&self, options: Options) -> Result<ModelSolver, Error> {
        // Kinematic analysis needs as many equations as coordinates; a model
        // with inertia and free degrees of freedom has an equilibrium only.
        let d = &self.derivation;
        if d.rows.len() != d.nc() {
            return Err(Error::Setup(kinema_runtime::LinalgError::Dimension {
                what: "equations of the model (kinematic analysis needs NDOF = 0)",
                expected: d.nc(),
                found: d.rows.len(),
            }));
        }
        Solver::with_options(self.system(), options)
    }
}

/// The solver [`Model::solver`] returns.
pub type ModelSolver = Solver<TapeSystem, Auto>;

/// A [`System`] evaluated by tapes: compiled once, evaluated with no
/// allocation. Its scratch is the tapes' register file.
#[derive(Clone, Debug)]
pub struct TapeSystem {
    coordinate_names: Vec<String>,
    equation_names: Vec<String>,
    param_names: Vec<String>,
    pub(crate) params: Vec<f64>,
    pub(crate) pattern: Vec<(u32, u32)>,
    /// The value of each Φ_q entry that is a number (see
    /// [`System::jacobian_constant`]).
    constants: Vec<Option<f64>>,
    guess: Tape,
    pub(crate) phi: Tape,
    pub(crate) jacobian: Tape,
    both: Tape,
    nu: Tape,
    gamma: Tape,
    /// Named points and measures with their derivatives.
    pub(crate) outputs: crate::model_outputs::OutputTape,
    /// Inverse dynamics (see [`crate::dynamics`]).
    dynamics: crate::dynamics::TapeDynamics,
    /// Registers the largest tape needs (the scratch's length).
    registers: usize,
    /// Φ's subexpressions with a function that can be at a kink (see
    /// [`System::kink`]).
    kinks: Option<crate::kinks::KinkTape>,
    /// Φ's functions of time with a domain that can be left (see
    /// [`System::undefined`]).
    domains: Option<crate::domains::DomainTape>,
    pub(crate) zeros: Vec<f64>,
    /// The tapes of the closed-form position solution, if the model is a
    /// linkage of revolute joints and driven angles (shared by clones).
    linkage_tapes: Option<std::sync::Arc<crate::linkage::LinkageTapes>>,
    /// That solution planned at the current parameters (see
    /// [`System::linkage`]).
    linkage: Option<kinema_runtime::Linkage>,
    /// The equations that read t, compiled apart for
    /// [`PrecisionScope::Timed`](crate::PrecisionScope::Timed) (shared by
    /// clones).
    pub(crate) timed: Option<std::sync::Arc<crate::precision::TimedTapes>>,
    /// The JIT compiling (or having compiled) the hot path, shared by
    /// clones.
    #[cfg(feature = "jit")]
    jit: Option<std::sync::Arc<crate::jit::Jit>>,
    /// Why the JIT was asked for and is not used.
    jit_fallback: Option<String>,
    /// Assembly's start in place of the model's guesses, if set
    /// ([`TapeSystem::set_guess`]).
    pub(crate) guess_override: Option<Vec<f64>>,
}

impl TapeSystem {
    /// Compiles the tapes of a derivation (the interpreter, [`Backend::Tape`]).
    #[must_use]
    pub fn new(d: &Derivation) -> TapeSystem {
        TapeSystem::with_backend(d, Backend::Tape)
    }

    /// Compiles the tapes of a derivation, and with [`Backend::Jit`] starts
    /// compiling the hot path (Φ, Φ_q, ν, γ, and the folded LU when a
    /// solver is built) to native code on the process's compiling thread:
    /// the system
    /// runs on the tapes until that code is ready, then on it, with the
    /// same results bit for bit (see [`wait_for_jit`](Self::wait_for_jit)).
    /// A model the JIT does not take runs on the tapes and
    /// [`jit_fallback`](Self::jit_fallback) says why.
    #[must_use]
    pub fn with_backend(d: &Derivation, backend: Backend) -> TapeSystem {
        let a = &d.arena;
        let jac: Vec<ExprId> = d.phi_q.entries.iter().map(|e| e.expr).collect();
        let guess: Vec<ExprId> = d.coordinates.iter().map(|c| c.guess).collect();
        let both: Vec<ExprId> = d.phi.iter().chain(&jac).copied().collect();
        let tapes = [
            Tape::compile(a, &guess),
            Tape::compile(a, &d.phi),
            Tape::compile(a, &jac),
            Tape::compile(a, &both),
            Tape::compile(a, &d.nu),
            Tape::compile(a, &d.gamma),
        ];
        let outputs = crate::model_outputs::OutputTape::new(d);
        let dynamics = crate::dynamics::TapeDynamics::new(d);
        let linkage_tapes = crate::linkage::LinkageTapes::new(d);
        let registers = tapes
            .iter()
            .map(Tape::registers)
            .max()
            .unwrap_or(0)
            .max(outputs.registers())
            .max(dynamics.registers())
            .max(linkage_tapes.as_ref().map_or(0, |l| l.registers()));
        let params = d.param_values();
        let linkage = linkage_tapes.as_ref().and_then(|l| l.plan(&params));
        let [guess, phi, jacobian, both, nu, gamma] = tapes;
        let n = d.nc();
        #[cfg(feature = "jit")]
        let (jit, jit_fallback) = match backend {
            Backend::Tape => (None, None),
            Backend::Jit => {
                let hot = crate::jit::HotTapes {
                    phi: &phi,
                    jacobian: &jacobian,
                    both: &both,
                    nu: &nu,
                    gamma: &gamma,
                    n_phi: d.phi.len(),
                };
                // The memo after the interpreter's cache and registers.
                match crate::jit::Jit::start(&hot, 3 * n + registers) {
                    Ok(jit) => (Some(jit), None),
                    Err(why) => (None, Some(why)),
                }
            }
        };
        #[cfg(not(feature = "jit"))]
        let jit_fallback = (backend == Backend::Jit)
            .then(|| "kinema was built without its `jit` feature".to_owned());
        TapeSystem {
            coordinate_names: d.coordinates.iter().map(|c| c.name.clone()).collect(),
            equation_names: d.rows.iter().map(|r| r.name.clone()).collect(),
            param_names: d.params.iter().map(|p| p.name.clone()).collect(),
            params,
            pattern: d.phi_q.entries.iter().map(|e| (e.row, e.col)).collect(),
            constants: d
                .phi_q
                .entries
                .iter()
                .map(|e| match a.node(e.expr) {
                    NodeRef::Num(v) => Some(v),
                    _ => None,
                })
                .collect(),
            zeros: vec![0.0; n],
            guess,
            phi,
            jacobian,
            both,
            nu,
            gamma,
            outputs,
            dynamics,
            registers,
            kinks: crate::kinks::KinkTape::new(a, &d.phi),
            domains: crate::domains::DomainTape::new(a, &d.phi),
            timed: crate::precision::TimedTapes::new(d).map(std::sync::Arc::new),
            linkage_tapes: linkage_tapes.map(std::sync::Arc::new),
            linkage,
            #[cfg(feature = "jit")]
            jit,
            jit_fallback,
            guess_override: None,
        }
    }

    /// Where assembly ([`Solver::assemble`](kinema_runtime::Solver::assemble))
    /// starts Newton: `Some(q)` in place of the model's guesses — a
    /// continuation's solution at nearby parameters, to assemble on its
    /// branch — or `None` for the model's guesses again. A `q` of another
    /// length than the coordinates' is ignored (the guesses stay).
    /// Allocates only when first set.
    pub fn set_guess(&mut self, q: Option<&[f64]>) {
        match q {
            Some(q) if q.len() == self.coordinate_names.len() => {
                let guess = self.guess_override.get_or_insert_with(Vec::new);
                guess.clear();
                guess.extend_from_slice(q);
            }
            Some(_) => {}
            None => self.guess_override = None,
        }
    }

    /// The back end that evaluates this system now: [`Backend::Jit`] once
    /// its tapes are compiled to native code, else [`Backend::Tape`].
    #[must_use]
    pub fn backend(&self) -> Backend {
        #[cfg(feature = "jit")]
        if self.jit.as_ref().and_then(|j| j.compiled()).is_some() {
            return Backend::Jit;
        }
        Backend::Tape
    }

    /// Waits until every compilation this system (or a solver built on it)
    /// has started is finished, and returns the back end then in use. Not
    /// needed for correct results (the tape computes the same numbers); for
    /// measurements and tests of the compiled code.
    pub fn wait_for_jit(&self) -> Backend {
        #[cfg(feature = "jit")]
        if let Some(jit) = &self.jit {
            jit.wait();
        }
        self.backend()
    }

    /// Why [`Backend::Jit`] was asked for and the system runs on the tape
    /// instead (no native code for this host, a compilation that failed, a
    /// model too large to compile within the load-time budget, or the `jit`
    /// feature off); `None` if it was not asked for, is in use or is still
    /// compiling (a failure is known once it has happened).
    #[must_use]
    pub fn jit_fallback(&self) -> Option<&str> {
        #[cfg(feature = "jit")]
        if let Some(why) = self.jit.as_ref().and_then(|j| j.failure()) {
            return Some(why);
        }
        self.jit_fallback.as_deref()
    }

    /// The compiled tapes, once ready, and the part of the scratch they use
    /// (see [`cache`]).
    #[cfg(feature = "jit")]
    #[inline]
    fn compiled<'a>(
        &self,
        scratch: &'a mut Vec<f64>,
    ) -> Option<(&crate::jit::Compiled, &'a mut [f64])> {
        let jit = self.jit.as_ref()?;
        let compiled = jit.compiled()?;
        Some((compiled, cache(scratch, jit.cache_len())))
    }

    /// The parameters' names, in declaration order.
    #[must_use]
    pub fn param_names(&self) -> &[String] {
        &self.param_names
    }

    /// The parameters' current values.
    #[must_use]
    pub fn params(&self) -> &[f64] {
        &self.params
    }

    /// Sets a parameter by name.
    ///
    /// # Errors
    /// [`UnknownParam::Name`] (with the model's parameter names) if there is
    /// no such parameter: a typo is an error, not a silent no-op.
    pub fn set_param(&mut self, name: &str, value: f64) -> Result<(), UnknownParam> {
        match self.param_names.iter().position(|p| p == name) {
            Some(i) => self.set_param_at(i, value),
            None => Err(UnknownParam::Name {
                name: name.to_owned(),
                known: self.param_names.clone(),
            }),
        }
    }

    /// Sets the parameter at `index` (declaration order).
    ///
    /// # Errors
    /// [`UnknownParam::Index`] (with the model's parameter names) if there
    /// is no such parameter.
    pub fn set_param_at(&mut self, index: usize, value: f64) -> Result<(), UnknownParam> {
        match self.params.get_mut(index) {
            Some(p) => {
                *p = value;
                self.replan();
                Ok(())
            }
            None => Err(UnknownParam::Index {
                index,
                known: self.param_names.clone(),
            }),
        }
    }

    /// Plans the closed-form solution again at the current parameters.
    fn replan(&mut self) {
        if let Some(tapes) = &self.linkage_tapes {
            self.linkage = tapes.plan(&self.params);
        }
    }

    /// Runs `tape` and writes its outputs to `out`; on a size mismatch (a
    /// slice of the wrong length), writes NaN so the caller sees non-finite
    /// values instead of going on silently (the `System` trait's rule).
    pub(crate) fn run(
        &self,
        tape: &Tape,
        scratch: &mut Vec<f64>,
        inputs: &TapeInputs<'_>,
        out: &mut [f64],
    ) {
        let (trig, registers) = self.split(scratch, tape);
        if tape.eval_with_cache(inputs, registers, trig, out).is_err() {
            out.fill(f64::NAN);
        }
    }

    /// The register file for `tape` in the scratch (see [`Self::split`]).
    pub(crate) fn registers<'a>(&self, scratch: &'a mut Vec<f64>, tape: &Tape) -> &'a mut [f64] {
        self.split(scratch, tape).1
    }

    /// The scratch as the sin/cos cache of the coordinates (3 values per
    /// coordinate, see [`Tape::eval_with_cache`]) and the register file after
    /// it, grown if it is too short (a scratch of another system: its
    /// contents are not this system's, so such a scratch is for growing
    /// only — a `Solver` makes a new one whenever its system is lent out
    /// mutably); no allocation otherwise.
    fn split<'a>(&self, scratch: &'a mut Vec<f64>, tape: &Tape) -> (&'a mut [f64], &'a mut [f64]) {
        let cache = self.trig_len();
        if scratch.len() < cache + tape.registers() {
            grow(scratch, cache + tape.registers());
        }
        scratch.split_at_mut(cache)
    }

    /// Length of the sin/cos cache at the start of the scratch.
    pub(crate) fn trig_len(&self) -> usize {
        3 * self.coordinate_names.len()
    }
}

/// The part of the scratch the compiled tapes use (the coordinates'
/// sin/cos cache at its start, the memo after the interpreter's
/// registers): its first `n` entries, grown if the scratch came from
/// another system.
#[cfg(feature = "jit")]
#[inline]
fn cache(scratch: &mut Vec<f64>, n: usize) -> &mut [f64] {
    if scratch.len() < n {
        grow(scratch, n);
    }
    &mut scratch[..n]
}

/// Grows a scratch to `n` entries, the new ones NaN (nothing cached).
#[cold]
#[inline(never)]
pub(crate) fn grow(scratch: &mut Vec<f64>, n: usize) {
    scratch.resize(n, f64::NAN);
}

/// Fills the outputs of an evaluation that could not run with NaN.
#[cold]
#[inline(never)]
pub(crate) fn poison(outputs: &mut [&mut [f64]]) {
    for out in outputs {
        out.fill(f64::NAN);
    }
}

impl TapeSystem {
    /// The inverse-dynamics part (crate-internal).
    pub(crate) fn dynamics_part(&self) -> &crate::dynamics::TapeDynamics {
        &self.dynamics
    }
}

impl TapeSystem {
    /// Where the kink check's registers and error bounds start in the
    /// scratch: after everything the evaluations use (the interpreter's
    /// cache and registers, the compiled tapes' memo).
    pub(crate) fn kink_base(&self) -> usize {
        let interpreter = self.trig_len() + self.registers;
        #[cfg(feature = "jit")]
        let interpreter = interpreter.max(self.jit.as_ref().map_or(0, |j| j.cache_len()));
        interpreter
    }

    /// Length of the kink checks' part of the scratch: the registers of
    /// Φ's kink tape or the results' (the larger) and their error bounds
    /// (none without a function that can be at a kink).
    pub(crate) fn kink_len(&self) -> usize {
        let phi = self
            .kinks
            .as_ref()
            .map_or(0, crate::kinks::KinkTape::registers);
        let domains = self
            .domains
            .as_ref()
            .map_or(0, crate::domains::DomainTape::registers);
        2 * phi.max(self.outputs.kink_registers()).max(domains)
    }

    /// The first function of `kinks` at its kink at `inputs` (see
    /// [`Tape::kink`]), in the scratch's kink part (grown if the scratch
    /// came from another system) through its sin/cos cache, which the
    /// evaluations at this q have filled. Out of line: most models have no
    /// function with a kink.
    #[inline(never)]
    pub(crate) fn find_kink(
        &self,
        kinks: &crate::kinks::KinkTape,
        scratch: &mut Vec<f64>,
        inputs: &TapeInputs<'_>,
        uncertainty: f64,
        size: f64,
    ) -> Option<crate::kinks::Found> {
        let (base, len) = (self.kink_base(), kinks.registers());
        if scratch.len() < base + 2 * len {
            grow(scratch, base + 2 * len);
        }
        let (start, rest) = scratch.split_at_mut(base);
        let (registers, errors) = rest[..2 * len].split_at_mut(len);
        let trig = &mut start[..self.trig_len()];
        kinks.find(inputs, uncertainty, size, registers, errors, trig)
    }

    /// [`System::undefined`] on `domains`, in the scratch's kink part
    /// (grown if the scratch came from another system). Out of line: most
    /// models have no function of time with a restricted domain.
    #[inline(never)]
    fn find_undefined(
        &self,
        domains: &crate::domains::DomainTape,
        scratch: &mut Vec<f64>,
        q: &[f64],
        t: f64,
        t_error: f64,
    ) -> Option<kinema_runtime::Undefined> {
        let inputs = self.inputs(q, &self.zeros, t);
        let (base, len) = (self.kink_base(), domains.registers());
        if scratch.len() < base + 2 * len {
            grow(scratch, base + 2 * len);
        }
        let (registers, errors) = scratch[base..base + 2 * len].split_at_mut(len);
        let found = domains.find(&inputs, t_error, registers, errors)?;
        let domain = match found.undefined.domain {
            kinema_expr::Domain::Pole => kinema_runtime::Domain::Pole,
            kinema_expr::Domain::Outside => kinema_runtime::Domain::Outside,
            kinema_expr::Domain::Edge => kinema_runtime::Domain::Edge,
            kinema_expr::Domain::NoAngle => kinema_runtime::Domain::NoAngle,
            kinema_expr::Domain::Overflow => kinema_runtime::Domain::Overflow,
        };
        Some(kinema_runtime::Undefined {
            equation: found.root,
            function: found.undefined.function,
            domain,
            argument: found.undefined.argument,
        })
    }

    /// The tapes' inputs: `q`, `qd`, this system's parameters, `t`.
    pub(crate) fn inputs<'a>(&'a self, q: &'a [f64], qd: &'a [f64], t: f64) -> TapeInputs<'a> {
        TapeInputs {
            q,
            qd,
            params: &self.params,
            t,
        }
    }

    /// [`System::phi_and_jacobian`] on the tape. Out of line: the compiled
    /// path's frame stays light.
    #[inline(never)]
    fn interpret_both(
        &self,
        registers: &mut Vec<f64>,
        q: &[f64],
        t: f64,
        phi: &mut [f64],
        values: &mut [f64],
    ) {
        let inputs = self.inputs(q, &self.zeros, t);
        // The outputs are Φ then Φ_q's values, read where the tape left them.
        let (trig, registers) = self.split(registers, &self.both);
        let outputs = self
            .both
            .eval_in_registers_with_cache(&inputs, registers, trig);
        match outputs {
            Ok(out) if out.len() == phi.len() + values.len() => {
                let (p, j) = out.split_at(phi.len());
                phi.copy_from_slice(p);
                values.copy_from_slice(j);
            }
            _ => poison(&mut [phi, values]),
        }
    }
}

/// A parameter that [`TapeSystem::set_param`] or
/// [`TapeSystem::set_param_at`] was asked to set and the model does not have.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum UnknownParam {
    /// No parameter of that name.
    Name {
        /// The name asked for.
        name: String,
        /// The model's parameters, in declaration order.
        known: Vec<String>,
    },
    /// No parameter at that index.
    Index {
        /// The index asked for (declaration order).
        index: usize,
        /// The model's parameters, in declaration order.
        known: Vec<String>,
    },
}

impl std::fmt::Display for UnknownParam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let known = match self {
            Self::Name { name, known } => {
                write!(f, "unknown parameter `{name}`")?;
                known
            }
            Self::Index { index, known } => {
                write!(f, "no parameter at index {index}")?;
                known
            }
        };
        if known.is_empty() {
            write!(f, "; the model has no parameters")
        } else {
            write!(f, "; the model's parameters are: {}", known.join(", "))
        }
    }
}

impl std::error::Error for UnknownParam {}
