//! The animation page of `kinema run --animate FILE.html`: one
//! self-contained HTML file (inline script and style, no network) that plays
//! the mechanism's motion in a canvas, drawn in the SVG plot's style.
//!
//! What is embedded, once: the scene read by [`Scene::of`] turned into
//! body-frame geometry (links, plates, blocks, simEngine2D rectangles and
//! colours, joint points), the fixed points, the traced points that move
//! (the plot's [`classify`]), the driven quantities, the view box and the
//! time-slider markers. Per frame: the time (float64) and every body's pose
//! x, y, φ (float32, x and y relative to the view's centre so that a
//! mechanism far from the origin keeps its precision), both base64-encoded
//! little-endian typed arrays. A 1000-step run of a 100-body chain is about
//! 1.6 MB: 1001 × 100 × 3 × 4 bytes of poses, × 4/3 for base64.
//!
//! The frames are the run's output states as the plot keeps them
//! ([`Samples`]; the same results as the CSV, no second analysis), thinned
//! evenly to at most [`MAX_VALUES`] pose values.
//!
//! The page's script exposes what it drew as `window.kinema` (current
//! frame and time, each body's drawn pose and its pixel position, the view
//! transform) for the browser test (`tests/animate.rs`).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use kinema::{Axis, Body, System};

use super::Failure;
use super::load::Loaded;
use super::output::{OutputFile, Outputs};
use super::plot::{MAX_PATHS, PALETTE, Samples, classify, hull, spread};
use super::scene::{BodyShape, Driven, Rgb, Scene, Traced};

/// Most pose values (3 per body per frame) embedded: 4 bytes each, about
/// 16 MB of base64.
pub const MAX_VALUES: usize = 3_000_000;

/// The page template; `/*KINEMA_STYLE*/`, `/*KINEMA_SCRIPT*/` and
/// `/*KINEMA_DATA*/` are replaced by the style sheet, the script and the
/// data.
const TEMPLATE: &str = include_str!("animate/page.html");
/// The page's style sheet.
const STYLE: &str = include_str!("animate/page.css");
/// The page's script.
const SCRIPT: &str = include_str!("animate/page.js");

/// A mark on the time slider: a singular event, or where a failed run
/// stopped.
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    /// Time [s].
    pub t: f64,
    /// What happened there, for people.
    pub label: String,
}

/// The page file, created before the run so that a bad path fails at once
/// (through [`Outputs`]: not an input, not another output; written to a
/// temporary file and renamed into place).
#[derive(Debug)]
pub struct Target {
    file: OutputFile,
}

impl Target {
    /// Creates the file.
    ///
    /// # Errors
    /// [`Failure::Input`] if it cannot be created, is `-`, or is an input or
    /// another output.
    pub fn create(outputs: &mut Outputs, path: &Path) -> Result<Target, Failure> {
        if path.as_os_str() == "-" {
            return Err(Failure::usage(
                "--animate writes a file; `-` (standard output) is for the CSV",
            ));
        }
        Ok(Target {
            file: outputs.create("--animate", path)?,
        })
    }

    /// The destination.
    pub fn path(&self) -> &Path {
        self.file.path()
    }

    /// Builds the page and writes it into place.
    ///
    /// # Errors
    /// [`Failure::Analysis`] if there is no state to show or writing fails.
    pub fn write<S: System>(
        mut self,
        loaded: &Loaded,
        system: &S,
        samples: &Samples,
        markers: &[Marker],
        title: &str,
    ) -> Result<(), Failure> {
        let scene = Scene::of(loaded, system);
        let subtitle = subtitle(loaded, samples);
        let path = self.file.path().display().to_string();
        let html = page(&scene, samples, markers, title, &subtitle)
            .map_err(|e| Failure::analysis(format_args!("cannot draw `{path}`: {e}")))?;
        self.file
            .write_all(html.as_bytes())
            .map_err(|e| Failure::analysis(format_args!("cannot write `{path}`: {e}")))?;
        self.file.commit()
    }
}

fn subtitle(loaded: &Loaded, samples: &Samples) -> String {
    let nb = loaded.checked().bodies.len();
    let source = if loaded.adm.is_some() {
        "simEngine2D model"
    } else {
        "model"
    };
    let file = Path::new(&loaded.file)
        .file_name()
        .map_or_else(|| loaded.file.clone(), |f| f.to_string_lossy().into_owned());
    format!(
        "{source} {file} · {nb} bod{} · {} states",
        if nb == 1 { "y" } else { "ies" },
        samples.len()
    )
}

