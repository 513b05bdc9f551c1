//! Every relative link in README.md and docs/ names a file or directory that exists in the
//! repository (the part before a `#` fragment, resolved from the Markdown file's directory).
//! Links with a scheme (`https:`, `mailto:`) and links within a page (`#…`) are not checked;
//! links inside fenced code blocks and inline code are not links.

use std::path::{Path, PathBuf};

/// The repository's root (two levels above this crate).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("the repository's root")
}

/// The link targets of a Markdown text with their 1-based line numbers: inline links
/// `[text](target)` and `![alt](target)`, and reference definitions `[name]: target`.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    let mut fenced = false;
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("```") || trimmed.starts_with("~~~") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        // Reference definitions: `[name]: target`.
        if let Some(rest) = trimmed.strip_prefix('[')
            && let Some(end) = rest.find("]:")
            && !rest[..end].contains(']')
        {
            if let Some(target) = rest[end + 2..].split_whitespace().next() {
                found.push((i + 1, target.trim_matches(['<', '>']).to_string()));
            }
            continue;
        }
        // Inline links, outside inline code spans.
        let mut in_code = false;
        let bytes = line.as_bytes();
        let mut k = 0;
        while k < bytes.len() {
            match bytes[k] {
                b'`' => in_code = !in_code,
                b']' if !in_code && bytes.get(k + 1) == Some(&b'(') => {
                    let start = k + 2;
                    let mut depth = 0usize;
                    let mut end = None;
                    for (j, &b) in bytes.iter().enumerate().skip(start) {
                        match b {
                            b'(' => depth += 1,
                            b')' if depth == 0 => {
                                end = Some(j);
                                break;
                            }
                            b')' => depth -= 1,
                            _ => {}
                        }
                    }
                    if let Some(end) = end {
                        let inner = line[start..end].trim();
                        // `[text](target "title")`: the target is the first word.
                        let target = inner.split_whitespace().next().unwrap_or("");
                        found.push((i + 1, target.trim_matches(['<', '>']).to_string()));
                        k = end;
                    }
                }
                _ => {}
            }
            k += 1;
        }
    }
    found
}

/// Whether a link target is a path in the repository (not a URL, not a fragment of the page).
fn is_relative(target: &str) -> bool {
    !(target.is_empty()
        || target.starts_with('#')
        || target.starts_with('/')
        || target.contains("://")
        || target.starts_with("mailto:"))
}

/// The broken relative links of the Markdown file `file` (`FILE:LINE: target`).
fn broken(file: &Path, text: &str) -> Vec<String> {
    let dir = file.parent().expect("a file's directory");
    links(text)
        .into_iter()
        .filter(|(_, t)| is_relative(t))
        .filter(|(_, t)| {
            let path = t.split('#').next().unwrap_or("");
            !dir.join(path).exists()
        })
        .map(|(line, t)| format!("{}:{line}: {t}", file.display()))
        .collect()
}

/// README.md and every Markdown file under docs/.
fn documents() -> Vec<PathBuf> {
    let root = root();
    let mut files = vec![root.join("README.md")];
    let mut dirs = vec![root.join("docs")];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).expect("docs/ is readable") {
            let p = e.expect("a directory entry").path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "md") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

#[test]
fn every_relative_link_in_the_readme_and_docs_resolves() {
    let docs = documents();
    assert!(docs.len() > 10, "README.md and docs/*.md: {docs:?}");
    let mut bad = Vec::new();
    let mut checked = 0;
    for f in &docs {
        let text = std::fs::read_to_string(f).expect("a Markdown file");
        checked += links(&text).iter().filter(|(_, t)| is_relative(t)).count();
        bad.extend(broken(f, &text));
    }
    assert!(checked > 20, "only {checked} relative links found");
    assert!(bad.is_empty(), "broken links:\n{}", bad.join("\n"));
}

#[test]
fn the_check_finds_a_broken_link_and_passes_the_others() {
    let root = root();
    let file = root.join("docs").join("example.md");
    let text = "\
See [the architecture](ARCHITECTURE.md#crates) and [the README](../README.md),
![a picture](no-such-picture.png), [a site](https://example.org/x), [here](#top),
`[not a link](nowhere.md)`, and [a reference][r].

```
[not a link either](nowhere.md)
```

[r]: missing/reference.md
";
    let bad = broken(&file, text);
    let names: Vec<&str> = bad.iter().map(|b| b.rsplit(' ').next().unwrap()).collect();
    assert_eq!(
        names,
        ["no-such-picture.png", "missing/reference.md"],
        "{bad:?}"
    );
    assert!(bad[0].contains("example.md:2:"), "{bad:?}");
}
