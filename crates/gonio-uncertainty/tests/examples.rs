//! The example budget files in `examples/budgets/` reproduce their published numbers (one table of
//! cases, every file).

use gonio_uncertainty::parse_budget_file;

struct Case {
    file: &'static str,
    /// (u_c, tolerance), ν_eff, (k, tolerance), (U, tolerance) as published.
    u_c: (f64, f64),
    nu_eff: f64,
    k: (f64, f64),
    expanded: (f64, f64),
}

const CASES: [Case; 3] = [
    // Hsieh et al., 2022, Table 3: u_c 0.069″ (printed 0.07″), ν_eff 13, k 2.16, U 0.15″.
    Case {
        file: "hsieh2022-shift-angle.toml",
        u_c: (0.069, 5e-4),
        nu_eff: 13.0,
        k: (2.16, 5e-3),
        expanded: (0.15, 5e-3),
    },
    // Hsieh et al., 2022 self-calibration: u 0.0109″ (printed 0.01″), ν_eff 53, k 2.01, U 0.022″
    // (0.02″).
    Case {
        file: "hsieh2022-selfcal.toml",
        u_c: (0.0109, 5e-5),
        nu_eff: 53.0,
        k: (2.01, 5e-3),
        expanded: (0.022, 5e-4),
    },
    // JCGM 100 H.1: u_c 32 nm, ν_eff 16, k₉₉ 2.92, U₉₉ 93 nm (= 2.92 × 32 nm; 92.5 unrounded).
    Case {
        file: "jcgm100-h1.toml",
        u_c: (32.0, 0.5),
        nu_eff: 16.0,
        k: (2.92, 5e-3),
        expanded: (93.0, 1.0),
    },
];

#[test]
fn example_budgets_reproduce_published_numbers() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/budgets");
    for c in CASES {
        let text = std::fs::read_to_string(dir.join(c.file)).unwrap();
        let set = parse_budget_file(&text).unwrap_or_else(|e| panic!("{}:{e}", c.file));
        let r = set.evaluate(None, None).unwrap();
        assert!(
            (r.u_c - c.u_c.0).abs() < c.u_c.1,
            "{}: u_c {}",
            c.file,
            r.u_c
        );
        assert_eq!(r.nu_eff, c.nu_eff, "{}", c.file);
        assert!((r.k - c.k.0).abs() < c.k.1, "{}: k {}", c.file, r.k);
        assert!(
            (r.expanded - c.expanded.0).abs() < c.expanded.1,
            "{}: U {}",
            c.file,
            r.expanded
        );
    }
}
