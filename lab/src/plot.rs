//! Learning-curve plots as SVG and PNG, with optional confidence bands, for single runs and
//! comparisons (pure vs hybrid, across seeds).
//!
//! Text is laid out with the bundled DejaVu Sans font (`assets/fonts/DejaVuSans.ttf`,
//! through plotters' `ab_glyph` feature), so no system font library is needed; PNGs are
//! rendered into an RGB buffer and encoded with the `png` crate.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::prelude::*;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // The font is bundled at compile time and known to parse.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// One curve: `y` against `x`, with an optional band `[lower, upper]` (e.g. mean ± std or a
/// confidence interval across seeds).
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Abscissae (e.g. environment steps).
    pub x: Vec<f64>,
    /// Ordinates (e.g. mean episode return); non-finite points are skipped.
    pub y: Vec<f64>,
    /// Lower edge of the band, same length as `x`.
    pub lower: Option<Vec<f64>>,
    /// Upper edge of the band.
    pub upper: Option<Vec<f64>>,
}

/// Axis titles and figure title.
#[derive(Clone, Debug, PartialEq)]
pub struct PlotLabels {
    /// Figure title.
    pub title: String,
    /// x-axis title.
    pub x: String,
    /// y-axis title.
    pub y: String,
}

/// Why a plot could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Nothing finite to draw.
    #[error("{path}: no finite data points to plot")]
    Empty {
        /// Output file.
        path: PathBuf,
    },
    /// Drawing or writing failed.
    #[error("{path}: {message}")]
    Backend {
        /// Output file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// The file extension is neither `.svg` nor `.png`.
    #[error("{path}: unsupported plot format (use .svg or .png)")]
    Format {
        /// Output file.
        path: PathBuf,
    },
}

const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

/// Writes the curves to `path` (`.svg` or `.png`, 1000 × 600 pixels).
pub fn plot_curves(path: &Path, labels: &PlotLabels, series: &[Series]) -> Result<(), PlotError> {
    register_font();
    let finite = |v: &f64| v.is_finite();
    let xs: Vec<f64> = series.iter().flat_map(|s| s.x.iter().copied()).filter(finite).collect();
    let ys: Vec<f64> = series
        .iter()
        .flat_map(|s| s.y.iter().chain(s.lower.iter().flatten()).chain(s.upper.iter().flatten()).copied())
        .filter(finite)
        .collect();
    if xs.is_empty() || ys.is_empty() {
        return Err(PlotError::Empty { path: path.to_path_buf() });
    }
    let range = ranges(&xs, &ys);
    render(path, (1000, 600), &Figure::Curves { labels, series, range })
}

/// One small chart of [`plot_panels`]: a titled curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    /// Title (the metric's name).
    pub title: String,
    /// `(x, y)` points; non-finite ones are skipped.
    pub points: Vec<(f64, f64)>,
}

/// Writes `panels` as a grid of small charts (three per row, 420 × 260 pixels each) with a
/// common x-axis title; panels without a finite point are left out.
pub fn plot_panels(path: &Path, title: &str, x: &str, panels: &[Panel]) -> Result<(), PlotError> {
    register_font();
    let drawn: Vec<&Panel> =
        panels.iter().filter(|p| p.points.iter().any(|(x, y)| x.is_finite() && y.is_finite())).collect();
    if drawn.is_empty() {
        return Err(PlotError::Empty { path: path.to_path_buf() });
    }
    let rows = drawn.len().div_ceil(3);
    render(path, (1260, 40 + 260 * rows as u32), &Figure::Panels { title, x, panels: &drawn })
}

/// The drawing range of the finite `xs` and `ys` (non-empty), with 5 % room on y.
fn ranges(xs: &[f64], ys: &[f64]) -> (f64, f64, f64, f64) {
    let (x0, x1) = min_max(xs);
    let (y0, y1) = min_max(ys);
    // A flat curve gets ±5 % of its value (±1 at zero), so that its ticks read as its value.
    let pad = if y1 > y0 {
        (y1 - y0) * 0.05
    } else if y0 != 0.0 {
        (y0.abs() * 0.05).max(1e-300)
    } else {
        1.0
    };
    (x0, if x1 > x0 { x1 } else { x0 + 1.0 }, y0 - pad, y1 + pad)
}

/// What a file shows.
enum Figure<'a> {
    Curves { labels: &'a PlotLabels, series: &'a [Series], range: (f64, f64, f64, f64) },
    Panels { title: &'a str, x: &'a str, panels: &'a [&'a Panel] },
}

fn paint<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    figure: &Figure<'_>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    match figure {
        Figure::Curves { labels, series, range } => draw(root, labels, series, *range, &Frame::FULL),
        Figure::Panels { title, x, panels } => {
            root.fill(&WHITE)?;
            let body = root.titled(title, ("sans-serif", 22))?;
            let rows = panels.len().div_ceil(3);
            for (area, panel) in body.split_evenly((rows, 3)).iter().zip(panels.iter()) {
                let pts: Vec<(f64, f64)> =
                    panel.points.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
                let (xs, ys): (Vec<f64>, Vec<f64>) = pts.iter().copied().unzip();
                let labels = PlotLabels { title: panel.title.clone(), x: x.to_string(), y: String::new() };
                let range = ranges(&xs, &ys);
                let series = Series { label: String::new(), x: xs, y: ys, lower: None, upper: None };
                draw(area, &labels, std::slice::from_ref(&series), range, &Frame::PANEL)?;
            }
            Ok(())
        }
    }
}

