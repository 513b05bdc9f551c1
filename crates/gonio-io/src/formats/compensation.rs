//! The compensation tables (`--compensation`): a calibration's `angle_deg,correction_arcsec`,
//! the correction (−α) to add to the encoder's reading at each calibrated angle; an axis's
//! `target_deg,correction_up_arcsec,correction_down_arcsec,correction_mean_arcsec`, the
//! correction to add to the commanded position per direction of approach and for both alike
//! (an empty field for a direction a unidirectional test does not have).

use gonio_calib::axis::AxisCompensation;
use gonio_calib::certificate::Certificate;

/// The table of a certificate as CSV text (header and one row per angle).
pub fn csv(cert: &Certificate) -> String {
    let mut s = String::from("angle_deg,correction_arcsec\n");
    for c in &cert.compensation {
        s.push_str(&format!("{},{:.6}\n", c.angle_deg, c.correction_arcsec));
    }
    s
}

/// An axis's table as CSV text (header and one row per target).
///
/// ```
/// use gonio_calib::axis::AxisCompensation;
/// let row = AxisCompensation { target_deg: 90.0, correction_up_arcsec: Some(-1.5),
///     correction_down_arcsec: None, correction_mean_arcsec: -1.5 };
/// assert_eq!(gonio_io::formats::compensation::axis_csv(&[row]),
///     "target_deg,correction_up_arcsec,correction_down_arcsec,correction_mean_arcsec\n90,-1.500000,,-1.500000\n");
/// ```
pub fn axis_csv(rows: &[AxisCompensation]) -> String {
    let mut s = String::from(
        "target_deg,correction_up_arcsec,correction_down_arcsec,correction_mean_arcsec\n",
    );
    let cell = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6}"));
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{:.6}\n",
            r.target_deg,
            cell(r.correction_up_arcsec),
            cell(r.correction_down_arcsec),
            r.correction_mean_arcsec
        ));
    }
    s
}
