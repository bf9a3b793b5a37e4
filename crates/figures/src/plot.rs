//! Line and scatter figures as SVG, drawn with `plotters`.
//!
//! SVG opens in every browser and embeds directly in the HTML report. Text is measured with a
//! bundled DejaVu Sans font (`assets/`), so plotting needs no system fonts.
//!
//! **Readable at 100 % zoom.** Every text of a figure is at least [`MIN_TEXT_PX`] pixels
//! high at the figure's own size (tick labels and legend 13.7 px, axis names 14.5 px, title
//! 17.7 px; plotters writes `font-size` = size / 1.24), so a figure shown at its own width or
//! wider never has text below 11 px.
//!
//! **Small files.** Long series are reduced for display once the pixel geometry is known
//! ([`crate::simplify`]): time series to the M4 envelope of each pixel column, curves in the
//! plane by Douglas–Peucker with a tolerance of [`SIMPLIFY_PX`] pixel, markers to one per pixel
//! cell. The data files beside a figure keep every sample; the figure keeps every peak.
//!
//! [`Multiples`] draws several figures as panels of one SVG (small multiples, e.g. one
//! controller per panel on shared axes).

use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::simplify;

/// Smallest text of a figure at its own size \[px\] (tick labels and legend).
pub const MIN_TEXT_PX: f64 = TICK_SIZE / SVG_FONT_SCALE;
/// Tolerance of the Douglas–Peucker reduction of curves \[px\].
pub const SIMPLIFY_PX: f64 = 0.4;

/// plotters' SVG backend writes `font-size` = text size / 1.24.
const SVG_FONT_SCALE: f64 = 1.24;
const TITLE_SIZE: f64 = 22.0;
const AXIS_NAME_SIZE: f64 = 18.0;
const TICK_SIZE: f64 = 17.0;
const MARGIN: u32 = 14;
const X_LABEL_AREA: u32 = 58;
const Y_LABEL_AREA: u32 = 96;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// A polyline through the points.
    Line,
    /// A closed polygon outline (last point joined to the first).
    Closed,
    /// Markers only.
    Points,
}

/// Where the legend sits inside the plot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Legend {
    /// Upper right corner (default).
    UpperRight,
    /// Upper left corner.
    UpperLeft,
    /// Lower right corner.
    LowerRight,
    /// Lower left corner.
    LowerLeft,
    /// No legend.
    Hidden,
}

/// One data series of a [`Figure`].
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label (empty: no legend entry).
    pub label: String,
    /// The (x, y) points.
    pub points: Vec<(f64, f64)>,
    /// How it is drawn.
    pub style: Style,
    /// Palette colour index; `None`: the series' position in the figure.
    pub color: Option<usize>,
}

impl Series {
    fn new(label: impl Into<String>, points: Vec<(f64, f64)>, style: Style) -> Series {
        Series {
            label: label.into(),
            points,
            style,
            color: None,
        }
    }

    /// A polyline.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series::new(label, points, Style::Line)
    }

    /// A closed polygon.
    pub fn closed(label: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series::new(label, points, Style::Closed)
    }

    /// Markers.
    pub fn points(label: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series::new(label, points, Style::Points)
    }

    /// Draws the series in palette colour `index` (so one quantity keeps its colour across
    /// figures and panels).
    pub fn with_color(mut self, index: usize) -> Series {
        self.color = Some(index);
        self
    }
}

/// A 2D figure with axes, labels and a legend.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Title above the plot.
    pub title: String,
    /// x-axis label (with unit).
    pub x_label: String,
    /// y-axis label (with unit).
    pub y_label: String,
    /// The data.
    pub series: Vec<Series>,
    /// Use the same scale on both axes (for geometry: workspaces, trajectories).
    pub equal_aspect: bool,
    /// Size in pixels (when drawn on its own).
    pub size: (u32, u32),
    /// Axis ranges (x0, x1, y0, y1); `None`: the data range padded by 5 %.
    pub range: Option<(f64, f64, f64, f64)>,
    /// Legend placement.
    pub legend: Legend,
}

/// Errors of the figure writer.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// No finite point to plot.
    #[error("figure {title:?} has no finite data point")]
    Empty {
        /// The figure title.
        title: String,
    },
    /// The drawing backend failed.
    #[error("drawing figure {title:?} failed: {message}")]
    Draw {
        /// The figure title.
        title: String,
        /// The backend's message.
        message: String,
    },
}

/// Colours used for successive series (colour-blind-safe Okabe–Ito palette).
pub const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
    RGBColor(86, 180, 233),
    RGBColor(0, 0, 0),
];

static FONT: Once = Once::new();

