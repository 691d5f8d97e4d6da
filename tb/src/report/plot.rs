//! The SVG charts of every report (sweep, ablation, bench, depth): horizontal bars per
//! configuration, bars grouped per scene, lines over a power-of-two axis, histograms, and
//! scatters with labels placed so that they do not collide. Every element is drawn in the order
//! given, so the same data give the same file.

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::{Error, Result};

const SIZE: (u32, u32) = (960, 600);

fn to_err(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::io(path, std::io::Error::other(e.to_string()))
}

/// The axis range of `values` (and 0 unless `zoom`), padded by 8 %: with `zoom` only the
/// values' span (speed-ups near 1), otherwise from zero (or below it, for negative values). All
/// zeros give the range 0 to 1, so that the ticks still read.
fn value_range(values: impl Iterator<Item = f64> + Clone, zoom: bool) -> (f64, f64) {
    let hi = values.clone().fold(0.0, f64::max);
    let lo = values.fold(hi, f64::min);
    let lo = if zoom { lo } else { lo.min(0.0) };
    if hi - lo < 1e-9 && hi.abs() < 1e-9 {
        return (0.0, 1.0);
    }
    let pad = (hi - lo).max(hi.abs() * 1e-3) * 0.08;
    let bottom = if zoom {
        (lo - pad).max(0.0)
    } else if lo < 0.0 {
        lo - pad
    } else {
        0.0
    };
    (bottom, hi + pad)
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

/// How a legend shows a series.
#[derive(Clone, Copy, Debug)]
enum Key {
    Bar(RGBColor),
    Line(RGBColor),
    Dot(RGBColor, i32),
}

/// Width of a legend column for `names`: key, gap, the longest name, and `extra` pixels after it.
fn legend_width<'n>(names: impl Iterator<Item = &'n str>, extra: u32) -> u32 {
    let text = names.map(|n| text_px(n, 12)).max().unwrap_or(0).max(60) as u32;
    28 + text + extra + 12
}

/// A white canvas of `size` plus a legend column `legend_w` wide at its right, where the legend
/// can hide no data: the whole canvas, the plot's part and the legend's.
fn canvas_with_legend(
    path: &Path,
    size: (u32, u32),
    legend_w: u32,
) -> Result<(Area<'_>, Area<'_>, Area<'_>)> {
    let root = canvas(path, (size.0 + legend_w, size.1))?;
    let (plot, legend) = root.split_horizontally(size.0);
    Ok((root, plot, legend))
}

/// Colour of series `i`, dark enough for thin lines.
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

/// `c` darkened towards black (`t < 0`, by `-t`) or lightened towards white (`t > 0`, by `t`).
fn shade(RGBColor(r, g, b): RGBColor, t: f64) -> RGBColor {
    let s = |c: u8| {
        let c = f64::from(c);
        (if t < 0.0 { c * (1.0 + t) } else { c + (255.0 - c) * t }).round() as u8
    };
    RGBColor(s(r), s(g), s(b))
}

fn lightness(RGBColor(r, g, b): RGBColor) -> f64 {
    super::layout::lab((r, g, b)).0
}

/// How far a family's shades reach: from 75 % darker to 70 % of the way to white, and no
/// lighter than [`LIGHTEST`] (lighter bars fade into the white canvas).
const SHADE_SPAN: (f64, f64) = (-0.75, 0.7);
/// The lightest shade's CIE L*.
const LIGHTEST: f64 = 85.0;

