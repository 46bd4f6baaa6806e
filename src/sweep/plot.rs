//! A sweep's plots: for one metric, its mean against the first axis with 95 % confidence
//! bars, one line per combination of the other axes' values (SVG, drawn with plotters).

use plotters::prelude::*;

/// A point of a line: the index of the first axis' value, the mean, the 95 % interval.
pub type Point = (usize, f64, Option<(f64, f64)>);

/// One line of a plot: a combination of the other axes' values and its points.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// `path=value, ...` of the other axes; empty with a single axis.
    pub label: String,
    pub points: Vec<Point>,
}

/// The SVG text of the plot of `metric` (in `unit`) against the axis `x_name` whose values
/// are `x_values` (RON text: numbers are placed at their value, anything else in order).
pub fn svg(
    metric: &str,
    unit: &str,
    x_name: &str,
    x_values: &[String],
    lines: &[Line],
) -> Result<String, String> {
    let numbers: Option<Vec<f64>> = x_values.iter().map(|v| v.trim().parse().ok()).collect();
    let xs: Vec<f64> = match &numbers {
        Some(v) => v.clone(),
        None => (0..x_values.len()).map(|i| i as f64).collect(),
    };
    let (mut x0, mut x1) = bounds(xs.iter().copied());
    let pad = if x1 > x0 { (x1 - x0) * 0.05 } else { 0.5 };
    (x0, x1) = (x0 - pad, x1 + pad);
    let ys = lines.iter().flat_map(|l| {
        l.points.iter().flat_map(|(_, m, ci)| {
            let (lo, hi) = ci.unwrap_or((*m, *m));
            [lo, hi, *m]
        })
    });
    let (mut y0, mut y1) = bounds(ys.filter(|v| v.is_finite()));
    if y1.partial_cmp(&y0) != Some(std::cmp::Ordering::Greater) {
        (y0, y1) = (y0 - 1.0, y1 + 1.0);
    }
    let pad = (y1 - y0) * 0.08;
    (y0, y1) = (y0 - pad, y1 + pad);
    let mut out = String::new();
    {
        // The legend gets its own strip under the plot, so it never covers data.
        let labelled: Vec<(usize, &Line)> = lines
            .iter()
            .enumerate()
            .filter(|(_, l)| !l.label.is_empty())
            .collect();
        let legend_height = if labelled.is_empty() {
            0
        } else {
            12 + 20 * labelled.len() as u32
        };
        let root =
            SVGBackend::with_string(&mut out, (800, 480 + legend_height)).into_drawing_area();
        let e = |e: &dyn std::fmt::Display| e.to_string();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let (top, bottom) = root.split_vertically(480);
        let mut chart = ChartBuilder::on(&top)
            .caption(format!("{metric}: mean and 95 % CI"), ("sans-serif", 22))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|x| e(&x))?;
        let categories = numbers.is_none();
        let label_of = |x: &f64| -> String {
            if categories {
                let i = x.round();
                if (x - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < x_values.len() {
                    x_values[i as usize].clone()
                } else {
                    String::new()
                }
            } else {
                format!("{x}")
            }
        };
        chart
            .configure_mesh()
            .x_desc(x_name)
            .y_desc(unit)
            .x_labels(x_values.len().clamp(2, 12))
            .x_label_formatter(&label_of)
            .bold_line_style(BLACK.mix(0.15))
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(|x| e(&x))?;
        for (k, line) in lines.iter().enumerate() {
            let colour = Palette99::pick(k).to_rgba();
            let at = |i: usize| xs[i];
            chart
                .draw_series(LineSeries::new(
                    line.points.iter().map(|(i, m, _)| (at(*i), *m)),
                    colour.stroke_width(2),
                ))
                .map_err(|x| e(&x))?;
            chart
                .draw_series(
                    line.points
                        .iter()
                        .map(|(i, m, _)| Circle::new((at(*i), *m), 3, colour.filled())),
                )
                .map_err(|x| e(&x))?;
            chart
                .draw_series(line.points.iter().filter_map(|(i, m, ci)| {
                    ci.map(|(lo, hi)| {
                        ErrorBar::new_vertical(at(*i), lo, *m, hi, colour.stroke_width(1), 8)
                    })
                }))
                .map_err(|x| e(&x))?;
        }
        for (row, (k, line)) in labelled.iter().enumerate() {
            let colour = Palette99::pick(*k).to_rgba();
            let y = 6 + 20 * row as i32;
            bottom
                .draw(&PathElement::new(
                    vec![(92, y + 8), (122, y + 8)],
                    colour.stroke_width(2),
                ))
                .map_err(|x| e(&x))?;
            bottom
                .draw(&Text::new(
                    line.label.clone(),
                    (130, y),
                    ("sans-serif", 15).into_font(),
                ))
                .map_err(|x| e(&x))?;
        }
        root.present().map_err(|x| e(&x))?;
    }
    Ok(out)
}

fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if lo.is_finite() {
        (lo, hi)
    } else {
        (0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_lines_with_bars_and_a_legend() {
        let lines = [
            Line {
                label: "network.lambda=1.0".into(),
                points: vec![(0, 2.0, Some((1.0, 3.0))), (1, 4.0, Some((3.5, 4.5)))],
            },
            Line {
                label: "network.lambda=10.0".into(),
                points: vec![(0, 1.0, None), (1, 1.5, Some((1.0, 2.0)))],
            },
        ];
        let x = ["50".to_string(), "100".to_string()];
        let svg = svg("collisions", "collisions", "robots[0].count", &x, &lines).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..80]);
        assert!(svg.contains("network.lambda=10.0") && svg.contains("robots[0].count"));
        // Deterministic: the same data, the same bytes.
        assert_eq!(
            svg,
            super::svg("collisions", "collisions", "robots[0].count", &x, &lines).unwrap()
        );
        // Categories (not numbers) are labelled by their text.
        let cats = ["Reliable(delay: 1.0)".to_string(), "Lossy".to_string()];
        let svg = super::svg("events", "events", "network", &cats, &lines[..1]).unwrap();
        assert!(svg.contains("Lossy"), "categorical labels");
    }
}
