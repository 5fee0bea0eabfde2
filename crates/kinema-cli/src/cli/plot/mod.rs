//! The SVG figure of `kinema run --plot`: the mechanism at several instants
//! with the paths of its joint points (equal aspect), the driven
//! coordinates against time, and position, velocity and acceleration of the
//! joint points against time; the model's outputs (measures) against time.
//!
//! Layout (1400 × 1560 px): a title block; the mechanism view on the left
//! with its legend beside it and the driven coordinates on the right; below,
//! the joint points' x and y components (columns) as position, velocity and
//! acceleration (rows). Legends are drawn in their own strips so they never
//! hide a curve. A model with inertia adds reaction forces and driver
//! efforts; forward dynamics adds the energies and their balance.

use std::error::Error;
use std::io::Write;
use std::path::Path;

use kinema::{Body, PointKinematics, State, point_kinematics};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

mod charts;
mod dynamics;
mod legend;
mod mechanism;
mod outputs;

use super::Failure;
use super::load::Loaded;
use super::output::{OutputFile, Outputs};
use super::scene::Scene;

use charts::{draw_driven, draw_points};
use mechanism::{Mechanism, mechanism_bounds};
pub(crate) use mechanism::{classify, hull};

/// Figure width [px].
const WIDTH: u32 = 1400;
/// Height of the title block [px].
const HEAD: u32 = 64;
/// Height of the joint points' panels [px].
const POINTS: u32 = 780;
/// Instants at which the mechanism is drawn.
const INSTANTS: usize = 6;
/// At most this many joint-point paths in the mechanism view (one colour
/// each).
pub(crate) const MAX_PATHS: usize = PALETTE.len();
/// At most this many joint points in the time plots.
const MAX_SERIES: usize = 6;
/// At most this many driven quantities in the time plots.
const MAX_DRIVEN: usize = 4;
/// Longest polyline drawn (samples are thinned beyond).
const MAX_POINTS: usize = 1200;
/// Font family of every text.
const FONT: &str = "sans-serif";
/// Largest magnitude an axis may reach. Beyond it the plotting library's
/// tick search overflows (and loops without end); a panel whose values go
/// further is not drawn, with a warning.
const MAX_AXIS: f64 = 1e300;
/// Narrowest axis relative to its magnitude: below, the ticks cannot be
/// told apart in f64 (and the tick search loops without end).
const MIN_RELATIVE_SPAN: f64 = 1e-9;
/// Narrowest axis in absolute terms (its tick spacing must stay a normal
/// number).
const MIN_SPAN: f64 = 1e-300;

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type Drawn = Result<(), Box<dyn Error>>;

/// Colours of paths and series (Tableau 10 without its blue and grey: the
/// mechanism is drawn in greys).
pub(crate) const PALETTE: [RGBColor; 8] = [
    RGBColor(0xf2, 0x8e, 0x2b),
    RGBColor(0x4e, 0x79, 0xa7),
    RGBColor(0xe1, 0x57, 0x59),
    RGBColor(0x59, 0xa1, 0x4f),
    RGBColor(0xb0, 0x7a, 0xa1),
    RGBColor(0x76, 0xb7, 0xb2),
    RGBColor(0x9c, 0x75, 0x5f),
    RGBColor(0xed, 0xc9, 0x48),
];

/// The output states of a run, kept for plotting.
#[derive(Debug, Clone, Default)]
pub struct Samples {
    n: usize,
    t: Vec<f64>,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    /// Names of the dynamics columns (empty for a kinematic model).
    dyn_names: Vec<String>,
    /// Their values, `dyn_names.len()` per state.
    dyn_values: Vec<f64>,
    /// Forward dynamics: (kinetic, potential, work of the other forces)
    /// of each state, given by [`Samples::push_energy`] (empty otherwise).
    energy: Vec<[f64; 3]>,
}

impl Samples {
    /// Room for states of `n` coordinates.
    pub fn new(n: usize) -> Samples {
        Samples {
            n,
            ..Samples::default()
        }
    }

    /// Also keeps the dynamics columns `names` (reactions, efforts) of
    /// each state, given by [`Samples::push_dynamics`] after each push.
    pub fn with_dynamics(mut self, names: &[String]) -> Samples {
        self.dyn_names = names.to_vec();
        self
    }

    /// The dynamics values of the state just pushed.
    pub fn push_dynamics(&mut self, values: &[f64]) {
        let w = self.dyn_names.len();
        self.dyn_values
            .extend((0..w).map(|k| values.get(k).copied().unwrap_or(f64::NAN)));
    }

