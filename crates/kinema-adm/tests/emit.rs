//! Snapshots of the `.kin` text emitted for the crate's own ADM files, one
//! per constraint type, and checks of what the reader keeps.

#![allow(clippy::unwrap_used)] // tests: a failure should stop the test

mod common;

use kinema_adm::{Analysis, ConstraintKind, ForceKind, Model, Source, check_kinematic, to_kin};

fn model(name: &str) -> Model {
    let source = common::source(name);
    Model::parse(&source).unwrap_or_else(|e| panic!("{}", common::render(&source, e)))
}

#[test]
fn absolute_elements_and_ignored_parts() {
    // AbsoluteX, AbsoluteY, AbsoluteAngle (driver); tabs, no final newline,
    // arithmetic numbers, every force type, unknown top-level keys.
    let m = model("absolute_pendulum.adm");
    insta::assert_snapshot!("absolute_pendulum", to_kin(&m));
    assert_eq!(m.ignored_keys, ["contacts", "notes"]);
    assert_eq!(m.forces.len(), 4);
    assert!(
        matches!(m.forces[3].kind, ForceKind::PointForceFile { ref mfile, .. } if mfile == "myForce")
    );
    let vis = m.vis.as_ref().unwrap();
    assert_eq!(vis.bg_rgb, Some([200.0 / 255.0, 200.0 / 255.0, 1.0]));
    assert_eq!(
        vis.xlim,
        Some([
            -2.0 * std::f64::consts::PI / 3.0,
            2.0 * std::f64::consts::PI / 3.0
        ])
    );
    let body_vis = m.bodies[0].vis.as_ref().unwrap();
    assert_eq!(body_vis.shapes.len(), 2);
    assert_eq!(body_vis.shapes[1].size, [0.2, 0.2]);
    assert_eq!(body_vis.points, [[1.0, 0.0], [-1.0, 0.0]]);
    assert_eq!(m.bodies[0].mass, Some(2.0));
    assert!(m.warnings.is_empty());
}

#[test]
fn revolute_slider_crank() {
    let m = model("slider_crank.adm");
    insta::assert_snapshot!("slider_crank", to_kin(&m));
    let counts = check_kinematic(&m, &Analysis::default()).unwrap();
    assert_eq!((counts.n, counts.m, counts.driver_rows), (9, 9, 1));
    assert_eq!(m.q0(), [0.1, 0.1, 0.8, 0.7, 0.1, -0.2, 1.2, 0.0, 0.0]);
    assert_eq!(m.body_names(), ["crank", "rod", "slider"]);
}

#[test]
fn revolute_four_bar() {
    let m = model("four_bar.adm");
    insta::assert_snapshot!("four_bar", to_kin(&m));
    // `{}` in forces is no element.
    assert_eq!(m.forces.len(), 1);
    assert_eq!(m.gravity, [0.0, 0.0]);
}

#[test]
fn translational_joint() {
    let m = model("translational.adm");
    insta::assert_snapshot!("translational", to_kin(&m));
    let ConstraintKind::Translational { vp1, vp2, .. } = m.constraints[3].kind else {
        panic!("not translational");
    };
    // The model keeps the vectors as written; the emitter normalises them.
    assert_eq!((vp1, vp2), ([2.0, 0.0], [3.0, 4.0]));
    assert!(to_kin(&m).contains("(1, 0), block(-0.2, 0), (0.6, 0.8))"));
}

#[test]
fn rack_pinion() {
    let m = model("rack_pinion.adm");
    insta::assert_snapshot!("rack_pinion", to_kin(&m));
    let counts = check_kinematic(&m, &Analysis::default()).unwrap();
    assert_eq!((counts.n, counts.m), (6, 6));
}

