//! Unit tests of the time grids.

use super::*;

#[test]
fn uniform_grid_ends_on_t_end() {
    let g = Grid::uniform(0.3, 3).expect("increasing");
    assert_eq!(g.times.len(), 4);
    assert_eq!(g.times.last().copied(), Some(0.3));
    assert!(g.output.iter().all(|&o| o));
}

#[test]
fn simengine_grid_marks_outputs() {
    let a = Analysis {
        tend: 1.0,
        step_size: 0.1,
        output_steps: 4,
        ..Analysis::default()
    };
    let g = Grid::simengine(&a, &String::new).expect("increasing");
    assert!(g.times.windows(2).all(|w| w[1] > w[0]));
    let outs: Vec<f64> = g
        .times
        .iter()
        .zip(&g.output)
        .filter(|(_, o)| **o)
        .map(|(t, _)| *t)
        .collect();
    assert_eq!(outs, a.output_times());
    assert!(g.times.len() > outs.len());
}
