//! The dynamics panels of `--plot`: reaction forces (magnitude of each
//! element's force on each body, the largest few) and driver efforts
//! against time, for a model with inertia; for forward dynamics, the
//! energies and their balance.

use plotters::prelude::*;

use super::charts::time_chart;
use super::legend::{Swatch, draw_legend_row};
use super::{Area, Drawn, MAX_SERIES, PALETTE, Samples, text};

/// Height of the dynamics row.
pub(super) const HEIGHT: u32 = 340;

/// Height of the energy row (forward dynamics).
pub(super) const ENERGY_HEIGHT: u32 = 340;

/// Draws the energy panel of forward dynamics: kinetic T, potential V
/// (gravity), the work W of the other forces and drivers since the start,
/// and the balance T + V − W, which stays at its initial value when the
/// integration is exact; its legend gives how far it strayed.
pub(super) fn draw_energy(area: &Area<'_>, samples: &Samples, warnings: &mut Vec<String>) -> Drawn {
    let t = &samples.t;
    let series = |f: &dyn Fn(&[f64; 3]) -> f64| -> Vec<(f64, f64)> {
        t.iter()
            .zip(&samples.energy)
            .map(|(&ti, e)| (ti, f(e)))
            .collect()
    };
    let balance = series(&|e| e[0] + e[1] - e[2]);
    let first = balance.first().map_or(f64::NAN, |p| p.1);
    let drift = balance.iter().fold(0.0_f64, |m, &(_, b)| {
        if (b - first).is_nan() {
            f64::NAN
        } else {
            m.max((b - first).abs())
        }
    });
    let lines = [
        ("kinetic T".to_owned(), series(&|e| e[0])),
        ("potential V (gravity)".to_owned(), series(&|e| e[1])),
        ("work W of the other forces".to_owned(), series(&|e| e[2])),
        (format!("balance T + V − W (strays {drift:.2e})"), balance),
    ];
    panel(area, "Energy", "energy", &lines, warnings)
}

/// Draws the two panels side by side.
pub(super) fn draw(area: &Area<'_>, samples: &Samples, warnings: &mut Vec<String>) -> Drawn {
    let (left, right) = area.split_horizontally(area.dim_in_pixel().0 / 2);
    let names = &samples.dyn_names;
    let width = names.len();
    let t = &samples.t;
    let column = |k: usize| -> Vec<(f64, f64)> {
        t.iter()
            .zip(samples.dyn_values.chunks_exact(width.max(1)))
            .map(|(&ti, row)| (ti, row.get(k).copied().unwrap_or(f64::NAN)))
            .collect()
    };
    // Reaction force magnitudes |F| per element and body, the largest peaks.
    let mut forces: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for (k, name) in names.iter().enumerate() {
        let Some(base) = name.strip_suffix(".Fx") else {
            continue;
        };
        let fy = names.iter().position(|n| *n == format!("{base}.Fy"));
        let Some(fy) = fy else { continue };
        let (x, y) = (column(k), column(fy));
        let magnitude = x
            .iter()
            .zip(&y)
            .map(|(&(ti, a), &(_, b))| (ti, a.hypot(b)))
            .collect();
        forces.push((base.trim_start_matches("reaction.").to_owned(), magnitude));
    }
    let peak = |v: &Vec<(f64, f64)>| v.iter().fold(0.0_f64, |m, &(_, x)| m.max(x.abs()));
    forces.sort_by(|a, b| peak(&b.1).total_cmp(&peak(&a.1)));
    forces.truncate(MAX_SERIES);
    let efforts: Vec<(String, Vec<(f64, f64)>)> = names
        .iter()
        .enumerate()
        .filter_map(|(k, n)| n.strip_prefix("driver.").map(|d| (d.to_owned(), column(k))))
        .take(MAX_SERIES)
        .collect();
    panel(&left, "Reaction forces |F|", "force", &forces, warnings)?;
    panel(
        &right,
        "Driver efforts",
        "force or torque",
        &efforts,
        warnings,
    )
}

fn panel(
    area: &Area<'_>,
    title: &str,
    y_desc: &str,
    lines: &[(String, Vec<(f64, f64)>)],
    warnings: &mut Vec<String>,
) -> Drawn {
    let area = area.titled(title, text(16))?;
    let (legend, chart) = area.split_vertically(30);
    if lines.is_empty() {
        chart.draw_text("(none)", &text(14), (70, 40))?;
        return Ok(());
    }
    let entries: Vec<(String, Swatch)> = lines
        .iter()
        .enumerate()
        .map(|(k, (l, _))| (l.clone(), Swatch::Line(PALETTE[k % PALETTE.len()], 2)))
        .collect();
    draw_legend_row(&legend, &entries)?;
    let series: Vec<(RGBColor, Vec<(f64, f64)>)> = lines
        .iter()
        .enumerate()
        .map(|(k, (_, v))| (PALETTE[k % PALETTE.len()], v.clone()))
        .collect();
    let reference = lines
        .iter()
        .flat_map(|(_, v)| v.iter().map(|p| p.1.abs()))
        .filter(|x| x.is_finite())
        .fold(0.0_f64, f64::max);
    time_chart(&chart, title, y_desc, true, &series, reference, warnings)
}