fn register_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../assets/DejaVuSans.ttf");
        // The bundled font is valid; registration cannot fail for it.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, bytes);
    });
}

fn font(size: f64) -> TextStyle<'static> {
    TextStyle::from(("sans-serif", size).into_font())
}

/// Pads a data interval by 5 % (a point by 5 % of its magnitude, at least 0.05).
fn pad(a: f64, b: f64) -> (f64, f64) {
    let d = if b > a {
        0.05 * (b - a)
    } else {
        a.abs().max(1.0) * 0.05
    };
    (a - d, b + d)
}

impl Figure {
    /// A figure with no series yet.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        Figure {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            equal_aspect: false,
            size: (800, 500),
            range: None,
            legend: Legend::UpperRight,
        }
    }

    /// Adds a series.
    pub fn with(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// Uses the same scale on both axes.
    pub fn equal_aspect(mut self) -> Self {
        self.equal_aspect = true;
        self
    }

    /// Fixes the axis ranges (e.g. shared by the panels of [`Multiples`]).
    pub fn with_range(mut self, x: (f64, f64), y: (f64, f64)) -> Self {
        self.range = Some((x.0, x.1, y.0, y.1));
        self
    }

    /// Places the legend.
    pub fn with_legend(mut self, legend: Legend) -> Self {
        self.legend = legend;
        self
    }

    /// Sets the size in pixels.
    pub fn with_size(mut self, width: u32, height: u32) -> Self {
        self.size = (width, height);
        self
    }

    /// The finite data range (x0, x1, y0, y1), unpadded.
    pub fn data_range(&self) -> Option<(f64, f64, f64, f64)> {
        let finite = self
            .series
            .iter()
            .flat_map(|s| s.points.iter())
            .filter(|(x, y)| x.is_finite() && y.is_finite());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        let mut any = false;
        for &(x, y) in finite {
            any = true;
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        any.then_some((x0, x1, y0, y1))
    }

    /// The axis ranges on a drawing area of `size` pixels: the fixed range, or the data
    /// range padded by 5 %, widened on one axis for equal scales.
    fn range(&self, size: (u32, u32)) -> Option<(f64, f64, f64, f64)> {
        let (mut x0, mut x1, mut y0, mut y1) = match self.range {
            Some(r) => r,
            None => {
                let (x0, x1, y0, y1) = self.data_range()?;
                let (x0, x1) = pad(x0, x1);
                let (y0, y1) = pad(y0, y1);
                (x0, x1, y0, y1)
            }
        };
        if self.equal_aspect {
            let (w, h) = plot_area(size);
            let scale = ((x1 - x0) / w).max((y1 - y0) / h);
            let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
            x0 = cx - 0.5 * scale * w;
            x1 = cx + 0.5 * scale * w;
            y0 = cy - 0.5 * scale * h;
            y1 = cy + 0.5 * scale * h;
        }
        Some((x0, x1, y0, y1))
    }

    /// Renders the figure as an SVG document of [`Figure::size`].
    pub fn to_svg(&self) -> Result<String, PlotError> {
        register_font();
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, self.size).into_drawing_area();
            root.fill(&WHITE).map_err(|e| self.draw_err(&e))?;
            self.draw_on(&root)?;
            root.present().map_err(|e| self.draw_err(&e))?;
        }
        Ok(svg)
    }

    fn draw_err(&self, e: &dyn std::fmt::Display) -> PlotError {
        PlotError::Draw {
            title: self.title.clone(),
            message: e.to_string(),
        }
    }

    /// Draws the figure on a drawing area (the whole SVG, or one panel of [`Multiples`]).
    fn draw_on(&self, area: &DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), PlotError> {
        let size = area.dim_in_pixel();
        let (x0, x1, y0, y1) = self.range(size).ok_or_else(|| PlotError::Empty {
            title: self.title.clone(),
        })?;
        // Tick labels ≈ 80 px apart along x (wide numbers like "-60.0" must not touch in a
        // narrow panel) and 50 px along y; 3 to 8 of them.
        let x_ticks = ((size.0.saturating_sub(Y_LABEL_AREA) / 80) as usize).clamp(3, 8);
        let y_ticks = ((size.1.saturating_sub(X_LABEL_AREA) / 50) as usize).clamp(3, 8);
        let mut chart = ChartBuilder::on(area)
            .caption(&self.title, font(TITLE_SIZE))
            .margin(MARGIN)
            .x_label_area_size(X_LABEL_AREA)
            .y_label_area_size(Y_LABEL_AREA)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| self.draw_err(&e))?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .label_style(font(TICK_SIZE))
            .axis_desc_style(font(AXIS_NAME_SIZE))
            .x_labels(x_ticks)
            .y_labels(y_ticks)
            .max_light_lines(2)
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(215, 215, 215))
            .draw()
            .map_err(|e| self.draw_err(&e))?;
        let (px, py) = chart.plotting_area().get_pixel_range();
        let to_pixels = Pixels {
            x0,
            y1,
            sx: f64::from(px.end - px.start) / (x1 - x0),
            sy: f64::from(py.end - py.start) / (y1 - y0),
        };
        for (i, s) in self.series.iter().enumerate() {
            let color = PALETTE[s.color.unwrap_or(i) % PALETTE.len()];
            let pts = to_pixels.reduce(s);
            let anno = match s.style {
                Style::Line | Style::Closed => chart
                    .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                    .map_err(|e| self.draw_err(&e))?,
                Style::Points => chart
                    .draw_series(pts.into_iter().map(|p| Circle::new(p, 2, color.filled())))
                    .map_err(|e| self.draw_err(&e))?,
            };
            if !s.label.is_empty() {
                anno.label(s.label.clone()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 22, y)], color.stroke_width(3))
                });
            }
        }
        let position = match self.legend {
            Legend::UpperRight => SeriesLabelPosition::UpperRight,
            Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
            Legend::LowerRight => SeriesLabelPosition::LowerRight,
            Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
            Legend::Hidden => return Ok(()),
        };
        if self.series.iter().any(|s| !s.label.is_empty()) {
            chart
                .configure_series_labels()
                .label_font(font(TICK_SIZE))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(120, 120, 120))
                .position(position)
                .draw()
                .map_err(|e| self.draw_err(&e))?;
        }
        Ok(())
    }
}

