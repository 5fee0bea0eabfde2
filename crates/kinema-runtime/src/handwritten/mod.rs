//! Hand-written reference mechanisms of the project benchmarks
//! (`BENCHMARKS.md`, `benches/peers/README.md`): exactly the peers' frames, equation
//! order and initial guesses.
//!
//! They are the baselines that generated code and the tape interpreter are
//! tested and measured against, written the way generated code should look:
//! straight-line, each sine and cosine computed once, no allocation.
//! Enabled by the cargo feature `handwritten`.
//!
//! Conventions (Haug, absolute coordinates): body i has (x_i, y_i, φ_i) at
//! 3i, 3i + 1, 3i + 2; A(φ) = [[cos φ, −sin φ], [sin φ, cos φ]]; a revolute
//! between P on i and Q on j is r_i + A_i s′_P − r_j − A_j s′_Q = 0 (x row,
//! then y row) with γ = A_i s′_P φ̇_i² − A_j s′_Q φ̇_j²; an angle driver
//! φ_i − f(t) = 0 has ν = f′(t), γ = f″(t).

mod chain;
mod four_bar;
mod slider_crank;

pub use chain::{Chain, Drivers};
pub use four_bar::FourBar;
pub use slider_crank::SliderCrank;

/// The `System` trait's rule for slices of the wrong length: `true` when
/// every input has length `n` and every output the length paired with it;
/// otherwise every output is filled with NaN (never a panic).
fn sized(n: usize, inputs: &[&[f64]], outputs: &mut [(&mut [f64], usize)]) -> bool {
    let ok = inputs.iter().all(|i| i.len() == n) && outputs.iter().all(|(o, len)| o.len() == *len);
    if !ok {
        for (o, _) in outputs.iter_mut() {
            o.fill(f64::NAN);
        }
    }
    ok
}
