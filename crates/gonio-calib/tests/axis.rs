//! ISO 230-2 parameters against a data set computed by hand: 5 targets × 5 runs × 2 directions,
//! each cell's five deviations μ + c·(−2, −1, 0, 1, 2), so that x̄ = μ and
//! s = c·√((4 + 1 + 0 + 1 + 4)/4) = c·√2.5 exactly. Every expected value below is worked out from
//! the standard's definitions in the comments, not by the code under test.

use gonio_calib::axis::{
    AxisError, AxisInput, AxisReading, Direction, FaceReading, Polygon, analyse, evaluate,
};
use gonio_calib::certificate::Instrument;

/// (target, μ↑, c↑, μ↓, c↓).
const CELLS: [(f64, f64, f64, f64, f64); 5] = [
    (0.0, 1.0, 0.2, -1.0, 0.4),
    (90.0, 2.5, 0.4, 0.5, 0.2),
    (180.0, 0.5, 0.6, -2.0, 0.2),
    (270.0, -1.5, 0.2, -2.5, 0.4),
    (360.0, 1.5, 0.2, 0.0, 0.8),
];

const OFFSETS: [f64; 5] = [-2.0, -1.0, 0.0, 1.0, 2.0];

fn readings(directions: &[Direction]) -> Vec<AxisReading> {
    let mut r = Vec::new();
    // Runs in the order of the standard's cycle: run j up through all targets, then down.
    for (j, o) in OFFSETS.iter().enumerate() {
        for &d in directions {
            for &(t, mu_up, c_up, mu_down, c_down) in &CELLS {
                let (mu, c) = match d {
                    Direction::Up => (mu_up, c_up),
                    Direction::Down => (mu_down, c_down),
                };
                r.push(AxisReading {
                    target_deg: t,
                    direction: d,
                    run: j as u32 + 1,
                    deviation_arcsec: mu + c * o,
                });
            }
        }
    }
    r
}

fn close(what: &str, got: Option<f64>, want: f64) {
    let g = got.unwrap_or_else(|| panic!("{what}: null, expected {want}"));
    assert!(
        (g - want).abs() <= 1e-9 * want.abs(),
        "{what}: {g}, expected {want}"
    );
}

