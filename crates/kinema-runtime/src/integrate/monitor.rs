//! Singular configurations met by forward dynamics: redundant constraints
//! at the start, and every passage through a configuration where Φ_q
//! loses rank.
//!
//! **The measure.** With D = diag(Φ_q M⁻¹ Φ_qᵀ) (each row's scale in the
//! mass metric), the scaled Gram matrix Ĝ = D^−½ Φ_q M⁻¹ Φ_qᵀ D^−½ has a
//! unit diagonal whatever the units of the rows and coordinates; its
//! smallest eigenvalue μ is 0 exactly where Φ_q loses rank, and s = √μ is
//! the smallest singular value of the scaled Φ_q (`D^−½ Φ_q M^−½`). With
//! r redundant rows at the start the monitor follows the (r + 1)-th
//! smallest instead.
//!
//! **Per step, cheap.** The integrators factor a regularized saddle-point
//! matrix [A cΦ_qᵀ; Φ_q −E] every step anyway (saddle.rs, with E = ε D and
//! A ≈ M); one solve with it applies (Ĝ + ε)⁻¹ (up to A's h-terms), so
//! one step of inverse (subspace) iteration per integration step follows
//! s along the motion, warm-started from the last step's vectors.
//!
//! **A passage.** A local minimum of s along the steps whose lines to its
//! neighbours reach zero within their bracket (a V: s ∝ |t − t*| at a
//! crossing), or below 10⁻³, is a candidate; the motion between
//! the neighbouring steps is interpolated (cubic Hermite in q, q̇) and the
//! minimum of the exact s (a singular value decomposition of the scaled
//! Φ_q) located by golden-section search. At or below the threshold
//! ([`Monitor::new`]) it is a passage: its time, and the diagnosis there
//! (dependent equations, coordinates left free). Candidates that stay
//! above it were only close to singular; nothing is said.

use nalgebra::{DMatrix, SVD};

use super::ForwardSystem;
use super::saddle::REGULARIZATION;
use crate::error::Dependency;

/// Largest m·n for which the dense decompositions run (the rank at the
/// start, the location and diagnosis of a passage).
pub const MAX_DENSE: usize = 600 * 600;

/// Most redundant rows the monitor can look past (the tracked vectors are
/// one more).
const MAX_TRACKED: usize = 8;

/// A step's s that is a local minimum is a candidate when the lines
/// through it and either neighbour reach zero within the bracket, or it
/// is below this, whatever its neighbours.
const LOW: f64 = 1e-3;

/// A singular value of the scaled Φ_q at most this (relative to the
/// largest) counts as zero in the rank at the start.
const RANK_CUTOFF: f64 = 1e-8;

/// A component of a unit singular vector at least this large names its
/// equation or coordinate (as in the kinematic diagnosis).
const INVOLVED: f64 = 1e-3;

/// Steps of inverse (subspace) iteration per integration step.
const TRACKING_ITERATIONS: usize = 2;

/// Below this scaled s the monitor runs at every accepted step (a long
/// chain's s is 10⁻² and less all along its regular motion: the rule on
/// the rate of fall covers the approach to a passage).
const NEAR: f64 = LOW;

/// Elsewhere it runs often enough to see s at least this many times
/// before it could reach zero at its current rate of fall …
const SAMPLES_BEFORE_ZERO: f64 = 8.0;

/// … and at least once every `MAX_SKIP + 1` accepted steps (at every
/// step, its solves were a third of a small model's step).
const MAX_SKIP: u32 = 15;

/// Above this s an evaluation makes one step of inverse iteration, not
/// [`TRACKING_ITERATIONS`]: far from a singular configuration the estimate
/// only paces the evaluations.
const FAR: f64 = 0.1;

/// Size of the perturbation added to the tracked vectors every step.
const PERTURBATION: f64 = 1e-2;

