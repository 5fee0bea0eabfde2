kinema::mechanism! {
    mechanism M {
        body bar { guess: (0.5, 0, 0), mass: 1, inertia: 0.1 }
        joint pin: revolute(ground(0, 0), bar(-0.5, 0));
        driver swing: bar.phi == t;
        force push: point_force(bra(0.5, 0), (0, -1));
    }
}

fn main() {}
