//! The serial chain with params, for the sensitivity benchmark
//! (benches/sensitivity.rs): `kinema_model::chain::chain_kin(n)` with its
//! link length a param `l` (1) and its drivers' amplitude a param `a`
//! (0.3), the same mechanism at the declared values. Shared by build.rs
//! (which generates its code) and the library (its tape and JIT).

/// [`kinema_model::chain::chain_kin`]`(n)` with params `l` and `a`.
#[must_use]
pub fn chain_kin_params(n: usize) -> String {
    let text = kinema_model::chain::chain_kin(n);
    let mut out = String::with_capacity(text.len() + 64);
    for line in text.lines() {
        let line = line
            .replace("(-0.5, 0)", "(-l / 2, 0)")
            .replace("(0.5, 0)", "(l / 2, 0)")
            .replace("0.3 * sin(", "a * sin(");
        out.push_str(&line);
        out.push('\n');
        if line.starts_with("mechanism ") {
            out.push_str("    /// link length\n    param l = 1.0;\n");
            out.push_str("    /// drivers' amplitude\n    param a = 0.3;\n");
        }
    }
    out
}
