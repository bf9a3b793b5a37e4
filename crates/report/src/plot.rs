//! Line and scatter figures as SVG, drawn with `plotters`.
//!
//! SVG opens in every browser and embeds directly in the HTML report. Text is measured with a
//! bundled DejaVu Sans font (`assets/`), so plotting needs no system fonts.

use std::sync::Once;

use plotters::prelude::*;

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

/// One data series of a [`Figure`].
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label (empty: no legend entry).
    pub label: String,
    /// The (x, y) points.
    pub points: Vec<(f64, f64)>,
    /// How it is drawn.
    pub style: Style,
}

impl Series {
    /// A polyline.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            label: label.into(),
            points,
            style: Style::Line,
        }
    }

    /// A closed polygon.
    pub fn closed(label: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            label: label.into(),
            points,
            style: Style::Closed,
        }
    }

    /// Markers.
    pub fn points(label: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            label: label.into(),
            points,
            style: Style::Points,
        }
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
    /// Size in pixels.
    pub size: (u32, u32),
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
const PALETTE: [RGBColor; 7] = [
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

    /// The data range (x0, x1, y0, y1), padded by 5 %.
    fn range(&self) -> Option<(f64, f64, f64, f64)> {
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
        if !any {
            return None;
        }
        let pad = |a: f64, b: f64| {
            let d = if b > a {
                0.05 * (b - a)
            } else {
                a.abs().max(1.0) * 0.05
            };
            (a - d, b + d)
        };
        let (mut x0, mut x1) = pad(x0, x1);
        let (mut y0, mut y1) = pad(y0, y1);
        if self.equal_aspect {
            let (w, h) = (self.size.0 as f64 - 110.0, self.size.1 as f64 - 90.0);
            let scale = ((x1 - x0) / w).max((y1 - y0) / h);
            let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
            x0 = cx - 0.5 * scale * w;
            x1 = cx + 0.5 * scale * w;
            y0 = cy - 0.5 * scale * h;
            y1 = cy + 0.5 * scale * h;
        }
        Some((x0, x1, y0, y1))
    }

    /// Renders the figure as an SVG document.
    pub fn to_svg(&self) -> Result<String, PlotError> {
        register_font();
        let (x0, x1, y0, y1) = self.range().ok_or_else(|| PlotError::Empty {
            title: self.title.clone(),
        })?;
        let mut svg = String::new();
        let draw_err = |e: &dyn std::fmt::Display| PlotError::Draw {
            title: self.title.clone(),
            message: e.to_string(),
        };
        {
            let root = SVGBackend::with_string(&mut svg, self.size).into_drawing_area();
            root.fill(&WHITE).map_err(|e| draw_err(&e))?;
            let mut chart = ChartBuilder::on(&root)
                .caption(&self.title, ("sans-serif", 20))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| draw_err(&e))?;
            chart
                .configure_mesh()
                .x_desc(&self.x_label)
                .y_desc(&self.y_label)
                .light_line_style(RGBColor(235, 235, 235))
                .draw()
                .map_err(|e| draw_err(&e))?;
            for (i, s) in self.series.iter().enumerate() {
                let color = PALETTE[i % PALETTE.len()];
                let pts: Vec<(f64, f64)> = s
                    .points
                    .iter()
                    .copied()
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .collect();
                let anno = match s.style {
                    Style::Line | Style::Closed => {
                        let mut pts = pts;
                        if s.style == Style::Closed && !pts.is_empty() {
                            pts.push(pts[0]);
                        }
                        chart
                            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
                            .map_err(|e| draw_err(&e))?
                    }
                    Style::Points => chart
                        .draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))
                        .map_err(|e| draw_err(&e))?,
                };
                if !s.label.is_empty() {
                    anno.label(s.label.clone()).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                    });
                }
            }
            if self.series.iter().any(|s| !s.label.is_empty()) {
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .position(SeriesLabelPosition::UpperRight)
                    .draw()
                    .map_err(|e| draw_err(&e))?;
            }
            root.present().map_err(|e| draw_err(&e))?;
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
    }
}
