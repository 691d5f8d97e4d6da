//! The SVG charts of every report (sweep, ablation, bench, depth): horizontal bars per
//! configuration, bars grouped per scene, lines over a power-of-two axis, histograms, and
//! scatters with labels placed so that they do not collide. Every element is drawn in the order
//! given, so the same data give the same file.

use std::path::Path;

use plotters::prelude::*;

use crate::error::{Error, Result};

const SIZE: (u32, u32) = (960, 600);

fn to_err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::io(path, std::io::Error::other(e.to_string()))
}

/// The axis range of `values` (and 0 unless `zoom`), padded by 8 %: with `zoom` only the
/// values' span (speed-ups near 1), otherwise from zero.
fn value_range(values: impl Iterator<Item = f64> + Clone, zoom: bool) -> (f64, f64) {
    let hi = values.clone().fold(0.0, f64::max).max(1e-9);
    let lo = if zoom { values.fold(hi, f64::min) } else { 0.0 };
    let pad = (hi - lo).max(hi * 1e-3) * 0.08;
    (if zoom { (lo - pad).max(0.0) } else { 0.0 }, hi + pad)
}

/// An axis description, saying where the axis starts when it does not start at zero (a zoomed
/// axis is a broken one).
fn axis_desc(desc: &str, start: f64) -> String {
    if start > 0.0 {
        format!("{desc} (axis broken: starts at {start:.2})")
    } else {
        desc.to_owned()
    }
}

type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;
type Chart2d<'a> = ChartContext<
    'a,
    SVGBackend<'a>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A white canvas of `size` pixels writing to `path`.
fn canvas(path: &Path, size: (u32, u32)) -> Result<Area<'_>> {
    let root = SVGBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| to_err(path, e))?;
    Ok(root)
}

/// The titled plot area of every chart here, `y_area` pixels of labels at the left.
fn chart_on<'a>(
    area: &Area<'a>,
    path: &Path,
    title: &str,
    y_area: u32,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
) -> Result<Chart2d<'a>> {
    ChartBuilder::on(area)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(y_area)
        .build_cartesian_2d(x, y)
        .map_err(|e| to_err(path, e))
}

/// Colour of series `i`, dark enough for thin lines.
/// Draws the series legend at `corner` and writes the file: the end of every chart here.
fn legend_and_present<'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, CT>,
    root: &DrawingArea<SVGBackend<'a>, plotters::coord::Shift>,
    corner: SeriesLabelPosition,
    path: &Path,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(corner)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| to_err(path, e))?;
    root.present().map_err(|e| to_err(path, e))
}

pub fn color(i: usize) -> RGBColor {
    OKABE_ITO[i % OKABE_ITO.len()]
}

/// Okabe and Ito's eight colours, told apart under every common colour-vision deficiency; the
/// yellow is darkened so thin lines stay visible on white.
const OKABE_ITO: [RGBColor; 8] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(213, 94, 0),
    RGBColor(86, 180, 233),
    RGBColor(204, 121, 167),
    RGBColor(160, 150, 30),
    RGBColor(0, 0, 0),
];

/// Colour of series `i` of `n`: the palette, and beyond its eight colours the same hues again in
/// a lighter and then a muted shade, so neighbouring series always differ in hue.
fn series_color(i: usize, n: usize) -> RGBColor {
    let RGBColor(r, g, b) = color(i);
    let round = if n <= OKABE_ITO.len() { 0 } else { i / OKABE_ITO.len() % 3 };
    let shade = |c: u8| match round {
        1 => c + (255 - c) / 2,
        2 => c / 2 + 60,
        _ => c,
    };
    RGBColor(shade(r), shade(g), shade(b))
}

/// The hue of each family of series ([`family_shades`]): Okabe and Ito's blue, orange, bluish
/// green, vermillion, sky blue, reddish purple, then again.
const FAMILY_HUES: [usize; 6] = [0, 1, 2, 3, 4, 5];

