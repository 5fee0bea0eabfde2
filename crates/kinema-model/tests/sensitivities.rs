//! Parameter sensitivities (issue 40, the symbolic step): the derived Φ_p,
//! velocity and acceleration right-hand sides and the results' y_p, ẏ_p,
//! ÿ_p against central finite differences of the derivation's own Φ, Φ_q,
//! ν, γ and results, at random states of every model in `models/`; the
//! text `kinema derive` will print, pinned; the errors.
//!
//! The identities checked are algebraic (they hold at any q, q̇, q̈, s, ṡ,
//! s̈, p, t, not only on a solution), so the states are random: near the
//! guess, with random velocities, accelerations and sensitivities, the
//! params within 10 % of their defaults.

use std::path::{Path, PathBuf};

use kinema_expr::{Tape, TapeInputs};
use kinema_model::{Derivation, Sensitivities, SensitivityError, derive_str};
use proptest::collection::vec;
use proptest::test_runner::{Config, TestCaseError, TestRunner};

/// Relative step of the central differences (of the larger of the
/// param's value and the coordinates'). The differences are of fourth
/// order (`fourth_order`), so the step can be large enough for their
/// roundoff, ε |f| / h, to stay far below the agreement where f is much
/// larger than its derivative: with second-order differences at 1e-6 the
/// IFToMM pendulum's acceleration rhs along its mass (3.4e-4, of an R_a
/// of about 2) disagreed by up to 2.6e-6, failing 3 runs of the suite in
/// 127. Each difference also bounds its own error (`Difference`), which
/// the comparison allows on top of the agreement.
const STEP: f64 = 1e-4;
/// Agreement required, relative to the largest entry of the compared
/// vector (so an entry that is zero does not need a tolerance of its own).
const AGREEMENT: f64 = 1e-6;

fn models_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn derive_file(path: &Path) -> Derivation {
    let src = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    derive_str(&src).unwrap_or_else(|e| panic!("{}", e.render(&src, &path.display().to_string())))
}

/// The derivation of `path` and its sensitivities to every param.
fn with_all_params(path: &Path) -> (Derivation, Sensitivities) {
    let mut d = derive_file(path);
    let names: Vec<String> = d.params.iter().map(|p| p.name.clone()).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let s = d
        .sensitivities(&names)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (d, s)
}

/// A random state: q near the guess, the rest in a few units, params
/// within 10 % of their defaults.
struct State {
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    s: Vec<f64>,
    sd: Vec<f64>,
    sdd: Vec<f64>,
    p: Vec<f64>,
    /// Multipliers, one per row of Φ (the dynamics level).
    lambda: Vec<f64>,
    t: f64,
}

impl State {
    /// How many uniform numbers in [-1, 1] a state of `d` takes.
    fn len(d: &Derivation) -> usize {
        6 * d.nc() + d.params.len() + d.rows.len() + 1
    }

    fn new(d: &Derivation, u: &[f64]) -> State {
        let nc = d.nc();
        let mut it = u.iter().copied();
        let mut take = |n: usize, f: &dyn Fn(usize, f64) -> f64| -> Vec<f64> {
            (0..n).map(|k| f(k, it.next().unwrap_or(0.0))).collect()
        };
        let guess = d.guess_values();
        let defaults = d.param_values();
        let q = take(nc, &|k, x| guess[k] + 0.3 * x);
        let qd = take(nc, &|_, x| 2.0 * x);
        let qdd = take(nc, &|_, x| 3.0 * x);
        let s = take(nc, &|_, x| x);
        let sd = take(nc, &|_, x| 1.5 * x);
        let sdd = take(nc, &|_, x| 2.0 * x);
        let p = take(defaults.len(), &|k, x| defaults[k] * (1.0 + 0.1 * x));
        let lambda = take(d.rows.len(), &|_, x| 4.0 * x);
        let t = 0.5 * (1.0 + take(1, &|_, x| x)[0]);
        State {
            lambda,
            q,
            qd,
            qdd,
            s,
            sd,
            sdd,
            p,
            t,
        }
    }

    /// The augmented inputs the sensitivity expressions read: [q; s] and
    /// [q̇; ṡ].
    fn augmented(&self) -> (Vec<f64>, Vec<f64>) {
        (
            [self.q.as_slice(), &self.s].concat(),
            [self.qd.as_slice(), &self.sd].concat(),
        )
    }

