//! A rotary axis tested to ISO 230-2 in a report: the standard's plot (x̄↑ and x̄↓ against the
//! target with their ±2s bands, and every approach) and its tables (the parameters with their
//! expanded uncertainties, every target, the reference's budget), from the document of
//! `gonio axis` ([`AxisResult`]).

use crate::ReportError;
use crate::html::esc;
use crate::plot::{
    BLUE, FRAME, Figure, GREEN, SIZE, TICK, VERMILION, cartesian, decimals, err, fixed, legend_at,
    mesh, range, render,
};
use gonio_calib::axis::{AxisResult, AxisTarget, Direction};
use plotters::prelude::*;
use std::fmt::Write as _;

fn num(v: Option<f64>, d: usize) -> String {
    match v {
        Some(x) if x.is_finite() => format!("{x:.d$}"),
        _ => "–".into(),
    }
}

/// One direction's approaches as the plot draws them.
struct Side {
    direction: Direction,
    color: RGBColor,
    /// (target, x̄, s) per target.
    means: Vec<(f64, f64, f64)>,
    /// (target, x) per approach.
    single: Vec<(f64, f64)>,
}

impl Side {
    fn of(doc: &AxisResult, direction: Direction) -> Side {
        fn cell(t: &AxisTarget, d: Direction) -> (Option<f64>, Option<f64>, &[f64]) {
            match d {
                Direction::Up => (t.mean_up_arcsec, t.s_up_arcsec, &t.deviations_up_arcsec),
                Direction::Down => (
                    t.mean_down_arcsec,
                    t.s_down_arcsec,
                    &t.deviations_down_arcsec,
                ),
            }
        }
        let mut means = Vec::new();
        let mut single = Vec::new();
        for t in &doc.targets {
            let (m, s, x) = cell(t, direction);
            if let (Some(m), Some(s)) = (m, s) {
                means.push((t.target_deg, m, s));
            }
            single.extend(x.iter().map(|&v| (t.target_deg, v)));
        }
        Side {
            direction,
            color: if direction == Direction::Up {
                BLUE
            } else {
                VERMILION
            },
            means,
            single,
        }
    }
}