    /// The energies of the state just pushed (forward dynamics): kinetic,
    /// potential (gravity) and the work of the other forces and drivers
    /// since the start; `--plot` then draws the energy panel.
    pub fn push_energy(&mut self, kinetic: f64, potential: f64, work: f64) {
        self.energy.push([kinetic, potential, work]);
    }

    /// Keeps a state.
    pub fn push(&mut self, state: &State) {
        self.push_values(state.t(), [state.q(), state.qd(), state.qdd()]);
    }

    /// Keeps a state given by its parts (forward dynamics has no
    /// kinematic [`State`]).
    pub fn push_values(&mut self, t: f64, [q, qd, qdd]: [&[f64]; 3]) {
        self.t.push(t);
        self.q.extend_from_slice(q);
        self.qd.extend_from_slice(qd);
        self.qdd.extend_from_slice(qdd);
    }

    /// Number of states.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether there is no state.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Time of state `k`.
    pub fn time(&self, k: usize) -> Option<f64> {
        self.t.get(k).copied()
    }

    /// Positions q of state `k`.
    pub fn positions(&self, k: usize) -> Option<&[f64]> {
        self.q.get(self.range(k))
    }

    pub(super) fn range(&self, k: usize) -> std::ops::Range<usize> {
        k * self.n..(k + 1) * self.n
    }

    /// Coordinate `i` of q (order 0), q̇ (1) or q̈ (2) at state `k`.
    fn coordinate(&self, order: usize, k: usize, i: usize) -> f64 {
        let v = [&self.q, &self.qd, &self.qdd][order.min(2)];
        v.get(k * self.n + i).copied().unwrap_or(f64::NAN)
    }

    /// Kinematics of a body point at state `k`.
    fn point(&self, k: usize, body: usize, local: [f64; 2]) -> Option<PointKinematics> {
        let r = self.range(k);
        point_kinematics(
            self.q.get(r.clone())?,
            self.qd.get(r.clone())?,
            self.qdd.get(r)?,
            Body::new(body),
            local,
        )
    }

    /// Global position of a body point at state `k`, NaN if out of range.
    fn position(&self, k: usize, body: usize, local: [f64; 2]) -> [f64; 2] {
        self.point(k, body, local)
            .map_or([f64::NAN; 2], |p| p.position)
    }
}

/// The plot file, created before the run so that a bad path fails early;
/// it replaces an earlier file only once the figure is written.
#[derive(Debug)]
pub struct Target {
    file: OutputFile,
}

impl Target {
    /// Creates the file through `outputs` (as option `--plot`).
    ///
    /// # Errors
    /// [`Failure::Input`] if it cannot be created, or is an input or
    /// another output.
    pub fn create(outputs: &mut Outputs, path: &Path) -> Result<Target, Failure> {
        Ok(Target {
            file: outputs.create("--plot", path)?,
        })
    }

    /// Draws the figure and writes it.
    ///
    /// # Errors
    /// [`Failure::Analysis`] if drawing or writing fails.
    pub fn write<S: kinema::Outputs>(
        mut self,
        loaded: &Loaded,
        system: &S,
        samples: &Samples,
        title: &str,
    ) -> Result<(), Failure> {
        let scene = Scene::of(loaded, system);
        let path = self.file.path().display().to_string();
        let measures = outputs::Measures::of(system, loaded.model.derivation(), samples);
        let (svg, warnings) = render(
            &scene,
            samples,
            &measures,
            title,
            &subtitle(loaded, samples),
        )
        .map_err(|e| Failure::analysis(format_args!("cannot draw `{path}`: {e}")))?;
        for w in warnings {
            super::print_stderr(&format!("warning: `{path}`: {w}"));
        }
        self.file
            .write_all(svg.as_bytes())
            .map_err(|e| Failure::analysis(format_args!("cannot write `{path}`: {e}")))?;
        self.file.commit()
    }
}

fn subtitle(loaded: &Loaded, samples: &Samples) -> String {
    let nb = loaded.checked().bodies.len();
    let dof = loaded.checked().dof();
    let source = match &loaded.adm {
        Some(_) => format!("simEngine2D model {}", file_name(&loaded.file)),
        None => format!("model {}", file_name(&loaded.file)),
    };
    format!(
        "{source} · {nb} bod{} · {} kinematic equations, {} driving · {} states",
        if nb == 1 { "y" } else { "ies" },
        dof.kinematic,
        dof.driving,
        samples.len()
    )
}

