//! Reads every real simEngine2D file in `../shared/simengine2d/` (beside the
//! repository), when that folder is present: each ADM parses, has the counts
//! of docs/src/simengine2d.md's table, and prints as `.kin`; each ACF parses to the
//! values the page lists. Skips with a notice when the folder is absent.
//! (The files are reference material and are not copied into the repository.)

#![allow(clippy::unwrap_used)] // tests: a failure should stop the test

use std::path::PathBuf;

use kinema_adm::{Analysis, ConstraintKind, Counts, Model, Simulation, to_kin};

fn folder() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/simengine2d");
    if dir.is_dir() {
        Some(dir)
    } else {
        println!(
            "NOTICE: {} is absent; skipping the tests on the real simEngine2D files",
            dir.display()
        );
        None
    }
}

/// docs/src/simengine2d.md, "The course's models": bodies, n, m.
const COUNTS: &[(&str, usize, usize, usize)] = &[
    ("pendKIN", 1, 3, 3),
    ("simplePend", 1, 3, 3),
    ("rodDYN", 1, 3, 3),
    ("dpendKIN", 2, 6, 6),
    ("project1", 2, 6, 6),
    ("rack_pinion", 2, 6, 6),
    ("sliderCrankKIN", 3, 9, 9),
    ("projectFinalKIN", 3, 9, 9),
    ("projectFinalDYN", 3, 9, 9),
    ("shurikenCatapult", 5, 15, 15),
    ("pend1", 1, 3, 2),
    ("pendDYN", 1, 3, 2),
    ("pend2", 1, 3, 2),
    ("pendEQL", 1, 3, 2),
    ("finalExam", 2, 6, 5),
    ("sliderCrankDYN", 3, 9, 8),
    ("project2", 3, 9, 8),
    ("doublePendDYN", 2, 6, 4),
    ("dpendVIS", 2, 6, 4),
];

/// docs/src/simengine2d.md, "The analysis file (ACF)": simulation, tend, stepSize, outputSteps.
const ANALYSES: &[(&str, Simulation, f64, f64, usize)] = &[
    ("kinematics", Simulation::Kinematics, 5.0, 0.01, 500),
    ("project1", Simulation::Kinematics, 5.0, 0.01, 300),
    ("shurikenCatapult", Simulation::Kinematics, 5.0, 0.01, 500),
    ("dynamics", Simulation::Dynamics, 4.0, 0.005, 400),
    ("finalExam", Simulation::Dynamics, 4.0, 0.005, 400),
    ("project2", Simulation::Dynamics, 1.0, 0.001, 500),
];