/// The whole page as HTML text.
///
/// # Errors
/// When there is no state to show.
pub fn page(
    scene: &Scene,
    samples: &Samples,
    markers: &[Marker],
    title: &str,
    subtitle: &str,
) -> Result<String, String> {
    let data = data(scene, samples, markers, title, subtitle)?;
    // Splice in order: data last, so that nothing in the data is read as a
    // placeholder.
    let html = TEMPLATE
        .replacen("/*KINEMA_STYLE*/", STYLE, 1)
        .replacen("/*KINEMA_SCRIPT*/", SCRIPT, 1)
        .replacen("<!--KINEMA_TITLE-->", &html_escape(title), 1)
        .replacen("/*KINEMA_DATA*/", &data, 1);
    Ok(html)
}

/// The data object, as a JavaScript (JSON) expression.
fn data(
    scene: &Scene,
    samples: &Samples,
    markers: &[Marker],
    title: &str,
    subtitle: &str,
) -> Result<String, String> {
    if samples.is_empty() {
        return Err("there is no state to show".to_string());
    }
    let nb = scene.bodies.len();
    let per_frame = (3 * nb).max(1);
    let frames = spread(samples.len(), (MAX_VALUES / per_frame).max(2));
    let (moving, fixed) = classify(scene, samples);
    let bounds = view_bounds(scene, samples, &frames, &moving, &fixed);
    let size = (bounds.x[1] - bounds.x[0])
        .max(bounds.y[1] - bounds.y[0])
        .max(1e-12);
    let centre = [
        0.5 * (bounds.x[0] + bounds.x[1]),
        0.5 * (bounds.y[0] + bounds.y[1]),
    ];

    let mut times: Vec<u8> = Vec::with_capacity(8 * frames.len());
    let mut poses: Vec<u8> = Vec::with_capacity(4 * 3 * nb * frames.len());
    for &k in &frames {
        let t = samples.time(k).unwrap_or(f64::NAN);
        times.extend_from_slice(&t.to_le_bytes());
        let q = samples.positions(k).unwrap_or(&[]);
        for i in 0..nb {
            let at = |a: Axis| q.get(Body::new(i).coord(a).index());
            let [x, y, phi] = Axis::ALL.map(|a| at(a).copied().unwrap_or(f64::NAN));
            let pose = [x - centre[0], y - centre[1], phi];
            for v in pose {
                // Narrowing to float32 is the format (see the module doc).
                #[allow(clippy::cast_possible_truncation)]
                poses.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
    }

    let mut j = Json::default();
    j.open('{');
    j.key("title");
    j.string(title);
    j.key("subtitle");
    j.string(subtitle);
    j.key("unit");
    j.string(scene.length_unit.as_deref().unwrap_or(""));
    j.key("bounds");
    j.numbers(&[bounds.x[0], bounds.x[1], bounds.y[0], bounds.y[1]]);
    j.key("centre");
    j.numbers(&centre);
    j.key("block");
    j.numbers(&[0.07 * size, 0.04 * size]);
    j.key("bodies");
    j.open('[');
    for body in &scene.bodies {
        body_json(&mut j, body);
    }
    j.close(']');
    j.key("fixed");
    j.open('[');
    for f in &fixed {
        j.numbers(f);
    }
    j.close(']');
    j.key("traces");
    j.open('[');
    let shown = spread(moving.len(), MAX_PATHS);
    for (k, t) in moving.iter().enumerate() {
        j.open('{');
        j.key("label");
        j.string(&t.label);
        j.key("body");
        j.number(t.body as f64);
        j.key("local");
        j.numbers(&t.local);
        j.key("color");
        let c = PALETTE[k % PALETTE.len()];
        j.string(&format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2));
        j.key("on");
        j.raw(if shown.contains(&k) { "true" } else { "false" });
        j.close('}');
    }
    j.close(']');
    j.key("driven");
    j.open('[');
    for d in &scene.driven {
        driven_json(&mut j, scene, d);
    }
    j.close(']');
    j.key("markers");
    j.open('[');
    for m in markers {
        j.open('{');
        j.key("t");
        j.number(m.t);
        j.key("label");
        j.string(&m.label);
        j.close('}');
    }
    j.close(']');
    j.key("frames");
    j.number(frames.len() as f64);
    j.key("times");
    j.string(&base64(&times));
    j.key("poses");
    j.string(&base64(&poses));
    j.close('}');
    Ok(j.out)
}

/// The geometry of one body in its own frame, drawn as the plot draws it:
/// simEngine2D rectangles; a bar between two joint points (or from the one
/// joint point to the origin), a plate (convex hull) for more, a block at
/// the origin for none.
fn body_json(j: &mut Json, body: &BodyShape) {
    j.open('{');
    j.key("name");
    j.string(&body.name);
    j.key("rects");
    j.open('[');
    for (loc, size) in &body.rects {
        j.numbers(&[loc[0], loc[1], size[0], size[1]]);
    }
    j.close(']');
    j.key("color");
    match body.color {
        Some(c) => j.string(&hex(c)),
        None => j.raw("null"),
    }
    let origin = [0.0, 0.0];
    let points = &body.points;
    let (kind, outline): (&str, Vec<[f64; 2]>) = match points.as_slice() {
        [] => ("block", Vec::new()),
        [p] if *p == origin => ("block", Vec::new()),
        [p] => ("bar", vec![*p, origin]),
        [a, b] => ("bar", vec![*a, *b]),
        _ => ("plate", hull(points)),
    };
    j.key("link");
    j.string(kind);
    j.key("outline");
    j.open('[');
    for p in &outline {
        j.numbers(p);
    }
    j.close(']');
    j.key("joints");
    j.open('[');
    for p in points {
        j.numbers(p);
    }
    j.close(']');
    j.close('}');
}

/// A driven quantity: a coordinate (its index in q) or a body point's x or
/// y; its label and unit.
fn driven_json(j: &mut Json, scene: &Scene, d: &Driven) {
    let length = scene.length_unit.as_deref().unwrap_or("");
    j.open('{');
    match d {
        Driven::Coordinate(c) => {
            let name = scene.coordinates.get(*c).map_or("?", String::as_str);
            j.key("label");
            j.string(name);
            j.key("coordinate");
            j.number(*c as f64);
            j.key("unit");
            j.string(if c % 3 == 2 { "rad" } else { length });
        }
        Driven::PointComponent {
            body,
            local,
            component,
            label,
        } => {
            j.key("label");
            j.string(&format!(
                "{label} ({})",
                if *component == 0 { "x" } else { "y" }
            ));
            j.key("body");
            j.number(*body as f64);
            j.key("local");
            j.numbers(local);
            j.key("component");
            j.number(*component as f64);
            j.key("unit");
            j.string(length);
        }
    }
    j.close('}');
}

fn hex(c: Rgb) -> String {
    let b = |v: f64| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    format!("#{:02x}{:02x}{:02x}", b(c[0]), b(c[1]), b(c[2]))
}

/// An axis-aligned box: `x = [min, max]`, `y = [min, max]`.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    x: [f64; 2],
    y: [f64; 2],
}