/// A fixed pseudo-random number in [−1, 1] for index `i` (a hash, not a
/// generator: the same every run).
fn pseudo_random(i: usize) -> f64 {
    let mut z = (i as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Golden-section rounds locating a passage (0.618³⁰ ≈ 5·10⁻⁷ of the
/// bracket).
const ROUNDS: usize = 30;

/// A singular configuration the motion passed.
#[derive(Clone, Debug, PartialEq)]
pub struct Passage {
    /// When s was smallest (golden-section search on the interpolated
    /// motion).
    pub t: f64,
    /// The smallest singular value of the scaled Φ_q there.
    pub sigma: f64,
    /// The diagnosis there: the dependent equations, the coordinates
    /// left free.
    pub dependency: Dependency,
}

impl std::fmt::Display for Passage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "singular configuration passed at t = {}: {}; the motion went on through it (q and q̇ \
             continuous), and the constraint forces there are not determined by the model",
            self.t, self.dependency
        )
    }
}

/// An accepted state kept for the interpolation of a passage.
#[derive(Clone, Debug)]
struct Sample {
    t: f64,
    s: f64,
    q: Vec<f64>,
    qd: Vec<f64>,
}

/// The monitor and its buffers (see the module documentation).
#[derive(Debug)]
pub struct Monitor {
    n: usize,
    m: usize,
    /// Tracked vectors (k × m, orthonormal rows).
    x: Vec<f64>,
    y: Vec<f64>,
    k: usize,
    /// √Dᵣ of the last step.
    d: Vec<f64>,
    rhs: Vec<f64>,
    h: [f64; MAX_TRACKED * MAX_TRACKED],
    /// The last three accepted states, oldest first.
    samples: [Sample; 3],
    count: usize,
    threshold: f64,
    redundancy: Option<Dependency>,
    /// The rank of Φ_q at the start (`None` when not decided).
    rank: Option<usize>,
    passages: Vec<Passage>,
    /// Whether the monitor runs (off for sizes above [`MAX_DENSE`] or
    /// more than `MAX_TRACKED − 1` redundant rows).
    active: bool,
    /// The start's scaled s, for the failure messages.
    last_s: f64,
    /// Whether evaluations are paced by s (see [`pace`](Self::pace)).
    paced: bool,
    /// Accepted steps to let pass before the next evaluation.
    skip: u32,
    /// Evaluations of s so far.
    evaluations: u64,
    /// The time of the last accepted step seen, and the step before it.
    last_t: f64,
    step_h: f64,
    /// Work of the dense decompositions.
    mass: Vec<f64>,
    jac: Vec<f64>,
    qi: Vec<f64>,
}

impl Monitor {
    /// A monitor for `system` at the start (q₀): the rank at the start
    /// (redundant rows are diagnosed once) and the tracked vectors.
    /// `threshold` is the scaled singular value at or below which a
    /// located minimum is a singular configuration (the integrators pass
    /// 10⁻⁶, or more when their own accuracy is coarser). Allocates.
    pub fn new<S: ForwardSystem>(system: &mut S, q0: &[f64], t0: f64, threshold: f64) -> Monitor {
        let (n, m) = (system.coords(), system.rows());
        let sample = || Sample {
            t: f64::NAN,
            s: f64::NAN,
            q: vec![0.0; n],
            qd: vec![0.0; n],
        };
        let mut monitor = Monitor {
            n,
            m,
            x: Vec::new(),
            y: Vec::new(),
            k: 1,
            d: vec![0.0; m],
            rhs: vec![0.0; n + m],
            h: [0.0; MAX_TRACKED * MAX_TRACKED],
            samples: [sample(), sample(), sample()],
            count: 0,
            threshold,
            redundancy: None,
            rank: None,
            passages: Vec::with_capacity(16),
            active: m > 0 && m * n <= MAX_DENSE,
            last_s: f64::NAN,
            paced: false,
            skip: 0,
            evaluations: 0,
            last_t: t0,
            step_h: f64::NAN,
            mass: vec![0.0; n],
            jac: vec![0.0; m * n],
            qi: vec![0.0; n],
        };
        if !monitor.active {
            return monitor;
        }
        let Some(svd) = monitor.scaled_svd(system, q0, t0, true) else {
            monitor.active = false;
            return monitor;
        };
        let largest = svd.singular_values.max();
        let rank = svd
            .singular_values
            .iter()
            .filter(|&&s| s > RANK_CUTOFF * largest)
            .count();
        monitor.rank = Some(rank);
        if rank < m {
            // Redundant rows leave no coordinate free beyond the motion's
            // own degrees of freedom: only the equations are named.
            let mut d = monitor.diagnose(system, &svd, RANK_CUTOFF * largest);
            d.coordinates.clear();
            monitor.redundancy = Some(d);
        }
        monitor.k = m - rank + 1;
        if monitor.k > MAX_TRACKED || monitor.k > m {
            monitor.active = false;
            return monitor;
        }
        // Start from the right singular vectors of the k smallest singular
        // values of the scaled Φ_qᵀ (left of Φ_q): converged at once.
        let k = monitor.k;
        monitor.x = vec![0.0; k * m];
        monitor.y = vec![0.0; k * m];
        if let Some(u) = &svd.u {
            let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
            order.sort_by(|&a, &b| svd.singular_values[a].total_cmp(&svd.singular_values[b]));
            for (v, &j) in order.iter().take(k).enumerate() {
                for r in 0..m {
                    monitor.x[v * m + r] = u[(r, j)];
                }
            }
        }
        monitor
    }

