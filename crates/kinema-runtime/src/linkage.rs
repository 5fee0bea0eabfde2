//! Closed-form positions of linkages: [`Linkage`].
//!
//! A mechanism made only of revolute joints and driven angles usually
//! decomposes into a sequence of groups, each placed in closed form from
//! the bodies placed before it (Assur's decomposition):
//!
//! * a **crank**: a body whose angle is driven (absolutely, or relative to
//!   a placed body), pinned to a placed body: its position follows from
//!   the pin and the angle;
//! * an **RRR dyad**: two bodies pinned to each other, each pinned to a
//!   placed body: the pin between them is an intersection of two circles,
//!   on the branch the mechanism is on, and each body's angle follows from
//!   where its pins are.
//!
//! [`Linkage::plan`] finds such a sequence using every joint and driven
//! angle exactly once, or says there is none (a slider, a user-written
//! equation, a structure that is not of this kind: Newton–Raphson solves
//! those). [`Linkage::place`] then computes q at a time with no iteration
//! and reports how far each dyad is from its singular configuration (its
//! two links in line), so that the [`Solver`](crate::Solver) can leave the
//! neighbourhood of a singular configuration to Newton and its monitor.

use std::f64::consts::PI;

/// A revolute joint: the point at local coordinates `local[k]` on
/// `bodies[k]` (a body's index; `None` is ground, whose local coordinates
/// are global) is the same for k = 0 and 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pin {
    /// The two bodies (`None`: ground).
    pub bodies: [Option<u32>; 2],
    /// The joint's local coordinates on each.
    pub local: [[f64; 2]; 2],
}

/// A driven angle: φ of `body` is the angle given at each time (see
/// [`System::linkage_angles`](crate::System::linkage_angles)), plus φ of
/// `relative_to` when that is a body.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DrivenAngle {
    /// The driven body.
    pub body: u32,
    /// The body the angle is measured from (`None`: ground).
    pub relative_to: Option<u32>,
}

/// Where a placed point comes from: body `body` (`None`: ground) at local
/// coordinates `local`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Anchor {
    body: Option<u32>,
    local: [f64; 2],
}

/// One body of a dyad: pinned at `local` to the anchor, and at `local + u`
/// to the other body of the dyad.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Side {
    body: u32,
    anchor: Anchor,
    local: [f64; 2],
    u: [f64; 2],
    /// |u|².
    length2: f64,
    /// 1/|u|².
    inv_length2: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Stage {
    /// `body` at angle `angle` (plus φ of `relative_to`), pinned at `local`
    /// to the anchor.
    Crank {
        body: u32,
        angle: u32,
        relative_to: Option<u32>,
        anchor: Anchor,
        local: [f64; 2],
    },
    /// Two bodies pinned to each other (branch `branch`); `inv_lengths`
    /// is 1/(|u1| |u2|); the links are in line where φ2 − φ1 + `offset`
    /// is a multiple of π (`offset` = angle of u2 − angle of u1).
    Dyad {
        sides: [Side; 2],
        branch: u32,
        inv_lengths: f64,
        offset: f64,
    },
}

/// A closed-form position solution: the order in which a linkage's bodies
/// are placed (see the [module](self) documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Linkage {
    bodies: usize,
    angles: usize,
    dyads: usize,
    stages: Vec<Stage>,
}

/// The scratch of [`Linkage::place`] and [`Linkage::read_branches`]: each
/// body's cos φ and sin φ.
pub type Rotations = [[f64; 2]];

