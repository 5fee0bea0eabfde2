kinema::mechanism! {
    mechanism ScotchYoke {
        param r = 0.3;
        body crank { guess: (0, 0, 0) }
        body yoke { guess: (r, 0, 0) }
        coord s;
        point crank.pin = (r, 0);
        curve yoke.slot(u) = (0, u);
        joint pivot: revolute(crank(0, 0), ground(0, 0));
        joint guide: translational(ground(0, 0), (1, 0), yoke(0, 0), (1, 0));
        joint pin: point_follower(crank.pin, crank.slot, s);
        driver turn: abs_angle(crank, t);
    }
}

fn main() {}