    /// A monitor that watches nothing (before [`Monitor::new`] runs).
    #[must_use]
    pub fn inactive() -> Monitor {
        let sample = || Sample {
            t: f64::NAN,
            s: f64::NAN,
            q: Vec::new(),
            qd: Vec::new(),
        };
        Monitor {
            n: 0,
            m: 0,
            x: Vec::new(),
            y: Vec::new(),
            k: 1,
            d: Vec::new(),
            rhs: Vec::new(),
            h: [0.0; MAX_TRACKED * MAX_TRACKED],
            samples: [sample(), sample(), sample()],
            count: 0,
            threshold: 0.0,
            redundancy: None,
            rank: None,
            passages: Vec::new(),
            active: false,
            last_s: f64::NAN,
            paced: false,
            skip: 0,
            evaluations: 0,
            last_t: f64::NAN,
            step_h: f64::NAN,
            mass: Vec::new(),
            jac: Vec::new(),
            qi: Vec::new(),
        }
    }

    /// The redundant rows found at the start, diagnosed.
    #[must_use]
    pub fn redundancy(&self) -> Option<&Dependency> {
        self.redundancy.as_ref()
    }

    /// The numerical rank of Φ_q at the start (of the row- and
    /// mass-scaled matrix, singular values below 10⁻⁸ of the largest
    /// negligible), or `None` when it was not decided (a size beyond
    /// [`MAX_DENSE`], non-finite values, no rows).
    #[must_use]
    pub fn rank(&self) -> Option<usize> {
        self.rank
    }

    /// The passages so far, in time order.
    #[must_use]
    pub fn passages(&self) -> &[Passage] {
        &self.passages
    }

    /// Whether the last accepted state was within 10⁻³ of a singular
    /// configuration (scaled s): what a failure there is said to be near.
    #[must_use]
    pub fn near_singular(&self) -> bool {
        self.active && self.last_s <= LOW
    }

