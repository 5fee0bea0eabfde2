//! What a user does to pin a mechanism's maths: snapshot the derivation the
//! generated type carries. For the benchmark slider-crank the text must also
//! be exactly what kinema-model renders for the same file.

mod generated {
    kinema::mechanism!(file = "models/slider_crank.kin");
}
use generated::SliderCrank;

#[test]
fn slider_crank_derivation() {
    insta::assert_snapshot!(SliderCrank::derivation());
}

#[test]
fn generated_derivation_is_the_models_rendering() {
    let model = kinema::Model::from_file("models/slider_crank.kin").expect("model derives");
    assert_eq!(SliderCrank::derivation(), model.derivation_text());
}
