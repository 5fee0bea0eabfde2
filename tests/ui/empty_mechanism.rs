kinema::mechanism! {
    mechanism Empty { }
}

fn main() {}