fn file_name(path: &str) -> String {
    Path::new(path)
        .file_name()
        .map_or_else(|| path.to_string(), |f| f.to_string_lossy().into_owned())
}

/// A plotted joint point: which traced point, its colour, its label.
struct Series {
    body: usize,
    local: [f64; 2],
    label: String,
    color: RGBColor,
}

/// Draws the whole figure as SVG text, with the warnings about panels
/// that could not be drawn (values beyond what a figure can show: see
/// [`MAX_AXIS`]).
///
/// A wide mechanism gets the full width with the driven coordinates in a
/// row below it; a compact one sits beside them; with no driven
/// coordinate (forward dynamics) the mechanism has the row to itself.
///
/// # Errors
/// Drawing errors (the SVG backend writes to a string: none expected).
fn render(
    scene: &Scene,
    samples: &Samples,
    measures: &outputs::Measures,
    title: &str,
    subtitle: &str,
) -> Result<(String, Vec<String>), Box<dyn Error>> {
    if samples.is_empty() {
        return Err("there is no state to plot".into());
    }
    let (moving, fixed) = classify(scene, samples);
    let paths: Vec<Series> = pick_refs(&moving, MAX_PATHS)
        .into_iter()
        .enumerate()
        .map(|(k, t)| Series {
            body: t.body,
            local: t.local,
            label: t.label.clone(),
            color: PALETTE[k % PALETTE.len()],
        })
        .collect();
    let instants = instants(samples.len());
    let bounds = mechanism_bounds(scene, samples, &paths, &fixed, &instants);
    let mut warnings = Vec::new();
    // The layout of a view that cannot be drawn is that of a square.
    let aspect = match bounds.check() {
        Ok(()) => (bounds.x[1] - bounds.x[0]) / (bounds.y[1] - bounds.y[0]).max(1e-300),
        Err(_) => 1.0,
    };
    let wide = aspect >= 1.4; // NaN: not wide
    let legend_w = 240;
    let mech_h = if wide {
        // Plot width over aspect, plus title, margins and axis labels.
        let plot_w = f64::from(WIDTH - legend_w - 94);
        (plot_w / (1.12 * aspect) + 120.0).clamp(380.0, 720.0) as u32
    } else {
        720
    };
    // Forward dynamics (no driver) gets no driven-coordinates panel.
    let driven = !scene.driven.is_empty();
    let driven_h = if wide && driven { 300 } else { 0 };
    let measures_h = if measures.is_empty() {
        0
    } else {
        outputs::HEIGHT
    };
    let dyn_h = if samples.dyn_names.is_empty() {
        0
    } else {
        dynamics::HEIGHT
    };
    let energy_h = if samples.energy.is_empty() {
        0
    } else {
        dynamics::ENERGY_HEIGHT
    };
    let height = HEAD + mech_h + driven_h + POINTS + measures_h + dyn_h + energy_h;

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let (head, body) = root.split_vertically(HEAD);
        let centre = plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Center,
            plotters::style::text_anchor::VPos::Top,
        );
        head.draw_text(title, &text(22).pos(centre), (WIDTH as i32 / 2, 10))?;
        head.draw_text(
            subtitle,
            &text(14).color(&RGBColor(90, 90, 90)).pos(centre),
            (WIDTH as i32 / 2, 40),
        )?;
        let (upper, lower) = body.split_vertically(mech_h + driven_h);
        let series: Vec<&Series> = pick_refs(&paths, MAX_SERIES);
        let mechanism = Mechanism {
            scene,
            samples,
            paths: &paths,
            fixed: &fixed,
            instants: &instants,
            bounds,
        };
        if !driven {
            let (view, legend) = upper.split_horizontally(WIDTH - legend_w);
            mechanism.draw(&view, &legend, &mut warnings)?;
        } else if wide {
            let (top, driven_area) = upper.split_vertically(mech_h);
            let (view, legend) = top.split_horizontally(WIDTH - legend_w);
            mechanism.draw(&view, &legend, &mut warnings)?;
            draw_driven(&driven_area, scene, samples, true, &mut warnings)?;
        } else {
            let (left, driven_area) = upper.split_horizontally(800);
            let (view, legend) = left.split_horizontally(800 - legend_w);
            mechanism.draw(&view, &legend, &mut warnings)?;
            draw_driven(&driven_area, scene, samples, false, &mut warnings)?;
        }
        let (points_area, rest) = lower.split_vertically(POINTS);
        let (measures_area, rest) = rest.split_vertically(measures_h);
        let (dyn_area, energy_area) = rest.split_vertically(dyn_h);
        draw_points(&points_area, scene, samples, &series, &mut warnings)?;
        if !measures.is_empty() {
            outputs::draw_measures(&measures_area, measures, &mut warnings)?;
        }
        if dyn_h > 0 {
            dynamics::draw(&dyn_area, samples, &mut warnings)?;
        }
        if energy_h > 0 {
            dynamics::draw_energy(&energy_area, samples, &mut warnings)?;
        }
        root.present()?;
    }
    Ok((svg, warnings))
}