/// The standard's plot: x̄↑ and x̄↓ against the target with their x̄ ± 2s bands, every
/// approach as a dot and, in a bidirectional test, the mean x̄_i of both.
///
/// # Errors
/// [`ReportError::Plot`] if drawing fails.
pub fn figure(doc: &AxisResult) -> Result<Figure, ReportError> {
    let id = "axis";
    let dirs: Vec<Side> = Direction::BOTH
        .iter()
        .map(|&d| Side::of(doc, d))
        .filter(|s| !s.means.is_empty())
        .collect();
    let (x0, x1) = range(doc.targets.iter().map(|t| t.target_deg), 0.04);
    let (y0, y1) = range(
        dirs.iter().flat_map(|side| {
            side.means
                .iter()
                .flat_map(|&(_, v, s)| [v - 2.0 * s, v + 2.0 * s])
                .chain(side.single.iter().map(|p| p.1))
                .collect::<Vec<_>>()
        }),
        0.1,
    );
    // Room above the data for the legend (upper left): its lines of ≈ 21.5 px, its padding, and
    // a gap, out of the plot's height.
    let lines = 2 * dirs.len() + usize::from(doc.targets.iter().any(|t| t.mean_arcsec.is_some()));
    let plot_h = f64::from(SIZE.1 - 2 * FRAME.margin - FRAME.x_area);
    let f = ((28.0 + 21.5 * lines as f64) / plot_h).min(0.7);
    let y1 = y0 + (y1 - y0) / (1.0 - f);
    let svg = render(id, SIZE, |root| {
        let mut chart = cartesian(root, id, FRAME, None, x0..x1, y0..y1)?;
        mesh(&mut chart, "target P / °", Some("deviation x / ″"))
            .x_labels(13)
            .y_labels(9)
            .x_label_formatter(&|v| fixed(*v, decimals(x1 - x0, 13).min(3)))
            .y_label_formatter(&|v| fixed(*v, decimals(y1 - y0, 9)))
            .draw()
            .map_err(err(id))?;
        for side in &dirs {
            let (d, color, means, single) = (side.direction, side.color, &side.means, &side.single);
            let mut band: Vec<(f64, f64)> =
                means.iter().map(|&(t, m, s)| (t, m + 2.0 * s)).collect();
            band.extend(means.iter().rev().map(|&(t, m, s)| (t, m - 2.0 * s)));
            let arrow = if d == Direction::Up { "↑" } else { "↓" };
            chart
                .draw_series(std::iter::once(Polygon::new(
                    band,
                    color.mix(0.14).filled(),
                )))
                .map_err(err(id))?
                .label(format!("x̄{arrow} ± 2s{arrow}"))
                .legend(move |(x, y)| {
                    Rectangle::new([(x, y - 6), (x + 18, y + 6)], color.mix(0.14).filled())
                });
            for sign in [1.0, -1.0] {
                chart
                    .draw_series(LineSeries::new(
                        means.iter().map(|&(t, m, s)| (t, m + sign * 2.0 * s)),
                        color.mix(0.55).stroke_width(1),
                    ))
                    .map_err(err(id))?;
            }
            chart
                .draw_series(
                    single
                        .iter()
                        .map(|&p| Circle::new(p, 2, color.mix(0.45).filled())),
                )
                .map_err(err(id))?;
            chart
                .draw_series(LineSeries::new(
                    means.iter().map(|&(t, m, _)| (t, m)),
                    color.stroke_width(2),
                ))
                .map_err(err(id))?
                .label(format!("x̄{arrow} ({} approach)", d.word()))
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 18, y)], color.stroke_width(2))
                });
            chart
                .draw_series(
                    means
                        .iter()
                        .map(|&(t, m, _)| Circle::new((t, m), 4, color.filled())),
                )
                .map_err(err(id))?;
        }
        let mean: Vec<(f64, f64)> = doc
            .targets
            .iter()
            .filter_map(|t| t.mean_arcsec.map(|m| (t.target_deg, m)))
            .collect();
        if !mean.is_empty() {
            chart
                .draw_series(LineSeries::new(mean, GREEN.stroke_width(1)))
                .map_err(err(id))?
                .label("x̄ = (x̄↑ + x̄↓)/2")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], GREEN.stroke_width(1)));
        }
        legend_at(&mut chart, id, TICK, SeriesLabelPosition::UpperLeft)?;
        Ok(())
    })?;
    Ok(Figure {
        id: id.into(),
        title: format!("Positioning deviations ({})", doc.standard),
        caption: format!(
            "The mean unidirectional positioning deviations at each of the {} targets with their ±2s bands ({}; dots: every approach), as {} draws them; {}.",
            doc.targets.len(),
            doc.runs_summary(),
            doc.standard,
            doc.deviations
        ),
        svg,
    })
}

/// The section's heading and what the test was.
pub(crate) fn header(b: &mut String, doc: &AxisResult, source: &str) {
    let _ = write!(
        b,
        "<section class=\"axis\"><header><h1>Rotary axis: accuracy and repeatability of positioning</h1>\
         <p class=\"method\">{} — {} <span class=\"source\">({})</span></p></header>\
         <table class=\"kv\"><tr><th>test</th><td>{}, {} targets from {}° to {}°, {}</td></tr>\
         <tr><th>deviations</th><td>{}</td></tr></table>",
        esc(&doc.standard),
        esc(&doc.standard_title),
        esc(source),
        esc(&doc.test),
        doc.targets.len(),
        doc.targets.first().map_or(0.0, |t| t.target_deg),
        doc.targets.last().map_or(0.0, |t| t.target_deg),
        esc(&doc.runs_summary()),
        esc(&doc.deviations)
    );
}

