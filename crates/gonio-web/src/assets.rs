//! The dashboard's static files, built into the binary (no CDN, no network).

use axum::extract::Path;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};

/// The live view.
pub(crate) const LIVE_HTML: &str = include_str!("../assets/live.html");
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