/// Colours for series that come in families (`family[i]`: series `i`'s, from 0): a hue per
/// family, and within a family shades from dark to light in series order, so a family reads as
/// one colour and neighbours always differ (in hue across families, in shade within one).
pub fn family_shades(family: &[usize]) -> Vec<RGBColor> {
    let size = |f: usize| family.iter().filter(|&&g| g == f).count();
    family
        .iter()
        .enumerate()
        .map(|(i, &f)| {
            let RGBColor(r, g, b) = color(FAMILY_HUES[f % FAMILY_HUES.len()]);
            let (rank, m) = (family[..i].iter().filter(|&&g| g == f).count(), size(f));
            // From 35 % darker to halfway to white.
            let t = if m < 2 { 0.0 } else { -0.35 + 0.85 * rank as f64 / (m - 1) as f64 };
            let shade = |c: u8| {
                let c = f64::from(c);
                (if t < 0.0 { c * (1.0 + t) } else { c + (255.0 - c) * t }).round() as u8
            };
            RGBColor(shade(r), shade(g), shade(b))
        })
        .collect()
}

/// Entry `k` of a legend drawn beside a plot: a swatch in `style` and `name`.
fn legend_entry(legend: &Area<'_>, path: &Path, k: usize, name: &str, style: ShapeStyle) -> Result<()> {
    let y = 50 + 18 * k as i32;
    legend.draw(&Rectangle::new([(8, y - 5), (22, y + 5)], style)).map_err(|e| to_err(path, e))?;
    legend.draw(&Text::new(name.to_string(), (28, y - 7), ("sans-serif", 12))).map_err(|e| to_err(path, e))
}

/// Label of the row at position `v` of a bar chart whose rows sit at integers.
fn row_label(labels: &[String], v: f64) -> String {
    let i = v.round();
    if (v - i).abs() > 1e-6 || i < 0.0 {
        return String::new();
    }
    labels.get(i as usize).cloned().unwrap_or_default()
}

/// One set of bars, one value per row (`None` leaves the row empty).
#[derive(Clone, Debug)]
pub struct Bars {
    pub name: String,
    pub values: Vec<Option<f64>>,
}

/// Horizontal bars, one row per label. Bar sets are drawn over each other in order, so for a
/// stacked look pass cumulative values with the largest first. `dots` are extra points drawn
/// as small circles over the bars (e.g. per-scene values behind a mean), `rule` a vertical line
/// (e.g. the baseline's 1.0). With `zoom` the axis spans only the values (speed-ups near 1),
/// otherwise it starts at zero.
#[allow(clippy::too_many_arguments)]
pub fn hbars(
    path: &Path,
    title: &str,
    x_desc: &str,
    labels: &[String],
    bars: &[Bars],
    dots: &[(usize, f64)],
    rule: Option<f64>,
    zoom: bool,
) -> Result<()> {
    let values = bars
        .iter()
        .flat_map(|b| b.values.iter().flatten())
        .chain(dots.iter().map(|d| &d.1))
        .chain(rule.as_ref());
    let (left, top) = value_range(values.copied(), zoom);
    let n = labels.len().max(1);
    let height = (SIZE.1).max(90 + 28 * n as u32);
    let root = canvas(path, (SIZE.0, height))?;
    let mut chart = chart_on(&root, path, title, 170, left..top, -0.5..n as f64 - 0.5)?;
    let label = |v: &f64| row_label(labels, *v);
    chart
        .configure_mesh()
        .x_desc(axis_desc(x_desc, left))
        .y_labels(4 * n)
        .y_label_formatter(&label)
        .disable_y_mesh()
        .draw()
        .map_err(|e| to_err(path, e))?;
    for (s, b) in bars.iter().enumerate() {
        let style = color(s).filled();
        let rects = b.values.iter().enumerate().filter_map(|(i, v)| {
            let y = i as f64;
            v.map(|v| Rectangle::new([(left, y - 0.35), (v, y + 0.35)], style))
        });
        chart
            .draw_series(rects)
            .map_err(|e| to_err(path, e))?
            .label(b.name.as_str())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], style));
    }
    if !dots.is_empty() {
        chart
            .draw_series(dots.iter().map(|&(i, v)| Circle::new((v, i as f64), 3, BLACK.filled())))
            .map_err(|e| to_err(path, e))?
            .label("per scene")
            .legend(|(x, y)| Circle::new((x + 7, y), 3, BLACK.filled()));
    }
    if let Some(r) = rule {
        chart
            .draw_series(LineSeries::new([(r, -0.5), (r, n as f64 - 0.5)], BLACK.stroke_width(1)))
            .map_err(|e| to_err(path, e))?;
    }
    legend_and_present(&mut chart, &root, SeriesLabelPosition::LowerRight, path)
}

