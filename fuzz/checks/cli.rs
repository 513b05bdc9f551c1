//! Invariants checked on every input of the CLI's fuzz targets (the parsers of
//! `crates/gonio-io/src/formats/`), and replayed on the kept corpora and crashes by
//! `crates/gonio-cli/tests/fuzz_regressions.rs`.
//!
//! Whatever the bytes: no panic, no abort, no hang, no memory blow-up; an error is one line of at
//! most `MAX_ERROR_CHARS` characters that starts with the input's name (`in:`), with a line
//! (and column) inside the input when it gives one; a parsed value serialises without a
//! non-finite number where the format has numbers. The first byte of some targets selects the
//! parser (one target per family of formats).
#![allow(dead_code)]

use gonio_io::formats;
use gonio_io::input::{MAX_ERROR_CHARS, decode, one_line};

const NAME: &str = "in";

/// An error's one-line text: short, no control characters, naming the input, its line inside it.
fn check_error(data: &[u8], e: &anyhow::Error) {
    let m = one_line(e);
    assert!(
        m.chars().count() <= MAX_ERROR_CHARS + 40,
        "{} chars: {m}",
        m.len()
    );
    assert!(!m.chars().any(|c| c.is_control()), "{m:?}");
    if let Some(rest) = m.strip_prefix("in:") {
        let line: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
        if let Ok(l) = line.parse::<usize>() {
            let lines = data.iter().filter(|&&b| b == b'\n' || b == b'\r').count() + 1;
            assert!(l >= 1 && l <= lines, "line {l} of {lines}: {m}");
        }
    }
}

fn text(data: &[u8]) -> Option<String> {
    match decode(NAME, data) {
        Ok(t) => Some(t),
        Err(e) => {
            check_error(data, &e);
            None
        }
    }
}

fn run<T>(data: &[u8], r: anyhow::Result<T>) -> Option<T> {
    match r {
        Ok(v) => Some(v),
        Err(e) => {
            check_error(data, &e);
            None
        }
    }
}

/// Polygon readings CSV (`shift_deg,start_face,step,reading_arcsec[,repeat]`): parse and build
/// the reading set; with few readings, calibrate by least squares.
pub fn readings_csv(data: &[u8]) {
    let Some(t) = text(data) else { return };
    if let Some(set) = run(data, formats::readings::parse(NAME, &t, None))
        && set.len() <= 400
    {
        let _ = gonio_calib::shift_angle::calibrate(&set, &Default::default());
    }
}

/// Heads: byte 0 selects a heads file as TOML (even) or JSON (odd), or (≥ 0x80) head readings
/// CSV for three equally spaced heads.
pub fn heads(data: &[u8]) {
    let Some((&sel, rest)) = data.split_first() else {
        return;
    };
    let Some(t) = text(rest) else { return };
    if sel >= 0x80 {
        let (h, _) =
            formats::heads::load(&gonio_io::input::Inputs::new(), "eda:3").expect("preset");
        if let Some(table) = run(rest, formats::csv::CsvTable::parse(NAME, &t))
            && let Some(rt) = run(rest, formats::heads::read_turns(&table, &h, sel & 1 == 1))
            && rt
                .turns
                .iter()
                .map(|t| t.positions_deg.len())
                .sum::<usize>()
                <= 2000
            && let Err(e) = gonio_calib::selfcal::calibrate(&h, &rt.turns, &Default::default())
        {
            check_error(rest, &formats::heads::locate(e, &table, &rt.lines));
        }
    } else {
        run(rest, formats::heads::parse(NAME, &t, sel & 1 == 1));
    }
}

/// Station TOML: byte 0 selects a recipe (0 mod 3), optics (1) or a scene (2).
pub fn station_toml(data: &[u8]) {
    let Some((&sel, rest)) = data.split_first() else {
        return;
    };
    let Some(t) = text(rest) else { return };
    if sel % 3 == 2 {
        if let Some(scene) = run(rest, formats::frames::parse_scene(NAME, &t)) {
            // A scene that passed its checks renders a small frame in bounded time.
            let o = gonio_vision::Optics {
                window_width_px: 128,
                window_height_px: 64,
                ..gonio_vision::Optics::default()
            };
            if let Ok(r) = gonio_sim::frames::GratingRenderer::new(&o, scene) {
                let mut f = vec![0u8; r.frame_len()];
                let _ = r.render(10.0, 50.0, 0.0, 0.0, 1, &mut f);
            }
        }
    } else if sel % 3 == 0 {
        if let Some(r) = run(rest, formats::recipe::parse(NAME, &t)) {
            // A recipe that passed its checks sizes a turn: bounded.
            assert!(r.frames_per_turn() <= 1_000_000, "{}", r.frames_per_turn());
        }
    } else if let Some(o) = run(rest, formats::frames::parse_optics(NAME, &t)) {
        assert!(o.sensor_width_px <= gonio_vision::MAX_SENSOR_PX);
        let _ = gonio_vision::Detector::new(&o).expect("optics checked");
    }
}