    /// The state moved by `eps` along the seeds of param `k`: q + εs,
    /// q̇ + εṡ, q̈ + εs̈, p_k + ε.
    fn moved(&self, k: usize, eps: f64) -> State {
        let along = |x: &[f64], dx: &[f64]| -> Vec<f64> {
            x.iter().zip(dx).map(|(a, b)| a + eps * b).collect()
        };
        let mut p = self.p.clone();
        p[k] += eps;
        State {
            lambda: self.lambda.clone(),
            q: along(&self.q, &self.s),
            qd: along(&self.qd, &self.sd),
            qdd: along(&self.qdd, &self.sdd),
            s: self.s.clone(),
            sd: self.sd.clone(),
            sdd: self.sdd.clone(),
            p,
            t: self.t,
        }
    }
}

fn mat_vec(m: &[Vec<f64>], x: &[f64]) -> Vec<f64> {
    m.iter()
        .map(|row| row.iter().zip(x).map(|(a, b)| a * b).sum())
        .collect()
}

/// R_v = Φ_q q̇ − ν, from the derivation's Φ_q and ν.
fn r_v(d: &Derivation, x: &State) -> Vec<f64> {
    let jq = d.eval_dense(&d.phi_q, &x.q, &x.qd, x.t, &x.p);
    let nu = d.eval_vec(&d.nu, &x.q, &x.qd, x.t, &x.p);
    mat_vec(&jq, &x.qd)
        .iter()
        .zip(nu)
        .map(|(a, b)| a - b)
        .collect()
}

/// R_a = Φ_q q̈ − γ, from the derivation's Φ_q and γ.
fn r_a(d: &Derivation, x: &State) -> Vec<f64> {
    let jq = d.eval_dense(&d.phi_q, &x.q, &x.qd, x.t, &x.p);
    let gamma = d.eval_vec(&d.gamma, &x.q, &x.qd, x.t, &x.p);
    mat_vec(&jq, &x.qdd)
        .iter()
        .zip(gamma)
        .map(|(a, b)| a - b)
        .collect()
}

/// Every result's (y, ẏ, ÿ), ÿ = y_q q̈ + c.
fn results(d: &Derivation, x: &State) -> Vec<[f64; 3]> {
    d.outputs
        .iter()
        .map(|o| {
            let at = |e| d.eval(e, &x.q, &x.qd, x.t, &x.p);
            let qdd: f64 = o
                .jacobian
                .iter()
                .map(|&(k, e)| at(e) * x.qdd[k as usize])
                .sum();
            [at(o.value), at(o.velocity), qdd + at(o.acceleration)]
        })
        .collect()
}

/// R_d = Φ_qᵀλ − Q_A + M q̈ (zero on the inverse dynamics' solution),
/// from the derivation's Φ_q, Q_A and M.
fn r_d(d: &Derivation, x: &State) -> Vec<f64> {
    let Some(dy) = &d.dynamics else {
        return Vec::new();
    };
    let mut out = vec![0.0; d.nc()];
    for en in &d.phi_q.entries {
        let v = d.eval(en.expr, &x.q, &x.qd, x.t, &x.p);
        out[en.col as usize] += v * x.lambda[en.row as usize];
    }
    let at = |e| d.eval(e, &x.q, &x.qd, x.t, &x.p);
    for (k, (&qa, &m)) in dy.applied.iter().zip(&dy.mass).enumerate() {
        out[k] += -at(qa) + at(m) * x.qdd[k];
    }
    out
}

/// The largest difference of `exact` and the difference `fd`, beyond the
/// difference's own error bound, relative to the largest entry of either;
/// 0 for two (near-)zero vectors.
fn disagreement(exact: &[f64], fd: &Difference) -> f64 {
    let scale = exact
        .iter()
        .chain(&fd.value)
        .fold(0.0f64, |m, v| m.max(v.abs()));
    if scale < 1e-9 {
        return 0.0;
    }
    exact
        .iter()
        .zip(&fd.value)
        .zip(&fd.error)
        .fold(0.0f64, |m, ((a, b), e)| m.max((a - b).abs() - e))
        / scale
}