/// Colours for series that come in families (`family[i]`: series `i`'s, from 0): a hue per
/// family, and within a family shades from dark to light in series order, evenly spaced in
/// perceived lightness (CIE L*) so that no two members of a family look alike, and a family
/// reads as one colour while neighbours differ (in hue across families, in shade within one).
pub fn family_shades(family: &[usize]) -> Vec<RGBColor> {
    let size = |f: usize| family.iter().filter(|&&g| g == f).count();
    family
        .iter()
        .enumerate()
        .map(|(i, &f)| {
            let hue = color(FAMILY_HUES[f % FAMILY_HUES.len()]);
            let (rank, m) = (family[..i].iter().filter(|&&g| g == f).count(), size(f));
            if m < 2 {
                return hue;
            }
            let (dark, light) =
                (lightness(shade(hue, SHADE_SPAN.0)), lightness(shade(hue, SHADE_SPAN.1)).min(LIGHTEST));
            let target = dark + (light - dark) * rank as f64 / (m - 1) as f64;
            // Lightness grows with t: bisect for the shade of the target lightness.
            let (mut lo, mut hi) = SHADE_SPAN;
            for _ in 0..40 {
                let mid = (lo + hi) / 2.0;
                if lightness(shade(hue, mid)) < target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            shade(hue, (lo + hi) / 2.0)
        })
        .collect()
}

/// The middle of entry `k`'s row in a legend drawn beside a plot.
fn legend_row(k: usize) -> i32 {
    50 + 18 * k as i32
}

/// Entry `k` of a legend drawn beside a plot: its key and `name`.
fn legend_entry(legend: &Area<'_>, path: &Path, k: usize, name: &str, key: Key) -> Result<()> {
    let y = legend_row(k);
    let drawn = match key {
        Key::Bar(c) => legend.draw(&Rectangle::new([(8, y - 5), (22, y + 5)], c.filled())),
        Key::Line(c) => legend
            .draw(&PathElement::new([(4, y), (24, y)], c.stroke_width(2)))
            .and_then(|_| legend.draw(&Circle::new((14, y), 3, c.filled()))),
        Key::Dot(c, r) => legend.draw(&Circle::new((14, y), r, c.filled())),
    };
    drawn.map_err(|e| to_err(path, e))?;
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
    let names = bars.iter().map(|b| b.name.as_str()).chain(["per scene"]);
    let (root, plot, legend) = canvas_with_legend(path, (SIZE.0, height), legend_width(names, 0))?;
    let mut chart = chart_on(&plot, path, title, 170, left..top, -0.5..n as f64 - 0.5)?;
    let label = |v: &f64| row_label(labels, *v);
    chart
        .configure_mesh()
        .x_desc(axis_desc(x_desc, left))
        .y_labels(4 * n)
        .y_label_formatter(&label)
        .disable_y_mesh()
        .draw()
        .map_err(|e| to_err(path, e))?;
    // Bars grow from the axis's start, or from zero when the axis spans negative values.
    let base = left.max(0.0);
    for (s, b) in bars.iter().enumerate() {
        let style = color(s).filled();
        let rects = b.values.iter().enumerate().filter_map(|(i, v)| {
            let y = i as f64;
            v.map(|v| Rectangle::new([(base, y - 0.35), (v, y + 0.35)], style))
        });
        chart.draw_series(rects).map_err(|e| to_err(path, e))?;
        legend_entry(&legend, path, s, &b.name, Key::Bar(color(s)))?;
    }
    if !dots.is_empty() {
        chart
            .draw_series(dots.iter().map(|&(i, v)| Circle::new((v, i as f64), 3, BLACK.filled())))
            .map_err(|e| to_err(path, e))?;
        legend_entry(&legend, path, bars.len(), "per scene", Key::Dot(BLACK, 3))?;
    }
    if let Some(r) = rule {
        chart
            .draw_series(LineSeries::new([(r, -0.5), (r, n as f64 - 0.5)], BLACK.stroke_width(1)))
            .map_err(|e| to_err(path, e))?;
    }
    root.present().map_err(|e| to_err(path, e))
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
    // The legend: each series' name, then its value in the last group.
    let legend_w = legend_width(series.iter().map(|b| b.name.as_str()), 50);
    let width = (SIZE.0 - legend_w.min(SIZE.0 / 2)).max(90 + (n * (k * 6 + 14)) as u32);
    let (root, plot, legend) = canvas_with_legend(path, (width, SIZE.1), legend_w)?;
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
        let c = colors.get(s).copied().unwrap_or_else(|| series_color(s, k));
        let style = c.filled();
        let rects = b.values.iter().enumerate().filter_map(|(g, v)| {
            let x = g as f64 - 0.4 + slot * s as f64;
            v.map(|v| Rectangle::new([(x, bottom), (x + slot * 0.9, v)], style))
        });
        chart.draw_series(rects).map_err(|e| to_err(path, e))?;
        // The legend beside the plot, in series order (the order of the bars in every group),
        // with each series' value in the last group (the geomean): bars a few pixels wide have
        // no room for a number of their own.
        legend_entry(&legend, path, s, &b.name, Key::Bar(c))?;
        if let Some(Some(v)) = b.values.get(n - 1) {
            let font = TextStyle::from(("sans-serif", 12).into_font()).pos(Pos::new(HPos::Right, VPos::Top));
            let at = (legend_w as i32 - 8, legend_row(s) - 7);
            legend.draw(&Text::new(format!("{v:.3}"), at, font)).map_err(|e| to_err(path, e))?;
        }
    }
    if let Some(last) =
        groups.last().filter(|_| series.iter().any(|b| matches!(b.values.get(n - 1), Some(Some(_)))))
    {
        let font = TextStyle::from(("sans-serif", 12).into_font()).pos(Pos::new(HPos::Right, VPos::Top));
        legend
            .draw(&Text::new(last.clone(), (legend_w as i32 - 8, 22), font))
            .map_err(|e| to_err(path, e))?;
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
    let height = (SIZE.1).max(90 + 28 * n as u32);
    let legend_w = legend_width(segments.iter().map(|b| b.name.as_str()), 0);
    let (root, plot, legend) = canvas_with_legend(path, (SIZE.0, height), legend_w)?;
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
        let c = colors.get(j).copied().unwrap_or_else(|| color(j));
        let style = c.filled();
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
        legend_entry(&legend, path, j, &b.name, Key::Bar(c))?;
    }
    if let Some(r) = rule {
        chart
            .draw_series(LineSeries::new([(r, -0.5), (r, n as f64 - 0.5)], BLACK.stroke_width(1)))
            .map_err(|e| to_err(path, e))?;
    }
    root.present().map_err(|e| to_err(path, e))
}

