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
        // One panel per metric and one for the legend.
        let panels = result.metrics.len() + 1;
        let cols = 2;
        let rows = panels.div_ceil(cols);
        let size = (PANEL.0 * cols as u32, PANEL.1 * rows as u32 + 50);
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let root = root
            .titled(result.title, ("sans-serif", 26).into_font().color(&BLACK))
            .map_err(|e| e.to_string())?;
        let areas = root.split_evenly((rows, cols));
        let times = time_range(result);
        for (metric, area) in result.metrics.iter().zip(areas.iter()) {
            draw_panel(area, result, metric, times)?;
        }
        draw_legend(&areas[result.metrics.len()], result)?;
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

/// Ticks of a log axis over `[lo, hi]`: 1, 2 and 5 times the powers of ten inside
/// it, or every whole multiple when that gives fewer than three.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let ticks = |mantissas: &[f64]| -> Vec<f64> {
        let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        (k0..=k1)
            .flat_map(|k| mantissas.iter().map(move |m| m * 10f64.powi(k)))
            .filter(|v| (lo..=hi).contains(v))
            .collect()
    };
    let coarse = ticks(&[1.0, 2.0, 5.0]);
    if coarse.len() >= 3 {
        coarse
    } else {
        ticks(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
    }
}

/// Tick label of a log axis value: only whole multiples of a power of ten are labelled
/// (plain decimals where short, else `1e-3` style); the axes ask for few labels, so
/// they do not overlap.
fn tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    let mantissa = a / 10f64.powf(a.log10().floor());
    if (mantissa - mantissa.round()).abs() > 1e-6 * mantissa {
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
        .build_cartesian_2d(
            (t0..t1).log_scale().with_key_points(log_ticks(t0, t1)),
            (y0..y1).log_scale().with_key_points(log_ticks(y0, y1)),
        )
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
            .draw_series(points.iter().enumerate().map(|(k, &(t, e, label))| {
                // Labels alternate above and below the curve, so neighbours do not overlap.
                let offset = if k % 2 == 0 { (6, -17) } else { (6, 5) };
                EmptyElement::at((t, e))
                    + Circle::new((0, 0), 4, colour.filled())
                    + Text::new(label.to_string(), offset, ("sans-serif", 12).into_font().color(&colour))
            }))
            .map_err(err)?;
    }
    Ok(())
}

/// The legend in its own panel: a coloured line and the series name per row, then
/// how to read the labels.
fn draw_legend(area: &DrawingArea<SVGBackend, Shift>, result: &KnobResult) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<_>| e.to_string();
    let font = ("sans-serif", 17).into_font().color(&BLACK);
    let (x0, mut y) = (60, 50);
    for (i, series) in result.series.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        area.draw(&PathElement::new(vec![(x0, y), (x0 + 40, y)], colour.stroke_width(4)))
            .map_err(err)?;
        area.draw(&Circle::new((x0 + 20, y), 5, colour.filled())).map_err(err)?;
        area.draw(&Text::new(series.name.clone(), (x0 + 55, y - 9), font.clone()))
            .map_err(err)?;
        y += 32;
    }
    let note = ("sans-serif", 15).into_font().color(&RGBColor(70, 70, 70));
    y += 16;
    for line in [
        format!("Point labels: {}.", result.knob),
        "Lower left is better: less error for less time.".to_string(),
    ] {
        for chunk in wrap(&line, 70) {
            area.draw(&Text::new(chunk, (x0, y), note.clone())).map_err(err)?;
            y += 22;
        }
    }
    Ok(())
}

/// Splits `text` into lines of at most about `width` characters at spaces.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = vec![String::new()];
    for word in text.split(' ') {
        let last = lines.last_mut().expect("one line");
        if !last.is_empty() && last.chars().count() + 1 + word.chars().count() > width {
            lines.push(word.to_string());
        } else {
            if !last.is_empty() {
                last.push(' ');
            }
            last.push_str(word);
        }
    }
    lines
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
        assert_eq!(tick(0.003), "0.003");
        assert_eq!(tick(0.0035), "");
    }

    #[test]
    fn log_ticks_are_round_and_inside() {
        assert_eq!(log_ticks(0.15, 30.0), [0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0]);
        let fine = log_ticks(0.12, 0.45);
        assert_eq!(fine.len(), 3);
        assert!((fine[0] - 0.2).abs() < 1e-12 && (fine[2] - 0.4).abs() < 1e-12);
    }

    #[test]
    fn wrapping_keeps_every_word() {
        let lines = wrap("one two three four", 9);
        assert_eq!(lines, ["one two", "three", "four"]);
    }

    #[test]
    fn padding_leaves_room_and_survives_no_values() {
        assert_eq!(padded([0.0, -1.0].into_iter()), (0.1, 10.0));
        let (lo, hi) = padded([1.0, 4.0].into_iter());
        assert!(lo < 1.0 && hi > 4.0);
    }
}
