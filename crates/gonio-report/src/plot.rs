//! Plots as SVG text (plotters' SVG backend), one function per figure of a report.
//!
//! Every axis is labelled `quantity / unit` (ISO 80000-1), text uses the embedded font
//! ([`crate::font`]), and colours are the Okabe–Ito palette (distinguishable with the common
//! colour-vision deficiencies).

use crate::ReportError;
use crate::batch::{BatchView, PartView, TurnView};
use crate::font::{self, FAMILY};
use gonio_calib::certificate::Certificate;
use gonio_calib::compare::Comparison;
use gonio_station::published::YU_2024;
use plotters::chart::MeshStyle;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::FontStyle;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One figure: a stable id (the file name with `--plots`), a title, a caption and the SVG.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// File-name-safe id, e.g. `alpha`.
    pub id: String,
    /// Title shown above it.
    pub title: String,
    /// What it shows, one or two sentences.
    pub caption: String,
    /// The SVG document.
    pub svg: String,
}

impl Figure {
    /// The SVG as a file of its own: the embedded font added, so that it renders the same
    /// anywhere.
    pub fn standalone_svg(&self) -> String {
        let style = format!("<defs><style>{}</style></defs>", font::css_font_faces());
        match self
            .svg
            .find("<svg")
            .and_then(|i| self.svg[i..].find('>').map(|j| i + j + 1))
        {
            Some(at) => format!("{}{}{}", &self.svg[..at], style, &self.svg[at..]),
            None => self.svg.clone(),
        }
    }
}

/// Width and height of a standard figure, px.
pub(crate) const SIZE: (u32, u32) = (860, 400);
pub(crate) const TICK: u32 = 17;
const DESC: u32 = 19;

/// Okabe–Ito colours.
pub(crate) const BLUE: RGBColor = RGBColor(0, 114, 178);
pub(crate) const ORANGE: RGBColor = RGBColor(230, 159, 0);
pub(crate) const GREEN: RGBColor = RGBColor(0, 158, 115);
pub(crate) const VERMILION: RGBColor = RGBColor(213, 94, 0);
pub(crate) const SKY: RGBColor = RGBColor(86, 180, 233);
pub(crate) const PURPLE: RGBColor = RGBColor(204, 121, 167);
pub(crate) const GREY: RGBColor = RGBColor(110, 110, 110);
const GRID: RGBColor = RGBColor(232, 232, 232);
const PALETTE: [RGBColor; 7] = [BLUE, VERMILION, GREEN, ORANGE, PURPLE, SKY, BLACK];

pub(crate) fn err<E: std::fmt::Debug>(what: &str) -> impl FnOnce(E) -> ReportError + '_ {
    move |e| ReportError::Plot {
        figure: what.to_string(),
        message: format!("{e:?}"),
    }
}

pub(crate) fn tick() -> TextStyle<'static> {
    (FAMILY, TICK).into_font().into()
}

fn desc() -> TextStyle<'static> {
    (FAMILY, DESC).into_font().into()
}

fn note(size: u32, color: RGBColor) -> TextStyle<'static> {
    (FAMILY, size).into_font().color(&color)
}

fn bold(size: u32) -> TextStyle<'static> {
    (FAMILY, size, FontStyle::Bold).into_font().into()
}

/// A range that includes every value with a margin, never empty.
pub(crate) fn range(values: impl Iterator<Item = f64>, margin: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let span = (hi - lo).max(hi.abs().max(lo.abs()) * 1e-3).max(1e-9);
    (lo - margin * span, hi + margin * span)
}

/// Decimal places that show a step of `span/count` distinctly.
pub(crate) fn decimals(span: f64, count: usize) -> usize {
    let step = span / count.max(1) as f64;
    if step <= 0.0 || !step.is_finite() {
        return 2;
    }
    (-(step.log10().floor()) as i32).clamp(0, 6) as usize
}

pub(crate) fn render(
    id: &str,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), ReportError>,
) -> Result<String, ReportError> {
    font::register();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(err(id))?;
        draw(&root)?;
        root.present().map_err(err(id))?;
    }
    Ok(svg)
}

/// Margins and label areas of one chart, px.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Frame {
    pub(crate) margin: u32,
    margin_right: u32,
    pub(crate) x_area: u32,
    y_area: u32,
}

impl Frame {
    /// This frame with an x label area of `px`.
    const fn x_area(self, px: u32) -> Self {
        Self { x_area: px, ..self }
    }
}

/// The frame of a standard figure.
pub(crate) const FRAME: Frame = Frame {
    margin: 14,
    margin_right: 24,
    x_area: 52,
    y_area: 86,
};

/// A Cartesian chart of plotters over the ranges `X` and `Y`.
type Chart<'a, DB, X, Y> = ChartContext<
    'a,
    DB,
    Cartesian2d<<X as AsRangedCoord>::CoordDescType, <Y as AsRangedCoord>::CoordDescType>,
>;

/// A Cartesian chart on `area` in `frame`, with an optional caption above it.
pub(crate) fn cartesian<'a, DB: DrawingBackend, X: AsRangedCoord, Y: AsRangedCoord>(
    area: &'a DrawingArea<DB, Shift>,
    id: &str,
    frame: Frame,
    caption: Option<&str>,
    x: X,
    y: Y,
) -> Result<Chart<'a, DB, X, Y>, ReportError> {
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(frame.margin)
        .margin_right(frame.margin_right);
    if let Some(c) = caption {
        builder.caption(c, bold(TICK));
    }
    builder
        .x_label_area_size(frame.x_area)
        .y_label_area_size(frame.y_area)
        .build_cartesian_2d(x, y)
        .map_err(err(id))
}

/// The house mesh of `chart`: axis descriptions (`y_desc` none for a labelled category
/// axis), text styles and the grid; the caller adds the labels and draws it.
pub(crate) fn mesh<'a, 'b, DB, X, Y, XT, YT>(
    chart: &'b mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    x_desc: &str,
    y_desc: Option<&str>,
) -> MeshStyle<'a, 'b, X, Y, DB>
where
    DB: DrawingBackend,
    X: Ranged<ValueType = XT> + ValueFormatter<XT>,
    Y: Ranged<ValueType = YT> + ValueFormatter<YT>,
{
    let mut m = chart.configure_mesh();
    m.x_desc(x_desc);
    if let Some(y) = y_desc {
        m.y_desc(y);
    }
    m.axis_desc_style(desc())
        .label_style(tick())
        .light_line_style(TRANSPARENT)
        .bold_line_style(GRID);
    m
}

