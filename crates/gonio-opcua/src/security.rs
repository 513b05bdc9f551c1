//! The server's security as a line's MES expects it:
//!
//! - on a loopback address (127.0.0.1, ::1), SecurityPolicy `None` is offered only for
//!   anonymous sessions, and only when asked for ([`Security::anonymous`]);
//! - users (name and password, checked against argon2 hashes: [`crate::users`]) log in only
//!   through an encrypted channel: `Basic256Sha256`, `Aes128_Sha256_RsaOaep` or
//!   `Aes256_Sha256_RsaPss`, each with Sign & Encrypt — the only endpoints off loopback;
//! - the encrypted endpoints need the server's certificate: from files (DER or PEM
//!   certificate, PEM private key), or generated once into the PKI directory
//!   (`own/cert.der`, `private/private.pem`: RSA 2048, self-signed, valid 5 years), which
//!   also holds the client certificates the server trusts (`trusted/`) and those it
//!   has refused (`rejected/`, to be moved to `trusted/` by an administrator). The stack
//!   finds a trusted certificate by a file name of its own (`CN=NAME [THUMBPRINT].der`, the
//!   name it gives a refused one); a certificate put into `trusted/` under another name
//!   (`.der` or `.pem`) is copied to that name when the server starts.
//!
//! ```
//! use gonio_opcua::security::Security;
//! let addr = "127.0.0.1:4840".parse().unwrap();
//! let e = gonio_opcua::security::endpoints(addr, &Security::loopback_anonymous()).unwrap();
//! assert_eq!(e.len(), 1);
//! assert!(gonio_opcua::security::endpoints("192.0.2.7:4840".parse().unwrap(),
//!     &Security::loopback_anonymous()).is_err());
//! ```

use crate::OpcUaError;
use crate::users::Users;
use opcua::crypto::{CertificateStore, KeySize, PrivateKey, SecurityPolicy, X509, X509Data};
use opcua::server::{ANONYMOUS_USER_TOKEN_ID, ServerEndpoint};
use opcua::types::MessageSecurityMode;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The encrypted policies offered (each with Sign & Encrypt).
pub const SECURE_POLICIES: [SecurityPolicy; 3] = [
    SecurityPolicy::Basic256Sha256,
    SecurityPolicy::Aes128Sha256RsaOaep,
    SecurityPolicy::Aes256Sha256RsaPss,
];

/// How the server lets clients in.
#[derive(Debug, Clone, Default)]
pub struct Security {
    /// The PKI directory: the server's generated certificate (unless [`Self::certificate`]
    /// is given) and the client certificates it trusts. Needed for the encrypted endpoints.
    pub pki_dir: Option<PathBuf>,
    /// The server's certificate (`.der` or `.pem`) and private key (PEM) files.
    pub certificate: Option<(PathBuf, PathBuf)>,
    /// The users who may log in (through an encrypted endpoint).
    pub users: Option<Arc<Users>>,
    /// Anonymous sessions, allowed only on a loopback address.
    pub anonymous: bool,
}

impl Security {
    /// Anonymous sessions on loopback, nothing else.
    pub fn loopback_anonymous() -> Security {
        Security {
            anonymous: true,
            ..Security::default()
        }
    }
}

/// One endpoint the server offers: its id (for the configuration) and itself.
pub type Endpoint = (String, ServerEndpoint);

fn refuse(message: impl Into<String>) -> OpcUaError {
    OpcUaError::Security {
        message: message.into(),
    }
}

/// The endpoints for a server listening on `addr` (all at path `/`).
///
/// # Errors
/// [`OpcUaError::Security`]: anonymous access off loopback, no way to log in at all, or users
/// without a PKI directory.
pub fn endpoints(addr: SocketAddr, s: &Security) -> Result<Vec<Endpoint>, OpcUaError> {
    let loopback = addr.ip().to_canonical().is_loopback();
    if s.anonymous && !loopback {
        return Err(refuse(format!(
            "{addr}: anonymous access is for a loopback address only; off loopback every session needs a user (--opcua-users) over an encrypted endpoint"
        )));
    }
    if !s.anonymous && s.users.is_none() {
        return Err(refuse(
            "no way to log in: give --opcua-users FILE (user names and argon2 password hashes), or --opcua-anonymous on a loopback address",
        ));
    }
    if s.pki_dir.is_none() && (s.users.is_some() || s.certificate.is_some()) {
        return Err(refuse(
            "the encrypted endpoints need --opcua-pki DIR (where the server's certificate is generated once, unless --opcua-cert and --opcua-key are given, and where the client certificates it trusts are kept)",
        ));
    }
    let anonymous: Vec<String> = if s.anonymous {
        vec![ANONYMOUS_USER_TOKEN_ID.to_string()]
    } else {
        vec![]
    };
    let mut out = Vec::new();
    if s.anonymous {
        out.push((
            "none".to_string(),
            ServerEndpoint::new(
                "/",
                SecurityPolicy::None,
                MessageSecurityMode::None,
                &anonymous,
            ),
        ));
    }
    if s.users.is_some() {
        for p in SECURE_POLICIES {
            out.push((
                format!("{}_sign_encrypt", p.to_str()),
                ServerEndpoint::new("/", p, MessageSecurityMode::SignAndEncrypt, &anonymous),
            ));
        }
    }
    Ok(out)
}