#[test]
fn names_are_identifiers_and_unique() {
    let text = r#"{ "name": "names",
      "bodies": [
        { "name": "Long Rod", "id": 1, "q0": [0, 0, 0] },
        { "name": "Long-Rod", "id": 2, "q0": [0, 0, 0] },
        { "name": "ground", "id": 3, "q0": [0, 0, 0] } ],
      "constraints": [
        { "name": "driver", "id": 1, "type": "AbsoluteAngle", "body1": 1, "fun": "t" },
        { "name": "Long Rod", "id": 2, "type": "AbsoluteAngle", "body1": 2, "fun": "0" },
        { "name": "g", "id": 3, "type": "RackPinion", "body1": 1, "body2": 3, "sP1": [0, 0],
          "sQ1": [1, 0], "sP2": [0, 0], "R2": 1, "theta1": 0, "theta2": 0, "fun": "NONE" },
        { "name": "g_1", "id": 4, "type": "AbsoluteAngle", "body1": 3, "fun": "0" } ] }"#;
    let m = Model::parse(&Source::new("names.adm", text)).unwrap();
    let names = kinema_adm::Names::of(&m);
    assert_eq!(names.mechanism, "Names");
    assert_eq!(names.bodies, ["Long_Rod", "Long_Rod_2", "ground_"]);
    assert_eq!(
        names.constraints,
        [vec!["driver"], vec!["Long_Rod_3"], vec!["g"], vec!["g_1"]]
    );
    let rows: Vec<(String, usize)> = names
        .rows(&m)
        .into_iter()
        .map(|r| (r.row, r.constraint))
        .collect();
    assert_eq!(
        rows,
        [
            ("driver".into(), 0),
            ("Long_Rod_3".into(), 1),
            // The engine's rolling row first: kinema's `.2`.
            ("g.2".into(), 2),
            ("g.1".into(), 2),
            ("g_1".into(), 3)
        ]
    );
    let crank = model("slider_crank.adm");
    let rows: Vec<String> = kinema_adm::Names::of(&crank)
        .rows(&crank)
        .into_iter()
        .map(|r| r.row)
        .collect();
    assert_eq!(
        rows,
        [
            "pivot_x",
            "pivot_y",
            "crank_rod.x",
            "crank_rod.y",
            "rod_slider.x",
            "rod_slider.y",
            "slider_on_axis",
            "slider_no_turn",
            "crank_angle"
        ]
    );
}

#[test]
fn constraint_ids_are_labels_with_a_warning() {
    let text = r#"{ "bodies": [ { "name": "a", "id": 1, "q0": [0, 0, 0] } ],
      "constraints": [ { "name": "x", "id": 7, "type": "AbsoluteX", "body1": 1, "sP1": [0, 0], "fun": "0" } ] }"#;
    let source = Source::new("ids.adm", text);
    let m = Model::parse(&source).unwrap();
    assert_eq!(m.name, "model");
    assert_eq!(m.gravity, [0.0, -9.81]);
    assert_eq!(m.warnings.len(), 1);
    insta::assert_snapshot!("id_warning", common::render(&source, m.warnings));
}

#[test]
fn crlf_line_endings() {
    let text = common::read("free_pendulum.adm").replace('\n', "\r\n");
    let m = Model::parse(&Source::new("crlf.adm", text.as_str())).unwrap();
    assert_eq!(m.constraints.len(), 2);
}

#[test]
fn analyses() {
    let a = Analysis::parse(&common::source("kinematics.acf")).unwrap();
    assert_eq!(a.output_times().len(), 41);
    assert_eq!(a.output_times()[1], 0.05);
    let p = Analysis::parse(&common::source("plain.acf")).unwrap();
    assert_eq!((p.tend, p.step_size, p.output_steps), (1.0, 0.005, 20));
    let d = Analysis::parse(&common::source("dynamics.acf")).unwrap();
    assert_eq!(d.simulation, kinema_adm::Simulation::Dynamics);
    assert_eq!(Analysis::read(&common::data("plain.acf")).unwrap(), p);
}
