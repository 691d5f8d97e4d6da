//! Reads back a chart's SVG (as [`super::plot`] writes it through plotters) and finds what a
//! reader would trip over: text boxes that overlap each other, text struck through by a data or
//! axis line, text over a data point, a data point hidden under a legend, text off the canvas;
//! and colours of one family too close to tell apart.
//!
//! A text's box comes from its position, anchor (`text-anchor`, and `dy` for the vertical
//! anchor), rotation and font size, with its width from DejaVu Sans's advance widths (the
//! `sans-serif` of a Debian system and of `rsvg-convert`): an estimate to a few percent, so two
//! boxes count as overlapping only when they share more than [`SLACK`] pixels each way.

/// Pixels two boxes may share each way before they count as overlapping: the width estimate's
/// error on a short label.
pub const SLACK: f64 = 1.0;

/// An axis-aligned box in pixels: `x0 <= x1`, `y0 <= y1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub x0: f64,
    pub y0: f64,
    pub x1: f64,
    pub y1: f64,
}

impl Rect {
    fn overlaps(&self, o: &Rect, slack: f64) -> bool {
        self.x0.max(o.x0) + slack < self.x1.min(o.x1) && self.y0.max(o.y0) + slack < self.y1.min(o.y1)
    }

    fn contains(&self, (x, y): (f64, f64), margin: f64) -> bool {
        x >= self.x0 - margin && x <= self.x1 + margin && y >= self.y0 - margin && y <= self.y1 + margin
    }

    fn shrunk(&self, by: f64) -> Rect {
        Rect { x0: self.x0 + by, y0: self.y0 + by, x1: self.x1 - by, y1: self.y1 - by }
    }
}

/// One `<text>` element: its string and estimated box.
#[derive(Clone, Debug, PartialEq)]
pub struct Label {
    pub text: String,
    pub rect: Rect,
}

/// A drawn line (`<line>`, or a `<polyline>`'s points) that text must not cross: axes, ticks,
/// data lines, rules. Grid lines (opacity under a half, or a light grey) are left out.
#[derive(Clone, Debug, PartialEq)]
pub struct Stroke {
    pub points: Vec<(f64, f64)>,
}

/// What a chart's SVG holds, as far as the checks go.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Drawing {
    pub width: f64,
    pub height: f64,
    pub labels: Vec<Label>,
    pub strokes: Vec<Stroke>,
    /// Data points: centre and radius, with their index in drawing order.
    pub dots: Vec<((f64, f64), f64, usize)>,
    /// Opaque-white boxes (legend backgrounds) after the canvas, with their drawing order.
    pub covers: Vec<(Rect, usize)>,
}

/// DejaVu Sans's advance width of `c`, in ems (rounded from the font's metrics).
fn advance(c: char) -> f64 {
    match c {
        ' ' | '.' | ',' => 0.318,
        ':' | ';' | '|' => 0.337,
        'i' | 'j' | 'l' | '\'' => 0.278,
        'I' => 0.295,
        '!' => 0.4,
        '(' | ')' | '[' | ']' | '{' | '}' => 0.39,
        'f' => 0.352,
        't' => 0.392,
        'r' => 0.411,
        '-' => 0.361,
        's' => 0.521,
        'z' | 'c' => 0.55,
        'k' | 'v' | 'x' | 'y' => 0.592,
        'a' | 'e' | 'o' => 0.615,
        'm' => 0.974,
        'w' => 0.818,
        'L' => 0.557,
        'F' => 0.575,
        'J' => 0.295,
        'M' => 0.863,
        'W' => 0.989,
        'O' | 'Q' | 'G' => 0.787,
        '0'..='9' | '_' | '?' | '$' => 0.636,
        '+' | '=' | '<' | '>' | '×' | '~' => 0.838,
        '%' => 0.95,
        '/' | '\\' => 0.337,
        'a'..='z' => 0.634,
        'A'..='Z' => 0.7,
        _ => 0.8,
    }
}

/// Estimated width in pixels of `text` at `size` pixels per em.
pub fn text_width(text: &str, size: f64) -> f64 {
    text.chars().map(advance).sum::<f64>() * size
}

