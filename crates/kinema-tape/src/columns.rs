//! Which quantities a run's table holds: the columns of `kinema run
//! --columns` (and of the Python package's `columns=`), their names in the
//! CSV's header.
//!
//! The CSV is `t`, then the body block (selected coordinates, their `_dot`,
//! their `_ddot`), then the results block (selected named points' and
//! measures' columns, their `_dot`, their `_ddot`). Each block keeps
//! declaration order whatever the order of the list; a quantity named
//! twice is written once.

use std::fmt;

use kinema_model::{Derivation, OutputSource};

/// A `--columns` list that names something the model does not have, or
/// nothing at all; the message says which item and what is expected.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ColumnError(pub String);

impl fmt::Display for ColumnError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ColumnError {}

/// The selected coordinates and result columns, by index.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Selection {
    /// Coordinates, increasing.
    pub coordinates: Vec<usize>,
    /// Result columns ([`Derivation::outputs`]), increasing.
    pub outputs: Vec<usize>,
    /// Values only (`--positions-only`): no `_dot` and `_ddot` columns.
    pub positions_only: bool,
}

impl Selection {
    /// Everything: bodies, points and outputs (the default).
    pub fn all(d: &Derivation) -> Selection {
        Selection {
            coordinates: (0..d.nc()).collect(),
            outputs: (0..d.outputs.len()).collect(),
            positions_only: false,
        }
    }

    /// This selection with the values only (`positions_only`), or also
    /// their `_dot` and `_ddot` columns.
    pub fn with_positions_only(self, positions_only: bool) -> Selection {
        Selection {
            positions_only,
            ..self
        }
    }

    /// How many of q, q̇, q̈ (y, ẏ, ÿ) each selected quantity writes.
    pub fn orders(&self) -> usize {
        if self.positions_only { 1 } else { 3 }
    }

    /// The selection `--columns` asks for, every column without it.
    ///
    /// # Errors
    /// As [`Selection::parse`].
    pub fn of_option(spec: Option<&str>, d: &Derivation) -> Result<Selection, ColumnError> {
        spec.map_or_else(|| Ok(Selection::all(d)), |spec| Selection::parse(spec, d))
    }

    /// Reads a comma-separated list: `bodies`, `points`, `outputs`, `all`;
    /// a body (its three coordinates); a point `B.name` or an output
    /// `NAME` (its columns); or one column by name (`crank.x`,
    /// `crank.pin.y`, `dir.x`; a `_dot`/`_ddot` name selects its quantity).
    ///
    /// # Errors
    /// A [`ColumnError`] naming the first item that is none of these.
    pub fn parse(spec: &str, d: &Derivation) -> Result<Selection, ColumnError> {
        if spec.split(',').all(|item| item.trim().is_empty()) {
            return Err(ColumnError(
                "--columns is empty: expected a comma-separated list such as `bodies,outputs`"
                    .to_owned(),
            ));
        }
        let mut coords = vec![false; d.nc()];
        let mut outs = vec![false; d.outputs.len()];
        for item in spec.split(',').map(str::trim) {
            if item.is_empty() || item == "t" {
                continue;
            }
            let base = item
                .strip_suffix("_ddot")
                .or_else(|| item.strip_suffix("_dot"))
                .unwrap_or(item);
            let mut found = false;
            for (k, c) in d.coordinates.iter().enumerate() {
                let body = d.bodies.get(c.body).map(String::as_str);
                if matches!(item, "all" | "bodies") || c.name == base || body == Some(item) {
                    coords[k] = true;
                    found = true;
                }
            }
            for (k, o) in d.outputs.iter().enumerate() {
                let group = match o.source {
                    OutputSource::Point(_) => "points",
                    OutputSource::Measure(_) => "outputs",
                };
                if item == "all" || item == group || o.name == base || o.declared == item {
                    outs[k] = true;
                    found = true;
                }
            }
            if !found && !matches!(item, "all" | "bodies" | "points" | "outputs") {
                return Err(ColumnError(format!(
                    "--columns: `{item}` is not a column of this model: expected `bodies`, \
                     `points`, `outputs`, `all`, a body, a point (`body.name`), an output, or a \
                     column such as `{}` (see `kinema derive` for the names)",
                    d.coordinates.first().map_or("crank.x", |c| c.name.as_str())
                )));
            }
        }
        let pick = |v: Vec<bool>| {
            v.iter()
                .enumerate()
                .filter(|(_, s)| **s)
                .map(|(k, _)| k)
                .collect()
        };
        Ok(Selection {
            coordinates: pick(coords),
            outputs: pick(outs),
            positions_only: false,
        })
    }

    /// The header's names after `t`: each selected quantity's value, `_dot`
    /// and `_ddot` (the value alone with `positions_only`), bodies' block
    /// first.
    pub fn header(&self, d: &Derivation) -> Vec<String> {
        let mut out = Vec::with_capacity(3 * (self.coordinates.len() + self.outputs.len()));
        let coords: Vec<&str> = self
            .coordinates
            .iter()
            .filter_map(|&k| d.coordinates.get(k).map(|c| c.name.as_str()))
            .collect();
        let outs: Vec<&str> = self
            .outputs
            .iter()
            .filter_map(|&k| d.outputs.get(k).map(|o| o.name.as_str()))
            .collect();
        for names in [coords, outs] {
            for suffix in &["", "_dot", "_ddot"][..self.orders()] {
                out.extend(names.iter().map(|n| format!("{n}{suffix}")));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_names_and_errors() -> Result<(), String> {
        let src = "mechanism M {
            body bar { guess: (1, 0, 0) }
            point bar.tip = (1, 0);
            joint pin: revolute(ground(0, 0), bar(-1, 0));
            driver swing: bar.phi == t;
            output lead: bar.phi - t;
        }";
        let d = kinema_model::derive_str(src).map_err(|e| e.to_string())?;
        let all = Selection::all(&d);
        assert_eq!(all.coordinates, [0, 1, 2]);
        assert_eq!(all.outputs, [0, 1, 2]);
        let s = Selection::parse("outputs, bar.tip", &d).map_err(|e| e.to_string())?;
        assert!(s.coordinates.is_empty());
        assert_eq!(s.outputs, [0, 1, 2]);
        let s = Selection::parse("lead_dot,bar.phi,t", &d).map_err(|e| e.to_string())?;
        assert_eq!(s.coordinates, [2]);
        assert_eq!(s.outputs, [2]);
        assert_eq!(
            s.header(&d),
            [
                "bar.phi",
                "bar.phi_dot",
                "bar.phi_ddot",
                "lead",
                "lead_dot",
                "lead_ddot"
            ]
        );
        assert!(Selection::parse("points,bar", &d).is_ok_and(|s| s.coordinates.len() == 3));
        assert!(Selection::parse("foot", &d).is_err());
        assert!(Selection::parse(" , ", &d).is_err());
        assert!(Selection::parse("t", &d).is_ok_and(|s| s.header(&d).is_empty()));
        Ok(())
    }
}