/// A pixel box `(x0, y0, x1, y1)`.
pub type Box4 = (i32, i32, i32, i32);

/// The pixel width of `text` at `size` (plotters' font size: it writes `size / 1.24` pixels per
/// em), rounded up.
fn text_px(text: &str, size: u32) -> i32 {
    super::layout::text_width(text, f64::from(size) / 1.24).ceil() as i32
}

/// The thin box a line segment occupies, a pixel either side, as an obstacle for labels.
fn segment_box((x0, y0): (i32, i32), (x1, y1): (i32, i32)) -> Box4 {
    (x0.min(x1) - 1, y0.min(y1) - 1, x0.max(x1) + 1, y0.max(y1) + 1)
}

/// Where labels go beside their points (pixel boxes `(x0, y0, x1, y1)`). Each label has
/// candidate positions around its point, nearest first; a position costs by how much of its box
/// lies outside `bounds` (the plot area), then by how much it overlaps other labels, points and
/// `obstacles` (e.g. the boxes of a line's segments) plus, for a leader line (drawn when the label
/// sits far from its point) through a label or a label on one, as much as half the label
/// covered. Labels are placed in the order given, each at its cheapest position (the nearest of
/// equals) among those placed before it; then each in turn moves to its cheapest position among
/// all the others, until none moves, so that an early label does not keep the only place a later
/// one has. That runs in the order given and, unless it leaves nothing in the way, in three more
/// (by x both ways, and reversed), and the cheapest result wins. A text is `size` font units (its width from [`text_px`]) and `text_h` pixels high.
/// Deterministic: the same input, the same places.
pub fn place_labels(
    points: &[(i32, i32)],
    texts: &[String],
    size: u32,
    text_h: i32,
    radius: i32,
    bounds: Box4,
    obstacles: &[Box4],
) -> Vec<(i32, i32)> {
    /// Rounds of moving labels after the first placement: a bound on the time for crowds where
    /// moves go on trading one collision for another (the layout check reports what is left).
    const ROUNDS: usize = 8;
    let overlap = |a: Box4, b: Box4| {
        let w = (a.2.min(b.2) - a.0.max(b.0)).max(0);
        let h = (a.3.min(b.3) - a.1.max(b.1)).max(0);
        i64::from(w * h)
    };
    let dots: Vec<Box4> =
        points.iter().map(|&(x, y)| (x - radius, y - radius, x + radius, y + radius)).collect();
    let widths: Vec<i32> = texts.iter().map(|t| text_px(t, size)).collect();
    let candidates: Vec<Vec<(i32, i32)>> =
        points.iter().zip(&widths).map(|(&p, &w)| label_candidates(p, w, text_h, radius)).collect();
    // Label `i` at `c`, against the labels placed in `at` (other than `i`) and their leaders.
    let cost = |i: usize, c: (i32, i32), at: &[Option<(i32, i32)>]| {
        let (w, p) = (widths[i], points[i]);
        let b = (c.0, c.1, c.0 + w, c.1 + text_h);
        let others = || {
            at.iter().enumerate().filter(move |&(j, _)| j != i).filter_map(|(j, a)| {
                let a = (*a)?;
                Some(((a.0, a.1, a.0 + widths[j], a.1 + text_h), leader(points[j], a, widths[j], text_h)))
            })
        };
        // Outside the plot costs more than any overlap inside it.
        let outside = i64::from(w * text_h) - overlap(b, bounds);
        let crowd: i64 = others()
            .map(|o| o.0)
            .chain(dots.iter().copied())
            .chain(obstacles.iter().copied())
            .map(|o| overlap(b, o))
            .sum();
        let own = leader(p, c, w, text_h);
        let crossed = others().filter(|o| own.is_some_and(|(p, q)| crosses_box(p, q, o.0))).count()
            + others().filter(|o| o.1.is_some_and(|(p, q)| crosses_box(p, q, b))).count();
        let half = i64::from(w * text_h) / 2;
        outside * 1_000_000_000_000 + crowd + half * crossed as i64
    };
    // The cheapest candidate of label `i`, the earliest of equals.
    let best = |i: usize, at: &[Option<(i32, i32)>]| {
        candidates[i].iter().map(|&c| (cost(i, c, at), c)).min_by_key(|x| x.0).expect("candidates")
    };
    // Places the labels in `order`, then moves them in that order; the places and their cost.
    let place = |order: &[usize]| {
        let mut at: Vec<Option<(i32, i32)>> = vec![None; points.len()];
        for &i in order {
            at[i] = Some(best(i, &at).1);
        }
        for _ in 0..ROUNDS {
            let mut moved = false;
            for &i in order {
                let now = cost(i, at[i].expect("placed"), &at);
                let (c, to) = best(i, &at);
                if c < now {
                    at[i] = Some(to);
                    moved = true;
                }
            }
            if !moved {
                break;
            }
        }
        let total: i64 = (0..points.len()).map(|i| cost(i, at[i].expect("placed"), &at)).sum();
        (total, at.into_iter().map(|a| a.expect("placed")).collect::<Vec<_>>())
    };
    // The order given first, then others that hand a cluster's first places to other members
    // (from the left, from the right, last first); the cheapest wins, the earliest of equals.
    let given: Vec<usize> = (0..points.len()).collect();
    let mut left = given.clone();
    left.sort_by_key(|&i| points[i].0);
    let mut right = left.clone();
    right.reverse();
    let last_first: Vec<usize> = given.iter().rev().copied().collect();
    let mut best_total: Option<(i64, Vec<(i32, i32)>)> = None;
    for order in [given, left, right, last_first] {
        let (total, at) = place(&order);
        if best_total.as_ref().is_none_or(|b| total < b.0) {
            best_total = Some((total, at));
        }
        if total == 0 {
            break;
        }
    }
    best_total.map(|b| b.1).unwrap_or_default()
}

