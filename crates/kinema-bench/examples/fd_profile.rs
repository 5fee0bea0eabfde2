//! R HHT steps (h = 1 ms, from rest) of a forward-dynamics benchmark
//! mechanism, generated or tape, for callgrind: per-step instructions =
//! (Ir at 2R − Ir at R) / R, the set-up cancelling.
//!
//! `valgrind --tool=callgrind target/release/examples/fd_profile fd_chain100 generated 20`
//! (a fourth argument sets `HhtOptions::sparse_from`; the steps' allocations
//! are counted and printed).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use kinema::{ForwardSystem, Hht, HhtOptions};

/// Counts allocations (the steps' count is printed).
struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

#[allow(
    unsafe_code,
    reason = "a GlobalAlloc impl is unsafe by definition; it only forwards"
)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: the caller's contract, passed on.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract, passed on.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;
use kinema_bench::{forward_model, generated_forward};

fn run<S: ForwardSystem>(system: S, q0: &[f64], steps: usize) {
    let qd0 = vec![0.0; q0.len()];
    // A fourth argument: HhtOptions::sparse_from.
    let sparse_from = std::env::args()
        .nth(4)
        .and_then(|s| s.parse().ok())
        .unwrap_or(HhtOptions::default().sparse_from);
    let options = HhtOptions {
        sparse_from,
        ..HhtOptions::default()
    };
    let (mut hht, _) = Hht::new(system, q0, &qd0, 0.0, options).unwrap_or_else(|e| panic!("{e}"));
    let allocations = ALLOCATIONS.load(Ordering::Relaxed);
    let start = std::time::Instant::now();
    let mut slowest = (0, std::time::Duration::ZERO);
    for k in 0..steps {
        let t = std::time::Instant::now();
        hht.step(1e-3).unwrap_or_else(|e| panic!("{e}"));
        if t.elapsed() > slowest.1 {
            slowest = (k, t.elapsed());
        }
    }
    let elapsed = start.elapsed();
    let allocations = ALLOCATIONS.load(Ordering::Relaxed) - allocations;
    let s = hht.stats();
    eprintln!(
        "{steps} steps: {:.2?} per step, {} iterations, {} factorizations; slowest step {} ({:.2?}); {allocations} allocations",
        elapsed / steps.max(1) as u32,
        s.iterations,
        s.factorizations,
        slowest.0,
        slowest.1
    );
    std::hint::black_box(hht.q());
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("fd_chain100", String::as_str);
    let back = args.get(2).map_or("generated", String::as_str);
    let steps: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(20);
    let model = forward_model(name);
    let q0 = model.initial_configuration();
    if back == "tape" {
        let tape = model
            .forward_system()
            .unwrap_or_else(|| panic!("no inertia"));
        run(tape, &q0, steps);
        return;
    }
    match name {
        "fd_slider_crank" => run(
            generated_forward::fd_slider_crank::FdSliderCrank::default().forward(),
            &q0,
            steps,
        ),
        "fd_chain10" => run(
            generated_forward::fd_chain10::FdChain10::default().forward(),
            &q0,
            steps,
        ),
        _ => run(
            generated_forward::fd_chain100::FdChain100::default().forward(),
            &q0,
            steps,
        ),
    }
}
