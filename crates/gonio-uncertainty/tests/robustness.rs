//! No panic on any input: arbitrary text and mutated budget files either parse and evaluate (with
//! finite or typed-error results) or give a one-line error with a line number.

use gonio_uncertainty::parse_budget_file;
use proptest::prelude::*;

const BASE: &str = r#"coverage = 0.95
[[budget]]
name = "inner"
[[budget.contribution]]
name = "a"
std_dev = 0.13
n = 6
[[budget.contribution]]
name = "b"
distribution = "rectangular"
half_width = 0.07
relative_uncertainty = 0.10
[[budget]]
name = "outer"
[[budget.contribution]]
name = "i"
from = "inner"
[[budget.contribution]]
name = "c"
u = 0.01
dof = 5
sensitivity = 0.04
"#;

fn check(text: &str) {
    match parse_budget_file(text) {
        Ok(set) => {
            if let Ok(r) = set.evaluate(None, None) {
                assert!(r.u_c >= 0.0 && !r.u_c.is_nan());
                assert!(r.k > 0.0 && !r.k.is_nan(), "{text}");
            }
        }
        Err(e) => {
            assert!(
                e.line >= 1 && e.line <= text.lines().count().max(1) + 1,
                "{e}"
            );
            assert!(!e.message.contains('\n'));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn arbitrary_text_never_panics(s in "\\PC{0,200}") {
        check(&s);
    }

    #[test]
    fn mutated_numbers_never_panic(
        v in prop::sample::select(vec!["-1", "0", "1e308", "-1e-300", "nan", "inf", "-inf", "\"inf\"", "0.5", "\"x\"", "[]", "2"]),
        which in 0usize..8,
    ) {
        let targets = ["0.95", "0.13", "6", "0.07", "0.10", "0.01", "5", "0.04"];
        let text = BASE.replacen(targets[which], v, 1);
        check(&text);
    }

    #[test]
    fn deleted_lines_never_panic(skip in 0usize..26) {
        let text: String = BASE
            .lines()
            .enumerate()
            .filter(|(i, _)| *i != skip)
            .map(|(_, l)| format!("{l}\n"))
            .collect();
        check(&text);
    }
}
