//! Pages rendered on the server: a part with its plots (the report's SVG figures), the list of
//! calibration certificates, and a certificate as the report shows it.

use crate::state::{AppState, blocking, error, parse_id};
use axum::extract::{Path, State};
use axum::http::StatusCode;
use axum::response::{Html, IntoResponse, Response};
use gonio_calib::certificate::Certificate;
use gonio_report::batch::{BatchView, PartView, SummaryView};
use gonio_report::html::esc;
use gonio_report::plot;
use gonio_store::StoredPart;
use std::fmt::Write as _;

fn nav(title: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>{} · gonio</title><link rel=\"stylesheet\" href=\"/static/style.css\">\
         <link rel=\"icon\" href=\"/static/icon.svg\" type=\"image/svg+xml\">\
         <style>{}</style></head><body>\
         <nav><a href=\"/\">Live</a><a href=\"/history\">History</a>\
         <a href=\"/calibrations\">Calibrations</a><span class=\"ro\">read-only</span></nav>\
         <main>{}</main></body></html>\n",
        esc(title),
        gonio_report::font::css_font_faces(),
        body
    )
}

/// A number with `d` decimals, or a dash when it is not defined (`None`) or not finite.
fn num(x: impl Into<Option<f64>>, d: usize) -> String {
    match x.into() {
        Some(x) if x.is_finite() => format!("{x:.d$}"),
        _ => "—".into(),
    }
}

fn part_body(p: &StoredPart) -> Result<String, String> {
    let mut b = String::new();
    let _ = write!(
        b,
        "<h1>Part {} <span class=\"serial\">{}</span> <span class=\"verdict {}\">{}</span></h1>",
        p.part,
        esc(&p.serial),
        p.verdict.name(),
        esc(&p.result)
    );
    if let Some(why) = &p.reject_reason {
        let _ = write!(b, "<p class=\"why\">{}</p>", esc(why));
    }
    let rows = [
        ("station", esc(&p.station)),
        (
            "batch",
            format!("{} (part {} of it)", p.batch, p.batch_index + 1),
        ),
        (
            "recipe",
            format!(
                "{} <code>{}</code>",
                esc(&p.recipe),
                esc(p.recipe_hash.get(..12).unwrap_or(&p.recipe_hash))
            ),
        ),
        ("strategy", esc(&p.strategy)),
        (
            "started / ended (UTC)",
            format!("{} / {}", esc(&p.started_at), esc(&p.ended_at)),
        ),
        ("initial e / µm", num(p.initial_e_um, 2)),
        ("final e / µm", num(p.final_e_um, 2)),
        ("pushes", p.pushes.to_string()),
        ("station time / s", num(p.time_s, 1)),
        (
            "focus, measure, push / s",
            format!(
                "{}, {}, {}",
                num(p.phase_times.focus_s, 1),
                num(p.phase_times.measure_s, 1),
                num(p.phase_times.push_s, 1)
            ),
        ),
        (
            "of the push: align, approach, stroke, retract / s",
            format!(
                "{}, {}, {}, {}",
                num(p.phase_times.align_s, 2),
                num(p.phase_times.approach_s, 2),
                num(p.phase_times.stroke_s, 2),
                num(p.phase_times.retract_s, 2)
            ),
        ),
        ("re-measured turns", p.remeasured_turns.to_string()),
        ("software", esc(&p.software_version)),
    ];
    b.push_str("<table class=\"kv\">");
    for (k, v) in rows {
        let _ = write!(b, "<tr><th>{k}</th><td>{v}</td></tr>");
    }
    if let (Some(t0), Some(t1)) = (p.true_initial_e_um, p.true_final_e_um) {
        let _ = write!(
            b,
            "<tr><th>simulation truth: e / µm</th><td>{} → {}</td></tr>",
            num(t0, 2),
            num(t1, 2)
        );
    }
    b.push_str("</table>");

    b.push_str("<h2>Turns</h2><table class=\"grid\"><tr><th>#</th><th>kind</th><th>frames (valid)</th><th>e / µm</th><th>θ<sub>max</sub> / °</th><th>residual / px</th><th>focus / µm</th><th>quality gate</th></tr>");
    for (i, t) in p.turns.iter().enumerate() {
        let gate = match &t.quality {
            Some(q) if q["ok"] == true => "trusted".to_string(),
            Some(q) => format!(
                "failed: {}",
                esc(&q["failures"]
                    .as_array()
                    .map(|f| f
                        .iter()
                        .filter_map(|x| x["check"].as_str())
                        .collect::<Vec<_>>()
                        .join(", "))
                    .unwrap_or_default())
            ),
            None => "ring lost".into(),
        };
        let _ = write!(
            b,
            "<tr><td>{}</td><td>{}</td><td>{} ({})</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            i + 1,
            serde_json::to_value(t.kind)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default(),
            t.frames_taken,
            t.valid_frames,
            num(t.e_um, 2),
            num(t.theta_max_deg, 1),
            num(t.residual_rms_px, 3),
            num(t.focus_um, 1),
            gate
        );
    }
    b.push_str("</table>");
    if !p.push_log.is_empty() {
        b.push_str("<h2>Pushes</h2><table class=\"grid\"><tr><th>#</th><th>e before / µm</th><th>e after / µm</th><th>stroke / µm</th><th>direction / °</th><th>approach</th><th>duration / s</th><th>as predicted</th></tr>");
        for (i, q) in p.push_log.iter().enumerate() {
            let _ = write!(
                b,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:?}</td><td>{}</td><td>{}</td></tr>",
                i + 1,
                num(q.e_before_um, 2),
                num(q.e_after_um, 2),
                num(q.commanded_um, 2),
                num(q.angle_deg, 1),
                q.approach,
                num(q.duration_s, 1),
                match q.consistent {
                    Some(true) => "yes",
                    Some(false) => "no",
                    None => "—",
                }
            );
        }
        b.push_str("</table>");
    }
    // The report's plots, from the same JSON the API serves.
    let view: PartView = serde_json::to_value(p)
        .and_then(serde_json::from_value)
        .map_err(|e| format!("part view: {e}"))?;
    let mut figs = Vec::new();
    if let Some(f) = plot::part_c_theta(&view).map_err(|e| e.to_string())? {
        figs.push(f);
    }
    let one = BatchView {
        seed: None,
        strategy: p.strategy.clone(),
        recipe: p.recipe.clone(),
        parts: vec![view],
        summary: SummaryView {
            parts: 1,
            mean_time_s: p.time_s.unwrap_or(f64::NAN),
            mean_final_e_um: p.final_e_um.unwrap_or(f64::NAN),
            mean_pushes: f64::from(p.pushes),
            max_pushes: p.pushes,
            rejected: usize::from(p.verdict == gonio_store::Verdict::Reject),
        },
    };
    if let Some(f) = plot::batch_pushes(&one).map_err(|e| e.to_string())? {
        figs.push(f);
    }
    for f in figs {
        let _ = write!(
            b,
            "<figure class=\"plot\" id=\"{}\"><figcaption><strong>{}</strong> {}</figcaption>{}</figure>",
            esc(&f.id),
            esc(&f.title),
            esc(&f.caption),
            f.svg
        );
    }
    Ok(b)
}

