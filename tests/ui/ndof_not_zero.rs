kinema::mechanism! {
    mechanism M {
        body crank { guess: (0.1, 0.1, 0.8) }
        body rod { guess: (0.7, 0.1, -0.2) }
        joint pivot: revolute(ground(0, 0), crank(-0.15, 0));
        joint pin: revolute(crank(0.15, 0), rod(-0.5, 0));
        driver spin: crank.phi == t;
    }
}

fn main() {}
