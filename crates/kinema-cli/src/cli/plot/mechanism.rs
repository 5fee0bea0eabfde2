//! The mechanism view: bodies at several instants, the paths of their
//! joint points, ground pivots; equal aspect.

use kinema::{Axis, Body};
use plotters::prelude::*;

use super::legend::{Swatch, draw_legend_column};
use super::{
    Area, Drawn, SafeAxis, Samples, Series, check_axis, check_extent, length_label, skip_panel,
    spread, text, thinned, tick,
};
use crate::cli::output::time;
use crate::cli::scene::{BodyShape, Rgb, Scene, Traced};

/// Splits the traced points into moving ones (a point that coincides with
/// an earlier one at every state left out) and the positions of fixed ones
/// (drawn as pivots). A body none of whose traced points moves gets its
/// frame origin traced instead (the pendulum's bar).
pub(crate) fn classify(scene: &Scene, samples: &Samples) -> (Vec<Traced>, Vec<[f64; 2]>) {
    let extent = scene_extent(scene, samples);
    let tol = 1e-9 * extent.max(1e-300);
    let probe = spread(samples.len(), 5);
    let all = thinned(samples.len());
    let close = |p: [f64; 2], r: [f64; 2]| (p[0] - r[0]).abs() <= tol && (p[1] - r[1]).abs() <= tol;
    let origins = scene.bodies.iter().enumerate().map(|(i, b)| Traced {
        body: i,
        local: [0.0, 0.0],
        label: format!("{} (frame origin)", b.name),
    });
    let candidates: Vec<(bool, Traced)> = scene
        .traced
        .iter()
        .cloned()
        .map(|t| (false, t))
        .chain(origins.map(|t| (true, t)))
        .collect();
    let mut moving: Vec<Traced> = Vec::new();
    let mut fixed: Vec<[f64; 2]> = Vec::new();
    for (origin, t) in candidates {
        if origin && moving.iter().any(|m| m.body == t.body) {
            continue;
        }
        let first = samples.position(0, t.body, t.local);
        if !first.iter().all(|v| v.is_finite()) {
            continue;
        }
        let still = all
            .iter()
            .all(|&k| close(samples.position(k, t.body, t.local), first));
        if still {
            if !origin && !fixed.iter().any(|f| close(*f, first)) {
                fixed.push(first);
            }
            continue;
        }
        let same_as = |o: &Traced| {
            let coincide = |k: &usize| {
                close(
                    samples.position(*k, t.body, t.local),
                    samples.position(*k, o.body, o.local),
                )
            };
            probe.iter().all(coincide) && all.iter().all(coincide)
        };
        if !moving.iter().any(same_as) {
            moving.push(t);
        }
    }
    for g in &scene.ground {
        if !fixed.iter().any(|f| close(*f, *g)) {
            fixed.push(*g);
        }
    }
    (moving, fixed)
}

/// Size of what is drawn: the larger side of the bounding box of the
/// bodies' points over a few states, and of the ground points.
pub(super) fn scene_extent(scene: &Scene, samples: &Samples) -> f64 {
    let mut b = Bounds::default();
    for k in spread(samples.len(), 5) {
        for (i, body) in scene.bodies.iter().enumerate() {
            b.add(samples.position(k, i, [0.0, 0.0]));
            for p in &body.points {
                b.add(samples.position(k, i, *p));
            }
        }
    }
    for g in &scene.ground {
        b.add(*g);
    }
    b.size()
}

/// An axis-aligned bounding box.
#[derive(Debug, Clone, Copy)]
pub(super) struct Bounds {
    pub(super) x: [f64; 2],
    pub(super) y: [f64; 2],
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds {
            x: [f64::INFINITY, f64::NEG_INFINITY],
            y: [f64::INFINITY, f64::NEG_INFINITY],
        }
    }
}

impl Bounds {
    fn add(&mut self, p: [f64; 2]) {
        if p[0].is_finite() && p[1].is_finite() {
            self.x = [self.x[0].min(p[0]), self.x[1].max(p[0])];
            self.y = [self.y[0].min(p[1]), self.y[1].max(p[1])];
        }
    }

    fn is_empty(&self) -> bool {
        !(self.x[0] <= self.x[1] && self.y[0] <= self.y[1])
    }