pub(crate) async fn part_page(State(st): State<AppState>, Path(id): Path<String>) -> Response {
    let id = match parse_id("part", &id) {
        Ok(i) => i,
        Err(r) => return *r,
    };
    match blocking(&st.pool, move |s| s.part(id)).await {
        Ok(Some(p)) => match part_body(&p) {
            Ok(b) => Html(nav(&format!("Part {}", p.serial), &b)).into_response(),
            Err(e) => error(StatusCode::INTERNAL_SERVER_ERROR, e),
        },
        Ok(None) => (
            StatusCode::NOT_FOUND,
            Html(nav("Not found", &format!("<h1>No part {id}</h1>"))),
        )
            .into_response(),
        Err(r) => r,
    }
}

pub(crate) async fn calibrations_page(State(st): State<AppState>) -> Response {
    let list = match blocking(&st.pool, |s| s.calibrations()).await {
        Ok(l) => l,
        Err(r) => return r,
    };
    let mut b = String::from("<h1>Calibration certificates</h1>");
    if list.is_empty() {
        b.push_str("<p>No certificates stored yet: <code>gonio shift-angle … --db</code> or <code>gonio selfcal … --db</code> stores one.</p>");
    } else {
        b.push_str("<table class=\"grid\"><tr><th>#</th><th>item</th><th>procedure</th><th>method</th><th>date</th><th>max |α| / ″</th><th>max U / ″</th><th>source</th><th>stored (UTC)</th></tr>");
        for c in &list {
            let _ = write!(
                b,
                "<tr><td><a href=\"/calibrations/{0}\">{0}</a></td><td>{1}</td><td>{2}</td><td>{3}</td><td>{4}</td><td>{5}</td><td>{6}</td><td>{7}</td><td>{8}</td></tr>",
                c.calibration,
                esc(c.item.as_deref().unwrap_or("—")),
                esc(&c.procedure),
                esc(&c.method),
                esc(c.calibration_date.as_deref().unwrap_or("—")),
                num(c.max_abs_error_arcsec, 3),
                c.max_expanded_arcsec.map_or("—".into(), |u| num(u, 3)),
                esc(&c.source),
                esc(&c.stored_at),
            );
        }
        b.push_str("</table>");
    }
    Html(nav("Calibrations", &b)).into_response()
}

pub(crate) async fn calibration_page(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Response {
    let id = match parse_id("calibration", &id) {
        Ok(i) => i,
        Err(r) => return *r,
    };
    let c = match blocking(&st.pool, move |s| s.calibration(id)).await {
        Ok(Some(c)) => c,
        Ok(None) => return error(StatusCode::NOT_FOUND, format!("no calibration {id}")),
        Err(r) => return r,
    };
    let cert: Certificate = match c.certificate.clone().map(serde_json::from_value) {
        Some(Ok(cert)) => cert,
        Some(Err(e)) => return error(StatusCode::INTERNAL_SERVER_ERROR, e),
        None => return error(StatusCode::INTERNAL_SERVER_ERROR, "certificate missing"),
    };
    // The report's own page for one certificate, with the dashboard's navigation on top.
    let mut r = gonio_report::html::Report::new(&format!("Calibration {id}"));
    if let Err(e) = r.add_certificate(&cert, &c.source) {
        return error(StatusCode::INTERNAL_SERVER_ERROR, e);
    }
    let page = r.render().replacen(
        "<body>",
        "<body><link rel=\"icon\" href=\"/static/icon.svg\" type=\"image/svg+xml\"><nav style=\"margin-bottom:16px\"><a href=\"/\">Live</a> · <a href=\"/history\">History</a> · <a href=\"/calibrations\">Calibrations</a></nav>",
        1,
    );
    Html(page).into_response()
}
