kinema::mechanism! {
    mechanism M {
        body bar { guess: (0.5, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-0.5, 0));
        constraint swing: bar.phi == 2 * t;
    }
}

fn main() {}