fn files(dir: &std::path::Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

fn stem(p: &std::path::Path) -> String {
    p.file_stem().unwrap().to_string_lossy().into_owned()
}

#[test]
fn every_adm_parses_counts_and_emits() {
    let Some(dir) = folder() else { return };
    let adms = files(&dir, "adm");
    assert!(!adms.is_empty());
    for path in &adms {
        let name = stem(path);
        let model = Model::read(path).unwrap_or_else(|e| panic!("{e}")).0;
        assert!(model.warnings.is_empty(), "{name}: {:?}", model.warnings);
        let counts = Counts::of(&model);
        let expected = COUNTS
            .iter()
            .find(|c| c.0 == name)
            .unwrap_or_else(|| panic!("{name} is not in docs/src/simengine2d.md's table"));
        assert_eq!(
            (counts.bodies, counts.n, counts.m),
            (expected.1, expected.2, expected.3),
            "{name}"
        );
        let kin = to_kin(&model);
        let items = kin
            .lines()
            .filter(|l| {
                ["    joint ", "    constraint ", "    driver "]
                    .iter()
                    .any(|k| l.starts_with(k))
            })
            .count();
        // One item per element (a RackPinion is the library's
        // `rack_pinion`, one element with one reaction).
        assert_eq!(items, model.constraints.len(), "{name}:\n{kin}");
        assert_eq!(
            kin.matches("    body ").count(),
            model.bodies.len(),
            "{name}"
        );
        println!(
            "{name}: {} bodies, n = {}, m = {}, NDOF = {}, {} forces, {} lines of .kin",
            counts.bodies,
            counts.n,
            counts.m,
            counts.ndof(),
            model.forces.len(),
            kin.lines().count()
        );
    }
    assert_eq!(adms.len(), COUNTS.len());
}

#[test]
fn every_acf_parses() {
    let Some(dir) = folder() else { return };
    let acfs = files(&dir, "acf");
    assert_eq!(acfs.len(), ANALYSES.len());
    for path in &acfs {
        let name = stem(path);
        let a = Analysis::read(path).unwrap_or_else(|e| panic!("{e}"));
        let e = ANALYSES.iter().find(|a| a.0 == name).unwrap();
        assert_eq!(
            (a.simulation, a.tend, a.step_size, a.output_steps),
            (e.1, e.2, e.3, e.4),
            "{name}"
        );
        assert_eq!(a.output_times().len(), e.4 + 1);
        assert_eq!(a.output_times().last().copied(), Some(e.2));
    }
}

#[test]
fn details_of_the_real_files() {
    let Some(dir) = folder() else { return };
    // Arithmetic where JSON wants a number.
    let shuriken = Model::read(&dir.join("shurikenCatapult.adm")).unwrap().0;
    let bg = shuriken.vis.as_ref().unwrap().bg_rgb.unwrap();
    assert_eq!(bg, [187.0 / 255.0, 98.0 / 255.0, 0.0]);
    assert_eq!(shuriken.ignored_keys, ["contacts"]);
    assert!(shuriken.forces.is_empty()); // `{}` is no force element
    assert_eq!(shuriken.bodies[2].name, "Long Rod");
    let kin = to_kin(&shuriken);
    assert!(
        kin.contains("body Long_Rod { guess: (178, -126.2, 1.126), mass: 5, inertia: 900 }"),
        "{kin}"
    );
    assert!(kin.contains("joint Translational_Collar_Long_Rod: translational(Collar(3, 0), (1, 0), Long_Rod(2, 0), (1, 0));"), "{kin}");
    assert!(
        kin.contains("driver Crank_Angle: abs_angle(Crank, 15 * t);"),
        "{kin}"
    );

    // RackPinion as one library element, the offsets as written.
    let rp = Model::read(&dir.join("rack_pinion.adm")).unwrap().0;
    let kin = to_kin(&rp);
    assert!(
        kin.contains(
            "constraint rp: rack_pinion(rack(0, 0), (-1, 0), pinion(0, 0), 0.2, \
             1 + 0.2 * (-3.141592653897 - 1.570796326795 + 3 * pi / 2));"
        ),
        "{kin}"
    );
    let ConstraintKind::AbsoluteAngle { fun, .. } = &rp.constraints[4].kind else {
        panic!()
    };
    assert_eq!(fun.eval(0.3), (10.0f64 * 0.3).sin());

    // Drivers and constraints.
    let sc = Model::read(&dir.join("sliderCrankKIN.adm")).unwrap().0;
    let kin = to_kin(&sc);
    assert!(
        kin.contains("driver absAngleDriver_crank: abs_angle(crank, powi(t, 2));"),
        "{kin}"
    );
    assert!(
        kin.contains("constraint absAngle_slider: abs_angle(slider, 0);"),
        "{kin}"
    );
    let rod = Model::read(&dir.join("rodDYN.adm")).unwrap().0;
    assert!(to_kin(&rod).contains("driver driver: abs_angle(pend, t + pi / 6);"));

    // A dynamics model's forces are imported, but for its PointForceFile.
    let p2 = Model::read(&dir.join("project2.adm")).unwrap().0;
    let ignored = kinema_adm::ignored_by_kinematics(&p2);
    assert_eq!(ignored.len(), 1, "{ignored:?}");
    assert!(ignored[0].contains("\"force\" (id 1, PointForceFile)"));
    assert!(ignored[0].contains("pistonForce.m"));
    assert!(
        to_kin(&p2).contains("force torque: torque("),
        "{}",
        to_kin(&p2)
    );
    let refusal = kinema_adm::check_kinematic(&p2, &Analysis::default()).unwrap_err();
    assert_eq!(refusal.counts.ndof(), 1);
}
