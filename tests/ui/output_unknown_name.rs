kinema::mechanism! {
    mechanism M {
        body bar { guess: (0.5, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-0.5, 0));
        driver swing: bar.phi == t;
        output height: bar.y + offset;
    }
}

fn main() {}