/// Top-left corners for a `w` × `text_h` label of the point `(x, y)` drawn `radius` wide,
/// nearest first: right, left, above, below, the diagonals, then further up and down on either
/// side a line of text at a time, then out along the diagonals (so that a leader line passes
/// beside labels stacked over the point rather than through them) and straight up and down.
fn label_candidates((x, y): (i32, i32), w: i32, text_h: i32, radius: i32) -> Vec<(i32, i32)> {
    let g = radius + 3;
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
    for k in 1..=8 {
        let (dx, dy) = (k * (text_h + 2) + g, k * (text_h + 2));
        candidates.extend([
            (x + dx, y - dy - text_h),
            (x - dx - w, y - dy - text_h),
            (x + dx, y + dy),
            (x - dx - w, y + dy),
            (x - w / 2, y - g - text_h - dy),
            (x - w / 2, y + g + dy),
        ]);
    }
    candidates
}

/// The leader line from a point to its label placed at `at` (`w` × `text_h`), if the label sits
/// too far from the point to read as its own without one. It ends on the label's box: at the
/// middle of its near side, or, when the label stands straight above or below the point, at the
/// middle of its near edge, never inside the text.
fn leader((px, py): (i32, i32), at: (i32, i32), w: i32, text_h: i32) -> Option<((i32, i32), (i32, i32))> {
    let mid = at.1 + text_h / 2;
    let end = if px > at.0 && px < at.0 + w {
        (at.0 + w / 2, if py > mid { at.1 + text_h } else { at.1 })
    } else {
        (px.clamp(at.0, at.0 + w), mid)
    };
    ((mid - py).abs() > text_h + 2).then_some(((px, py), end))
}

