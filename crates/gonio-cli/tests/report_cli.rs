//! `gonio report` and `gonio certificate --dcc` end to end: the DCC validates against the
//! shipped DCC 3.1.2 / D-SI 2.1.0 schemas (xmllint), and the HTML report renders in headless
//! Chromium with content in every plot and no console error.
//!
//! Both tools are Debian packages (`libxml2-utils`, `chromium`) that `.ci/run` installs; the tests
//! fail, naming the package, when one is missing.

mod common;

use common::{example, gonio, repo};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Standard output of a successful `gonio` run.
fn ok(args: &[&str]) -> String {
    common::ok(args).0
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// Certificates of both methods and their comparison, from the simulator.
fn certificates(d: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let (lab, heads) =
        common::simulated_lab(d, "3", &["--repeats", "2", "--seed", "3"], &["--seed", "4"]);
    let (sa, sc, cmp) = (d.join("sa.json"), d.join("sc.json"), d.join("cmp.json"));
    ok(&[
        "shift-angle",
        &s(&lab),
        "--instrument",
        &example("instrument-shift-angle.toml"),
        "--json",
        &s(&sa),
    ]);
    ok(&[
        "selfcal",
        &s(&heads),
        "--heads",
        "selfa12",
        "--instrument",
        &example("instrument-selfcal.toml"),
        "--json",
        &s(&sc),
    ]);
    ok(&["compare", &s(&sa), &s(&sc), "--json", &s(&cmp)]);
    (sa, sc, cmp)
}

fn xmllint(file: &Path) -> Output {
    Command::new("xmllint")
        .args([
            "--noout",
            "--schema",
            &repo("schemas/dcc/dcc-3.1.2.xsd"),
            &s(file),
        ])
        .output()
        .expect("xmllint runs (Debian package libxml2-utils; .ci/run installs it)")
}

#[test]
fn dcc_export_validates_against_the_dcc_schema() {
    let d = tempfile::tempdir().unwrap();
    let (sa, sc, _) = certificates(d.path());
    let meta = example("certificate-meta.toml");
    for (cert, name) in [(&sa, "sa.xml"), (&sc, "sc.xml")] {
        let xml = d.path().join(name);
        let out = ok(&["certificate", &s(cert), "--meta", &meta, "--dcc", &s(&xml)]);
        assert!(out.contains("metadata complete"), "{out}");
        let v = xmllint(&xml);
        assert!(
            v.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&v.stderr)
        );
        let text = std::fs::read_to_string(&xml).unwrap();
        assert!(text.contains("xmlns:dcc=\"https://ptb.de/dcc\""));
        assert!(text.contains("<dcc:uniqueIdentifier>GON-2025-0042</dcc:uniqueIdentifier>"));
        assert!(text.contains("<si:unit>\\arcsecond</si:unit>"));
        // Every calibrated angle is an si:real with its expanded uncertainty.
        let c: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(cert).unwrap()).unwrap();
        let key = if name == "sa.xml" {
            "encoder_errors"
        } else {
            "errors"
        };
        let n = c[key].as_array().unwrap().len();
        assert_eq!(
            text.matches("<si:expandedUnc>").count(),
            n + if name == "sa.xml" { 24 } else { 0 }
        );
        assert_eq!(text.matches("<si:unit>\\degree</si:unit>").count(), n);
    }
    // Without metadata: refused (exit 2, the missing fields named), or a schema-valid draft.
    let xml = d.path().join("draft.xml");
    let o = gonio(&["certificate", &s(&sa), "--dcc", &s(&xml)]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("customer.name") && err.contains("--draft"),
        "{err}"
    );
    assert!(!xml.exists());
    ok(&["certificate", &s(&sa), "--dcc", &s(&xml), "--draft"]);
    let v = xmllint(&xml);
    assert!(v.status.success(), "{}", String::from_utf8_lossy(&v.stderr));
    assert!(std::fs::read_to_string(&xml).unwrap().contains("DRAFT"));
}

fn chromium() -> String {
    for c in [
        "/usr/bin/chromium",
        "/usr/bin/chromium-browser",
        "/usr/bin/google-chrome",
    ] {
        if Path::new(c).exists() {
            return c.into();
        }
    }
    panic!("headless Chromium not found (Debian package chromium; .ci/run installs it)");
}