/// The plotting area of a figure drawn on `size` pixels, approximately (for equal scales).
fn plot_area(size: (u32, u32)) -> (f64, f64) {
    let caption = TITLE_SIZE + 10.0;
    (
        (f64::from(size.0) - f64::from(2 * MARGIN + Y_LABEL_AREA)).max(1.0),
        (f64::from(size.1) - f64::from(2 * MARGIN + X_LABEL_AREA) - caption).max(1.0),
    )
}

/// The map from data to pixel coordinates of a plotting area (origin top left).
struct Pixels {
    x0: f64,
    y1: f64,
    sx: f64,
    sy: f64,
}

impl Pixels {
    /// The finite points of a series that are drawn at this scale ([`crate::simplify`]),
    /// in data coordinates; a closed series is closed.
    fn reduce(&self, s: &Series) -> Vec<(f64, f64)> {
        let mut data: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        if s.style == Style::Closed && !data.is_empty() {
            data.push(data[0]);
        }
        let px: Vec<(f64, f64)> = data
            .iter()
            .map(|&(x, y)| ((x - self.x0) * self.sx, (self.y1 - y) * self.sy))
            .collect();
        let keep = match s.style {
            Style::Points => simplify::distinct_cells(&px),
            Style::Line if simplify::is_monotone(&data) => simplify::m4(&px),
            _ => simplify::douglas_peucker(&px, SIMPLIFY_PX),
        };
        keep.into_iter().map(|k| data[k]).collect()
    }
}

/// Small multiples: figures drawn as panels of one SVG, `columns` per row, under a title.
#[derive(Debug, Clone)]
pub struct Multiples {
    /// Title above the panels.
    pub title: String,
    /// The panels, row by row.
    pub panels: Vec<Figure>,
    /// Panels per row (≥ 1).
    pub columns: usize,
    /// Size of one panel in pixels.
    pub panel_size: (u32, u32),
}

impl Multiples {
    /// Panels of `panel_size` pixels, `columns` per row.
    pub fn new(title: impl Into<String>, columns: usize, panel_size: (u32, u32)) -> Self {
        Multiples {
            title: title.into(),
            panels: Vec::new(),
            columns: columns.max(1),
            panel_size,
        }
    }

    /// Adds a panel.
    pub fn with(mut self, panel: Figure) -> Self {
        self.panels.push(panel);
        self
    }

