//! Bounds on the fitted unknowns, kept by a change of variables.
//!
//! MINPACK's Levenberg–Marquardt has no bounds. As MINUIT and lmfit do,
//! each bounded unknown p is fitted through an internal u with
//! p = lo + (hi − lo)(sin u + 1)/2 (both bounds), p = lo − 1 + √(u² + 1)
//! (a lower bound) or p = hi + 1 − √(u² + 1) (an upper one): every u is a
//! p within its bounds, and the Jacobian is multiplied by dp/du (chain
//! rule, exact). A start is placed strictly inside its bounds, where dp/du
//! is not zero.

use std::fmt;
use std::str::FromStr;

/// A bound on one varied param: `name=lo:hi`, either side may be empty
/// (`l1=0:` bounds from below only).
#[derive(Clone, Debug, PartialEq)]
pub struct Bound {
    /// The param.
    pub name: String,
    /// The lower bound, if any.
    pub lo: Option<f64>,
    /// The upper bound, if any.
    pub hi: Option<f64>,
}

impl FromStr for Bound {
    type Err = String;

    /// `name=lo:hi` (`name=lo:`, `name=:hi`).
    fn from_str(s: &str) -> Result<Bound, String> {
        let (name, range) = s
            .split_once('=')
            .ok_or_else(|| format!("`{s}` is not a bound: write NAME=LO:HI (e.g. l1=0.5:2)"))?;
        let name = name.trim();
        if name.is_empty() {
            return Err(format!("`{s}`: the bound names no param"));
        }
        let (lo, hi) = range
            .split_once(':')
            .ok_or_else(|| format!("`{s}` is not a bound: write {name}=LO:HI"))?;
        let side = |text: &str, which: &str| -> Result<Option<f64>, String> {
            let text = text.trim();
            if text.is_empty() {
                return Ok(None);
            }
            match text.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Some(v)),
                _ => Err(format!(
                    "the {which} bound of {name}, `{text}`, is not a finite number"
                )),
            }
        };
        let bound = Bound {
            name: name.to_owned(),
            lo: side(lo, "lower")?,
            hi: side(hi, "upper")?,
        };
        if let (Some(lo), Some(hi)) = (bound.lo, bound.hi)
            && lo >= hi
        {
            return Err(format!(
                "the bounds of {name} are empty: {lo} is not below {hi}"
            ));
        }
        Ok(bound)
    }
}

impl fmt::Display for Bound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let side = |v: Option<f64>| v.map_or_else(String::new, |v| v.to_string());
        write!(f, "{}={}:{}", self.name, side(self.lo), side(self.hi))
    }
}

/// One unknown's change of variables (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Map {
    Free,
    /// p = exp(u): a positive quantity (a gap between two targets' times)
    /// whose slope never vanishes at a finite u.
    Positive,
    Both(f64, f64),
    Lower(f64),
    Upper(f64),
}

impl Map {
    pub(crate) fn new(lo: Option<f64>, hi: Option<f64>) -> Map {
        match (lo, hi) {
            (Some(lo), Some(hi)) => Map::Both(lo, hi),
            (Some(lo), None) => Map::Lower(lo),
            (None, Some(hi)) => Map::Upper(hi),
            (None, None) => Map::Free,
        }
    }

    /// Whether `p` is within the bounds.
    pub(crate) fn contains(self, p: f64) -> bool {
        match self {
            Map::Free => true,
            Map::Positive => p > 0.0,
            Map::Both(lo, hi) => (lo..=hi).contains(&p),
            Map::Lower(lo) => p >= lo,
            Map::Upper(hi) => p <= hi,
        }
    }

    /// p of the internal u.
    pub(crate) fn outer(self, u: f64) -> f64 {
        match self {
            Map::Free => u,
            Map::Positive => u.exp(),
            Map::Both(lo, hi) => lo + (hi - lo) * 0.5 * (u.sin() + 1.0),
            Map::Lower(lo) => lo - 1.0 + u.hypot(1.0),
            Map::Upper(hi) => hi + 1.0 - u.hypot(1.0),
        }
    }

    /// dp/du at u.
    pub(crate) fn slope(self, u: f64) -> f64 {
        match self {
            Map::Free => 1.0,
            Map::Positive => u.exp(),
            Map::Both(lo, hi) => (hi - lo) * 0.5 * u.cos(),
            Map::Lower(_) => u / u.hypot(1.0),
            Map::Upper(_) => -u / u.hypot(1.0),
        }
    }

    /// The internal u of a p, moved strictly inside the bounds (by a
    /// millionth of their width, or of 1 for a one-sided bound) so that
    /// dp/du is not zero there.
    pub(crate) fn inner(self, p: f64) -> f64 {
        const INSIDE: f64 = 1e-6;
        match self {
            Map::Free => p,
            Map::Positive => p.max(f64::MIN_POSITIVE).ln(),
            Map::Both(lo, hi) => {
                let s = (2.0 * (p - lo) / (hi - lo) - 1.0).clamp(-1.0 + INSIDE, 1.0 - INSIDE);
                s.asin()
            }
            Map::Lower(lo) => {
                let d = (p - lo).max(INSIDE) + 1.0;
                (d * d - 1.0).sqrt()
            }
            Map::Upper(hi) => {
                let d = (hi - p).max(INSIDE) + 1.0;
                (d * d - 1.0).sqrt()
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests: a failure should stop the test
mod tests {
    use super::*;

    #[test]
    fn parses_bounds_and_refuses_bad_ones() {
        let b: Bound = "l1=0.5:2".parse().unwrap();
        assert_eq!((b.lo, b.hi), (Some(0.5), Some(2.0)));
        let b: Bound = "l1=:2".parse().unwrap();
        assert_eq!((b.lo, b.hi), (None, Some(2.0)));
        assert!("l1".parse::<Bound>().unwrap_err().contains("NAME=LO:HI"));
        assert!("l1=2:1".parse::<Bound>().unwrap_err().contains("empty"));
        assert!("l1=a:1".parse::<Bound>().unwrap_err().contains("`a`"));
        assert!("l1=nan:1".parse::<Bound>().unwrap_err().contains("finite"));
    }

    #[test]
    fn the_maps_round_trip_and_their_slopes_are_exact() {
        for map in [
            Map::Free,
            Map::Positive,
            Map::Both(-1.0, 3.0),
            Map::Lower(0.5),
            Map::Upper(-2.0),
        ] {
            for p in [-2.5, -0.7, 0.6, 1.9, 2.9] {
                if !map.contains(p) {
                    continue;
                }
                let u = map.inner(p);
                assert!((map.outer(u) - p).abs() < 1e-5, "{map:?} {p}");
                let h = 1e-6;
                let fd = (map.outer(u + h) - map.outer(u - h)) / (2.0 * h);
                assert!((fd - map.slope(u)).abs() < 1e-8, "{map:?} {p}");
                assert!(map.slope(u) != 0.0);
            }
            for u in [-7.0, -1.0, 0.3, 12.0] {
                assert!(map.contains(map.outer(u)));
            }
        }
    }
}