/// The parameters, every target, the reference's budget and the notes.
pub(crate) fn tables(b: &mut String, doc: &AxisResult) {
    let p = &doc.parameters;
    let u = &doc.uncertainty.parameters;
    let _ = write!(
        b,
        "<h2>Parameters</h2><table class=\"grid\" id=\"axis-parameters\"><thead><tr><th>parameter</th><th>symbol</th><th>value / ″</th><th>U (k = {}) / ″</th></tr></thead><tbody>",
        doc.uncertainty.k
    );
    let rows = [
        ("bidirectional accuracy of positioning", "A", p.a, u.a),
        ("unidirectional accuracy, positive", "A↑", p.a_up, u.a_up),
        (
            "unidirectional accuracy, negative",
            "A↓",
            p.a_down,
            u.a_down,
        ),
        ("bidirectional systematic positioning error", "E", p.e, u.e),
        (
            "unidirectional systematic positioning error, positive",
            "E↑",
            p.e_up,
            u.e_up,
        ),
        (
            "unidirectional systematic positioning error, negative",
            "E↓",
            p.e_down,
            u.e_down,
        ),
        (
            "range of the mean bidirectional positioning error",
            "M",
            p.m,
            u.m,
        ),
        ("reversal value", "B", p.b, u.b),
        ("mean reversal value", "B̄", p.b_mean, u.b_mean),
        ("bidirectional repeatability of positioning", "R", p.r, u.r),
        (
            "unidirectional repeatability, positive",
            "R↑",
            p.r_up,
            u.r_up,
        ),
        (
            "unidirectional repeatability, negative",
            "R↓",
            p.r_down,
            u.r_down,
        ),
    ];
    for (name, sym, v, uu) in rows {
        let _ = write!(
            b,
            "<tr><td>{name}</td><td>{sym}</td><td>{}</td><td>{}</td></tr>",
            num(v, 3),
            num(uu, 3)
        );
    }
    b.push_str("</tbody></table>");
    let _ = write!(
        b,
        "<details><summary>Every target ({})</summary><table class=\"grid\" id=\"axis-targets\"><thead><tr><th>target / °</th><th>face</th><th>x̄↑ / ″</th><th>s↑ / ″</th><th>x̄↓ / ″</th><th>s↓ / ″</th><th>B_i / ″</th><th>R_i / ″</th><th>x̄_i / ″</th></tr></thead><tbody>",
        doc.targets.len()
    );
    for t in &doc.targets {
        let _ = write!(
            b,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            t.target_deg,
            t.face.map_or("–".into(), |f| f.to_string()),
            num(t.mean_up_arcsec, 3),
            num(t.s_up_arcsec, 3),
            num(t.mean_down_arcsec, 3),
            num(t.s_down_arcsec, 3),
            num(t.b_arcsec, 3),
            num(t.r_arcsec, 3),
            num(t.mean_arcsec, 3)
        );
    }
    b.push_str("</tbody></table></details>");
    if let Some(r) = &doc.uncertainty.reference {
        let _ = write!(
            b,
            "<h2>The reference's uncertainty of one deviation</h2><p class=\"note\">The budget at {}°, where it is largest: u = {:.4}″, ν_eff = {}, k = {:.2}, U = {:.4}″ (p = {:.0} %).</p>\
             <table class=\"grid\"><thead><tr><th>contribution</th><th>source</th><th>u / ″</th><th>ν</th><th>share</th></tr></thead><tbody>",
            r.target_deg,
            r.u_arcsec,
            if r.nu_eff.is_finite() {
                format!("{:.0}", r.nu_eff)
            } else {
                "∞".into()
            },
            r.k,
            r.expanded_arcsec,
            r.p * 100.0
        );
        for c in &r.budget.contributions {
            let _ = write!(
                b,
                "<tr><td>{}</td><td>{}</td><td>{:.4}</td><td>{}</td><td>{:.1} %</td></tr>",
                esc(&c.name),
                esc(&c.source),
                c.u,
                if c.nu.is_finite() {
                    format!("{:.0}", c.nu)
                } else {
                    "∞".into()
                },
                c.share * 100.0
            );
        }
        b.push_str("</tbody></table>");
    }
    let notes: Vec<&str> = doc
        .notes
        .iter()
        .map(String::as_str)
        .chain(doc.bidirectional_note.as_deref())
        .chain(doc.polygon.as_ref().map(|p| p.note.as_str()))
        .chain(std::iter::once(doc.uncertainty.note.as_str()))
        .chain(doc.uncertainty.reference_note.as_deref())
        .collect();
    b.push_str("<ul class=\"statements\">");
    for n in notes {
        let _ = write!(b, "<li>{}</li>", esc(n));
    }
    b.push_str("</ul>");
}