    /// Renders every panel into one SVG document.
    pub fn to_svg(&self) -> Result<String, PlotError> {
        register_font();
        let err = |e: &dyn std::fmt::Display| PlotError::Draw {
            title: self.title.clone(),
            message: e.to_string(),
        };
        if self.panels.is_empty() {
            return Err(PlotError::Empty {
                title: self.title.clone(),
            });
        }
        let columns = self.columns.min(self.panels.len());
        let rows = self.panels.len().div_ceil(columns);
        let title_h = 40;
        let size = (
            self.panel_size.0 * columns as u32,
            self.panel_size.1 * rows as u32 + title_h,
        );
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let (head, body) = root.split_vertically(title_h);
            head.titled(&self.title, font(TITLE_SIZE + 2.0))
                .map_err(|e| err(&e))?;
            for (panel, area) in self.panels.iter().zip(body.split_evenly((rows, columns))) {
                panel.draw_on(&area)?;
            }
            root.present().map_err(|e| err(&e))?;
        }
        Ok(svg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_has_title_labels_and_one_path_per_line_series() {
        let fig = Figure::new("Loop", "U [V]", "x [µm]")
            .with(Series::line(
                "model",
                vec![(0.0, 0.0), (1.0, 1.0), (2.0, 0.5)],
            ))
            .with(Series::closed(
                "polygon",
                vec![(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)],
            ));
        let svg = fig.to_svg().unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..40]);
        for text in ["Loop", "U [V]", "x [µm]", "model", "polygon"] {
            assert!(svg.contains(text), "missing {text}");
        }
        assert!(svg.matches("<polyline").count() >= 2);
    }

    #[test]
    fn empty_figure_is_an_error() {
        let fig = Figure::new("t", "x", "y").with(Series::line("nan", vec![(f64::NAN, 0.0)]));
        assert!(matches!(fig.to_svg(), Err(PlotError::Empty { .. })));
        assert!(matches!(
            Multiples::new("m", 2, (400, 300)).to_svg(),
            Err(PlotError::Empty { .. })
        ));
    }

    /// Every `font-size` of an SVG document.
    fn font_sizes(svg: &str) -> Vec<f64> {
        svg.split("font-size=\"")
            .skip(1)
            .filter_map(|s| s.split('"').next()?.parse().ok())
            .collect()
    }

    #[test]
    fn every_text_is_at_least_min_text_px() {
        // Goal: the report needs text ≥ 11 px at 100 % zoom; at its own size every text of
        // a figure and of small multiples is ≥ MIN_TEXT_PX (13.7 px), so any display at
        // ≥ 80 % of that size keeps it ≥ 11 px.
        let fig = Figure::new("title", "x [s]", "y [nm]")
            .with(Series::line("a", vec![(0.0, 1.0), (1.0, 2.0)]))
            .with(Series::points("b", vec![(0.5, 1.5)]));
        let multiples = Multiples::new("panels", 2, (420, 380))
            .with(fig.clone())
            .with(fig.clone());
        for svg in [fig.to_svg().unwrap(), multiples.to_svg().unwrap()] {
            let sizes = font_sizes(&svg);
            assert!(sizes.len() > 8, "{sizes:?}");
            let min = sizes.iter().fold(f64::MAX, |m, &s| m.min(s));
            assert!(min >= MIN_TEXT_PX - 1e-9 && MIN_TEXT_PX > 13.0, "{min}");
        }
    }

    #[test]
    fn long_series_are_drawn_small_and_keep_their_peaks() {
        // Goal: a 10⁶-sample noisy time series (100 s at 10 kHz) and a 10⁵-sample noisy loop
        // become SVGs under 80 kB (all 10⁶ points would be > 10 MB), and the one-sample peak
        // of the time series still sets the top of the y axis range and is drawn.
        let n = 1_000_000;
        let mut s: u64 = 1;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut ts: Vec<(f64, f64)> = (0..n).map(|k| (k as f64 * 1e-4, 10.0 * rnd())).collect();
        ts[765_432].1 = 100.0;
        let fig = Figure::new("error", "t [s]", "e [nm]").with(Series::line("e", ts));
        let svg = fig.to_svg().unwrap();
        assert!(svg.len() < 80_000, "{} bytes", svg.len());
        let (_, _, _, y1) = fig.range(fig.size).unwrap();
        assert!((y1 - 105.0).abs() < 1.0, "peak sets the range: {y1}");
        let top = svg
            .split("points=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap()
            .split(' ')
            .filter_map(|p| p.split(',').nth(1)?.parse::<i32>().ok())
            .min()
            .unwrap();
        assert!(top < 60, "the peak is drawn near the top: y = {top} px");
        let lp: Vec<(f64, f64)> = (0..100_000)
            .map(|k| {
                let t = k as f64 * 1e-3;
                (
                    500.0 + 500.0 * t.sin(),
                    30.0 * (t + 0.2).sin() + 0.01 * rnd(),
                )
            })
            .collect();
        let svg = Figure::new("loop", "U", "x")
            .with(Series::line("x(U)", lp))
            .to_svg()
            .unwrap();
        assert!(svg.len() < 80_000, "{} bytes", svg.len());
    }
}
