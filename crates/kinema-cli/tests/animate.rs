//! `kinema run --animate` in a real browser: Debian's `chromium`, driven
//! headless over the DevTools protocol (`headless_chrome`), loads the page
//! the binary wrote and checks what it draws against the CSV of the same
//! run.
//!
//! Without a chromium on the machine each test prints one line saying so
//! and passes as skipped; with `CI=true` a missing browser is a failure
//! (`.ci/run` installs it). `KINEMA_CHROMIUM` names another browser binary.
//! Screenshots are written to `target/tmp/animate/`; with
//! `KINEMA_SCREENSHOT=PATH` the slider-crank's is also copied to PATH (how
//! `docs/src/animation.png` is made).

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::sleep;
use std::time::{Duration, Instant};

use headless_chrome::protocol::cdp::Page::CaptureScreenshotFormatOption;
use headless_chrome::protocol::cdp::Runtime::ConsoleAPICalledEventTypeOption;
use headless_chrome::protocol::cdp::types::Event;
use headless_chrome::{Browser, LaunchOptions, Tab};
use serde_json::Value;

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// The repository root (models/, the other crates' test data); the binary
/// runs there.
const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// One browser at a time: the frame-rate measurement must not share the
/// machine with another page.
static BROWSER: Mutex<()> = Mutex::new(());

fn one_at_a_time() -> MutexGuard<'static, ()> {
    BROWSER
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Where artifacts go: a fresh directory per test under cargo's temporary
/// directory for integration tests.
fn artifacts(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("animate")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    if let Err(e) = std::fs::create_dir_all(&dir) {
        panic!("cannot create `{}`: {e}", dir.display());
    }
    dir
}

/// The browser binary: `KINEMA_CHROMIUM`, else the first of the usual names
/// on PATH.
fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("KINEMA_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    for dir in std::env::split_paths(&path) {
        for name in [
            "chromium",
            "chromium-browser",
            "google-chrome",
            "google-chrome-stable",
        ] {
            let candidate = dir.join(name);
            if candidate.is_file() {
                return Some(candidate);
            }
        }
    }
    None
}

/// A browser with one tab, and every console error and uncaught exception
/// the page reports.
struct Page {
    _browser: Browser,
    tab: Arc<Tab>,
    errors: Arc<Mutex<Vec<String>>>,
}

