//! The contact state along an interface over one period, as a user of a finite-element
//! model reads it: a long-format CSV (one row per contact and time sample) and a space–time
//! picture (position along the interface × time over the period, coloured by the contact
//! force and by the gap).

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use mshbm::model::ContactInterface;
use mshbm::solution::PeriodicSolution;
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
/// sample (nodes separated by `;` for node-to-node contacts).
pub fn contacts_csv(model: &Model, s: &PeriodicSolution) -> String {
    let mut out = String::from("interface,contact,nodes,position,time_s,gap,force\n");
    for i in interfaces(model) {
        for (k, c) in i.contacts.clone().enumerate() {
            let series = &s.contacts[c];
            let nodes: Vec<String> = i.nodes[k].iter().map(|p| p.to_string()).collect();
            for (j, t) in s.time_s.iter().enumerate() {
                let _ = writeln!(
                    out,
                    "{},{c},{},{:.12e},{t:.12e},{:.12e},{:.12e}",
                    i.name,
                    nodes.join(";"),
                    i.positions[k],
                    series.gap[j],
                    series.force[j]
                );
            }
        }
    }
    out
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
            .caption(&self.title, ("sans-serif", 20))
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
        // colour bar
        let mut scale = ChartBuilder::on(&bar)
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
}

/// The space–time map of every interface of `model` for the solution `s`: per interface a
/// panel of the contact force and one of the gap, stacked; `.svg` or `.png` by extension.
pub fn save_contact_map(model: &Model, s: &PeriodicSolution, path: &Path) -> Result<()> {
    let interfaces = interfaces(model);
    let mut panels = Vec::new();
    for i in &interfaces {
        let series: Vec<_> = i.contacts.clone().map(|c| &s.contacts[c]).collect();
        panels.push(Panel {
            title: format!("{}: contact force at {} Hz", i.name, s.frequency_hz),
            positions: &i.positions,
            values: series.iter().map(|c| c.force.clone()).collect(),
        });
        panels.push(Panel {
            title: format!("{}: gap", i.name),
            positions: &i.positions,
            values: series.iter().map(|c| c.gap.clone()).collect(),
        });
    }
    let size = (1000, 420 * panels.len().max(1) as u32);
    render_to_file(path, size, |r| draw(r, &panels), |r| draw(r, &panels))
}

fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, panels: &[Panel<'_>]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    for (area, panel) in root
        .split_evenly((panels.len().max(1), 1))
        .iter()
        .zip(panels)
    {
        panel.draw(area)?;
    }
    Ok(())
}