/// One quantity's exact and finite-difference values.
struct Compared {
    what: String,
    exact: Vec<f64>,
    fd: Difference,
}

/// A finite difference and a bound on its own error, entry by entry.
struct Difference {
    value: Vec<f64>,
    error: Vec<f64>,
}

impl Difference {
    fn negated(self) -> Difference {
        Difference {
            value: self.value.iter().map(|v| -v).collect(),
            ..self
        }
    }
}

/// The derivative at 0 of `f` by the fourth-order central difference of
/// step `h`, (8 (f(h) − f(−h)) − (f(2h) − f(−2h))) / 12h, and a bound on
/// its error: its distance from the same difference at 2h (whose
/// truncation error is 16 times its own: a model's stiff spring at a
/// random state made it 3.5e-6 at 1e-4, seen in a seed hunt) plus 64
/// roundoffs of the largest |f| over h (Φ of about 1 moved by ω at
/// t = 1.4e-6, a Φ_p of 1.4e-6: 2.2e-6 of it).
fn fourth_order(h: f64, f: impl Fn(f64) -> Vec<f64>) -> Difference {
    let at: Vec<Vec<f64>> = [h, -h, 2.0 * h, -2.0 * h, 4.0 * h, -4.0 * h]
        .iter()
        .map(|&e| f(e))
        .collect();
    let stencil = |i: usize, a: usize, k: f64| {
        (8.0 * (at[a][i] - at[a + 1][i]) - (at[a + 2][i] - at[a + 3][i])) / (12.0 * k * h)
    };
    let size = at.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let roundoff = 64.0 * f64::EPSILON * size / h;
    let n = at[0].len();
    let value: Vec<f64> = (0..n).map(|i| stencil(i, 0, 1.0)).collect();
    let error = (0..n)
        .map(|i| (value[i] - stencil(i, 2, 2.0)).abs() + roundoff)
        .collect();
    Difference { value, error }
}

