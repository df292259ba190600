//! A small SVG line-plot writer (axes with ticks, optional logarithmic axes, markers, legend):
//! enough for the study's plots without a plotting dependency (`png` renders them to PNG).

use std::fmt::Write;

/// One line of a plot.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    /// Points in drawing order; non-finite points (and, on a log axis, non-positive ones) are left out.
    pub points: Vec<(f64, f64)>,
}

/// A plot to draw.
#[derive(Debug, Clone)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Logarithmic axes.
    pub log_x: bool,
    pub log_y: bool,
    /// Draw a marker at every point (plots with few points).
    pub markers: bool,
}

const W: f64 = 760.0;
const H: f64 = 480.0;
const LEFT: f64 = 90.0;
const RIGHT: f64 = 190.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 60.0;
const COLORS: [&str; 10] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf",
];

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Whether a log axis suits these values: all positive and spanning more than a factor 20.
pub fn suits_log(values: impl Iterator<Item = f64>) -> bool {
    let (mut lo, mut hi, mut any) = (f64::INFINITY, 0.0f64, false);
    for v in values.filter(|v| v.is_finite()) {
        if v <= 0.0 {
            return false;
        }
        lo = lo.min(v);
        hi = hi.max(v);
        any = true;
    }
    any && hi / lo > 20.0
}

/// Tick positions of a linear axis over [lo, hi]: about 5 round numbers.
fn linear_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = hi - lo;
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= 6.0)
        .unwrap_or(10.0 * mag);
    let mut t = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while t <= hi + 1e-9 * span {
        out.push(if t.abs() < 1e-12 * span { 0.0 } else { t });
        t += step;
    }
    out
}