/// The value of attribute `name` in a tag's attribute text.
fn attr<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let mut rest = tag;
    while let Some(i) = rest.find(name) {
        let before_ok = i == 0 || rest.as_bytes()[i - 1] == b' ';
        let after = &rest[i + name.len()..];
        if before_ok {
            if let Some(v) = after.strip_prefix("=\"") {
                return v.split('"').next();
            }
        }
        rest = after;
    }
    None
}

fn num(tag: &str, name: &str) -> f64 {
    attr(tag, name).and_then(|v| v.trim().parse().ok()).unwrap_or(0.0)
}

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// The box of a text drawn at `(x, y)` as plotters' SVG backend writes it: `text-anchor` for
/// the horizontal anchor, `dy` (`0.76em` top, `0.5ex` centre, `-0.5ex` bottom, none: baseline)
/// for the vertical one, then `rotate(a, x, y)`.
fn label_rect(text: &str, x: f64, y: f64, size: f64, anchor: &str, dy: &str, rotate: f64) -> Rect {
    let w = text_width(text, size);
    // DejaVu Sans: ascent 0.76 em above the baseline, descent 0.24 em below; an ex is 0.55 em.
    let baseline = match dy {
        "0.76em" => 0.76 * size,
        "0.5ex" => 0.275 * size,
        "-0.5ex" => -0.275 * size,
        _ => 0.0,
    };
    let x0 = match anchor {
        "middle" => -w / 2.0,
        "end" => -w,
        _ => 0.0,
    };
    let corners = [(x0, baseline - 0.76 * size), (x0 + w, baseline + 0.24 * size)];
    let (s, c) = rotate.to_radians().sin_cos();
    let turned: Vec<(f64, f64)> = [
        (corners[0].0, corners[0].1),
        (corners[1].0, corners[0].1),
        (corners[0].0, corners[1].1),
        (corners[1].0, corners[1].1),
    ]
    .iter()
    .map(|&(dx, dy)| (x + dx * c - dy * s, y + dx * s + dy * c))
    .collect();
    let fold = |f: fn(f64, f64) -> f64, pick: fn(&(f64, f64)) -> f64, init: f64| {
        turned.iter().map(pick).fold(init, f)
    };
    Rect {
        x0: fold(f64::min, |p| p.0, f64::INFINITY),
        y0: fold(f64::min, |p| p.1, f64::INFINITY),
        x1: fold(f64::max, |p| p.0, f64::NEG_INFINITY),
        y1: fold(f64::max, |p| p.1, f64::NEG_INFINITY),
    }
}

/// Reads the texts, strokes, dots and covers of an SVG written by plotters' SVG backend.
pub fn read(svg: &str) -> Drawing {
    let mut d = Drawing::default();
    for (order, chunk) in svg.split('<').enumerate() {
        let Some((name, rest)) = chunk.split_once(|c: char| c == ' ' || c == '>') else { continue };
        let tag = rest.split('>').next().unwrap_or("");
        let opacity = attr(tag, "opacity").and_then(|v| v.parse::<f64>().ok()).unwrap_or(1.0);
        // A grid line: faint, or light grey (every channel at least 0xC8).
        let light =
            attr(tag, "stroke").and_then(|c| c.strip_prefix('#')).filter(|c| c.len() == 6).is_some_and(|c| {
                (0..3).all(|i| u8::from_str_radix(&c[2 * i..2 * i + 2], 16).is_ok_and(|v| v >= 0xC8))
            });
        let drawn = opacity >= 0.5 && !light;
        match name {
            "svg" => (d.width, d.height) = (num(tag, "width"), num(tag, "height")),
            "text" => {
                let text = unescape(rest.split_once('>').map_or("", |x| x.1).trim());
                let size = num(tag, "font-size");
                let rotate = attr(tag, "transform")
                    .and_then(|t| t.strip_prefix("rotate(")?.split(',').next()?.trim().parse().ok())
                    .unwrap_or(0.0);
                let (x, y) = (num(tag, "x"), num(tag, "y"));
                let (anchor, dy) =
                    (attr(tag, "text-anchor").unwrap_or("start"), attr(tag, "dy").unwrap_or(""));
                if !text.is_empty() {
                    d.labels.push(Label { rect: label_rect(&text, x, y, size, anchor, dy, rotate), text });
                }
            }
            "line" if drawn => d.strokes.push(Stroke {
                points: vec![(num(tag, "x1"), num(tag, "y1")), (num(tag, "x2"), num(tag, "y2"))],
            }),
            "polyline" if drawn => {
                let points = attr(tag, "points")
                    .unwrap_or("")
                    .split_whitespace()
                    .filter_map(|p| {
                        let (x, y) = p.split_once(',')?;
                        Some((x.parse().ok()?, y.parse().ok()?))
                    })
                    .collect();
                d.strokes.push(Stroke { points });
            }
            "circle" => d.dots.push(((num(tag, "cx"), num(tag, "cy")), num(tag, "r"), order)),
            "rect" if order > 2 && attr(tag, "fill") == Some("#FFFFFF") && opacity >= 0.5 => {
                let (x, y) = (num(tag, "x"), num(tag, "y"));
                d.covers.push((
                    Rect { x0: x, y0: y, x1: x + num(tag, "width"), y1: y + num(tag, "height") },
                    order,
                ));
            }
            _ => {}
        }
    }
    d
}