/// Every derived sensitivity at state `x`, with its central difference.
fn compare_at(d: &Derivation, sens: &Sensitivities, x: &State) -> Vec<Compared> {
    let mut out = Vec::new();
    for ps in &sens.params {
        let k = ps.index;
        let h = STEP * if x.p[k] == 0.0 { 1.0 } else { x.p[k].abs() };
        // The step moves p by h and q by h·s: s, ṡ, s̈ are scaled to the
        // size ∂q/∂p has (that of q over that of p), so both move by about
        // 1e-6 of their own size, whether p is a moment of inertia of 1e-6
        // or a stiffness of 4530.
        let x = &x.tangent_scaled(h / STEP);
        let central = |f: &dyn Fn(&State) -> Vec<f64>| fourth_order(h, |eps| f(&x.moved(k, eps)));
        let (qa, qda) = x.augmented();
        let at = |es: &[kinema_expr::ExprId]| d.eval_vec(es, &qa, &qda, x.t, &x.p);

        // Φ_p: Φ at p moved, q held.
        let fd = fourth_order(h, |eps| {
            let mut p = x.p.clone();
            p[k] += eps;
            d.eval_vec(&d.phi, &x.q, &x.qd, x.t, &p)
        });
        out.push(Compared {
            what: format!("Phi_p (p = {})", ps.name),
            exact: at(&ps.phi_p),
            fd,
        });

        // Velocity: −D R_v along (s, 1), q̇ held (ṡ is the unknown).
        let fd = central(&|y| {
            let mut y = y.clone_with_qdd(&x.qdd);
            y.qd.clone_from(&x.qd);
            r_v(d, &y)
        })
        .negated();
        out.push(Compared {
            what: format!("velocity rhs (p = {})", ps.name),
            exact: at(&ps.velocity_rhs),
            fd,
        });

        // Acceleration: −D R_a along (s, ṡ, 1), q̈ held (s̈ is the
        // unknown); exact = rhs − W q̈.
        let w = d.eval_dense(&ps.acceleration_qdd, &qa, &qda, x.t, &x.p);
        let exact = at(&ps.acceleration_rhs)
            .iter()
            .zip(mat_vec(&w, &x.qdd))
            .map(|(a, b)| a - b)
            .collect();
        let fd = central(&|y| r_a(d, &y.clone_with_qdd(&x.qdd))).negated();
        out.push(Compared {
            what: format!("acceleration rhs (p = {})", ps.name),
            exact,
            fd,
        });

        // Results: y, ẏ, ÿ along (s, ṡ, s̈, 1).
        if !ps.outputs.is_empty() {
            let fd = central(&|y| results(d, y).into_iter().flatten().collect());
            let exact = ps
                .outputs
                .iter()
                .zip(&d.outputs)
                .flat_map(|(o, column)| {
                    let e = |e| d.eval(e, &qa, &qda, x.t, &x.p);
                    let sdd: f64 = column
                        .jacobian
                        .iter()
                        .map(|&(j, c)| e(c) * x.sdd[j as usize])
                        .sum();
                    let qdd: f64 = o.qdd.iter().map(|&(j, c)| e(c) * x.qdd[j as usize]).sum();
                    [e(o.value), e(o.velocity), sdd + qdd + e(o.acceleration)]
                })
                .collect();
            out.push(Compared {
                what: format!("results (p = {})", ps.name),
                exact,
                fd,
            });
        }

        // Dynamics: D R_d along (s, ṡ, s̈, 1), λ held (λ_p is the unknown):
        // Wᵀλ − dQ_A/dp + (dM/dp) q̈ + M s̈.
        if let (Some(dy), Some(dp)) = (&d.dynamics, &ps.dynamics) {
            let mut exact = vec![0.0; d.nc()];
            for en in &ps.acceleration_qdd.entries {
                let v = d.eval(en.expr, &qa, &qda, x.t, &x.p);
                exact[en.col as usize] += v * x.lambda[en.row as usize];
            }
            let e = |e| d.eval(e, &qa, &qda, x.t, &x.p);
            for (k, v) in exact.iter_mut().enumerate().take(dy.mass.len()) {
                *v += -e(dp.applied[k]) + e(dp.mass[k]) * x.qdd[k] + e(dy.mass[k]) * x.sdd[k];
            }
            out.push(Compared {
                what: format!("dynamics (p = {})", ps.name),
                exact,
                fd: central(&|y| r_d(d, y)),
            });

            // The reactions' arms along (s, 1).
            assert_eq!(dp.arms.len(), dy.reactions.len());
            if !dy.reactions.is_empty() {
                let arms = |y: &State| -> Vec<f64> {
                    dy.reactions
                        .iter()
                        .flat_map(|r| r.arm.map(|a| d.eval(a, &y.q, &y.qd, y.t, &y.p)))
                        .collect()
                };
                out.push(Compared {
                    what: format!("reaction arms (p = {})", ps.name),
                    exact: dp.arms.iter().flat_map(|a| a.map(e)).collect(),
                    fd: central(&arms),
                });
            }
        }
    }
    out
}

impl State {
    /// A copy with s, ṡ, s̈ scaled by (the size of q) / `p_size`.
    fn tangent_scaled(&self, p_size: f64) -> State {
        let q_size = self.q.iter().fold(1e-3f64, |m, v| m.max(v.abs()));
        let scale = |v: &[f64]| v.iter().map(|x| x * q_size / p_size).collect();
        State {
            s: scale(&self.s),
            sd: scale(&self.sd),
            sdd: scale(&self.sdd),
            ..self.clone_with_qdd(&self.qdd)
        }
    }

    /// A copy whose q̈ is `qdd` (the acceleration level holds q̈ fixed).
    fn clone_with_qdd(&self, qdd: &[f64]) -> State {
        State {
            lambda: self.lambda.clone(),
            q: self.q.clone(),
            qd: self.qd.clone(),
            qdd: qdd.to_vec(),
            s: self.s.clone(),
            sd: self.sd.clone(),
            sdd: self.sdd.clone(),
            p: self.p.clone(),
            t: self.t,
        }
    }
}