impl Page {
    /// Opens `html` in headless chromium, or `None` (one line printed) when
    /// there is none and this is not CI.
    fn open(html: &Path, test: &str) -> Result<Option<Page>, Box<dyn std::error::Error>> {
        let Some(binary) = chromium() else {
            let why = "no chromium on PATH (apt-get install chromium, or set KINEMA_CHROMIUM)";
            if std::env::var("CI").is_ok_and(|v| v == "true") {
                return Err(format!("{test}: {why}; CI must run the browser tests").into());
            }
            // Once for the file, past the test harness's capture.
            static SAID: std::sync::Once = std::sync::Once::new();
            SAID.call_once(|| {
                let _ = writeln!(
                    std::io::stderr(),
                    "skipped the browser tests of tests/animate.rs: {why}"
                );
            });
            return Ok(None);
        };
        let options = LaunchOptions {
            path: Some(binary),
            headless: true,
            // Root in containers: chromium's sandbox needs user namespaces.
            sandbox: false,
            window_size: Some((1280, 800)),
            idle_browser_timeout: Duration::from_secs(120),
            ..LaunchOptions::default()
        };
        let browser = Browser::new(options)?;
        let tab = browser.new_tab()?;
        let errors: Arc<Mutex<Vec<String>>> = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&errors);
        tab.enable_runtime()?;
        tab.enable_log()?;
        tab.add_event_listener(Arc::new(move |event: &Event| {
            let message = match event {
                Event::RuntimeConsoleAPICalled(e)
                    if e.params.Type == ConsoleAPICalledEventTypeOption::Error =>
                {
                    Some(format!("console.error: {:?}", e.params.args))
                }
                Event::RuntimeExceptionThrown(e) => Some(format!(
                    "exception: {} {:?}",
                    e.params.exception_details.text,
                    e.params
                        .exception_details
                        .exception
                        .as_ref()
                        .and_then(|x| x.description.clone())
                )),
                Event::LogEntryAdded(e)
                    if format!("{:?}", e.params.entry.level).eq_ignore_ascii_case("error") =>
                {
                    Some(format!("log error: {}", e.params.entry.text))
                }
                _ => None,
            };
            if let Some(m) = message
                && let Ok(mut errors) = sink.lock()
            {
                errors.push(m);
            }
        }))?;
        let url = format!("file://{}", html.canonicalize()?.display());
        tab.navigate_to(&url)?;
        tab.wait_until_navigated()?;
        let page = Page {
            _browser: browser,
            tab,
            errors,
        };
        // The script has run when `window.kinema` exists.
        let start = Instant::now();
        while page.eval("typeof window.kinema")? != "object" {
            if start.elapsed() > Duration::from_secs(20) {
                return Err(format!(
                    "the page never set window.kinema; errors: {:?}",
                    page.errors()
                )
                .into());
            }
            sleep(Duration::from_millis(50));
        }
        Ok(Some(page))
    }

    /// Evaluates `expression` and returns its value (through JSON;
    /// `undefined` is null). A syntax error or an exception is an error.
    fn eval(&self, expression: &str) -> Result<Value, Box<dyn std::error::Error>> {
        let wrapped = format!(
            "(() => {{ try {{ return JSON.stringify({{ ok: ({expression}) }}); }} \
             catch (e) {{ return JSON.stringify({{ error: String(e) }}); }} }})()"
        );
        let result = self.tab.evaluate(&wrapped, false)?;
        let Some(Value::String(s)) = result.value else {
            return Err(
                format!("`{expression}` did not evaluate: {:?}", result.description).into(),
            );
        };
        let mut v: Value = serde_json::from_str(&s)?;
        if let Some(e) = v.get("error") {
            return Err(format!("`{expression}` threw {e}").into());
        }
        Ok(v.get_mut("ok").map(Value::take).unwrap_or(Value::Null))
    }

    fn number(&self, expression: &str) -> Result<f64, Box<dyn std::error::Error>> {
        self.eval(expression)?
            .as_f64()
            .ok_or_else(|| format!("`{expression}` is not a number").into())
    }

    fn numbers(&self, expression: &str) -> Result<Vec<f64>, Box<dyn std::error::Error>> {
        let v = self.eval(&format!("Array.from({expression})"))?;
        v.as_array()
            .ok_or_else(|| format!("`{expression}` is not an array"))?
            .iter()
            .map(|x| {
                x.as_f64()
                    .ok_or_else(|| format!("`{expression}`: {x}").into())
            })
            .collect()
    }

    fn text(&self, id: &str) -> Result<String, Box<dyn std::error::Error>> {
        match self.eval(&format!("document.getElementById('{id}').textContent"))? {
            Value::String(s) => Ok(s),
            other => Err(format!("#{id} has no text: {other}").into()),
        }
    }

    fn screenshot(&self, path: &Path) -> Result<Vec<u8>, Box<dyn std::error::Error>> {
        let png =
            self.tab
                .capture_screenshot(CaptureScreenshotFormatOption::Png, None, None, true)?;
        std::fs::write(path, &png)?;
        Ok(png)
    }

    /// Moves the time slider to frame `k` as a person dragging it does.
    fn scrub(&self, k: usize) -> Result<(), Box<dyn std::error::Error>> {
        self.eval(&format!(
            "(() => {{ const s = document.getElementById('slider'); s.value = '{k}'; \
             s.dispatchEvent(new Event('input')); return 0; }})()"
        ))?;
        Ok(())
    }

    fn errors(&self) -> Vec<String> {
        self.errors.lock().map(|e| e.clone()).unwrap_or_default()
    }
}

/// Runs the binary; returns its exit code and standard error.
fn kinema(args: &[&str]) -> (Option<i32>, String) {
    match Command::new(env!("CARGO_BIN_EXE_kinema"))
        .args(args)
        .current_dir(ROOT)
        .output()
    {
        Ok(o) => (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        ),
        Err(e) => panic!("cannot run kinema: {e}"),
    }
}

