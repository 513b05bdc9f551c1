//! The compensation table (`--compensation`): `angle_deg,correction_arcsec`, the correction
//! (−α) to add to the encoder's reading at each calibrated angle.

use gonio_calib::certificate::Certificate;

/// The table of a certificate as CSV text (header and one row per angle).
pub fn csv(cert: &Certificate) -> String {
    let mut s = String::from("angle_deg,correction_arcsec\n");
    for c in &cert.compensation {
        s.push_str(&format!("{},{:.6}\n", c.angle_deg, c.correction_arcsec));
    }
    s
}
