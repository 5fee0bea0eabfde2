//! Named results beyond the coordinates: the model's named points
//! (`B.name.x`, `B.name.y`) and measures (`output NAME: EXPR;`), each with
//! its first and second time derivatives: [`Outputs`], and named access to
//! every column of a run: [`Table`].

use crate::state::State;
use crate::system::System;
use crate::trajectory::Trajectory;

/// A time with the motion at it: positions q, velocities q̇ and
/// accelerations q̈ (what [`Outputs::outputs`] evaluates at).
#[derive(Clone, Copy, Debug)]
pub struct Motion<'a> {
    /// Time t.
    pub t: f64,
    /// Positions q.
    pub q: &'a [f64],
    /// Velocities q̇.
    pub qd: &'a [f64],
    /// Accelerations q̈.
    pub qdd: &'a [f64],
}

impl<'a> Motion<'a> {
    /// A solved state's time and motion.
    #[must_use]
    pub fn of(state: &'a State) -> Self {
        Self {
            t: state.t(),
            q: state.q(),
            qd: state.qd(),
            qdd: state.qdd(),
        }
    }
}

/// A result column at a kink ([`Outputs::output_kink`]): its value is
/// right, its rates are the rounding errors'.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputKink {
    /// The result column (its index in [`Outputs::output_name`]'s order).
    pub column: usize,
    /// The function, as in [`Kink::function`](crate::Kink::function).
    pub function: &'static str,
}

/// A system whose model declares named results: m scalar columns y (points'
/// components, then measures), evaluated at a solved state with their
/// derivatives ẏ and ÿ.
///
/// Implemented by generated mechanisms and by the tape back end. Evaluation
/// allocates nothing (the scratch is the system's).
pub trait Outputs: System {
    /// Number of scalar result columns m.
    fn output_len(&self) -> usize;

    /// Name of result column `i < m` (`"crank.pin.x"`, `"reach"`,
    /// `"dir.y"`); the derivatives' columns add `_dot` and `_ddot`.
    fn output_name(&self, i: usize) -> &str;

    /// Writes `[y, ẏ, ÿ]` (each of length m) at a state's time, positions,
    /// velocities and accelerations (`at`). Slices of the wrong length give
    /// NaN, never a panic.
    fn outputs(&self, scratch: &mut Self::Scratch, at: Motion<'_>, out: [&mut [f64]; 3]);

    /// The first result column that, at `state`, goes through a function
    /// at a point where it is not differentiable (a distance between two
    /// points that coincide but for roundoff, `atan2(0, 0)`, `acos(±1)`),
    /// within a bound on its argument's error (the state's residual and
    /// roundoff at `size`, as [`System::kink`] for Φ): its value is right,
    /// its rates ẏ and ÿ there are the rounding errors'. Called on kept
    /// states, not in steps: must not allocate after its first call. The
    /// default: `None`, the system cannot tell.
    fn output_kink(
        &self,
        scratch: &mut Self::Scratch,
        state: &State,
        size: f64,
    ) -> Option<OutputKink> {
        let _ = (scratch, state, size);
        None
    }

    /// The index of the result column named `name`, if any.
    fn output_index(&self, name: &str) -> Option<usize> {
        (0..self.output_len()).find(|&i| self.output_name(i) == name)
    }

    /// y, ẏ, ÿ at a solved state into `out` (no allocation).
    fn outputs_of(&self, scratch: &mut Self::Scratch, state: &State, out: &mut [Vec<f64>; 3]) {
        let [y, yd, ydd] = out;
        self.outputs(scratch, Motion::of(state), [y, yd, ydd]);
    }

    /// y, ẏ, ÿ at a solved state (a fresh scratch: allocates, for one-off use).
    fn outputs_at(&self, state: &State) -> [Vec<f64>; 3] {
        let m = self.output_len();
        let mut out = [vec![0.0; m], vec![0.0; m], vec![0.0; m]];
        self.outputs_of(&mut self.scratch(), state, &mut out);
        out
    }
}

/// Every column of a run by name, as the CLI's CSV has them: `t`; the
/// coordinates with `_dot` and `_ddot`; the results ([`Outputs`]) with
/// `_dot` and `_ddot`.
///
/// ```text
/// let table = Table::new(solver.system(), &trajectory);
/// let foot_y = table.column("foot.y");
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    names: Vec<String>,
    rows: usize,
    /// Column-major: column j is `data[j * rows..(j + 1) * rows]`.
    data: Vec<f64>,
}

impl Table {
    /// Evaluates the results of `system` at every state of `trajectory`.
    #[must_use]
    pub fn new<S: Outputs + ?Sized>(system: &S, trajectory: &Trajectory) -> Table {
        let n = trajectory.coordinate_names().len();
        let m = system.output_len();
        let rows = trajectory.len();
        let mut names = Vec::with_capacity(1 + 3 * (n + m));
        names.push("t".to_string());
        for suffix in ["", "_dot", "_ddot"] {
            for c in trajectory.coordinate_names() {
                names.push(format!("{c}{suffix}"));
            }
        }
        for suffix in ["", "_dot", "_ddot"] {
            for i in 0..m {
                names.push(format!("{}{suffix}", system.output_name(i)));
            }
        }
        let mut data = vec![f64::NAN; names.len() * rows];
        let mut scratch = system.scratch();
        let (mut y, mut yd, mut ydd) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        for (r, s) in trajectory.iter().enumerate() {
            data[r] = s.t();
            for (block, values) in [s.q(), s.qd(), s.qdd()].into_iter().enumerate() {
                for (i, &v) in values.iter().take(n).enumerate() {
                    data[(1 + block * n + i) * rows + r] = v;
                }
            }
            system.outputs(&mut scratch, Motion::of(s), [&mut y, &mut yd, &mut ydd]);
            for (block, values) in [&y, &yd, &ydd].into_iter().enumerate() {
                for (i, &v) in values.iter().enumerate() {
                    data[(1 + 3 * n + block * m + i) * rows + r] = v;
                }
            }
        }
        Table { names, rows, data }
    }

    /// The column named `name` (`"t"`, `"slider.x_dot"`, `"crank.pin.y"`,
    /// `"reach_ddot"`), one value per state; `None` for an unknown name.
    #[must_use]
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        let j = self.names.iter().position(|n| n == name)?;
        self.data.get(j * self.rows..(j + 1) * self.rows)
    }

    /// The column names, in CSV order.
    #[must_use]
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Number of rows (states).
    #[must_use]
    pub fn rows(&self) -> usize {
        self.rows
    }
}

impl Trajectory {
    /// Every column of this run by name, results of `system` included (see
    /// [`Table`]): `trajectory.table(solver.system()).column("foot.y")`.
    #[must_use]
    pub fn table<S: Outputs + ?Sized>(&self, system: &S) -> Table {
        Table::new(system, self)
    }
}

impl Table {
    /// Writes the table as CSV (the command line's columns, `kinema run`'s
    /// number format `{:e}`): a header, then one row per state.
    ///
    /// # Errors
    /// Write errors of `out`.
    pub fn write_csv<W: std::io::Write>(&self, mut out: W) -> std::io::Result<()> {
        writeln!(out, "{}", self.names.join(","))?;
        let mut line = crate::csv::CsvLine::new();
        for r in 0..self.rows {
            line.clear();
            for j in 0..self.names.len() {
                let v = self.data.get(j * self.rows + r).copied();
                line.number(v.unwrap_or(f64::NAN));
            }
            line.write_to(&mut out)?;
        }
        out.flush()
    }
}
