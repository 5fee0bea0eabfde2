//! The benchmark slider-crank: [`SliderCrank`].

use std::f64::consts::{FRAC_PI_4, PI};

use crate::system::System;

/// Slider-crank (`slider_crank` of the benchmarks): crank (body 0) pinned to
/// ground at the origin, connecting rod (body 1), slider (body 2) on the
/// global x axis; crank angle driven, φ₁ = φ₀ + ω t.
///
/// Each body frame sits at the link's midpoint, local x′ along the link; the
/// slider's frame is at the wrist pin. n = 9, 21 Jacobian nonzeros.
///
/// | rows | equation |
/// |---|---|
/// | `pivot.x`, `pivot.y` | r₁ + A₁(−l₁/2, 0) = 0 |
/// | `pin.x`, `pin.y` | r₁ + A₁(l₁/2, 0) − r₂ − A₂(−l₂/2, 0) = 0 |
/// | `wrist.x`, `wrist.y` | r₂ + A₂(l₂/2, 0) − r₃ = 0 |
/// | `on_axis` | y₃ = 0 |
/// | `no_turn` | φ₃ = 0 |
/// | `crank_angle` | φ₁ − (φ₀ + ω t) = 0 |
///
/// The defaults are the benchmark's: l₁ = 0.3, l₂ = 1, φ₀ = π/4, ω = 2π,
/// initial guess [0.1, 0.1, 0.8, 0.7, 0.1, −0.2, 1.2, 0, 0].
#[derive(Debug, Clone, PartialEq)]
pub struct SliderCrank {
    /// Crank length l₁.
    pub crank: f64,
    /// Rod length l₂.
    pub rod: f64,
    /// Crank angle at t = 0, φ₀.
    pub phi0: f64,
    /// Crank speed ω.
    pub omega: f64,
    /// Initial guess for assembly.
    pub guess: [f64; 9],
}

impl Default for SliderCrank {
    fn default() -> Self {
        Self {
            crank: 0.3,
            rod: 1.0,
            phi0: FRAC_PI_4,
            omega: 2.0 * PI,
            guess: [0.1, 0.1, 0.8, 0.7, 0.1, -0.2, 1.2, 0.0, 0.0],
        }
    }
}

const COORDINATES: [&str; 9] = [
    "crank.x",
    "crank.y",
    "crank.phi",
    "rod.x",
    "rod.y",
    "rod.phi",
    "slider.x",
    "slider.y",
    "slider.phi",
];
const EQUATIONS: [&str; 9] = [
    "pivot.x",
    "pivot.y",
    "pin.x",
    "pin.y",
    "wrist.x",
    "wrist.y",
    "on_axis",
    "no_turn",
    "crank_angle",
];
const PATTERN: [(u32, u32); 21] = [
    (0, 0),
    (0, 2),
    (1, 1),
    (1, 2),
    (2, 0),
    (2, 2),
    (2, 3),
    (2, 5),
    (3, 1),
    (3, 2),
    (3, 4),
    (3, 5),
    (4, 3),
    (4, 5),
    (4, 6),
    (5, 4),
    (5, 5),
    (5, 7),
    (6, 7),
    (7, 8),
    (8, 2),
];

impl SliderCrank {
    #[inline(always)]
    fn write_phi(
        &self,
        q: &[f64],
        t: f64,
        (s1, c1): (f64, f64),
        (s2, c2): (f64, f64),
        phi: &mut [f64],
    ) {
        let (h1, h2) = (0.5 * self.crank, 0.5 * self.rod);
        let [x1, y1, p1, x2, y2, _, x3, y3, p3] = q9(q);
        let out = [
            x1 - h1 * c1,
            y1 - h1 * s1,
            x1 + h1 * c1 - x2 + h2 * c2,
            y1 + h1 * s1 - y2 + h2 * s2,
            x2 + h2 * c2 - x3,
            y2 + h2 * s2 - y3,
            y3,
            p3,
            p1 - (self.phi0 + self.omega * t),
        ];
        phi[..9].copy_from_slice(&out);
    }

