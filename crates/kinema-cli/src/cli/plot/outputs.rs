//! The model's measures (`output NAME: EXPR;`) against time: value, first
//! and second time derivative, side by side, below the joint points.

use kinema::lang::{Derivation, OutputSource};
use kinema::{Motion, Outputs};

use super::charts::{Lines, time_chart};
use super::legend::{Swatch, draw_legend_row};
use super::{Area, Drawn, MAX_SERIES, PALETTE, Samples, text, thinned};

/// Height of the outputs' panels [px].
pub(super) const HEIGHT: u32 = 320;

/// The measures' columns evaluated at the kept states: their names and,
/// per order (value, `_dot`, `_ddot`), one line each.
#[derive(Default)]
pub(super) struct Measures {
    names: Vec<String>,
    lines: [Lines; 3],
}

impl Measures {
    /// Evaluates the first [`MAX_SERIES`] measure columns of `system` (named
    /// points are drawn as joint points) at the thinned samples.
    pub(super) fn of<S: Outputs>(
        system: &S,
        derivation: &Derivation,
        samples: &Samples,
    ) -> Measures {
        let columns: Vec<usize> = derivation
            .outputs
            .iter()
            .enumerate()
            .filter(|(_, o)| matches!(o.source, OutputSource::Measure(_)))
            .map(|(k, _)| k)
            .take(MAX_SERIES)
            .collect();
        let mut out = Measures::default();
        if columns.is_empty() {
            return out;
        }
        let m = system.output_len();
        let mut scratch = system.scratch();
        let (mut y, mut yd, mut ydd) = (vec![0.0; m], vec![0.0; m], vec![0.0; m]);
        for (k, &c) in columns.iter().enumerate() {
            out.names.push(system.output_name(c).to_string());
            for lines in &mut out.lines {
                lines.push((PALETTE[k % PALETTE.len()], Vec::new()));
            }
        }
        for s in thinned(samples.len()) {
            let t = samples.t[s];
            let range = samples.range(s);
            let (Some(q), Some(qd), Some(qdd)) = (
                samples.q.get(range.clone()),
                samples.qd.get(range.clone()),
                samples.qdd.get(range),
            ) else {
                continue;
            };
            system.outputs(
                &mut scratch,
                Motion { t, q, qd, qdd },
                [&mut y, &mut yd, &mut ydd],
            );
            for (order, values) in [&y, &yd, &ydd].into_iter().enumerate() {
                for (k, &c) in columns.iter().enumerate() {
                    let v = values.get(c).copied().unwrap_or(f64::NAN);
                    out.lines[order][k].1.push((t, v));
                }
            }
        }
        out
    }

    /// Whether there is nothing to draw.
    pub(super) fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
}

/// Draws the measures: a legend row, then value, `_dot`, `_ddot` panels.
pub(super) fn draw_measures(
    area: &Area<'_>,
    measures: &Measures,
    warnings: &mut Vec<String>,
) -> Drawn {
    let area = area.titled("Outputs against time", text(16))?;
    let (legend, charts) = area.split_vertically(30);
    let entries: Vec<(String, Swatch)> = measures
        .names
        .iter()
        .zip(&measures.lines[0])
        .map(|(n, (color, _))| (n.clone(), Swatch::Line(*color, 2)))
        .collect();
    draw_legend_row(&legend, &entries)?;
    let panels = charts.split_evenly((1, 3));
    let what = [
        "value",
        "first derivative (_dot)",
        "second derivative (_ddot)",
    ];
    for (order, panel) in panels.iter().enumerate() {
        let reference = measures.lines[order]
            .iter()
            .flat_map(|(_, v)| v.iter().map(|&(_, y)| y.abs()))
            .filter(|y| y.is_finite())
            .fold(0.0_f64, f64::max);
        time_chart(
            panel,
            &format!("outputs, {}", what[order]),
            what[order],
            true,
            &measures.lines[order],
            reference,
            warnings,
        )?;
    }
    Ok(())
}
