//! The users of `--opcua-users`: a text file, one user a line, `NAME:HASH`, where HASH is
//! the password's argon2 hash as a PHC string (`$argon2id$v=19$m=…,t=…,p=…$salt$hash`, what
//! the `argon2` command-line tool prints with `-e`, and Python's `argon2-cffi`
//! `PasswordHasher().hash`); `#` starts a comment line, blank lines are skipped. Names are
//! 1 to 64 visible ASCII characters without `:`. Checked with the RustCrypto `argon2` crate.
//!
//! A hash's cost is bounded (memory ≤ [`MAX_MEMORY_KIB`] KiB, ≤ [`MAX_PASSES`] passes, ≤
//! [`MAX_LANES`] lanes), so that no line of the file makes a login take minutes; an unknown
//! user costs the same as a known one.
//!
//! ```
//! use gonio_opcua::users::Users;
//! let text = "# the line's MES\nmes:$argon2id$v=19$m=8,t=1,p=1$c2FsdHNhbHQ$ZmFrZWhhc2hmYWtl\n";
//! let users = Users::parse(text, std::path::Path::new("users.txt")).unwrap();
//! assert_eq!(users.names(), ["mes"]);
//! assert!(Users::parse("mes:secret\n", std::path::Path::new("users.txt")).is_err());
//! ```

use crate::OpcUaError;
use argon2::password_hash::{PasswordHash, PasswordVerifier};
use argon2::{Argon2, Params};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Most memory a hash may ask for, KiB (256 MiB).
pub const MAX_MEMORY_KIB: u32 = 256 * 1024;
/// Most passes a hash may ask for.
pub const MAX_PASSES: u32 = 16;
/// Most lanes a hash may ask for.
pub const MAX_LANES: u32 = 16;
/// Largest users file read, bytes.
const MAX_FILE_BYTES: u64 = 1 << 20;

/// The users who may log in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Users {
    /// Name → PHC string.
    hashes: BTreeMap<String, String>,
}

impl Users {
    /// Reads a users file.
    ///
    /// # Errors
    /// [`OpcUaError::Users`] naming the file, line and column.
    pub fn read(path: &Path) -> Result<Users, OpcUaError> {
        let err = |message: String| OpcUaError::Users {
            path: path.to_path_buf(),
            line: 1,
            column: 1,
            message,
        };
        let meta = std::fs::metadata(path).map_err(|e| err(e.to_string()))?;
        if !meta.is_file() {
            return Err(err("not a regular file".into()));
        }
        if meta.len() > MAX_FILE_BYTES {
            return Err(err(format!(
                "{} bytes: a users file is at most {MAX_FILE_BYTES} bytes",
                meta.len()
            )));
        }
        let bytes = std::fs::read(path).map_err(|e| err(e.to_string()))?;
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            let before = &e.as_bytes()[..at];
            let line = before.iter().filter(|b| **b == b'\n').count() + 1;
            let column = at
                - before
                    .iter()
                    .rposition(|b| *b == b'\n')
                    .map_or(0, |i| i + 1)
                + 1;
            OpcUaError::Users {
                path: path.to_path_buf(),
                line,
                column,
                message: "not UTF-8".into(),
            }
        })?;
        Users::parse(&text, path)
    }

    /// Reads a users file's text (`path`: for messages).
    ///
    /// # Errors
    /// [`OpcUaError::Users`] naming the line and column of the first fault.
    pub fn parse(text: &str, path: &Path) -> Result<Users, OpcUaError> {
        let at = |line: usize, column: usize, message: String| OpcUaError::Users {
            path: PathBuf::from(path),
            line,
            column,
            message,
        };
        let mut hashes = BTreeMap::new();
        for (i, raw) in text.lines().enumerate() {
            let n = i + 1;
            let line = raw.trim_end_matches('\r');
            let trimmed = line.trim_start();
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            let Some((name, hash)) = line.split_once(':') else {
                return Err(at(
                    n,
                    1,
                    "expected NAME:HASH (an argon2 PHC string, e.g. from `argon2 SALT -id -e`)"
                        .into(),
                ));
            };
            if name.is_empty()
                || name.len() > 64
                || !name.bytes().all(|b| b.is_ascii_graphic() && b != b':')
            {
                return Err(at(
                    n,
                    1,
                    format!("user name {name:?}: expected 1 to 64 visible ASCII characters"),
                ));
            }
            let column = name.len() + 2;
            check_hash(hash).map_err(|m| at(n, column, m))?;
            if hashes.insert(name.to_string(), hash.to_string()).is_some() {
                return Err(at(n, 1, format!("user {name} is listed twice")));
            }
        }
        if hashes.is_empty() {
            return Err(at(1, 1, "no users in the file".into()));
        }
        Ok(Users { hashes })
    }

    /// The users' names, sorted.
    pub fn names(&self) -> Vec<&str> {
        self.hashes.keys().map(String::as_str).collect()
    }

    /// Whether `password` is `name`'s. Takes the time of one hash whether or not the user
    /// exists.
    pub fn verify(&self, name: &str, password: &str) -> bool {
        let (hash, known) = match self.hashes.get(name) {
            Some(h) => (h, true),
            None => match self.hashes.values().next() {
                Some(h) => (h, false),
                None => return false,
            },
        };
        let Ok(parsed) = PasswordHash::new(hash) else {
            return false;
        };
        let ok = Argon2::default()
            .verify_password(password.as_bytes(), &parsed)
            .is_ok();
        ok && known
    }
}