/// The mesh of a chart over a whole turn (x 0…360°, a label every 30°) with `y_labels` values
/// on a y span of `y_span`, drawn.
fn turn_mesh<'a, DB: DrawingBackend, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, Y>>,
    id: &str,
    (x_desc, y_desc): (&str, &str),
    y_span: f64,
    y_labels: usize,
) -> Result<(), ReportError>
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    mesh(chart, x_desc, Some(y_desc))
        .x_labels(13)
        .y_labels(y_labels)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| fixed(*v, decimals(y_span, y_labels)))
        .draw()
        .map_err(err(id))
}

/// The legend box (upper right) of `chart`, its text `size` px, drawn.
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    id: &str,
    size: u32,
) -> Result<(), ReportError> {
    legend_at(chart, id, size, SeriesLabelPosition::UpperRight)
}

/// The legend box of `chart` at `position`, its text `size` px, drawn.
pub(crate) fn legend_at<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    id: &str,
    size: u32,
    position: SeriesLabelPosition,
) -> Result<(), ReportError> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(GREY)
        .label_font(note(size, BLACK))
        .draw()
        .map_err(err(id))
}

/// Indices of at most ~`max` points keeping each bucket's smallest and largest value (the
/// envelope survives decimation).
fn decimate(values: &[f64], max: usize) -> Vec<usize> {
    if values.len() <= max {
        return (0..values.len()).collect();
    }
    let buckets = (max / 2).max(1);
    let per = values.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(2 * buckets + 1);
    for start in (0..values.len()).step_by(per) {
        let end = (start + per).min(values.len());
        let (mut lo, mut hi) = (start, start);
        for i in start..end {
            if values[i] < values[lo] {
                lo = i;
            }
            if values[i] > values[hi] {
                hi = i;
            }
        }
        out.push(lo.min(hi));
        if lo != hi {
            out.push(lo.max(hi));
        }
    }
    out
}

/// `v` with `d` decimals, without a minus sign on zero.
pub(crate) fn fixed(v: f64, d: usize) -> String {
    let s = format!("{v:.d$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

fn arcsec(v: f64) -> String {
    format!("{v:.4}″")
}

/// Where a legend of `labels` (text `TICK` px) goes above a curve over a whole turn so that it
/// covers none of its points `(θ / °, top value)`: the upper corner (right, else left) that
/// needs the least room above the curve, and the top of the y range `y1` raised to make that
/// room when the data reach into the legend's corner (`y0 … y1`: the range of the data with
/// its margin). A standard figure ([`SIZE`], [`FRAME`]); the legend's size is estimated from
/// its lines and their longest label (plotters: 5 px from the corner, ≈ 21.5 px a line,
/// ≈ 8.6 px a character of the tick font and 40 px for the marker and padding).
fn legend_room(
    points: &[(f64, f64)],
    labels: &[String],
    (y0, y1): (f64, f64),
) -> (SeriesLabelPosition, f64) {
    let plot_w = f64::from(SIZE.0 - FRAME.margin - FRAME.margin_right - FRAME.y_area);
    let plot_h = f64::from(SIZE.1 - 2 * FRAME.margin - FRAME.x_area);
    let chars = labels.iter().map(|l| l.chars().count()).max().unwrap_or(0);
    // The legend's extent from the plot's corner, with a gap of 6 px around it.
    let width_px = 5.0 + 40.0 + 8.6 * chars as f64 + 6.0;
    let height_px = 5.0 + 11.0 + 21.5 * labels.len() as f64 + 6.0;
    let width_deg = 360.0 * width_px / plot_w;
    let f = (height_px / plot_h).min(0.9);
    // The top of the y range that puts the highest point under the legend's corner below it.
    let need = |inside: &dyn Fn(f64) -> bool| {
        let top = points
            .iter()
            .filter(|p| inside(p.0))
            .map(|p| p.1)
            .filter(|v| v.is_finite())
            .fold(f64::NEG_INFINITY, f64::max);
        if top.is_finite() {
            y1.max((top - f * y0) / (1.0 - f))
        } else {
            y1
        }
    };
    let right = need(&|x| x >= 360.0 - width_deg);
    let left = need(&|x| x <= width_deg);
    if left < right {
        (SeriesLabelPosition::UpperLeft, left)
    } else {
        (SeriesLabelPosition::UpperRight, right)
    }
}

/// α(θ) with the ±U band and the measured points coloured by shift.
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn alpha(cert: &Certificate) -> Result<Figure, ReportError> {
    let pts = &cert.points;
    let values: Vec<f64> = pts.iter().map(|p| p.value_arcsec).collect();
    let keep = decimate(&values, 4000);
    let has_u = pts.iter().any(|p| p.expanded_arcsec.is_some());
    let (y0, y1) = range(
        pts.iter().flat_map(|p| {
            let u = p.expanded_arcsec.unwrap_or(0.0);
            [p.value_arcsec - u, p.value_arcsec + u]
        }),
        0.08,
    );
    let shifts: Vec<f64> = cert
        .shift_angle
        .as_ref()
        .map(|s| s.shifts_deg.clone())
        .unwrap_or_default();
    let k = pts.iter().find_map(|p| p.k);
    let band_label = match (k, cert.points.iter().find_map(|p| p.p)) {
        (Some(k), Some(p)) => format!("±U (k = {k:.2}, p = {:.0} %)", p * 100.0),
        _ => "±U".to_string(),
    };
    let show_shifts = !shifts.is_empty() && pts.len() <= 4000;
    let many = shifts.len() > PALETTE.len();
    let shift_label = |si: usize| {
        if !many || si == 0 {
            Some(format!("measured, S = {}°", shifts[si]))
        } else if si == 1 {
            Some(format!(
                "measured, S = {}° … {}°",
                shifts[1],
                shifts[shifts.len() - 1]
            ))
        } else {
            None
        }
    };
    // The legend's lines, and room for it above the curve.
    let mut labels: Vec<String> = has_u.then(|| band_label.clone()).into_iter().collect();
    labels.push("α(θ)".into());
    if show_shifts {
        labels.extend((0..shifts.len()).filter_map(shift_label));
    }
    let tops: Vec<(f64, f64)> = pts
        .iter()
        .map(|p| {
            (
                p.angle_deg,
                p.value_arcsec + p.expanded_arcsec.unwrap_or(0.0),
            )
        })
        .collect();
    let (corner, y1) = legend_room(&tops, &labels, (y0, y1));
    let svg = render("alpha", SIZE, |root| {
        let mut chart = cartesian(root, "alpha", FRAME, None, 0f64..360f64, y0..y1)?;
        turn_mesh(
            &mut chart,
            "alpha",
            ("angle θ / °", "encoder error α / ″"),
            y1 - y0,
            9,
        )?;
        if has_u {
            let mut band: Vec<(f64, f64)> = keep
                .iter()
                .map(|&i| &pts[i])
                .filter_map(|p| p.expanded_arcsec.map(|u| (p.angle_deg, p.value_arcsec + u)))
                .collect();
            let lower: Vec<(f64, f64)> = keep
                .iter()
                .rev()
                .map(|&i| &pts[i])
                .filter_map(|p| p.expanded_arcsec.map(|u| (p.angle_deg, p.value_arcsec - u)))
                .collect();
            band.extend(lower);
            chart
                .draw_series(std::iter::once(Polygon::new(band, SKY.mix(0.35).filled())))
                .map_err(err("alpha"))?
                .label(band_label.clone())
                .legend(|(x, y)| {
                    Rectangle::new([(x, y - 6), (x + 18, y + 6)], SKY.mix(0.35).filled())
                });
        }
        chart
            .draw_series(LineSeries::new(
                keep.iter()
                    .map(|&i| (pts[i].angle_deg, pts[i].value_arcsec)),
                BLUE.stroke_width(2),
            ))
            .map_err(err("alpha"))?
            .label("α(θ)")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLUE.stroke_width(2)));
        if show_shifts {
            for (si, s) in shifts.iter().enumerate() {
                let color = if many {
                    if si == 0 { BLACK } else { VERMILION }
                } else {
                    PALETTE[si % PALETTE.len()]
                };
                let series = chart
                    .draw_series(
                        pts.iter()
                            .filter(|p| p.shift_deg == Some(*s))
                            .map(|p| Circle::new((p.angle_deg, p.value_arcsec), 3, color.filled())),
                    )
                    .map_err(err("alpha"))?;
                if let Some(l) = shift_label(si) {
                    series
                        .label(l)
                        .legend(move |(x, y)| Circle::new((x + 9, y), 3, color.filled()));
                }
            }
        }
        legend_at(&mut chart, "alpha", TICK, corner)?;
        Ok(())
    })?;
    let caption = if has_u {
        format!(
            "The encoder's angle error α at each of the {} calibrated angles with its expanded uncertainty U (shaded); largest |α| {}, largest U {}.",
            pts.len(),
            arcsec(cert.max_abs_error_arcsec()),
            arcsec(cert.max_expanded_arcsec().unwrap_or(f64::NAN))
        )
    } else {
        format!(
            "The encoder's angle error α at each of the {} calibrated angles (no expanded uncertainty: the random part is unknown).",
            pts.len()
        )
    };
    Ok(Figure {
        id: "alpha".into(),
        title: "Encoder angle error α(θ)".into(),
        caption,
        svg,
    })
}