/// Vertical bars grouped as the paper's figures are: one group per label along the x axis (e.g.
/// each scene, then the geomean), one bar per series in every group (e.g. each configuration),
/// the series in the legend, coloured by `colors` (one per series; empty: the palette in order).
/// `rule` is a horizontal line (e.g. the baseline's 1.0); with `zoom` the axis spans only the
/// values, otherwise it starts at zero.
#[allow(clippy::too_many_arguments)]
pub fn grouped_bars(
    path: &Path,
    title: &str,
    y_desc: &str,
    groups: &[String],
    series: &[Bars],
    colors: &[RGBColor],
    rule: Option<f64>,
    zoom: bool,
) -> Result<()> {
    let values = series.iter().flat_map(|b| b.values.iter().flatten()).chain(rule.as_ref());
    let (bottom, top) = value_range(values.copied(), zoom);
    // A zoomed axis says where it starts, beside the break mark drawn on it below.
    let y_desc = axis_desc(y_desc, bottom);
    let n = groups.len().max(1);
    let k = series.len().max(1);
    // Every bar at least 6 pixels wide, so a sweep of many scenes and configurations stays legible.
    const LEGEND_W: u32 = 190;
    let width = SIZE.0.max(LEGEND_W + 90 + (n * (k * 6 + 14)) as u32);
    let root = canvas(path, (width, SIZE.1))?;
    let (plot, legend) = root.split_horizontally(width - LEGEND_W);
    let mut chart = chart_on(&plot, path, title, 70, -0.5..n as f64 - 0.5, bottom..top)?;
    let label = |v: &f64| row_label(groups, *v);
    chart
        .configure_mesh()
        .y_desc(&y_desc)
        .x_labels(4 * n)
        .x_label_formatter(&label)
        .x_label_style(("sans-serif", 13))
        .disable_x_mesh()
        .draw()
        .map_err(|e| to_err(path, e))?;
    let slot = 0.8 / k as f64;
    for (s, b) in series.iter().enumerate() {
        let style = colors.get(s).copied().unwrap_or_else(|| series_color(s, k)).filled();
        let rects = b.values.iter().enumerate().filter_map(|(g, v)| {
            let x = g as f64 - 0.4 + slot * s as f64;
            v.map(|v| Rectangle::new([(x, bottom), (x + slot * 0.9, v)], style))
        });
        chart.draw_series(rects).map_err(|e| to_err(path, e))?;
        // The last group (the geomean) carries each bar's value, written upwards from its top.
        if let Some(Some(v)) = b.values.get(n - 1) {
            let x = (n - 1) as f64 - 0.4 + slot * (s as f64 + 0.45);
            let (px, py) = chart.backend_coord(&(x, *v));
            let font = ("sans-serif", 11).into_font().transform(FontTransform::Rotate270).color(&BLACK);
            plot.draw(&Text::new(format!("{v:.3}"), (px - 6, py - 4), font)).map_err(|e| to_err(path, e))?;
        }
        // The legend beside the plot, in series order (the order of the bars in every group).
        legend_entry(&legend, path, s, &b.name, style)?;
    }
    if let Some(r) = rule {
        chart
            .draw_series(LineSeries::new([(-0.5, r), (n as f64 - 0.5, r)], BLACK.stroke_width(1)))
            .map_err(|e| to_err(path, e))?;
    }
    if bottom > 0.0 {
        // Two slanted strokes across the foot of the y axis: the axis does not start at zero.
        let (x0, y0) = chart.backend_coord(&(-0.5, bottom));
        for dy in [-10, -4] {
            let stroke =
                PathElement::new(vec![(x0 - 7, y0 + dy + 3), (x0 + 7, y0 + dy - 3)], BLACK.stroke_width(2));
            plot.draw(&stroke).map_err(|e| to_err(path, e))?;
        }
    }
    root.present().map_err(|e| to_err(path, e))
}

