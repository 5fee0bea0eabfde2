//! What a plot draws, read from the model: each body's joint points (the
//! body-fixed points its equations use), points fixed in ground, the driven
//! coordinates, the length unit, and simEngine2D drawing data when present.

use std::collections::BTreeMap;

use kinema::System;
use kinema::lang::{BodyRef, CheckedModel, LibKind, RowKind};

use super::load::Loaded;

/// A colour, components in 0..=1.
pub type Rgb = [f64; 3];

/// How one body is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyShape {
    /// The body's name.
    pub name: String,
    /// Distinct local points used by its equations, in order of use.
    pub points: Vec<[f64; 2]>,
    /// Rectangles from simEngine2D `vis.shapes`: centre and full size, body
    /// frame.
    pub rects: Vec<([f64; 2], [f64; 2])>,
    /// Colour from simEngine2D `vis.RGB`.
    pub color: Option<Rgb>,
}

/// A body-fixed point whose path and kinematics are plotted.
#[derive(Debug, Clone, PartialEq)]
pub struct Traced {
    /// Index of the body.
    pub body: usize,
    /// Local coordinates.
    pub local: [f64; 2],
    /// For legends: the first equation that uses it, or `body point k`.
    pub label: String,
}

/// A quantity a driver prescribes.
#[derive(Debug, Clone, PartialEq)]
pub enum Driven {
    /// A coordinate (`crank.phi`): its index in q.
    Coordinate(usize),
    /// The x (`component` 0) or y (1) of a body-fixed point (`abs_x`,
    /// `abs_y`).
    PointComponent {
        /// Index of the body.
        body: usize,
        /// Local coordinates.
        local: [f64; 2],
        /// 0 for x, 1 for y.
        component: usize,
        /// For legends.
        label: String,
    },
}

/// Everything a plot needs from the model.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// One per body, in declaration order.
    pub bodies: Vec<BodyShape>,
    /// Points fixed in ground that equations use (global coordinates).
    pub ground: Vec<[f64; 2]>,
    /// Joint points of moving bodies, deduplicated (a revolute joint's two
    /// points count once), then named points, then simEngine2D `vis.points`.
    pub traced: Vec<Traced>,
    /// What the drivers prescribe, in row order.
    pub driven: Vec<Driven>,
    /// Coordinate names.
    pub coordinates: Vec<String>,
    /// The length unit, if the model says (`[m]` in a param's doc comment).
    pub length_unit: Option<String>,
    /// simEngine2D `vis.xlim`, `vis.ylim`.
    pub limits: Option<([f64; 2], [f64; 2])>,
}

impl Scene {
    /// Reads the scene of a loaded model; `system` is its compiled system
    /// (for the pattern of Φ_q and the coordinate names).
    pub fn of<S: System>(loaded: &Loaded, system: &S) -> Scene {
        let c = &loaded.checked();
        let mut bodies: Vec<BodyShape> = c
            .bodies
            .iter()
            .map(|b| BodyShape {
                name: b.name.clone(),
                points: Vec::new(),
                rects: Vec::new(),
                color: None,
            })
            .collect();
        let mut ground: Vec<[f64; 2]> = Vec::new();
        let mut traced: Vec<Traced> = Vec::new();
        for (k, e) in c.equations.iter().enumerate() {
            let points = c.equation_points(k);
            // A revolute joint's two points are one physical point.
            let revolute = e.library == Some(LibKind::Revolute);
            let mut traced_one = false;
            for p in points {
                match p.body {
                    BodyRef::Ground => push_unique(&mut ground, p.local),
                    BodyRef::Body(i) => {
                        let i = i as usize;
                        if let Some(b) = bodies.get_mut(i) {
                            push_unique(&mut b.points, p.local);
                        }
                        let known = traced.iter().any(|t| t.body == i && t.local == p.local);
                        if !(known || (revolute && traced_one)) {
                            traced.push(Traced {
                                body: i,
                                local: p.local,
                                label: e.name.clone(),
                            });
                        }
                        traced_one = true;
                    }
                }
            }
        }
        // Named points (`point B.name`) are results: their paths are drawn
        // too. (An ADM model's are its `vis.points`, labelled below as the
        // engine did.)
        let named = if loaded.adm.is_some() {
            &[][..]
        } else {
            &c.points[..]
        };
        for p in named {
            let BodyRef::Body(i) = p.body else { continue };
            let i = i as usize;
            let known = traced
                .iter()
                .any(|t| t.body == i && t.local == p.local_value);
            if !known && p.local_value.iter().all(|v| v.is_finite()) {
                let body = c.bodies.get(i).map_or("body", |b| b.name.as_str());
                traced.push(Traced {
                    body: i,
                    local: p.local_value,
                    label: format!("{body}.{}", p.name),
                });
            }
        }
        let mut limits = None;
        if let Some(adm) = &loaded.adm {
            for (shape, body) in bodies.iter_mut().zip(&adm.model.bodies) {
                if let Some(vis) = &body.vis {
                    shape.color = vis.rgb;
                    shape.rects = vis.shapes.iter().map(|r| (r.loc, r.size)).collect();
                }
            }
            for (i, body) in adm.model.bodies.iter().enumerate() {
                let Some(vis) = &body.vis else { continue };
                for (k, &p) in vis.points.iter().enumerate() {
                    if !traced.iter().any(|t| t.body == i && t.local == p) {
                        let name = adm.names.bodies.get(i).map_or("body", String::as_str);
                        traced.push(Traced {
                            body: i,
                            local: p,
                            label: format!("{name} point {}", k + 1),
                        });
                    }
                }
            }
            if let Some(vis) = &adm.model.vis
                && let (Some(x), Some(y)) = (vis.xlim, vis.ylim)
                && x[1] > x[0]
                && y[1] > y[0]
            {
                limits = Some((x, y));
            }
        }
        Scene {
            bodies,
            ground,
            traced,
            driven: driven(loaded, system),
            coordinates: (0..system.len())
                .map(|i| system.coordinate_name(i).to_string())
                .collect(),
            length_unit: length_unit(c),
            limits,
        }
    }
}