    /// Whether the box can be drawn: finite, within ±[`super::MAX_AXIS`]
    /// (so that no padding overflows); the reason otherwise.
    pub(super) fn check(&self) -> Result<(), String> {
        if self.is_empty() {
            return Err("there is no finite point to draw".to_string());
        }
        check_extent(self.x[0], self.x[1]).map_err(|w| format!("x: {w}"))?;
        check_extent(self.y[0], self.y[1]).map_err(|w| format!("y: {w}"))
    }

    fn size(&self) -> f64 {
        if self.is_empty() {
            0.0
        } else {
            (self.x[1] - self.x[0]).max(self.y[1] - self.y[0])
        }
    }
}

/// Grey of instant `j` of `m`: light early, near black last.
pub(super) fn instant_color(j: usize, m: usize) -> RGBColor {
    let f = if m <= 1 {
        1.0
    } else {
        j as f64 / (m - 1) as f64
    };
    let level = (200.0 - 170.0 * f).round().clamp(0.0, 255.0) as u8;
    RGBColor(level, level, level)
}

pub(super) fn rgb(c: Rgb) -> RGBColor {
    let b = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    RGBColor(b(c[0]), b(c[1]), b(c[2]))
}

pub(super) fn rotate(phi: f64, s: [f64; 2]) -> [f64; 2] {
    let (sn, c) = phi.sin_cos();
    [c * s[0] - sn * s[1], sn * s[0] + c * s[1]]
}

/// Global position of local point `s` of body `i` at state `k`.
pub(super) fn global(samples: &Samples, k: usize, i: usize, s: [f64; 2]) -> [f64; 2] {
    samples.position(k, i, s)
}

/// Convex hull (monotone chain) of a few points, counter-clockwise.
pub(crate) fn hull(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut p: Vec<[f64; 2]> = points.to_vec();
    p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut lower: Vec<[f64; 2]> = Vec::new();
    for &q in &p {
        while lower.len() >= 2 && cross(lower[lower.len() - 2], lower[lower.len() - 1], q) <= 0.0 {
            lower.pop();
        }
        lower.push(q);
    }
    let mut upper: Vec<[f64; 2]> = Vec::new();
    for &q in p.iter().rev() {
        while upper.len() >= 2 && cross(upper[upper.len() - 2], upper[upper.len() - 1], q) <= 0.0 {
            upper.pop();
        }
        upper.push(q);
    }
    lower.pop();
    upper.pop();
    lower.extend(upper);
    lower
}

/// Data ranges around `b` with the aspect ratio of a `w` × `h` px plot, a
/// 6 % margin.
pub(super) fn equal_aspect(b: Bounds, w: f64, h: f64) -> ([f64; 2], [f64; 2]) {
    let (mut dx, mut dy) = (b.x[1] - b.x[0], b.y[1] - b.y[0]);
    let size = dx.max(dy);
    // A margin of 6 %, and at least a millionth of the coordinates'
    // magnitude (one point far from the origin) or 1 (one point at it).
    let magnitude = [b.x[0], b.x[1], b.y[0], b.y[1]]
        .iter()
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    let pad = (0.06 * size).max(1e-6 * magnitude);
    let pad = if pad > 0.0 { pad } else { 1.0 };
    dx += 2.0 * pad;
    dy += 2.0 * pad;
    let scale = (dx / w).max(dy / h);
    let (cx, cy) = (0.5 * (b.x[0] + b.x[1]), 0.5 * (b.y[0] + b.y[1]));
    let (hx, hy) = (0.5 * scale * w, 0.5 * scale * h);
    ([cx - hx, cx + hx], [cy - hy, cy + hy])
}

/// What has to fit in the mechanism view: the bodies at the drawn
/// instants, the paths, the fixed points; simEngine2D `xlim`/`ylim` when
/// given.
pub(super) fn mechanism_bounds(
    scene: &Scene,
    samples: &Samples,
    paths: &[Series],
    fixed: &[[f64; 2]],
    instants: &[usize],
) -> Bounds {
    if let Some((x, y)) = scene.limits {
        // Limits as written in the file: in either order, possibly equal
        // (a zero-width limit is widened by `equal_aspect`).
        return Bounds {
            x: [x[0].min(x[1]), x[0].max(x[1])],
            y: [y[0].min(y[1]), y[0].max(y[1])],
        };
    }
    let mut b = Bounds::default();
    for &k in instants {
        for (i, body) in scene.bodies.iter().enumerate() {
            b.add(global(samples, k, i, [0.0, 0.0]));
            for p in &body.points {
                b.add(global(samples, k, i, *p));
            }
            for (loc, size) in &body.rects {
                for c in rect_corners(*loc, *size) {
                    b.add(global(samples, k, i, c));
                }
            }
        }
    }
    for s in paths {
        for k in thinned(samples.len()) {
            b.add(samples.position(k, s.body, s.local));
        }
    }
    for f in fixed {
        b.add(*f);
    }
    if b.is_empty() {
        return Bounds {
            x: [-1.0, 1.0],
            y: [-1.0, 1.0],
        };
    }
    // Room below the lowest point for the ground symbols (none when the
    // box is beyond what can be drawn: the view is skipped).
    if b.check().is_ok() {
        let s = 0.05 * b.size();
        b.y[0] -= s;
    }
    b
}

