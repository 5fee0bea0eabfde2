kinema::mechanism! {
    mechanism M {
        body bar { guess: (0.5, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-l, 0));
        driver swing: bar.phi == atan(t, 1);
    }
}

fn main() {}
