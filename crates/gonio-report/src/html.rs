//! One self-contained HTML report: the embedded font, inline SVG plots, tables; no script, no
//! external resource, readable offline and printable.
//!
//! A report holds any number of sections, one per input: a calibration certificate (with its
//! ISO/IEC 17025 §7.8 administrative data, or a DRAFT banner naming what is missing), a
//! comparison of two certificates, a rotary axis tested to ISO 230-2, or a mounting batch.

use crate::ReportError;
use crate::batch::BatchView;
use crate::font;
use crate::plot::{self, Figure};
use gonio_calib::axis::AxisResult;
use gonio_calib::certificate::{Certificate, CertificateMeta, Procedure};
use gonio_calib::compare::Comparison;
use gonio_station::published;
use std::fmt::Write as _;

/// The paper behind the shift-angle method and the self-calibration comparison.
pub const HSIEH_2022: &str = "Hsieh, Watanabe, Hsu, “Calibration of Rotary Encoders Using a Shift-Angle Method”, Appl. Sci. 2022, 12(10), 5008";
/// The paper behind the mounting station.
pub const YU_2024: &str = "Yu et al., “Encoder grating mounting system based on near-sensor computing”, Sci. Rep. 2024 (s41598-024-72452-6)";

/// Escapes text for HTML.
pub fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            _ => o.push(c),
        }
    }
    o
}

fn multiline(s: &str) -> String {
    esc(s).replace('\n', "<br>")
}

fn f(v: f64, d: usize) -> String {
    if v.is_finite() {
        format!("{v:.d$}")
    } else {
        "–".into()
    }
}

fn opt(v: Option<f64>, d: usize) -> String {
    v.map_or("–".into(), |x| f(x, d))
}

fn dof(v: Option<f64>) -> String {
    match v {
        Some(x) if x.is_infinite() => "∞".into(),
        Some(x) if x.fract() == 0.0 => format!("{x:.0}"),
        Some(x) => format!("{x:.1}"),
        None => "–".into(),
    }
}

/// A report being assembled.
#[derive(Debug, Clone, Default)]
pub struct Report {
    title: String,
    body: String,
    figures: Vec<Figure>,
    drafts: usize,
    sections: usize,
}

impl Report {
    /// An empty report with a title.
    pub fn new(title: &str) -> Report {
        Report {
            title: title.to_string(),
            ..Report::default()
        }
    }

    /// Every figure so far, in order (ids made unique per report).
    pub fn figures(&self) -> &[Figure] {
        &self.figures
    }

    /// Whether any certificate in the report is a draft (required metadata missing).
    pub fn is_draft(&self) -> bool {
        self.drafts > 0
    }

    fn figure(&mut self, mut fig: Figure) {
        self.sections_figure_id(&mut fig);
        let _ = writeln!(
            self.body,
            "<figure class=\"plot\" id=\"fig-{}\"><h3>{}</h3>{}<figcaption>{}</figcaption></figure>",
            esc(&fig.id),
            esc(&fig.title),
            fig.svg,
            esc(&fig.caption)
        );
        self.figures.push(fig);
    }

    fn sections_figure_id(&self, fig: &mut Figure) {
        if self.figures.iter().any(|g| g.id == fig.id) {
            fig.id = format!("{}-{}", fig.id, self.sections);
        }
    }