impl Linkage {
    /// The decomposition of `bodies` bodies joined by `pins` and driven by
    /// `angles` into cranks and dyads, each joint and driven angle used
    /// once; `None` if there is none, or if a dyad's body has its two pins
    /// at the same point (its angle would be undetermined).
    #[must_use]
    pub fn plan(bodies: usize, pins: &[Pin], angles: &[DrivenAngle]) -> Option<Linkage> {
        let in_range = |b: Option<u32>| b.is_none_or(|b| (b as usize) < bodies);
        let pins_ok = pins.iter().all(|p| {
            let [a, b] = p.bodies;
            in_range(a) && in_range(b) && a != b && p.local.iter().flatten().all(|v| v.is_finite())
        });
        let angles_ok = angles.iter().all(|a| {
            in_range(Some(a.body)) && in_range(a.relative_to) && a.relative_to != Some(a.body)
        });
        if !(pins_ok && angles_ok) {
            return None;
        }
        let mut of_body: Vec<Vec<u32>> = vec![Vec::new(); bodies];
        for (k, p) in pins.iter().enumerate() {
            for b in p.bodies.into_iter().flatten() {
                of_body[b as usize].push(k as u32);
            }
        }
        let mut driven: Vec<Option<u32>> = vec![None; bodies];
        for (k, a) in angles.iter().enumerate() {
            if driven[a.body as usize].replace(k as u32).is_some() {
                // Two angles on one body: redundant or contradictory.
                return None;
            }
        }
        let mut planner = Planner {
            pins,
            of_body: &of_body,
            placed: vec![false; bodies],
            used: vec![false; pins.len()],
        };
        // A worklist: each body is examined again only when a body it is
        // pinned to (or whose angle its own is measured from) is placed,
        // so planning is linear in the joints whatever the declaration
        // order.
        let mut relatives: Vec<Vec<u32>> = vec![Vec::new(); bodies];
        for a in angles {
            if let Some(m) = a.relative_to {
                relatives[m as usize].push(a.body);
            }
        }
        let mut queue: std::collections::VecDeque<u32> = (0..bodies as u32).collect();
        let mut queued = vec![true; bodies];
        let mut stages = Vec::new();
        let mut dyads = 0;
        while let Some(b) = queue.pop_front() {
            queued[b as usize] = false;
            if planner.placed[b as usize] {
                continue;
            }
            let placed: [Option<u32>; 2] = if let Some(k) = driven[b as usize] {
                let relative_to = angles[k as usize].relative_to;
                let crank = planner
                    .known(relative_to)
                    .then(|| planner.pin_to_placed(b, None))
                    .flatten();
                let Some((pin, anchor, local)) = crank else {
                    continue;
                };
                planner.used[pin as usize] = true;
                stages.push(Stage::Crank {
                    body: b,
                    angle: k,
                    relative_to,
                    anchor,
                    local,
                });
                [Some(b), None]
            } else {
                let Some(sides) = planner.dyad(b, &driven)? else {
                    continue;
                };
                stages.push(Stage::Dyad {
                    sides,
                    branch: dyads,
                    inv_lengths: 1.0 / (sides[0].length2 * sides[1].length2).sqrt(),
                    offset: sides[1].u[1].atan2(sides[1].u[0]) - sides[0].u[1].atan2(sides[0].u[0]),
                });
                dyads += 1;
                [Some(sides[0].body), Some(sides[1].body)]
            };
            for p in placed.into_iter().flatten() {
                planner.placed[p as usize] = true;
                let pinned = of_body[p as usize]
                    .iter()
                    .filter_map(|&k| planner.ends(k, p).0);
                for next in pinned.chain(relatives[p as usize].iter().copied()) {
                    if !planner.placed[next as usize] && !queued[next as usize] {
                        queued[next as usize] = true;
                        queue.push_back(next);
                    }
                }
            }
        }
        let complete = planner.placed.iter().all(|&p| p) && planner.used.iter().all(|&u| u);
        complete.then_some(Linkage {
            bodies,
            angles: angles.len(),
            dyads: dyads as usize,
            stages,
        })
    }

    /// Number of bodies (q has three coordinates per body).
    #[must_use]
    pub fn bodies(&self) -> usize {
        self.bodies
    }

    /// Number of driven angles (the length of [`place`](Self::place)'s
    /// `angles`).
    #[must_use]
    pub fn angles(&self) -> usize {
        self.angles
    }

    /// Number of dyads (the length of the branches).
    #[must_use]
    pub fn dyads(&self) -> usize {
        self.dyads
    }

    /// Whether configurations `a` and `b` lie on the same side of every
    /// dyad's singular configurations (its links in line): the links'
    /// relative angle in the same open interval between multiples of π.
    /// A closed-form placement never leaves its interval (its branch is
    /// fixed); the analytic continuation of the motion does where it
    /// passes a bifurcation, which a prediction of the motion shows.
    #[must_use]
    pub fn same_side(&self, a: &[f64], b: &[f64]) -> bool {
        let n = 3 * self.bodies;
        if a.len() != n || b.len() != n {
            return false;
        }
        self.stages.iter().all(|stage| match *stage {
            Stage::Crank { .. } => true,
            Stage::Dyad { sides, offset, .. } => {
                let (i, j) = (
                    3 * sides[0].body as usize + 2,
                    3 * sides[1].body as usize + 2,
                );
                let cell = |q: &[f64]| ((q[j] - q[i] + offset) / PI).floor();
                cell(a) == cell(b)
            }
        })
    }