/// Angle logs and eccentricity samples: byte 0 selects an angle log (even) or one turn's
/// `theta_deg,c_px` samples (odd), fitted when parsed.
pub fn angles_csv(data: &[u8]) {
    let Some((&sel, rest)) = data.split_first() else {
        return;
    };
    let Some(t) = text(rest) else { return };
    if sel & 1 == 0 {
        if let Some(log) = run(rest, formats::angles::parse(NAME, &t)) {
            assert!(!log.is_empty());
        }
    } else if let Some(s) = run(rest, formats::samples::parse(NAME, &t))
        && s.samples.len() <= 2000
    {
        let r = gonio_station::Recipe::default();
        let _ = gonio_station::fit::fit_judged(
            &s.samples,
            s.samples.len(),
            &r.fit,
            &r.quality_limits(),
        );
    }
}

/// JSON files: byte 0 selects an encoder model (0), a certificate (1), a curve to compare (2) or
/// a report input (3); a parsed certificate goes back out through the JSON emitter.
pub fn json_files(data: &[u8]) {
    let Some((&sel, rest)) = data.split_first() else {
        return;
    };
    let Some(t) = text(rest) else { return };
    match sel % 4 {
        0 => {
            if let Some(m) = run(rest, formats::encoder::parse(NAME, &t)) {
                let _ = m.error_at(gonio_core::Degrees(12.5));
            }
        }
        1 => {
            if let Some(c) = run(rest, formats::certificate::parse(NAME, &t)) {
                let _ = gonio_io::json::to_bytes(&c);
            }
        }
        2 => {
            run(rest, formats::curve::parse(NAME, &t));
        }
        _ => {
            run(rest, formats::report::parse(NAME, &t));
        }
    }
}

/// Frame files: PNG/TIFF headers and pixels decoded with the default optics' sensor as the size
/// limit, cut to the window; byte 0 tries a raw size string instead.
pub fn frames(data: &[u8]) {
    let o = gonio_vision::Optics::default();
    if data.first() == Some(&b'R') {
        let s = String::from_utf8_lossy(&data[1..]);
        let _ = formats::frames::parse_raw_size(&s, &o);
        return;
    }
    let (sw, sh) = (o.sensor_width_px as usize, o.sensor_height_px as usize);
    if let Some((w, h, px)) = run(data, formats::frames::decode_grey8(NAME, data, sw, sh)) {
        assert!(w <= sw && h <= sh && px.len() == w * h);
        let _ = formats::frames::to_window(&o, NAME, w, h, px);
    }
}

/// Autocollimator: byte 0 selects an ELCOMAT log (even) or a measuring plan (odd), whose
/// planned readings are then listed.
pub fn elcomat(data: &[u8]) {
    let Some((&sel, rest)) = data.split_first() else {
        return;
    };
    if sel & 1 == 0 {
        let t = String::from_utf8_lossy(rest);
        run(
            rest,
            gonio_lab::log::parse(NAME, &t).map_err(anyhow::Error::from),
        );
    } else {
        let Some(t) = text(rest) else { return };
        if let Some(p) = run(
            rest,
            gonio_lab::plan::Plan::parse_text(NAME, &t).map_err(anyhow::Error::from),
        ) {
            let r = p.readings();
            assert!(r.len() as u64 <= gonio_lab::plan::MAX_PLANNED_READINGS);
        }
    }
}

/// A rotary axis: byte 0 selects readings CSV (even; bit 1: `reading_arcsec` corrected by an
/// 8-face polygon) or an axis's measuring plan (odd). Readings: parse and evaluate to ISO
/// 230-2, the result's JSON finite; a plan: list its cycle and checks.
pub fn axis(data: &[u8]) {
    let Some((&sel, rest)) = data.split_first() else {
        return;
    };
    let Some(t) = text(rest) else { return };
    if sel & 1 == 0 {
        let polygon = (sel & 2 == 2).then(|| {
            gonio_calib::axis::Polygon::new(
                &[0.3, -0.1, 0.2, 0.0, -0.4, 0.1, 0.2, -0.3],
                &[0.02; 8],
                50.0,
                "p",
            )
            .expect("a valid polygon")
        });
        if let Some(file) = run(rest, formats::axis::parse(NAME, &t, polygon))
            && let Some(doc) = run(rest, file.analyse(&Default::default()))
        {
            gonio_io::json::to_bytes(&doc).expect("finite");
        }
    } else if let Some(p) = run(
        rest,
        gonio_lab::axis::AxisPlan::parse_text(NAME, &t).map_err(anyhow::Error::from),
    ) {
        use gonio_lab::sequence::Sequence;
        let v = p.positions();
        assert!(v.len() as u64 <= gonio_lab::plan::MAX_PLANNED_READINGS);
        assert_eq!(p.partners(&v).len(), v.len());
    }
}