/// The compensation curve: the correction to add to the encoder's reading.
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn compensation(cert: &Certificate) -> Result<Figure, ReportError> {
    let c = &cert.compensation;
    let values: Vec<f64> = c.iter().map(|r| r.correction_arcsec).collect();
    let keep = decimate(&values, 4000);
    let (y0, y1) = range(values.iter().copied(), 0.08);
    let svg =
        render("compensation", SIZE, |root| {
            let mut chart = cartesian(root, "compensation", FRAME, None, 0f64..360f64, y0..y1)?;
            turn_mesh(
                &mut chart,
                "compensation",
                ("encoder reading θ / °", "correction −α / ″"),
                y1 - y0,
                9,
            )?;
            chart
                .draw_series(LineSeries::new(
                    keep.iter()
                        .map(|&i| (c[i].angle_deg, c[i].correction_arcsec)),
                    GREEN.stroke_width(2),
                ))
                .map_err(err("compensation"))?;
            if c.len() <= 720 {
                chart
                    .draw_series(c.iter().map(|r| {
                        Circle::new((r.angle_deg, r.correction_arcsec), 2, GREEN.filled())
                    }))
                    .map_err(err("compensation"))?;
            }
            Ok(())
        })?;
    Ok(Figure {
        id: "compensation".into(),
        title: "Compensation curve".into(),
        caption: format!(
            "The correction to add to the encoder's reading at {} angles (−α; the table is in the certificate JSON and `--compensation`).",
            c.len()
        ),
        svg,
    })
}

/// The polygon's pitch deviation β per face with its expanded uncertainty.
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn pitch(cert: &Certificate) -> Result<Option<Figure>, ReportError> {
    let Some(b) = cert.pitch_deviations() else {
        return Ok(None);
    };
    let bar = |p: &gonio_calib::certificate::PitchDeviation| {
        p.expanded_arcsec.unwrap_or(if p.u_arcsec.is_finite() {
            p.u_arcsec
        } else {
            0.0
        })
    };
    let with_u = b.iter().any(|p| p.expanded_arcsec.is_some());
    let (y0, y1) = range(
        b.iter()
            .flat_map(|p| [p.value_arcsec - bar(p), p.value_arcsec + bar(p)]),
        0.1,
    );
    let n = b.len() as f64;
    let svg = render("pitch", SIZE, |root| {
        let mut chart = cartesian(root, "pitch", FRAME, None, 0.5f64..n + 0.5, y0..y1)?;
        mesh(&mut chart, "polygon face k", Some("pitch deviation β / ″"))
            .x_labels((b.len() + 1).min(25))
            .y_labels(9)
            .x_label_formatter(&|v| {
                if (v - v.round()).abs() < 1e-9 && *v >= 1.0 {
                    format!("{v:.0}")
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&|v| fixed(*v, decimals(y1 - y0, 9)))
            .draw()
            .map_err(err("pitch"))?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                [(0.5, 0.0), (n + 0.5, 0.0)],
                GREY.stroke_width(1),
            )))
            .map_err(err("pitch"))?;
        chart
            .draw_series(b.iter().map(|p| {
                let x = p.face as f64;
                let u = bar(p);
                PathElement::new(
                    [(x, p.value_arcsec - u), (x, p.value_arcsec + u)],
                    BLUE.stroke_width(2),
                )
            }))
            .map_err(err("pitch"))?;
        chart
            .draw_series(
                b.iter()
                    .map(|p| Circle::new((p.face as f64, p.value_arcsec), 4, BLUE.filled())),
            )
            .map_err(err("pitch"))?;
        Ok(())
    })?;
    Ok(Some(Figure {
        id: "pitch".into(),
        title: "Polygon pitch deviations β".into(),
        caption: format!(
            "β per face (Σβ = 0) with {} (the estimator's random part).",
            if with_u {
                "its expanded uncertainty U"
            } else {
                "its standard uncertainty u"
            }
        ),
        svg,
    }))
}

