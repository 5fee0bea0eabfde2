kinema::mechanism! {
    mechanism M {
        gravity = (0, -9.81);
        body crank { guess: (0.5, 0, 0), mass: 2, inertia: 0.1 }
        body rod { guess: (1.5, 0, 0) }
        joint pin: revolute(ground(0, 0), crank(-0.5, 0));
        joint elbow: revolute(crank(0.5, 0), rod(-0.5, 0));
        constraint level: rod.y == 0;
        driver swing: crank.phi == t;
    }
}

fn main() {}
