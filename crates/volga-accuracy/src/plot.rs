//! One SVG plot per knob: a panel per metric, error (log) against time (log), one
//! curve per series, each point labelled with its setting.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::{KnobResult, Metric};

/// Tableau-like colours, distinguishable in print and for common colour blindness.
const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(90, 90, 90),
];

const PANEL: (u32, u32) = (720, 480);

/// The SVG text of `result`'s plot.
pub fn plot_svg(result: &KnobResult) -> Result<String, String> {
    let mut svg = String::new();
    {
        let panels = result.metrics.len().max(1);
        let cols = panels.min(2);
        let rows = panels.div_ceil(cols);
        let size = (PANEL.0 * cols as u32, PANEL.1 * rows as u32 + 50);
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let root = root
            .titled(result.title, ("sans-serif", 26).into_font().color(&BLACK))
            .map_err(|e| e.to_string())?;
        let areas = root.split_evenly((rows, cols));
        let times = time_range(result);
        for (i, (metric, area)) in result.metrics.iter().zip(areas.iter()).enumerate() {
            draw_panel(area, result, metric, times, i == 0)?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

/// Padded log range of every positive time in the result.
fn time_range(result: &KnobResult) -> (f64, f64) {
    let times = result.series.iter().flat_map(|s| s.settings.iter().map(|p| p.time_s));
    padded(times)
}

/// `(min / 1.8, max · 1.8)` of the positive values (a factor so log axes leave room
/// for labels); `(0.1, 10)` if there are none.
fn padded(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    if lo.is_finite() {
        (lo / 1.8, hi * 1.8)
    } else {
        (0.1, 10.0)
    }
}

/// Tick label of a log axis value: only 1, 2 and 5 times a power of ten are labelled
/// (plain decimals where short, else `1e-3` style), so labels never overlap.
fn tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    let mantissa = a / 10f64.powf(a.log10().floor());
    if ![1.0, 2.0, 5.0, 10.0].iter().any(|m| (mantissa - m).abs() < 1e-6 * m) {
        return String::new();
    }
    if (1e-3..1e4).contains(&a) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

fn draw_panel(
    area: &DrawingArea<SVGBackend, Shift>,
    result: &KnobResult,
    metric: &Metric,
    (t0, t1): (f64, f64),
    legend: bool,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<_>| e.to_string();
    let values = result
        .series
        .iter()
        .flat_map(|s| s.settings.iter().filter_map(|p| p.errors.get(metric.id).copied()));
    let (y0, y1) = padded(values);
    let mut chart = ChartBuilder::on(area)
        .margin(14)
        .x_label_area_size(48)
        .y_label_area_size(80)
        .build_cartesian_2d((t0..t1).log_scale(), (y0..y1).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("wall time (s), log scale")
        .y_desc(metric.label)
        .axis_desc_style(("sans-serif", 15))
        .label_style(("sans-serif", 13))
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .light_line_style(WHITE)
        .bold_line_style(RGBColor(220, 220, 220))
        .draw()
        .map_err(err)?;
    for (i, series) in result.series.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        // Points with a positive error (a log axis cannot show 0; the table has it).
        let points: Vec<(f64, f64, &str)> = series
            .settings
            .iter()
            .filter_map(|p| {
                let e = *p.errors.get(metric.id)?;
                (e > 0.0 && e.is_finite() && p.time_s > 0.0).then_some((p.time_s, e, p.label.as_str()))
            })
            .collect();
        chart
            .draw_series(LineSeries::new(
                points.iter().map(|p| (p.0, p.1)),
                colour.stroke_width(2),
            ))
            .map_err(err)?
            .label(series.name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], colour.stroke_width(3)));
        chart
            .draw_series(points.iter().map(|&(t, e, label)| {
                EmptyElement::at((t, e))
                    + Circle::new((0, 0), 4, colour.filled())
                    + Text::new(
                        label.to_string(),
                        (6, -16),
                        ("sans-serif", 12).into_font().color(&colour),
                    )
            }))
            .map_err(err)?;
    }
    if legend {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 13))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .draw()
            .map_err(err)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_read_as_numbers() {
        assert_eq!(tick(0.5), "0.5");
        assert_eq!(tick(10.0), "10");
        assert_eq!(tick(0.0001), "1e-4");
        assert_eq!(tick(0.0), "0");
        assert_eq!(tick(0.002), "0.002");
        assert_eq!(tick(0.003), "");
    }

    #[test]
    fn padding_leaves_room_and_survives_no_values() {
        assert_eq!(padded([0.0, -1.0].into_iter()), (0.1, 10.0));
        let (lo, hi) = padded([1.0, 4.0].into_iter());
        assert!(lo < 1.0 && hi > 4.0);
    }
}
