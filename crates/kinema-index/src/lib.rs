//! Typed `u32` indices for kinema, in the manner of la-arena's `Idx` and
//! cranelift-entity's `entity_impl!`.
//!
//! - [`entity!`] declares a `u32` newtype index (`ExprId`, `SymId`, [`Body`],
//!   …) with a checked constructor: an index that does not fit in `u32` is a
//!   bug, so [`new`](Body::new) panics with the type's name rather than
//!   aliasing another id silently.
//! - [`u32_of`] is the same check for the places that keep a plain `u32`
//!   (counts, spans, literals in generated code).
//! - [`Coord`] names one generalized coordinate of a planar body, `(x, y, φ)`
//!   = [`Axis::X`], [`Axis::Y`], [`Axis::Phi`]; [`Coord::index`] is the one
//!   place the layout `q[3·body + axis]` is spelled.
//!
//! ```
//! use kinema_index::{Axis, Body, Coord};
//!
//! let c = Coord::new(Body::new(2), Axis::Phi);
//! assert_eq!(c.index(), 8);
//! assert_eq!(Coord::of_index(8), c);
//! assert_eq!(format!("{c}"), "body2.phi");
//! ```

use std::fmt;

/// `i` as a `u32`, for an index or a count of `what` (a type or a thing's
/// name, used in the message).
///
/// # Panics
///
/// When `i > u32::MAX`: kinema counts its ids in `u32`, and growing past that
/// is a bug (a model or an arena too large to be real), never a value to
/// saturate into an alias of another id.
///
/// ```
/// assert_eq!(kinema_index::u32_of(7, "row"), 7);
/// ```
#[inline]
#[must_use]
#[track_caller]
pub fn u32_of(i: usize, what: &str) -> u32 {
    match u32::try_from(i) {
        Ok(v) => v,
        Err(_) => overflow(i, what),
    }
}

#[cold]
#[inline(never)]
#[track_caller]
fn overflow(i: usize, what: &str) -> ! {
    panic!("{what} index {i} does not fit in u32 (kinema counts its ids in u32; this is a bug)")
}

