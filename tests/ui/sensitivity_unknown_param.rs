// A sensitivity asked of a name that is not a param: the error says what
// the name is and lists the model's params; the type is still generated
// (without sensitivities), so code naming it adds no follow-on error.
kinema::mechanism!(file = "../../models/slider_crank.kin", sensitivity = ["l1", "slider"]);

fn main() {
    let _ = SliderCrank::default().solver(kinema::Options::default());
}