/// Whether segment `a`–`b` passes through the inside of `r`.
fn crosses(a: (f64, f64), b: (f64, f64), r: &Rect) -> bool {
    // Sample the segment finely enough for boxes a few pixels high.
    let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
    let steps = (len / 0.5).ceil().max(1.0) as usize;
    (0..=steps).any(|i| {
        let t = i as f64 / steps as f64;
        r.contains((a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t), 0.0)
    })
}

/// Every layout fault of a drawing, one sentence each; empty when the chart reads cleanly.
pub fn faults(d: &Drawing) -> Vec<String> {
    let mut out = Vec::new();
    for (i, a) in d.labels.iter().enumerate() {
        let r = &a.rect;
        if r.x0 < -SLACK || r.y0 < -SLACK || r.x1 > d.width + SLACK || r.y1 > d.height + SLACK {
            out.push(format!("'{}' runs off the canvas: {r:?}", a.text));
        }
        for b in &d.labels[i + 1..] {
            if r.overlaps(&b.rect, SLACK) {
                out.push(format!("'{}' overlaps '{}': {r:?} and {:?}", a.text, b.text, b.rect));
            }
        }
        let inner = r.shrunk(SLACK);
        // Every line counts, a label's own leader line too: it ends on the label's edge, and one
        // that reaches into the text strikes it.
        for s in &d.strokes {
            if s.points.windows(2).any(|w| crosses(w[0], w[1], &inner)) {
                out.push(format!("a line through '{}' ({r:?}): {:?}", a.text, s.points));
            }
        }
        for &((x, y), rad, _) in &d.dots {
            let dot = Rect { x0: x - rad, y0: y - rad, x1: x + rad, y1: y + rad };
            if r.overlaps(&dot, SLACK) {
                out.push(format!("'{}' covers the point at ({x}, {y})", a.text));
            }
        }
    }
    for &((x, y), rad, drawn) in &d.dots {
        let dot = Rect { x0: x - rad, y0: y - rad, x1: x + rad, y1: y + rad };
        if d.covers.iter().any(|(c, order)| *order > drawn && c.overlaps(&dot, 0.0)) {
            out.push(format!("the point at ({x}, {y}) is hidden under a legend"));
        }
    }
    out
}

