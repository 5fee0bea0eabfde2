//! The benchmark serial chain: [`Chain`].

use std::f64::consts::{FRAC_PI_4, PI};

use crate::system::System;

/// Serial chain of N unit links (`chainN` of the benchmarks), each link's
/// absolute angle driven: link 1 pinned to ground at the origin, link k's
/// tail pinned to link k − 1's tip, φ_k = π/4 + a sin(2π t + k) (k 1-based,
/// a = 0.3).
///
/// Frames at link midpoints, s′_tail = (−1/2, 0), s′_tip = (1/2, 0);
/// n = 3N, 9N − 4 Jacobian nonzeros. For link k the rows 3k − 3, 3k − 2,
/// 3k − 1 (0-based) are
///
/// | rows | equation |
/// |---|---|
/// | `joint{k}.x`, `joint{k}.y` | k = 1: r₁ + A₁(−½, 0) = 0; k ≥ 2: r_{k−1} + A_{k−1}(½, 0) − r_k − A_k(−½, 0) = 0 |
/// | `angle{k}` | φ_k − (π/4 + a sin(2π t + k)) = 0 |
///
/// Coordinates are named `link{k}.x`, `link{k}.y`, `link{k}.phi`. The initial
/// guess is the exact configuration at t = 0 (forward kinematics), as in the
/// benchmarks.
///
/// The drivers' f(t), f′(t), f″(t) depend on t only, so they are computed
/// once per time and kept in the scratch ([`Drivers`]; Newton evaluates Φ
/// several times at the same t) — the hoisting of t-only subexpressions that
/// generated code does too.
#[derive(Debug, Clone, PartialEq)]
pub struct Chain {
    links: usize,
    /// Amplitude a of the angle drivers.
    pub amplitude: f64,
    coordinate_names: Vec<String>,
    equation_names: Vec<String>,
    pattern: Vec<(u32, u32)>,
}

/// The scratch of a [`Chain`]: (f, f′, f″) of every link's driver at time
/// `t` for amplitude `amplitude`.
#[derive(Debug, Clone)]
pub struct Drivers {
    t: f64,
    amplitude: f64,
    values: Vec<[f64; 3]>,
}

impl Chain {
    /// The chain of `links` links (the benchmarks use 2, 10, 50, 200, 1000).
    #[must_use]
    pub fn new(links: usize) -> Self {
        let mut coordinate_names = Vec::with_capacity(3 * links);
        let mut equation_names = Vec::with_capacity(3 * links);
        let mut pattern = Vec::with_capacity((9 * links).saturating_sub(4));
        for k in 0..links {
            for c in ["x", "y", "phi"] {
                coordinate_names.push(format!("link{}.{c}", k + 1));
            }
            equation_names.push(format!("joint{}.x", k + 1));
            equation_names.push(format!("joint{}.y", k + 1));
            equation_names.push(format!("angle{}", k + 1));
            let (r, j) = (3 * k as u32, 3 * k as u32);
            if k == 0 {
                pattern.extend([(r, j), (r, j + 2), (r + 1, j + 1), (r + 1, j + 2)]);
            } else {
                let i = j - 3;
                pattern.extend([(r, i), (r, i + 2), (r, j), (r, j + 2)]);
                pattern.extend([
                    (r + 1, i + 1),
                    (r + 1, i + 2),
                    (r + 1, j + 1),
                    (r + 1, j + 2),
                ]);
            }
            pattern.push((r + 2, j + 2));
        }
        Self {
            links,
            amplitude: 0.3,
            coordinate_names,
            equation_names,
            pattern,
        }
    }

