kinema::mechanism! {
    mechanism M {
        body crank { guess: (0.5, 0, 0), velocity: (0, 1, 2) }
        joint pin: revolute(ground(0, 0), crank(-0.5, 0));
        driver swing: crank.phi == t;
    }
}

fn main() {}
