//! The one font every report and plot uses, embedded so that text renders the same everywhere:
//! DejaVu Sans (regular and bold), subset to Latin, Greek and the mathematical symbols a
//! metrology report needs (`assets/`, Bitstream Vera / DejaVu licence in
//! `assets/DejaVu-LICENSE.txt`). The plots measure text with the same font the browser draws it
//! with.

use base64::Engine as _;
use std::sync::Once;

/// The CSS and SVG font family name.
pub const FAMILY: &str = "GonioSans";

/// DejaVu Sans, subset (TrueType).
pub const REGULAR: &[u8] = include_bytes!("../assets/DejaVuSans-subset.ttf");

/// DejaVu Sans Bold, subset (TrueType).
pub const BOLD: &[u8] = include_bytes!("../assets/DejaVuSans-Bold-subset.ttf");

/// Registers the font with the plotting library (once per process) so that plots lay out text
/// with the metrics the browser will use.
pub fn register() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // Both are the files above, which are valid fonts (a test renders text with them).
        let _ = plotters::style::register_font(FAMILY, plotters::style::FontStyle::Normal, REGULAR);
        let _ = plotters::style::register_font(FAMILY, plotters::style::FontStyle::Bold, BOLD);
    });
}

/// `@font-face` rules with the fonts inlined as base64 data URLs.
///
/// ```
/// let css = gonio_report::font::css_font_faces();
/// assert!(css.contains("font-family: 'GonioSans'") && css.contains("data:font/ttf;base64,"));
/// ```
pub fn css_font_faces() -> String {
    let b64 = |b: &[u8]| base64::engine::general_purpose::STANDARD.encode(b);
    format!(
        "@font-face {{ font-family: '{FAMILY}'; font-weight: normal; src: url(data:font/ttf;base64,{}) format('truetype'); }}\n\
         @font-face {{ font-family: '{FAMILY}'; font-weight: bold; src: url(data:font/ttf;base64,{}) format('truetype'); }}\n",
        b64(REGULAR),
        b64(BOLD)
    )
}