/// Stacked horizontal bars, one row per label, each made of `segments` from the axis out
/// (segment `j`'s value in row `i` is `segments[j].values[i]`), coloured by `colors` and named in
/// a legend beside the plot in stacking order; `rule` is a vertical line (e.g. the baseline's
/// total). The axis starts at zero.
pub fn stacked_bars(
    path: &Path,
    title: &str,
    x_desc: &str,
    labels: &[String],
    segments: &[Bars],
    colors: &[RGBColor],
    rule: Option<f64>,
) -> Result<()> {
    let n = labels.len().max(1);
    let totals: Vec<f64> =
        (0..n).map(|i| segments.iter().filter_map(|b| b.values.get(i).copied().flatten()).sum()).collect();
    let (left, right) = value_range(totals.iter().copied().chain(rule), false);
    const LEGEND_W: u32 = 130;
    let height = (SIZE.1).max(90 + 28 * n as u32);
    let root = canvas(path, (SIZE.0 + LEGEND_W, height))?;
    let (plot, legend) = root.split_horizontally(SIZE.0);
    let mut chart = chart_on(&plot, path, title, 170, left..right, -0.5..n as f64 - 0.5)?;
    let label = |v: &f64| row_label(labels, *v);
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_labels(4 * n)
        .y_label_formatter(&label)
        .disable_y_mesh()
        .draw()
        .map_err(|e| to_err(path, e))?;
    let mut start = vec![0.0; n];
    for (j, b) in segments.iter().enumerate() {
        let style = colors.get(j).copied().unwrap_or_else(|| color(j)).filled();
        let rects: Vec<_> = (0..n)
            .filter_map(|i| {
                let v = b.values.get(i).copied().flatten()?;
                let y = i as f64;
                let r = Rectangle::new([(start[i], y - 0.35), (start[i] + v, y + 0.35)], style);
                start[i] += v;
                Some(r)
            })
            .collect();
        chart.draw_series(rects).map_err(|e| to_err(path, e))?;
        legend_entry(&legend, path, j, &b.name, style)?;
    }
    if let Some(r) = rule {
        chart
            .draw_series(LineSeries::new([(r, -0.5), (r, n as f64 - 0.5)], BLACK.stroke_width(1)))
            .map_err(|e| to_err(path, e))?;
    }
    root.present().map_err(|e| to_err(path, e))
}

/// Where labels go beside their points (pixel boxes `(x0, y0, x1, y1)`), placed in the order
/// given: each label takes the first of eight positions around its point whose box overlaps no
/// label placed before it and no point, or, if every one does, the least overlapping. Text is
/// `char_w` pixels per character and `text_h` high. Deterministic: the same input, the same
/// places.
pub fn place_labels(
    points: &[(i32, i32)],
    texts: &[String],
    char_w: i32,
    text_h: i32,
    radius: i32,
) -> Vec<(i32, i32)> {
    type Box4 = (i32, i32, i32, i32);
    let overlap = |a: Box4, b: Box4| {
        let w = (a.2.min(b.2) - a.0.max(b.0)).max(0);
        let h = (a.3.min(b.3) - a.1.max(b.1)).max(0);
        w * h
    };
    let dots: Vec<Box4> =
        points.iter().map(|&(x, y)| (x - radius, y - radius, x + radius, y + radius)).collect();
    let mut placed: Vec<Box4> = Vec::new();
    let mut out = Vec::new();
    for (&(x, y), text) in points.iter().zip(texts) {
        let w = char_w * text.chars().count() as i32;
        let g = radius + 3;
        // Top-left corners: right, left, above, below, the diagonals, then further up and down
        // on either side, a line of text at a time.
        let mut candidates = vec![
            (x + g, y - text_h / 2),
            (x - g - w, y - text_h / 2),
            (x - w / 2, y - g - text_h),
            (x - w / 2, y + g),
            (x + g, y - g - text_h),
            (x + g, y + g),
            (x - g - w, y - g - text_h),
            (x - g - w, y + g),
        ];
        for k in 1..=6 {
            let dy = k * (text_h + 2);
            for side in [x + g, x - g - w] {
                candidates.push((side, y - text_h / 2 - dy));
                candidates.push((side, y - text_h / 2 + dy));
            }
        }
        let cost = |&(cx, cy): &(i32, i32)| {
            let b = (cx, cy, cx + w, cy + text_h);
            placed.iter().chain(&dots).map(|&o| overlap(b, o)).sum::<i32>()
        };
        // The first free place, else the least crowded (the earliest of equals).
        let best = candidates.iter().copied().min_by_key(|c| cost(c)).unwrap_or((x + g, y));
        placed.push((best.0, best.1, best.0 + w, best.1 + text_h));
        out.push(best);
    }
    out
}

