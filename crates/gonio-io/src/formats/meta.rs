//! Certificate metadata (`--meta META.toml`): the administrative data of ISO/IEC 17025 §7.8.
//! See `examples/certificate-meta.toml` for every field.

use anyhow::Result;
use gonio_calib::certificate::CertificateMeta;
use std::path::Path;

/// Reads a metadata file; errors name the file, line and column. Missing fields are not errors
/// (the certificate is then a draft).
///
/// # Errors
/// As [`parse`], and the file cannot be read.
pub fn load(inputs: &crate::input::Inputs, path: &Path) -> Result<CertificateMeta> {
    inputs.load(path, parse)
}

/// Parses metadata text; `name` names it in errors.
///
/// # Errors
/// Syntax, unknown keys, bad dates (located); a control character in a text, or an
/// environmental value that is not finite or not physical (a temperature of `nan`), naming the
/// file and the field ([`CertificateMeta::validate`]).
pub fn parse(name: &str, text: &str) -> Result<CertificateMeta> {
    let m: CertificateMeta = super::parse_toml(name, text)?;
    m.validate().map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gonio_calib::certificate::Procedure;

    fn example() -> String {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/certificate-meta.toml");
        std::fs::read_to_string(p).unwrap()
    }

    #[test]
    fn the_example_is_complete_for_both_procedures() {
        let m = parse("m.toml", &example()).unwrap();
        assert_eq!(
            m.missing_fields(Procedure::ShiftAngle),
            Vec::<String>::new()
        );
        assert_eq!(
            m.missing_fields(Procedure::SelfCalibration),
            Vec::<String>::new()
        );
        assert_eq!(
            m.dates
                .as_ref()
                .unwrap()
                .calibration
                .as_ref()
                .unwrap()
                .as_str(),
            "2025-03-10"
        );
        assert!(m.standard("polygon").unwrap().certificate.is_some());
    }

    #[test]
    fn control_characters_and_nan_are_refused() {
        let e = parse("m.toml", "[customer]\nname = \"A\\u0001B\"\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "m.toml: customer.name: control character U+0001 at character 2: not allowed in certificate text"
        );
        let e = parse("m.toml", "title = \"x\\u001b[31m\"\n").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("m.toml: title: control character U+001B"),
            "{e}"
        );
        let e = parse("m.toml", "[environment]\ntemperature_c = nan\n").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("m.toml: environment.temperature_c: NaN: expected"),
            "{e}"
        );
        let e = parse("m.toml", "[environment]\nhumidity_percent = 120.0\n").unwrap_err();
        assert!(
            e.to_string().contains("environment.humidity_percent: 120"),
            "{e}"
        );
        let e = parse(
            "m.toml",
            "[[reference_standards]]\nrole = \"polygon\"\ndescription = \"\\f\"\n",
        )
        .unwrap_err();
        assert!(
            e.to_string().contains("reference_standards[0].description"),
            "{e}"
        );
        // Tabs and newlines are text.
        parse("m.toml", "remarks = \"a\\tb\\nc\"\n").unwrap();
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let p = "m.toml";
        let e = parse(p, "title = \"x\"\n[custmer]\nname = \"y\"\n").unwrap_err();
        assert!(e.to_string().starts_with("m.toml:2:"), "{e}");
        assert!(e.to_string().contains("custmer"), "{e}");
        let e = parse(p, "[dates]\nreceipt = 2025-02-30\n").unwrap_err();
        assert!(e.to_string().starts_with("m.toml:2:11:"), "{e}");
        let e = parse(p, "[dates]\nissue = \"14.03.2025\"\n").unwrap_err();
        assert!(e.to_string().starts_with("m.toml:2:9:"), "{e}");
        assert!(e.to_string().contains("YYYY-MM-DD"), "{e}");
        let e = parse(p, "title = \n").unwrap_err();
        assert!(e.to_string().starts_with("m.toml:1:"), "{e}");
        // Missing fields are not errors: the certificate is a draft.
        let m = parse(p, "title = \"Calibration certificate\"\n").unwrap();
        let missing = m.missing_fields(Procedure::ShiftAngle);
        assert!(missing.contains(&"customer.name".to_string()));
        assert!(!missing.contains(&"title".to_string()));
    }
}