/// Declares a `u32` newtype index.
///
/// ```
/// kinema_index::entity! {
///     /// A row of the constraint equations.
///     pub struct Row; "row"
/// }
/// let r = Row::new(3);
/// assert_eq!(r.index(), 3);
/// assert_eq!(r.as_u32(), 3);
/// assert_eq!(format!("{r} {r:?}"), "row3 row3");
/// ```
///
/// The string is the prefix of its `Debug` and `Display` forms. The field's
/// visibility may be given (`pub struct Id(pub(crate) u32); "e"`) where the
/// declaring crate builds ids in hot code it has already bounded; by default
/// it is private, so ids are made only through the checked `new`.
///
/// `new(usize)` panics, naming the type, when the index exceeds `u32::MAX`:
///
/// ```should_panic
/// kinema_index::entity! {
///     /// A node.
///     pub struct Node; "n"
/// }
/// let _ = Node::new(usize::MAX); // "Node index … does not fit in u32"
/// ```
#[macro_export]
macro_rules! entity {
    ($(#[$attr:meta])* $vis:vis struct $name:ident; $prefix:literal) => {
        $crate::entity! { $(#[$attr])* $vis struct $name(u32); $prefix }
    };
    ($(#[$attr:meta])* $vis:vis struct $name:ident($fvis:vis u32); $prefix:literal) => {
        $(#[$attr])*
        #[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        $vis struct $name($fvis u32);

        impl $name {
            /// The id at position `index`.
            ///
            /// # Panics
            ///
            /// When `index` exceeds `u32::MAX` (a bug: ids never alias).
            #[inline]
            #[must_use]
            #[track_caller]
            $vis fn new(index: usize) -> Self {
                Self($crate::u32_of(index, stringify!($name)))
            }

            /// The id at position `index`, already a `u32` (for constants,
            /// e.g. in generated code).
            #[inline]
            #[must_use]
            $vis const fn from_u32(index: u32) -> Self {
                Self(index)
            }

            /// The id's position (dense, from 0).
            #[inline]
            #[must_use]
            $vis fn index(self) -> usize {
                self.0 as usize
            }

            /// The id's position as the `u32` it is stored in.
            #[inline]
            #[must_use]
            $vis fn as_u32(self) -> u32 {
                self.0
            }
        }

        impl ::std::fmt::Debug for $name {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                ::std::write!(f, "{}{}", $prefix, self.0)
            }
        }

        impl ::std::fmt::Display for $name {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                ::std::write!(f, "{}{}", $prefix, self.0)
            }
        }
    };
}

entity! {
    /// A body, by its position among a system's bodies (the ground is not
    /// one). Its coordinates are `q[3·i]`, `q[3·i + 1]`, `q[3·i + 2]`: see
    /// [`Coord`].
    pub struct Body; "body"
}

impl Body {
    /// This body's coordinate along `axis`.
    #[inline]
    #[must_use]
    pub fn coord(self, axis: Axis) -> Coord {
        Coord { body: self, axis }
    }
}

/// One of a planar body's three coordinates.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Debug)]
pub enum Axis {
    /// The x coordinate of the body's origin.
    X = 0,
    /// The y coordinate of the body's origin.
    Y = 1,
    /// The body's angle φ.
    Phi = 2,
}

impl Axis {
    /// The three axes in the order they are stored: x, y, φ.
    pub const ALL: [Self; 3] = [Self::X, Self::Y, Self::Phi];

    /// The axis's offset within its body's three coordinates (0, 1, 2).
    #[inline]
    #[must_use]
    pub fn index(self) -> usize {
        self as usize
    }

    /// The name used in messages and column headers: `x`, `y`, `phi`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::X => "x",
            Self::Y => "y",
            Self::Phi => "phi",
        }
    }
}

/// A generalized coordinate of a body: `q[3·body + axis]`.
///
/// Systems lay their coordinates out body by body, `(x, y, φ)` each, then
/// the coordinates of their own (if any) after all bodies; a `Coord` names
/// only the bodies' part.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Debug)]
pub struct Coord {
    /// The body.
    pub body: Body,
    /// Which of its coordinates.
    pub axis: Axis,
}

impl Coord {
    /// The coordinate `axis` of `body`.
    #[inline]
    #[must_use]
    pub fn new(body: Body, axis: Axis) -> Self {
        Self { body, axis }
    }

    /// The coordinate's position in q: `3·body + axis`.
    #[inline]
    #[must_use]
    pub fn index(self) -> usize {
        3 * self.body.index() + self.axis.index()
    }

    /// The coordinate at position `i` of q (the inverse of
    /// [`index`](Self::index)).
    ///
    /// # Panics
    ///
    /// When `i / 3` exceeds `u32::MAX` (see [`Body::new`]).
    #[inline]
    #[must_use]
    #[track_caller]
    pub fn of_index(i: usize) -> Self {
        Self {
            body: Body::new(i / 3),
            axis: Axis::ALL[i % 3],
        }
    }
}

impl fmt::Display for Coord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}", self.body, self.axis.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coord_round_trips() {
        for i in 0..30 {
            let c = Coord::of_index(i);
            assert_eq!(c.index(), i);
            assert_eq!(c.body.index(), i / 3);
            assert_eq!(c.axis.index(), i % 3);
        }
        assert_eq!(Body::new(4).coord(Axis::Y).index(), 13);
    }

    #[test]
    fn u32_of_accepts_the_largest() {
        assert_eq!(u32_of(u32::MAX as usize, "x"), u32::MAX);
    }

    #[test]
    #[should_panic(expected = "Body index 4294967296 does not fit in u32")]
    fn body_past_u32_panics_with_its_name() {
        let _ = Body::new(u32::MAX as usize + 1);
    }

    #[test]
    #[should_panic(expected = "row index 4294967296 does not fit in u32")]
    fn u32_of_past_u32_panics_with_the_name() {
        let _ = u32_of(u32::MAX as usize + 1, "row");
    }
}