/// Renders `figure` to `path` (`.svg` or `.png`) at `size` pixels.
fn render(path: &Path, (w, h): (u32, u32), figure: &Figure<'_>) -> Result<(), PlotError> {
    let err =
        |e: &dyn std::fmt::Display| PlotError::Backend { path: path.to_path_buf(), message: e.to_string() };
    match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => {
            let root = SVGBackend::new(path, (w, h)).into_drawing_area();
            paint(&root, figure).map_err(|e| err(&e))?;
            root.present().map_err(|e| err(&e))?;
        }
        Some("png") => {
            let mut buf = vec![0u8; (w * h * 3) as usize];
            {
                let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
                paint(&root, figure).map_err(|e| err(&e))?;
                root.present().map_err(|e| err(&e))?;
            }
            let file = std::fs::File::create(path).map_err(|e| err(&e))?;
            let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut writer = enc.write_header().map_err(|e| err(&e))?;
            writer.write_image_data(&buf).map_err(|e| err(&e))?;
            writer.finish().map_err(|e| err(&e))?;
        }
        _ => return Err(PlotError::Format { path: path.to_path_buf() }),
    }
    Ok(())
}

/// Decimals for tick labels of an axis spanning `range`.
fn decimals(range: f64) -> usize {
    if range >= 50.0 {
        0
    } else if range >= 1.0 {
        1
    } else if range >= 0.1 {
        3
    } else {
        // Two digits past the first one that changes across the axis.
        ((-range.log10()).ceil() as usize + 2).min(8)
    }
}

fn min_max(v: &[f64]) -> (f64, f64) {
    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(*x), b.max(*x)))
}

/// Sizes of a chart's parts (pixels, font points).
struct Frame {
    caption: u32,
    margin: u32,
    x_area: u32,
    y_area: u32,
    labels: u32,
    /// Tick labels on x and y (`None`: plotters' default).
    ticks: Option<(usize, usize)>,
}

impl Frame {
    /// A whole figure.
    const FULL: Frame = Frame { caption: 24, margin: 15, x_area: 45, y_area: 70, labels: 14, ticks: None };
    /// One of [`plot_panels`]'s small charts.
    const PANEL: Frame =
        Frame { caption: 15, margin: 8, x_area: 40, y_area: 60, labels: 11, ticks: Some((4, 5)) };
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    labels: &PlotLabels,
    series: &[Series],
    (x0, x1, y0, y1): (f64, f64, f64, f64),
    frame: &Frame,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(&labels.title, ("sans-serif", frame.caption))
        .margin(frame.margin)
        .x_label_area_size(frame.x_area)
        .y_label_area_size(frame.y_area)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    let (x_dec, y_dec) = (decimals(x1 - x0), decimals(y1 - y0));
    let fx = move |v: &f64| format!("{v:.x_dec$}");
    // Small quantities (learning rates, KL) in scientific notation.
    let tiny = y0.abs().max(y1.abs()) < 1e-2;
    let fy = move |v: &f64| if tiny { format!("{v:.2e}") } else { format!("{v:.y_dec$}") };
    let mut mesh = chart.configure_mesh();
    if let Some((nx, ny)) = frame.ticks {
        mesh.x_labels(nx).y_labels(ny);
    }
    mesh.x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .x_desc(&labels.x)
        .y_desc(&labels.y)
        .label_style(("sans-serif", frame.labels))
        .axis_desc_style(("sans-serif", frame.labels + 2))
        .draw()?;
    for (k, s) in series.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        if let (Some(lo), Some(hi)) = (&s.lower, &s.upper) {
            // The band as a polygon: upper edge forward, lower edge back.
            let pts: Vec<(f64, f64)> =
                s.x.iter()
                    .zip(hi)
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .map(|(x, y)| (*x, *y))
                    .chain(
                        s.x.iter()
                            .zip(lo)
                            .rev()
                            .filter(|(x, y)| x.is_finite() && y.is_finite())
                            .map(|(x, y)| (*x, *y)),
                    )
                    .collect();
            if pts.len() >= 3 {
                chart.draw_series(std::iter::once(Polygon::new(pts, color.mix(0.2).filled())))?;
            }
        }
        let line: Vec<(f64, f64)> =
            s.x.iter()
                .zip(&s.y)
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .map(|(x, y)| (*x, *y))
                .collect();
        chart
            .draw_series(LineSeries::new(line, color.stroke_width(2)))?
            .label(s.label.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2)));
    }
    if series.iter().any(|s| !s.label.is_empty()) {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .position(SeriesLabelPosition::LowerRight)
            .draw()?;
    }
    Ok(())
}
