//! The benchmark four-bar: [`FourBar`].

use std::f64::consts::{FRAC_PI_4, PI};

use crate::system::System;

/// Four-bar linkage (`four_bar` of the benchmarks): crank (body 0) pinned to
/// ground at O = (0, 0), coupler (body 1), rocker (body 2) pinned to ground
/// at D = (d, 0); crank angle driven, φ₁ = φ₀ + ω t.
///
/// Body frames at the link midpoints, local x′ along the link (the rocker's
/// from D towards B). n = 9, 25 Jacobian nonzeros.
///
/// | rows | equation |
/// |---|---|
/// | `pivot.x`, `pivot.y` | r₁ + A₁(−l₁/2, 0) = 0 |
/// | `a.x`, `a.y` | r₁ + A₁(l₁/2, 0) − r₂ − A₂(−l₂/2, 0) = 0 |
/// | `b.x`, `b.y` | r₂ + A₂(l₂/2, 0) − r₃ − A₃(l₃/2, 0) = 0 |
/// | `d.x`, `d.y` | r₃ + A₃(−l₃/2, 0) − (d, 0) = 0 |
/// | `crank_angle` | φ₁ − (φ₀ + ω t) = 0 |
///
/// Defaults are the benchmark's Grashof crank-rocker: l₁ = 0.3, l₂ = 1,
/// l₃ = 0.8, d = 1, φ₀ = π/4, ω = 2π, initial guess
/// [0.1, 0.1, 0.8, 0.6, 0.5, 0.6, 1.0, 0.4, 1.5] (elbow-up branch).
#[derive(Debug, Clone, PartialEq)]
pub struct FourBar {
    /// Crank length l₁.
    pub crank: f64,
    /// Coupler length l₂.
    pub coupler: f64,
    /// Rocker length l₃.
    pub rocker: f64,
    /// Distance d between the ground pins.
    pub ground: f64,
    /// Crank angle at t = 0, φ₀.
    pub phi0: f64,
    /// Crank speed ω.
    pub omega: f64,
    /// Initial guess for assembly.
    pub guess: [f64; 9],
}

impl Default for FourBar {
    fn default() -> Self {
        Self {
            crank: 0.3,
            coupler: 1.0,
            rocker: 0.8,
            ground: 1.0,
            phi0: FRAC_PI_4,
            omega: 2.0 * PI,
            guess: [0.1, 0.1, 0.8, 0.6, 0.5, 0.6, 1.0, 0.4, 1.5],
        }
    }
}

const COORDINATES: [&str; 9] = [
    "crank.x",
    "crank.y",
    "crank.phi",
    "coupler.x",
    "coupler.y",
    "coupler.phi",
    "rocker.x",
    "rocker.y",
    "rocker.phi",
];
const EQUATIONS: [&str; 9] = [
    "pivot.x",
    "pivot.y",
    "a.x",
    "a.y",
    "b.x",
    "b.y",
    "d.x",
    "d.y",
    "crank_angle",
];
const PATTERN: [(u32, u32); 25] = [
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
    (4, 8),
    (5, 4),
    (5, 5),
    (5, 7),
    (5, 8),
    (6, 6),
    (6, 8),
    (7, 7),
    (7, 8),
    (8, 2),
];

type SinCos = (f64, f64);

impl FourBar {
    #[inline(always)]
    fn write_phi(
        &self,
        q: &[f64],
        t: f64,
        [(s1, c1), (s2, c2), (s3, c3)]: [SinCos; 3],
        phi: &mut [f64],
    ) {
        let (h1, h2, h3) = (0.5 * self.crank, 0.5 * self.coupler, 0.5 * self.rocker);
        let (x1, y1, p1, x2, y2, x3, y3) = (q[0], q[1], q[2], q[3], q[4], q[6], q[7]);
        phi[..9].copy_from_slice(&[
            x1 - h1 * c1,
            y1 - h1 * s1,
            x1 + h1 * c1 - x2 + h2 * c2,
            y1 + h1 * s1 - y2 + h2 * s2,
            x2 + h2 * c2 - x3 - h3 * c3,
            y2 + h2 * s2 - y3 - h3 * s3,
            x3 - h3 * c3 - self.ground,
            y3 - h3 * s3,
            p1 - (self.phi0 + self.omega * t),
        ]);
    }

    #[inline(always)]
    fn write_jacobian(&self, [(s1, c1), (s2, c2), (s3, c3)]: [SinCos; 3], values: &mut [f64]) {
        let (h1, h2, h3) = (0.5 * self.crank, 0.5 * self.coupler, 0.5 * self.rocker);
        values[..25].copy_from_slice(&[
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
            h3 * s3,
            1.0,
            h2 * c2,
            -1.0,
            -h3 * c3,
            1.0,
            h3 * s3,
            1.0,
            -h3 * c3,
            1.0,
        ]);
    }
}

#[inline(always)]
fn sin_cos(q: &[f64]) -> [SinCos; 3] {
    [q[2].sin_cos(), q[5].sin_cos(), q[8].sin_cos()]
}

impl System for FourBar {
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
        self.write_phi(q, t, sin_cos(q), phi);
    }

    fn jacobian(&self, _scratch: &mut Self::Scratch, q: &[f64], _t: f64, values: &mut [f64]) {
        if !super::sized(9, &[q], &mut [(&mut *values, PATTERN.len())]) {
            return;
        }
        self.write_jacobian(sin_cos(q), values);
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
        let sc = sin_cos(q);
        self.write_phi(q, t, sc, phi);
        self.write_jacobian(sc, values);
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
        let (h1, h2, h3) = (0.5 * self.crank, 0.5 * self.coupler, 0.5 * self.rocker);
        let [(s1, c1), (s2, c2), (s3, c3)] = sin_cos(q);
        let (w1, w2, w3) = (qd[2] * qd[2], qd[5] * qd[5], qd[8] * qd[8]);
        let (a1x, a1y) = (h1 * c1 * w1, h1 * s1 * w1);
        let (a2x, a2y) = (h2 * c2 * w2, h2 * s2 * w2);
        let (a3x, a3y) = (h3 * c3 * w3, h3 * s3 * w3);
        gamma[..9].copy_from_slice(&[
            -a1x,
            -a1y,
            a1x + a2x,
            a1y + a2y,
            a2x - a3x,
            a2y - a3y,
            -a3x,
            -a3y,
            0.0,
        ]);
    }
}