/// The mechanism view: what to draw.
pub(super) struct Mechanism<'a> {
    pub(super) scene: &'a Scene,
    pub(super) samples: &'a Samples,
    pub(super) paths: &'a [Series],
    pub(super) fixed: &'a [[f64; 2]],
    pub(super) instants: &'a [usize],
    pub(super) bounds: Bounds,
}

impl Mechanism<'_> {
    /// Draws the view on `view` and its legend on `legend`; a view whose
    /// coordinates cannot be drawn shows why, with a warning.
    pub(super) fn draw(
        &self,
        view: &Area<'_>,
        legend: &Area<'_>,
        warnings: &mut Vec<String>,
    ) -> Drawn {
        let Mechanism {
            scene,
            fixed,
            bounds: b,
            ..
        } = *self;

        let area = view.titled(
            "Mechanism at several instants, with the paths of its joint points",
            text(16),
        )?;
        let (margin, x_label, y_label) = (12u32, 44u32, 70u32);
        let (w, h) = area.dim_in_pixel();
        let plot_w = f64::from(w.saturating_sub(2 * margin + y_label).max(10));
        let plot_h = f64::from(h.saturating_sub(2 * margin + x_label).max(10));
        const WHAT: &str = "the mechanism view";
        if let Err(why) = b.check() {
            return skip_panel(&area, WHAT, &why, warnings);
        }
        let (xr, yr) = equal_aspect(b, plot_w, plot_h);
        if let Err(why) = check_axis(xr) {
            return skip_panel(&area, WHAT, &format!("x: {why}"), warnings);
        }
        if let Err(why) = check_axis(yr) {
            return skip_panel(&area, WHAT, &format!("y: {why}"), warnings);
        }
        // Symbol sizes follow what is drawn (a tenth of the view for a
        // single point), whatever its scale.
        let size = match b.size() {
            s if s > 0.0 => s,
            _ => 0.1 * (xr[1] - xr[0]).min(yr[1] - yr[0]),
        };
        let mut chart = ChartBuilder::on(&area)
            .margin(margin)
            .x_label_area_size(x_label)
            .y_label_area_size(y_label)
            .build_cartesian_2d(SafeAxis::new(xr), SafeAxis::new(yr))?;
        let unit = length_label(scene);
        chart
            .configure_mesh()
            .x_desc(format!("x [{unit}]"))
            .y_desc(format!("y [{unit}]"))
            .light_line_style(RGBColor(240, 240, 240))
            .bold_line_style(RGBColor(220, 220, 220))
            .label_style(text(12))
            .axis_desc_style(text(14))
            .x_label_formatter(&|v| tick(*v, xr[1] - xr[0]))
            .y_label_formatter(&|v| tick(*v, yr[1] - yr[0]))
            .draw()?;

        self.draw_paths(&mut chart)?;
        self.draw_bodies(&mut chart, size)?;
        for f in fixed {
            draw_ground(&mut chart, *f, 0.035 * size)?;
        }
        draw_legend_column(legend, &self.legend_entries())
    }

    /// The paths of the joint points, first, under the bodies.
    fn draw_paths(&self, chart: &mut MechChart<'_, '_>) -> Drawn {
        let samples = self.samples;
        for s in self.paths {
            let line: Vec<(f64, f64)> = thinned(samples.len())
                .into_iter()
                .map(|k| samples.position(k, s.body, s.local))
                .filter(|p| p[0].is_finite() && p[1].is_finite())
                .map(|p| (p[0], p[1]))
                .collect();
            chart.draw_series(std::iter::once(PathElement::new(
                line,
                s.color.stroke_width(2),
            )))?;
        }
        Ok(())
    }

    /// The bodies at each instant, earliest (lightest) first; `size`: the
    /// extent of what is drawn, which symbol sizes follow.
    fn draw_bodies(&self, chart: &mut MechChart<'_, '_>, size: f64) -> Drawn {
        let block = [0.07 * size, 0.04 * size];
        let m = self.instants.len();
        for (j, &k) in self.instants.iter().enumerate() {
            let grey = instant_color(j, m);
            let last = j + 1 == m;
            let width = if last { 3 } else { 2 };
            let pen = Pen { grey, width, block };
            for (i, body) in self.scene.bodies.iter().enumerate() {
                let at = BodyAt {
                    samples: self.samples,
                    k,
                    i,
                };
                draw_body(chart, at, body, pen, last)?;
            }
        }
        Ok(())
    }

    /// The legend: the instants' times and shades, the paths, the symbols.
    fn legend_entries(&self) -> Vec<(String, Swatch)> {
        let m = self.instants.len();
        let mut entries: Vec<(String, Swatch)> = vec![("Instants".to_string(), Swatch::Heading)];
        for (j, &k) in self.instants.iter().enumerate() {
            let t = self.samples.t.get(k).copied().unwrap_or(f64::NAN);
            entries.push((
                format!("t = {} s", time(t)),
                Swatch::Line(instant_color(j, m), 3),
            ));
        }
        if !self.paths.is_empty() {
            entries.push(("Paths of points".to_string(), Swatch::Heading));
        }
        for p in self.paths {
            entries.push((p.label.clone(), Swatch::Line(p.color, 2)));
        }
        entries.push(("Symbols".to_string(), Swatch::Heading));
        if !self.fixed.is_empty() {
            entries.push(("fixed point".to_string(), Swatch::Pivot));
        }
        entries.push(("joint point".to_string(), Swatch::Joint));
        entries
    }
}

