//! The design picture of Figure 4 as an engineer reads it: the density image (black = solid)
//! with a scale bar, and the supports, the two PEA input nodes and the output marked where
//! the scenario puts them. Drawn as an SVG around the run's `density.png` (pixels kept
//! sharp), so the marks stay text and lines at any zoom.

use std::fmt::Write as _;

use flexstage_run::scenario::{Edge, Scenario, Selector};

use super::{base64, esc};

/// Width of the drawn image \[px of the SVG\].
const W: f64 = 800.0;
/// Height of the band below the image that holds the scale bar and the key.
const BAND: f64 = 56.0;
/// Text size \[px of the SVG\]: at the half-page width of the report (≈ 550 px) about 13 px.
const TEXT: f64 = 20.0;

/// A "nice" scale-bar length \[m\]: 1, 2 or 5 × 10ⁿ, about a fifth of the domain length.
pub(super) fn scale_length(length: f64) -> f64 {
    let target = length / 5.0;
    let decade = 10f64.powf(target.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|m| m * decade)
        .find(|&v| v <= target)
        .unwrap_or(decade)
}

/// The annotated picture: the PNG `png` of the design domain of `s` with its marks.
pub(super) fn svg(png: &[u8], s: &Scenario) -> String {
    let (l, w) = (s.mesh.length, s.mesh.width);
    let h = W * w / l;
    let px = |p: [f64; 2]| (p[0] / l * W, (w - p[1]) / w * h);
    let mut out = String::with_capacity(png.len() * 4 / 3 + 4096);
    let _ = write!(
        out,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"-30 -30 {:.0} {:.0}\" \
         font-family=\"sans-serif\" font-size=\"{TEXT}\">\
         <image x=\"0\" y=\"0\" width=\"{W}\" height=\"{h:.2}\" preserveAspectRatio=\"none\" \
         style=\"image-rendering:pixelated\" href=\"data:image/png;base64,{}\"/>\
         <rect x=\"0\" y=\"0\" width=\"{W}\" height=\"{h:.2}\" fill=\"none\" stroke=\"#99a\"/>",
        W + 60.0,
        h + BAND + 40.0,
        base64(png)
    );
    // A support drawn as a larger disk under a PEA at the same node stays visible as a ring.
    let mut mark = |at: &Selector, color: &str, r: f64| {
        let _ = match *at {
            Selector::Nearest { point } => {
                let (x, y) = px(point);
                write!(
                    out,
                    "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"{r}\" fill=\"{color}\" \
                     stroke=\"#fff\" stroke-width=\"2\"/>"
                )
            }
            Selector::Box { min, max } => {
                let (x0, y1) = px(min);
                let (x1, y0) = px(max);
                write!(
                    out,
                    "<rect x=\"{x0:.1}\" y=\"{y0:.1}\" width=\"{:.1}\" height=\"{:.1}\" \
                     fill=\"none\" stroke=\"{color}\" stroke-width=\"4\"/>",
                    (x1 - x0).max(4.0),
                    (y1 - y0).max(4.0)
                )
            }
            Selector::Edge { edge } => {
                let (a, b) = match edge {
                    Edge::Left => ([0.0, 0.0], [0.0, w]),
                    Edge::Right => ([l, 0.0], [l, w]),
                    Edge::Bottom => ([0.0, 0.0], [l, 0.0]),
                    Edge::Top => ([0.0, w], [l, w]),
                };
                let ((x0, y0), (x1, y1)) = (px(a), px(b));
                write!(
                    out,
                    "<line x1=\"{x0:.1}\" y1=\"{y0:.1}\" x2=\"{x1:.1}\" y2=\"{y1:.1}\" \
                     stroke=\"{color}\" stroke-width=\"6\"/>"
                )
            }
        };
    };
    for sup in &s.supports {
        mark(&sup.at, "#0072b2", 15.0);
    }
    mark(&s.actuators.pea1, "#d55e00", 9.0);
    mark(&s.actuators.pea2, "#d55e00", 9.0);
    mark(&s.output.at, "#009e73", 9.0);
    // Labels beside the point marks (inside the domain, white halo for legibility).
    let mut label = |at: &Selector, text: &str| {
        let p = match *at {
            Selector::Nearest { point } => point,
            Selector::Box { min, max } => [0.5 * (min[0] + max[0]), 0.5 * (min[1] + max[1])],
            Selector::Edge { .. } => return,
        };
        let (x, y) = px(p);
        let (anchor, dx) = if x > 0.5 * W {
            ("end", -14.0)
        } else {
            ("start", 14.0)
        };
        let _ = write!(
            out,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"{anchor}\" dominant-baseline=\"middle\" \
             stroke=\"#fff\" stroke-width=\"5\" paint-order=\"stroke\" fill=\"#1b2a41\">{}</text>",
            x + dx,
            y,
            esc(text)
        );
    };
    label(&s.actuators.pea1, "PEA1");
    label(&s.actuators.pea2, "PEA2");
    label(&s.output.at, "output");
    // Scale bar and key below the image.
    let bar = scale_length(l);
    let y = h + 30.0;
    let _ = write!(
        out,
        "<line x1=\"0\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"#1b2a41\" \
         stroke-width=\"5\"/><text x=\"{:.1}\" y=\"{y:.1}\" dominant-baseline=\"middle\" \
         fill=\"#1b2a41\">{:.0} mm</text>\
         <circle cx=\"{:.1}\" cy=\"{y:.1}\" r=\"9\" fill=\"#0072b2\"/>\
         <text x=\"{:.1}\" y=\"{y:.1}\" dominant-baseline=\"middle\">support</text>\
         <circle cx=\"{:.1}\" cy=\"{y:.1}\" r=\"9\" fill=\"#d55e00\"/>\
         <text x=\"{:.1}\" y=\"{y:.1}\" dominant-baseline=\"middle\">PEA input</text>\
         <circle cx=\"{:.1}\" cy=\"{y:.1}\" r=\"9\" fill=\"#009e73\"/>\
         <text x=\"{:.1}\" y=\"{y:.1}\" dominant-baseline=\"middle\">output</text></svg>",
        bar / l * W,
        bar / l * W + 12.0,
        bar * 1e3,
        W * 0.40,
        W * 0.40 + 16.0,
        W * 0.58,
        W * 0.58 + 16.0,
        W * 0.80,
        W * 0.80 + 16.0,
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scale_bar_is_a_round_fifth_of_the_domain() {
        assert!((scale_length(0.12) - 0.02).abs() < 1e-15);
        assert!((scale_length(0.06) - 0.01).abs() < 1e-15);
        assert!((scale_length(0.3) - 0.05).abs() < 1e-15);
    }

    #[test]
    fn the_picture_marks_supports_peas_and_output_with_a_scale() {
        let s = Scenario::paper();
        let svg = svg(&[137, 80, 78, 71], &s);
        assert!(super::super::page::inline_svg(&svg).is_some(), "inlinable");
        for text in [">PEA1<", ">PEA2<", ">output<", ">support<", " mm<"] {
            assert!(svg.contains(text), "missing {text}");
        }
        // One point mark per support, PEA and output, plus the key's three.
        let points = s.supports.len() + 3;
        assert!(svg.matches("<circle").count() >= 3, "{svg}");
        assert!(svg.matches("<circle").count() + svg.matches("<rect").count() >= points + 3);
    }
}