/// Residuals of every reading: histogram with the normal density of σ̂, and against reading
/// order.
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn residuals(cert: &Certificate) -> Result<Vec<Figure>, ReportError> {
    let Some(sa) = &cert.shift_angle else {
        return Ok(Vec::new());
    };
    let r = &sa.reading_residuals_arcsec;
    if r.is_empty() {
        return Ok(Vec::new());
    }
    let sigma = cert
        .residuals
        .sigma_hat_arcsec
        .unwrap_or(cert.residuals.rms_arcsec);
    let max = r
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(3.0 * sigma)
        .max(1e-9);
    let bins = ((r.len() as f64).sqrt().round() as usize).clamp(8, 60);
    let width = 2.0 * max / bins as f64;
    let mut counts = vec![0usize; bins];
    for v in r {
        let i = (((v + max) / width).floor() as isize).clamp(0, bins as isize - 1) as usize;
        counts[i] += 1;
    }
    let top = counts.iter().copied().max().unwrap_or(1) as f64;
    let expected_peak = r.len() as f64 * width / (sigma * (2.0 * std::f64::consts::PI).sqrt());
    let ytop = top.max(expected_peak) * 1.12;
    let dec = decimals(2.0 * max, 8);
    let hist = render("residual-histogram", SIZE, |root| {
        let mut chart = cartesian(
            root,
            "residual-histogram",
            FRAME,
            None,
            -max..max,
            0.0..ytop,
        )?;
        mesh(
            &mut chart,
            "residual (reading − model) / ″",
            Some("readings per bin"),
        )
        .x_labels(9)
        .y_labels(7)
        .x_label_formatter(&|v| fixed(*v, dec))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .draw()
        .map_err(err("residual-histogram"))?;
        chart
            .draw_series(counts.iter().enumerate().map(|(i, &c)| {
                let x = -max + i as f64 * width;
                Rectangle::new([(x, 0.0), (x + width, c as f64)], BLUE.mix(0.55).filled())
            }))
            .map_err(err("residual-histogram"))?
            .label(format!("{} readings", r.len()))
            .legend(|(x, y)| {
                Rectangle::new([(x, y - 6), (x + 18, y + 6)], BLUE.mix(0.55).filled())
            });
        let pdf = |x: f64| expected_peak * (-0.5 * (x / sigma).powi(2)).exp();
        chart
            .draw_series(LineSeries::new(
                (0..=200).map(|i| {
                    let x = -max + 2.0 * max * i as f64 / 200.0;
                    (x, pdf(x))
                }),
                VERMILION.stroke_width(2),
            ))
            .map_err(err("residual-histogram"))?
            .label(format!("normal, σ̂ = {}", arcsec(sigma)))
            .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], VERMILION.stroke_width(2)));
        legend(&mut chart, "residual-histogram", TICK)?;
        Ok(())
    })?;
    let n = r.len() as f64;
    let order = render("residuals", SIZE, |root| {
        let mut chart = cartesian(
            root,
            "residuals",
            FRAME,
            None,
            0.0..n + 1.0,
            -max * 1.05..max * 1.05,
        )?;
        mesh(
            &mut chart,
            "reading number (file order)",
            Some("residual / ″"),
        )
        .x_labels(10)
        .y_labels(9)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| fixed(*v, dec))
        .draw()
        .map_err(err("residuals"))?;
        chart
            .draw_series(
                r.iter()
                    .enumerate()
                    .map(|(i, &v)| Circle::new(((i + 1) as f64, v), 2, BLUE.mix(0.7).filled())),
            )
            .map_err(err("residuals"))?;
        for s in [-2.0, 2.0] {
            chart
                .draw_series(DashedLineSeries::new(
                    [(0.0, s * sigma), (n + 1.0, s * sigma)],
                    8,
                    5,
                    VERMILION.stroke_width(2),
                ))
                .map_err(err("residuals"))?;
        }
        chart
            .draw_series(std::iter::once(Text::new(
                "±2σ̂",
                (n * 0.985, 2.0 * sigma),
                note(TICK, VERMILION).pos(Pos::new(HPos::Right, VPos::Bottom)),
            )))
            .map_err(err("residuals"))?;
        Ok(())
    })?;
    Ok(vec![
        Figure {
            id: "residual-histogram".into(),
            title: "Residuals: distribution".into(),
            caption: format!(
                "Residuals of all {} readings against the fitted model, with the normal density of σ̂ = {} (RMS {}, largest |r| {}).",
                r.len(),
                arcsec(sigma),
                arcsec(cert.residuals.rms_arcsec),
                arcsec(cert.residuals.max_abs_arcsec)
            ),
            svg: hist,
        },
        Figure {
            id: "residuals".into(),
            title: "Residuals against reading order".into(),
            caption: "Every reading's residual in the order of the readings file: drift or a step shows as a trend.".into(),
            svg: order,
        },
    ])
}