/// A named line through `(x, y)` points.
#[derive(Clone, Debug)]
pub struct Line {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

/// Lines over `x`; with `log2_x` the axis is logarithmic and labelled with the powers of two.
/// With `zoom` the y axis spans only the values (speed-ups near 1), otherwise it starts at zero.
pub fn lines(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    log2_x: bool,
    zoom: bool,
    series: &[Line],
) -> Result<()> {
    let tx = |x: f64| if log2_x { x.log2() } else { x };
    let all = || series.iter().flat_map(|s| s.points.iter());
    let (x0, x1) =
        all().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(tx(p.0)), b.max(tx(p.0))));
    let (x0, x1) = if x0.is_finite() { (x0, x1.max(x0 + 1.0)) } else { (0.0, 1.0) };
    let pad = (x1 - x0) * 0.04;
    let (y0, y1) = value_range(all().map(|p| p.1), zoom);
    let root = canvas(path, SIZE)?;
    let mut chart = chart_on(&root, path, title, 70, x0 - pad..x1 + pad, y0..y1)?;
    let x_label = |v: &f64| {
        if !log2_x {
            return format!("{v}");
        }
        let r = v.round();
        if (v - r).abs() < 1e-6 {
            format!("{}", 2f64.powf(r))
        } else {
            String::new()
        }
    };
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(axis_desc(y_desc, y0))
        .x_labels(if log2_x { 4 * (x1 - x0 + 1.0) as usize } else { 12 })
        .x_label_formatter(&x_label)
        .draw()
        .map_err(|e| to_err(path, e))?;
    for (i, s) in series.iter().enumerate() {
        let c = series_color(i, series.len());
        let pts: Vec<(f64, f64)> = s.points.iter().map(|&(x, y)| (tx(x), y)).collect();
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))
            .map_err(|e| to_err(path, e))?
            .label(s.name.as_str())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], c.stroke_width(2)));
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled()))).map_err(|e| to_err(path, e))?;
    }
    legend_and_present(&mut chart, &root, SeriesLabelPosition::UpperRight, path)
}

/// A labelled design point of the cost-versus-performance plot.
#[derive(Clone, Debug)]
pub struct Point {
    pub name: String,
    pub x: f64,
    pub y: f64,
    pub highlight: bool,
}

/// Scatter of labelled points; highlighted ones are red and joined by a step line in x order
/// (the Pareto front).
pub fn scatter(path: &Path, title: &str, x_desc: &str, y_desc: &str, points: &[Point]) -> Result<()> {
    let (x0, x1) = points.iter().fold((0.0f64, 0.0f64), |(a, b), p| (a.min(p.x), b.max(p.x)));
    let (y0, y1) = points.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.y), b.max(p.y)));
    let y0 = if y0.is_finite() { y0 } else { 0.0 };
    let (xpad, ypad) = (((x1 - x0) * 0.06).max(1.0), ((y1 - y0) * 0.08).max(0.01));
    let root = canvas(path, SIZE)?;
    let mut chart =
        chart_on(&root, path, title, 70, x0 - xpad..x1 + xpad * 3.0, (y0 - ypad).max(0.0)..y1 + ypad)?;
    chart.configure_mesh().x_desc(x_desc).y_desc(y_desc).draw().map_err(|e| to_err(path, e))?;
    let red = RGBColor(214, 39, 40);
    let mut front: Vec<(f64, f64)> = points.iter().filter(|p| p.highlight).map(|p| (p.x, p.y)).collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let steps = front.windows(2).flat_map(|w| [w[0], (w[1].0, w[0].1), w[1]]).collect::<Vec<_>>();
    chart
        .draw_series(LineSeries::new(if front.len() > 1 { steps } else { front }, red.stroke_width(1)))
        .map_err(|e| to_err(path, e))?
        .label("Pareto front")
        .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], red.stroke_width(1)));
    let font = ("sans-serif", 12).into_font();
    for p in points {
        let c = if p.highlight { red } else { RGBColor(90, 90, 90) };
        let size = if p.highlight { 5 } else { 4 };
        chart
            .draw_series([EmptyElement::at((p.x, p.y)) + Circle::new((0, 0), size, c.filled())])
            .map_err(|e| to_err(path, e))?;
    }
    // Labels in pixels, the Pareto front's first so they sit nearest their points.
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by_key(|&i| !points[i].highlight);
    let pixels: Vec<(i32, i32)> =
        order.iter().map(|&i| chart.backend_coord(&(points[i].x, points[i].y))).collect();
    let texts: Vec<String> = order.iter().map(|&i| points[i].name.clone()).collect();
    for ((text, at), &(px, py)) in texts.iter().zip(place_labels(&pixels, &texts, 7, 12, 5)).zip(&pixels) {
        // A label moved away from its point gets a thin leader line to it.
        let (lx, ly) = (px.clamp(at.0, at.0 + 7 * text.chars().count() as i32), at.1 + 6);
        if (ly - py).abs() > 14 {
            root.draw(&PathElement::new([(px, py), (lx, ly)], RGBColor(150, 150, 150).stroke_width(1)))
                .map_err(|e| to_err(path, e))?;
        }
        root.draw(&Text::new(text.clone(), at, font.clone())).map_err(|e| to_err(path, e))?;
    }
    legend_and_present(&mut chart, &root, SeriesLabelPosition::LowerRight, path)
}

