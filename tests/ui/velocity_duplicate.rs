kinema::mechanism! {
    mechanism M {
        body bar { guess: (1, 0, 0), mass: 2, inertia: 0.3, velocity: (0, 1, 1), velocity: (0, 2, 2) }
        gravity = (0, -9.81);
        joint pivot: revolute(bar(-1, 0), ground(0, 0));
    }
}

fn main() {}