/// Checks every sensitivity of the model at `cases` random states; the
/// largest disagreement seen.
fn check_model(path: &Path, cases: u32) -> f64 {
    let (d, sens) = with_all_params(path);
    let worst = std::cell::Cell::new(0.0f64);
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    });
    let result = runner.run(&vec(-1.0f64..1.0, State::len(&d)), |u| {
        let x = State::new(&d, &u);
        for c in compare_at(&d, &sens, &x) {
            if c.exact.iter().chain(&c.fd.value).any(|v| !v.is_finite()) {
                return Err(TestCaseError::fail(format!(
                    "{}: not finite: exact {:?}, differences {:?}",
                    c.what, c.exact, c.fd.value
                )));
            }
            let e = disagreement(&c.exact, &c.fd);
            worst.set(worst.get().max(e));
            if e > AGREEMENT {
                return Err(TestCaseError::fail(format!(
                    "{}: disagreement {e:e} beyond the differences' error\n  exact {:?}\n  \
                     differences {:?}\n  their error bounds {:?}",
                    c.what, c.exact, c.fd.value, c.fd.error
                )));
            }
        }
        Ok(())
    });
    if let Err(e) = result {
        panic!("{}: {e}", path.display());
    }
    eprintln!(
        "{}: {} params, largest disagreement beyond the differences' error {:.1e}",
        path.file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        sens.params.len(),
        worst.get()
    );
    worst.get()
}

/// Every `.kin` file under `dir`, sorted.
fn kin_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "kin") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

#[test]
fn slider_crank_agrees_with_finite_differences() {
    check_model(&models_dir().join("slider_crank.kin"), 64);
}

#[test]
fn four_bar_agrees_with_finite_differences() {
    check_model(&models_dir().join("four_bar.kin"), 64);
}

#[test]
fn roller_cam_follower_agrees_with_finite_differences() {
    check_model(&models_dir().join("roller_cam.kin"), 64);
}

/// Every model of `models/` (the iftomm ones included) and the follower
/// models of the repository's tests.
#[test]
fn every_model_agrees_with_finite_differences() {
    let mut files = kin_files(&models_dir());
    assert!(files.len() >= 10, "{files:?}");
    files.extend(kin_files(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/followers"),
    ));
    for f in files {
        check_model(&f, 16);
    }
}

/// The models with inertia get the dynamics' terms, checked above with
/// the rest (the iftomm models of `models/`, and the slider-crank of the
/// repository's dynamics tests).
#[test]
fn models_with_inertia_agree_with_finite_differences() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    for f in [
        root.join("models/iftomm/a03_andrews.kin"),
        root.join("tests/dynamics/slider_crank.kin"),
    ] {
        let (d, s) = with_all_params(&f);
        assert!(d.dynamics.is_some(), "{}", f.display());
        assert!(s.params.iter().all(|p| p.dynamics.is_some()));
        check_model(&f, 16);
    }
}

/// The comparison has teeth: a sensitivity with a sign error, or without
/// its explicit ∂/∂p part, is refused.
#[test]
fn a_wrong_sensitivity_is_refused() {
    let (d, sens) = with_all_params(&models_dir().join("four_bar.kin"));
    let u: Vec<f64> = (0..State::len(&d))
        .map(|i| ((i as f64) * 0.618_033_988_7).fract() * 2.0 - 1.0)
        .collect();
    let x = State::new(&d, &u);
    let compared = compare_at(&d, &sens, &x);
    assert!(compared.len() >= 4 * sens.params.len());
    for c in &compared {
        assert!(disagreement(&c.exact, &c.fd) <= AGREEMENT, "{}", c.what);
        let negated: Vec<f64> = c.exact.iter().map(|v| -v).collect();
        let norm = c.exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if norm > 1e-9 {
            assert!(disagreement(&negated, &c.fd) > 0.1, "{}", c.what);
        }
    }
    // Without ∂Φ/∂p (only Φ_q s), the position level of l1 is wrong.
    let l1 = &sens.params[0];
    assert_eq!(l1.name, "l1");
    let (qa, qda) = x.augmented();
    let w: Vec<f64> = d
        .eval_vec(&l1.phi_p, &qa, &qda, x.t, &x.p)
        .iter()
        .map(|v| v * 0.5)
        .collect();
    assert!(disagreement(&w, &compared[0].fd) > 0.1);
}