/// How far outside its range, in range widths, a coordinate is drawn at
/// most: further points are moved to that distance, which keeps the
/// plotting library's pixel arithmetic (i32) from overflowing on a point
/// far outside the view (a vis `xlim` much narrower than the motion).
const GUARD: f64 = 1e4;

/// An f64 axis (plotters' own inside) whose mapping to pixels never
/// overflows: coordinates beyond [`GUARD`] widths outside the range are
/// drawn at that distance, far outside the figure. Its range must have
/// passed [`check_axis`].
#[derive(Clone)]
pub(super) struct SafeAxis {
    inner: RangedCoordf64,
    lo: f64,
    hi: f64,
}

impl SafeAxis {
    /// The axis over `r`, checked by [`check_axis`].
    pub(super) fn new(r: [f64; 2]) -> SafeAxis {
        SafeAxis {
            inner: (r[0]..r[1]).into(),
            lo: r[0],
            hi: r[1],
        }
    }
}

impl Ranged for SafeAxis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let span = self.hi - self.lo;
        let v = if value.is_nan() {
            *value
        } else {
            value
                .max(self.lo - GUARD * span)
                .min(self.hi + GUARD * span)
        };
        self.inner.map(&v, limit)
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        self.inner.key_points(hint)
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }
}

/// Tick labels: [`tick`] at this axis's span, on every axis (plotters'
/// default would print `0.6000000000000001`).
impl ValueFormatter<f64> for SafeAxis {
    fn format_ext(&self, value: &f64) -> String {
        tick(*value, self.hi - self.lo)
    }
}

/// Checks the values an axis must show, `[lo, hi]` before padding:
/// finite and within [`MAX_AXIS`]. The reason, for a warning, otherwise.
fn check_extent(lo: f64, hi: f64) -> Result<(), String> {
    if !(lo.is_finite() && hi.is_finite()) {
        return Err("its values are not finite".to_string());
    }
    let m = lo.abs().max(hi.abs());
    if m > MAX_AXIS {
        return Err(format!(
            "its values reach {m:.1e}, beyond the ±{MAX_AXIS:.0e} a figure can show"
        ));
    }
    Ok(())
}

/// Checks a padded axis range before it reaches the plotting library:
/// finite, within [`MAX_AXIS`], increasing, and wide enough for its
/// magnitude that ticks can be told apart. The reason otherwise.
fn check_axis(r: [f64; 2]) -> Result<(), String> {
    let m = r[0].abs().max(r[1].abs());
    // Padding may take an extent of MAX_AXIS a little further.
    if m.is_nan() || m > 10.0 * MAX_AXIS {
        return Err(format!(
            "its range [{:.3e}, {:.3e}] is beyond what a figure can show",
            r[0], r[1]
        ));
    }
    let span = r[1] - r[0];
    if !(span >= MIN_SPAN && span >= MIN_RELATIVE_SPAN * m) {
        return Err(format!(
            "its range [{:.3e}, {:.3e}] is too narrow to draw",
            r[0], r[1]
        ));
    }
    Ok(())
}

/// Draws, in a panel that cannot be drawn, why, and records the warning.
fn skip_panel(area: &Area<'_>, what: &str, why: &str, warnings: &mut Vec<String>) -> Drawn {
    area.draw_text(
        &format!("({what} not drawn: {why})"),
        &text(13).color(&RGBColor(150, 40, 40)),
        (70, 40),
    )?;
    warnings.push(format!("{what} is not drawn: {why}"));
    Ok(())
}

fn text(size: u32) -> TextStyle<'static> {
    TextStyle::from((FONT, size).into_font())
}

/// Indices of `items` to keep, at most `max`, evenly spread, first and last
/// included.
pub(crate) fn spread(len: usize, max: usize) -> Vec<usize> {
    if len <= max {
        return (0..len).collect();
    }
    let mut out: Vec<usize> = (0..max)
        .map(|k| (k * (len - 1) + (max - 1) / 2) / (max - 1).max(1))
        .collect();
    out.dedup();
    out
}