/// The harmonic amplitude spectrum of α, with each method's invisible orders marked.
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn spectrum(cert: &Certificate) -> Result<Option<Figure>, ReportError> {
    let s = &cert.spectrum;
    let lines: Vec<_> = s
        .lines
        .iter()
        .filter(|l| l.visible && l.amplitude_arcsec > 0.0)
        .collect();
    if lines.is_empty() {
        return Ok(None);
    }
    let kmax = s.lines.iter().map(|l| l.order).max().unwrap_or(1) as f64;
    let amax = lines.iter().map(|l| l.amplitude_arcsec).fold(0.0, f64::max);
    let mut amps: Vec<f64> = lines.iter().map(|l| l.amplitude_arcsec).collect();
    amps.sort_by(f64::total_cmp);
    let floor = (amps[amps.len() / 20] / 3.0).max(amax * 1e-6);
    let (y0, y1) = (floor, amax * 3.0);
    let mut noise: Vec<f64> = lines
        .iter()
        .map(|l| l.u_amplitude_arcsec)
        .filter(|u| u.is_finite() && *u > 0.0)
        .collect();
    noise.sort_by(f64::total_cmp);
    let noise2 = noise.get(noise.len() / 2).map(|u| 2.0 * u);
    let svg = render("spectrum", SIZE, |root| {
        let mut chart = cartesian(
            root,
            "spectrum",
            FRAME,
            None,
            0f64..kmax + 1.0,
            (y0..y1).log_scale(),
        )?;
        mesh(
            &mut chart,
            "harmonic order (cycles per turn)",
            Some("amplitude / ″"),
        )
        .x_labels(12)
        .y_labels(8)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| {
            if *v >= 1.0 {
                format!("{v:.0}")
            } else {
                let d = (-(v.log10().floor()) as usize).min(7);
                format!("{v:.d$}")
            }
        })
        .draw()
        .map_err(err("spectrum"))?;
        let marks = [VERMILION, PURPLE, ORANGE];
        for (i, inv) in s.invisible.iter().enumerate() {
            let color = marks[i % marks.len()];
            let orders: Vec<u32> = inv
                .orders
                .iter()
                .copied()
                .filter(|&k| (k as f64) <= kmax)
                .collect();
            if orders.is_empty() {
                continue;
            }
            let dash = chart
                .draw_series(orders.iter().map(|&k| {
                    PathElement::new(
                        [(k as f64, y0), (k as f64, y1)],
                        color.mix(0.8).stroke_width(2),
                    )
                }))
                .map_err(err("spectrum"))?;
            dash.label(format!("invisible to the {}", inv.by))
                .legend(move |(x, y)| {
                    PathElement::new([(x + 9, y - 7), (x + 9, y + 7)], color.stroke_width(2))
                });
        }
        if let Some(n2) = noise2.filter(|n| *n > y0) {
            chart
                .draw_series(DashedLineSeries::new(
                    [(0.0, n2), (kmax + 1.0, n2)],
                    6,
                    4,
                    GREY.stroke_width(1),
                ))
                .map_err(err("spectrum"))?
                .label(format!("2·u(A) = {}", arcsec(n2)))
                .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], GREY.stroke_width(1)));
        }
        chart
            .draw_series(lines.iter().map(|l| {
                PathElement::new(
                    [
                        (l.order as f64, y0),
                        (l.order as f64, l.amplitude_arcsec.max(y0)),
                    ],
                    BLUE.stroke_width(if kmax > 200.0 { 1 } else { 2 }),
                )
            }))
            .map_err(err("spectrum"))?
            .label("amplitude A_k")
            .legend(|(x, y)| {
                PathElement::new([(x + 9, y - 7), (x + 9, y + 7)], BLUE.stroke_width(2))
            });
        legend(&mut chart, "spectrum", TICK)?;
        Ok(())
    })?;
    let blind: Vec<String> = s
        .invisible
        .iter()
        .map(|i| {
            let shown: Vec<String> = i.orders.iter().take(8).map(|k| k.to_string()).collect();
            format!(
                "the {} cannot see orders {}{}",
                i.by,
                shown.join(", "),
                if i.orders.len() > 8 { ", …" } else { "" }
            )
        })
        .collect();
    Ok(Some(Figure {
        id: "spectrum".into(),
        title: "Harmonic amplitude spectrum of α".into(),
        caption: format!(
            "Amplitude of each harmonic of α(θ) (log scale); {}. {}",
            blind.join("; "),
            if s.invisible.len() > 1 {
                "The joint estimate holds every order one of the instruments sees; only the orders invisible to both are absent from the result, whatever the encoder has there."
            } else {
                "Those orders are absent from the result, whatever the encoder has there."
            }
        ),
        svg,
    }))
}

/// Horizontal bars of each budget row's share of u_c².
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn budget_shares(cert: &Certificate) -> Result<Option<Figure>, ReportError> {
    let Some(b) = &cert.budget else {
        return Ok(None);
    };
    let rows = &b.contributions;
    let n = rows.len();
    let longest = rows
        .iter()
        .map(|r| r.name.chars().count())
        .max()
        .unwrap_or(10);
    let label_px = (longest as u32 * 9 + 20).clamp(120, 360);
    let height = (70 + 38 * n as u32).max(180);
    let names: Vec<String> = rows.iter().map(|r| r.name.clone()).collect();
    let svg = render("budget", (SIZE.0, height), |root| {
        let frame = Frame {
            margin_right: 40,
            y_area: label_px,
            ..FRAME
        };
        let mut chart = cartesian(
            root,
            "budget",
            frame,
            None,
            0f64..100f64,
            -0.5f64..n as f64 - 0.5,
        )?;
        mesh(&mut chart, "share of u_c² / %", None)
            .disable_y_mesh()
            .x_labels(11)
            .y_labels(n)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| {
                let i = v.round();
                if (v - i).abs() < 1e-6 && i >= 0.0 && (i as usize) < n {
                    names[n - 1 - i as usize].clone()
                } else {
                    String::new()
                }
            })
            .draw()
            .map_err(err("budget"))?;
        chart
            .draw_series(rows.iter().enumerate().map(|(i, r)| {
                let y = (n - 1 - i) as f64;
                Rectangle::new(
                    [(0.0, y - 0.32), (r.share * 100.0, y + 0.32)],
                    BLUE.filled(),
                )
            }))
            .map_err(err("budget"))?;
        chart
            .draw_series(rows.iter().enumerate().map(|(i, r)| {
                let y = (n - 1 - i) as f64;
                let x = r.share * 100.0;
                let (pos, at) = if x > 85.0 {
                    (Pos::new(HPos::Right, VPos::Center), x - 1.0)
                } else {
                    (Pos::new(HPos::Left, VPos::Center), x + 1.0)
                };
                let color = if x > 85.0 { WHITE } else { BLACK };
                Text::new(
                    format!("{:.1} %", r.share * 100.0),
                    (at, y),
                    note(TICK, color).pos(pos),
                )
            }))
            .map_err(err("budget"))?;
        Ok(())
    })?;
    Ok(Some(Figure {
        id: "budget".into(),
        title: "Uncertainty budget: shares".into(),
        caption: format!(
            "Each contribution's share (c_i·u_i)²/u_c² of the combined variance, at the angle with the largest U ({}).",
            b.name
        ),
        svg,
    }))
}