fn tick_label(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.1e}");
        return s.replace(".0e", "e");
    }
    let s = format!("{v:.4}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// Range of an axis with a margin; a degenerate range is widened.
fn axis_range(vals: &[f64], log: bool) -> (f64, f64) {
    let vals: Vec<f64> = vals
        .iter()
        .map(|&v| if log { v.log10() } else { v })
        .collect();
    let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo <= 1e-12 * hi.abs().max(lo.abs()).max(1e-300) {
        let d = if log { 0.5 } else { lo.abs().max(1.0) * 0.1 };
        return (lo - d, hi + d);
    }
    let m = 0.05 * (hi - lo);
    (lo - m, hi + m)
}

impl Plot {
    /// The plot as an SVG document.
    pub fn to_svg(&self) -> String {
        let keep = |(x, y): &(f64, f64)| {
            x.is_finite() && y.is_finite() && (!self.log_x || *x > 0.0) && (!self.log_y || *y > 0.0)
        };
        let xs: Vec<f64> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().filter(|p| keep(p)).map(|p| p.0))
            .collect();
        let ys: Vec<f64> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().filter(|p| keep(p)).map(|p| p.1))
            .collect();
        let (x0, x1) = axis_range(&xs, self.log_x);
        let (y0, y1) = axis_range(&ys, self.log_y);
        let (pw, ph) = (W - LEFT - RIGHT, H - TOP - BOTTOM);
        let tx = |x: f64| {
            let v = if self.log_x { x.log10() } else { x };
            LEFT + (v - x0) / (x1 - x0) * pw
        };
        let ty = |y: f64| {
            let v = if self.log_y { y.log10() } else { y };
            TOP + ph - (v - y0) / (y1 - y0) * ph
        };
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(s, r#"<rect width="{W}" height="{H}" fill="white"/>"#);
        let _ = writeln!(
            s,
            r#"<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
            LEFT + pw / 2.0,
            esc(&self.title)
        );
        // ticks and grid
        let ticks = |lo: f64, hi: f64, log: bool| -> Vec<(f64, String)> {
            if log {
                let (a, b) = (lo.ceil() as i32, hi.floor() as i32);
                let mut t: Vec<(f64, String)> = (a..=b)
                    .map(|e| (10f64.powi(e), tick_label(10f64.powi(e))))
                    .collect();
                if t.len() < 2 {
                    t = linear_ticks(10f64.powf(lo), 10f64.powf(hi))
                        .into_iter()
                        .filter(|v| *v > 0.0)
                        .map(|v| (v, tick_label(v)))
                        .collect();
                }
                t
            } else {
                linear_ticks(lo, hi)
                    .into_iter()
                    .map(|v| (v, tick_label(v)))
                    .collect()
            }
        };
        for (v, label) in ticks(x0, x1, self.log_x) {
            let x = tx(v);
            let _ = writeln!(
                s,
                r##"<line x1="{x:.1}" y1="{TOP}" x2="{x:.1}" y2="{:.1}" stroke="#e0e0e0"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                TOP + ph,
                TOP + ph + 18.0,
                esc(&label)
            );
        }
        for (v, label) in ticks(y0, y1, self.log_y) {
            let y = ty(v);
            let _ = writeln!(
                s,
                r##"<line x1="{LEFT}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#e0e0e0"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
                LEFT + pw,
                LEFT - 6.0,
                y + 4.0,
                esc(&label)
            );
        }
        let _ = writeln!(
            s,
            r#"<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#
        );
        let _ = writeln!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">{}{}</text>"#,
            LEFT + pw / 2.0,
            H - 15.0,
            esc(&self.x_label),
            if self.log_x { " (log)" } else { "" }
        );
        let _ = writeln!(
            s,
            r#"<text x="18" y="{}" text-anchor="middle" transform="rotate(-90 18 {})">{}{}</text>"#,
            TOP + ph / 2.0,
            TOP + ph / 2.0,
            esc(&self.y_label),
            if self.log_y { " (log)" } else { "" }
        );
        for (i, ser) in self.series.iter().enumerate() {
            let color = COLORS[i % COLORS.len()];
            let pts: Vec<(f64, f64)> = ser
                .points
                .iter()
                .filter(|p| keep(p))
                .map(|&(x, y)| (tx(x), ty(y)))
                .collect();
            if pts.len() > 1 {
                let path: Vec<String> = pts.iter().map(|(x, y)| format!("{x:.2},{y:.2}")).collect();
                let _ = writeln!(
                    s,
                    r#"<polyline fill="none" stroke="{color}" stroke-width="1.5" points="{}"/>"#,
                    path.join(" ")
                );
            }
            if self.markers || pts.len() == 1 {
                for (x, y) in &pts {
                    let _ = writeln!(
                        s,
                        r#"<circle cx="{x:.2}" cy="{y:.2}" r="3.5" fill="{color}"/>"#
                    );
                }
            }
            let ly = TOP + 10.0 + 18.0 * i as f64;
            let lx = LEFT + pw + 15.0;
            let _ = writeln!(
                s,
                r#"<line x1="{lx}" y1="{ly}" x2="{}" y2="{ly}" stroke="{color}" stroke-width="2"/><text x="{}" y="{}">{}</text>"#,
                lx + 20.0,
                lx + 26.0,
                ly + 4.0,
                esc(&ser.name)
            );
        }
        s += "</svg>\n";
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        let t = linear_ticks(0.03, 0.97);
        assert_eq!(t.len(), 4, "{t:?}");
        assert!(
            (t[0] - 0.2).abs() < 1e-12 && (t[3] - 0.8).abs() < 1e-12,
            "{t:?}"
        );
        assert!(suits_log([1e-3, 1.0].into_iter()));
        assert!(!suits_log([-1.0, 1.0].into_iter()));
    }

    #[test]
    fn svg_has_one_line_per_series_and_escapes_text() {
        let p = Plot {
            title: "a < b".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![
                Series {
                    name: "Q1N2".into(),
                    points: vec![(1.0, 1.0), (2.0, 0.5), (4.0, 0.1)],
                },
                Series {
                    name: "Q1C1".into(),
                    points: vec![(1.0, 2.0), (2.0, f64::NAN), (4.0, 0.3)],
                },
            ],
            log_x: true,
            log_y: true,
            markers: true,
        };
        let svg = p.to_svg();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert_eq!(
            svg.matches("<circle").count(),
            5,
            "the NaN point is left out"
        );
        assert!(svg.contains("a &lt; b") && svg.contains("Q1C1"));
    }
}