    /// Adds a calibration certificate: administrative data (or the DRAFT banner), results,
    /// plots, the budget, the statements and the signature block.
    ///
    /// # Errors
    /// [`ReportError::Plot`] if a plot cannot be drawn.
    pub fn add_certificate(&mut self, cert: &Certificate, source: &str) -> Result<(), ReportError> {
        self.sections += 1;
        let missing = cert.missing_meta();
        let meta = cert.meta.clone().unwrap_or_default();
        let title = meta
            .title
            .clone()
            .unwrap_or_else(|| "Calibration certificate".into());
        let b = &mut self.body;
        let _ = write!(
            b,
            "<section class=\"certificate\"><header><h1>{}</h1>",
            esc(&title)
        );
        if let Some(n) = &meta.certificate_number {
            let _ = write!(
                b,
                "<p class=\"number\">Certificate number <strong>{}</strong></p>",
                esc(n)
            );
        }
        let _ = write!(
            b,
            "<p class=\"method\">{} <span class=\"source\">({})</span></p></header>",
            esc(&cert.method_title()),
            esc(source)
        );
        if !missing.is_empty() {
            self.drafts += 1;
            let _ = write!(
                b,
                "<div class=\"draft\" role=\"alert\"><strong>DRAFT</strong> — not a valid certificate: {} required field{} missing: <code>{}</code>. Give them with <code>--meta META.toml</code> (see examples/certificate-meta.toml).</div>",
                missing.len(),
                if missing.len() == 1 { " is" } else { "s are" },
                esc(&missing.join(", "))
            );
        }
        admin_table(b, cert, &meta);
        results_summary(b, cert);
        for fig in [
            Some(plot::alpha(cert)?),
            Some(plot::compensation(cert)?),
            plot::pitch(cert)?,
        ]
        .into_iter()
        .flatten()
        {
            self.figure(fig);
        }
        for fig in plot::residuals(cert)? {
            self.figure(fig);
        }
        if let Some(fig) = plot::spectrum(cert)? {
            self.figure(fig);
        }
        if let Some(fig) = plot::budget_shares(cert)? {
            self.figure(fig);
        }
        let b = &mut self.body;
        budget_table(b, cert);
        harmonic_check_table(b, cert);
        values_table(b, cert);
        statements(b, cert, &meta);
        signature(b, cert, &meta);
        b.push_str("</section>\n");
        Ok(())
    }

    /// Adds a comparison of two certificates.
    ///
    /// # Errors
    /// [`ReportError::Plot`] if the plot cannot be drawn.
    pub fn add_comparison(&mut self, c: &Comparison, source: &str) -> Result<(), ReportError> {
        self.sections += 1;
        let b = &mut self.body;
        let _ = write!(
            b,
            "<section class=\"comparison\"><header><h1>Comparison of two calibrations</h1><p class=\"method\">as in {} §3.2 <span class=\"source\">({})</span></p></header>",
            esc(HSIEH_2022),
            esc(source)
        );
        let _ = write!(
            b,
            "<table class=\"kv\"><tr><th>A</th><td>{}</td></tr><tr><th>B</th><td>{}</td></tr>\
             <tr><th>common angles</th><td>{}</td></tr>\
             <tr><th>largest |A − B|</th><td>{} ″ at {}°</td></tr>\
             <tr><th>mean / RMS difference</th><td>{} ″ / {} ″</td></tr>\
             <tr><th>largest En</th><td class=\"{}\">{} at {}° ({})</td></tr>\
             <tr><th>U from</th><td>A: {}; B: {}</td></tr></table><p class=\"note\">{}</p>",
            esc(&c.method_a),
            esc(&c.method_b),
            c.points.len(),
            f(c.max_abs_difference_arcsec, 4),
            f(c.max_abs_difference_angle_deg, 3),
            f(c.mean_difference_arcsec, 4),
            f(c.rms_difference_arcsec, 4),
            if c.all_en_pass { "pass" } else { "fail" },
            opt(c.max_en, 2),
            opt(c.max_en_angle_deg, 3),
            if c.all_en_pass {
                "every En ≤ 1".to_string()
            } else if c.en_undefined > 0 {
                format!(
                    "not passed: En undefined at {} angles, where both U are 0",
                    c.en_undefined
                )
            } else {
                "some En > 1".to_string()
            },
            esc(&c.uncertainty_source.a),
            esc(&c.uncertainty_source.b),
            esc(&c.note)
        );
        self.figure(plot::comparison(c)?);
        self.body.push_str("</section>\n");
        Ok(())
    }

    /// Adds a rotary axis tested to ISO 230-2: the standard's plot and its tables.
    ///
    /// # Errors
    /// [`ReportError::Plot`] if the plot cannot be drawn.
    pub fn add_axis(&mut self, doc: &AxisResult, source: &str) -> Result<(), ReportError> {
        self.sections += 1;
        crate::axis::header(&mut self.body, doc, source);
        self.figure(crate::axis::figure(doc)?);
        crate::axis::tables(&mut self.body, doc);
        self.body.push_str("</section>\n");
        Ok(())
    }