/// Renders `url` to a PNG of `w`×`h` px; returns Chromium's log (stderr).
fn screenshot(dir: &Path, url: &str, png: &Path, w: u32, h: u32, extra: &[&str]) -> String {
    let profile = tempfile::tempdir_in(dir).unwrap();
    let mut args = vec![
        "--headless".to_string(),
        "--no-sandbox".into(),
        "--disable-gpu".into(),
        "--disable-quic".into(),
        "--no-first-run".into(),
        "--disable-background-networking".into(),
        "--disable-component-update".into(),
        "--disable-sync".into(),
        "--hide-scrollbars".into(),
        // Any attempt to reach the network fails loudly.
        "--host-resolver-rules=MAP * ~NOTFOUND".into(),
        format!("--user-data-dir={}", s(profile.path())),
        "--enable-logging=stderr".into(),
        "--v=0".into(),
        format!("--window-size={w},{h}"),
        format!("--screenshot={}", s(png)),
    ];
    args.extend(extra.iter().map(|a| a.to_string()));
    args.push(url.into());
    let o = Command::new(chromium())
        .args(&args)
        .output()
        .expect("chromium runs");
    assert!(
        o.status.success() && png.exists(),
        "chromium failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Console messages and failed loads in Chromium's log (its own D-Bus and GPU chatter aside).
fn page_errors(log: &str) -> Vec<&str> {
    log.lines()
        .filter(|l| l.contains("CONSOLE") || l.contains("net::ERR") || l.contains("Uncaught"))
        .collect()
}

/// In a rectangle: the fraction of pixels that are not (near) white, and the number of coloured
/// pixels (not grey: axes, ticks and text are black and grey, data is drawn in colour).
fn ink(img: &image::RgbaImage, x0: u32, y0: u32, w: u32, h: u32) -> (f64, usize) {
    let (mut dark, mut coloured) = (0usize, 0usize);
    for y in y0..(y0 + h).min(img.height()) {
        for x in x0..(x0 + w).min(img.width()) {
            let p = img.get_pixel(x, y).0;
            if p[0] < 235 || p[1] < 235 || p[2] < 235 {
                dark += 1;
            }
            let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
            if hi - lo > 40 {
                coloured += 1;
            }
        }
    }
    (dark as f64 / (w * h) as f64, coloured)
}

#[test]
fn report_renders_in_headless_chromium() {
    let d = tempfile::tempdir().unwrap();
    let (sa, sc, cmp) = certificates(d.path());
    let batch = d.path().join("batch.json");
    ok(&[
        "mount",
        "--sim",
        "--seed",
        "2",
        "--parts",
        "12",
        "--json",
        &s(&batch),
    ]);
    let html = d.path().join("report.html");
    let plots = d.path().join("plots");
    let out = ok(&[
        "report",
        &s(&sa),
        &s(&sc),
        &s(&cmp),
        &s(&batch),
        "--meta",
        &example("certificate-meta.toml"),
        "--out",
        &s(&html),
        "--plots",
        &s(&plots),
    ]);
    assert!(!out.contains("DRAFT"), "{out}");
    let text = std::fs::read_to_string(&html).unwrap();
    // Self-contained: nothing is fetched (SVG's xmlns is a name, not a load).
    for needle in ["src=\"http", "href=\"http", "url(http", "<script", "<link"] {
        assert!(!text.contains(needle), "report contains {needle}");
    }
    let mut svgs: Vec<PathBuf> = std::fs::read_dir(&plots)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    svgs.sort();
    // Two certificates (7 + 4 plots), the comparison (1) and the batch (3).
    assert_eq!(svgs.len(), 15, "{svgs:?}");
    assert_eq!(text.matches("<figure class=\"plot\"").count(), svgs.len());

    // The whole page: rendered, not blank, no console error or network attempt.
    let page = d.path().join("page.png");
    let log = screenshot(
        d.path(),
        &format!("file://{}", s(&html)),
        &page,
        1000,
        16000,
        &[],
    );
    let errors = page_errors(&log);
    assert!(errors.is_empty(), "console: {errors:?}");
    let img = image::open(&page).unwrap().to_rgba8();
    let (frac, colours) = ink(&img, 0, 0, img.width(), img.height());
    assert!(
        frac > 0.03 && colours > 8,
        "blank page? ink {frac}, colours {colours}"
    );
    // The parsed page holds every plot with its drawing (DOM after load).
    let dom = Command::new(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--dump-dom",
            &format!("--user-data-dir={}", s(&d.path().join("prof-dom"))),
            &format!("file://{}", s(&html)),
        ])
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert_eq!(dom.matches("<figure class=\"plot\"").count(), svgs.len());
    for fig in dom.split("<figure class=\"plot\"").skip(1) {
        let body = &fig[..fig.find("</figure>").unwrap()];
        // Axes and grid are black and grey; data is drawn in the report's palette.
        let data = [
            "#0072B2", "#D55E00", "#009E73", "#56B4E9", "#CC79A7", "#E69F00",
        ]
        .iter()
        .map(|c| body.matches(c).count())
        .sum::<usize>();
        assert!(
            body.contains("<svg") && data >= 1,
            "a plot without data ({} bytes, {data} data elements): {}",
            body.len(),
            &body[..80.min(body.len())]
        );
    }

    // Every plot on its own, laid out on a grid of known cells: each cell has ink and colour.
    let (cw, ch) = (430u32, 260u32);
    let mut grid = String::from("<!DOCTYPE html><html><body style=\"margin:0;background:#fff\">");
    for (i, p) in svgs.iter().enumerate() {
        let (x, y) = ((i % 2) as u32 * cw, (i / 2) as u32 * ch);
        grid.push_str(&format!(
            "<img src=\"{}\" style=\"position:absolute;left:{x}px;top:{y}px;width:{}px;height:{}px;object-fit:contain\">",
            s(p),
            cw - 10,
            ch - 10
        ));
    }
    grid.push_str("</body></html>");
    let grid_html = d.path().join("grid.html");
    std::fs::write(&grid_html, grid).unwrap();
    let rows = svgs.len().div_ceil(2) as u32;
    let shot = d.path().join("grid.png");
    let log = screenshot(
        d.path(),
        &format!("file://{}", s(&grid_html)),
        &shot,
        2 * cw,
        rows * ch,
        &["--allow-file-access-from-files"],
    );
    assert!(page_errors(&log).is_empty(), "{:?}", page_errors(&log));
    let img = image::open(&shot).unwrap().to_rgba8();
    for (i, p) in svgs.iter().enumerate() {
        let (x, y) = ((i % 2) as u32 * cw, (i / 2) as u32 * ch);
        let (frac, coloured) = ink(&img, x, y, cw - 10, ch - 10);
        // Axes, ticks and labels alone are ink without colour; one thin data curve across the
        // cell is a few hundred coloured pixels.
        assert!(
            frac > 0.01 && coloured >= 150,
            "{}: ink {frac:.3}, {coloured} coloured px",
            p.display()
        );
    }
    if let Ok(dir) = std::env::var("GONIO_KEEP_SCREENSHOTS") {
        for f in [&page, &shot] {
            std::fs::copy(f, Path::new(&dir).join(f.file_name().unwrap())).unwrap();
        }
    }
}

#[test]
fn an_axis_report_draws_the_standards_plot_and_table() {
    let d = tempfile::tempdir().unwrap();
    let p = |name: &str| s(&d.path().join(name));
    ok(&["simulate", "axis", "--seed", "4", "--out", &p("ax")]);
    ok(&["axis", &p("ax/readings.csv"), "--json", &p("axis.json")]);
    ok(&[
        "simulate",
        "axis",
        "--seed",
        "4",
        "--directions",
        "+",
        "--out",
        &p("up"),
    ]);
    ok(&["axis", &p("up/readings.csv"), "--json", &p("up.json")]);
    let out = ok(&[
        "report",
        &p("axis.json"),
        &p("up.json"),
        "--out",
        &p("axis.html"),
        "--plots",
        &p("plots"),
    ]);
    assert!(out.contains("2 plots"), "{out}");
    let html = std::fs::read_to_string(d.path().join("axis.html")).unwrap();
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("axis.json")).unwrap())
            .unwrap();
    // The table: the twelve parameters with their values and U, as the JSON has them; the
    // unidirectional test's bidirectional ones undefined.
    let tables: Vec<&str> = html
        .split("<table class=\"grid\" id=\"axis-parameters\">")
        .skip(1)
        .map(|t| &t[..t.find("</table>").unwrap()])
        .collect();
    assert_eq!(tables.len(), 2);
    assert_eq!(tables[0].matches("<tr>").count(), 1 + 12);
    let row = |t: &str, sym: &str| {
        let at = t.find(&format!("<td>{sym}</td>")).unwrap();
        t[at..t[at..].find("</tr>").unwrap() + at].to_string()
    };
    let a = row(tables[0], "A");
    assert!(
        a.contains(&format!(
            "<td>{:.3}</td>",
            doc["A_arcsec"].as_f64().unwrap()
        )) && a.contains(&format!(
            "<td>{:.3}</td>",
            doc["uncertainty"]["parameters"]["A_arcsec"]
                .as_f64()
                .unwrap()
        )),
        "{a}"
    );
    assert!(row(tables[1], "A").contains("<td>–</td><td>–</td>"));
    assert!(!row(tables[1], "A↑").contains('–'));
    assert!(html.contains("ISO 230-2:2014") && html.contains("unidirectional (positive)"));
    // Rendered in Chromium: no console error; each plot, on its own, has ink and both
    // directions' colours (a unidirectional test's one).
    let page = d.path().join("axis.png");
    let log = screenshot(
        d.path(),
        &format!("file://{}", p("axis.html")),
        &page,
        1000,
        3000,
        &[],
    );
    assert!(page_errors(&log).is_empty(), "{:?}", page_errors(&log));
    let mut svgs: Vec<PathBuf> = std::fs::read_dir(d.path().join("plots"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    svgs.sort();
    for (svg, colours) in svgs.iter().zip([&["#0072B2", "#D55E00"][..], &["#0072B2"]]) {
        let text = std::fs::read_to_string(svg).unwrap();
        for c in colours {
            assert!(text.matches(c).count() >= 9, "{}: {c}", svg.display());
        }
        let png = svg.with_extension("png");
        let log = screenshot(d.path(), &format!("file://{}", s(svg)), &png, 860, 400, &[]);
        assert!(page_errors(&log).is_empty(), "{:?}", page_errors(&log));
        let img = image::open(&png).unwrap().to_rgba8();
        let (frac, coloured) = ink(&img, 0, 0, img.width(), img.height());
        assert!(
            frac > 0.02 && coloured >= 500,
            "{}: ink {frac:.3}, {coloured} coloured px",
            svg.display()
        );
    }
}
