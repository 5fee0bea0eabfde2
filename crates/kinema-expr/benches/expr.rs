//! Derivation speed on the serial chain of BENCHMARKS.md, built by hand with
//! the engine's API, and tape versus tree evaluation.
//!
//! `cargo bench -p kinema-expr`

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use kinema_expr::{Arena, ExprId, SparseMatrix, SymId, Tape, TapeInputs};

/// The derivation of the N-link chain: Φ, Φ_q and γ.
struct Chain {
    arena: Arena,
    phi: Vec<ExprId>,
    jac: SparseMatrix,
    gamma: Vec<ExprId>,
}

/// `r + A(φ)·(sx, 0)` for body coordinates (x, y, φ).
fn point(a: &mut Arena, q: [ExprId; 3], sx: f64) -> [ExprId; 2] {
    let c = a.cos(q[2]);
    let s = a.sin(q[2]);
    let dx = a.scale(sx, c);
    let dy = a.scale(sx, s);
    [a.add(q[0], dx), a.add(q[1], dy)]
}

/// Builds Φ of the chain (revolute to ground or to the previous link, then
/// an absolute-angle driver, per link) and derives Φ_q and γ.
fn chain(n: usize) -> Chain {
    let mut a = Arena::new();
    let t = a.time();
    let mut q: Vec<[ExprId; 3]> = Vec::with_capacity(n);
    let mut coords: Vec<SymId> = Vec::with_capacity(3 * n);
    let mut seeds: Vec<(SymId, ExprId)> = Vec::with_capacity(3 * n);
    for k in 0..n {
        let mut body = [t; 3];
        for (c, name) in ["x", "y", "phi"].iter().enumerate() {
            let i = (3 * k + c) as u32;
            let e = a.coordinate(&format!("b{}.{name}", k + 1), i);
            let v = a.velocity(&format!("b{}.{name}_dot", k + 1), i);
            let s = a.symbol_of(e).expect("coordinate is a symbol");
            coords.push(s);
            seeds.push((s, v));
            body[c] = e;
        }
        q.push(body);
    }
    let mut phi = Vec::with_capacity(3 * n);
    for k in 0..n {
        let tail = point(&mut a, q[k], -0.5);
        if k == 0 {
            phi.extend(tail);
        } else {
            let tip = point(&mut a, q[k - 1], 0.5);
            phi.push(a.sub(tip[0], tail[0]));
            phi.push(a.sub(tip[1], tail[1]));
        }
        // φ_k − (π/4 + 0.3 sin(2π t + k))
        let two_pi_t = a.scale(2.0 * std::f64::consts::PI, t);
        let kk = a.num((k + 1) as f64);
        let arg = a.add(two_pi_t, kk);
        let s = a.sin(arg);
        let wave = a.scale(0.3, s);
        let quarter = a.num(std::f64::consts::FRAC_PI_4);
        let f = a.add(quarter, wave);
        phi.push(a.sub(q[k][2], f));
    }
    let jac = a.jacobian(&phi, &coords);
    let v = a.seeds(&seeds);
    let one = a.one();
    let ts = a.symbol_of(t).expect("time is a symbol");
    let dt = a.seeds(&[(ts, one)]);
    let gamma = phi
        .iter()
        .map(|&p| {
            // γ = −(Φ_q q̇)_q q̇ − 2 Φ_qt q̇ − Φ_tt
            let w = a.directional(p, v);
            let wq = a.directional(w, v);
            let wt = a.directional(w, dt);
            let pt = a.directional(p, dt);
            let ptt = a.directional(pt, dt);
            let two_wt = a.scale(2.0, wt);
            let s = a.sum(&[wq, two_wt, ptt]);
            a.neg(s)
        })
        .collect();
    Chain {
        arena: a,
        phi,
        jac,
        gamma,
    }
}

fn derivation(c: &mut Criterion) {
    let mut group = c.benchmark_group("chain derivation (build Φ, Φ_q, γ)");
    group.sample_size(20);
    for n in [10usize, 100, 1000] {
        let ch = chain(n);
        eprintln!(
            "chain N={n}: {} nodes, {} Jacobian nonzeros, {} γ entries",
            ch.arena.len(),
            ch.jac.entries.len(),
            ch.gamma.len()
        );
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, &n| {
            b.iter(|| black_box(chain(n)).arena.len());
        });
    }
    group.finish();
}

fn evaluation(c: &mut Criterion) {
    let n = 100;
    let ch = chain(n);
    let outputs: Vec<ExprId> = ch
        .phi
        .iter()
        .copied()
        .chain(ch.jac.entries.iter().map(|e| e.expr))
        .chain(ch.gamma.iter().copied())
        .collect();
    let tape = Tape::compile(&ch.arena, &outputs);
    let q: Vec<f64> = (0..3 * n).map(|i| 0.1 * i as f64).collect();
    let qd: Vec<f64> = (0..3 * n).map(|i| 0.01 * i as f64).collect();
    let mut regs = vec![0.0; tape.registers()];
    let mut out = vec![0.0; outputs.len()];
    eprintln!(
        "chain N={n}: tape of {} instructions, {} registers, {} outputs",
        tape.len(),
        tape.registers(),
        outputs.len()
    );
    let mut group = c.benchmark_group("chain N=100 evaluation of Φ, Φ_q, γ");
    group.bench_function("tape", |b| {
        b.iter(|| {
            let inputs = TapeInputs {
                q: &q,
                qd: &qd,
                params: &[],
                t: 0.3,
            };
            tape.eval(black_box(&inputs), &mut regs, &mut out)
                .expect("inputs fit");
            out[0]
        });
    });
    group.bench_function("tree", |b| {
        b.iter(|| {
            let values = |s: SymId| match ch.arena.symbol(s).kind {
                kinema_expr::SymKind::Coordinate(i) => q[i as usize],
                kinema_expr::SymKind::Velocity(i) => qd[i as usize],
                _ => 0.3,
            };
            ch.arena.eval_many(black_box(&outputs), values)[0]
        });
    });
    group.finish();
}

criterion_group!(benches, derivation, evaluation);
criterion_main!(benches);