/// The certificate and key files the server uses, relative to nothing (absolute), checked:
/// given ones must load and belong together; in the PKI directory they are generated the
/// first time (for `application_uri` and the `hosts` the server is reached by).
///
/// # Errors
/// [`OpcUaError::Certificate`] naming the file.
pub(crate) fn certificate(
    s: &Security,
    application_uri: &str,
    application_name: &str,
    hosts: &[String],
) -> Result<Option<(PathBuf, PathBuf)>, OpcUaError> {
    let Some(pki) = &s.pki_dir else {
        return Ok(None);
    };
    let bad = |path: &Path, message: String| OpcUaError::Certificate {
        path: path.to_path_buf(),
        message,
    };
    std::fs::create_dir_all(pki)
        .map_err(|e| bad(pki, format!("cannot create the PKI directory: {e}")))?;
    let pki = std::fs::canonicalize(pki).map_err(|e| bad(pki, e.to_string()))?;
    let (cert, key) = match &s.certificate {
        Some((c, k)) => (
            std::path::absolute(c).map_err(|e| bad(c, e.to_string()))?,
            std::path::absolute(k).map_err(|e| bad(k, e.to_string()))?,
        ),
        None => {
            let (c, k) = (pki.join("own/cert.der"), pki.join("private/private.pem"));
            if !c.exists() && !k.exists() {
                generate(&c, &k, application_uri, application_name, hosts)
                    .map_err(|e| bad(&c, e))?;
            }
            (c, k)
        }
    };
    check_pair(&cert, &key)?;
    adopt_trusted(&pki.join("trusted"))?;
    Ok(Some((cert, key)))
}

/// Copies each certificate in `trusted` (`.der` or `.pem`) that is not under the file name
/// the stack looks it up by to that name, as DER.
fn adopt_trusted(trusted: &Path) -> Result<(), OpcUaError> {
    let bad = |path: &Path, message: String| OpcUaError::Certificate {
        path: path.to_path_buf(),
        message,
    };
    std::fs::create_dir_all(trusted).map_err(|e| bad(trusted, e.to_string()))?;
    let entries = std::fs::read_dir(trusted).map_err(|e| bad(trusted, e.to_string()))?;
    for entry in entries.flatten() {
        let path = entry.path();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !path.is_file() || !matches!(ext, "der" | "pem") {
            continue;
        }
        let bytes = std::fs::read(&path).map_err(|e| bad(&path, e.to_string()))?;
        let cert = if ext == "der" {
            X509::from_der(&bytes)
        } else {
            X509::from_pem(&bytes)
        }
        .map_err(|_| {
            bad(
                &path,
                "a trusted client certificate that does not load".into(),
            )
        })?;
        let named = trusted.join(CertificateStore::cert_file_name(&cert));
        if named != path && !named.exists() {
            let der = cert
                .to_der()
                .map_err(|e| bad(&path, format!("cannot convert to DER: {e}")))?;
            std::fs::write(&named, der).map_err(|e| bad(&named, e.to_string()))?;
        }
    }
    Ok(())
}

/// Generates a self-signed application instance certificate and its key.
fn generate(
    cert: &Path,
    key: &Path,
    application_uri: &str,
    application_name: &str,
    hosts: &[String],
) -> Result<(), String> {
    let names =
        X509Data::alt_host_names(application_uri, Some(hosts.to_vec()), false, false, false);
    let data = X509Data {
        key_size: 2048,
        common_name: application_name.to_string(),
        organization: "gonio".into(),
        organizational_unit: "mounting station".into(),
        country: "EU".into(),
        state: String::new(),
        alt_host_names: names,
        certificate_duration_days: 5 * 365,
    };
    CertificateStore::create_certificate_and_key(&data, false, cert, key).map(|_| ())
}

