//! The runtime's `System` for the tape back end: each evaluation of the
//! solver (Φ, Φ_q, ν, γ, the guess, the checks it asks for) on the
//! interpreter's tapes, or on their compiled code once the JIT has it.

use kinema_expr::TapeInputs;
use kinema_runtime::System;

use super::{TapeSystem, poison};

impl System for TapeSystem {
    type Scratch = Vec<f64>;

    fn scratch(&self) -> Vec<f64> {
        // The cache's angles NaN: no angle seen yet.
        vec![f64::NAN; self.kink_base() + self.kink_len()]
    }

    fn len(&self) -> usize {
        self.coordinate_names.len()
    }

    fn coordinate_name(&self, i: usize) -> &str {
        self.coordinate_names.get(i).map_or("", String::as_str)
    }

    fn equation_name(&self, i: usize) -> &str {
        self.equation_names.get(i).map_or("", String::as_str)
    }

    fn initial_guess(&self, q: &mut [f64]) {
        if let Some(guess) = &self.guess_override
            && guess.len() == q.len()
        {
            q.copy_from_slice(guess);
            return;
        }
        // Guesses are rarely evaluated: a scratch register file is fine here.
        let mut registers = Vec::new();
        let inputs = TapeInputs {
            q: &[],
            qd: &[],
            params: &self.params,
            t: 0.0,
        };
        self.run(&self.guess, &mut registers, &inputs, q);
    }

    fn jacobian_pattern(&self) -> &[(u32, u32)] {
        &self.pattern
    }

    fn jacobian_constant(&self, k: usize) -> Option<f64> {
        self.constants.get(k).copied().flatten()
    }

    /// The constants are the Jacobian's numbers, which its tape (and the
    /// JIT's code of it) writes as they are; a failed evaluation writes NaN
    /// into every value, which the folded LU's finiteness check of the
    /// run-time entries refuses (and Newton, Φ's NaN).
    fn jacobian_constants_exact(&self) -> bool {
        true
    }

    /// With the JIT asked for, the folded LU's solves are compiled too, in
    /// the background (interpreted until then, or if that fails: same
    /// results).
    #[cfg(feature = "jit")]
    fn compile_folded_solves(
        &self,
        solves: &kinema_runtime::linalg::FoldedSolves<'_>,
    ) -> Option<Box<dyn kinema_runtime::linalg::CompiledSolves>> {
        let jit = self.jit.as_ref()?;
        if self.len() > kinema_jit::MAX_LU_DIMENSION {
            return None;
        }
        jit.solves(solves)
    }

    /// With the JIT asked for, the folded LU's factorization is compiled
    /// too, in the background (same values, same scan; interpreted until
    /// then, or if that fails).
    #[cfg(feature = "jit")]
    fn compile_folded_factor(
        &self,
        factor: &kinema_runtime::linalg::FoldedFactor<'_>,
    ) -> Option<Box<dyn kinema_runtime::linalg::CompiledFactor>> {
        let jit = self.jit.as_ref()?;
        if self.len() > kinema_jit::MAX_LU_DIMENSION {
            return None;
        }
        jit.factor(factor)
    }

    /// Φ's kink tape, with a bound on each value's error (see
    /// [`Tape::kink`]), when Φ has a function that can be at a kink.
    #[inline]
    fn kink(
        &self,
        scratch: &mut Vec<f64>,
        q: &[f64],
        uncertainty: f64,
        size: f64,
        t: f64,
    ) -> Option<kinema_runtime::Kink> {
        let kinks = self.kinks.as_ref()?;
        let inputs = self.inputs(q, &self.zeros, t);
        let found = self.find_kink(kinks, scratch, &inputs, uncertainty, size)?;
        Some(kinema_runtime::Kink {
            equation: Some(found.root),
            function: found.function,
        })
    }

