//! The dashboard's static files, built into the binary (no CDN, no network).

use axum::extract::Path;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};

/// The live view.
const LIVE_HTML: &str = include_str!("../assets/live.html");

/// The live view: with a station, every panel (the current frame, the pushes, the ring column
/// c(θ), the counters, the recent parts); without one, the history's counters and recent parts
/// only, and a line saying that no station is attached (no empty frame or turn panel).
pub(crate) fn live_page(station: bool) -> String {
    let class = if station { "station" } else { "no-station" };
    LIVE_HTML.replacen("<body>", &format!("<body class=\"{class}\">"), 1)
}
/// The history of parts.
pub(crate) const HISTORY_HTML: &str = include_str!("../assets/history.html");
/// The style sheet of every page.
pub(crate) const STYLE_CSS: &str = include_str!("../assets/style.css");
const LIVE_JS: &str = include_str!("../assets/live.js");
const HISTORY_JS: &str = include_str!("../assets/history.js");
const ICON_SVG: &str = include_str!("../assets/icon.svg");

pub(crate) async fn file(Path(name): Path<String>) -> Response {
    let (body, mime) = match name.as_str() {
        "style.css" => (STYLE_CSS, "text/css; charset=utf-8"),
        "live.js" => (LIVE_JS, "text/javascript; charset=utf-8"),
        "history.js" => (HISTORY_JS, "text/javascript; charset=utf-8"),
        "icon.svg" => (ICON_SVG, "image/svg+xml"),
        _ => return (StatusCode::NOT_FOUND, "no such file").into_response(),
    };
    ([(header::CONTENT_TYPE, mime)], body).into_response()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The opening tags of the elements enclosing byte `at` of `html` (void and self-closed
    /// elements aside), outermost first.
    fn enclosing(html: &str, at: usize) -> Vec<&str> {
        let mut open: Vec<&str> = Vec::new();
        let mut i = 0;
        while let Some(k) = html[i..at].find('<') {
            let start = i + k;
            let end = start + html[start..].find('>').expect("a closed tag");
            let tag = &html[start..=end];
            if tag.starts_with("</") {
                open.pop();
            } else if !tag.starts_with("<!")
                && !tag.ends_with("/>")
                && !["<meta", "<link", "<br", "<img", "<input"]
                    .iter()
                    .any(|v| tag.starts_with(v))
            {
                open.push(tag);
            }
            i = end + 1;
            if i >= at {
                break;
            }
        }
        open
    }

    #[test]
    fn without_a_station_the_live_view_hides_its_panels_and_says_so() {
        let without = live_page(false);
        assert!(without.contains("<body class=\"no-station\">"));
        assert!(live_page(true).contains("<body class=\"station\">"));
        let in_station_only = |id: &str| {
            let at = without.find(id).unwrap_or_else(|| panic!("{id}"));
            enclosing(&without, at)
                .iter()
                .any(|t| t.contains("station-only"))
        };
        // The frame, the pushes, c(θ) and the part's serial and phase are the station's …
        for id in [
            "id=\"thumb\"",
            "id=\"pushplot\"",
            "id=\"ctheta\"",
            "id=\"phase\"",
        ] {
            assert!(in_station_only(id), "{id} shows without a station");
        }
        // … the counters and the recent parts are the store's.
        for id in ["id=\"counters\"", "id=\"recent\""] {
            assert!(!in_station_only(id), "{id} hidden without a station");
        }
        assert!(without.contains("No station is attached"));
        assert!(STYLE_CSS.contains("body.no-station .station-only { display: none; }"));
        assert!(STYLE_CSS.contains("body.no-station .no-station-note { display: block; }"));
    }
}