/// Checks that `cert` (`.der` or `.pem`) and `key` (PEM) load and that the key is the
/// certificate's (a signature made with it verifies with the certificate's public key).
fn check_pair(cert: &Path, key: &Path) -> Result<(), OpcUaError> {
    let bad = |path: &Path, message: String| OpcUaError::Certificate {
        path: path.to_path_buf(),
        message,
    };
    let ext = cert.extension().and_then(|e| e.to_str()).unwrap_or("");
    if ext != "der" && ext != "pem" {
        return Err(bad(
            cert,
            "expected a certificate file named .der (DER) or .pem (PEM)".into(),
        ));
    }
    let bytes = std::fs::read(cert).map_err(|e| bad(cert, e.to_string()))?;
    let x509 = if ext == "der" {
        X509::from_der(&bytes)
    } else {
        X509::from_pem(&bytes)
    }
    .map_err(|_| {
        bad(
            cert,
            format!("not an X.509 certificate in {} form", ext.to_uppercase()),
        )
    })?;
    let pkey = PrivateKey::read_pem_file(key).map_err(|_| {
        bad(
            key,
            "not an RSA private key in PEM form (PKCS#8 or PKCS#1)".into(),
        )
    })?;
    let public = x509
        .public_key()
        .map_err(|e| bad(cert, format!("its public key: {e}")))?;
    let data = b"gonio: does the key belong to the certificate?";
    let mut signature = vec![0u8; pkey.size()];
    let signed = pkey.sign_sha256(data, &mut signature).is_ok();
    if !signed || !public.verify_sha256(data, &signature).unwrap_or(false) {
        return Err(bad(
            key,
            format!(
                "this key does not belong to the certificate {}",
                cert.display()
            ),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with_users() -> Security {
        Security {
            users: Some(Arc::new(
                Users::parse(
                    "op:$argon2id$v=19$m=8,t=1,p=1$c2FsdHNhbHQ$d2p4IuLtKdcd4a0yX8zuGQ\n",
                    Path::new("users"),
                )
                .unwrap(),
            )),
            pki_dir: Some("pki".into()),
            ..Security::default()
        }
    }

    #[test]
    fn off_loopback_only_encrypted_endpoints_and_no_anonymous() {
        let remote: SocketAddr = "192.0.2.7:4840".parse().unwrap();
        let e = endpoints(remote, &with_users()).unwrap();
        assert_eq!(e.len(), 3);
        for (_, ep) in &e {
            assert_eq!(ep.security_mode, "SignAndEncrypt");
            assert_ne!(ep.security_policy(), SecurityPolicy::None);
            assert!(ep.user_token_ids.is_empty(), "no anonymous token");
        }
        let anon = Security {
            anonymous: true,
            ..with_users()
        };
        let err = endpoints(remote, &anon).unwrap_err().to_string();
        assert!(err.contains("loopback address only"), "{err}");
        let err = endpoints("[2001:db8::1]:4840".parse().unwrap(), &anon).unwrap_err();
        assert!(err.to_string().contains("loopback"));
    }

    #[test]
    fn on_loopback_none_only_for_anonymous_and_only_when_asked() {
        let local: SocketAddr = "127.0.0.1:4840".parse().unwrap();
        let e = endpoints(local, &with_users()).unwrap();
        assert!(
            e.iter()
                .all(|(_, ep)| ep.security_policy() != SecurityPolicy::None)
        );
        let both = Security {
            anonymous: true,
            ..with_users()
        };
        let e = endpoints("[::1]:4840".parse().unwrap(), &both).unwrap();
        assert_eq!(e.len(), 4);
        let none: Vec<_> = e
            .iter()
            .filter(|(_, ep)| ep.security_policy() == SecurityPolicy::None)
            .collect();
        assert_eq!(none.len(), 1);
        assert!(none[0].1.user_token_ids.contains(ANONYMOUS_USER_TOKEN_ID));
    }

    #[test]
    fn no_way_in_or_users_without_a_pki_is_refused() {
        let local: SocketAddr = "127.0.0.1:4840".parse().unwrap();
        let err = endpoints(local, &Security::default()).unwrap_err();
        assert!(err.to_string().contains("no way to log in"));
        let no_pki = Security {
            pki_dir: None,
            ..with_users()
        };
        let err = endpoints(local, &no_pki).unwrap_err();
        assert!(err.to_string().contains("--opcua-pki"));
    }
}