impl Bounds {
    fn empty() -> Bounds {
        Bounds {
            x: [f64::INFINITY, f64::NEG_INFINITY],
            y: [f64::INFINITY, f64::NEG_INFINITY],
        }
    }

    fn add(&mut self, p: [f64; 2]) {
        if p[0].is_finite() && p[1].is_finite() {
            self.x = [self.x[0].min(p[0]), self.x[1].max(p[0])];
            self.y = [self.y[0].min(p[1]), self.y[1].max(p[1])];
        }
    }

    fn is_empty(&self) -> bool {
        !(self.x[0] <= self.x[1] && self.y[0] <= self.y[1])
    }
}

/// What the view must show over the whole motion: the bodies' points,
/// rectangles and origins, the traced points' paths and the fixed points,
/// with room below for the ground symbols; simEngine2D `xlim`/`ylim` when
/// given (as the plot).
fn view_bounds(
    scene: &Scene,
    samples: &Samples,
    frames: &[usize],
    moving: &[Traced],
    fixed: &[[f64; 2]],
) -> Bounds {
    if let Some((x, y)) = scene.limits {
        return Bounds { x, y };
    }
    let mut b = Bounds::empty();
    // The body outlines at a few instants, every traced point at every
    // frame (thinned: the box only needs the extremes to a pixel).
    for k in spread(frames.len(), 400) {
        let Some(&k) = frames.get(k) else { continue };
        let Some(q) = samples.positions(k) else {
            continue;
        };
        for (i, body) in scene.bodies.iter().enumerate() {
            b.add(global(q, i, [0.0, 0.0]));
            for p in &body.points {
                b.add(global(q, i, *p));
            }
            for (loc, size) in &body.rects {
                for (sx, sy) in [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)] {
                    b.add(global(q, i, [loc[0] + sx * size[0], loc[1] + sy * size[1]]));
                }
            }
        }
        for t in moving {
            b.add(global(q, t.body, t.local));
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
    let size = (b.x[1] - b.x[0]).max(b.y[1] - b.y[0]);
    b.y[0] -= 0.05 * size;
    b
}

/// Global position of local point `s` of body `i` in positions `q`; NaN
/// if `q` is too short.
fn global(q: &[f64], i: usize, s: [f64; 2]) -> [f64; 2] {
    match Axis::ALL.map(|a| q.get(Body::new(i).coord(a).index())) {
        [Some(&x), Some(&y), Some(&phi)] => {
            let (sn, c) = phi.sin_cos();
            [x + c * s[0] - sn * s[1], y + sn * s[0] + c * s[1]]
        }
        _ => [f64::NAN; 2],
    }
}

/// Text safe inside HTML element content.
fn html_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

/// A small JSON writer for the page's data: strings escaped so that the
/// text is also safe inside a `<script>` element (`<` as `\u003c`),
/// non-finite numbers as `null`.
#[derive(Debug, Default)]
struct Json {
    out: String,
    /// Whether the current container already has an item.
    has_item: Vec<bool>,
}

impl Json {
    /// Before an item: a comma if it is not the container's first.
    fn item(&mut self) {
        if let Some(has) = self.has_item.last_mut() {
            if *has {
                self.out.push(',');
            }
            *has = true;
        }
    }

    fn open(&mut self, c: char) {
        self.item();
        self.out.push(c);
        self.has_item.push(false);
    }

    fn close(&mut self, c: char) {
        self.has_item.pop();
        self.out.push(c);
    }

    fn key(&mut self, k: &str) {
        self.item();
        self.push_string(k);
        self.out.push(':');
        // The value that follows is not another item.
        if let Some(has) = self.has_item.last_mut() {
            *has = false;
        }
    }

    fn raw(&mut self, text: &str) {
        self.item();
        self.out.push_str(text);
    }

    fn number(&mut self, v: f64) {
        self.item();
        if v.is_finite() {
            let _ = write!(self.out, "{v:?}");
        } else {
            self.out.push_str("null");
        }
    }

    fn numbers(&mut self, v: &[f64]) {
        self.open('[');
        for &x in v {
            self.number(x);
        }
        self.close(']');
    }

    fn string(&mut self, s: &str) {
        self.item();
        self.push_string(s);
    }

    fn push_string(&mut self, s: &str) {
        self.out.push('"');
        for c in s.chars() {
            match c {
                '"' => self.out.push_str("\\\""),
                '\\' => self.out.push_str("\\\\"),
                '\n' => self.out.push_str("\\n"),
                '<' | '>' | '&' | '\u{2028}' | '\u{2029}' => {
                    let _ = write!(self.out, "\\u{:04x}", c as u32);
                }
                c if (c as u32) < 0x20 => {
                    let _ = write!(self.out, "\\u{:04x}", c as u32);
                }
                c => self.out.push(c),
            }
        }
        self.out.push('"');
    }
}

/// Standard base64 with padding.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk.first().copied().unwrap_or(0),
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        let sextet = |shift: u32| char::from(ALPHABET[((n >> shift) & 63) as usize]);
        out.push(sextet(18));
        out.push(sextet(12));
        out.push(if chunk.len() > 1 { sextet(6) } else { '=' });
        out.push(if chunk.len() > 2 { sextet(0) } else { '=' });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_of_rfc4648_vectors() {
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, encoded) in cases {
            assert_eq!(base64(plain.as_bytes()), encoded, "{plain:?}");
        }
    }

    #[test]
    fn json_is_safe_in_a_script_element() {
        let mut j = Json::default();
        j.open('{');
        j.key("a");
        j.string("</script>\"\\\n");
        j.key("b");
        j.numbers(&[1.0, f64::NAN, -0.5]);
        j.key("c");
        j.open('[');
        j.open('{');
        j.close('}');
        j.open('{');
        j.key("d");
        j.raw("true");
        j.close('}');
        j.close(']');
        j.close('}');
        assert_eq!(
            j.out,
            r#"{"a":"\u003c/script\u003e\"\\\n","b":[1.0,null,-0.5],"c":[{},{"d":true}]}"#
        );
    }

    #[test]
    fn no_state_no_page() {
        let scene = Scene {
            bodies: Vec::new(),
            ground: Vec::new(),
            traced: Vec::new(),
            driven: Vec::new(),
            coordinates: Vec::new(),
            length_unit: None,
            limits: None,
        };
        let page = page(&scene, &Samples::new(0), &[], "t", "s");
        assert_eq!(page, Err("there is no state to show".to_string()));
    }

    #[test]
    fn template_has_each_placeholder_once() {
        for p in [
            "/*KINEMA_STYLE*/",
            "/*KINEMA_SCRIPT*/",
            "/*KINEMA_DATA*/",
            "<!--KINEMA_TITLE-->",
        ] {
            assert_eq!(TEMPLATE.matches(p).count(), 1, "{p}");
            assert!(!STYLE.contains(p) && !SCRIPT.contains(p), "{p}");
        }
    }

    #[test]
    fn html_escapes_markup() {
        assert_eq!(
            html_escape("a<b & \"c\">"),
            "a&lt;b &amp; &quot;c&quot;&gt;"
        );
    }
}
