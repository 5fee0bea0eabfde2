//! Quantities against time: the driven coordinates, and the joint points'
//! position, velocity and acceleration.

use plotters::prelude::*;

use super::legend::{Swatch, draw_legend_row};
use super::{
    Area, Drawn, MAX_DRIVEN, PALETTE, SafeAxis, Samples, Series, check_axis, check_extent,
    length_label, skip_panel, text, thinned, tick, units,
};
use crate::cli::scene::{Driven, Scene};

/// The driven quantities against time: position, velocity, acceleration,
/// side by side (`horizontal`) or stacked.
pub(super) fn draw_driven(
    area: &Area<'_>,
    scene: &Scene,
    samples: &Samples,
    horizontal: bool,
    warnings: &mut Vec<String>,
) -> Drawn {
    let area = area.titled("Driven coordinates", text(16))?;
    let (legend, charts) = area.split_vertically(30);
    let driven: Vec<&Driven> = scene.driven.iter().take(MAX_DRIVEN).collect();
    if driven.is_empty() {
        charts.draw_text("(the model has no driver)", &text(14), (70, 40))?;
        return Ok(());
    }
    let length = length_label(scene);
    let mut labels = Vec::new();
    let mut bases = Vec::new();
    for d in &driven {
        match d {
            Driven::Coordinate(i) => {
                let name = scene.coordinates.get(*i).cloned().unwrap_or_default();
                bases.push(if name.ends_with(".phi") {
                    "rad".to_string()
                } else {
                    length.clone()
                });
                labels.push(name);
            }
            Driven::PointComponent {
                label, component, ..
            } => {
                bases.push(length.clone());
                labels.push(format!("{} of {label}", ["x", "y"][(*component).min(1)]));
            }
        }
    }
    let common = bases
        .iter()
        .all(|b| *b == bases[0])
        .then(|| bases[0].clone());
    let entries: Vec<(String, Swatch)> = labels
        .iter()
        .zip(&bases)
        .enumerate()
        .map(|(k, (l, b))| {
            let label = if common.is_some() {
                l.clone()
            } else {
                format!("{l} [{b}]")
            };
            (label, Swatch::Line(PALETTE[(k + 2) % PALETTE.len()], 2))
        })
        .collect();
    draw_legend_row(&legend, &entries)?;
    let rows = charts.split_evenly(if horizontal { (1, 3) } else { (3, 1) });
    let names = ["position", "velocity", "acceleration"];
    let all: Vec<Lines> = (0..3)
        .map(|order| {
            driven
                .iter()
                .enumerate()
                .map(|(k, d)| {
                    let values = thinned(samples.len())
                        .into_iter()
                        .map(|s| {
                            let t = samples.t[s];
                            let v = match d {
                                Driven::Coordinate(i) => samples.coordinate(order, s, *i),
                                Driven::PointComponent {
                                    body,
                                    local,
                                    component,
                                    ..
                                } => samples.point(s, *body, *local).map_or(f64::NAN, |p| {
                                    [p.position, p.velocity, p.acceleration][order]
                                        [(*component).min(1)]
                                }),
                            };
                            (t, v)
                        })
                        .collect();
                    (PALETTE[(k + 2) % PALETTE.len()], values)
                })
                .collect()
        })
        .collect();
    let reference = references(&all, samples);
    for (order, (panel, series)) in rows.iter().zip(&all).enumerate() {
        let y_desc = match &common {
            Some(base) => format!("{} [{}]", names[order], units(base)[order]),
            None => names[order].to_string(),
        };
        time_chart(
            panel,
            &format!("driven {}", names[order]),
            &y_desc,
            horizontal || order == 2,
            series,
            reference[order],
            warnings,
        )?;
    }
    Ok(())
}

/// Joint points against time: x (left) and y (right) of position,
/// velocity and acceleration (rows).
pub(super) fn draw_points(
    area: &Area<'_>,
    scene: &Scene,
    samples: &Samples,
    series: &[&Series],
    warnings: &mut Vec<String>,
) -> Drawn {
    let area = area.titled(
        "Joint points against time: x (left) and y (right) components",
        text(16),
    )?;
    let (legend, charts) = area.split_vertically(30);
    if series.is_empty() {
        charts.draw_text("(no moving joint point)", &text(14), (70, 40))?;
        return Ok(());
    }
    let entries: Vec<(String, Swatch)> = series
        .iter()
        .map(|s| (s.label.clone(), Swatch::Line(s.color, 2)))
        .collect();
    draw_legend_row(&legend, &entries)?;
    let u = units(&length_label(scene));
    let names = ["position", "velocity", "acceleration"];
    let panels = charts.split_evenly((3, 2));
    // Panel p shows order p / 2 of component p % 2.
    let all: Vec<Lines> = (0..6)
        .map(|p| {
            let (order, component) = (p / 2, p % 2);
            series
                .iter()
                .map(|s| {
                    let values = thinned(samples.len())
                        .into_iter()
                        .map(|k| {
                            let v = samples.point(k, s.body, s.local).map_or(f64::NAN, |pk| {
                                [pk.position, pk.velocity, pk.acceleration][order][component]
                            });
                            (samples.t[k], v)
                        })
                        .collect();
                    (s.color, values)
                })
                .collect()
        })
        .collect();
    // One reference per order, over both components.
    let by_order: Vec<Lines> = (0..3)
        .map(|order| {
            all[2 * order]
                .iter()
                .chain(&all[2 * order + 1])
                .cloned()
                .collect()
        })
        .collect();
    let reference = references(&by_order, samples);
    for (p, (panel, lines)) in panels.iter().zip(&all).enumerate() {
        let (order, component) = (p / 2, p % 2);
        let axis = ["x", "y"][component];
        let y_desc = format!("{axis} {} [{}]", names[order], u[order]);
        time_chart(
            panel,
            &format!("the joint points' {axis} {}", names[order]),
            &y_desc,
            order == 2,
            lines,
            reference[order],
            warnings,
        )?;
    }
    Ok(())
}