/// The expressions compile to a tape that reads s and ṡ after q and q̇
/// (`Coordinate(nc + k)`, `Velocity(nc + k)`) and gives the tree
/// evaluator's bits.
#[test]
fn tapes_read_the_augmented_state() {
    let (d, sens) = with_all_params(&models_dir().join("four_bar.kin"));
    let nc = d.nc();
    for (k, (&s, &sd)) in sens.coordinates.iter().zip(&sens.velocities).enumerate() {
        assert_eq!(
            d.arena.symbol(s).kind,
            kinema_expr::SymKind::Coordinate((nc + k) as u32)
        );
        assert_eq!(
            d.arena.symbol(sd).kind,
            kinema_expr::SymKind::Velocity((nc + k) as u32)
        );
        assert_eq!(
            d.arena.symbol(s).name,
            format!("∂{}", d.coordinates[k].name)
        );
    }
    let u: Vec<f64> = (0..State::len(&d))
        .map(|i| ((i as f64) * 0.414_213_562_3).fract() * 2.0 - 1.0)
        .collect();
    let x = State::new(&d, &u);
    let (qa, qda) = x.augmented();
    for ps in &sens.params {
        let mut exprs = ps.phi_p.clone();
        exprs.extend(&ps.velocity_rhs);
        exprs.extend(&ps.acceleration_rhs);
        exprs.extend(ps.acceleration_qdd.entries.iter().map(|en| en.expr));
        for o in &ps.outputs {
            exprs.extend([o.value, o.velocity, o.acceleration]);
        }
        let tape = Tape::compile(&d.arena, &exprs);
        let mut registers = vec![0.0; tape.registers()];
        let mut out = vec![0.0; exprs.len()];
        let inputs = TapeInputs {
            q: &qa,
            qd: &qda,
            params: &x.p,
            t: x.t,
        };
        tape.eval(&inputs, &mut registers, &mut out)
            .unwrap_or_else(|e| panic!("{e}"));
        let tree = d.eval_vec(&exprs, &qa, &qda, x.t, &x.p);
        for (a, b) in out.iter().zip(&tree) {
            assert_eq!(a.to_bits(), b.to_bits(), "{} vs {}", a, b);
        }
        // Given only q and q̇, the tape asks for s and ṡ.
        let short = TapeInputs {
            q: &x.q,
            qd: &x.qd,
            params: &x.p,
            t: x.t,
        };
        assert!(tape.eval(&short, &mut registers, &mut out).is_err());
    }
}

/// What `kinema derive` will print for the sensitivities of the
/// slider-crank to a length (in a named point and the driver-free rows)
/// and to the crank speed (in the driver, with its time terms).
#[test]
fn slider_crank_sensitivities_text() {
    let mut d = derive_file(&models_dir().join("slider_crank.kin"));
    let before = d.render();
    let s = d
        .sensitivities(&["l1", "omega"])
        .unwrap_or_else(|e| panic!("{e}"));
    insta::assert_snapshot!(d.render_sensitivities(&s));
    // The derivation's own text does not change.
    assert_eq!(d.render(), before);
}

/// With inertia, the text adds dM/dp and dQ_A/dp (the IFToMM pendulum,
/// whose mass is a param: gravity's force follows it).
#[test]
fn pendulum_dynamics_sensitivities_text() {
    let mut d = derive_file(&models_dir().join("iftomm/a01_pendulum.kin"));
    let s = d
        .sensitivities(&["m", "l"])
        .unwrap_or_else(|e| panic!("{e}"));
    insta::assert_snapshot!(d.render_sensitivities(&s));
}

