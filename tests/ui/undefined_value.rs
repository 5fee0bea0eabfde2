kinema::mechanism! {
    mechanism M {
        body bar { guess: (0.5, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-0.5, 0));
        driver swing: bar.phi == t + (bar.x - bar.x) / (bar.y - bar.y);
    }
}

kinema::mechanism! {
    mechanism N {
        body bar { guess: (0.5, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-0.5, 0));
        driver swing: bar.phi == t + 0 * (1e308 * 1e308);
    }
}

kinema::mechanism! {
    mechanism P {
        body bar { guess: (0.5, 0, 0) }
        joint pin: revolute(ground(0, 0), bar(-0.5, 0));
        driver swing: bar.phi == t + 1 / (1e-320 * (1 + t));
    }
}

fn main() {}
