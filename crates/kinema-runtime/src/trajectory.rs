//! A computed motion: [`Trajectory`].

use std::io;
use std::ops::Index;

use kinema_index::Body;

use crate::csv::CsvWriter;
use crate::event::SingularEvent;
use crate::kinematics::PointKinematics;
use crate::state::State;
use crate::system::System;

/// The states of a [`Solver::run`](crate::Solver::run), one per time of the
/// grid, with the coordinate names for output.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    names: Vec<String>,
    states: Vec<State>,
    events: Vec<SingularEvent>,
}

impl Trajectory {
    pub(crate) fn for_system<S: System + ?Sized>(system: &S, capacity: usize) -> Self {
        Self {
            names: (0..system.len())
                .map(|i| system.coordinate_name(i).to_owned())
                .collect(),
            states: Vec::with_capacity(capacity),
            events: Vec::new(),
        }
    }

    pub(crate) fn set_events(&mut self, events: Vec<SingularEvent>) {
        self.events = events;
    }

    /// The singular configurations the run met, in time order (see
    /// [`Solver`](crate::Solver), "Singular configurations").
    #[must_use]
    pub fn events(&self) -> &[SingularEvent] {
        &self.events
    }

    pub(crate) fn push(&mut self, state: State) {
        self.states.push(state);
    }

    /// Number of states (times).
    #[must_use]
    pub fn len(&self) -> usize {
        self.states.len()
    }

    /// `true` if there is no state.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }

    /// The states in time order.
    #[must_use]
    pub fn states(&self) -> &[State] {
        &self.states
    }

    /// The state at time index `k`, if any.
    #[must_use]
    pub fn get(&self, k: usize) -> Option<&State> {
        self.states.get(k)
    }

    /// Iterates over the states in time order.
    pub fn iter(&self) -> std::slice::Iter<'_, State> {
        self.states.iter()
    }

    /// The times t.
    pub fn times(&self) -> impl ExactSizeIterator<Item = f64> + '_ {
        self.states.iter().map(State::t)
    }

    /// Coordinate names, in coordinate order.
    #[must_use]
    pub fn coordinate_names(&self) -> &[String] {
        &self.names
    }

    /// Mean number of Newton updates per step.
    #[must_use]
    pub fn mean_iterations(&self) -> f64 {
        if self.states.is_empty() {
            return 0.0;
        }
        let total: usize = self.states.iter().map(|s| s.stats().iterations).sum();
        total as f64 / self.states.len() as f64
    }

    /// Kinematics of a body-fixed point at time index `k` (see
    /// [`State::point`]); `None` if `k` is out of range or the system has no
    /// such body.
    #[must_use]
    pub fn point(&self, k: usize, body: Body, s: [f64; 2]) -> Option<PointKinematics> {
        self.states.get(k)?.point(body, s)
    }

    /// Writes the trajectory as CSV per the command-line contract: columns
    /// `t`, the coordinate names, the names suffixed `_dot`, then `_ddot`;
    /// one row per state; numbers in shortest round-trip form.
    pub fn write_csv<W: io::Write>(&self, out: W) -> io::Result<()> {
        let mut csv = CsvWriter::new(out, &self.names)?;
        for state in &self.states {
            csv.write_state(state)?;
        }
        csv.flush()
    }
}

impl Index<usize> for Trajectory {
    type Output = State;

    /// The state at time index `k`; panics if out of range, like slices (use
    /// [`Trajectory::get`] to avoid that).
    fn index(&self, k: usize) -> &State {
        &self.states[k]
    }
}

impl<'a> IntoIterator for &'a Trajectory {
    type Item = &'a State;
    type IntoIter = std::slice::Iter<'a, State>;

    fn into_iter(self) -> Self::IntoIter {
        self.states.iter()
    }
}

/// `steps` equal steps from 0 to `t_end`: the `steps + 1` times `k·T/N`
/// (`(k/N)·T` where `k·T` overflows), the last exactly `t_end`. The grid of
/// `kinema run --t-end T --steps N`, of the Python package's `steps=` and of
/// sweeps, so that they step through the same doubles.
#[must_use]
pub fn uniform_times(t_end: f64, steps: usize) -> Vec<f64> {
    (0..=steps)
        .map(|k| {
            if k == steps {
                t_end
            } else {
                let p = k as f64 * t_end;
                if p.is_finite() {
                    p / steps as f64
                } else {
                    (k as f64 / steps as f64) * t_end
                }
            }
        })
        .collect()
}