fn pick_refs<T>(items: &[T], max: usize) -> Vec<&T> {
    spread(items.len(), max)
        .into_iter()
        .filter_map(|k| items.get(k))
        .collect()
}

/// The states at which the mechanism is drawn.
fn instants(len: usize) -> Vec<usize> {
    spread(len, INSTANTS)
}

/// Sample indices of a polyline, thinned to [`MAX_POINTS`].
fn thinned(len: usize) -> Vec<usize> {
    spread(len, MAX_POINTS)
}

fn length_label(scene: &Scene) -> String {
    scene
        .length_unit
        .as_ref()
        .map_or_else(|| "length".to_string(), Clone::clone)
}

/// Units of a quantity and its first two time derivatives.
fn units(base: &str) -> [String; 3] {
    [base.to_string(), format!("{base}/s"), format!("{base}/s²")]
}

/// A tick label on an axis spanning about `span`: short, scientific for
/// very large or small values, and `0` for roundoff around zero.
///
/// Ticks are multiples of a round step (1, 2 or 5 times a power of ten)
/// computed in floating point, so `v` is within rounding of a short
/// decimal: the label is the shortest decimal (fixed, or scientific with at
/// least one digit after the point outside [1e-3, 1e5)) within 1e-9 of the
/// span of `v`, which tells neighbouring ticks apart (they differ by a
/// step, far more than that) and drops the rounding (`0.6`, not
/// `0.6000000000000001`).
fn tick(v: f64, span: f64) -> String {
    let a = v.abs();
    let tolerance = (1e-9 * span.abs()).max(4.0 * f64::EPSILON * a);
    if v == 0.0 || a <= 1e-9 * span.abs() {
        return "0".to_string();
    }
    let close = |s: &str| s.parse::<f64>().is_ok_and(|x| (x - v).abs() <= tolerance);
    let scientific = !(1e-3..1e5).contains(&a);
    for digits in if scientific { 1..=16 } else { 0..=17 } {
        let s = if scientific {
            format!("{v:.digits$e}")
        } else {
            format!("{v:.digits$}")
        };
        if close(&s) {
            return if s == "-0" { "0".to_string() } else { s };
        }
    }
    // Not reached: 17 digits round-trip every f64.
    format!("{v:e}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_keeps_ends() {
        assert_eq!(spread(3, 6), vec![0, 1, 2]);
        let s = spread(101, 6);
        assert_eq!(s.first(), Some(&0));
        assert_eq!(s.last(), Some(&100));
        assert_eq!(s.len(), 6);
        assert!(spread(0, 6).is_empty());
    }

    #[test]
    fn ticks() {
        assert_eq!(tick(0.25, 1.0), "0.25");
        assert_eq!(tick(-0.0001, 1e-3), "-1.0e-4");
        assert_eq!(tick(1.0, 2.0), "1");
        assert_eq!(tick(-5.6e-17, 2.0), "0");
    }

    /// The time axis of a run over [0, 1] printed `0.6000000000000001`;
    /// neighbouring ticks closer than 1e-3 printed alike (`1` and `1`).
    #[test]
    fn ticks_are_the_shortest_decimal_that_tells_neighbours_apart() {
        let sixth = 6.0 * 0.1;
        assert_ne!(sixth, 0.6, "the floating-point tick of the bug");
        assert_eq!(tick(sixth, 1.0), "0.6");
        assert_eq!(tick(0.1 + 0.2, 1.0), "0.3");
        let (a, b) = (1.0 + 1e-4, 1.0 + 2e-4);
        assert_eq!(
            (tick(a, 1e-3).as_str(), tick(b, 1e-3).as_str()),
            ("1.0001", "1.0002")
        );
        assert_eq!(tick(125_000.0, 1e5), "1.25e5");
        assert_eq!(tick(120_000.000_000_001, 1e5), "1.2e5");
        // Every tick of a range, as plotters makes them, distinct.
        let axis = SafeAxis::new([0.0, 1.3]);
        let points = axis.key_points(12);
        let labels: Vec<String> = points.iter().map(|v| axis.format_ext(v)).collect();
        for (v, l) in points.iter().zip(&labels) {
            assert!(l.len() <= 4, "{v} as {l}");
        }
        let mut unique = labels.clone();
        unique.dedup();
        assert_eq!(unique, labels);
    }
}