#[test]
fn every_parameter_of_the_hand_computed_test() {
    let q = 2.5f64.sqrt();
    let e = evaluate(&readings(&Direction::BOTH)).unwrap();
    let p = e.parameters;
    // B_i = μ↑ − μ↓ = 2, 2, 2.5, 1, 1.5.
    close("B", p.b, 2.5);
    close("B_mean", p.b_mean, 9.0 / 5.0);
    // R_i↑ = 4c↑q: largest at 180° (c = 0.6); R_i↓ = 4c↓q: largest at 360° (c = 0.8).
    close("R_up", p.r_up, 2.4 * q);
    close("R_down", p.r_down, 3.2 * q);
    // R_i = max(2s↑ + 2s↓ + |B_i|, R_i↑, R_i↓): 1.2q + 2, 1.2q + 2, 1.6q + 2.5, 1.2q + 1, and
    // at 360° max(2q + 1.5, 3.2q) = 3.2q (5.0596), just above 1.6q + 2.5 (5.0298).
    close("R", p.r, 3.2 * q);
    // E↑ = 2.5 − (−1.5); E↓ = 0.5 − (−2.5); E over both = 2.5 − (−2.5).
    close("E_up", p.e_up, 4.0);
    close("E_down", p.e_down, 3.0);
    close("E", p.e, 5.0);
    // x̄_i = 0, 1.5, −0.75, −2, 0.75.
    close("M", p.m, 3.5);
    // A↑: max(μ↑ + 2s↑) = 2.5 + 0.8q (90°), min(μ↑ − 2s↑) = −1.5 − 0.4q (270°).
    close("A_up", p.a_up, 4.0 + 1.2 * q);
    // A↓: max(μ↓ + 2s↓) = 1.6q (360°), min(μ↓ − 2s↓) = −2.5 − 0.8q (270°).
    close("A_down", p.a_down, 2.5 + 2.4 * q);
    // A: max over both 2.5 + 0.8q, min over both −2.5 − 0.8q.
    close("A", p.a, 5.0 + 1.6 * q);
    // Per target, 180°: x̄↑ 0.5, x̄↓ −2, s↑ 0.6q, s↓ 0.2q, B_i 2.5, R_i 1.6q + 2.5, n 5 and 5.
    let doc = analyse(
        &AxisInput::Deviations(readings(&Direction::BOTH)),
        &Instrument::default(),
    )
    .unwrap();
    let t = &doc.targets[2];
    assert_eq!((t.target_deg, t.n_up, t.n_down), (180.0, 5, 5));
    close("x̄↑(180)", t.mean_up_arcsec, 0.5);
    close("x̄↓(180)", t.mean_down_arcsec, -2.0);
    close("s↑(180)", t.s_up_arcsec, 0.6 * q);
    close("s↓(180)", t.s_down_arcsec, 0.2 * q);
    close("B(180)", t.b_arcsec, 2.5);
    close("R(180)", t.r_arcsec, 1.6 * q + 2.5);
    // The compensation: −x̄↑, −x̄↓ and −x̄_i.
    let c = &doc.compensation[1];
    close("up(90)", c.correction_up_arcsec, -2.5);
    close("down(90)", c.correction_down_arcsec, -0.5);
    close("mean(90)", Some(c.correction_mean_arcsec), -1.5);
    // The uncertainty of the scatter alone: U(B̄) = 2·√(Σ_i (s↑² + s↓²)/n)/m with
    // Σ(c↑² + c↓²) = 1.68, so 2·√(1.68·2.5/5)/5; U(R↓) = 2·4·s/√(2(n − 1)) at s = 0.8q.
    let u = &doc.uncertainty.parameters;
    close(
        "U(B_mean)",
        u.b_mean,
        2.0 * (1.68 * 2.5 / 5.0f64).sqrt() / 5.0,
    );
    close("U(R_down)", u.r_down, 2.0 * 4.0 * 0.8 * q / 8.0f64.sqrt());
    assert!(doc.uncertainty.reference.is_none() && doc.bidirectional_note.is_none());
    assert!(doc.notes.is_empty(), "{:?}", doc.notes);
}

#[test]
fn a_unidirectional_test_has_its_direction_and_no_bidirectional_parameters() {
    let q = 2.5f64.sqrt();
    let doc = analyse(
        &AxisInput::Deviations(readings(&[Direction::Up])),
        &Instrument::default(),
    )
    .unwrap();
    let p = doc.parameters;
    close("A_up", p.a_up, 4.0 + 1.2 * q);
    close("E_up", p.e_up, 4.0);
    close("R_up", p.r_up, 2.4 * q);
    for (name, v) in p.named() {
        if !name.ends_with("_up") {
            assert_eq!(v, None, "{name}");
        }
    }
    assert_eq!(doc.test, "unidirectional (positive)");
    let note = doc.bidirectional_note.as_deref().unwrap();
    assert!(
        note.contains("unidirectional") && note.contains("null"),
        "{note}"
    );
    assert_eq!(doc.targets[0].mean_down_arcsec, None);
    assert_eq!(doc.compensation[0].correction_down_arcsec, None);
    close(
        "mean(0)",
        Some(doc.compensation[0].correction_mean_arcsec),
        -1.0,
    );
    // The JSON has the contract's names, nulls where undefined.
    let json = serde_json::to_value(&doc).unwrap();
    assert!(json["A_arcsec"].is_null() && json["A_up_arcsec"].is_number());
    assert!(json["targets"][0]["s_down_arcsec"].is_null());
}