    /// The branch of each dyad in configuration `q`: the side of the line
    /// through its two anchors on which the pin between its bodies lies
    /// (+1 to the left, −1 to the right, 0 on the line or not finite).
    /// `rot` holds a cos and sin per body. Lengths must be as
    /// [`place`](Self::place) states; nothing is written otherwise.
    pub fn read_branches(&self, q: &[f64], rot: &mut Rotations, branches: &mut [f64]) {
        if q.len() != 3 * self.bodies || rot.len() != self.bodies || branches.len() != self.dyads {
            return;
        }
        for (b, r) in rot.iter_mut().enumerate() {
            let (s, c) = q[3 * b + 2].sin_cos();
            *r = [c, s];
        }
        for stage in &self.stages {
            if let Stage::Dyad { sides, branch, .. } = stage {
                let p1 = at(q, rot, sides[0].anchor);
                let p2 = at(q, rot, sides[1].anchor);
                let (b, local, u) = (sides[0].body, sides[0].local, sides[0].u);
                let joint = at(
                    q,
                    rot,
                    Anchor {
                        body: Some(b),
                        local: [local[0] + u[0], local[1] + u[1]],
                    },
                );
                let d = [p2[0] - p1[0], p2[1] - p1[1]];
                let cross = d[0] * (joint[1] - p1[1]) - d[1] * (joint[0] - p1[0]);
                branches[*branch as usize] = if cross > 0.0 {
                    1.0
                } else if cross < 0.0 {
                    -1.0
                } else {
                    0.0
                };
            }
        }
    }

    /// Places every body at the driven `angles` (one per driven angle, in
    /// the order given to [`plan`](Self::plan)) on the dyads' `branches`,
    /// into `q`; each angle found from a direction is taken within π of
    /// its value in `previous` (the motion is continuous), whose cos and
    /// sin `rot` holds on entry (as [`read_branches`](Self::read_branches)
    /// or the last placement from `previous` leaves it) and the placed
    /// configuration's on return. Returns the
    /// smallest dyad margin: the sine of the angle between a dyad's two
    /// links at their common pin (1 with no dyad). 0 where a dyad cannot
    /// close (its anchors too far apart or too near), has no branch, or a
    /// value is not finite; then q and `rot` are incomplete. `rot` has one
    /// entry per body. Slices of other lengths than stated give 0 and
    /// write nothing.
    pub fn place(
        &self,
        angles: &[f64],
        previous: &[f64],
        branches: &[f64],
        rot: &mut Rotations,
        q: &mut [f64],
    ) -> f64 {
        let n = 3 * self.bodies;
        if angles.len() != self.angles
            || previous.len() != n
            || q.len() != n
            || branches.len() != self.dyads
            || rot.len() != self.bodies
        {
            return 0.0;
        }
        let mut margin: f64 = 1.0;
        for stage in &self.stages {
            match *stage {
                Stage::Crank {
                    body,
                    angle,
                    relative_to,
                    anchor,
                    local,
                } => {
                    let base = relative_to.map_or(0.0, |m| q[3 * m as usize + 2]);
                    let phi = base + angles[angle as usize];
                    let (s, c) = phi.sin_cos();
                    let pin = at(q, rot, anchor);
                    set(q, rot, body, pin, local, [c, s], phi);
                }
                Stage::Dyad {
                    sides,
                    branch,
                    inv_lengths,
                    ..
                } => {
                    let sigma = branches[branch as usize];
                    let p1 = at(q, rot, sides[0].anchor);
                    let p2 = at(q, rot, sides[1].anchor);
                    let d = [p2[0] - p1[0], p2[1] - p1[1]];
                    let dd = d[0] * d[0] + d[1] * d[1];
                    let inv_dd = 1.0 / dd;
                    let (l1, l2) = (sides[0].length2, sides[1].length2);
                    // The pin Q = P1 + a d + σ h R d, a and h as fractions
                    // of |d|: |Q − P1|² = l1, |Q − P2|² = l2.
                    let a = 0.5 * (l1 - l2 + dd) * inv_dd;
                    let h2 = l1 * inv_dd - a * a;
                    // False for NaN too (d = 0, a non-finite anchor).
                    if !(h2 > 0.0 && sigma != 0.0) {
                        return 0.0;
                    }
                    let h = sigma * h2.sqrt();
                    let joint = [p1[0] + a * d[0] - h * d[1], p1[1] + a * d[1] + h * d[0]];
                    // sin of the angle at Q = |d| h / (|u1| |u2|).
                    margin = margin.min(dd * h.abs() * inv_lengths);
                    for (side, p) in sides.iter().zip([p1, p2]) {
                        // The rotation taking u (local) to Q − P (global).
                        let v = [joint[0] - p[0], joint[1] - p[1]];
                        let u = side.u;
                        let c = (u[0] * v[0] + u[1] * v[1]) * side.inv_length2;
                        let s = (u[0] * v[1] - u[1] * v[0]) * side.inv_length2;
                        let b = side.body as usize;
                        let phi = turned(previous[3 * b + 2], rot[b], [c, s]);
                        set(q, rot, side.body, p, side.local, [c, s], phi);
                    }
                }
            }
        }
        if margin.is_finite() { margin } else { 0.0 }
    }
}

