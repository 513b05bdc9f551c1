//! A DCC is valid or not written: many random certificates, hand-edited the way a
//! user could (negative U, p > 1, k < 1, angles out of range or twice, no angles) and with
//! random metadata strings (control characters, XML's special characters, any Unicode, NaN
//! temperatures), go the way `gonio certificate --dcc` takes them: read from JSON (validated),
//! then written as a DCC. Every case the generator made valid must be written and validate
//! against the bundled schema (`xmllint --schema schemas/dcc/dcc-3.1.2.xsd`, one run over all
//! files); every case it made invalid must be refused, when read or when written.

use gonio_calib::certificate::{
    Authorisation, CalibrationDates, Certificate, CertificateMeta, Date, Environment, Instrument,
    Item, MethodMeta, Party, ReferenceStandard,
};
use gonio_calib::shift_angle::{Options, Reading, ReadingSet, calibrate};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use std::process::Command;

/// A shift-angle certificate of a 6-face polygon at two shifts (12 angles), with U, k and p.
fn base() -> Certificate {
    let mut r = Vec::new();
    for s in [0.0, 20.0] {
        for j in 1..=6usize {
            for i in 1..=6usize {
                for (k, e) in [(1u32, 0.01), (2, -0.01)] {
                    let v = 0.1 * i as f64 - 0.05 * j as f64 + e + s * 1e-3;
                    r.push(Reading {
                        repeat: k,
                        ..Reading::new(s, j, i, v)
                    });
                }
            }
        }
    }
    let set = ReadingSet::new(6, r).unwrap();
    let cal = calibrate(&set, &Options::default()).unwrap();
    Certificate::from_shift_angle(&cal, &set, false, 2, &Instrument::default()).unwrap()
}

/// A random string; `bad` puts a character XML 1.0 cannot carry in it.
fn text(rng: &mut ChaCha8Rng, bad: bool) -> String {
    const POOL: &[&str] = &[
        "a",
        "Z",
        "7",
        " ",
        "<",
        ">",
        "&",
        "\"",
        "'",
        "]]>",
        "ü",
        "ß",
        "測",
        "🙂",
        "\t",
        "\n",
        "\r",
        "±",
        "″",
        "\u{a0}",
        "\u{2028}",
        "\u{fffd}",
        "<!--",
        "&amp;",
        "\u{10ffff}",
    ];
    const BAD: &[char] = &[
        '\u{1}', '\u{1b}', '\u{c}', '\u{0}', '\u{7f}', '\u{fffe}', '\u{ffff}',
    ];
    let n = rng.random_range(0..12);
    let mut s: String = (0..n)
        .map(|_| POOL[rng.random_range(0..POOL.len())])
        .collect();
    if bad {
        let c = BAD[rng.random_range(0..BAD.len())];
        let at = rng.random_range(0..=s.chars().count());
        let i = s.char_indices().nth(at).map_or(s.len(), |(i, _)| i);
        s.insert(i, c);
    }
    s
}

