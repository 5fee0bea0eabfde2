//! A small symbolic engine for kinematics: hash-consed expressions with
//! canonical forms, memoized differentiation, schedules for code generation,
//! and tapes for run-time evaluation.
//!
//! # Model
//! Expressions live in an [`Arena`] and are referred to by copyable
//! [`ExprId`]s. Leaves are numbers and [symbols](SymKind): generalized
//! coordinates, their velocities, parameters (run-time values that are never
//! folded) and time. Sums and products are n-ary with numeric coefficients and
//! constant exponents; subtraction, negation and division are not node kinds
//! but coefficients and powers. Every constructor canonicalizes and interns, so
//! equal expressions share one id, common subexpressions are shared by
//! construction, and derivatives are memoized per (node, variable).
//!
//! Operand order is a function of the expressions alone (kind, then value,
//! symbol or structural hash), never of construction order or of a hash map's
//! iteration, so printed output and generated code are stable.
//!
//! Nothing walks the DAG recursively: every traversal uses an explicit stack,
//! so a sum of 100 000 terms or a nesting 100 000 deep is fine on a small stack.
//!
//! # Example: the x-row of a revolute joint and its derivatives
//! ```
//! use kinema_expr::Arena;
//! let mut a = Arena::new();
//! let x1 = a.coordinate("x1", 0);
//! let phi1 = a.coordinate("phi1", 2);
//! let c = a.cos(phi1);
//! let arm = a.scale(0.5, c);
//! let phi = a.add(x1, arm); // x1 + 0.5 cos(phi1)
//! let s_phi1 = a.symbol_of(phi1).unwrap();
//! let d = a.diff(phi, s_phi1);
//! assert_eq!(a.display(d).to_string(), "-0.5*sin(phi1)");
//! ```

mod arena;
mod build;
mod calculus;
mod eval;
mod function;
mod node;
mod print;
mod schedule;
mod tape;

pub use arena::Arena;
pub use build::FLATTEN_MAX;
pub use calculus::{Columns, Entry, SeedsId, SparseMatrix};
pub use function::{FUNCTIONS, Function, FunctionKind, function, unary_function};
pub use node::{ExprId, Factor, NodeRef, SymId, SymKind, Symbol, Term, UnaryOp, smooth};
pub use print::{Display, format_number};
pub use schedule::Schedule;
pub use tape::{
    Domain, Instr, Reg, Tape, TapeError, TapeInputs, TapeKink, TapeLayout, TapeUndefined,
};
