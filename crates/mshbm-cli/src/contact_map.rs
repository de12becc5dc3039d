//! The contact state along an interface over one period, as a user of a finite-element
//! model reads it: a long-format CSV (one row per contact and time sample) and a picture.
//! For an interface along a line, a space–time map (position along the interface × time
//! over the period, coloured by the contact force and by the gap); for an interface that
//! spans a face (its nodes vary along two axes), a map over the face of the fraction of the
//! period each node is in contact and of its largest contact force.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use mshbm::model::ContactInterface;
use mshbm::solution::{ContactState, PeriodicSolution};
use mshbm::Model;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;

use crate::plot::render_to_file;

/// The interfaces of `model`, or, for a model without any, one interface holding every
/// contact with its index as position.
pub fn interfaces(model: &Model) -> Vec<ContactInterface> {
    if !model.interfaces.is_empty() {
        return model.interfaces.clone();
    }
    let n = model.contacts.len();
    vec![ContactInterface {
        name: "contacts".into(),
        contacts: 0..n,
        positions: (0..n).map(|k| k as f64).collect(),
        nodes: model
            .contacts
            .iter()
            .map(|c| vec![c.dofs[0] / model.dofs_per_node])
            .collect(),
    }]
}

/// `interface,contact,nodes,position,time_s,gap,force`: one row per contact and time
/// sample (nodes separated by `;` for node-to-node contacts, by their labels in the mesh or
/// matrix file when the model has them, `Model::node_label`); with friction on the
/// contacts also `state,tangential_force,limit` (`open`, `stick` or `slip`; the friction
/// force and its bound `μ λ_N`); on a 3D interface with friction (the Coulomb cone)
/// `tangential_force` is along the first tangent and `tangential_force_2` along the second.
pub fn contacts_csv(model: &Model, s: &PeriodicSolution) -> String {
    let friction = frictional_contacts(s);
    let cone = friction && s.frictions.iter().all(|f| f.force2.len() == f.force.len());
    let mut out = String::from("interface,contact,nodes,position,time_s,gap,force");
    if friction {
        out.push_str(",state,tangential_force,limit");
    }
    if cone {
        out.push_str(",tangential_force_2");
    }
    out.push('\n');
    for i in interfaces(model) {
        for (k, c) in i.contacts.clone().enumerate() {
            let series = &s.contacts[c];
            let nodes: Vec<String> = i.nodes[k]
                .iter()
                .map(|&p| model.node_label(p).to_string())
                .collect();
            for (j, t) in s.time_s.iter().enumerate() {
                let _ = write!(
                    out,
                    "{},{c},{},{:.12e},{t:.12e},{:.12e},{:.12e}",
                    i.name,
                    nodes.join(";"),
                    i.positions[k],
                    series.gap[j],
                    series.force[j]
                );
                if friction {
                    let f = &s.frictions[c];
                    let _ = write!(
                        out,
                        ",{},{:.12e},{:.12e}",
                        f.state[j].name(),
                        f.force[j],
                        f.limit[j]
                    );
                    if cone {
                        let _ = write!(out, ",{:.12e}", f.force2[j]);
                    }
                }
                out.push('\n');
            }
        }
    }
    out
}

/// The solution's friction series are its contacts' (contacts with friction).
fn frictional_contacts(s: &PeriodicSolution) -> bool {
    !s.contacts.is_empty()
        && s.frictions.len() == s.contacts.len()
        && s.frictions.iter().all(|f| f.state.len() == s.time_s.len())
}

/// One panel of the map: `values[contact][sample]` over the positions and the period.
struct Panel<'a> {
    title: String,
    positions: &'a [f64],
    values: Vec<Vec<f64>>,
}

