//! Charts for `vlf sweep`, drawn with plotters into PNG (fonts embedded: no system fonts
//! needed): error against run time on log-log axes, both methods, the Pareto front marked;
//! and error per frame for the walkthrough.

use crate::error::{Result, VlfError};
use plotters::prelude::*;
use std::path::Path;

fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

fn plot_err(path: &Path, e: impl std::fmt::Display) -> VlfError {
    VlfError::Image {
        path: path.to_path_buf(),
        message: format!("cannot draw the chart: {e}"),
    }
}

/// One series of (time, error) points.
pub struct Series<'a> {
    pub name: &'a str,
    pub color: RGBColor,
    pub points: Vec<(f64, f64)>,
}

/// Points not dominated by another (no other point is both faster and more accurate),
/// sorted by time.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut sorted: Vec<(f64, f64)> = points.to_vec();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for p in sorted {
        if p.1 < best {
            best = p.1;
            front.push(p);
        }
    }
    front
}

/// Tick labels with at most three significant digits.
fn tick(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return "0".into();
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    if v.abs() < 1e-3 || v.abs() >= 1e5 {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    }
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold((f64::INFINITY, 0.0f64), |(l, h), v| (l.min(v), h.max(v)));
    if lo > hi {
        return (1e-3, 1.0);
    }
    (lo / 1.5, hi * 1.5)
}

type LogChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<LogCoord<f64>, LogCoord<f64>>>;

/// Log-log axes fitted to the series' points, described and ticked, with every series drawn as
/// dots of `dot` pixels and entered in the legend; returns the chart and its x range.
fn log_log_scatter<'a, DB: DrawingBackend + 'a>(
    area: &'a DrawingArea<DB, plotters::coord::Shift>,
    path: &Path,
    caption: Option<&str>,
    x_desc: &str,
    y_desc: &str,
    series: &[Series],
    dot: u32,
) -> Result<(LogChart<'a, DB>, (f64, f64))> {
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .collect();
    let (x0, x1) = range(all.iter().map(|p| p.0));
    let (y0, y1) = range(all.iter().map(|p| p.1));
    let mut builder = ChartBuilder::on(area);
    if let Some(c) = caption {
        builder.caption(c, ("sans-serif", 24));
    }
    let mut chart = builder
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| plot_err(path, e))?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .max_light_lines(1)
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| plot_err(path, e))?;
    for s in series {
        let color = s.color;
        chart
            .draw_series(
                s.points
                    .iter()
                    .filter(|p| p.0 > 0.0 && p.1 > 0.0)
                    .map(move |p| Circle::new(*p, dot, color.filled())),
            )
            .map_err(|e| plot_err(path, e))?
            .label(s.name)
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
    }
    Ok((chart, (x0, x1)))
}

/// Error against time, log-log, with the Pareto front over all series.
pub fn error_vs_time(path: &Path, title: &str, y_label: &str, series: &[Series]) -> Result<()> {
    register_font();
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .collect();
    let root = BitMapBackend::new(path, (1000, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
    let x_desc = "time (s): propagation + one frame for the light field, the whole image for the path tracer";
    let (mut chart, _) = log_log_scatter(&root, path, Some(title), x_desc, y_label, series, 5)?;
    let front = pareto_front(&all);
    chart
        .draw_series(LineSeries::new(front.clone(), BLACK.stroke_width(2)))
        .map_err(|e| plot_err(path, e))?
        .label("Pareto front (both methods)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    chart
        .draw_series(
            front
                .iter()
                .map(|p| Circle::new(*p, 8, BLACK.stroke_width(2))),
        )
        .map_err(|e| plot_err(path, e))?;
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()
        .map_err(|e| plot_err(path, e))?;
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}

/// Error per frame of a walkthrough, one line per method.
pub fn error_per_frame(path: &Path, title: &str, y_label: &str, series: &[Series]) -> Result<()> {
    register_font();
    let frames = series
        .iter()
        .map(|s| s.points.len())
        .max()
        .unwrap_or(1)
        .max(2) as f64;
    let (y0, y1) = range(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 24))
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..frames - 1.0, (y0..y1).log_scale())
        .map_err(|e| plot_err(path, e))?;
    chart
        .configure_mesh()
        .x_desc("frame")
        .y_desc(y_label)
        .y_label_formatter(&|v| tick(*v))
        .max_light_lines(1)
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| plot_err(path, e))?;
    for s in series {
        let color = s.color;
        chart
            .draw_series(LineSeries::new(s.points.clone(), color.stroke_width(2)))
            .map_err(|e| plot_err(path, e))?
            .label(s.name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()
        .map_err(|e| plot_err(path, e))?;
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}

/// One log-log panel: axis descriptions, series, and optionally a fitted slope drawn as a line
/// through the series' centre.
pub type Panel<'a> = (&'a str, &'a str, Vec<Series<'a>>, Option<f64>);

/// Two log-log panels side by side (the benchmark suite's scaling chart).
pub fn log_log(path: &Path, title: &str, panels: [Panel; 2]) -> Result<()> {
    register_font();
    let root = BitMapBackend::new(path, (1400, 620)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| plot_err(path, e))?;
    let root = root
        .titled(title, ("sans-serif", 24))
        .map_err(|e| plot_err(path, e))?;
    let areas = root.split_evenly((1, 2));
    for (area, (x_desc, y_desc, series, slope)) in areas.iter().zip(panels) {
        let (mut chart, (x0, x1)) = log_log_scatter(area, path, None, x_desc, y_desc, &series, 6)?;
        // the fit belongs to the first series
        let fitted: Vec<(f64, f64)> = series
            .first()
            .map(|s| {
                s.points
                    .iter()
                    .copied()
                    .filter(|p| p.0 > 0.0 && p.1 > 0.0)
                    .collect()
            })
            .unwrap_or_default();
        if let (Some(k), false) = (slope, fitted.is_empty()) {
            let n = fitted.len() as f64;
            let (mx, my) = (
                fitted.iter().map(|p| p.0.ln()).sum::<f64>() / n,
                fitted.iter().map(|p| p.1.ln()).sum::<f64>() / n,
            );
            let line: Vec<(f64, f64)> = [x0, x1]
                .iter()
                .map(|&x| (x, (my + k * (x.ln() - mx)).exp()))
                .collect();
            chart
                .draw_series(LineSeries::new(line, BLACK.stroke_width(2)))
                .map_err(|e| plot_err(path, e))?
                .label(format!("fitted slope {k:.2}"))
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .label_font(("sans-serif", 16))
            .draw()
            .map_err(|e| plot_err(path, e))?;
    }
    root.present().map_err(|e| plot_err(path, e))?;
    Ok(())
}