/// Differences of two calibrations with their U bars, and En per angle (dot-and-bar); the
/// largest En is called out.
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn comparison(c: &Comparison) -> Result<Figure, ReportError> {
    let p = &c.points;
    let ud =
        |q: &gonio_calib::compare::ComparePoint| q.expanded_a_arcsec.hypot(q.expanded_b_arcsec);
    let (y0, y1) = range(
        p.iter()
            .flat_map(|q| [q.difference_arcsec - ud(q), q.difference_arcsec + ud(q)]),
        0.08,
    );
    let en_top = (c.max_en.unwrap_or(0.0) * 1.25).max(1.3);
    let worst = p
        .iter()
        .filter(|q| q.en.is_some())
        .max_by(|a, b| a.en.unwrap_or(0.0).total_cmp(&b.en.unwrap_or(0.0)));
    let svg = render("comparison", (SIZE.0, 640), |root| {
        let (top, bottom) = root.split_vertically(360);
        let mut chart = cartesian(
            &top,
            "comparison",
            FRAME.x_area(44),
            None,
            0f64..360f64,
            y0..y1,
        )?;
        turn_mesh(
            &mut chart,
            "comparison",
            ("angle θ / °", "difference A − B / ″"),
            y1 - y0,
            8,
        )?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                [(0.0, 0.0), (360.0, 0.0)],
                GREY,
            )))
            .map_err(err("comparison"))?;
        chart
            .draw_series(p.iter().map(|q| {
                PathElement::new(
                    [
                        (q.angle_deg, q.difference_arcsec - ud(q)),
                        (q.angle_deg, q.difference_arcsec + ud(q)),
                    ],
                    SKY.stroke_width(1),
                )
            }))
            .map_err(err("comparison"))?
            .label("±√(U_A² + U_B²)")
            .legend(|(x, y)| {
                PathElement::new([(x + 9, y - 7), (x + 9, y + 7)], SKY.stroke_width(2))
            });
        chart
            .draw_series(
                p.iter()
                    .map(|q| Circle::new((q.angle_deg, q.difference_arcsec), 2, BLUE.filled())),
            )
            .map_err(err("comparison"))?
            .label("A − B")
            .legend(|(x, y)| Circle::new((x + 9, y), 3, BLUE.filled()));
        legend(&mut chart, "comparison", TICK)?;
        let mut en = cartesian(
            &bottom,
            "comparison",
            FRAME,
            None,
            0f64..360f64,
            0f64..en_top,
        )?;
        mesh(&mut en, "angle θ / °", Some("normalised error En"))
            .x_labels(13)
            .y_labels(7)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.1}"))
            .draw()
            .map_err(err("comparison"))?;
        en.draw_series(DashedLineSeries::new(
            [(0.0, 1.0), (360.0, 1.0)],
            8,
            5,
            VERMILION.stroke_width(2),
        ))
        .map_err(err("comparison"))?;
        en.draw_series(p.iter().filter_map(|q| {
            q.en.map(|e| {
                PathElement::new(
                    [(q.angle_deg, 0.0), (q.angle_deg, e)],
                    BLUE.mix(0.6).stroke_width(1),
                )
            })
        }))
        .map_err(err("comparison"))?;
        en.draw_series(p.iter().filter_map(|q| {
            q.en.map(|e| {
                let color = if e > 1.0 { VERMILION } else { BLUE };
                Circle::new((q.angle_deg, e), 3, color.filled())
            })
        }))
        .map_err(err("comparison"))?;
        if let Some(w) = worst {
            let e = w.en.unwrap_or(0.0);
            en.draw_series(std::iter::once(Circle::new(
                (w.angle_deg, e),
                8,
                BLACK.stroke_width(2),
            )))
            .map_err(err("comparison"))?;
            let right = w.angle_deg > 250.0;
            let pos = Pos::new(if right { HPos::Right } else { HPos::Left }, VPos::Center);
            let x = if right {
                w.angle_deg - 5.0
            } else {
                w.angle_deg + 5.0
            };
            let y = if e > en_top * 0.8 {
                e - en_top * 0.08
            } else {
                e + en_top * 0.06
            };
            en.draw_series(std::iter::once(Text::new(
                format!("largest En = {:.2} at {}°", e, trim(w.angle_deg)),
                (x, y),
                bold(TICK).pos(pos),
            )))
            .map_err(err("comparison"))?;
        }
        Ok(())
    })?;
    Ok(Figure {
        id: "comparison".into(),
        title: "Comparison: differences and En".into(),
        caption: format!(
            "A = {}, B = {}: the difference at each of the {} common angles with ±√(U_A² + U_B²), and En = |A − B|/√(U_A² + U_B²) (|En| ≤ 1 passes); {}.",
            c.method_a,
            c.method_b,
            p.len(),
            match (c.max_en, c.max_en_angle_deg) {
                (Some(e), Some(at)) => format!("largest En {e:.2} at {}°", trim(at)),
                _ => "En undefined at every angle (both U are 0)".to_string(),
            }
        ),
        svg,
    })
}