impl Panel<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let (map, bar) = area.split_horizontally(area.dim_in_pixel().0 - 130);
        // cell edges halfway between neighbouring positions (a uniform width for one)
        let order: Vec<usize> = {
            let mut o: Vec<usize> = (0..self.positions.len()).collect();
            o.sort_by(|&a, &b| self.positions[a].total_cmp(&self.positions[b]));
            o
        };
        let p: Vec<f64> = order.iter().map(|&k| self.positions[k]).collect();
        let half = |k: usize| -> f64 {
            if p.len() < 2 {
                0.5
            } else if k + 1 < p.len() {
                0.5 * (p[k + 1] - p[k])
            } else {
                0.5 * (p[k] - p[k - 1])
            }
        };
        let edges: Vec<(f64, f64)> = (0..p.len())
            .map(|k| {
                (
                    p[k] - if k == 0 { half(0) } else { half(k - 1) },
                    p[k] + half(k),
                )
            })
            .collect();
        let (lo, hi) = self
            .values
            .iter()
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(*v), h.max(*v))
            });
        let (lo, hi) = if hi > lo {
            (lo, hi)
        } else {
            (lo - 0.5, lo + 0.5)
        };
        let x_range = edges.first().map_or(0.0, |e| e.0)..edges.last().map_or(1.0, |e| e.1);
        let mut chart = ChartBuilder::on(&map)
            .caption(crate::output::one_line(&self.title), ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(x_range, 0.0..1.0)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .label_style(("sans-serif", 14))
            .x_desc("position along the interface")
            .y_desc("time / period")
            .draw()?;
        let samples = self.values.first().map_or(0, Vec::len);
        for (slot, &k) in order.iter().enumerate() {
            let (x0, x1) = edges[slot];
            for j in 0..samples {
                let (t0, t1) = (j as f64 / samples as f64, (j + 1) as f64 / samples as f64);
                let c = ViridisRGB.get_color_normalized(self.values[k][j], lo, hi);
                chart.draw_series(std::iter::once(Rectangle::new(
                    [(x0, t0), (x1, t1)],
                    c.filled(),
                )))?;
            }
        }
        colour_bar(&bar, lo, hi)
    }
}

/// The two axes along which the (first) nodes of `interface` spread most, in coordinate
/// order, when it spans a face: the second spread is more than 1e-6 of the first.
pub fn face_axes(model: &Model, interface: &ContactInterface) -> Option<(usize, usize)> {
    let d = model.coordinates.first().map_or(0, Vec::len);
    let spread = |a: usize| {
        let (lo, hi) = interface
            .nodes
            .iter()
            .map(|n| model.coordinates[n[0]][a])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
                (l.min(x), h.max(x))
            });
        hi - lo
    };
    let mut axes: Vec<(usize, f64)> = (0..d).map(|a| (a, spread(a))).collect();
    axes.sort_by(|a, b| b.1.total_cmp(&a.1));
    match axes[..] {
        // in the order of the coordinates (x across, then y, then z)
        [(a, sa), (b, sb), ..] if sb > 1e-6 * sa => Some((a.min(b), a.max(b))),
        _ => None,
    }
}

/// One panel of a face map: a value per node over the face's two axes.
struct FacePanel {
    title: String,
    axis_names: (String, String),
    x: Vec<f64>,
    y: Vec<f64>,
    values: Vec<f64>,
}

/// Half the smallest distance between distinct values of `v` (the cells of a structured
/// face); 0.5 when all values are equal.
fn half_spacing(v: &[f64]) -> f64 {
    let mut u = v.to_vec();
    u.sort_by(f64::total_cmp);
    let scale = u.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-300);
    let d = u
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|&d| d > 1e-9 * scale)
        .fold(f64::INFINITY, f64::min);
    if d.is_finite() {
        0.5 * d
    } else {
        0.5
    }
}

impl FacePanel {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let (map, bar) = area.split_horizontally(area.dim_in_pixel().0 - 130);
        let (hx, hy) = (half_spacing(&self.x), half_spacing(&self.y));
        let range = |v: &[f64], h: f64| {
            let (lo, hi) = v
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, u), &x| {
                    (l.min(x), u.max(x))
                });
            (lo - h)..(hi + h)
        };
        let (lo, hi) = self
            .values
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                (l.min(*v), h.max(*v))
            });
        let (lo, hi) = if hi > lo { (lo, hi) } else { (lo, lo + 1.0) };
        let mut chart = ChartBuilder::on(&map)
            .caption(crate::output::one_line(&self.title), ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(range(&self.x, hx), range(&self.y, hy))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .label_style(("sans-serif", 14))
            .x_desc(crate::output::one_line(&self.axis_names.0))
            .y_desc(crate::output::one_line(&self.axis_names.1))
            .draw()?;
        chart.draw_series(
            self.x
                .iter()
                .zip(&self.y)
                .zip(&self.values)
                .map(|((&x, &y), &v)| {
                    Rectangle::new(
                        [(x - hx, y - hy), (x + hx, y + hy)],
                        ViridisRGB.get_color_normalized(v, lo, hi).filled(),
                    )
                }),
        )?;
        colour_bar(&bar, lo, hi)
    }
}

