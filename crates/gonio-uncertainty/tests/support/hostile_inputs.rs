//! Hostile budget files generated in code (no large files in the repository), shared by the
//! tests and benches of gonio-uncertainty and the CLI tests (`#[path]` into this file).
#![allow(dead_code)]

/// A diamond of `depth` levels over one leaf of u = 0.1: level k has two rows that both refer to
/// level k − 1, with sensitivities 1 and 0.5 (2^depth paths; u(b_k) = 1.5^k · 0.1).
pub fn diamond(depth: usize) -> String {
    let mut s = String::from(
        "[[budget]]\nname = \"b0\"\n[[budget.contribution]]\nname = \"leaf\"\nu = 0.1\n",
    );
    for k in 1..=depth {
        s += &format!(
            "[[budget]]\nname = \"b{k}\"\n[[budget.contribution]]\nname = \"x\"\nfrom = \"b{}\"\n\
             [[budget.contribution]]\nname = \"y\"\nfrom = \"b{}\"\nsensitivity = 0.5\n",
            k - 1,
            k - 1
        );
    }
    s
}

/// One budget `name` of `n` rows of u = 0.1 (`r0`, `r1`, …), three lines each.
pub fn rows(name: &str, n: usize) -> String {
    let mut s = format!("[[budget]]\nname = \"{name}\"\n");
    for i in 0..n {
        s += &format!("[[budget.contribution]]\nname = \"r{i}\"\nu = 0.1\n");
    }
    s
}

/// A budget of `n` rows of u = 0.1 with correlation r between neighbours (the correlations start
/// at line 3n + 3).
pub fn chain(n: usize, r: f64) -> String {
    let mut s = rows("chain", n);
    for i in 0..n - 1 {
        s += &format!(
            "[[budget.correlation]]\nbetween = [\"r{i}\", \"r{}\"]\nr = {r}\n",
            i + 1
        );
    }
    s
}