    /// Brings the driver cache to time t (and the current amplitude), and
    /// gives its values.
    fn refresh_drivers<'a>(&self, drivers: &'a mut Drivers, t: f64) -> &'a [[f64; 3]] {
        let fresh = drivers.t == t
            && drivers.amplitude == self.amplitude
            && drivers.values.len() == self.links;
        if !fresh {
            drivers.values.resize(self.links, [0.0; 3]);
            for k in 0..self.links {
                let (f, fd, fdd) = self.angle(k + 1, t);
                drivers.values[k] = [f, fd, fdd];
            }
            drivers.t = t;
            drivers.amplitude = self.amplitude;
        }
        &drivers.values
    }

    /// Number of links N.
    #[must_use]
    pub fn links(&self) -> usize {
        self.links
    }

    /// Driven angle of link k (1-based) at t and its first two time
    /// derivatives: (f, f′, f″) with f = π/4 + a sin(2π t + k).
    #[must_use]
    pub fn angle(&self, k: usize, t: f64) -> (f64, f64, f64) {
        let w = 2.0 * PI;
        let (s, c) = (w * t + k as f64).sin_cos();
        (
            FRAC_PI_4 + self.amplitude * s,
            self.amplitude * w * c,
            -self.amplitude * w * w * s,
        )
    }

    /// Exact solution at t by forward kinematics: q, q̇, q̈ (each 3N long).
    #[must_use]
    pub fn exact(&self, t: f64) -> [Vec<f64>; 3] {
        let n = 3 * self.links;
        let (mut q, mut qd, mut qdd) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        // Position, velocity, acceleration of the current link's tail.
        let (mut p, mut v, mut a) = ([0.0; 2], [0.0; 2], [0.0; 2]);
        for k in 0..self.links {
            let (phi, w, alpha) = self.angle(k + 1, t);
            let (s, c) = phi.sin_cos();
            // Half-link vector e = ½(c, s): ė = ½(−s, c) w, ë = ½(−s, c) α − ½(c, s) w².
            let e = [0.5 * c, 0.5 * s];
            let ed = [-e[1] * w, e[0] * w];
            let edd = [-e[1] * alpha - e[0] * w * w, e[0] * alpha - e[1] * w * w];
            q[3 * k..3 * k + 3].copy_from_slice(&[p[0] + e[0], p[1] + e[1], phi]);
            qd[3 * k..3 * k + 3].copy_from_slice(&[v[0] + ed[0], v[1] + ed[1], w]);
            qdd[3 * k..3 * k + 3].copy_from_slice(&[a[0] + edd[0], a[1] + edd[1], alpha]);
            for d in 0..2 {
                p[d] += 2.0 * e[d];
                v[d] += 2.0 * ed[d];
                a[d] += 2.0 * edd[d];
            }
        }
        [q, qd, qdd]
    }
}

impl System for Chain {
    type Scratch = Drivers;

    fn scratch(&self) -> Drivers {
        Drivers {
            t: f64::NAN,
            amplitude: f64::NAN,
            values: vec![[0.0; 3]; self.links],
        }
    }

    fn len(&self) -> usize {
        3 * self.links
    }

    fn coordinate_name(&self, i: usize) -> &str {
        self.coordinate_names.get(i).map_or("?", String::as_str)
    }

    fn equation_name(&self, i: usize) -> &str {
        self.equation_names.get(i).map_or("?", String::as_str)
    }

    /// The exact configuration at t = 0, computed as the benchmarks do:
    /// φ_k = π/4 + 0.3 sin k, r_k = ∑_{m<k} (cos φ_m, sin φ_m) + ½ (cos φ_k, sin φ_k).
    fn initial_guess(&self, q: &mut [f64]) {
        if q.len() != self.len() {
            q.fill(f64::NAN);
            return;
        }
        let (mut px, mut py) = (0.0, 0.0);
        for (k, qk) in q.chunks_exact_mut(3).take(self.links).enumerate() {
            let phi = FRAC_PI_4 + 0.3 * ((k + 1) as f64).sin();
            let (s, c) = phi.sin_cos();
            qk.copy_from_slice(&[px + 0.5 * c, py + 0.5 * s, phi]);
            px += c;
            py += s;
        }
    }

    fn jacobian_pattern(&self) -> &[(u32, u32)] {
        &self.pattern
    }

    fn phi(&self, scratch: &mut Self::Scratch, q: &[f64], t: f64, phi: &mut [f64]) {
        if !super::sized(self.len(), &[q], &mut [(&mut *phi, self.len())]) {
            return;
        }
        let drivers = self.refresh_drivers(scratch, t);
        // Tip of the previous link.
        let (mut tip_x, mut tip_y) = (0.0, 0.0);
        for (k, (qk, out)) in q.chunks_exact(3).zip(phi.chunks_exact_mut(3)).enumerate() {
            let (s, c) = qk[2].sin_cos();
            let (hx, hy) = (0.5 * c, 0.5 * s);
            if k == 0 {
                // Revolute to ground: r₁ + A₁(−½, 0) − 0.
                out[0] = qk[0] - hx;
                out[1] = qk[1] - hy;
            } else {
                out[0] = tip_x - (qk[0] - hx);
                out[1] = tip_y - (qk[1] - hy);
            }
            out[2] = qk[2] - drivers[k][0];
            tip_x = qk[0] + hx;
            tip_y = qk[1] + hy;
        }
    }

