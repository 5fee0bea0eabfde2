//! Running one input in process with panics caught, the signature of what
//! happened, and the list of known findings a run may tolerate.

use std::panic::{self, AssertUnwindSafe};
use std::sync::{Mutex, Once};

use crate::{Finding, Reach, Target};

/// What one input did.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// No finding; how far it got.
    Clean(Reach),
    /// An oracle violation.
    Finding(Finding),
    /// A panic: where, what, and the backtrace.
    Panic {
        /// `file:line:col` of the panic.
        location: String,
        /// The panic message.
        message: String,
        /// The backtrace at the panic.
        backtrace: String,
    },
}

impl Verdict {
    /// A stable signature: the kind of finding and, for a panic, where it
    /// panicked. `None` for a clean run.
    #[must_use]
    pub fn signature(&self) -> Option<String> {
        match self {
            Verdict::Clean(_) => None,
            Verdict::Finding(f) => Some(f.signature()),
            Verdict::Panic { location, .. } => Some(format!("panic at {}", strip_column(location))),
        }
    }

    /// What happened, in a few lines.
    #[must_use]
    pub fn describe(&self) -> String {
        match self {
            Verdict::Clean(r) => format!("clean ({})", r.name()),
            Verdict::Finding(f) => format!("finding {f}"),
            Verdict::Panic {
                location,
                message,
                backtrace,
            } => format!("panic at {location}: {message}\n\nbacktrace:\n{backtrace}"),
        }
    }
}

/// `file:line:col` → `file:line` (columns move with formatting), with a
/// dependency's path made machine-independent:
/// `/root/.cargo/registry/src/index.crates.io-…/nalgebra-0.35.0/src/x.rs`
/// → `nalgebra-0.35.0/src/x.rs`.
#[must_use]
pub fn strip_column(location: &str) -> &str {
    let location = match location.find("/registry/src/") {
        Some(k) => {
            let rest = &location[k + "/registry/src/".len()..];
            rest.split_once('/')
                .map_or(rest, |(_, crate_path)| crate_path)
        }
        None => location,
    };
    match location.rsplit_once(':') {
        Some((head, col)) if col.chars().all(|c| c.is_ascii_digit()) && head.contains(':') => head,
        _ => location,
    }
}

/// The last panic seen by the hook (this process runs one input at a time).
static LAST_PANIC: Mutex<Option<(String, String, String)>> = Mutex::new(None);
static HOOK: Once = Once::new();

thread_local! {
    /// Whether this thread is inside [`catch`]: other panics (a failing
    /// test's assertion) are printed as usual.
    static CATCHING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Replaces the default panic hook (which prints) by one that records the
/// panic's location, message and backtrace for [`run_caught`].
pub fn install_panic_hook() {
    HOOK.call_once(|| {
        panic::set_hook(Box::new(|info| {
            let location = info
                .location()
                .map_or_else(|| "unknown".to_string(), ToString::to_string);
            let message = if let Some(s) = info.payload().downcast_ref::<&str>() {
                (*s).to_string()
            } else if let Some(s) = info.payload().downcast_ref::<String>() {
                s.clone()
            } else {
                "(non-string panic payload)".to_string()
            };
            if !CATCHING.with(std::cell::Cell::get) {
                eprintln!("panicked at {location}:\n{message}");
                return;
            }
            let backtrace = std::backtrace::Backtrace::force_capture().to_string();
            if let Ok(mut slot) = LAST_PANIC.lock() {
                *slot = Some((location, message, backtrace));
            }
        }));
    });
}

/// Runs one input with panics caught ([`install_panic_hook`] is called).
pub fn run_caught(target: Target, data: &[u8]) -> Verdict {
    catch(|| crate::run(target, data))
}

/// Runs `f` with panics caught and turned into [`Verdict::Panic`].
pub fn catch(f: impl FnOnce() -> Result<Reach, Finding>) -> Verdict {
    install_panic_hook();
    CATCHING.with(|c| c.set(true));
    let result = panic::catch_unwind(AssertUnwindSafe(f));
    CATCHING.with(|c| c.set(false));
    match result {
        Ok(Ok(reach)) => Verdict::Clean(reach),
        Ok(Err(f)) => Verdict::Finding(f),
        Err(_) => {
            let (location, message, backtrace) = LAST_PANIC
                .lock()
                .ok()
                .and_then(|mut s| s.take())
                .unwrap_or_else(|| ("unknown".into(), "unknown".into(), String::new()));
            Verdict::Panic {
                location,
                message,
                backtrace,
            }
        }
    }
}

/// Known findings, not yet fixed, that a run reports but does not fail on:
/// lines `target<TAB or spaces>signature-prefix`, `#` comments.
#[derive(Clone, Debug, Default)]
pub struct Known {
    entries: Vec<(String, String)>,
}

impl Known {
    /// Parses the list.
    #[must_use]
    pub fn parse(text: &str) -> Known {
        let entries = text
            .lines()
            .map(|l| l.split('#').next().unwrap_or("").trim())
            .filter(|l| !l.is_empty())
            .filter_map(|l| {
                let (target, sig) = l.split_once(char::is_whitespace)?;
                Some((target.to_string(), sig.trim().to_string()))
            })
            .collect();
        Known { entries }
    }

    /// The list committed with the crate (`known.txt`).
    #[must_use]
    pub fn committed() -> Known {
        Known::parse(include_str!("../known.txt"))
    }

    /// Whether a signature of `target` is known (`*` matches every target).
    #[must_use]
    pub fn contains(&self, target: Target, signature: &str) -> bool {
        self.entries
            .iter()
            .any(|(t, s)| (t == "*" || t == target.name()) && signature.starts_with(s.as_str()))
    }
}

/// Shrinks `data` while `same` holds for it: drops halves, then lines,
/// then single characters (of short inputs), within `budget` attempts.
pub fn minimize(data: &[u8], budget: usize, same: &mut dyn FnMut(&[u8]) -> bool) -> Vec<u8> {
    let mut best = data.to_vec();
    let mut tries = 0;
    // Lines (or, for one-line inputs, characters) in chunks of decreasing
    // size: a cheap delta debugging.
    for unit_is_line in [true, false] {
        let split = |d: &[u8]| -> Vec<Vec<u8>> {
            if unit_is_line {
                d.split_inclusive(|&b| b == b'\n')
                    .map(<[u8]>::to_vec)
                    .collect()
            } else {
                d.iter().map(|&b| vec![b]).collect()
            }
        };
        if !unit_is_line && best.len() > 2000 {
            break;
        }
        let mut chunk = split(&best).len() / 2;
        while chunk >= 1 {
            let mut i = 0;
            loop {
                let parts = split(&best);
                if i >= parts.len() || tries >= budget {
                    break;
                }
                let candidate: Vec<u8> = parts
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| *k < i || *k >= i + chunk)
                    .flat_map(|(_, p)| p.iter().copied())
                    .collect();
                tries += 1;
                if candidate.len() < best.len() && same(&candidate) {
                    best = candidate;
                } else {
                    i += chunk;
                }
            }
            chunk /= 2;
        }
    }
    best
}