/// The angle of rotation `to` (cos, sin) nearest `from`, whose rotation
/// is `from_cs`: `from` plus the angle between the two rotations, in
/// (−π, π]. For the small turns of a step (tan of at most 1/8, 7°) by
/// atan's series, the atan2 call otherwise.
#[inline]
fn turned(from: f64, from_cs: [f64; 2], to: [f64; 2]) -> f64 {
    let [c0, s0] = from_cs;
    let [c, s] = to;
    let cross = c0 * s - s0 * c;
    let dot = c0 * c + s0 * s;
    let x = cross / dot;
    let turn = if dot > 0.0 && x.abs() <= 0.125 {
        atan_small(x)
    } else {
        cross.atan2(dot)
    };
    from + turn
}

/// atan x for |x| ≤ 1/8 by its Taylor series x − x³/3 + x⁵/5 − … to the
/// term in x²³: the first one left out, x²⁵/25, is below 2⁻⁷⁶ |x|.
#[inline]
fn atan_small(x: f64) -> f64 {
    const C: [f64; 12] = [
        1.0,
        -1.0 / 3.0,
        1.0 / 5.0,
        -1.0 / 7.0,
        1.0 / 9.0,
        -1.0 / 11.0,
        1.0 / 13.0,
        -1.0 / 15.0,
        1.0 / 17.0,
        -1.0 / 19.0,
        1.0 / 21.0,
        -1.0 / 23.0,
    ];
    // x + x y (C1 + C2 y + …): the leading term exact, the rest (below
    // x/190) by Estrin's scheme in y = x², as pairs, pairs of pairs… (a
    // chain a quarter as long as Horner's).
    let y = x * x;
    let y2 = y * y;
    let y4 = y2 * y2;
    let y8 = y4 * y4;
    let p = |k: usize| C[k] + C[k + 1] * y;
    let low = (p(1) + p(3) * y2) + (p(5) + p(7) * y2) * y4;
    let high = p(9) + C[11] * y2;
    x + x * y * (low + high * y8)
}

/// The global position of an anchor, its body placed in `q` (cos and sin
/// of its angle in `rot`).
#[inline]
fn at(q: &[f64], rot: &Rotations, anchor: Anchor) -> [f64; 2] {
    let s = anchor.local;
    match anchor.body {
        None => s,
        Some(b) => {
            let b = b as usize;
            let [c, sn] = rot[b];
            [
                q[3 * b] + c * s[0] - sn * s[1],
                q[3 * b + 1] + sn * s[0] + c * s[1],
            ]
        }
    }
}

/// Places `body` at angle `phi` (cos and sin `cs`) with its point `local`
/// at `pin`.
#[inline]
fn set(
    q: &mut [f64],
    rot: &mut Rotations,
    body: u32,
    pin: [f64; 2],
    local: [f64; 2],
    cs: [f64; 2],
    phi: f64,
) {
    let b = body as usize;
    let [c, s] = cs;
    rot[b] = cs;
    q[3 * b] = pin[0] - (c * local[0] - s * local[1]);
    q[3 * b + 1] = pin[1] - (s * local[0] + c * local[1]);
    q[3 * b + 2] = phi;
}

/// The planner's bookkeeping: which bodies are placed, which pins used.
struct Planner<'a> {
    pins: &'a [Pin],
    of_body: &'a [Vec<u32>],
    placed: Vec<bool>,
    used: Vec<bool>,
}

