//! Secret files (the bearer token, the TLS private key) read as ssh reads a private key: a file
//! that its group or others may read or write is refused, or read with a warning for the caller
//! to show when it allows that ([`Permissions::AllowInsecure`]). The mode is taken from the
//! file as opened (no race with a swap after a check). On systems without Unix modes nothing is
//! checked.
//!
//! Errors: [`SecretError`], one line naming the file and, for its mode, what to do.
//!
//! ```no_run
//! use gonio_web::secret::{Permissions, read};
//! let token = read("dashboard.token".as_ref(), Permissions::Strict).unwrap();
//! assert!(token.warning.is_none());
//! ```

use std::io::Read;
use std::path::Path;
use thiserror::Error;

/// Whether a secret file open to group or others is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Permissions {
    /// Refused (as ssh refuses a private key).
    Strict,
    /// Read, with a warning in [`Secret::warning`].
    AllowInsecure,
}

/// A secret file's bytes.
#[derive(Debug)]
pub struct Secret {
    /// The file's content.
    pub bytes: Vec<u8>,
    /// With [`Permissions::AllowInsecure`], why the file is not safe, for the caller to show.
    pub warning: Option<String>,
}

/// The largest secret file read (a token is a line, a key a few kilobytes).
pub const MAX_SECRET_BYTES: u64 = 1 << 20;

/// A secret file that cannot be used.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SecretError {
    /// The file cannot be opened or read.
    #[error("{path}: cannot read it: {source}")]
    Read {
        /// The file.
        path: String,
        /// What the system said.
        source: std::io::Error,
    },
    /// The file is open to group or others.
    #[error(
        "{path}: its group or others may read or write it (mode {mode:04o}); run `chmod 600 {path}` (or give --allow-insecure-permissions)"
    )]
    Insecure {
        /// The file.
        path: String,
        /// Its permission bits.
        mode: u32,
    },
    /// The file is larger than [`MAX_SECRET_BYTES`].
    #[error("{path}: more than {MAX_SECRET_BYTES} bytes: not a token or a key")]
    TooLarge {
        /// The file.
        path: String,
    },
}

/// The permission bits of an open file that let group or others in (0 where modes do not exist).
fn open_to_others(f: &std::fs::File) -> std::io::Result<u32> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        Ok(f.metadata()?.permissions().mode() & 0o7777)
    }
    #[cfg(not(unix))]
    {
        let _ = f;
        Ok(0)
    }
}

/// Reads a secret file, checking its mode first.
///
/// # Errors
/// [`SecretError::Insecure`] for a file its group or others may read or write (with
/// [`Permissions::Strict`]), [`SecretError::Read`], [`SecretError::TooLarge`].
pub fn read(path: &Path, permissions: Permissions) -> Result<Secret, SecretError> {
    let shown = path.display().to_string();
    let io = |source| SecretError::Read {
        path: shown.clone(),
        source,
    };
    let f = std::fs::File::open(path).map_err(io)?;
    let mode = open_to_others(&f).map_err(io)?;
    let warning = if mode & 0o077 != 0 {
        let e = SecretError::Insecure {
            path: shown.clone(),
            mode,
        };
        match permissions {
            Permissions::Strict => return Err(e),
            Permissions::AllowInsecure => Some(format!(
                "{shown}: its group or others may read or write it (mode {mode:04o}); used anyway (--allow-insecure-permissions)"
            )),
        }
    } else {
        None
    };
    let mut bytes = Vec::new();
    f.take(MAX_SECRET_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > MAX_SECRET_BYTES {
        return Err(SecretError::TooLarge { path: shown });
    }
    Ok(Secret { bytes, warning })
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    fn file_with_mode(dir: &Path, mode: u32) -> std::path::PathBuf {
        let p = dir.join(format!("secret-{mode:o}"));
        std::fs::write(&p, "0123456789abcdef\n").unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(mode)).unwrap();
        p
    }

    #[test]
    fn a_file_open_to_group_or_others_is_refused_as_ssh_does() {
        let d = tempfile::tempdir().unwrap();
        for mode in [0o600, 0o400, 0o700] {
            let s = read(&file_with_mode(d.path(), mode), Permissions::Strict).unwrap();
            assert_eq!(s.bytes, b"0123456789abcdef\n");
            assert!(s.warning.is_none());
        }
        for mode in [0o644, 0o640, 0o604, 0o620, 0o602] {
            let p = file_with_mode(d.path(), mode);
            let e = read(&p, Permissions::Strict).unwrap_err().to_string();
            assert!(e.contains(&format!("mode 0{mode:o}")), "{e}");
            assert!(e.contains("chmod 600"), "{e}");
            let s = read(&p, Permissions::AllowInsecure).unwrap();
            assert_eq!(s.bytes, b"0123456789abcdef\n");
            assert!(s.warning.unwrap().contains("used anyway"));
        }
    }
}