    /// Adds a mounting batch, beside the 25 real parts of Yu et al., 2024.
    ///
    /// # Errors
    /// [`ReportError::Plot`] if a plot cannot be drawn.
    pub fn add_batch(&mut self, batch: &BatchView, source: &str) -> Result<(), ReportError> {
        self.sections += 1;
        let s = &batch.summary;
        let b = &mut self.body;
        let _ = write!(
            b,
            "<section class=\"batch\"><header><h1>Mounting batch</h1><p class=\"method\">automatic grating mounting as in {}; strategy {}{} <span class=\"source\">({})</span></p></header>",
            esc(YU_2024),
            esc(&batch.strategy),
            if batch.recipe.is_empty() {
                String::new()
            } else {
                format!(", recipe {}", esc(&batch.recipe))
            },
            esc(source)
        );
        let _ = write!(
            b,
            "<table class=\"grid\"><thead><tr><th></th><th>this batch ({} parts)</th><th>{}</th></tr></thead><tbody>\
             <tr><th>mean time per part</th><td>{} s</td><td>{} s</td></tr>\
             <tr><th>mean pushes per part</th><td>{}</td><td>{}</td></tr>\
             <tr><th>most pushes on one part</th><td>{}</td><td>{}</td></tr>\
             <tr><th>mean final eccentricity</th><td>{} µm</td><td>{} µm</td></tr>\
             <tr><th>parts rejected</th><td>{}</td><td>{}</td></tr></tbody></table>",
            s.parts,
            published::YU_2024.source,
            f(s.mean_time_s, 1),
            published::YU_2024.mean_time_s,
            f(s.mean_pushes, 2),
            published::YU_2024.mean_pushes,
            s.max_pushes,
            published::YU_2024.max_pushes,
            f(s.mean_final_e_um, 2),
            published::YU_2024.mean_final_e_um,
            s.rejected,
            published::YU_2024.rejected
        );
        for fig in [
            plot::batch_c_theta(batch)?,
            plot::batch_pushes(batch)?,
            plot::batch_parts(batch)?,
        ]
        .into_iter()
        .flatten()
        {
            self.figure(fig);
        }
        let b = &mut self.body;
        let _ = write!(
            b,
            "<details><summary>Every part ({})</summary><table class=\"grid\"><thead><tr><th>serial</th><th>initial e / µm</th><th>final e / µm</th><th>pushes</th><th>time / s</th><th>result</th></tr></thead><tbody>",
            batch.parts.len()
        );
        for p in &batch.parts {
            let _ = write!(
                b,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                esc(&p.serial),
                f(p.initial_e_um, 1),
                f(p.final_e_um, 2),
                p.pushes,
                f(p.time_s, 1),
                esc(&p.result.replace('_', " "))
            );
        }
        b.push_str("</tbody></table></details></section>\n");
        Ok(())
    }

    /// The whole document.
    pub fn render(&self) -> String {
        let mut o = String::with_capacity(self.body.len() + 300_000);
        let _ = write!(
            o,
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
             <meta name=\"generator\" content=\"gonio {}\"><title>{}{}</title><style>\n{}{}</style></head><body>\n",
            env!("CARGO_PKG_VERSION"),
            if self.is_draft() { "DRAFT — " } else { "" },
            esc(&self.title),
            font::css_font_faces(),
            CSS
        );
        o.push_str(&self.body);
        let _ = write!(
            o,
            "<footer>Produced by gonio {} · plots drawn as SVG with the embedded DejaVu Sans font · this file needs no network.</footer>\n</body></html>\n",
            env!("CARGO_PKG_VERSION")
        );
        o
    }
}

