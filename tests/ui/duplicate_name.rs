kinema::mechanism! {
    mechanism M {
        body bar { guess: (0.5, 0, 0) }
        body bar { guess: (1.5, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-0.5, 0));
        driver swing: bar.phi == t;
    }
}

fn main() {}