/// A named set of labelled `(x, y, label)` points.
#[derive(Clone, Debug)]
pub struct LabelledPoints {
    pub name: String,
    pub points: Vec<(f64, f64, String)>,
}

/// Scatter of labelled points on logarithmic axes (y from `y_floor`), one colour per set, labels
/// placed by [`place_labels`]; `hline` a labelled horizontal line (e.g. a tolerance).
pub fn log_scatter(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    y_floor: f64,
    sets: &[LabelledPoints],
    hline: Option<(f64, &str)>,
) -> Result<()> {
    let all = || sets.iter().flat_map(|s| s.points.iter());
    let (xmin, xmax) = all().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (xmin, xmax) = if xmin.is_finite() { (xmin / 1.5, xmax * 1.5) } else { (1e-3, 1.0) };
    let ymax = all().map(|p| p.1).chain(hline.map(|h| h.0)).fold(1.0, f64::max) * 2.0;
    let root = canvas(path, SIZE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d((xmin..xmax).log_scale(), (y_floor..ymax).log_scale())
        .map_err(|e| to_err(path, e))?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .bold_line_style(RGBColor(225, 225, 225))
        .light_line_style(TRANSPARENT)
        .draw()
        .map_err(|e| to_err(path, e))?;
    if let Some((y, name)) = hline {
        let red = RGBColor(214, 39, 40);
        chart
            .draw_series(LineSeries::new([(xmin, y), (xmax, y)], red.stroke_width(1)))
            .map_err(|e| to_err(path, e))?
            .label(name)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 16, y)], red));
    }
    for (i, s) in sets.iter().enumerate() {
        let c = color(i);
        chart
            .draw_series(s.points.iter().map(|p| Circle::new((p.0, p.1), 4, c.filled())))
            .map_err(|e| to_err(path, e))?
            .label(s.name.as_str())
            .legend(move |(x, y)| Circle::new((x + 8, y), 4, c.filled()));
    }
    let pixels: Vec<(i32, i32)> = all().map(|p| chart.backend_coord(&(p.0, p.1))).collect();
    let texts: Vec<String> = all().map(|p| p.2.clone()).collect();
    for (text, at) in texts.iter().zip(place_labels(&pixels, &texts, 6, 11, 4)) {
        root.draw(&Text::new(text.clone(), at, ("sans-serif", 11))).map_err(|e| to_err(path, e))?;
    }
    legend_and_present(&mut chart, &root, SeriesLabelPosition::MiddleMiddle, path)
}

/// A histogram over the integer bins `1..=bins`: `values[i]` is bin `i + 1`'s bar, drawn in bin
/// order (plotters' own `Histogram` sums through a hash map, so its SVG element order changed
/// from run to run).
pub fn histogram(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    bins: u32,
    values: &[f64],
) -> Result<()> {
    let top = values.iter().copied().fold(0.0, f64::max).max(1e-6);
    let root = canvas(path, (800, 480))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((1..bins + 1).into_segmented(), 0.0..top * 1.1)
        .map_err(|e| to_err(path, e))?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .disable_x_mesh()
        .draw()
        .map_err(|e| to_err(path, e))?;
    chart
        .draw_series(values.iter().zip(1u32..).map(|(&v, bin)| {
            let span = [(SegmentValue::Exact(bin), 0.0), (SegmentValue::Exact(bin + 1), v)];
            let mut bar = Rectangle::new(span, BLUE.filled());
            bar.set_margin(0, 0, 2, 2);
            bar
        }))
        .map_err(|e| to_err(path, e))?;
    root.present().map_err(|e| to_err(path, e))
}

