// Not under the crate root: found next to this file, as include_str! would.
kinema::mechanism!(file = "bad_model.kin");

fn main() {}