fn push_unique(points: &mut Vec<[f64; 2]>, p: [f64; 2]) {
    if !points.contains(&p) {
        points.push(p);
    }
}

/// What each driving row prescribes: the one coordinate in its row of Φ_q;
/// for `abs_x`/`abs_y` of a body point, that point's x or y; otherwise the
/// coordinates its row involves.
fn driven<S: System>(loaded: &Loaded, system: &S) -> Vec<Driven> {
    let d = loaded.model.derivation();
    let mut columns: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for &(r, c) in system.jacobian_pattern() {
        columns.entry(r as usize).or_default().push(c as usize);
    }
    let mut out = Vec::new();
    for (r, row) in d.rows.iter().enumerate() {
        if row.kind != RowKind::Driving {
            continue;
        }
        let cols = columns.get(&r).cloned().unwrap_or_default();
        let component = match row.library {
            Some(LibKind::AbsX) => Some(0),
            Some(LibKind::AbsY) => Some(1),
            _ => None,
        };
        let equation = loaded
            .checked()
            .equations
            .iter()
            .position(|e| e.name == row.equation);
        let point = equation.and_then(|k| loaded.checked().equation_points(k).into_iter().next());
        let item = match (cols.as_slice(), component, point) {
            ([c], _, _) => vec![Driven::Coordinate(*c)],
            (_, Some(component), Some(p)) => match p.body {
                BodyRef::Body(i) => vec![Driven::PointComponent {
                    body: i as usize,
                    local: p.local,
                    component,
                    label: row.equation.clone(),
                }],
                BodyRef::Ground => Vec::new(),
            },
            _ => cols.iter().map(|&c| Driven::Coordinate(c)).collect(),
        };
        for i in item {
            if !out.contains(&i) {
                out.push(i);
            }
        }
    }
    out
}

/// The most common length unit in the params' doc comments (`/// crank
/// length [m]`), if any.
fn length_unit(c: &CheckedModel) -> Option<String> {
    const LENGTHS: &[&str] = &["m", "mm", "cm", "dm", "km", "in", "ft", "µm", "um"];
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    for doc in c.params.iter().flat_map(|p| &p.docs) {
        let mut rest = doc.as_str();
        while let Some(open) = rest.find('[') {
            let after = &rest[open + 1..];
            let Some(close) = after.find(']') else { break };
            let unit = after[..close].trim();
            if let Some(u) = LENGTHS.iter().find(|&&u| u == unit) {
                *counts.entry(u).or_default() += 1;
            }
            rest = &after[close + 1..];
        }
    }
    counts
        .into_iter()
        .max_by_key(|&(_, n)| n)
        .map(|(u, _)| u.to_string())
}