const CSS: &str = r#"
:root { --ink: #1a1a1a; --muted: #5a5a5a; --rule: #d0d0d0; --accent: #0072b2; }
* { box-sizing: border-box; }
body { font-family: 'GonioSans', sans-serif; color: var(--ink); margin: 0 auto; max-width: 960px; padding: 24px 28px 48px; font-size: 15px; line-height: 1.45; background: #fff; }
h1 { font-size: 26px; margin: 8px 0 4px; }
h2 { font-size: 19px; margin: 28px 0 8px; border-bottom: 1px solid var(--rule); padding-bottom: 3px; }
h3 { font-size: 16px; margin: 0 0 6px; }
section { margin-bottom: 56px; }
section + section { border-top: 3px double var(--rule); padding-top: 16px; }
header p { margin: 2px 0; }
.number { font-size: 16px; }
.method { color: var(--muted); }
.source { font-size: 13px; }
.draft { border: 2px solid #d55e00; background: #fff1e8; color: #8a3000; padding: 10px 14px; margin: 14px 0; font-size: 15px; }
.draft strong { font-size: 18px; letter-spacing: 0.08em; }
table { border-collapse: collapse; margin: 8px 0 14px; font-size: 14px; }
table.kv th { text-align: left; vertical-align: top; padding: 3px 18px 3px 0; color: var(--muted); font-weight: normal; white-space: nowrap; }
table.kv td { padding: 3px 0; }
table.grid th, table.grid td { border: 1px solid var(--rule); padding: 3px 8px; text-align: right; }
table.grid th:first-child, table.grid td:first-child { text-align: left; }
table.grid thead th { background: #f3f3f3; }
table.grid.text td, table.grid.text th, table.grid td.t { text-align: left; }
td.pass { color: #006b4e; } td.fail { color: #b03000; font-weight: bold; }
figure.plot { margin: 22px 0; page-break-inside: avoid; }
figure.plot svg { display: block; max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { color: var(--muted); font-size: 13.5px; margin-top: 4px; }
.note { color: var(--muted); font-size: 13.5px; }
.statements li { margin: 4px 0; }
.signature { margin-top: 28px; display: flex; gap: 48px; }
.signature div { min-width: 260px; border-top: 1px solid var(--ink); padding-top: 4px; }
details summary { cursor: pointer; color: var(--accent); margin: 8px 0; }
code { font-family: 'GonioSans', sans-serif; font-size: 13px; background: #f6f6f6; padding: 0 3px; }
.missing { color: #b03000; }
footer { color: var(--muted); font-size: 12px; border-top: 1px solid var(--rule); padding-top: 8px; }
@media print { body { max-width: none; padding: 0; } details { display: block; } }
"#;

fn row(b: &mut String, k: &str, v: Option<String>) {
    let _ = write!(
        b,
        "<tr><th>{}</th><td>{}</td></tr>",
        esc(k),
        v.unwrap_or_else(|| "<span class=\"missing\">not given</span>".into())
    );
}

fn party(p: &Option<gonio_calib::certificate::Party>) -> Option<String> {
    let p = p.as_ref()?;
    let mut s = String::new();
    if let Some(n) = &p.name {
        let _ = write!(s, "<strong>{}</strong>", esc(n));
    }
    if let Some(a) = &p.address {
        let _ = write!(s, "<br>{}", multiline(a));
    }
    if let Some(c) = &p.country {
        let _ = write!(s, " ({})", esc(c));
    }
    if let Some(e) = &p.email {
        let _ = write!(s, "<br>{}", esc(e));
    }
    if let Some(a) = &p.accreditation {
        let _ = write!(s, "<br>{}", esc(a));
    }
    (!s.is_empty()).then_some(s)
}

fn admin_table(b: &mut String, cert: &Certificate, m: &CertificateMeta) {
    b.push_str("<h2>Administrative data</h2><table class=\"kv\">");
    row(b, "Calibration laboratory", party(&m.laboratory));
    if let Some(l) = &m.location {
        row(b, "Place of calibration", Some(esc(l)));
    }
    row(b, "Customer", party(&m.customer));
    let item = m.item.as_ref().map(|i| {
        let mut s = String::new();
        if let Some(d) = &i.description {
            let _ = write!(s, "{}", esc(d));
        }
        let mm: Vec<&str> = [&i.manufacturer, &i.model]
            .into_iter()
            .filter_map(|x| x.as_deref())
            .collect();
        if !mm.is_empty() {
            let _ = write!(s, "<br>{}", esc(&mm.join(", ")));
        }
        if let Some(id) = &i.identification {
            let _ = write!(s, "<br>identification: <strong>{}</strong>", esc(id));
        }
        if let Some(c) = &i.condition {
            let _ = write!(s, "<br>condition: {}", esc(c));
        }
        s
    });
    row(b, "Item calibrated", item);
    let d = m.dates.clone().unwrap_or_default();
    let ds = |x: &Option<gonio_calib::certificate::Date>| x.as_ref().map(|d| esc(d.as_str()));
    row(b, "Date of receipt", ds(&d.receipt));
    row(
        b,
        "Date of calibration",
        ds(&d.calibration).map(|c| match &d.calibration_end {
            Some(e) => format!("{c} to {}", esc(e.as_str())),
            None => c,
        }),
    );
    row(b, "Date of issue", ds(&d.issue));
    let mut method = format!(
        "{}<br><span class=\"note\">{}</span>",
        esc(&cert.method_title()),
        esc(match cert.procedure {
            Procedure::ShiftAngle | Procedure::SelfCalibration | Procedure::Joint => HSIEH_2022,
            _ => "",
        })
    );
    if let Some(mm) = &m.method {
        if let Some(p) = &mm.procedure {
            let _ = write!(method, "<br>laboratory procedure: {}", esc(p));
        }
        if let Some(dsc) = &mm.description {
            let _ = write!(method, "<br>{}", esc(dsc));
        }
    }
    row(b, "Method", Some(method));
    let env = m.environment.as_ref().map(|e| {
        let pm = |t: Option<f64>, u: &str| t.map_or(String::new(), |t| format!(" ± {t} {u}"));
        format!(
            "temperature {}{}, relative humidity {}{}",
            e.temperature_c
                .map_or("not given".into(), |t| format!("{t} °C")),
            pm(e.temperature_tolerance_c, "°C"),
            e.humidity_percent
                .map_or("not given".into(), |h| format!("{h} %")),
            pm(e.humidity_tolerance_percent, "%")
        )
    });
    row(b, "Environmental conditions", env);
    row(b, "Traceability", m.traceability.as_deref().map(multiline));
    row(
        b,
        "Deviations from the method",
        m.deviations.as_deref().map(multiline),
    );
    if let Some(r) = &m.remarks {
        row(b, "Remarks", Some(multiline(r)));
    }
    b.push_str("</table>");
    let needed = CertificateMeta::required_standards(cert.procedure);
    if !m.reference_standards.is_empty() || !needed.is_empty() {
        b.push_str("<h2>Reference standards</h2><table class=\"grid text\"><thead><tr><th>role</th><th>description</th><th>identification</th><th>certificate</th><th>issued by</th><th>calibrated</th></tr></thead><tbody>");
        let o = |s: &Option<String>| s.as_deref().map_or("–".into(), esc);
        for s in &m.reference_standards {
            let _ = write!(
                b,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                esc(&s.role),
                o(&s.description),
                o(&s.identification),
                o(&s.certificate),
                o(&s.issued_by),
                s.calibrated
                    .as_ref()
                    .map_or("–".into(), |d| esc(d.as_str()))
            );
        }
        for role in needed.iter().filter(|r| m.standard(r).is_none()) {
            let _ = write!(
                b,
                "<tr><td>{}</td><td colspan=\"5\" class=\"fail\">not given</td></tr>",
                esc(role)
            );
        }
        b.push_str("</tbody></table>");
    }
}

fn results_summary(b: &mut String, cert: &Certificate) {
    let p0 = cert.points.iter().find(|p| p.expanded_arcsec.is_some());
    let _ = write!(
        b,
        "<h2>Results</h2><table class=\"kv\">\
         <tr><th>calibrated angles</th><td>{}</td></tr>\
         <tr><th>largest |α|</th><td>{} ″ (peak-to-peak {} ″)</td></tr>\
         <tr><th>largest expanded uncertainty U</th><td>{} ″</td></tr>\
         <tr><th>coverage</th><td>p = {} %, k = {} (ν_eff = {})</td></tr>\
         <tr><th>residuals</th><td>RMS {} ″, largest {} ″, σ̂ {} ″ per {}, {} degrees of freedom</td></tr>",
        cert.points.len(),
        f(cert.max_abs_error_arcsec(), 4),
        f(cert.peak_to_peak_arcsec(), 4),
        opt(cert.max_expanded_arcsec(), 4),
        f(cert.uncertainty.coverage * 100.0, 2),
        opt(p0.and_then(|p| p.k), 3),
        dof(p0.and_then(|p| p.nu_eff)),
        f(cert.residuals.rms_arcsec, 4),
        f(cert.residuals.max_abs_arcsec, 4),
        opt(cert.residuals.sigma_hat_arcsec, 4),
        cert.noise_unit().unwrap_or("reading"),
        dof(Some(cert.residuals.dof))
    );
    if let Some(c) = &cert.residuals.chi2 {
        let _ = write!(
            b,
            "<tr><th>χ² check against σ = {} ″</th><td class=\"{}\">χ² = {}, P(χ² ≥ this) = {}: {}</td></tr>",
            f(c.sigma_arcsec, 4),
            if c.consistent { "pass" } else { "fail" },
            f(c.chi2, 1),
            f(c.p_upper, 3),
            if c.consistent {
                "consistent with the stated σ"
            } else {
                "not consistent with the stated σ"
            }
        );
    }
    if let Some(sa) = &cert.shift_angle {
        let _ = write!(
            b,
            "<tr><th>polygon</th><td>{} faces; shifts {}; {} readings</td></tr>",
            sa.faces,
            esc(&shift_list(&sa.shifts_deg)),
            sa.readings
        );
    }
    if let Some(j) = &cert.joint {
        let sigma = |s: &gonio_calib::joint::SigmaUsed| {
            if s.stated {
                format!("σ {} ″ (stated)", f(s.sigma_arcsec, 4))
            } else {
                format!("σ {} ″ (from its residuals)", f(s.sigma_arcsec, 4))
            }
        };
        let _ = write!(
            b,
            "<tr><th>polygon</th><td>{} faces; shifts {}; {} readings; {}</td></tr>\
             <tr><th>read heads</th><td>{} heads at {}°; {} positions; {}</td></tr>",
            j.faces,
            esc(&shift_list(&j.shifts_deg)),
            j.readings,
            sigma(&j.sigma_polygon),
            j.heads_deg.len(),
            esc(&j
                .heads_deg
                .iter()
                .map(|h| format!("{h:.2}"))
                .collect::<Vec<_>>()
                .join(", ")),
            j.positions,
            sigma(&j.sigma_heads)
        );
        if let Some(c) = &j.consistency {
            let _ = write!(
                b,
                "<tr><th>agreement</th><td>Δχ² = {} for {} degrees of freedom, P = {}: {}</td></tr>",
                f(c.chi2, 1),
                c.dof,
                f(c.p_upper, 3),
                if c.consistent {
                    "the instruments agree"
                } else {
                    "the instruments disagree"
                }
            );
        }
    }
    if let Some(sc) = &cert.selfcal {
        let _ = write!(
            b,
            "<tr><th>read heads</th><td>{} heads at {}°; {} positions × {} turn(s); reference head(s) {:?}</td></tr>",
            sc.heads_deg.len(),
            esc(&sc
                .heads_deg
                .iter()
                .map(|h| format!("{h:.2}"))
                .collect::<Vec<_>>()
                .join(", ")),
            sc.positions,
            sc.turns,
            sc.reference_heads
        );
    }
    b.push_str("</table>");
}

fn shift_list(s: &[f64]) -> String {
    if s.len() > 6 {
        format!("{}° … {}° ({} shifts)", s[0], s[s.len() - 1], s.len())
    } else {
        s.iter()
            .map(|x| format!("{x}°"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

fn budget_table(b: &mut String, cert: &Certificate) {
    let Some(r) = &cert.budget else {
        return;
    };
    let _ = write!(
        b,
        "<h2>Uncertainty budget ({})</h2><p class=\"note\">GUM (JCGM 100:2008): the estimator's random part and the instrument terms{}, combined without correlation; ν_eff by Welch–Satterthwaite, truncated.</p>\
         <table class=\"grid\"><thead><tr><th>contribution</th><th>evaluation</th><th>u_i / ″</th><th>c_i</th><th>|c_i·u_i| / ″</th><th>ν_i</th><th>share of u_c²</th></tr></thead><tbody>",
        esc(&r.name),
        cert.uncertainty
            .instrument_file
            .as_deref()
            .map_or(String::new(), |p| format!(" ({})", esc(p)))
    );
    for c in &r.contributions {
        let _ = write!(
            b,
            "<tr><td>{}</td><td class=\"t\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{} %</td></tr>",
            esc(&c.name),
            esc(&c.source),
            f(c.u, 5),
            f(c.c, 3),
            f(c.cu, 5),
            dof(Some(c.nu)),
            f(c.share * 100.0, 1)
        );
    }
    let _ = write!(
        b,
        "</tbody><tfoot><tr><th>combined</th><td colspan=\"6\">u_c = {} ″, ν_eff = {} (raw {}), p = {} %, k = {}, <strong>U = {} ″</strong></td></tr></tfoot></table>",
        f(r.u_c, 5),
        dof(Some(r.nu_eff)),
        f(r.nu_eff_raw, 1),
        f(r.coverage * 100.0, 2),
        f(r.k, 3),
        f(r.expanded, 4)
    );
}

fn harmonic_check_table(b: &mut String, cert: &Certificate) {
    let Some(h) = cert
        .shift_angle
        .as_ref()
        .and_then(|s| s.harmonic_check.as_ref())
    else {
        return;
    };
    let _ = write!(
        b,
        "<h2>Harmonic check of the setup error</h2><p class=\"note\">As in Hsieh et al., 2022, §3.1: α(θ) + U ≈ A·sin({}θ + B) + U_fit at the first shift, then A and B held and U_fit refitted at every other shift and compared with U from the circle closure. A = {} ± {} ″, B = {} ± {} rad.</p>\
         <table class=\"grid\"><thead><tr><th>shift S / °</th><th>start face</th><th>U fit / ″</th><th>U closure / ″</th><th>difference / ″</th></tr></thead><tbody>",
        h.order,
        f(h.amplitude_arcsec, 4),
        opt(h.u_amplitude_arcsec, 4),
        f(h.phase_rad, 4),
        opt(h.u_phase_rad, 4)
    );
    for s in &h.shifts {
        let _ = write!(
            b,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:+.1e}</td></tr>",
            s.shift_deg,
            s.start_face,
            f(s.u_fit_arcsec, 4),
            f(s.u_closure_arcsec, 4),
            s.difference_arcsec
        );
    }
    b.push_str("</tbody></table>");
}

fn values_table(b: &mut String, cert: &Certificate) {
    let n = cert.points.len();
    let step = n.div_ceil(720).max(1);
    let _ = write!(
        b,
        "<h2>Calibration values</h2><details><summary>{} of {} angles{}</summary><table class=\"grid\"><thead><tr><th>θ / °</th><th>α / ″</th><th>u / ″</th><th>U / ″</th><th>k</th><th>ν_eff</th><th>correction / ″</th></tr></thead><tbody>",
        n.div_ceil(step),
        n,
        if step > 1 {
            format!(" (every {step}th; all of them in the certificate JSON and the DCC)")
        } else {
            String::new()
        }
    );
    for p in cert.points.iter().step_by(step) {
        let _ = write!(
            b,
            "<tr><td>{}</td><td>{:+.4}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:+.4}</td></tr>",
            f(p.angle_deg, 3),
            p.value_arcsec,
            f(p.u_arcsec, 4),
            opt(p.expanded_arcsec, 4),
            opt(p.k, 3),
            dof(p.nu_eff),
            -p.value_arcsec
        );
    }
    b.push_str("</tbody></table></details>");
}

/// The text with its first letter in upper case.
fn capitalise(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map_or(String::new(), |f| f.to_uppercase().chain(c).collect())
}

fn statements(b: &mut String, cert: &Certificate, m: &CertificateMeta) {
    b.push_str("<h2>Statements</h2><ul class=\"statements\">");
    let p = cert.uncertainty.coverage * 100.0;
    let _ = write!(
        b,
        "<li>The expanded uncertainty U is the combined standard uncertainty u_c multiplied by the coverage factor k = t_p(ν_eff) of Student's distribution for the effective degrees of freedom, so that the interval α ± U holds the value with a probability of about {p:.4} % (JCGM 100:2008).</li>"
    );
    let blind: Vec<String> = cert
        .spectrum
        .invisible
        .iter()
        .filter(|i| !i.orders.is_empty())
        .map(|i| {
            let k: Vec<String> = i.orders.iter().take(6).map(|k| k.to_string()).collect();
            format!(
                "the {} cannot see harmonics of order {}{}",
                i.by,
                k.join(", "),
                if i.orders.len() > 6 { ", …" } else { "" }
            )
        })
        .collect();
    if cert.procedure == Procedure::Joint {
        let k: Vec<String> = cert
            .undetectable_orders
            .iter()
            .take(6)
            .map(|k| k.to_string())
            .collect();
        let _ = write!(
            b,
            "<li>{}. The joint estimate holds every harmonic one of the instruments sees; only those neither sees are absent from the result whatever their size: order {}{}.</li>",
            esc(&capitalise(&blind.join("; "))),
            k.join(", "),
            if cert.undetectable_orders.len() > 6 {
                ", …"
            } else {
                ""
            }
        );
        b.push_str("<li>α has zero mean over the circle; the correction is −α, to be added to the encoder's reading.</li>");
    } else if !blind.is_empty() {
        let _ = write!(
            b,
            "<li>Harmonics of α that the method cannot see are absent from the result whatever their size: {}.</li>",
            esc(&blind.join("; "))
        );
    }
    if cert.procedure == Procedure::ShiftAngle {
        b.push_str("<li>α is determined up to its mean over each shift's angles (circle closure); the correction is −α, to be added to the encoder's reading.</li>");
    }
    b.push_str("<li>The results relate only to the item calibrated.</li>");
    if m.accreditation_note().is_some() {
        b.push_str("<li>This certificate may not be reproduced other than in full except with the permission of the issuing laboratory.</li>");
    }
    b.push_str("</ul>");
}

fn signature(b: &mut String, cert: &Certificate, m: &CertificateMeta) {
    let a = m.authorisation.clone().unwrap_or_default();
    let issue = m
        .dates
        .as_ref()
        .and_then(|d| d.issue.as_ref())
        .map_or("date of issue not given".into(), |d| esc(d.as_str()));
    let _ = write!(
        b,
        "<div class=\"signature\"><div>{}<br><span class=\"note\">{}</span></div><div>{}<br><span class=\"note\">date of issue</span></div></div><p class=\"note\">Computed by {} {} from {} (format {}).</p>",
        a.name
            .as_deref()
            .map_or("authorising person not given".into(), esc),
        a.function.as_deref().map_or(String::new(), esc),
        issue,
        esc(&cert.software.name),
        esc(&cert.software.version),
        esc(cert.procedure.title()),
        esc(&cert.format)
    );
}

/// The administrative-data helpers the report uses.
trait MetaExt {
    fn accreditation_note(&self) -> Option<&str>;
}

impl MetaExt for CertificateMeta {
    fn accreditation_note(&self) -> Option<&str> {
        self.laboratory.as_ref()?.accreditation.as_deref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gonio_calib::certificate::{CertificateMeta, Instrument};
    use gonio_calib::shift_angle::{Options, Reading, ReadingSet, calibrate};

    fn cert() -> Certificate {
        // A 6-face polygon, full matrix, two repeats: α = 0.3·sin 2θ, readings ±0.01″.
        let n = 6usize;
        let mut r = Vec::new();
        for j in 1..=n {
            for i in 1..=n {
                let t = ((i - 1) as f64 * 60.0).to_radians();
                for (k, e) in [(1u32, 0.01), (2, -0.01)] {
                    r.push(Reading {
                        repeat: k,
                        ..Reading::new(0.0, j, i, 0.3 * (2.0 * t).sin() + e * (i as f64))
                    });
                }
            }
        }
        let set = ReadingSet::new(n, r).unwrap();
        let cal = calibrate(&set, &Options::default()).unwrap();
        Certificate::from_shift_angle(&cal, &set, false, 1, &Instrument::default()).unwrap()
    }

    #[test]
    fn escapes_text_and_marks_drafts() {
        assert_eq!(
            esc("<a href=\"x\">&'"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
        let mut r = Report::new("t");
        r.add_certificate(&cert(), "c.json").unwrap();
        assert!(r.is_draft());
        let html = r.render();
        assert!(html.contains("<strong>DRAFT</strong>") && html.contains("customer.name"));
        assert!(html.starts_with("<!DOCTYPE html>") && html.contains("<title>DRAFT — t</title>"));
        // Metadata with script-like text is shown, not run.
        let meta = CertificateMeta {
            title: Some("<script>alert(1)</script>".into()),
            ..CertificateMeta::default()
        };
        let mut r = Report::new("t");
        r.add_certificate(&cert().with_meta(meta), "c.json")
            .unwrap();
        let html = r.render();
        assert!(!html.contains("<script>") && html.contains("&lt;script&gt;"));
        // One figure per plot, ids unique.
        let ids: std::collections::HashSet<_> = r.figures().iter().map(|f| &f.id).collect();
        assert_eq!(ids.len(), r.figures().len());
        assert!(r.figures().len() >= 6);
    }
}