/// Checks a PHC string: argon2, parameters within bounds.
fn check_hash(hash: &str) -> Result<(), String> {
    let parsed = PasswordHash::new(hash).map_err(|e| {
        format!("not a PHC hash string ({e}): expected $argon2id$v=19$m=…,t=…,p=…$SALT$HASH")
    })?;
    let alg = parsed.algorithm.as_str();
    if !matches!(alg, "argon2id" | "argon2i" | "argon2d") {
        return Err(format!(
            "hash algorithm {alg}: expected argon2id, argon2i or argon2d"
        ));
    }
    if parsed.hash.is_none() || parsed.salt.is_none() {
        return Err("the hash string has no salt or no hash".into());
    }
    let p = Params::try_from(&parsed).map_err(|e| format!("argon2 parameters: {e}"))?;
    if p.m_cost() > MAX_MEMORY_KIB || p.t_cost() > MAX_PASSES || p.p_cost() > MAX_LANES {
        return Err(format!(
            "argon2 parameters m={},t={},p={}: at most m={MAX_MEMORY_KIB},t={MAX_PASSES},p={MAX_LANES}",
            p.m_cost(),
            p.t_cost(),
            p.p_cost()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use argon2::password_hash::{PasswordHasher, SaltString};

    fn hash(password: &str) -> String {
        let salt = SaltString::encode_b64(b"a fixed salt").unwrap();
        let a = Argon2::new(
            argon2::Algorithm::Argon2id,
            argon2::Version::V0x13,
            Params::new(64, 1, 1, None).unwrap(),
        );
        a.hash_password(password.as_bytes(), &salt)
            .unwrap()
            .to_string()
    }

    #[test]
    fn a_user_logs_in_with_the_password_and_nobody_else_does() {
        let text = format!("# MES\n\nmes:{}\nqa:{}\n", hash("right"), hash("other"));
        let u = Users::parse(&text, Path::new("u")).unwrap();
        assert_eq!(u.names(), ["mes", "qa"]);
        assert!(u.verify("mes", "right"));
        assert!(!u.verify("mes", "wrong"));
        assert!(!u.verify("qa", "right"));
        assert!(!u.verify("nobody", "right"));
    }

    #[test]
    fn faults_name_the_line_and_column() {
        let p = Path::new("users.txt");
        let e = Users::parse("# c\nmes $argon2id\n", p)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("users.txt:2:1: expected NAME:HASH"), "{e}");
        let e = Users::parse("mes:plain\n", p).unwrap_err().to_string();
        assert!(e.starts_with("users.txt:1:5: not a PHC hash string"), "{e}");
        let e = Users::parse(
            "mes:$pbkdf2-sha256$i=1000$c2FsdHNhbHQ$aGFzaGhhc2hoYXNo\n",
            p,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("expected argon2id"), "{e}");
        let big = "mes:$argon2id$v=19$m=2097152,t=1,p=1$c2FsdHNhbHQ$aGFzaGhhc2hoYXNo\n";
        let e = Users::parse(big, p).unwrap_err().to_string();
        assert!(e.contains("at most m=262144"), "{e}");
        let h = hash("x");
        let e = Users::parse(&format!("a:{h}\na:{h}\n"), p)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("users.txt:2:1: user a is listed twice"),
            "{e}"
        );
        let e = Users::parse("# nobody\n", p).unwrap_err().to_string();
        assert!(e.contains("no users"), "{e}");
        let e = Users::parse("a b:x\n", p).unwrap_err().to_string();
        assert!(e.contains("visible ASCII"), "{e}");
    }

    #[test]
    fn a_file_that_is_not_text_is_refused_at_its_first_bad_byte() {
        let d = tempfile::tempdir().unwrap();
        let f = d.path().join("users.txt");
        std::fs::write(&f, b"# ok\nm\xffes:x\n").unwrap();
        let e = Users::read(&f).unwrap_err().to_string();
        assert!(e.ends_with(":2:2: not UTF-8"), "{e}");
    }
}
