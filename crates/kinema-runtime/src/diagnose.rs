//! Rank-revealing diagnosis of a singular Φ_q (error path only; allocates).

use nalgebra::{DMatrix, SVD};

use crate::error::Dependency;
use crate::system::System;

/// Largest n for which the dense SVD is run (≈ 1 s at n = 600).
pub(crate) const MAX_DENSE_DIAGNOSIS: usize = 600;

/// A component of a unit singular vector at least this large names its
/// equation or coordinate.
const INVOLVED: f64 = 1e-6;

/// Explains a singular Φ_q (nonzeros `values` in the system's pattern order):
/// which equations are dependent, which are redundant, which coordinates
/// move freely. See [`Dependency`] for the maths.
pub(crate) fn dependency<S: System + ?Sized>(
    system: &S,
    values: &[f64],
    singular_tolerance: f64,
) -> Dependency {
    let n = system.len();
    let mut dep = Dependency {
        rank: None,
        condition: None,
        dim: n,
        equations: Vec::new(),
        redundant: Vec::new(),
        coordinates: Vec::new(),
    };
    if n == 0 || n > MAX_DENSE_DIAGNOSIS || values.iter().any(|v| !v.is_finite()) {
        return dep;
    }
    let mut a = DMatrix::<f64>::zeros(n, n);
    for (&(r, c), &v) in system.jacobian_pattern().iter().zip(values) {
        if let Some(slot) = a.get_mut((r as usize, c as usize)) {
            *slot = v;
        }
    }
    let Some(svd) = SVD::try_new(a, true, true, f64::EPSILON, 200 * n + 1000) else {
        return dep;
    };
    let (Some(u), Some(v_t)) = (&svd.u, &svd.v_t) else {
        return dep;
    };
    let sigma = &svd.singular_values;
    let sigma_max = sigma.max();
    dep.condition = Some(sigma_max / sigma.min());
    let cutoff = (10.0 * singular_tolerance).max(n as f64 * f64::EPSILON) * sigma_max;
    let smallest = sigma.imin();
    let null: Vec<usize> = (0..n)
        .filter(|&k| sigma[k] <= cutoff || k == smallest)
        .collect();
    dep.rank = Some(n - null.len());

    let mut eq_involved = vec![false; n];
    let mut coord_involved = vec![false; n];
    for &k in &null {
        for i in 0..n {
            eq_involved[i] |= u[(i, k)].abs() >= INVOLVED;
            coord_involved[i] |= v_t[(k, i)].abs() >= INVOLVED;
        }
    }
    dep.equations = names(system, &eq_involved, S::equation_name);
    dep.coordinates = names(system, &coord_involved, S::coordinate_name);

    // Redundant equations: Gaussian elimination on the null vectors (rows of
    // W = [u_k]ᵀ). Each step picks, among the entries at least 1e-3 of the
    // largest remaining one, the last-written equation; it is called
    // redundant (the others of its combination can replace it), and is
    // eliminated from the remaining null vectors.
    let mut w: Vec<Vec<f64>> = null
        .iter()
        .map(|&k| (0..n).map(|i| u[(i, k)]).collect())
        .collect();
    let mut picked = Vec::with_capacity(w.len());
    for r in 0..w.len() {
        let largest = w[r..].iter().flatten().fold(0.0_f64, |m, x| m.max(x.abs()));
        if largest == 0.0 {
            break;
        }
        let mut choice = None;
        for (s, row) in w.iter().enumerate().skip(r) {
            for (i, &x) in row.iter().enumerate() {
                let better = match choice {
                    None => true,
                    Some((_, j, y)) => i > j || (i == j && x.abs() > f64::abs(y)),
                };
                if x.abs() >= 1e-3 * largest && better {
                    choice = Some((s, i, x));
                }
            }
        }
        let Some((s, i, _)) = choice else { break };
        w.swap(r, s);
        let pivot_row = w[r].clone();
        for row in w.iter_mut().skip(r + 1) {
            let f = row[i] / pivot_row[i];
            for (x, p) in row.iter_mut().zip(&pivot_row) {
                *x -= f * p;
            }
        }
        picked.push(i);
    }
    picked.sort_unstable();
    dep.redundant = picked
        .iter()
        .map(|&i| system.equation_name(i).to_owned())
        .collect();
    dep
}

fn names<S: System + ?Sized>(
    system: &S,
    mask: &[bool],
    name: fn(&S, usize) -> &str,
) -> Vec<String> {
    mask.iter()
        .enumerate()
        .filter(|&(_, &m)| m)
        .map(|(i, _)| name(system, i).to_owned())
        .collect()
}