/// A CSV of the command line's contract: header and rows of numbers.
struct Csv {
    header: Vec<String>,
    rows: Vec<Vec<f64>>,
}

impl Csv {
    fn read(path: &Path) -> Result<Csv, Box<dyn std::error::Error>> {
        let text = std::fs::read_to_string(path)?;
        let mut lines = text.lines();
        let header = lines
            .next()
            .ok_or("empty CSV")?
            .split(',')
            .map(str::to_string)
            .collect();
        let rows = lines
            .map(|l| l.split(',').map(str::parse::<f64>).collect())
            .collect::<Result<_, _>>()?;
        Ok(Csv { header, rows })
    }

    fn column(&self, name: &str) -> Result<usize, Box<dyn std::error::Error>> {
        self.header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| format!("no column {name}").into())
    }
}

/// What the page drew at frame `k` matches CSV row `k`: the time, every
/// body's pose (float32 precision), its pixel through the view transform,
/// and, with `ink`, the canvas is dark on each bar body long enough to
/// sample away from its joint circles.
fn check_frame(page: &Page, csv: &Csv, bodies: &[String], k: usize, ink: bool) -> TestResult {
    let row = &csv.rows[k];
    assert_eq!(page.number("kinema.drawn.frame")?, k as f64);
    // The drawn time is the CSV's, to the last bit (float64 in the page).
    assert_eq!(
        page.number("kinema.drawn.time")?,
        row[0],
        "time of frame {k}"
    );
    let poses = page.numbers("kinema.drawn.poses")?;
    let pixels = page.numbers("kinema.drawn.pixels")?;
    let [scale, ox, oy] = [
        page.number("kinema.view.scale")?,
        page.number("kinema.view.ox")?,
        page.number("kinema.view.oy")?,
    ];
    assert_eq!(poses.len(), 3 * bodies.len());
    for (i, b) in bodies.iter().enumerate() {
        let x = row[csv.column(&format!("{b}.x"))?];
        let y = row[csv.column(&format!("{b}.y"))?];
        let phi = row[csv.column(&format!("{b}.phi"))?];
        let tol = 1e-6 * (1.0 + x.abs().max(y.abs()));
        assert!(
            (poses[3 * i] - x).abs() <= tol,
            "{b}.x at row {k}: {} vs {x}",
            poses[3 * i]
        );
        assert!(
            (poses[3 * i + 1] - y).abs() <= tol,
            "{b}.y at row {k}: {} vs {y}",
            poses[3 * i + 1]
        );
        assert!(
            (poses[3 * i + 2] - phi).abs() <= 1e-6 * (1.0 + phi.abs()),
            "{b}.phi at row {k}: {} vs {phi}",
            poses[3 * i + 2]
        );
        let (px, py) = (ox + x * scale, oy - y * scale);
        assert!(
            (pixels[2 * i] - px).abs() < 0.05 && (pixels[2 * i + 1] - py).abs() < 0.05,
            "{b} drawn at pixel ({}, {}), the CSV row puts it at ({px}, {py})",
            pixels[2 * i],
            pixels[2 * i + 1]
        );
    }
    if !ink {
        return Ok(());
    }
    // A bar is drawn between its two joint points: the canvas is dark 30 %
    // along it (its frame's axes start at the midpoint), computed here from
    // the CSV row.
    let links = page.eval(
        "kinema.data.bodies.map(b => b.link === 'bar' ? [b.outline[0], b.outline[1]] : null)",
    )?;
    let links = links.as_array().ok_or("no bodies")?;
    let mut checked = 0;
    for (i, link) in links.iter().enumerate() {
        let Some(ends) = link.as_array() else {
            continue;
        };
        let p = |j: usize, c: usize| ends[j][c].as_f64().unwrap_or(f64::NAN);
        let along = [0.7 * p(0, 0) + 0.3 * p(1, 0), 0.7 * p(0, 1) + 0.3 * p(1, 1)];
        let length = scale * (p(1, 0) - p(0, 0)).hypot(p(1, 1) - p(0, 1));
        if length < 30.0 {
            continue;
        }
        let b = &bodies[i];
        let x = row[csv.column(&format!("{b}.x"))?];
        let y = row[csv.column(&format!("{b}.y"))?];
        let phi = row[csv.column(&format!("{b}.phi"))?];
        let (s, c) = phi.sin_cos();
        let g = [
            x + c * along[0] - s * along[1],
            y + s * along[0] + c * along[1],
        ];
        let rgba = page.numbers(&format!(
            "(() => {{ const c = document.getElementById('view'); const d = kinema.view.dpr; \
             return c.getContext('2d').getImageData(Math.round(({}) * d), Math.round(({}) * d), 1, 1).data; }})()",
            ox + g[0] * scale,
            oy - g[1] * scale
        ))?;
        assert!(
            rgba[0] < 100.0 && rgba[1] < 100.0 && rgba[2] < 100.0,
            "{b}'s bar is not drawn 30 % along it at row {k}: pixel {rgba:?}"
        );
        checked += 1;
    }
    assert!(checked > 0, "no bar body long enough to check pixels of");
    Ok(())
}