/// CIE L*a*b* of an sRGB colour (D65 white).
pub fn lab((r, g, b): (u8, u8, u8)) -> (f64, f64, f64) {
    let lin = |c: u8| {
        let c = f64::from(c) / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let (r, g, b) = (lin(r), lin(g), lin(b));
    let x = (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047;
    let y = 0.2126 * r + 0.7152 * g + 0.0722 * b;
    let z = (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883;
    let f = |t: f64| if t > 0.008856 { t.cbrt() } else { 7.787 * t + 16.0 / 116.0 };
    let (fx, fy, fz) = (f(x), f(y), f(z));
    (116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz))
}

/// CIE76 colour difference: about 2.3 is just noticeable, above 10 two swatches side by side read
/// as different colours at a glance.
pub fn delta_e(a: (u8, u8, u8), b: (u8, u8, u8)) -> f64 {
    let (p, q) = (lab(a), lab(b));
    ((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2) + (p.2 - q.2).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn svg(body: &str) -> String {
        format!("<svg width=\"400\" height=\"300\" viewBox=\"0 0 400 300\" xmlns=\"http://www.w3.org/2000/svg\">\n<rect x=\"0\" y=\"0\" width=\"400\" height=\"300\" opacity=\"1\" fill=\"#FFFFFF\" stroke=\"none\"/>\n{body}</svg>")
    }

    fn text(x: i32, y: i32, s: &str, extra: &str) -> String {
        format!("<text x=\"{x}\" y=\"{y}\" dy=\"0.76em\" text-anchor=\"start\" font-family=\"sans-serif\" font-size=\"10\" opacity=\"1\" fill=\"#000000\"{extra}>\n{s}\n</text>\n")
    }

    #[test]
    fn boxes_follow_anchor_and_rotation() {
        let w = text_width("1.234", 10.0);
        let d = read(&svg(&text(100, 50, "1.234", "")));
        assert_eq!(d.labels[0].rect, Rect { x0: 100.0, y0: 50.0, x1: 100.0 + w, y1: 60.0 });
        // Written upwards from (100, 50): the box stands above the point, one em wide.
        let up = read(&svg(&text(100, 50, "1.234", " transform=\"rotate(270, 100, 50)\"")));
        let r = up.labels[0].rect;
        assert!((r.y1 - 50.0).abs() < 1e-9 && (r.y0 - (50.0 - w)).abs() < 1e-9, "{r:?}");
        assert!((r.x1 - r.x0 - 10.0).abs() < 1e-9, "{r:?}");
    }

    #[test]
    fn separate_labels_pass_and_a_planted_overlap_is_caught() {
        let apart = svg(&(text(10, 10, "RB_8+SH_8", "") + &text(10, 30, "RB_8+SH_8+SK", "")));
        assert_eq!(faults(&read(&apart)), Vec::<String>::new());
        let planted = svg(&(text(10, 10, "RB_8+SH_8", "") + &text(40, 14, "RB_8+SH_8+SK", "")));
        let f = faults(&read(&planted));
        assert_eq!(f.len(), 1, "{f:?}");
        assert!(f[0].contains("overlaps"), "{f:?}");
    }

    #[test]
    fn a_line_through_a_label_a_covered_point_and_a_hidden_point_are_caught() {
        let label = text(100, 100, "SMS", "");
        let line = "<polyline fill=\"none\" opacity=\"1\" stroke=\"#D62728\" stroke-width=\"1\" points=\"50,105 150,105 150,200 \"/>\n";
        assert_eq!(faults(&read(&svg(&(label.clone() + line)))).len(), 1);
        // A leader line ending on its label's edge is not a strike-through; one reaching into
        // the text is.
        let leader = |end: &str| {
            format!("<polyline fill=\"none\" opacity=\"1\" stroke=\"#969696\" stroke-width=\"1\" points=\"60,160 {end} \"/>\n")
        };
        assert_eq!(faults(&read(&svg(&(label.clone() + &leader("100,105"))))), Vec::<String>::new());
        assert_eq!(faults(&read(&svg(&(label.clone() + &leader("110,105"))))).len(), 1);
        let dot = "<circle cx=\"105\" cy=\"104\" r=\"3\" opacity=\"1\" fill=\"#000000\" stroke=\"none\"/>\n";
        assert_eq!(faults(&read(&svg(&(label + dot)))).len(), 1);
        let legend = "<rect x=\"90\" y=\"90\" width=\"60\" height=\"40\" opacity=\"0.85\" fill=\"#FFFFFF\" stroke=\"none\"/>\n";
        let hidden = faults(&read(&svg(&(dot.to_string() + legend))));
        assert_eq!(hidden.len(), 1, "{hidden:?}");
        assert!(hidden[0].contains("hidden"));
        // A point drawn over the box shows.
        assert_eq!(faults(&read(&svg(&(legend.to_string() + dot)))), Vec::<String>::new());
    }

    #[test]
    fn colour_difference_tells_near_identical_blues_from_distinct_ones() {
        assert!(delta_e((0, 114, 178), (0, 118, 184)) < 3.0);
        assert!(delta_e((0, 114, 178), (86, 180, 233)) > 20.0);
        assert!(delta_e((0, 0, 0), (255, 255, 255)) > 99.0);
    }
}
