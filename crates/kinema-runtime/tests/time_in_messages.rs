//! Times in run-time error messages print short: the shortest form that
//! reads back as the same number, in exponent form when tiny or huge.

use kinema_runtime::{Error, Quantity, Time};

#[test]
fn times_print_short_and_read_back_exactly() {
    for t in [
        0.35,
        1.0,
        0.0,
        1e-300,
        5e-324,
        1.7e308,
        0.1 + 0.2,
        12345.678,
        -2.5e-7,
    ] {
        let s = Time(t).to_string();
        assert!(s.len() <= 24, "{t:?} printed as {s}");
        assert_eq!(s.parse::<f64>().ok(), Some(t), "{s} does not read back");
    }
    assert_eq!(Time(1e-300).to_string(), "1e-300");
    assert_eq!(Time(0.35).to_string(), "0.35");
    let e = Error::NonFinite {
        t: 1e-300,
        quantity: Quantity::Gamma,
        name: "pin.x".to_owned(),
    };
    assert_eq!(e.to_string(), "non-finite γ at t = 1e-300: pin.x");
    let e = Error::NonIncreasingTime {
        index: 1,
        previous: 5e-324,
        t: 0.0,
    };
    assert_eq!(
        e.to_string(),
        "times must increase: t = 0 (time index 1) follows t = 5e-324"
    );
}
