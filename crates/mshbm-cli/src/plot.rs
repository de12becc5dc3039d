//! Line plots (SVG or PNG, chosen by the file extension) with an embedded font, so no
//! system font libraries are needed. Plots are rendered in memory and written atomically
//! through the output policy (`crate::output`).

use std::path::Path;
use std::sync::Once;

use anyhow::{anyhow, bail, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::output::{one_line as drawn, write_atomic, OutputKind};

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // The font is compiled in; failure would be a build defect.
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).ok();
    });
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    Line,
    Dashed,
    Markers,
    /// Unfilled circles (e.g. a value that is not a converged result).
    HollowMarkers,
    LineAndMarkers,
    /// Consecutive pairs of points joined by a thin line each (e.g. min–max bands drawn
    /// as vertical bars).
    Segments,
}

/// One curve.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub style: Style,
    /// Index into the palette (same index, same colour).
    pub color: usize,
}

/// A horizontal reference line (e.g. the gap).
#[derive(Clone, Debug)]
pub struct HLine {
    pub label: String,
    pub y: f64,
}

/// A 2-D line chart.
#[derive(Clone, Debug, Default)]
pub struct Figure {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    pub hlines: Vec<HLine>,
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

fn draw_panels<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, figures: &[Figure]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    for (panel, fig) in root
        .split_evenly((figures.len().max(1), 1))
        .iter()
        .zip(figures)
    {
        fig.draw(panel)?;
    }
    Ok(())
}

/// The image format of a plot path (by its extension), or an error naming the path.
fn format_of(path: &Path) -> Result<&'static str> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("svg") => Ok("svg"),
        Some("png") => Ok("png"),
        _ => bail!("{}: plot file must end in .svg or .png", path.display()),
    }
}

/// Encode an RGB buffer of `size` pixels as PNG.
fn encode_png(rgb: &[u8], size: (u32, u32)) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, size.0, size.1);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().context("cannot encode the PNG")?;
    writer
        .write_image_data(rgb)
        .context("cannot encode the PNG")?;
    writer.finish().context("cannot encode the PNG")?;
    Ok(bytes)
}

/// Render with `draw` in memory (an SVG text or a PNG image, by the extension of `path`)
/// and write the file atomically: a full disk never leaves a truncated plot behind.
pub(crate) fn render_to_file(
    path: &Path,
    size: (u32, u32),
    draw_svg: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<()>,
    draw_png: impl FnOnce(&DrawingArea<BitMapBackend, Shift>) -> Result<()>,
) -> Result<()> {
    register_font();
    let cannot = || format!("{}: cannot draw the plot", path.display());
    let bytes = match format_of(path)? {
        "svg" => {
            let mut text = String::new();
            {
                let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
                draw_svg(&root).with_context(cannot)?;
                root.present()
                    .map_err(|e| anyhow!("{e:?}"))
                    .with_context(cannot)?;
            }
            text.into_bytes()
        }
        _ => {
            let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
                draw_png(&root).with_context(cannot)?;
                root.present()
                    .map_err(|e| anyhow!("{e:?}"))
                    .with_context(cannot)?;
            }
            encode_png(&rgb, size).with_context(cannot)?
        }
    };
    write_atomic(path, &bytes, OutputKind::Plot)
}

impl Figure {
    /// Render to `path`; the format follows the extension (`.svg` or `.png`).
    pub fn save(&self, path: &Path) -> Result<()> {
        render_to_file(
            path,
            (1000, 650),
            |root| self.draw(root),
            |root| self.draw(root),
        )
    }

    /// Render several figures as panels stacked vertically (sharing nothing but the file),
    /// e.g. a gap and an energy history over the same time axis (the paper's Fig. 5).
    pub fn save_stacked(figures: &[Figure], path: &Path) -> Result<()> {
        let size = (1000, 420 * figures.len().max(1) as u32);
        render_to_file(
            path,
            size,
            |root| draw_panels(root, figures),
            |root| draw_panels(root, figures),
        )
    }

    fn bounds(&self) -> ((f64, f64), (f64, f64)) {
        let mut xs = (f64::INFINITY, f64::NEG_INFINITY);
        let mut ys = (f64::INFINITY, f64::NEG_INFINITY);
        for s in &self.series {
            for &(x, y) in &s.points {
                if x.is_finite() && y.is_finite() {
                    xs = (xs.0.min(x), xs.1.max(x));
                    ys = (ys.0.min(y), ys.1.max(y));
                }
            }
        }
        for h in &self.hlines {
            ys = (ys.0.min(h.y), ys.1.max(h.y));
        }
        let pad = |(lo, hi): (f64, f64), frac: f64| {
            if !lo.is_finite() {
                return (0.0, 1.0);
            }
            let span = if hi > lo {
                hi - lo
            } else {
                lo.abs().max(1.0) * 1e-3
            };
            (lo - frac * span, hi + frac * span)
        };
        (pad(xs, 0.0), pad(ys, 0.05))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow::anyhow!("drawing failed: {e:?}");
        root.fill(&WHITE).map_err(err)?;
        let ((x0, x1), (y0, y1)) = self.bounds();
        let mut chart = ChartBuilder::on(root)
            .caption(drawn(&self.title), ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(drawn(&self.x_label))
            .y_desc(drawn(&self.y_label))
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 17))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(err)?;
        for h in &self.hlines {
            let style = ShapeStyle::from(&BLACK).stroke_width(1);
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(x0, h.y), (x1, h.y)],
                    6,
                    4,
                    style,
                ))
                .map_err(err)?
                .label(drawn(&h.label))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
        }
        for s in &self.series {
            let c = color(s.color);
            let line = ShapeStyle::from(&c).stroke_width(2);
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .collect();
            let anno = match s.style {
                Style::Line | Style::LineAndMarkers => chart
                    .draw_series(LineSeries::new(pts.clone(), line))
                    .map_err(err)?,
                Style::Dashed => chart
                    .draw_series(DashedLineSeries::new(pts.clone(), 8, 5, line))
                    .map_err(err)?,
                Style::Markers => chart
                    .draw_series(
                        pts.iter()
                            .map(|&p| Circle::new(p, 4, ShapeStyle::from(&c).filled())),
                    )
                    .map_err(err)?,
                Style::HollowMarkers => chart
                    .draw_series(
                        pts.iter()
                            .map(|&p| Circle::new(p, 5, ShapeStyle::from(&c).stroke_width(2))),
                    )
                    .map_err(err)?,
                Style::Segments => chart
                    .draw_series(pts.chunks_exact(2).map(|pair| {
                        PathElement::new(pair.to_vec(), ShapeStyle::from(&c).stroke_width(3))
                    }))
                    .map_err(err)?,
            };
            if !s.label.is_empty() {
                anno.label(drawn(&s.label))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], line));
            }
            if s.style == Style::LineAndMarkers {
                chart
                    .draw_series(
                        pts.iter()
                            .map(|&p| Circle::new(p, 3, ShapeStyle::from(&c).filled())),
                    )
                    .map_err(err)?;
            }
        }
        if self.series.iter().any(|s| !s.label.is_empty()) || !self.hlines.is_empty() {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 15))
                .draw()
                .map_err(err)?;
        }
        Ok(())
    }
}