/// A ground pivot or fixed point at `f`: a hatched triangle of size `s`
/// below it and a joint circle on it.
fn draw_ground(chart: &mut MechChart<'_, '_>, f: [f64; 2], s: f64) -> Drawn {
    let (x, y) = (f[0], f[1]);
    let base = y - 0.9 * s;
    chart.draw_series(std::iter::once(Polygon::new(
        vec![(x, y), (x - 0.55 * s, base), (x + 0.55 * s, base)],
        RGBColor(120, 120, 120).mix(0.35).filled(),
    )))?;
    chart.draw_series(std::iter::once(PathElement::new(
        vec![(x, y), (x - 0.55 * s, base), (x + 0.55 * s, base), (x, y)],
        BLACK.stroke_width(1),
    )))?;
    chart.draw_series(std::iter::once(PathElement::new(
        vec![(x - 0.8 * s, base), (x + 0.8 * s, base)],
        BLACK.stroke_width(2),
    )))?;
    for h in 0..5 {
        let x0 = x - 0.8 * s + f64::from(h) * 0.4 * s;
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(x0, base), (x0 - 0.25 * s, base - 0.3 * s)],
            BLACK.stroke_width(1),
        )))?;
    }
    chart.draw_series(std::iter::once(Circle::new((x, y), 4, WHITE.filled())))?;
    chart.draw_series(std::iter::once(Circle::new(
        (x, y),
        4,
        BLACK.stroke_width(2),
    )))?;
    Ok(())
}

pub(super) fn rect_corners(loc: [f64; 2], size: [f64; 2]) -> [[f64; 2]; 4] {
    let (hw, hh) = (0.5 * size[0], 0.5 * size[1]);
    [
        [loc[0] - hw, loc[1] - hh],
        [loc[0] + hw, loc[1] - hh],
        [loc[0] + hw, loc[1] + hh],
        [loc[0] - hw, loc[1] + hh],
    ]
}

pub(super) type MechChart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<SafeAxis, SafeAxis>>;

/// Body `i` at state `k` of the samples: where a drawing of it is placed.
#[derive(Clone, Copy)]
pub(super) struct BodyAt<'a> {
    pub(super) samples: &'a Samples,
    pub(super) k: usize,
    pub(super) i: usize,
}

/// How an instant's bodies are drawn: the instant's grey, the line width,
/// and the size of a block (slider).
#[derive(Clone, Copy)]
pub(super) struct Pen {
    pub(super) grey: RGBColor,
    pub(super) width: u32,
    pub(super) block: [f64; 2],
}