/// A chart as data, drawn by [`Chart::write_svg`].
#[derive(Clone, Debug)]
pub enum Chart {
    HBars {
        x_desc: String,
        labels: Vec<String>,
        bars: Vec<Bars>,
        dots: Vec<(usize, f64)>,
        rule: Option<f64>,
        zoom: bool,
    },
    Lines {
        x_desc: String,
        y_desc: String,
        log2_x: bool,
        zoom: bool,
        series: Vec<Line>,
    },
    Scatter {
        x_desc: String,
        y_desc: String,
        points: Vec<Point>,
    },
    Grouped {
        y_desc: String,
        groups: Vec<String>,
        series: Vec<Bars>,
        /// One per series; empty: the palette in order.
        colors: Vec<RGBColor>,
        rule: Option<f64>,
        zoom: bool,
    },
    Stacked {
        x_desc: String,
        labels: Vec<String>,
        /// From the axis out.
        segments: Vec<Bars>,
        /// One per segment.
        colors: Vec<RGBColor>,
        rule: Option<f64>,
    },
}

impl Chart {
    pub fn write_svg(&self, path: &Path, title: &str) -> Result<()> {
        match self {
            Chart::HBars { x_desc, labels, bars, dots, rule, zoom } => {
                hbars(path, title, x_desc, labels, bars, dots, *rule, *zoom)
            }
            Chart::Lines { x_desc, y_desc, log2_x, zoom, series } => {
                lines(path, title, x_desc, y_desc, *log2_x, *zoom, series)
            }
            Chart::Scatter { x_desc, y_desc, points } => scatter(path, title, x_desc, y_desc, points),
            Chart::Grouped { y_desc, groups, series, colors, rule, zoom } => {
                grouped_bars(path, title, y_desc, groups, series, colors, *rule, *zoom)
            }
            Chart::Stacked { x_desc, labels, segments, colors, rule } => {
                stacked_bars(path, title, x_desc, labels, segments, colors, *rule)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grouped_bars_mark_a_broken_axis_and_label_the_geomean() {
        let dir = std::env::temp_dir().join(format!("sms-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let groups: Vec<String> = ["ship", "clutter", "geomean"].map(String::from).to_vec();
        let series: Vec<Bars> = (0..17)
            .map(|i| Bars {
                name: format!("C{i}"),
                values: vec![Some(1.0), Some(1.1), Some(1.0 + i as f64 / 1000.0)],
            })
            .collect();
        let svg = |zoom: bool| {
            let path = dir.join(format!("g{zoom}.svg"));
            grouped_bars(&path, "t", "speed-up", &groups, &series, &[], Some(1.0), zoom).unwrap();
            std::fs::read_to_string(path).unwrap()
        };
        let (zoomed, full) = (svg(true), svg(false));
        // The texts written upwards (the axis description is one of them).
        let upwards: Vec<&str> = zoomed
            .split("<text")
            .skip(1)
            .filter(|t| t.contains("rotate(270"))
            .filter_map(|t| t.split_once('>')?.1.split("</text>").next().map(str::trim))
            .collect();
        for i in 0..17 {
            let value = format!("{:.3}", 1.0 + i as f64 / 1000.0);
            assert!(upwards.contains(&value.as_str()), "geomean label {value} not in {upwards:?}");
        }
        assert_eq!(upwards.len(), 17 + 1, "one label per geomean bar, and the axis description");
        assert!(zoomed.contains("axis broken: starts at 0.9"), "a zoomed axis says where it starts");
        assert!(!full.contains("axis broken"), "an axis from zero is not broken");
        // The break: two strokes, the only lines two pixels wide in this chart.
        let strokes = |svg: &str| svg.matches("stroke-width=\"2\"").count();
        assert_eq!((strokes(&zoomed), strokes(&full)), (2, 0));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn neighbouring_series_differ_in_hue_and_the_first_eight_are_okabe_ito() {
        for n in [3, 8, 17, 30] {
            let colours: Vec<RGBColor> = (0..n).map(|i| series_color(i, n)).collect();
            for w in colours.windows(2) {
                assert_ne!(w[0], w[1], "{n} series");
            }
            let distinct: std::collections::HashSet<_> = colours.iter().map(|c| (c.0, c.1, c.2)).collect();
            assert_eq!(distinct.len(), n.min(24), "{n} series");
        }
        assert_eq!((0..8).map(|i| series_color(i, 8)).collect::<Vec<_>>(), OKABE_ITO);
    }

    #[test]
    fn a_family_shares_a_hue_in_distinct_shades_and_neighbours_differ() {
        // The paper set's families: six RB sizes, three SH sizes, five SMS steps and RB sizes.
        let family = [0, 0, 0, 0, 0, 0, 1, 1, 1, 2, 2, 2, 2, 2];
        let c = family_shades(&family);
        for w in c.windows(2) {
            assert_ne!(w[0], w[1]);
        }
        let distinct: std::collections::HashSet<_> = c.iter().map(|c| (c.0, c.1, c.2)).collect();
        assert_eq!(distinct.len(), family.len(), "every bar its own colour");
        // A shade keeps its hue: the channels keep their order, so blue stays blue.
        let order = |c: &RGBColor| {
            let mut i = [(c.0, 0), (c.1, 1), (c.2, 2)];
            i.sort();
            i.map(|x| x.1)
        };
        for (f, hue) in [(0, 0), (1, 1), (2, 2)] {
            for (col, _) in c.iter().zip(&family).filter(|x| *x.1 == f) {
                assert_eq!(order(col), order(&color(hue)), "family {f}: {col:?}");
            }
        }
        assert_eq!(family_shades(&[0, 1, 2]), vec![color(0), color(1), color(2)], "one member: the hue");
    }

    #[test]
    fn stacked_bars_draw_every_segment_of_every_bar() {
        let dir = std::env::temp_dir().join(format!("sms-plot-stacked-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let labels: Vec<String> = ["RB_8", "SMS"].map(String::from).to_vec();
        let segments: Vec<Bars> = (0..3)
            .map(|j| Bars { name: format!("part{j}"), values: vec![Some(0.25 + j as f64 * 0.1), Some(0.2)] })
            .collect();
        let path = dir.join("s.svg");
        stacked_bars(&path, "t", "share", &labels, &segments, &[], Some(1.0)).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        for j in 0..3 {
            assert!(svg.contains(&format!("part{j}")), "legend names segment {j}");
        }
        let filled =
            |c: RGBColor| svg.matches(&format!("fill=\"#{:02X}{:02X}{:02X}\"", c.0, c.1, c.2)).count();
        for j in 0..3 {
            assert_eq!(filled(color(j)), 2 + 1, "two bars and a legend key of segment {j}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn labels_of_a_tight_cluster_do_not_collide() {
        // Five points within a few pixels, as the SH designs sit in the cost plot.
        let points = [(300, 100), (303, 101), (306, 99), (301, 104), (305, 103)];
        let texts: Vec<String> = ["RB_8+SH_4", "RB_8+SH_8", "RB_8+SH_16", "RB_8+SH_8+SK", "RB_8+SH_8+SK+RA"]
            .map(String::from)
            .to_vec();
        let at = place_labels(&points, &texts, 7, 12, 5);
        let boxes: Vec<_> =
            at.iter().zip(&texts).map(|(&(x, y), t)| (x, y, x + 7 * t.len() as i32, y + 12)).collect();
        for (i, a) in boxes.iter().enumerate() {
            for b in &boxes[i + 1..] {
                assert!(a.2 <= b.0 || b.2 <= a.0 || a.3 <= b.1 || b.3 <= a.1, "{a:?} and {b:?} overlap");
            }
        }
        assert_eq!(place_labels(&points, &texts, 7, 12, 5), at, "deterministic");
        // The old fixed offset put every label at its point's upper right: they overlapped.
        let fixed: Vec<_> = points.iter().map(|&(x, y)| (x + 7, y - 6)).collect();
        assert!((fixed[0].0 - fixed[1].0).abs() < 7 * 9 && (fixed[0].1 - fixed[1].1).abs() < 12);
    }
}