impl Planner<'_> {
    fn known(&self, body: Option<u32>) -> bool {
        body.is_none_or(|b| self.placed[b as usize])
    }

    /// The other end of pin `k` from `body`, and the local coordinates on
    /// each: (other, other's local, body's local).
    fn ends(&self, k: u32, body: u32) -> (Option<u32>, [f64; 2], [f64; 2]) {
        let p = &self.pins[k as usize];
        if p.bodies[0] == Some(body) {
            (p.bodies[1], p.local[1], p.local[0])
        } else {
            (p.bodies[0], p.local[0], p.local[1])
        }
    }

    /// An unused pin of `body` to a placed body (or ground) other than
    /// `except`: the pin, its anchor, and its local coordinates on `body`.
    fn pin_to_placed(&self, body: u32, except: Option<u32>) -> Option<(u32, Anchor, [f64; 2])> {
        self.of_body[body as usize].iter().find_map(|&k| {
            let (other, at, local) = self.ends(k, body);
            (!self.used[k as usize] && Some(k) != except && self.known(other)).then_some((
                k,
                Anchor {
                    body: other,
                    local: at,
                },
                local,
            ))
        })
    }

    /// A dyad of `b1` (not placed, not driven) and a body pinned to it,
    /// marking its three pins used; `Ok(None)` if there is none, `None`
    /// (no closed form) if one has a body with both pins at one point.
    fn dyad(&mut self, b1: u32, driven: &[Option<u32>]) -> Option<Option<[Side; 2]>> {
        let Some((p1, a1, s1)) = self.pin_to_placed(b1, None) else {
            return Some(None);
        };
        for &k in &self.of_body[b1 as usize] {
            let (other, at_b2, at_b1) = self.ends(k, b1);
            let Some(b2) = other else { continue };
            if self.used[k as usize] || self.placed[b2 as usize] || driven[b2 as usize].is_some() {
                continue;
            }
            let Some((p2, a2, s2)) = self.pin_to_placed(b2, Some(k)) else {
                continue;
            };
            let side = |body, anchor, local: [f64; 2], joint: [f64; 2]| {
                let u = [joint[0] - local[0], joint[1] - local[1]];
                let length2 = u[0] * u[0] + u[1] * u[1];
                let inv_length2 = 1.0 / length2;
                (length2 > 0.0 && inv_length2.is_finite()).then_some(Side {
                    body,
                    anchor,
                    local,
                    u,
                    length2,
                    inv_length2,
                })
            };
            let sides = [side(b1, a1, s1, at_b1)?, side(b2, a2, s2, at_b2)?];
            for used in [p1, p2, k] {
                self.used[used as usize] = true;
            }
            return Some(Some(sides));
        }
        Some(None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A four-bar: crank 0 (length 1) about the origin, coupler 1 (3),
    /// rocker 2 (2) about (3, 0); the coupler's frame is at its crank pin,
    /// the rocker's at its ground pin.
    fn four_bar() -> (Vec<Pin>, Vec<DrivenAngle>) {
        let pin = |a: Option<u32>, sa: [f64; 2], b: Option<u32>, sb: [f64; 2]| Pin {
            bodies: [a, b],
            local: [sa, sb],
        };
        let pins = vec![
            pin(Some(0), [0.0, 0.0], None, [0.0, 0.0]),
            pin(Some(0), [1.0, 0.0], Some(1), [0.0, 0.0]),
            pin(Some(1), [3.0, 0.0], Some(2), [2.0, 0.0]),
            pin(Some(2), [0.0, 0.0], None, [3.0, 0.0]),
        ];
        let angles = vec![DrivenAngle {
            body: 0,
            relative_to: None,
        }];
        (pins, angles)
    }

    /// The largest gap between the two ends of any pin in `q`.
    fn gap(pins: &[Pin], q: &[f64]) -> f64 {
        let rot: Vec<[f64; 2]> = (0..q.len() / 3)
            .map(|b| {
                let (s, c) = q[3 * b + 2].sin_cos();
                [c, s]
            })
            .collect();
        pins.iter()
            .map(|p| {
                let e = |k: usize| {
                    at(
                        q,
                        &rot,
                        Anchor {
                            body: p.bodies[k],
                            local: p.local[k],
                        },
                    )
                };
                let (a, b) = (e(0), e(1));
                (a[0] - b[0]).abs().max((a[1] - b[1]).abs())
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_four_bar_is_a_crank_and_a_dyad_placed_on_either_branch() {
        let (pins, angles) = four_bar();
        let linkage = Linkage::plan(3, &pins, &angles).expect("decomposes");
        assert_eq!((linkage.angles(), linkage.dyads()), (1, 1));
        let mut rot = vec![[0.0; 2]; 3];
        let previous = [0.0; 9];
        for sigma in [1.0, -1.0] {
            linkage.read_branches(&previous, &mut rot, &mut [0.0]);
            let mut q = [0.0; 9];
            let margin = linkage.place(&[1.0], &previous, &[sigma], &mut rot, &mut q);
            assert!(gap(&pins, &q) < 1e-14, "{q:?}");
            assert_eq!(q[2], 1.0);
            // The branch read back is the one placed on.
            let mut read = [0.0];
            linkage.read_branches(&q, &mut rot, &mut read);
            assert_eq!(read[0], sigma);
            // The margin is the sine of the angle between coupler and
            // rocker at their pin.
            let (phi1, phi2) = (q[5], q[8]);
            assert!((margin - (phi1 - phi2).sin().abs()).abs() < 1e-14);
        }
    }

    #[test]
    fn a_dyad_that_cannot_close_or_has_no_branch_gives_margin_zero() {
        let (mut pins, angles) = four_bar();
        // The rocker's ground pin too far for coupler and rocker (3 + 2).
        pins[3].local[1] = [7.0, 0.0];
        let linkage = Linkage::plan(3, &pins, &angles).expect("decomposes");
        let mut rot = vec![[0.0; 2]; 3];
        let mut q = [0.0; 9];
        assert_eq!(
            linkage.place(&[0.0], &[0.0; 9], &[1.0], &mut rot, &mut q),
            0.0
        );
        let (pins, angles) = four_bar();
        let linkage = Linkage::plan(3, &pins, &angles).expect("decomposes");
        assert_eq!(
            linkage.place(&[0.5], &[0.0; 9], &[0.0], &mut rot, &mut q),
            0.0
        );
        assert_eq!(
            linkage.place(&[f64::NAN], &[0.0; 9], &[1.0], &mut rot, &mut q),
            0.0
        );
        // Wrong lengths: nothing placed.
        assert_eq!(
            linkage.place(&[0.5], &[0.0; 6], &[1.0], &mut rot, &mut q),
            0.0
        );
    }

    #[test]
    fn angles_found_from_directions_follow_the_previous_configuration() {
        let (pins, angles) = four_bar();
        let linkage = Linkage::plan(3, &pins, &angles).expect("decomposes");
        let mut rot = vec![[0.0; 2]; 3];
        linkage.read_branches(&[0.0; 9], &mut rot, &mut [0.0]);
        let mut q = [0.0; 9];
        linkage.place(&[1.0], &[0.0; 9], &[1.0], &mut rot, &mut q);
        let mut shifted = q;
        shifted[5] += 4.0 * std::f64::consts::PI;
        shifted[8] -= 2.0 * std::f64::consts::PI;
        let mut again = [0.0; 9];
        linkage.place(&[1.0], &shifted, &[1.0], &mut rot, &mut again);
        assert!((again[5] - shifted[5]).abs() < 1e-12);
        assert!((again[8] - shifted[8]).abs() < 1e-12);
    }

    #[test]
    fn small_turns_are_atan_to_an_ulp_and_large_ones_atan2() {
        for k in -1000..=1000 {
            let x = f64::from(k) / 8000.0;
            let (fast, exact) = (atan_small(x), x.atan());
            assert!(
                (fast - exact).abs() <= f64::EPSILON * exact.abs(),
                "{x}: {fast} against {exact}"
            );
        }
        for turn in [0.01, -0.1, 0.2, 1.0, -2.0, 3.0, -3.1] {
            let from = 10.0;
            let (s0, c0) = f64::sin_cos(from);
            let (s, c) = f64::sin_cos(from + turn);
            let got = turned(from, [c0, s0], [c, s]);
            assert!((got - (from + turn)).abs() < 1e-13, "{turn}: {got}");
        }
    }

    #[test]
    fn a_dyad_side_is_its_links_relative_angle_between_multiples_of_pi() {
        let (pins, angles) = four_bar();
        let linkage = Linkage::plan(3, &pins, &angles).expect("decomposes");
        let mut rot = vec![[0.0; 2]; 3];
        linkage.read_branches(&[0.0; 9], &mut rot, &mut [0.0]);
        let mut up = [0.0; 9];
        linkage.place(&[1.0], &[0.0; 9], &[1.0], &mut rot, &mut up);
        linkage.read_branches(&[0.0; 9], &mut rot, &mut [0.0]);
        let mut down = [0.0; 9];
        linkage.place(&[1.0], &[0.0; 9], &[-1.0], &mut rot, &mut down);
        assert!(linkage.same_side(&up, &up));
        assert!(!linkage.same_side(&up, &down));
        // Coupler and rocker frames are along their links (offset π: the
        // rocker's pin to the coupler is at +x, the coupler's at +x too).
        let mut flat = up;
        flat[8] = flat[5] + 1e-9;
        let mut other = up;
        other[8] = flat[5] - 1e-9;
        assert!(!linkage.same_side(&flat, &other));
        assert!(!linkage.same_side(&up, &[0.0; 6]));
    }

    #[test]
    fn a_chain_plans_whatever_the_order_of_its_bodies() {
        // Body k pinned to body k + 1, the last to ground, each driven:
        // body n − 1 is placed first, body 0 last.
        let n = 500;
        let pins: Vec<Pin> = (0..n)
            .map(|k| Pin {
                bodies: [Some(k), (k + 1 < n).then_some(k + 1)],
                local: [[0.0, 0.0], [1.0, 0.0]],
            })
            .collect();
        let angles: Vec<DrivenAngle> = (0..n)
            .map(|k| DrivenAngle {
                body: k,
                relative_to: None,
            })
            .collect();
        let linkage = Linkage::plan(n as usize, &pins, &angles).expect("decomposes");
        let mut rot = vec![[1.0, 0.0]; n as usize];
        let mut q = vec![0.0; 3 * n as usize];
        let previous = q.clone();
        let turns = vec![0.5; n as usize];
        assert_eq!(linkage.place(&turns, &previous, &[], &mut rot, &mut q), 1.0);
        assert!(gap(&pins, &q) < 1e-12);
    }

    #[test]
    fn structures_without_a_closed_form_are_refused() {
        let (pins, angles) = four_bar();
        // No driver: one degree of freedom left.
        assert!(Linkage::plan(3, &pins, &[]).is_none());
        // A joint too many (the coupler pinned to ground as well).
        let mut extra = pins.clone();
        extra.push(Pin {
            bodies: [Some(1), None],
            local: [[1.0, 0.0], [1.0, 1.0]],
        });
        assert!(Linkage::plan(3, &extra, &angles).is_none());
        // A body with both of its dyad pins at one point.
        let mut point = pins.clone();
        point[2].local[0] = [0.0, 0.0];
        assert!(Linkage::plan(3, &point, &angles).is_none());
        // Out of range, a body pinned to itself, two angles on one body.
        assert!(Linkage::plan(2, &pins, &angles).is_none());
        let mut own = pins.clone();
        own[1].bodies = [Some(1), Some(1)];
        assert!(Linkage::plan(3, &own, &angles).is_none());
        let twice = [angles[0], angles[0]];
        assert!(Linkage::plan(3, &pins, &twice).is_none());
    }

    #[test]
    fn a_relative_angle_drives_a_body_from_a_placed_one() {
        // A double pendulum: body 0 at an absolute angle about the origin,
        // body 1 at a relative angle about body 0's tip.
        let pins = [
            Pin {
                bodies: [Some(0), None],
                local: [[0.0, 0.0], [0.0, 0.0]],
            },
            Pin {
                bodies: [Some(0), Some(1)],
                local: [[2.0, 0.0], [-1.0, 0.0]],
            },
        ];
        let angles = [
            DrivenAngle {
                body: 1,
                relative_to: Some(0),
            },
            DrivenAngle {
                body: 0,
                relative_to: None,
            },
        ];
        let linkage = Linkage::plan(2, &pins, &angles).expect("decomposes");
        let mut rot = vec![[0.0; 2]; 2];
        let mut q = [0.0; 6];
        let margin = linkage.place(&[0.5, 0.25], &[0.0; 6], &[], &mut rot, &mut q);
        assert_eq!(margin, 1.0);
        assert_eq!((q[2], q[5]), (0.25, 0.75));
        assert!(gap(&pins, &q) < 1e-15);
    }
}
