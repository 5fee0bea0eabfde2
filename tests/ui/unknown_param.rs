kinema::mechanism! {
    mechanism M {
        param l = 1.0;
        body bar { guess: (0.5, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-len / 2, 0));
        driver swing: bar.phi == t;
    }
}

fn main() {}
