//! The transposed solve Aᵀ x = b of every runtime LU, on the factorization
//! made for A x = b: through the pivoting kernel (first factorization) and
//! through the recorded replay (later ones), against the product Aᵀ x.

use kinema_runtime::linalg::{DenseLu, DynDenseLu, LinalgError, LinearSolver, SparseLu};

/// A nonsymmetric 6 × 6 matrix with zeros on the diagonal (pivoting
/// needed) and a fixed sparse pattern; `scale` changes the values.
fn example(scale: f64) -> (Vec<(u32, u32)>, Vec<f64>) {
    let n = 6;
    let mut pattern = Vec::new();
    let mut values = Vec::new();
    for i in 0..n {
        for j in 0..n {
            if (i + 2 * j) % 3 != 0 || i == (j + 1) % n {
                pattern.push((i as u32, j as u32));
                values.push(
                    scale * (1.0 + ((3 * i + 5 * j) % 7) as f64) * if j > i { -1.0 } else { 0.7 },
                );
            }
        }
    }
    (pattern, values)
}

fn check<L: LinearSolver>(name: &str) -> Result<(), LinalgError> {
    let n = 6;
    let (pattern, _) = example(1.0);
    let mut lu = L::analyze(n, &pattern)?;
    for round in 0..3 {
        let (_, values) = example(1.0 + 0.25 * f64::from(round));
        lu.factor(&values, 1e-14)?;
        let x: Vec<f64> = (0..n).map(|i| (i as f64 + 1.0).sin()).collect();
        // b = Aᵀ x.
        let mut b = vec![0.0; n];
        for (&(r, c), v) in pattern.iter().zip(&values) {
            b[c as usize] += v * x[r as usize];
        }
        lu.solve_transpose_in_place(&mut b)?;
        for (got, want) in b.iter().zip(&x) {
            assert!(
                (got - want).abs() < 1e-12,
                "{name} round {round}: {got} vs {want}"
            );
        }
        // And the ordinary solve still works on the same factors.
        let mut b = vec![0.0; n];
        for (&(r, c), v) in pattern.iter().zip(&values) {
            b[r as usize] += v * x[c as usize];
        }
        lu.solve_in_place(&mut b)?;
        for (got, want) in b.iter().zip(&x) {
            assert!(
                (got - want).abs() < 1e-12,
                "{name} round {round}: {got} vs {want}"
            );
        }
    }
    Ok(())
}

#[test]
fn every_lu_solves_the_transposed_system() -> Result<(), LinalgError> {
    check::<DenseLu<6>>("DenseLu")?;
    check::<DynDenseLu>("DynDenseLu")?;
    check::<SparseLu>("SparseLu")?;
    check::<kinema_runtime::linalg::Auto>("Auto")
}

#[test]
fn transposed_solve_before_factoring_is_an_error() -> Result<(), LinalgError> {
    let (pattern, _) = example(1.0);
    let mut lu = DynDenseLu::analyze(6, &pattern)?;
    let mut b = vec![1.0; 6];
    assert!(matches!(
        lu.solve_transpose_in_place(&mut b),
        Err(LinalgError::NotFactored)
    ));
    Ok(())
}