    /// How many accepted steps s was evaluated at (see
    /// [`due`](Self::due)).
    #[must_use]
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }

    /// The last step's estimate of s.
    #[must_use]
    pub fn last_s(&self) -> f64 {
        self.last_s
    }

    /// Paces the evaluations by s (see [`due`](Self::due)): for an
    /// integrator of many short steps (HHT's fixed step, where the
    /// monitor's solves were a third of a small model's step). Without it
    /// (the default, and the accurate mode's: few long steps, each of many
    /// evaluations) s is evaluated at every accepted step.
    pub fn pace(&mut self, on: bool) {
        self.paced = on;
    }

    /// Whether the monitor evaluates s at the accepted step that ends at
    /// `t` (call once per accepted step, then [`step`](Self::step) when
    /// true). It does at every step where s is below 10⁻³ or falling fast
    /// enough to reach zero within eight steps; elsewhere every few steps
    /// (at most sixteen apart), so a regular motion pays for its solves on
    /// one step in sixteen while a passage is still seen step by step.
    pub fn due(&mut self, t: f64) -> bool {
        if !self.active {
            return false;
        }
        self.step_h = t - self.last_t;
        self.last_t = t;
        if self.paced && self.skip > 0 {
            self.skip -= 1;
            return false;
        }
        true
    }

    /// The steps to let pass after an evaluation (see [`due`](Self::due)).
    fn steps_to_skip(&self) -> u32 {
        let [_, b, c] = &self.samples;
        if self.count < 2 || c.s <= NEAR || self.step_h.is_nan() || self.step_h <= 0.0 {
            return 0;
        }
        let slope = (c.s - b.s) / (c.t - b.t);
        let steps_to_zero = if slope < 0.0 {
            c.s / -slope / self.step_h
        } else {
            f64::INFINITY
        };
        let skip = (steps_to_zero / SAMPLES_BEFORE_ZERO).floor() - 1.0;
        if skip >= f64::from(MAX_SKIP) {
            MAX_SKIP
        } else if skip >= 1.0 {
            // In range: the cast keeps the value.
            skip as u32
        } else {
            0
        }
    }

    /// One step of the monitor at an accepted state (t, q, q̇): `solve`
    /// applies the regularized saddle-point factors factored near it
    /// (an n + m vector in place), `eps` is their E (so D = E / ε / `c`, c
    /// the factor of Φ_qᵀ in that matrix, the `scale` of
    /// `saddle::regularization`). A passage found is recorded (the
    /// system is evaluated then; allocates only then).
    pub fn step<S: ForwardSystem>(
        &mut self,
        system: &mut S,
        (t, q, qd): (f64, &[f64], &[f64]),
        eps: &[f64],
        scale: f64,
        solve: &mut dyn FnMut(&mut [f64]),
    ) {
        if !self.active {
            return;
        }
        let (n, m, k) = (self.n, self.m, self.k);
        for (d, &e) in self.d.iter_mut().zip(eps) {
            *d = (e.abs() / (REGULARIZATION * scale)).sqrt();
        }
        // A fixed pseudo-random perturbation keeps a component of every
        // mode in the tracked vectors: a mode that goes singular while
        // orthogonal to them (by a symmetry of the mechanism) would
        // otherwise never be amplified into view.
        for (i, x) in self.x.iter_mut().enumerate() {
            *x += PERTURBATION * pseudo_random(i);
        }
        orthonormalize(&mut self.x, k, m);
        let mut theta = f64::NAN;
        let iterations = if self.paced && self.last_s > FAR {
            1
        } else {
            TRACKING_ITERATIONS
        };
        for _ in 0..iterations {
            // Y = (Ĝ + ε)⁻¹ X: solve [A cΦᵀ; Φ −E][·; y] = [0; D^½ x], then
            // y ← −c D^½ y.
            for v in 0..k {
                self.rhs[..n].fill(0.0);
                for r in 0..m {
                    self.rhs[n + r] = self.d[r] * self.x[v * m + r];
                }
                solve(&mut self.rhs);
                for r in 0..m {
                    self.y[v * m + r] = -scale * self.d[r] * self.rhs[n + r];
                }
            }
            // H = Xᵀ Y (k × k, symmetric up to A's h-terms); its smallest
            // eigenvalue θ gives the largest tracked μ = 1/θ − ε.
            for a in 0..k {
                for b in 0..k {
                    let xa = &self.x[a * m..(a + 1) * m];
                    let yb = &self.y[b * m..(b + 1) * m];
                    let v: f64 = xa.iter().zip(yb).map(|(p, q)| p * q).sum();
                    self.h[a * k + b] = v;
                }
            }
            for a in 0..k {
                for b in a + 1..k {
                    let v = 0.5 * (self.h[a * k + b] + self.h[b * k + a]);
                    self.h[a * k + b] = v;
                    self.h[b * k + a] = v;
                }
            }
            theta = smallest_eigenvalue(&mut self.h[..k * k], k);
            // X ← orthonormalized Y (modified Gram–Schmidt).
            self.x.copy_from_slice(&self.y);
            orthonormalize(&mut self.x, k, m);
        }
        let mu = if theta > 0.0 {
            (1.0 / theta - REGULARIZATION).max(0.0)
        } else {
            0.0
        };
        let s = mu.sqrt();
        self.last_s = s;
        self.evaluations += 1;

        if !s.is_finite() {
            return;
        }
        self.push(t, s, q, qd);
        if self.count >= 3 {
            self.check(system);
        }
        self.skip = self.steps_to_skip();
    }

    fn push(&mut self, t: f64, s: f64, q: &[f64], qd: &[f64]) {
        self.samples.rotate_left(1);
        let last = &mut self.samples[2];
        last.t = t;
        last.s = s;
        last.q.copy_from_slice(q);
        last.qd.copy_from_slice(qd);
        self.count += 1;
    }

    /// Is the middle sample a candidate? Then locate and diagnose.
    fn check<S: ForwardSystem>(&mut self, system: &mut S) {
        let [a, b, c] = &self.samples;
        // A V that reaches zero: the line through a and b meets s = 0 before
        // c's time, or the line through c and b after a's (a crossing of a
        // singular configuration makes s ∝ |t − t*|; a smooth minimum of a
        // regular motion is flat there and its lines stay above zero).
        let reaches_zero = |(t1, s1): (f64, f64), (t2, s2): (f64, f64), span: f64| {
            let slope = (s2 - s1) / (t2 - t1);
            slope.abs() > 0.0 && s2 / slope.abs() <= span
        };
        let dips = b.s < a.s
            && b.s <= c.s
            && (b.s <= LOW
                || reaches_zero((a.t, a.s), (b.t, b.s), c.t - b.t)
                || reaches_zero((c.t, c.s), (b.t, b.s), b.t - a.t));
        if !dips {
            return;
        }
        if self.passages.last().is_some_and(|last| last.t >= a.t) {
            return;
        }
        let (t0, t1) = (a.t, c.t);
        let mut cost = |monitor: &mut Monitor, t: f64| -> f64 {
            monitor.interpolate(t);
            let q = std::mem::take(&mut monitor.qi);
            let s = monitor
                .scaled_svd(system, &q, t, false)
                .map_or(f64::INFINITY, |svd| {
                    sorted_small(&svd.singular_values, monitor.k)
                });
            monitor.qi = q;
            s
        };
        // Golden-section search for the minimum of s on [t0, t1].
        let g = 0.5 * (5.0_f64.sqrt() - 1.0);
        let (mut lo, mut hi) = (t0, t1);
        let mut x1 = hi - g * (hi - lo);
        let mut x2 = lo + g * (hi - lo);
        let mut f1 = cost(self, x1);
        let mut f2 = cost(self, x2);
        for _ in 0..ROUNDS {
            if f1 <= f2 {
                hi = x2;
                x2 = x1;
                f2 = f1;
                x1 = hi - g * (hi - lo);
                f1 = cost(self, x1);
            } else {
                lo = x1;
                x1 = x2;
                f1 = f2;
                x2 = lo + g * (hi - lo);
                f2 = cost(self, x2);
            }
        }
        let (t_min, s_min) = if f1 <= f2 { (x1, f1) } else { (x2, f2) };

        if s_min.is_nan() || s_min > self.threshold {
            return;
        }
        // Two overlapping brackets can locate one passage twice (a V
        // sampled with two low steps on either side of its vertex).
        let gap = 1e-6 * (t1 - t0).max(f64::EPSILON * t_min.abs());
        if self
            .passages
            .last()
            .is_some_and(|p| (p.t - t_min).abs() <= gap.max(0.5 * (t1 - t0)))
        {
            return;
        }
        self.interpolate(t_min);
        let q = std::mem::take(&mut self.qi);
        let dependency = match self.scaled_svd(system, &q, t_min, true) {
            Some(svd) => {
                let cutoff = (self.threshold * 10.0).max(s_min * 10.0);
                self.diagnose(system, &svd, cutoff)
            }
            None => Dependency::undiagnosed(self.m),
        };
        self.qi = q;
        self.passages.push(Passage {
            t: t_min,
            sigma: s_min,
            dependency,
        });
    }

    /// `qi` ← q(t) by cubic Hermite interpolation between the kept samples
    /// bracketing t.
    fn interpolate(&mut self, t: f64) {
        let i = if t <= self.samples[1].t { 0 } else { 1 };
        let (a, b) = (&self.samples[i], &self.samples[i + 1]);
        let h = b.t - a.t;
        if h.is_nan() || h <= 0.0 {
            self.qi.copy_from_slice(&b.q);
            return;
        }
        let u = ((t - a.t) / h).clamp(0.0, 1.0);
        let (u2, u3) = (u * u, u * u * u);
        let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
        let h10 = u3 - 2.0 * u2 + u;
        let h01 = -2.0 * u3 + 3.0 * u2;
        let h11 = u3 - u2;
        for (j, x) in self.qi.iter_mut().enumerate() {
            *x = h00 * a.q[j] + h10 * h * a.qd[j] + h01 * b.q[j] + h11 * h * b.qd[j];
        }
    }

    /// The SVD of the scaled D^−½ Φ_q M^−½ at (q, t) (m × n; `None` when
    /// a value is not finite, a mass is not positive, or it fails).
    fn scaled_svd<S: ForwardSystem>(
        &mut self,
        system: &mut S,
        q: &[f64],
        t: f64,
        vectors: bool,
    ) -> Option<SVD<f64, nalgebra::Dyn, nalgebra::Dyn>> {
        let (n, m) = (self.n, self.m);
        system.mass(q, &mut self.mass);
        system.jacobian(q, t, &mut self.jac);
        if self.mass.iter().any(|&w| !(w > 0.0 && w.is_finite()))
            || self.jac.iter().any(|v| !v.is_finite())
        {
            return None;
        }
        // With more rows than coordinates (redundant constraints) the
        // matrix is padded with zero columns to m × m, so the SVD's U holds
        // the whole left null space (nalgebra's SVD is thin).
        let mut a = DMatrix::<f64>::zeros(m, n.max(m));
        for r in 0..m {
            let row = &self.jac[r * n..(r + 1) * n];
            let g: f64 = row.iter().zip(&self.mass).map(|(x, w)| x * x / w).sum();
            let d = if g > 0.0 { 1.0 / g.sqrt() } else { 1.0 };
            for c in 0..n {
                a[(r, c)] = d * row[c] / self.mass[c].sqrt();
            }
        }
        let svd = SVD::try_new(a, vectors, vectors, f64::EPSILON, 200 * (m + n) + 1000)?;
        svd.singular_values
            .iter()
            .all(|s| s.is_finite())
            .then_some(svd)
    }

    /// The dependent equations and the coordinates left free along the
    /// singular values at or below `cutoff`.
    fn diagnose<S: ForwardSystem>(
        &self,
        system: &S,
        svd: &SVD<f64, nalgebra::Dyn, nalgebra::Dyn>,
        cutoff: f64,
    ) -> Dependency {
        let (n, m) = (self.n, self.m);
        let sigma = &svd.singular_values;
        let largest = sigma.max();
        let smallest = sigma.min();
        let null: Vec<usize> = (0..sigma.len())
            .filter(|&j| sigma[j] <= cutoff || sigma[j] == smallest)
            .collect();
        let rank = sigma.iter().filter(|&&s| s > cutoff).count();
        let mut dep = Dependency::undiagnosed(m);
        dep.rank = Some(rank);
        dep.condition = Some(if smallest > 0.0 {
            largest / smallest
        } else {
            f64::INFINITY
        });
        let (Some(u), Some(v_t)) = (&svd.u, &svd.v_t) else {
            return dep;
        };
        let mut eq = vec![false; m];
        let mut co = vec![false; n];
        for &j in &null {
            for (r, e) in eq.iter_mut().enumerate() {
                *e |= u[(r, j)].abs() >= INVOLVED;
            }
            for (c, e) in co.iter_mut().enumerate() {
                *e |= v_t[(j, c)].abs() >= INVOLVED;
            }
        }
        let w: Vec<Vec<f64>> = null
            .iter()
            .map(|&j| (0..m).map(|r| u[(r, j)]).collect())
            .collect();
        dep.redundant = crate::diagnose::redundant_set(w)
            .into_iter()
            .map(|r| system.equation_name(r).to_owned())
            .collect();
        dep.equations = (0..m)
            .filter(|&r| eq[r])
            .map(|r| system.equation_name(r).to_owned())
            .collect();
        dep.coordinates = (0..n)
            .filter(|&c| co[c])
            .map(|c| system.coordinate_name(c).to_owned())
            .collect();
        dep
    }
}