/// Whether segment `p`–`q` passes through box `b`, its end on the box's edge not counted.
fn crosses_box(p: (i32, i32), q: (i32, i32), b: Box4) -> bool {
    let steps = (p.0 - q.0).abs().max((p.1 - q.1).abs()).max(1);
    (0..steps).any(|i| {
        let (x, y) = (p.0 + (q.0 - p.0) * i / steps, p.1 + (q.1 - p.1) * i / steps);
        x > b.0 && x < b.2 && y > b.1 && y < b.3
    })
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
    let legend_w = legend_width(series.iter().map(|s| s.name.as_str()), 0);
    let (root, plot, legend) = canvas_with_legend(path, SIZE, legend_w)?;
    let mut chart = chart_on(&plot, path, title, 70, x0 - pad..x1 + pad, y0..y1)?;
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
            .map_err(|e| to_err(path, e))?;
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled()))).map_err(|e| to_err(path, e))?;
        legend_entry(&legend, path, i, &s.name, Key::Line(c))?;
    }
    root.present().map_err(|e| to_err(path, e))
}

/// A labelled design point of the cost-versus-performance plot.
#[derive(Clone, Debug)]
pub struct Point {
    pub name: String,
    pub x: f64,
    pub y: f64,
    pub highlight: bool,
}

/// The plot area of `chart` in canvas pixels.
fn plot_box<CT: plotters::coord::CoordTranslate>(chart: &ChartContext<'_, SVGBackend<'_>, CT>) -> Box4 {
    let (x, y) = chart.plotting_area().get_pixel_range();
    (x.start, y.start, x.end, y.end)
}

/// Draws `texts` beside their points `pixels` where [`place_labels`] puts them (font 12, or
/// `size`), each moved far from its point with a thin leader line to it.
fn draw_labels(
    root: &Area<'_>,
    path: &Path,
    pixels: &[(i32, i32)],
    texts: &[String],
    size: u32,
    bounds: Box4,
    obstacles: &[Box4],
) -> Result<()> {
    const TEXT_H: i32 = 12;
    for ((text, at), &(px, py)) in
        texts.iter().zip(place_labels(pixels, texts, size, TEXT_H, 5, bounds, obstacles)).zip(pixels)
    {
        if let Some((p, q)) = leader((px, py), at, text_px(text, size), TEXT_H) {
            root.draw(&PathElement::new([p, q], RGBColor(150, 150, 150).stroke_width(1)))
                .map_err(|e| to_err(path, e))?;
        }
        root.draw(&Text::new(text.clone(), at, ("sans-serif", size))).map_err(|e| to_err(path, e))?;
    }
    Ok(())
}