/// Asking twice gives the same expressions (the arena memoizes), in the
/// order asked.
#[test]
fn asking_again_gives_the_same_expressions() {
    let mut d = derive_file(&models_dir().join("four_bar.kin"));
    let a = d
        .sensitivities(&["l2", "l1"])
        .unwrap_or_else(|e| panic!("{e}"));
    let size = d.arena.size();
    let b = d.sensitivities(&["l1"]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(a.params[0].name, "l2");
    assert_eq!(a.params[1].name, "l1");
    assert_eq!(a.params[1].phi_p, b.params[0].phi_p);
    assert_eq!(a.params[1].velocity_rhs, b.params[0].velocity_rhs);
    assert_eq!(a.params[1].acceleration_rhs, b.params[0].acceleration_rhs);
    assert_eq!(a.params[1].acceleration_qdd, b.params[0].acceleration_qdd);
    assert_eq!(a.coordinates, b.coordinates);
    assert_eq!(d.arena.size(), size);
}

#[test]
fn names_that_are_not_params_are_errors_naming_the_params() {
    let mut d = derive_file(&models_dir().join("slider_crank.kin"));
    let msg = |d: &mut Derivation, names: &[&str]| match d.sensitivities(names) {
        Ok(_) => panic!("{names:?} accepted"),
        Err(e) => e.to_string(),
    };
    let known = "the model's params are l1, l2, omega";
    assert_eq!(
        msg(&mut d, &["l1", "l9"]),
        format!("no param named `l9`; {known}")
    );
    assert_eq!(
        msg(&mut d, &["crank"]),
        format!("`crank` is a body, not a param; {known}")
    );
    assert_eq!(
        msg(&mut d, &["crank.phi"]),
        format!("`crank.phi` is a coordinate, not a param; {known}")
    );
    assert_eq!(
        msg(&mut d, &["reach"]),
        format!("`reach` is an output, not a param; {known}")
    );
    assert_eq!(
        msg(&mut d, &["crank.o.x"]),
        format!("`crank.o.x` is an output, not a param; {known}")
    );
    assert_eq!(
        msg(&mut d, &["pin"]),
        format!("`pin` is an equation, not a param; {known}")
    );
    assert_eq!(
        msg(&mut d, &["t"]),
        format!("`t` is time, not a param; {known}")
    );
    assert_eq!(
        msg(&mut d, &["l2", "l2"]),
        "the param `l2` is asked for more than once"
    );
    let mut chain = derive_file(&models_dir().join("chain10.kin"));
    assert_eq!(
        msg(&mut chain, &["l"]),
        "no param named `l`; the model has no params"
    );
    // Nothing asked, nothing derived.
    let s = chain.sensitivities(&[]).unwrap_or_else(|e| panic!("{e}"));
    assert!(s.params.is_empty());
}

/// Derivatives beyond the budget are a clear error, and the derivation is
/// left as it was (no symbol, no half-derived expression added).
#[test]
fn over_budget_is_an_error_and_changes_nothing() {
    let mut d = derive_file(&models_dir().join("four_bar.kin"));
    let size = d.arena.size();
    let text = d.render();
    let err = d
        .sensitivities_with_budget(&["l1"], 20)
        .err()
        .unwrap_or_else(|| panic!("a budget of 20 entries was enough"));
    assert_eq!(
        err,
        SensitivityError::TooLarge {
            param: "l1".into(),
            item: "o".into(),
            budget: 20
        }
    );
    assert_eq!(
        err.to_string(),
        "the derivatives of `o` with respect to `l1` are too large: they would need more than \
         20 expression entries (the limit per equation)"
    );
    assert_eq!(d.arena.size(), size);
    assert_eq!(d.render(), text);
    // With the default budget it works, after the failure.
    let s = d.sensitivities(&["l1"]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.params.len(), 1);
}

/// The serial chain of BENCHMARKS.md with its link length a param `L`.
fn chain_with_length(n: usize) -> Derivation {
    let src = kinema_model::chain::chain_kin(n)
        .replace("(0.5, 0)", "(L / 2, 0)")
        .replace("(-0.5, 0)", "(-L / 2, 0)")
        .replacen('{', "{\n    param L = 1;", 1);
    derive_str(&src).unwrap_or_else(|e| panic!("{}", e.render(&src, "chain.kin")))
}

/// What one param adds to the arena is linear in the size of the model
/// (nothing quadratic in the number of bodies, no blow-up).
#[test]
fn one_param_costs_linear_size() {
    let mut added = Vec::new();
    for n in [25, 50, 100] {
        let mut d = chain_with_length(n);
        let before = d.arena.size();
        let s = d.sensitivities(&["L"]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.params[0].phi_p.len(), 3 * n);
        let grown = d.arena.size() - before;
        eprintln!("chain{n}: the derivation {before} entries, one param adds {grown}");
        added.push(grown as f64);
    }
    for w in added.windows(2) {
        let ratio = w[1] / w[0];
        assert!((1.5..2.5).contains(&ratio), "{added:?}");
    }
}