    #[inline(always)]
    fn write_jacobian(&self, (s1, c1): (f64, f64), (s2, c2): (f64, f64), values: &mut [f64]) {
        let (h1, h2) = (0.5 * self.crank, 0.5 * self.rod);
        let out = [
            1.0,
            h1 * s1,
            1.0,
            -h1 * c1,
            1.0,
            -h1 * s1,
            -1.0,
            -h2 * s2,
            1.0,
            h1 * c1,
            -1.0,
            h2 * c2,
            1.0,
            -h2 * s2,
            -1.0,
            1.0,
            h2 * c2,
            -1.0,
            1.0,
            1.0,
            1.0,
        ];
        values[..21].copy_from_slice(&out);
    }
}

/// The first nine coordinates (the runtime always passes n = 9).
#[inline(always)]
fn q9(q: &[f64]) -> [f64; 9] {
    let mut a = [0.0; 9];
    a.copy_from_slice(&q[..9]);
    a
}

impl System for SliderCrank {
    type Scratch = ();

    fn scratch(&self) {}

    fn len(&self) -> usize {
        9
    }

    fn coordinate_name(&self, i: usize) -> &str {
        COORDINATES.get(i).copied().unwrap_or("?")
    }

    fn equation_name(&self, i: usize) -> &str {
        EQUATIONS.get(i).copied().unwrap_or("?")
    }

    fn initial_guess(&self, q: &mut [f64]) {
        if q.len() != 9 {
            q.fill(f64::NAN);
            return;
        }
        q[..9].copy_from_slice(&self.guess);
    }

    fn jacobian_pattern(&self) -> &[(u32, u32)] {
        &PATTERN
    }

    fn phi(&self, _scratch: &mut Self::Scratch, q: &[f64], t: f64, phi: &mut [f64]) {
        if !super::sized(9, &[q], &mut [(&mut *phi, 9)]) {
            return;
        }
        self.write_phi(q, t, q[2].sin_cos(), q[5].sin_cos(), phi);
    }

    fn jacobian(&self, _scratch: &mut Self::Scratch, q: &[f64], _t: f64, values: &mut [f64]) {
        if !super::sized(9, &[q], &mut [(&mut *values, PATTERN.len())]) {
            return;
        }
        self.write_jacobian(q[2].sin_cos(), q[5].sin_cos(), values);
    }

    fn phi_and_jacobian(
        &self,
        _scratch: &mut Self::Scratch,
        q: &[f64],
        t: f64,
        phi: &mut [f64],
        values: &mut [f64],
    ) {
        if !super::sized(
            9,
            &[q],
            &mut [(&mut *phi, 9), (&mut *values, PATTERN.len())],
        ) {
            return;
        }
        let (sc1, sc2) = (q[2].sin_cos(), q[5].sin_cos());
        self.write_phi(q, t, sc1, sc2, phi);
        self.write_jacobian(sc1, sc2, values);
    }

    fn nu(&self, _scratch: &mut Self::Scratch, q: &[f64], _t: f64, nu: &mut [f64]) {
        if !super::sized(9, &[q], &mut [(&mut *nu, 9)]) {
            return;
        }
        nu[..9].copy_from_slice(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, self.omega]);
    }

    fn gamma(
        &self,
        _scratch: &mut Self::Scratch,
        q: &[f64],
        qd: &[f64],
        _t: f64,
        gamma: &mut [f64],
    ) {
        if !super::sized(9, &[q, qd], &mut [(&mut *gamma, 9)]) {
            return;
        }
        let (h1, h2) = (0.5 * self.crank, 0.5 * self.rod);
        let ((s1, c1), (s2, c2)) = (q[2].sin_cos(), q[5].sin_cos());
        let (w1, w2) = (qd[2] * qd[2], qd[5] * qd[5]);
        let (a1x, a1y) = (h1 * c1 * w1, h1 * s1 * w1);
        let (a2x, a2y) = (h2 * c2 * w2, h2 * s2 * w2);
        gamma[..9].copy_from_slice(&[-a1x, -a1y, a1x + a2x, a1y + a2y, a2x, a2y, 0.0, 0.0, 0.0]);
    }
}