/// Scatter of labelled points; highlighted ones are red and joined by a step line in x order
/// (the Pareto front). Labels keep off the points, each other and the step line.
pub fn scatter(path: &Path, title: &str, x_desc: &str, y_desc: &str, points: &[Point]) -> Result<()> {
    let (x0, x1) = points.iter().fold((0.0f64, 0.0f64), |(a, b), p| (a.min(p.x), b.max(p.x)));
    let (y0, y1) = points.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| (a.min(p.y), b.max(p.y)));
    let y0 = if y0.is_finite() { y0 } else { 0.0 };
    let (xpad, ypad) = (((x1 - x0) * 0.06).max(1.0), ((y1 - y0) * 0.08).max(0.01));
    let legend_w = legend_width(["Pareto front", "other designs"].into_iter(), 0);
    let (root, plot, legend) = canvas_with_legend(path, SIZE, legend_w)?;
    let mut chart =
        chart_on(&plot, path, title, 70, x0 - xpad..x1 + xpad * 3.0, (y0 - ypad).max(0.0)..y1 + ypad)?;
    chart.configure_mesh().x_desc(x_desc).y_desc(y_desc).draw().map_err(|e| to_err(path, e))?;
    let (red, grey) = (RGBColor(214, 39, 40), RGBColor(90, 90, 90));
    let mut front: Vec<(f64, f64)> = points.iter().filter(|p| p.highlight).map(|p| (p.x, p.y)).collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let steps = front.windows(2).flat_map(|w| [w[0], (w[1].0, w[0].1), w[1]]).collect::<Vec<_>>();
    let line = if front.len() > 1 { steps } else { front };
    chart
        .draw_series(LineSeries::new(line.iter().copied(), red.stroke_width(1)))
        .map_err(|e| to_err(path, e))?;
    legend_entry(&legend, path, 0, "Pareto front", Key::Line(red))?;
    legend_entry(&legend, path, 1, "other designs", Key::Dot(grey, 4))?;
    for p in points {
        let c = if p.highlight { red } else { grey };
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
    let line_px: Vec<(i32, i32)> = line.iter().map(|p| chart.backend_coord(p)).collect();
    let obstacles: Vec<Box4> = line_px.windows(2).map(|w| segment_box(w[0], w[1])).collect();
    draw_labels(&root, path, &pixels, &texts, 12, plot_box(&chart), &obstacles)?;
    root.present().map_err(|e| to_err(path, e))
}