#[test]
fn slider_crank_page_renders_plays_and_scrubs_to_csv_rows() -> TestResult {
    let _one = one_at_a_time();
    let dir = artifacts("slider_crank");
    let (csv_path, html) = (dir.join("motion.csv"), dir.join("motion.html"));
    let (code, stderr) = kinema(&[
        "run",
        "models/slider_crank.kin",
        "--t-end",
        "2",
        "--steps",
        "200",
        "--out",
        &csv_path.to_string_lossy(),
        "--animate",
        &html.to_string_lossy(),
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    let text = std::fs::read_to_string(&html)?;
    // Self-contained: nothing is fetched from anywhere.
    for reference in ["http:", "https:", "<link", "src=", "@import", "url("] {
        assert!(
            !text.contains(reference),
            "the page refers to `{reference}`"
        );
    }
    let csv = Csv::read(&csv_path)?;
    let Some(page) = Page::open(
        &html,
        "slider_crank_page_renders_plays_and_scrubs_to_csv_rows",
    )?
    else {
        return Ok(());
    };
    let bodies = ["crank", "rod", "slider"].map(String::from);
    assert_eq!(page.number("kinema.data.frames")?, csv.rows.len() as f64);
    check_frame(&page, &csv, &bodies, 0, true)?;

    // Play: the time display and a body's drawn position change between
    // two screenshots.
    let first = page.screenshot(&dir.join("playing-1.png"))?;
    let (time1, pixels1) = (page.text("time")?, page.numbers("kinema.drawn.pixels")?);
    page.eval("kinema.play()")?;
    sleep(Duration::from_millis(600));
    let second = page.screenshot(&dir.join("playing-2.png"))?;
    let (time2, pixels2) = (page.text("time")?, page.numbers("kinema.drawn.pixels")?);
    page.eval("kinema.pause()")?;
    assert_ne!(time1, time2, "the time display did not advance");
    assert!(
        pixels1
            .iter()
            .zip(&pixels2)
            .any(|(a, b)| (a - b).abs() > 1.0),
        "no body moved: {pixels1:?} then {pixels2:?}"
    );
    assert_ne!(first, second, "the two screenshots are the same");

    // Scrubbing to t sets the drawn configuration of t.
    for k in [37, 150, 200, 1] {
        page.scrub(k)?;
        check_frame(&page, &csv, &bodies, k, true)?;
        let t = csv.rows[k][0];
        let shown = page.text("time")?;
        let value: f64 = shown
            .trim_start_matches("t = ")
            .trim_end_matches(" s")
            .parse()?;
        assert!(
            (value - t).abs() < 1e-9 + 1e-3 * t,
            "time display {shown:?} for t = {t}"
        );
        // The driven crank angle is shown as the CSV has it.
        let driven = page.text("driven")?;
        let phi = csv.rows[k][csv.column("crank.phi")?];
        assert!(
            driven.contains(&format!("{phi:.4} rad")),
            "driven values {driven:?} at crank.phi = {phi}"
        );
    }

    // Keyboard: right arrow one frame, shift+right ten, space plays.
    page.scrub(10)?;
    page.tab.press_key("ArrowRight")?;
    check_frame(&page, &csv, &bodies, 11, true)?;
    page.tab.press_key_with_modifiers(
        "ArrowRight",
        Some(&[headless_chrome::browser::tab::ModifierKey::Shift]),
    )?;
    check_frame(&page, &csv, &bodies, 21, true)?;
    page.tab.press_key(" ")?;
    assert_eq!(page.eval("kinema.state.playing")?, Value::Bool(true));
    page.tab.press_key(" ")?;
    assert_eq!(page.eval("kinema.state.playing")?, Value::Bool(false));

    // Body frames and paths toggle.
    page.eval("document.getElementById('show-frames').click()")?;
    assert_eq!(page.eval("kinema.state.frames")?, Value::Bool(true));
    let traces = page.number("kinema.data.traces.length")?;
    assert!(traces >= 2.0, "the crank pin and the wrist are traced");

    // The artifact: mid-stroke, frames on, paths on.
    page.scrub(70)?;
    check_frame(&page, &csv, &bodies, 70, true)?;
    page.screenshot(&dir.join("animation.png"))?;
    if let Some(target) = std::env::var_os("KINEMA_SCREENSHOT") {
        std::fs::copy(dir.join("animation.png"), target)?;
    }
    assert_eq!(page.errors(), Vec::<String>::new(), "console errors");
    Ok(())
}

#[test]
fn failed_run_is_marked_on_the_time_slider() -> TestResult {
    let _one = one_at_a_time();
    let dir = artifacts("lockup");
    let (csv_path, html) = (dir.join("lockup.csv"), dir.join("lockup.html"));
    let (code, stderr) = kinema(&[
        "run",
        "crates/kinema-cli/tests/cli/models/lockup.kin",
        "--out",
        &csv_path.to_string_lossy(),
        "--animate",
        &html.to_string_lossy(),
    ]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(
        stderr.contains("shows the motion up to t = "),
        "the error names the page: {stderr}"
    );
    let csv = Csv::read(&csv_path)?;
    let last = csv.rows.last().ok_or("no rows")?[0];
    let Some(page) = Page::open(&html, "failed_run_is_marked_on_the_time_slider")? else {
        return Ok(());
    };
    // Every computed row is a frame; the marker sits at the last one.
    assert_eq!(page.number("kinema.data.frames")?, csv.rows.len() as f64);
    assert_eq!(page.number("kinema.times[kinema.times.length - 1]")?, last);
    assert_eq!(page.number("kinema.data.markers.length")?, 1.0);
    assert_eq!(page.number("kinema.data.markers[0].t")?, last);
    let label = page.eval("kinema.data.markers[0].label")?;
    assert!(
        label.as_str().is_some_and(|l| l.contains("lock-up")),
        "marker label {label}"
    );
    let marks = page.number("document.querySelectorAll('#marks .mark').length")?;
    assert_eq!(marks, 1.0);
    // The marker is at the right end of the slider.
    let left = page.eval("document.querySelector('#marks .mark').style.left")?;
    assert_eq!(left, Value::from("100%"));
    // Clicking it shows the last good frame.
    page.eval("document.querySelector('#marks .mark').click()")?;
    assert_eq!(page.number("kinema.drawn.time")?, last);
    page.screenshot(&dir.join("lockup.png"))?;
    assert_eq!(page.errors(), Vec::<String>::new(), "console errors");
    Ok(())
}

#[test]
fn singular_configurations_are_marked_on_the_time_slider() -> TestResult {
    let _one = one_at_a_time();
    let dir = artifacts("change_point");
    let (csv_path, html) = (dir.join("change_point.csv"), dir.join("change_point.html"));
    let (code, stderr) = kinema(&[
        "run",
        "tests/singular/change_point.kin",
        "--t-end",
        "2",
        "--steps",
        "72",
        "--out",
        &csv_path.to_string_lossy(),
        "--animate",
        &html.to_string_lossy(),
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    let Some(page) = Page::open(
        &html,
        "singular_configurations_are_marked_on_the_time_slider",
    )?
    else {
        return Ok(());
    };
    // The two passages of the fold (t = 0.875 and 1.875), as the run's
    // warnings report them, each a marker at its time.
    assert_eq!(page.number("kinema.data.markers.length")?, 2.0);
    for (k, expected) in [0.875, 1.875].into_iter().enumerate() {
        let t = page.number(&format!("kinema.data.markers[{k}].t"))?;
        assert!((t - expected).abs() < 1e-6, "marker {k} at {t}");
        let label = page.eval(&format!("kinema.data.markers[{k}].label"))?;
        assert!(
            label
                .as_str()
                .is_some_and(|l| l.starts_with("bifurcation at t = ")),
            "marker label {label}"
        );
    }
    let marks = page.number("document.querySelectorAll('#marks .mark').length")?;
    assert_eq!(marks, 2.0);
    assert_eq!(page.errors(), Vec::<String>::new(), "console errors");
    Ok(())
}

/// A serial chain of `n` unit links pinned to ground, every angle driven.
fn chain(n: usize) -> String {
    let mut s = format!("/// Serial chain of {n} unit links.\nmechanism Chain{n} {{\n");
    let phi = std::f64::consts::FRAC_PI_4;
    let (mut x, mut y) = (0.0f64, 0.0f64);
    for i in 1..=n {
        let (c, sn) = (phi.cos(), phi.sin());
        s.push_str(&format!(
            "    body b{i} {{ guess: ({}, {}, {phi}) }}\n",
            x + 0.5 * c,
            y + 0.5 * sn
        ));
        x += c;
        y += sn;
    }
    s.push_str("    joint pin1: revolute(b1(-0.5, 0), ground(0, 0));\n");
    for i in 2..=n {
        s.push_str(&format!(
            "    joint pin{i}: revolute(b{}(0.5, 0), b{i}(-0.5, 0));\n",
            i - 1
        ));
    }
    for i in 1..=n {
        s.push_str(&format!(
            "    driver angle{i}: abs_angle(b{i}, pi / 4 + 0.3 * sin(2 * pi * t + {i}));\n"
        ));
    }
    s.push_str("}\n");
    s
}

#[test]
fn hundred_body_chain_page_size_and_frame_rate() -> TestResult {
    let _one = one_at_a_time();
    let dir = artifacts("chain100");
    let model = dir.join("chain100.kin");
    std::fs::write(&model, chain(100))?;
    let (csv_path, html) = (dir.join("chain100.csv"), dir.join("chain100.html"));
    let (code, stderr) = kinema(&[
        "run",
        &model.to_string_lossy(),
        "--t-end",
        "2",
        "--steps",
        "1000",
        "--out",
        &csv_path.to_string_lossy(),
        "--animate",
        &html.to_string_lossy(),
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    let size = std::fs::metadata(&html)?.len();
    println!("1000-step, 100-body chain page: {size} bytes");
    // Poses: 1001 frames × 100 bodies × 3 float32, base64; the rest is
    // small.
    let poses = 1001 * 100 * 3 * 4 * 4 / 3;
    assert!(
        size > poses && size < poses + 200_000,
        "{size} bytes for {poses} bytes of poses"
    );
    let csv = Csv::read(&csv_path)?;
    let Some(page) = Page::open(&html, "hundred_body_chain_page_size_and_frame_rate")? else {
        return Ok(());
    };
    let bodies: Vec<String> = (1..=100).map(|i| format!("b{i}")).collect();
    page.scrub(500)?;
    check_frame(&page, &csv, &bodies, 500, false)?;
    // Every path on: the most the page can be asked to draw.
    page.eval("document.getElementById('traces-all').click()")?;
    page.eval("document.getElementById('show-frames').click()")?;
    // A second of warm-up (the script's first runs are compiled lazily).
    page.eval("kinema.play()")?;
    sleep(Duration::from_secs(1));
    page.eval("(kinema.perf.intervals.length = 0, kinema.perf.draws.length = 0, 0)")?;
    sleep(Duration::from_secs(4));
    page.eval("kinema.pause()")?;
    let s = page.eval("kinema.perfSummary()")?;
    let get = |k: &str| s[k].as_f64().unwrap_or(f64::NAN);
    println!(
        "100 bodies, every path and frame on: {:.1} frames/s over {} frames \
         (median interval {:.2} ms, 90th percentile {:.2} ms), drawing a frame: \
         median {:.2} ms, max {:.2} ms",
        get("fps"),
        get("frames"),
        get("medianInterval"),
        get("p90Interval"),
        get("medianDraw"),
        get("maxDraw")
    );
    page.screenshot(&dir.join("chain100.png"))?;
    // 60 fps leaves 16.7 ms a frame: drawing must take a fraction of it.
    // (The frame rate itself is printed, not asserted: on a loaded
    // machine the browser's compositor, not the page, sets it.)
    assert!(get("medianDraw") < 8.0, "drawing is too slow: {s}");
    assert!(get("frames") > 40.0, "too few frames in 4 s: {s}");
    assert_eq!(page.errors(), Vec::<String>::new(), "console errors");
    Ok(())
}

#[test]
fn page_that_would_overwrite_the_csv_or_sit_in_no_directory_is_refused() {
    let dir = artifacts("refusals");
    let csv = dir.join("same.csv").to_string_lossy().into_owned();
    let (code, stderr) = kinema(&[
        "run",
        "models/pendulum.kin",
        "--out",
        &csv,
        "--animate",
        &csv,
    ]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(
        stderr.contains("are the same file: each output needs a file of its own"),
        "{stderr}"
    );
    let missing = dir.join("no/such/dir/motion.html");
    let (code, stderr) = kinema(&[
        "run",
        "models/pendulum.kin",
        "--out",
        &dir.join("ok.csv").to_string_lossy(),
        "--animate",
        &missing.to_string_lossy(),
    ]);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("cannot create"), "{stderr}");
    // Nothing is left behind: no page, no temporary file.
    let left: Vec<_> = std::fs::read_dir(&dir)
        .map(|d| d.filter_map(Result::ok).map(|e| e.file_name()).collect())
        .unwrap_or_default();
    assert!(
        left.iter().all(|f| !f.to_string_lossy().ends_with(".tmp")),
        "{left:?}"
    );
}

#[test]
fn simengine2d_page_uses_the_files_drawing_data() -> TestResult {
    let _one = one_at_a_time();
    let dir = artifacts("adm");
    let (csv_path, html) = (dir.join("adm.csv"), dir.join("adm.html"));
    let (code, stderr) = kinema(&[
        "run",
        "crates/kinema-adm/tests/data/slider_crank.adm",
        "--t-end",
        "1",
        "--steps",
        "50",
        "--out",
        &csv_path.to_string_lossy(),
        "--animate",
        &html.to_string_lossy(),
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    let csv = Csv::read(&csv_path)?;
    let Some(page) = Page::open(&html, "simengine2d_page_uses_the_files_drawing_data")? else {
        return Ok(());
    };
    // The file's vis: xlim, ylim; each body's colour and rectangle.
    assert_eq!(
        page.numbers("kinema.data.bounds")?,
        vec![-0.5, 1.5, -0.5, 0.5]
    );
    assert_eq!(
        page.eval("kinema.data.bodies.map(b => b.color)")?,
        serde_json::json!(["#cc4d66", "#3333e6", "#339966"])
    );
    assert_eq!(
        page.eval("kinema.data.bodies.map(b => b.rects)")?,
        serde_json::json!([
            [[0, 0, 0.34, 0.04]],
            [[0, 0, 1.04, 0.04]],
            [[0, 0, 0.2, 0.1]]
        ])
    );
    let bodies = ["crank", "rod", "slider"].map(String::from);
    for k in [0, 13, 50] {
        page.scrub(k)?;
        check_frame(&page, &csv, &bodies, k, true)?;
    }
    page.screenshot(&dir.join("adm.png"))?;
    assert_eq!(page.errors(), Vec::<String>::new(), "console errors");
    Ok(())
}
