//! Planar vector algebra over expression ids: the one vocabulary in which both
//! user-written equations and the whole constraint library are written.
//! Nothing here differentiates: the engine derives Φ_q, ν and γ.

use kinema_expr::{Arena, ExprId};

/// A planar vector whose components are expressions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Vec2 {
    /// x component.
    pub x: ExprId,
    /// y component.
    pub y: ExprId,
}

impl Vec2 {
    /// The vector `(x, y)`.
    #[must_use]
    pub fn new(x: ExprId, y: ExprId) -> Self {
        Vec2 { x, y }
    }
}

/// Vector operations on an [`Arena`].
pub trait VecAlgebra {
    /// `(a, b)` from numbers.
    fn vnum(&mut self, a: f64, b: f64) -> Vec2;
    /// `u + v`
    fn vadd(&mut self, u: Vec2, v: Vec2) -> Vec2;
    /// `u − v`
    fn vsub(&mut self, u: Vec2, v: Vec2) -> Vec2;
    /// `−u`
    fn vneg(&mut self, u: Vec2) -> Vec2;
    /// `c·u`
    fn vscale(&mut self, c: ExprId, u: Vec2) -> Vec2;
    /// `u / c`
    fn vdiv(&mut self, u: Vec2, c: ExprId) -> Vec2;
    /// `uᵀv`
    fn dot(&mut self, u: Vec2, v: Vec2) -> ExprId;
    /// `u_x v_y − u_y v_x`
    fn cross(&mut self, u: Vec2, v: Vec2) -> ExprId;
    /// `|u|`
    fn norm(&mut self, u: Vec2) -> ExprId;
    /// `u / |u|`
    fn unit(&mut self, u: Vec2) -> Vec2;
    /// `R u` with R = [[0, −1], [1, 0]] (+90°).
    fn perp(&mut self, u: Vec2) -> Vec2;
    /// `A(angle) u`.
    fn rot(&mut self, angle: ExprId, u: Vec2) -> Vec2;
}

impl VecAlgebra for Arena {
    fn vnum(&mut self, a: f64, b: f64) -> Vec2 {
        Vec2::new(self.num(a), self.num(b))
    }
    fn vadd(&mut self, u: Vec2, v: Vec2) -> Vec2 {
        Vec2::new(self.add(u.x, v.x), self.add(u.y, v.y))
    }
    fn vsub(&mut self, u: Vec2, v: Vec2) -> Vec2 {
        Vec2::new(self.sub(u.x, v.x), self.sub(u.y, v.y))
    }
    fn vneg(&mut self, u: Vec2) -> Vec2 {
        Vec2::new(self.neg(u.x), self.neg(u.y))
    }
    fn vscale(&mut self, c: ExprId, u: Vec2) -> Vec2 {
        Vec2::new(self.mul(c, u.x), self.mul(c, u.y))
    }
    fn vdiv(&mut self, u: Vec2, c: ExprId) -> Vec2 {
        Vec2::new(self.div(u.x, c), self.div(u.y, c))
    }
    fn dot(&mut self, u: Vec2, v: Vec2) -> ExprId {
        let a = self.mul(u.x, v.x);
        let b = self.mul(u.y, v.y);
        self.add(a, b)
    }
    fn cross(&mut self, u: Vec2, v: Vec2) -> ExprId {
        let a = self.mul(u.x, v.y);
        let b = self.mul(u.y, v.x);
        self.sub(a, b)
    }
    fn norm(&mut self, u: Vec2) -> ExprId {
        let d = self.dot(u, u);
        self.sqrt(d)
    }
    fn unit(&mut self, u: Vec2) -> Vec2 {
        let n = self.norm(u);
        self.vdiv(u, n)
    }
    fn perp(&mut self, u: Vec2) -> Vec2 {
        Vec2::new(self.neg(u.y), u.x)
    }
    fn rot(&mut self, angle: ExprId, u: Vec2) -> Vec2 {
        let c = self.cos(angle);
        let s = self.sin(angle);
        let cx = self.mul(c, u.x);
        let sy = self.mul(s, u.y);
        let sx = self.mul(s, u.x);
        let cy = self.mul(c, u.y);
        Vec2::new(self.sub(cx, sy), self.add(sx, cy))
    }
}
