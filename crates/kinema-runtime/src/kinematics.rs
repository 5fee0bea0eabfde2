//! Kinematics of body-fixed points: [`PointKinematics`], [`point_kinematics`].

use kinema_index::{Axis, Body};

/// Global position, velocity and acceleration of a body-fixed point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointKinematics {
    /// r + A s′.
    pub position: [f64; 2],
    /// ṙ + B s′ φ̇.
    pub velocity: [f64; 2],
    /// r̈ + B s′ φ̈ − A s′ φ̇².
    pub acceleration: [f64; 2],
}

/// Kinematics of the point with local coordinates s′ = `s` on `body`, whose
/// r = (x, y) and φ are its [`Coord`](kinema_index::Coord)s in q (likewise in
/// q̇ and q̈), with A(φ) = [[cos φ, −sin φ], [sin φ, cos φ]] and B = dA/dφ:
///
/// * position r + A s′,
/// * velocity ṙ + B s′ φ̇,
/// * acceleration r̈ + B s′ φ̈ − A s′ φ̇².
///
/// `None` if the body's coordinates are out of range of any of the three
/// slices.
///
/// ```
/// use kinema_runtime::{Body, point_kinematics};
///
/// // Body 1 at (1, 2), turned a quarter turn, at rest.
/// let q = [0.0, 0.0, 0.0, 1.0, 2.0, std::f64::consts::FRAC_PI_2];
/// let zero = [0.0; 6];
/// let p = point_kinematics(&q, &zero, &zero, Body::new(1), [1.0, 0.0]).unwrap();
/// assert!((p.position[0] - 1.0).abs() < 1e-12 && (p.position[1] - 3.0).abs() < 1e-12);
/// assert!(point_kinematics(&q, &zero, &zero, Body::new(2), [1.0, 0.0]).is_none());
/// ```
#[must_use]
pub fn point_kinematics(
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    body: Body,
    s: [f64; 2],
) -> Option<PointKinematics> {
    let at = body.coord(Axis::X).index()..body.coord(Axis::Phi).index() + 1;
    let (&[x, y, phi], &[xd, yd, phid], &[xdd, ydd, phidd]) =
        (q.get(at.clone())?, qd.get(at.clone())?, qdd.get(at)?)
    else {
        return None;
    };
    let (sin, cos) = phi.sin_cos();
    // a = A s′, b = B s′ = R A s′ = (−a_y, a_x).
    let a = [cos * s[0] - sin * s[1], sin * s[0] + cos * s[1]];
    let b = [-a[1], a[0]];
    let w2 = phid * phid;
    Some(PointKinematics {
        position: [x + a[0], y + a[1]],
        velocity: [xd + b[0] * phid, yd + b[1] * phid],
        acceleration: [
            xdd + b[0] * phidd - a[0] * w2,
            ydd + b[1] * phidd - a[1] * w2,
        ],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotating_point_on_a_fixed_pivot() -> Result<(), &'static str> {
        // Body at the origin turning with φ = ωt: a point at s′ = (L, 0) moves
        // on a circle; at φ = π/2 with ω = 2, φ̈ = 0: v = (−Lω, 0), a = (0, −Lω²).
        let (l, w) = (0.5, 2.0);
        let p = point_kinematics(
            &[0.0, 0.0, std::f64::consts::FRAC_PI_2],
            &[0.0, 0.0, w],
            &[0.0, 0.0, 0.0],
            Body::new(0),
            [l, 0.0],
        )
        .ok_or("in range")?;
        let close =
            |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-15 && (a[1] - b[1]).abs() < 1e-15;
        assert!(close(p.position, [0.0, l]), "{p:?}");
        assert!(close(p.velocity, [-l * w, 0.0]), "{p:?}");
        assert!(close(p.acceleration, [0.0, -l * w * w]), "{p:?}");
        assert_eq!(
            point_kinematics(&[0.0; 3], &[0.0; 3], &[0.0; 3], Body::new(1), [0.0, 0.0]),
            None
        );
        assert_eq!(
            point_kinematics(
                &[0.0; 3],
                &[0.0; 3],
                &[0.0; 3],
                Body::new(u32::MAX as usize),
                [0.0, 0.0]
            ),
            None
        );
        Ok(())
    }
}