#[test]
fn polygon_readings_give_the_same_parameters() {
    // A 4-face polygon, face 1 at 0°; each reading carries its face's term K(f) = β_1 + … + β_f.
    let beta = [0.3, -0.1, 0.2, -0.4];
    let poly = Polygon::new(&beta, &[0.01; 4], 20.0, "poly.json").unwrap();
    let rows: Vec<FaceReading> = readings(&Direction::BOTH)
        .iter()
        .map(|r| {
            let face = (r.target_deg / 90.0).round() as usize % 4 + 1;
            let k: f64 = beta[..face].iter().sum();
            FaceReading {
                target_deg: r.target_deg,
                direction: r.direction,
                run: r.run,
                reading_arcsec: r.deviation_arcsec + k,
                face: None,
            }
        })
        .collect();
    let doc = analyse(
        &AxisInput::Readings {
            rows,
            polygon: poly,
        },
        &Instrument::default(),
    )
    .unwrap();
    close("E", doc.parameters.e, 5.0);
    close("M", doc.parameters.m, 3.5);
    assert_eq!(doc.targets[4].face, Some(1));
    // The polygon's term enters the reference's budget: √(0.01² + 0.01²) is the largest (faces 2
    // and 3: the shorter of the two sums has two faces).
    let r = doc.uncertainty.reference.unwrap();
    assert!(
        (r.u_arcsec - 0.0002f64.sqrt()).abs() < 1e-15,
        "{}",
        r.u_arcsec
    );
}

#[test]
fn errors_name_what_is_missing() {
    let all = readings(&Direction::BOTH);
    // A run missing at one target.
    let mut r = all.clone();
    r.retain(|x| !(x.target_deg == 90.0 && x.direction == Direction::Down && x.run == 3));
    assert_eq!(
        evaluate(&r).unwrap_err().to_string(),
        "target 90°, negative direction: run 3 is missing (the test has runs 1–5)"
    );
    // One target approached from one side only.
    let mut r = all.clone();
    r.retain(|x| !(x.target_deg == 270.0 && x.direction == Direction::Up));
    assert!(matches!(
        evaluate(&r).unwrap_err(),
        AxisError::MissingDirection {
            target_deg: 270.0,
            direction: Direction::Up
        }
    ));
    // The same approach twice.
    let mut r = all.clone();
    r.push(all[7]);
    assert!(matches!(
        evaluate(&r).unwrap_err(),
        AxisError::Duplicate {
            index: 50,
            first: 7,
            ..
        }
    ));
    // One run, one target, a number out of range.
    let one_run: Vec<_> = all.iter().filter(|x| x.run == 1).copied().collect();
    assert!(matches!(
        evaluate(&one_run),
        Err(AxisError::TooFewRuns { runs: 1 })
    ));
    let one_target: Vec<_> = all
        .iter()
        .filter(|x| x.target_deg == 0.0)
        .copied()
        .collect();
    assert!(matches!(
        evaluate(&one_target),
        Err(AxisError::TooFewTargets { targets: 1 })
    ));
    let mut r = all.clone();
    r[3].deviation_arcsec = f64::NAN;
    assert!(matches!(
        evaluate(&r),
        Err(AxisError::OutOfRange {
            index: 3,
            what: "deviation_arcsec",
            ..
        })
    ));
    // A huge number is named the short way, not in three hundred digits.
    r[3].deviation_arcsec = -1e300;
    assert_eq!(
        evaluate(&r).unwrap_err().to_string(),
        "reading 3: deviation_arcsec -1e300 is out of range: expected −1000000 to 1000000"
    );
    assert_eq!(evaluate(&[]), Err(AxisError::Empty));
    // Fewer runs than the standard's five: evaluated, with a note.
    let three: Vec<_> = all.iter().filter(|x| x.run <= 3).copied().collect();
    let doc = analyse(&AxisInput::Deviations(three), &Instrument::default()).unwrap();
    assert_eq!(doc.runs, 3);
    assert!(doc.notes[0].contains("has 5"), "{:?}", doc.notes);
}

#[test]
fn a_polygon_certificate_out_of_its_bounds_is_refused() {
    let u = [0.01; 4];
    // A corrupt or foreign certificate's pitch deviation: named, never taken off the readings.
    let e = Polygon::new(&[0.1, 1e300, -0.1, 0.0], &u, 10.0, "p.json").unwrap_err();
    assert_eq!(
        e.to_string(),
        "the polygon's calibration: the pitch deviation of face 2, 1e300″, is out of range: expected −3600 to 3600 arcsec"
    );
    let e = Polygon::new(
        &[0.1, 0.0, -0.1, 0.0],
        &[0.01, 0.01, 5e4, 0.01],
        10.0,
        "p.json",
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("face 3's pitch deviation, 50000″"),
        "{e}"
    );
    assert!(Polygon::new(&[3600.0, -3600.0, 0.0], &[3600.0; 3], 10.0, "p.json").is_ok());
}
