//! `kinema fit --plot`: the best design over its targets. Two target
//! columns are drawn as a path (the second against the first, over the
//! cycle, with equal scales), the targets as rings and each achieved
//! point joined to its target; any other number of columns against time.

use kinema::fit::{Design, Targets, Trace};
use plotters::prelude::*;

const WIDTH: u32 = 900;
const HEIGHT: u32 = 700;

/// The figure as SVG text.
///
/// # Errors
/// Drawing failed (plotters' message), or the trace has no finite value.
pub fn draw(trace: &Trace, targets: Targets, design: &Design) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let w = targets.columns().len();
        let achieved = |i: usize, c: usize| targets.row(i)[c] + design.errors()[i * w + c];
        if w == 2 {
            let xs = trace.values[0]
                .iter()
                .chain((0..targets.rows()).map(|i| &targets.row(i)[0]));
            let ys = trace.values[1]
                .iter()
                .chain((0..targets.rows()).map(|i| &targets.row(i)[1]));
            let (x0, x1) = extent(xs)?;
            let (y0, y1) = extent(ys)?;
            // Equal scales: a path's shape is what matters.
            let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
            let aspect = f64::from(WIDTH - 80) / f64::from(HEIGHT - 100);
            let half_h = ((y1 - y0) / 2.0).max((x1 - x0) / 2.0 / aspect) * 1.08;
            let half_w = half_h * aspect;
            let mut chart = ChartBuilder::on(&root)
                .caption(
                    format!(
                        "{} against {}: fitted path (line), targets (rings); rms error {:.3e}",
                        trace.columns[1],
                        trace.columns[0],
                        design.rms()
                    ),
                    ("sans-serif", 16),
                )
                .margin(15)
                .x_label_area_size(35)
                .y_label_area_size(55)
                .build_cartesian_2d(cx - half_w..cx + half_w, cy - half_h..cy + half_h)
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc(trace.columns[0].as_str())
                .y_desc(trace.columns[1].as_str())
                .draw()
                .map_err(|e| e.to_string())?;
            chart
                .draw_series(LineSeries::new(
                    trace.values[0]
                        .iter()
                        .zip(&trace.values[1])
                        .map(|(x, y)| (*x, *y)),
                    BLUE.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?;
            for i in 0..targets.rows() {
                let t = (targets.row(i)[0], targets.row(i)[1]);
                let a = (achieved(i, 0), achieved(i, 1));
                chart
                    .draw_series(LineSeries::new([t, a], RED.stroke_width(1)))
                    .map_err(|e| e.to_string())?;
                chart
                    .draw_series([Circle::new(t, 6, RED.stroke_width(2))])
                    .map_err(|e| e.to_string())?;
                chart
                    .draw_series([Circle::new(a, 2, BLUE.filled())])
                    .map_err(|e| e.to_string())?;
            }
        } else {
            let panels = root.split_evenly((w, 1));
            for (c, panel) in panels.iter().enumerate() {
                let times = design.times();
                let (t0, t1) = extent(trace.t.iter().chain(times))?;
                let ys = trace.values[c]
                    .iter()
                    .chain((0..targets.rows()).map(|i| &targets.row(i)[c]));
                let (y0, y1) = extent(ys)?;
                let pad = ((y1 - y0) * 0.08).max(1e-12);
                let mut chart = ChartBuilder::on(panel)
                    .caption(
                        format!(
                            "{} against t: fitted (line), targets (rings)",
                            trace.columns[c]
                        ),
                        ("sans-serif", 15),
                    )
                    .margin(12)
                    .x_label_area_size(30)
                    .y_label_area_size(55)
                    .build_cartesian_2d(t0..t1.max(t0 + 1e-12), y0 - pad..y1 + pad)
                    .map_err(|e| e.to_string())?;
                chart
                    .configure_mesh()
                    .x_desc("t")
                    .draw()
                    .map_err(|e| e.to_string())?;
                chart
                    .draw_series(LineSeries::new(
                        trace.t.iter().zip(&trace.values[c]).map(|(t, y)| (*t, *y)),
                        BLUE.stroke_width(2),
                    ))
                    .map_err(|e| e.to_string())?;
                chart
                    .draw_series(
                        times.iter().enumerate().map(|(i, &t)| {
                            Circle::new((t, targets.row(i)[c]), 6, RED.stroke_width(2))
                        }),
                    )
                    .map_err(|e| e.to_string())?;
            }
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

/// The finite values' range (widened when flat).
fn extent<'a>(values: impl Iterator<Item = &'a f64>) -> Result<(f64, f64), String> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return Err("no finite value to draw".to_owned());
    }
    if hi - lo < 1e-12 {
        return Ok((lo - 0.5, hi + 0.5));
    }
    Ok((lo, hi))
}