/// A vertical colour bar from `lo` to `hi`.
fn colour_bar<DB: DrawingBackend>(bar: &DrawingArea<DB, Shift>, lo: f64, hi: f64) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let mut scale = ChartBuilder::on(bar)
        .margin_top(45)
        .margin_bottom(50)
        .margin_right(20)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..1.0, lo..hi)?;
    scale
        .configure_mesh()
        .disable_mesh()
        .x_labels(0)
        .y_labels(6)
        .label_style(("sans-serif", 14))
        .y_label_formatter(&|v| format!("{v:.2e}"))
        .draw()?;
    let steps = 64;
    for s in 0..steps {
        let (a, b) = (
            lo + (hi - lo) * s as f64 / steps as f64,
            lo + (hi - lo) * (s + 1) as f64 / steps as f64,
        );
        let c = ViridisRGB.get_color_normalized(0.5 * (a + b), lo, hi);
        scale.draw_series(std::iter::once(Rectangle::new(
            [(0.0, a), (1.0, b)],
            c.filled(),
        )))?;
    }
    Ok(())
}

/// A frequency for a title: at most four decimals, no trailing rounding noise.
fn hz_label(hz: f64) -> String {
    format!("{}", (hz * 1e4).round() / 1e4)
}

/// A panel of either kind.
enum AnyPanel<'a> {
    SpaceTime(Panel<'a>),
    Face(FacePanel),
}

