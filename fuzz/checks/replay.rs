//! Replays a fuzz target's kept corpus (`fuzz/corpus/<target>/`) and crashes
//! (`fuzz/regressions/<target>/`) through its check, so that `cargo test` runs them. Used by the
//! regression tests of the crates (`#[path]` into this file).

use std::path::Path;

/// Runs `check` on every file of `fuzz/corpus/<target>/` and `fuzz/regressions/<target>/` under
/// `fuzz_dir`; a panic names the file. Returns the number of files run (the corpus must not be
/// empty).
pub fn replay(fuzz_dir: &Path, target: &str, check: fn(&[u8])) -> usize {
    let mut count = 0;
    for kind in ["corpus", "regressions"] {
        let dir = fuzz_dir.join(kind).join(target);
        let Ok(entries) = std::fs::read_dir(&dir) else {
            assert!(kind == "regressions", "missing {}", dir.display());
            continue;
        };
        let mut files: Vec<_> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
        files.sort();
        for f in files.iter().filter(|f| f.is_file()) {
            let data = std::fs::read(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
            if std::panic::catch_unwind(|| check(&data)).is_err() {
                panic!("fuzz {target}: {} fails its check", f.display());
            }
            count += 1;
        }
    }
    assert!(count > 0, "no corpus for fuzz target {target}");
    count
}