    /// Φ and Φ_q sharing each link's sine and cosine.
    fn phi_and_jacobian(
        &self,
        scratch: &mut Self::Scratch,
        q: &[f64],
        t: f64,
        phi: &mut [f64],
        values: &mut [f64],
    ) {
        if !super::sized(
            self.len(),
            &[q],
            &mut [(&mut *phi, self.len()), (&mut *values, self.pattern.len())],
        ) {
            return;
        }
        let drivers = self.refresh_drivers(scratch, t);
        let (mut tip_x, mut tip_y) = (0.0, 0.0);
        let (mut prev_hs, mut prev_hc) = (0.0, 0.0);
        for (k, (qk, out)) in q.chunks_exact(3).zip(phi.chunks_exact_mut(3)).enumerate() {
            let (s, c) = qk[2].sin_cos();
            let (hs, hc) = (0.5 * s, 0.5 * c);
            if k == 0 {
                out[0] = qk[0] - hc;
                out[1] = qk[1] - hs;
                values[..5].copy_from_slice(&[1.0, hs, 1.0, -hc, 1.0]);
            } else {
                out[0] = tip_x - (qk[0] - hc);
                out[1] = tip_y - (qk[1] - hs);
                let at = 9 * k - 4;
                values[at..at + 9]
                    .copy_from_slice(&[1.0, -prev_hs, -1.0, -hs, 1.0, prev_hc, -1.0, hc, 1.0]);
            }
            out[2] = qk[2] - drivers[k][0];
            tip_x = qk[0] + hc;
            tip_y = qk[1] + hs;
            (prev_hs, prev_hc) = (hs, hc);
        }
    }

    fn jacobian(&self, _scratch: &mut Self::Scratch, q: &[f64], _t: f64, values: &mut [f64]) {
        if !super::sized(self.len(), &[q], &mut [(&mut *values, self.pattern.len())]) {
            return;
        }
        let mut at = 0;
        let (mut prev_s, mut prev_c) = (0.0, 0.0);
        for (k, qk) in q.chunks_exact(3).enumerate() {
            let (s, c) = qk[2].sin_cos();
            let (hs, hc) = (0.5 * s, 0.5 * c);
            if k == 0 {
                values[..5].copy_from_slice(&[1.0, hs, 1.0, -hc, 1.0]);
                at = 5;
            } else {
                let (ps, pc) = (0.5 * prev_s, 0.5 * prev_c);
                values[at..at + 9].copy_from_slice(&[1.0, -ps, -1.0, -hs, 1.0, pc, -1.0, hc, 1.0]);
                at += 9;
            }
            (prev_s, prev_c) = (s, c);
        }
    }

    fn nu(&self, scratch: &mut Self::Scratch, q: &[f64], t: f64, nu: &mut [f64]) {
        if !super::sized(self.len(), &[q], &mut [(&mut *nu, self.len())]) {
            return;
        }
        let drivers = self.refresh_drivers(scratch, t);
        for (out, f) in nu.chunks_exact_mut(3).zip(drivers) {
            out[0] = 0.0;
            out[1] = 0.0;
            out[2] = f[1];
        }
    }

    fn gamma(&self, scratch: &mut Self::Scratch, q: &[f64], qd: &[f64], t: f64, gamma: &mut [f64]) {
        if !super::sized(self.len(), &[q, qd], &mut [(&mut *gamma, self.len())]) {
            return;
        }
        let drivers = self.refresh_drivers(scratch, t);
        // A_{k−1} s′_tip φ̇²_{k−1} of the previous link (zero for ground).
        let (mut prev_x, mut prev_y) = (0.0, 0.0);
        for (k, ((qk, qdk), out)) in q
            .chunks_exact(3)
            .zip(qd.chunks_exact(3))
            .zip(gamma.chunks_exact_mut(3))
            .enumerate()
        {
            let (s, c) = qk[2].sin_cos();
            let w2 = qdk[2] * qdk[2];
            let (ax, ay) = (0.5 * c * w2, 0.5 * s * w2);
            if k == 0 {
                // Revolute to ground: γ = A₁(−½, 0) φ̇₁².
                out[0] = -ax;
                out[1] = -ay;
            } else {
                // Revolute: γ = A_{k−1}(½, 0) φ̇²_{k−1} − A_k(−½, 0) φ̇_k².
                out[0] = prev_x + ax;
                out[1] = prev_y + ay;
            }
            out[2] = drivers[k][2];
            (prev_x, prev_y) = (ax, ay);
        }
    }
}