/// A tick value without float noise: at most six decimals, trailing zeros dropped (0.3, 1, 10).
fn tidy(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

/// A named set of labelled `(x, y, label)` points.
#[derive(Clone, Debug)]
pub struct LabelledPoints {
    pub name: String,
    pub points: Vec<(f64, f64, String)>,
}

/// Scatter of labelled points on logarithmic axes, one colour per set, labels placed by
/// [`place_labels`]; `hline` a labelled horizontal line (e.g. a tolerance). The y axis starts
/// below `y_floor` (where zeros are drawn), so that points on the floor stand clear of the x axis
/// with room for labels under them.
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
    let names = sets.iter().map(|s| s.name.as_str()).chain(hline.map(|h| h.1));
    let (root, plot, legend) = canvas_with_legend(path, SIZE, legend_width(names, 0))?;
    let mut chart = ChartBuilder::on(&plot)
        .caption(title, ("sans-serif", 20))
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d((xmin..xmax).log_scale(), (y_floor / 4.0..ymax).log_scale())
        .map_err(|e| to_err(path, e))?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        // At most nine ticks a decade: plotters' finer log ticks repeat each decade's end.
        .x_labels(9)
        .y_labels(9)
        .x_label_formatter(&|v| tidy(*v))
        .y_label_formatter(&|v| tidy(*v))
        .bold_line_style(RGBColor(225, 225, 225))
        .light_line_style(TRANSPARENT)
        .draw()
        .map_err(|e| to_err(path, e))?;
    let mut obstacles = Vec::new();
    for (i, s) in sets.iter().enumerate() {
        let c = color(i);
        chart
            .draw_series(s.points.iter().map(|p| Circle::new((p.0, p.1), 4, c.filled())))
            .map_err(|e| to_err(path, e))?;
        legend_entry(&legend, path, i, &s.name, Key::Dot(c, 4))?;
    }
    if let Some((y, name)) = hline {
        let red = RGBColor(214, 39, 40);
        chart
            .draw_series(LineSeries::new([(xmin, y), (xmax, y)], red.stroke_width(1)))
            .map_err(|e| to_err(path, e))?;
        legend_entry(&legend, path, sets.len(), name, Key::Line(red))?;
        obstacles.push(segment_box(chart.backend_coord(&(xmin, y)), chart.backend_coord(&(xmax, y))));
    }
    let pixels: Vec<(i32, i32)> = all().map(|p| chart.backend_coord(&(p.0, p.1))).collect();
    let texts: Vec<String> = all().map(|p| p.2.clone()).collect();
    draw_labels(&root, path, &pixels, &texts, 11, plot_box(&chart), &obstacles)?;
    root.present().map_err(|e| to_err(path, e))
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
    fn grouped_bars_mark_a_broken_axis_and_give_the_geomeans_in_the_legend() {
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
        let texts = crate::report::layout::read(&zoomed).labels;
        // Each series' geomean stands in the legend, right of its name, under the group's name.
        let at = |t: &str| texts.iter().find(|l| l.text == t).unwrap_or_else(|| panic!("no {t}")).rect;
        // The group's name is also on the x axis: the legend's heading is the rightmost.
        let head = texts
            .iter()
            .filter(|l| l.text == "geomean")
            .map(|l| l.rect)
            .max_by(|a, b| a.x0.total_cmp(&b.x0))
            .unwrap();
        for i in 0..17 {
            let (name, value) = (at(&format!("C{i}")), at(&format!("{:.3}", 1.0 + i as f64 / 1000.0)));
            assert!(value.x0 > name.x1 && (value.y0 - name.y0).abs() < 1e-9, "C{i}: {name:?} {value:?}");
            assert!((value.x1 - head.x1).abs() < 1e-9 && value.y0 > head.y1);
        }
        assert_eq!(
            crate::report::layout::faults(&crate::report::layout::read(&zoomed)),
            Vec::<String>::new()
        );
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
        // Every two members of a family, up to eight in any of the six hues, tell apart at a glance.
        for f in 0..FAMILY_HUES.len() {
            let c = family_shades(&[f; 8]);
            for (i, a) in c.iter().enumerate() {
                for b in &c[i + 1..] {
                    let de = crate::report::layout::delta_e((a.0, a.1, a.2), (b.0, b.1, b.2));
                    assert!(de >= 10.0, "family {f}: {a:?} and {b:?} differ by {de:.1}");
                }
                let on_white = crate::report::layout::delta_e((a.0, a.1, a.2), (255, 255, 255));
                assert!(on_white >= 20.0, "family {f}: {a:?} fades into the canvas ({on_white:.1})");
            }
        }
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
        let bounds = (0, 0, 1000, 1000);
        let at = place_labels(&points, &texts, 12, 12, 5, bounds, &[]);
        let boxes: Vec<_> =
            at.iter().zip(&texts).map(|(&(x, y), t)| (x, y, x + text_px(t, 12), y + 12)).collect();
        for (i, a) in boxes.iter().enumerate() {
            for b in &boxes[i + 1..] {
                assert!(a.2 <= b.0 || b.2 <= a.0 || a.3 <= b.1 || b.3 <= a.1, "{a:?} and {b:?} overlap");
            }
        }
        assert_eq!(place_labels(&points, &texts, 12, 12, 5, bounds, &[]), at, "deterministic");
        // The old fixed offset put every label at its point's upper right: they overlapped.
        let fixed: Vec<_> = points.iter().map(|&(x, y)| (x + 7, y - 6)).collect();
        assert!((fixed[0].0 - fixed[1].0).abs() < 7 * 9 && (fixed[0].1 - fixed[1].1).abs() < 12);
    }

    #[test]
    fn labels_stay_inside_the_plot_and_off_its_lines() {
        let texts = vec!["RB_16+SH_8+SK+RA".to_string()];
        let w = text_px(&texts[0], 12);
        let bounds = (100, 100, 500, 400);
        // At the plot's right edge the label goes left; at its left edge (the y axis's tick
        // labels beyond) it goes right.
        for x in [498, 102] {
            let at = place_labels(&[(x, 200)], &texts, 12, 12, 5, bounds, &[])[0];
            assert!(at.0 >= bounds.0 && at.0 + w <= bounds.2, "{x}: {at:?}");
        }
        // A line through the point keeps the label off it.
        let line = segment_box((100, 200), (500, 200));
        let at = place_labels(&[(300, 200)], &texts, 12, 12, 5, bounds, &[line])[0];
        assert!(at.1 + 12 <= line.1 || at.1 >= line.3, "{at:?} on the line {line:?}");
        let free = place_labels(&[(300, 200)], &texts, 12, 12, 5, bounds, &[])[0];
        assert!(free.1 < line.3 && free.1 + 12 > line.1, "without the line the label sits beside the point");
    }
}