/// The contact map of every interface of `model` for the solution `s`, panels stacked: for
/// an interface along a line a space–time panel of the contact force and one of the gap;
/// for an interface over a face a face panel of the fraction of the period each node is in
/// contact and one of its largest contact force. `.svg` or `.png` by extension.
pub fn save_contact_map(model: &Model, s: &PeriodicSolution, path: &Path) -> Result<()> {
    let interfaces = interfaces(model);
    let mut panels = Vec::new();
    for i in &interfaces {
        let series: Vec<_> = i.contacts.clone().map(|c| &s.contacts[c]).collect();
        if let Some((a, b)) = face_axes(model, i) {
            let coordinate = |axis: usize| -> Vec<f64> {
                i.nodes
                    .iter()
                    .map(|n| model.coordinates[n[0]][axis])
                    .collect()
            };
            let name = |axis: usize| ["x", "y", "z"].get(axis).unwrap_or(&"?").to_string();
            let fraction: Vec<f64> = series
                .iter()
                .map(|c| {
                    let closed = c.force.iter().filter(|&&f| f > 0.0).count();
                    closed as f64 / c.force.len().max(1) as f64
                })
                .collect();
            let largest: Vec<f64> = series
                .iter()
                .map(|c| c.force.iter().fold(0.0f64, |m, &f| m.max(f)))
                .collect();
            let titles = [
                format!(
                    "{}: fraction of the period in contact at {} Hz",
                    i.name,
                    hz_label(s.frequency_hz)
                ),
                format!("{}: largest contact force", i.name),
            ];
            for (title, values) in titles.into_iter().zip([fraction, largest]) {
                panels.push(AnyPanel::Face(FacePanel {
                    title,
                    axis_names: (name(a), name(b)),
                    x: coordinate(a),
                    y: coordinate(b),
                    values,
                }));
            }
            continue;
        }
        panels.push(AnyPanel::SpaceTime(Panel {
            title: format!(
                "{}: contact force at {} Hz",
                i.name,
                hz_label(s.frequency_hz)
            ),
            positions: &i.positions,
            values: series.iter().map(|c| c.force.clone()).collect(),
        }));
        panels.push(AnyPanel::SpaceTime(Panel {
            title: format!("{}: gap", i.name),
            positions: &i.positions,
            values: series.iter().map(|c| c.gap.clone()).collect(),
        }));
        if frictional_contacts(s) {
            let frictions: Vec<_> = i.contacts.clone().map(|c| &s.frictions[c]).collect();
            panels.push(AnyPanel::SpaceTime(Panel {
                title: format!("{}: state (0 open, 1 stick, 2 slip)", i.name),
                positions: &i.positions,
                values: frictions
                    .iter()
                    .map(|f| {
                        f.state
                            .iter()
                            .map(|state| match state {
                                ContactState::Open => 0.0,
                                ContactState::Stick => 1.0,
                                ContactState::Slip => 2.0,
                            })
                            .collect()
                    })
                    .collect(),
            }));
            // in the cone (two tangents) the force's modulus
            let cone = frictions.iter().all(|f| f.force2.len() == f.force.len());
            panels.push(AnyPanel::SpaceTime(Panel {
                title: if cone {
                    format!("{}: tangential (friction) force, modulus", i.name)
                } else {
                    format!("{}: tangential (friction) force", i.name)
                },
                positions: &i.positions,
                values: frictions
                    .iter()
                    .map(|f| {
                        if cone {
                            f.force
                                .iter()
                                .zip(&f.force2)
                                .map(|(a, b)| a.hypot(*b))
                                .collect()
                        } else {
                            f.force.clone()
                        }
                    })
                    .collect(),
            }));
        }
    }
    let size = (1000, 420 * panels.len().max(1) as u32);
    render_to_file(path, size, |r| draw(r, &panels), |r| draw(r, &panels))
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, panels: &[AnyPanel<'_>]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    for (area, panel) in root
        .split_evenly((panels.len().max(1), 1))
        .iter()
        .zip(panels)
    {
        match panel {
            AnyPanel::SpaceTime(p) => p.draw(area)?,
            AnyPanel::Face(p) => p.draw(area)?,
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(text: &str) -> Model {
        mshbm::model::file::parse_model(text, Path::new("m.toml"), &[]).unwrap()
    }

    const SOLID: &str = "kind = \"solid\"\n[solid]\nyoung = 2.1e5\npoisson = 0.3\ndensity = 7.85e-9\nclamped = [\"x0\"]\n";

    /// A line of contacts (the lower face of a 2D cantilever near its tip) is drawn as a
    /// space–time map; a patch of a 3D box's face as a face map over its two axes; a
    /// structured face's cells are half its node spacing wide.
    #[test]
    fn interfaces_over_a_face_are_told_from_lines() {
        let line = model(&format!(
            "{SOLID}dimension = 2\nsize = [100.0, 10.0]\ndivisions = [40, 4]\n\
             [[node_sets]]\nname = \"stop\"\nbox = [[88.0, 100.0], [0.0, 0.0]]\n\
             [[interfaces]]\nname = \"stop\"\nkind = \"obstacle\"\nset = \"stop\"\nnormal = [0.0, 1.0]\ngap = 0.05\n"
        ));
        assert_eq!(face_axes(&line, &line.interfaces[0]), None);
        let face = model(&format!(
            "{SOLID}dimension = 3\nsize = [10.0, 20.0, 4.0]\ndivisions = [10, 10, 4]\n\
             [[node_sets]]\nname = \"patch\"\nbox = [[2.0, 8.0], [2.0, 18.0], [0.0, 0.0]]\n\
             [[interfaces]]\nname = \"f\"\nkind = \"obstacle\"\nset = \"patch\"\nnormal = [0.0, 0.0, 1.0]\ngap = 0.01\n"
        ));
        assert_eq!(face_axes(&face, &face.interfaces[0]), Some((0, 1)));
        assert_eq!(half_spacing(&[2.0, 4.0, 2.0, 6.0, 4.0]), 1.0);
        assert_eq!(half_spacing(&[3.0, 3.0]), 0.5);
    }
}