/// Curves of one panel: colour and (t, value) points.
pub(super) type Lines = Vec<(RGBColor, Vec<(f64, f64)>)>;

/// A typical magnitude of position, velocity and acceleration of a group
/// of curves (`lines[order]`): the largest value, and at least the
/// position's size over the run's duration to the power `order`.
/// Variations below 1e-9 of it are roundoff and are drawn flat.
fn references(lines: &[Lines], samples: &Samples) -> [f64; 3] {
    let max_abs = |l: &Lines| {
        l.iter()
            .flat_map(|(_, v)| v.iter().map(|&(_, y)| y.abs()))
            .filter(|y| y.is_finite())
            .fold(0.0_f64, f64::max)
    };
    let duration = match (samples.t.first(), samples.t.last()) {
        (Some(a), Some(b)) if b > a => b - a,
        _ => 1.0,
    };
    let position = lines.first().map_or(0.0, max_abs);
    let mut out = [0.0; 3];
    for (order, r) in out.iter_mut().enumerate() {
        let own = lines.get(order).map_or(0.0, max_abs);
        *r = own.max(position / duration.powi(order as i32));
    }
    out
}

/// One panel against time; `reference` is a typical magnitude of the
/// quantity (see [`references`]). A panel whose values cannot be drawn
/// (beyond ±[`super::MAX_AXIS`]) shows why, and `what` is named in a
/// warning.
pub(super) fn time_chart(
    area: &Area<'_>,
    what: &str,
    y_desc: &str,
    x_desc: bool,
    series: &[(RGBColor, Vec<(f64, f64)>)],
    reference: f64,
    warnings: &mut Vec<String>,
) -> Drawn {
    let mut t = [f64::INFINITY, f64::NEG_INFINITY];
    let mut y = [f64::INFINITY, f64::NEG_INFINITY];
    for (_, values) in series {
        for &(ti, v) in values {
            if ti.is_finite() && v.is_finite() {
                t = [t[0].min(ti), t[1].max(ti)];
                y = [y[0].min(v), y[1].max(v)];
            }
        }
    }
    if !(t[0].is_finite() && t[1].is_finite()) {
        t = [0.0, 1.0];
    }
    if t[1] - t[0] <= 0.0 {
        t = [t[0] - 0.5, t[0] + 0.5];
    }
    if !(y[0].is_finite() && y[1].is_finite()) {
        y = [-1.0, 1.0];
    }
    // Huge values are refused before any padding can overflow.
    if let Err(why) = check_extent(t[0], t[1]) {
        return skip_panel(area, what, &format!("the time axis: {why}"), warnings);
    }
    if let Err(why) = check_extent(y[0], y[1]) {
        return skip_panel(area, what, &why, warnings);
    }
    // A reference from other, undrawable panels must not widen this one
    // beyond what can be drawn.
    let reference = if reference.is_finite() {
        reference.min(super::MAX_AXIS)
    } else {
        0.0
    };
    let span = y[1] - y[0];
    let reference = reference.max(y[0].abs()).max(y[1].abs());
    if span <= 1e-9 * reference || span == 0.0 {
        // Constant up to roundoff: centred on its value, with room around.
        let mid = 0.5 * (y[0] + y[1]);
        let pad = (0.1 * mid.abs()).max(1e-3 * reference);
        let pad = if pad > 0.0 {
            pad.max(10.0 * super::MIN_SPAN)
        } else {
            1.0
        };
        y = [mid - pad, mid + pad];
    } else {
        y = [y[0] - 0.06 * span, y[1] + 0.06 * span];
    }
    if let Err(why) = check_axis(t) {
        return skip_panel(area, what, &format!("the time axis: {why}"), warnings);
    }
    if let Err(why) = check_axis(y) {
        return skip_panel(area, what, &why, warnings);
    }
    let mut chart = ChartBuilder::on(area)
        .margin(8)
        .margin_right(16)
        .x_label_area_size(if x_desc { 40 } else { 24 })
        .y_label_area_size(76)
        .build_cartesian_2d(SafeAxis::new(t), SafeAxis::new(y))?;
    let y_ticks = |v: &f64| tick(*v, y[1] - y[0]);
    let mut mesh = chart.configure_mesh();
    mesh.y_desc(y_desc)
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(220, 220, 220))
        .label_style(text(11))
        .axis_desc_style(text(13))
        .y_labels(6)
        .x_labels(8)
        .y_label_formatter(&y_ticks);
    if x_desc {
        mesh.x_desc("t [s]");
    }
    mesh.draw()?;
    for (color, values) in series {
        let clean = values
            .iter()
            .copied()
            .filter(|(a, b)| a.is_finite() && b.is_finite());
        chart.draw_series(LineSeries::new(clean, color.stroke_width(2)))?;
    }
    Ok(())
}