/// The k-th smallest of `values` (k ≥ 1).
fn sorted_small(values: &nalgebra::DVector<f64>, k: usize) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().collect();
    v.sort_by(f64::total_cmp);
    v.get(k - 1).copied().unwrap_or(f64::INFINITY)
}

/// The smallest eigenvalue of the symmetric k × k `a` (row-major; its
/// contents are destroyed) by cyclic Jacobi rotations.
fn smallest_eigenvalue(a: &mut [f64], k: usize) -> f64 {
    for _ in 0..50 {
        let mut off = 0.0;
        for p in 0..k {
            for q in p + 1..k {
                off += a[p * k + q] * a[p * k + q];
            }
        }
        if off <= 1e-30 * a.iter().map(|v| v * v).sum::<f64>() {
            break;
        }
        for p in 0..k {
            for q in p + 1..k {
                let apq = a[p * k + q];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[q * k + q] - a[p * k + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for r in 0..k {
                    let (arp, arq) = (a[r * k + p], a[r * k + q]);
                    a[r * k + p] = c * arp - s * arq;
                    a[r * k + q] = s * arp + c * arq;
                }
                for r in 0..k {
                    let (apr, aqr) = (a[p * k + r], a[q * k + r]);
                    a[p * k + r] = c * apr - s * aqr;
                    a[q * k + r] = s * apr + c * aqr;
                }
            }
        }
    }
    (0..k).map(|i| a[i * k + i]).fold(f64::INFINITY, f64::min)
}

/// Orthonormalizes the k rows of length m of `x` (modified Gram–Schmidt);
/// a row that vanishes is replaced by a fixed vector orthogonalized again.
fn orthonormalize(x: &mut [f64], k: usize, m: usize) {
    for v in 0..k {
        for attempt in 0..2 {
            let (done, rest) = x.split_at_mut(v * m);
            let row = &mut rest[..m];
            for w in 0..v {
                let prev = &done[w * m..(w + 1) * m];
                let dot: f64 = prev.iter().zip(row.iter()).map(|(a, b)| a * b).sum();
                for (r, p) in row.iter_mut().zip(prev) {
                    *r -= dot * p;
                }
            }
            let norm = row.iter().map(|a| a * a).sum::<f64>().sqrt();
            if norm > 0.0 && norm.is_finite() {
                for r in row.iter_mut() {
                    *r /= norm;
                }
                break;
            }
            if attempt == 0 {
                for (i, r) in row.iter_mut().enumerate() {
                    *r = 1.0 + ((i * 7 + v * 3) % 11) as f64 * 0.1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_finds_the_smallest_eigenvalue() {
        // Eigenvalues of [[2, 1], [1, 2]]: 1 and 3.
        let mut a = [2.0, 1.0, 1.0, 2.0];
        assert!((smallest_eigenvalue(&mut a, 2) - 1.0).abs() < 1e-14);
        let mut b = [5.0];
        assert_eq!(smallest_eigenvalue(&mut b, 1), 5.0);
        // diag(4, 1, 9) rotated.
        let mut c = [4.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 9.0];
        assert!((smallest_eigenvalue(&mut c, 3) - 1.0).abs() < 1e-14);
    }

    #[test]
    fn gram_schmidt_orthonormalizes() {
        let mut x = [3.0, 4.0, 0.0, 1.0, 1.0, 1.0];
        orthonormalize(&mut x, 2, 3);
        let dot: f64 = (0..3).map(|i| x[i] * x[3 + i]).sum();
        assert!(dot.abs() < 1e-15);
        let n0: f64 = (0..3).map(|i| x[i] * x[i]).sum();
        assert!((n0 - 1.0).abs() < 1e-15);
    }
}