/// One random case and whether a valid DCC must come out of it.
fn case(rng: &mut ChaCha8Rng, base: &Certificate) -> (Certificate, bool) {
    let mut c = base.clone();
    let mut ok = true;
    // Each kind of damage with a small probability, so that most cases are valid.
    let hit = |rng: &mut ChaCha8Rng| rng.random_bool(0.005);
    for p in &mut c.points {
        p.value_arcsec = match rng.random_range(0..4) {
            0 => rng.random_range(-1e6..1e6),
            1 => rng.random_range(-1e-9..1e-9),
            _ => rng.random_range(-2.0..2.0),
        };
        p.u_arcsec = rng.random_range(0.0..0.5);
        let k = rng.random_range(1.0..5.0);
        p.k = Some(k);
        p.expanded_arcsec = Some(k * p.u_arcsec);
        p.p = Some(rng.random_range(0.7..0.999));
        if hit(rng) {
            p.expanded_arcsec = Some(-rng.random_range(1e-6..1.0));
            ok = false;
        }
        if hit(rng) {
            p.p = Some(rng.random_range(1.0..2.0));
            ok = false;
        }
        if hit(rng) {
            // A coverage factor below 1: a valid certificate, but no DCC states it.
            p.k = Some(rng.random_range(0.1..0.99));
            ok = false;
        }
        if hit(rng) {
            p.angle_deg = [1e300, -5.0, 360.0, 720.5][rng.random_range(0..4)];
            ok = false;
        }
    }
    if hit(rng) {
        let n = c.points.len();
        let (i, j) = (rng.random_range(0..n), rng.random_range(0..n));
        if i != j {
            c.points[i].angle_deg = c.points[j].angle_deg;
            ok = false;
        }
    }
    if rng.random_bool(0.02) {
        c.points.clear();
        ok = false;
    }
    // Metadata: every text random, now and then with a control character.
    let mut t = |rng: &mut ChaCha8Rng| {
        let bad = rng.random_bool(0.003);
        if bad {
            ok = false;
        }
        Some(text(rng, bad))
    };
    let party =
        |rng: &mut ChaCha8Rng, t: &mut dyn FnMut(&mut ChaCha8Rng) -> Option<String>| Party {
            name: t(rng),
            address: t(rng),
            country: Some(["DE", "de", "ZZZ", "", "FR"][rng.random_range(0..5)].into()),
            email: t(rng),
            phone: t(rng),
            accreditation: t(rng),
        };
    let mut meta = CertificateMeta {
        title: t(rng),
        certificate_number: t(rng),
        language: Some(["en", "de", "EN", "x", ""][rng.random_range(0..5)].into()),
        laboratory: Some(party(rng, &mut t)),
        location: t(rng),
        customer: Some(party(rng, &mut t)),
        item: Some(Item {
            description: t(rng),
            manufacturer: t(rng),
            model: t(rng),
            identification: t(rng),
            condition: t(rng),
        }),
        dates: Some(CalibrationDates {
            receipt: Some(Date::parse("2025-03-01").unwrap()),
            calibration: Some(Date::parse("2025-03-10").unwrap()),
            calibration_end: None,
            issue: Some(Date::parse("2025-03-14").unwrap()),
        }),
        method: Some(MethodMeta {
            procedure: t(rng),
            description: t(rng),
        }),
        environment: None,
        traceability: t(rng),
        reference_standards: ["polygon", "autocollimator"]
            .iter()
            .map(|role| ReferenceStandard {
                role: (*role).into(),
                description: t(rng),
                manufacturer: t(rng),
                identification: t(rng),
                certificate: t(rng),
                issued_by: t(rng),
                calibrated: None,
            })
            .collect(),
        deviations: t(rng),
        authorisation: Some(Authorisation {
            name: t(rng),
            function: t(rng),
        }),
        remarks: t(rng),
    };
    let mut env = Environment {
        temperature_c: Some(rng.random_range(15.0..25.0)),
        temperature_tolerance_c: Some(rng.random_range(0.0..1.0)),
        humidity_percent: Some(rng.random_range(20.0..80.0)),
        humidity_tolerance_percent: Some(rng.random_range(0.0..10.0)),
    };
    if rng.random_bool(0.03) {
        // (NaN and ∞ cannot pass through JSON: they are `null` there; the TOML metadata's NaN is
        // refused when read, tests/honest_values_cli.rs.)
        env.temperature_c = Some([-300.0, -273.5, 1e5][rng.random_range(0..3)]);
        ok = false;
    }
    if rng.random_bool(0.03) {
        env.humidity_percent = Some([100.5, 101.0, -1.0][rng.random_range(0..3)]);
        ok = false;
    }
    meta.environment = Some(env);
    (c.with_meta(meta), ok)
}

#[test]
fn the_dcc_writer_writes_schema_valid_xml_or_nothing() {
    let d = tempfile::tempdir().unwrap();
    let base = base();
    let mut rng = ChaCha8Rng::seed_from_u64(29);
    let (mut written, mut refused) = (Vec::new(), 0usize);
    const CASES: usize = 400;
    for i in 0..CASES {
        let (cert, ok) = case(&mut rng, &base);
        // The path of `gonio certificate`: the certificate read from its JSON, then the DCC.
        let json = serde_json::to_string(&cert).unwrap();
        let read: Result<Certificate, _> = serde_json::from_str(&json);
        let xml = read
            .map_err(|e| e.to_string())
            .and_then(|c| gonio_report::dcc::write(&c, true).map_err(|e| e.to_string()));
        match xml {
            Ok(x) => {
                assert!(ok, "case {i}: a damaged certificate was written as a DCC");
                let p = d.path().join(format!("case-{i:03}.xml"));
                std::fs::write(&p, x).unwrap();
                written.push(p);
            }
            Err(e) => {
                assert!(!ok, "case {i}: a valid certificate was refused: {e}");
                assert!(!e.contains('\n'), "case {i}: {e}");
                refused += 1;
            }
        }
    }
    // Both kinds occur, most cases are valid.
    assert!(written.len() > CASES / 3, "{} written", written.len());
    assert!(refused > 20, "{refused} refused");
    let schema = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../schemas/dcc/dcc-3.1.2.xsd");
    let o = Command::new("xmllint")
        .arg("--noout")
        .arg("--schema")
        .arg(&schema)
        .args(&written)
        .output()
        .expect("xmllint runs (Debian package libxml2-utils)");
    let err = String::from_utf8_lossy(&o.stderr);
    let failed: Vec<&str> = err
        .lines()
        .filter(|l| !l.ends_with(" validates"))
        .take(5)
        .collect();
    assert!(
        o.status.success() && failed.is_empty(),
        "xmllint: {failed:?}"
    );
    assert_eq!(err.lines().count(), written.len(), "{err}");
}

#[test]
fn a_value_a_dcc_cannot_state_is_an_error_naming_it() {
    let mut c = base().with_meta(CertificateMeta::default());
    c.points[3].k = Some(0.67);
    let e = gonio_report::dcc::write(&c, true).unwrap_err().to_string();
    assert!(e.contains("angle 3") && e.contains("k = 0.67"), "{e}");
    let mut c = base();
    c.points[0].value_arcsec = f64::NAN;
    let e = gonio_report::dcc::write(&c, true).unwrap_err().to_string();
    assert!(e.contains("angle 0") && e.contains("NaN"), "{e}");
    // A control character that reached the writer unchecked is refused, not written.
    let mut c = base();
    c.method = "least\u{1b}squares".into();
    let e = gonio_report::dcc::write(&c, true).unwrap_err().to_string();
    assert!(e.contains("U+001B"), "{e}");
}