fn trim(a: f64) -> String {
    let s = format!("{a:.3}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

fn part_turn(p: &PartView) -> Option<&TurnView> {
    p.turns.iter().find(|t| t.samples.len() >= 8)
}

/// c(θ) of the first measuring turn of a few parts, with the eccentricity fit.
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn batch_c_theta(b: &BatchView) -> Result<Option<Figure>, ReportError> {
    let panels: Vec<(String, &TurnView)> = b
        .parts
        .iter()
        .filter_map(|p| part_turn(p).map(|t| (p, t)))
        .take(4)
        .map(|(p, t)| {
            (
                format!("{}: e = {:.1} µm", p.serial, t.e_um.unwrap_or(f64::NAN)),
                t,
            )
        })
        .collect();
    if panels.is_empty() {
        return Ok(None);
    }
    Ok(Some(Figure {
        id: "c-theta".into(),
        title: "Ring column c(θ) over one turn, with the fit".into(),
        caption: "The first measuring turn of the first parts: the detector's ring column at each frame (blue) and the eccentricity fit c₀ + e·cos(θ − θ_max) + roundness (red).".into(),
        svg: c_theta_grid("c-theta", &panels)?,
    }))
}

/// c(θ) of every measuring turn of one part (initial, verify and re-measured turns), each with
/// its fit: the part's page in the dashboard.
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn part_c_theta(p: &PartView) -> Result<Option<Figure>, ReportError> {
    let panels: Vec<(String, &TurnView)> = p
        .turns
        .iter()
        .enumerate()
        .filter(|(_, t)| t.samples.len() >= 8)
        .map(|(i, t)| {
            (
                format!(
                    "turn {} ({}): e = {:.2} µm",
                    i + 1,
                    t.kind.as_deref().unwrap_or("turn"),
                    t.e_um.unwrap_or(f64::NAN)
                ),
                t,
            )
        })
        .collect();
    if panels.is_empty() {
        return Ok(None);
    }
    Ok(Some(Figure {
        id: "part-c-theta".into(),
        title: format!("{}: ring column c(θ) of every turn, with the fit", p.serial),
        caption: "Each measuring turn of the part: the detector's ring column at each valid frame (blue) and the eccentricity fit c₀ + e·cos(θ − θ_max) + roundness (red).".into(),
        svg: c_theta_grid("part-c-theta", &panels)?,
    }))
}

/// Panels of c(θ) with their fits, two per row.
fn c_theta_grid(id: &str, panels: &[(String, &TurnView)]) -> Result<String, ReportError> {
    let rows = panels.len().div_ceil(2) as u32;
    let size = (SIZE.0, 320 * rows);
    render(id, size, |root| {
        let areas = root.split_evenly((rows as usize, 2));
        for (area, (caption, turn)) in areas.iter().zip(panels) {
            let s = &turn.samples;
            let fit = gonio_station::fit::fit(s, &gonio_station::fit::FitOptions::default()).ok();
            let (y0, y1) = range(s.iter().map(|q| q.c_px), 0.12);
            let (x0, x1) = range(s.iter().map(|q| q.theta_deg), 0.0);
            let frame = Frame {
                margin: 10,
                margin_right: 18,
                x_area: 46,
                y_area: 74,
            };
            let mut chart = cartesian(area, id, frame, Some(caption), x0..x1, y0..y1)?;
            mesh(&mut chart, "servo angle θ / °", Some("ring column c / px"))
                .axis_desc_style(note(TICK, BLACK))
                .label_style(note(15, BLACK))
                .light_line_style(TRANSPARENT)
                .bold_line_style(GRID)
                .x_labels(7)
                .y_labels(6)
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_label_formatter(&|v| fixed(*v, decimals(y1 - y0, 6)))
                .draw()
                .map_err(err(id))?;
            let keep = decimate(&s.iter().map(|q| q.c_px).collect::<Vec<_>>(), 1500);
            chart
                .draw_series(
                    keep.iter().map(|&i| {
                        Circle::new((s[i].theta_deg, s[i].c_px), 2, BLUE.mix(0.6).filled())
                    }),
                )
                .map_err(err(id))?;
            if let Some(f) = &fit {
                chart
                    .draw_series(LineSeries::new(
                        (0..=200).map(|i| {
                            let t = x0 + (x1 - x0) * i as f64 / 200.0;
                            (t, f.model_px(t))
                        }),
                        VERMILION.stroke_width(1),
                    ))
                    .map_err(err(id))?;
            }
        }
        Ok(())
    })
}

/// The measured eccentricity before each push and after the last, per part.
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn batch_pushes(b: &BatchView) -> Result<Option<Figure>, ReportError> {
    let seqs: Vec<Vec<f64>> = b
        .parts
        .iter()
        .map(PartView::e_sequence)
        .filter(|s| s.len() >= 2)
        .collect();
    if seqs.is_empty() {
        return Ok(None);
    }
    let nmax = seqs.iter().map(Vec::len).max().unwrap_or(2) as f64;
    let all: Vec<f64> = seqs
        .iter()
        .flatten()
        .copied()
        .filter(|v| *v > 0.0)
        .collect();
    let (lo, hi) = (
        all.iter().copied().fold(f64::INFINITY, f64::min).max(1e-3) / 1.5,
        all.iter().copied().fold(0.0, f64::max) * 1.5,
    );
    let svg =
        render("e-pushes", SIZE, |root| {
            let mut chart = cartesian(
                root,
                "e-pushes",
                FRAME,
                None,
                -0.2f64..nmax - 0.8,
                (lo..hi).log_scale(),
            )?;
            mesh(
                &mut chart,
                "pushes made",
                Some("measured eccentricity e / µm"),
            )
            .x_labels(nmax as usize + 1)
            .y_labels(8)
            .x_label_formatter(&|v| {
                if (v - v.round()).abs() < 1e-9 && *v >= 0.0 {
                    format!("{v:.0}")
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&|v| {
                if *v >= 10.0 {
                    format!("{v:.0}")
                } else {
                    format!("{v:.1}")
                }
            })
            .draw()
            .map_err(err("e-pushes"))?;
            for s in &seqs {
                chart
                    .draw_series(LineSeries::new(
                        s.iter().enumerate().map(|(i, &e)| (i as f64, e.max(lo))),
                        BLUE.mix(0.35).stroke_width(1),
                    ))
                    .map_err(err("e-pushes"))?;
                chart
                    .draw_series(s.iter().enumerate().map(|(i, &e)| {
                        Circle::new((i as f64, e.max(lo)), 3, BLUE.mix(0.7).filled())
                    }))
                    .map_err(err("e-pushes"))?;
            }
            Ok(())
        })?;
    Ok(Some(Figure {
        id: "e-pushes".into(),
        title: "Eccentricity before and after each push".into(),
        caption: format!(
            "Each line is one of {} parts: the measured e before the first push (0), after each push, to the accepted (or rejected) value (log scale).",
            seqs.len()
        ),
        svg,
    }))
}

/// Pushes and time per part, with the batch mean and the paper's mean (Yu et al., 2024).
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn batch_parts(b: &BatchView) -> Result<Option<Figure>, ReportError> {
    let parts = &b.parts;
    if parts.is_empty() {
        return Ok(None);
    }
    let n = parts.len() as f64;
    let pmax = parts.iter().map(|p| p.pushes).max().unwrap_or(1).max(5) as f64 + 0.8;
    let tmax = parts.iter().map(|p| p.time_s).fold(30.0, f64::max) * 1.12;
    let svg = render("parts", (SIZE.0, 600), |root| {
        let (top, bottom) = root.split_vertically(300);
        for (area, is_time) in [(top, false), (bottom, true)] {
            let ytop = if is_time { tmax } else { pmax };
            let mut chart = cartesian(
                &area,
                "parts",
                FRAME.x_area(46),
                None,
                0.5f64..n + 0.5,
                0f64..ytop,
            )?;
            let y_desc = if is_time {
                "time per part / s"
            } else {
                "pushes per part"
            };
            mesh(&mut chart, "part number", Some(y_desc))
                .x_labels(((n as usize) + 1).min(26))
                .y_labels(7)
                .x_label_formatter(&|v| {
                    if (v - v.round()).abs() < 1e-9 && *v >= 1.0 {
                        format!("{v:.0}")
                    } else {
                        String::new()
                    }
                })
                .y_label_formatter(&|v| format!("{v:.0}"))
                .draw()
                .map_err(err("parts"))?;
            let value = |p: &PartView| if is_time { p.time_s } else { p.pushes as f64 };
            chart
                .draw_series(parts.iter().enumerate().map(|(i, p)| {
                    let x = (i + 1) as f64;
                    let color = if p.result == "accepted" {
                        BLUE
                    } else {
                        VERMILION
                    };
                    Rectangle::new([(x - 0.35, 0.0), (x + 0.35, value(p))], color.filled())
                }))
                .map_err(err("parts"))?;
            let mean = parts.iter().map(value).sum::<f64>() / n;
            let paper = if is_time {
                YU_2024.mean_time_s
            } else {
                YU_2024.mean_pushes
            };
            chart
                .draw_series(DashedLineSeries::new(
                    [(0.5, mean), (n + 0.5, mean)],
                    8,
                    5,
                    GREEN.stroke_width(2),
                ))
                .map_err(err("parts"))?
                .label(format!("this batch: mean {mean:.1}"))
                .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], GREEN.stroke_width(2)));
            chart
                .draw_series(DashedLineSeries::new(
                    [(0.5, paper), (n + 0.5, paper)],
                    3,
                    4,
                    BLACK.stroke_width(2),
                ))
                .map_err(err("parts"))?
                .label(format!(
                    "Yu et al., 2024 ({} parts): mean {paper}",
                    YU_2024.parts
                ))
                .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLACK.stroke_width(2)));
            legend(&mut chart, "parts", 15)?;
        }
        Ok(())
    })?;
    Ok(Some(Figure {
        id: "parts".into(),
        title: "Pushes and time per part".into(),
        caption: format!(
            "Bars per part (red: rejected), the batch mean (green) and the mean of the {} real parts of Yu et al., 2024 (black: {} pushes, {} s).",
            YU_2024.parts, YU_2024.mean_pushes, YU_2024.mean_time_s
        ),
        svg,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_the_envelope() {
        let v: Vec<f64> = (0..10_000).map(|i| ((i as f64) * 0.01).sin()).collect();
        let keep = decimate(&v, 1000);
        assert!(keep.len() <= 1002);
        let max = keep.iter().map(|&i| v[i]).fold(f64::MIN, f64::max);
        let min = keep.iter().map(|&i| v[i]).fold(f64::MAX, f64::min);
        assert!(max > 0.9999 && min < -0.9999);
        assert!(keep.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn the_alpha_legend_sits_above_the_curve() {
        let labels: Vec<String> = ["±U (k = 1.98, p = 95 %)", "α(θ)", "measured, S = 0°"]
            .map(String::from)
            .into();
        let plot_h = f64::from(SIZE.1 - 2 * FRAME.margin - FRAME.x_area);
        let legend_px = 5.0 + 11.0 + 21.5 * labels.len() as f64;
        // The demo's shape: a peak at 110°, a trough at 200°, a second peak at 290°.
        let curve =
            |t: f64| 1.5 * (t - 20.0).to_radians().sin() + 0.5 * (2.0 * t).to_radians().sin();
        let pts: Vec<(f64, f64)> = (0..360)
            .map(|i| (f64::from(i), curve(f64::from(i))))
            .collect();
        let (y0, y1) = range(pts.iter().map(|p| p.1), 0.08);
        let (corner, top) = legend_room(&pts, &labels, (y0, y1));
        assert!(top >= y1);
        // Every point under the legend's corner is below its bottom edge.
        let right = matches!(corner, SeriesLabelPosition::UpperRight);
        let under = |x: f64| if right { x >= 250.0 } else { x <= 110.0 };
        for &(x, v) in pts.iter().filter(|p| under(p.0)) {
            let below_px = (top - v) / (top - y0) * plot_h;
            assert!(
                below_px >= legend_px,
                "θ {x}: {below_px:.1} px below the top, legend {legend_px} px"
            );
        }
        // With nothing in the upper corners the range stays as it was.
        let low: Vec<(f64, f64)> = (0..360)
            .map(|i| {
                (
                    f64::from(i),
                    if (140..220).contains(&i) { 1.0 } else { -1.0 },
                )
            })
            .collect();
        let (y0, y1) = range(low.iter().map(|p| p.1), 0.08);
        assert_eq!(legend_room(&low, &labels, (y0, y1)).1, y1);
    }

    #[test]
    fn ranges_are_never_empty() {
        assert_eq!(range([].into_iter(), 0.1), (-1.0, 1.0));
        let (a, b) = range([2.0, 2.0].into_iter(), 0.1);
        assert!(a < 2.0 && b > 2.0);
        assert_eq!(decimals(0.2, 8), 2);
        assert_eq!(decimals(40.0, 8), 0);
    }
}
