//! Unbounded depth and width: nothing in the engine may recurse on the
//! expression, so these run on a thread with a 2 MiB stack (the default for
//! test threads, made explicit here).

use kinema_expr::{Arena, Tape, TapeInputs};

const N: usize = 100_000;

fn on_small_stack(f: impl FnOnce() + Send + 'static) {
    let handle = std::thread::Builder::new()
        .stack_size(2 << 20)
        .spawn(f)
        .expect("spawn test thread");
    if let Err(panic) = handle.join() {
        std::panic::resume_unwind(panic);
    }
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

#[test]
fn sum_of_100k_terms() {
    on_small_stack(|| {
        let mut a = Arena::new();
        let x = a.coordinate("x", 0);
        let sx = a.symbol_of(x).expect("x is a symbol");
        // Σ sin((k + 1)·x), k = 0..N
        let terms: Vec<_> = (0..N)
            .map(|k| {
                let arg = a.scale((k + 1) as f64, x);
                a.sin(arg)
            })
            .collect();
        let e = a.sum(&terms);
        let d = a.diff(e, sx);

        let xv: f64 = 0.3;
        let want: f64 = (0..N).map(|k| ((k + 1) as f64 * xv).sin()).sum();
        let want_d: f64 = (0..N)
            .map(|k| (k + 1) as f64 * ((k + 1) as f64 * xv).cos())
            .sum();
        let got = a.eval_many(&[e, d], |_| xv);
        assert!(close(got[0], want, 1e-9), "{} vs {want}", got[0]);
        assert!(close(got[1], want_d, 1e-9), "{} vs {want_d}", got[1]);

        let tape = Tape::compile(&a, &[e, d]);
        let mut regs = vec![0.0; tape.registers()];
        let mut out = [0.0; 2];
        let inputs = TapeInputs {
            q: &[xv],
            qd: &[],
            params: &[],
            t: 0.0,
        };
        tape.eval(&inputs, &mut regs, &mut out)
            .expect("tape inputs fit");
        assert_eq!(out[0].to_bits(), got[0].to_bits());
        assert_eq!(out[1].to_bits(), got[1].to_bits());

        let text = a.display(e).to_string();
        assert_eq!(text.matches("sin(").count(), N);
        let dtext = a.display(d).to_string();
        assert_eq!(dtext.matches("cos(").count(), N);
    });
}

#[test]
fn product_sin_nesting_100k_deep() {
    on_small_stack(|| {
        let mut a = Arena::new();
        let x = a.coordinate("x", 0);
        let sx = a.symbol_of(x).expect("x is a symbol");
        // e₀ = x, e_{k+1} = sin(x·e_k)
        let mut e = x;
        for _ in 0..N {
            let p = a.mul(x, e);
            e = a.sin(p);
        }
        let d = a.diff(e, sx);

        // Reference value and derivative by forward recursion in dual numbers.
        let xv: f64 = 0.7;
        let (mut v, mut dv) = (xv, 1.0);
        for _ in 0..N {
            let (p, dp) = (xv * v, v + xv * dv);
            (v, dv) = (p.sin(), p.cos() * dp);
        }
        let got = a.eval_many(&[e, d], |_| xv);
        assert!(close(got[0], v, 1e-12), "{} vs {v}", got[0]);
        assert!(close(got[1], dv, 1e-9), "{} vs {dv}", got[1]);

        // Registers are reused: the expression alone needs a handful. (With its
        // derivative every level stays live until the derivative uses it.)
        let alone = Tape::compile(&a, &[e]);
        assert!(alone.registers() < 8, "registers: {}", alone.registers());
        let tape = Tape::compile(&a, &[e, d]);
        let mut regs = vec![0.0; tape.registers()];
        let mut out = [0.0; 2];
        let inputs = TapeInputs {
            q: &[xv],
            qd: &[],
            params: &[],
            t: 0.0,
        };
        tape.eval(&inputs, &mut regs, &mut out)
            .expect("tape inputs fit");
        assert_eq!(out[0].to_bits(), got[0].to_bits());
        assert_eq!(out[1].to_bits(), got[1].to_bits());

        // The expression prints as a tree; the derivative, whose tree form
        // is quadratic in depth, prints as a program with shared bindings.
        let text = a.display(e).to_string();
        assert_eq!(text.matches("sin(").count(), N);
        assert!(text.starts_with("sin(x*sin(x*sin("));
        let program = a.display_program(&[("e", e), ("de", d)]);
        assert!(
            program.len() < 200 * N,
            "program is linear: {} bytes",
            program.len()
        );
        assert!(program.contains("\nde = "));
    });
}

#[test]
fn deep_chain_of_sums_and_quotients() {
    on_small_stack(|| {
        // e_{k+1} = (e_k + x)/(1 + x²): alternating sums and products, all distinct.
        let mut a = Arena::new();
        let x = a.coordinate("x", 0);
        let sx = a.symbol_of(x).expect("x is a symbol");
        let one = a.one();
        let x2 = a.powi(x, 2);
        let den = a.add(one, x2);
        let mut e = x;
        for _ in 0..N {
            let s = a.add(e, x);
            e = a.div(s, den);
        }
        let d = a.diff(e, sx);
        let xv: f64 = 0.5;
        let (mut v, mut dv) = (xv, 1.0);
        let (dn, ddn) = (1.0 + xv * xv, 2.0 * xv);
        for _ in 0..N {
            let (s, ds) = (v + xv, dv + 1.0);
            (v, dv) = (s / dn, (ds * dn - s * ddn) / (dn * dn));
        }
        let got = a.eval_many(&[e, d], |_| xv);
        assert!(close(got[0], v, 1e-12), "{} vs {v}", got[0]);
        assert!(close(got[1], dv, 1e-9), "{} vs {dv}", got[1]);
        let _ = a.display_program(&[("e", e), ("de", d)]);
    });
}
