//! `kinema::mechanism!`: declare a planar mechanism, get a specialized solver.
//!
//! A thin shell: every piece of work (parsing, checking, derivation, code
//! generation, error reporting) lives in `kinema-model` and `kinema-codegen`,
//! where it is tested without rustc. Use it through the facade crate:
//! `kinema::mechanism! { mechanism SliderCrank { … } }` or
//! `kinema::mechanism!(file = "models/slider_crank.kin")`.

use proc_macro::TokenStream;

/// Declares a mechanism in kinema's model language and expands to a struct
/// named after it that implements the runtime's `System` trait.
///
/// ```ignore
/// kinema::mechanism! {
///     mechanism Pendulum {
///         param l = 1.0;
///         body bar { guess: (0.5, 0.8, 1.0) }
///         joint pin: revolute(ground(0, 0), bar(-l, 0));
///         driver swing: bar.phi == 4 * t * t;
///     }
/// }
/// ```
///
/// or, for a model file relative to the crate root (edits trigger a rebuild,
/// errors point into the file):
///
/// ```ignore
/// kinema::mechanism!(file = "models/pendulum.kin");
/// ```
///
/// With `sensitivity = ["l1", "l2"]` (or `sensitivity = all`) after the
/// file, the generated type also evaluates those params' sensitivities
/// (`kinema::SensitivitySystem`, `Solver::sensitivities`) and has a
/// `PARAM_…` constant per param column:
///
/// ```ignore
/// kinema::mechanism!(file = "models/slider_crank.kin", sensitivity = ["l1", "l2"]);
/// ```
#[proc_macro]
pub fn mechanism(input: TokenStream) -> TokenStream {
    kinema_codegen::expand_macro(input.into()).into()
}
