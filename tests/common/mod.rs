//! Closed forms shared by the root crate's forward-dynamics tests.

/// K(k) and sn(u, k) by the arithmetic–geometric mean (descending Landen
/// transformation, Abramowitz & Stegun 16.4): the pendulum's elliptic
/// solution in tests/forward.rs and tests/iftomm.rs.
pub fn jacobi_sn(u: f64, k: f64) -> (f64, f64) {
    let mut a = vec![1.0_f64];
    let mut c = vec![k];
    let mut b = (1.0 - k * k).sqrt();
    while c.last().is_some_and(|c| c.abs() > 1e-17) && a.len() < 40 {
        let an = a[a.len() - 1];
        let (a1, b1, c1) = ((an + b) / 2.0, (an * b).sqrt(), (an - b) / 2.0);
        a.push(a1);
        c.push(c1);
        b = b1;
    }
    let nn = a.len() - 1;
    let big_k = std::f64::consts::PI / (2.0 * a[nn]);
    let mut phi = 2f64.powi(nn as i32) * a[nn] * u;
    for i in (1..=nn).rev() {
        phi = (phi + (c[i] / a[i] * phi.sin()).asin()) / 2.0;
    }
    (big_k, phi.sin())
}
