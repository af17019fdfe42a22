//! Log-log SVG charts of an error against render time or samples per
//! pixel, one labelled curve per method, drawn with plotters.

use std::path::Path;

use super::files::write_text;
use super::metrics::ErrorMetric;
use super::{LabError, Result};

/// The x axis of a [`write_chart`]: what it shows, in the title, and its
/// unit, under the axis.
pub(crate) struct ChartAxis {
    /// The quantity, e.g. "render time".
    pub quantity: &'static str,
    /// Its unit, e.g. "seconds".
    pub unit: &'static str,
}

/// Render time in seconds: the x axis of the equal-time charts.
pub(crate) const TIME_AXIS: ChartAxis = ChartAxis {
    quantity: "render time",
    unit: "seconds",
};

/// Samples per pixel: the x axis of charts against spp.
pub(crate) const SPP_AXIS: ChartAxis = ChartAxis {
    quantity: "samples per pixel",
    unit: "spp",
};

/// Writes (atomically) a log-log SVG chart of the error against `x`
/// (seconds, in the equal-time benchmarks) to `path`: one line with its
/// measured points per labelled curve of (x, error) points, drawn with
/// plotters' SVG backend (decade ticks and labels, a legend). Only curves
/// are drawn with stroke width 2, so `stroke-width="2"` polylines count them.
pub(crate) fn write_chart(
    path: &Path,
    title: &str,
    x_axis: &ChartAxis,
    metric: ErrorMetric,
    curves: &[(String, Vec<(f64, f64)>)],
) -> Result<()> {
    let svg = svg_chart(title, x_axis, metric, curves)
        .map_err(|e| LabError::Failed(format!("cannot draw chart {}: {e}", path.display())))?;
    write_text(path, &svg)
}

/// The chart of [`write_chart`] as SVG text.
fn svg_chart(
    title: &str,
    x_axis: &ChartAxis,
    metric: ErrorMetric,
    curves: &[(String, Vec<(f64, f64)>)],
) -> Result<String, Box<dyn std::error::Error>> {
    use plotters::prelude::*;
    /// Dark2 (ColorBrewer), one colour per curve.
    const COLOURS: [RGBColor; 8] = [
        RGBColor(0x1b, 0x9e, 0x77),
        RGBColor(0xd9, 0x5f, 0x02),
        RGBColor(0x75, 0x70, 0xb3),
        RGBColor(0xe7, 0x29, 0x8a),
        RGBColor(0x66, 0xa6, 0x1e),
        RGBColor(0xe6, 0xab, 0x02),
        RGBColor(0xa6, 0x76, 0x1d),
        RGBColor(0x66, 0x66, 0x66),
    ];
    let positive = |&(x, y): &(f64, f64)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite();
    let points = || {
        curves
            .iter()
            .flat_map(|(_, c)| c.iter().copied())
            .filter(positive)
    };
    let range = |values: Vec<f64>| {
        let lo = values.iter().copied().fold(f64::MAX, f64::min);
        let hi = values.iter().copied().fold(f64::MIN, f64::max);
        if lo > hi {
            return 0.1..1.0;
        }
        // A little room around the data, and never an empty range.
        lo / 1.25..(hi * 1.25).max(lo * 1.5)
    };
    let xs = range(points().map(|(x, _)| x).collect());
    let ys = range(points().map(|(_, y)| y).collect());
    let metric = metric.name();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (640, 420)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{title}: {metric} vs {} (log-log)", x_axis.quantity),
                ("sans-serif", 16),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(xs.log_scale(), ys.log_scale())?;
        chart
            .configure_mesh()
            .x_desc(x_axis.unit)
            .y_desc(metric)
            .x_label_formatter(&|x| format!("{x:.3}"))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .label_style(("sans-serif", 12))
            .draw()?;
        for (i, (label, curve)) in curves.iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            let curve: Vec<(f64, f64)> = curve.iter().copied().filter(positive).collect();
            chart
                .draw_series(LineSeries::new(
                    curve.iter().copied(),
                    colour.stroke_width(2),
                ))?
                .label(label.as_str())
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 4), (x + 16, y + 4)], colour.filled())
                });
            chart.draw_series(curve.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 12))
            .draw()?;
        root.present()?;
    }
    Ok(svg)
}