    /// Φ's tape with a bound on each value's error (see
    /// [`Tape::error_bounds`](kinema_expr::Tape::error_bounds)), in the
    /// scratch after the kink checks' part.
    fn phi_error_bounds(
        &self,
        scratch: &mut Vec<f64>,
        q: &[f64],
        t: f64,
        uncertainty: f64,
        size: f64,
        errors: &mut [f64],
    ) -> bool {
        self.phi_bounds(scratch, (q, t, uncertainty), size, errors)
    }

    fn equation_reads_time(&self, i: usize) -> bool {
        self.reads_time(i)
    }

    /// Φ's domain tape (its functions of time alone), with t uncertain by
    /// `t_error` (see [`Tape::undefined`]), in the scratch's kink part.
    #[inline]
    fn undefined(
        &self,
        scratch: &mut Vec<f64>,
        q: &[f64],
        t: f64,
        t_error: f64,
    ) -> Option<kinema_runtime::Undefined> {
        let domains = self.domains.as_ref()?;
        self.find_undefined(domains, scratch, q, t, t_error)
    }

    fn linkage(&self) -> Option<&kinema_runtime::Linkage> {
        self.linkage.as_ref()
    }

    fn linkage_angles(&self, registers: &mut Vec<f64>, t: f64, angles: &mut [f64]) {
        match &self.linkage_tapes {
            Some(tapes) => {
                let inputs = self.inputs(&self.zeros, &self.zeros, t);
                self.run(tapes.angles(), registers, &inputs, angles);
            }
            None => angles.fill(f64::NAN),
        }
    }

    fn phi(&self, registers: &mut Vec<f64>, q: &[f64], t: f64, phi: &mut [f64]) {
        let inputs = self.inputs(q, &self.zeros, t);
        #[cfg(feature = "jit")]
        if let Some((c, trig)) = self.compiled(registers) {
            return crate::jit::run(&c.phi, &inputs, trig, phi);
        }
        self.run(&self.phi, registers, &inputs, phi);
    }

    fn jacobian(&self, registers: &mut Vec<f64>, q: &[f64], t: f64, values: &mut [f64]) {
        let inputs = self.inputs(q, &self.zeros, t);
        #[cfg(feature = "jit")]
        if let Some((c, trig)) = self.compiled(registers) {
            return crate::jit::run(&c.jacobian, &inputs, trig, values);
        }
        self.run(&self.jacobian, registers, &inputs, values);
    }

    #[inline]
    fn phi_and_jacobian(
        &self,
        registers: &mut Vec<f64>,
        q: &[f64],
        t: f64,
        phi: &mut [f64],
        values: &mut [f64],
    ) {
        #[cfg(feature = "jit")]
        if let Some((c, trig)) = self.compiled(registers) {
            let inputs = self.inputs(q, &self.zeros, t);
            if phi.len() + values.len() != c.both.outputs()
                || c.both.eval_split(&inputs, trig, phi, values).is_err()
            {
                poison(&mut [phi, values]);
            }
            return;
        }
        self.interpret_both(registers, q, t, phi, values);
    }

    #[inline]
    fn nu(&self, registers: &mut Vec<f64>, q: &[f64], t: f64, nu: &mut [f64]) {
        let inputs = self.inputs(q, &self.zeros, t);
        #[cfg(feature = "jit")]
        if let Some((c, trig)) = self.compiled(registers) {
            return crate::jit::run(&c.nu, &inputs, trig, nu);
        }
        self.run(&self.nu, registers, &inputs, nu);
    }

    #[inline]
    fn gamma(&self, registers: &mut Vec<f64>, q: &[f64], qd: &[f64], t: f64, gamma: &mut [f64]) {
        let inputs = self.inputs(q, qd, t);
        #[cfg(feature = "jit")]
        if let Some((c, trig)) = self.compiled(registers) {
            return crate::jit::run(&c.gamma, &inputs, trig, gamma);
        }
        self.run(&self.gamma, registers, &inputs, gamma);
    }
}
