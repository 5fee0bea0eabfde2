//! Helpers shared by the integration tests.
#![allow(dead_code, reason = "each test file uses a different subset")]

/// Fails with a message naming the first component of `got` farther than
/// `tol` from `want`.
pub fn assert_close(what: &str, got: &[f64], want: &[f64], tol: f64) {
    assert_eq!(got.len(), want.len(), "{what}: lengths differ");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= tol,
            "{what}[{i}]: got {g}, want {w} (|Δ| = {:e} > {tol:e})",
            (g - w).abs()
        );
    }
}

/// The benchmark time grid t_k = k/1000, k = 0…1000.
pub fn benchmark_grid() -> Vec<f64> {
    (0..=1000).map(|k| k as f64 / 1000.0).collect()
}