/// One body at state `k`: simEngine2D rectangles if it has any; then the
/// link between its joint points (a bar for two, a plate for more, a block
/// for a single point at its origin), and its joints as small circles;
/// `last`: the latest instant, drawn strongest.
pub(super) fn draw_body(
    chart: &mut MechChart<'_, '_>,
    at: BodyAt<'_>,
    body: &BodyShape,
    pen: Pen,
    last: bool,
) -> Drawn {
    let BodyAt { samples, k, i } = at;
    let Pen { grey, width, .. } = pen;
    let phi = samples.coordinate(0, k, Body::new(i).coord(Axis::Phi).index());
    let to = |p: [f64; 2]| -> (f64, f64) {
        let g = global(samples, k, i, p);
        (g[0], g[1])
    };
    for (loc, size) in &body.rects {
        let corners: Vec<(f64, f64)> = rect_corners(*loc, *size).into_iter().map(to).collect();
        let fill = body.color.map_or(grey, rgb);
        let alpha = if last { 0.45 } else { 0.12 };
        chart.draw_series(std::iter::once(Polygon::new(
            corners.clone(),
            fill.mix(alpha).filled(),
        )))?;
        let mut outline = corners;
        if let Some(&first) = outline.first() {
            outline.push(first);
        }
        chart.draw_series(std::iter::once(PathElement::new(
            outline,
            grey.stroke_width(1),
        )))?;
    }
    let points = &body.points;
    let origin = [0.0, 0.0];
    match points.len() {
        0 => {
            draw_block(chart, at, phi, pen)?;
        }
        1 => {
            if points[0] == origin {
                draw_block(chart, at, phi, pen)?;
            } else {
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![to(points[0]), to(origin)],
                    grey.stroke_width(width + 1),
                )))?;
            }
        }
        2 => {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![to(points[0]), to(points[1])],
                grey.stroke_width(width + 1),
            )))?;
        }
        _ => {
            let h: Vec<(f64, f64)> = hull(points).into_iter().map(to).collect();
            chart.draw_series(std::iter::once(Polygon::new(
                h.clone(),
                grey.mix(0.18).filled(),
            )))?;
            let mut outline = h;
            if let Some(&first) = outline.first() {
                outline.push(first);
            }
            chart.draw_series(std::iter::once(PathElement::new(
                outline,
                grey.stroke_width(width),
            )))?;
        }
    }
    for p in points {
        let c = to(*p);
        chart.draw_series(std::iter::once(Circle::new(c, 3, WHITE.filled())))?;
        chart.draw_series(std::iter::once(Circle::new(c, 3, grey.stroke_width(1))))?;
    }
    Ok(())
}

/// A block (slider) centred on the body's origin, turned with it (`phi`).
pub(super) fn draw_block(
    chart: &mut MechChart<'_, '_>,
    at: BodyAt<'_>,
    phi: f64,
    pen: Pen,
) -> Drawn {
    let BodyAt { samples, k, i } = at;
    let Pen { grey, width, block } = pen;
    let r = global(samples, k, i, [0.0, 0.0]);
    if !(phi.is_finite() && r[0].is_finite() && r[1].is_finite()) {
        return Ok(());
    }
    let corners: Vec<(f64, f64)> = rect_corners([0.0, 0.0], block)
        .into_iter()
        .map(|c| {
            let g = rotate(phi, c);
            (r[0] + g[0], r[1] + g[1])
        })
        .collect();
    chart.draw_series(std::iter::once(Polygon::new(
        corners.clone(),
        grey.mix(0.25).filled(),
    )))?;
    let mut outline = corners;
    if let Some(&first) = outline.first() {
        outline.push(first);
    }
    chart.draw_series(std::iter::once(PathElement::new(
        outline,
        grey.stroke_width(width),
    )))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_a_square_with_centre() {
        let h = hull(&[[0.0, 0.0], [1.0, 0.0], [0.5, 0.5], [1.0, 1.0], [0.0, 1.0]]);
        assert_eq!(h.len(), 4);
    }

    #[test]
    fn equal_aspect_matches_pixels() {
        let b = Bounds {
            x: [0.0, 2.0],
            y: [0.0, 1.0],
        };
        let (x, y) = equal_aspect(b, 400.0, 400.0);
        assert!(((x[1] - x[0]) - (y[1] - y[0])).abs() < 1e-12);
        assert!(x[0] < 0.0 && x[1] > 2.0);
    }
}
