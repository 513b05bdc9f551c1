//! The connection loop: how the dashboard meets the network.
//!
//! Every connection gets at most [`ServeOptions::header_read_timeout`] to send a request's
//! headers (a TLS handshake the same), and at most [`ServeOptions::max_connections`] are open
//! at once: clients that connect and send nothing (or a byte a second) are closed when their
//! time is up, so they cannot lock the dashboard out for longer than that. A request's line and
//! headers together are at most [`ServeOptions::max_header_bytes`] (and 100 headers): a longer
//! head is answered `431 Request Header Fields Too Large` and the connection closed, never
//! collected.
//!
//! Every request's `Host` is checked against the names this dashboard serves (DNS
//! rebinding: a page of another site whose name was made to point at this machine sends its own
//! name): the IP address the connection arrived on, `localhost` on loopback, and the names of
//! [`ServeOptions::host_names`]; any port. A request naming another host gets `421`.
//!
//! Off loopback the dashboard is served over TLS ([`Tls`], rustls) and every request must carry
//! `Authorization: Bearer TOKEN` ([`BearerToken`]); without it the answer is `401`. Plain HTTP
//! is then not served on that port (its bytes fail the TLS handshake and the connection is
//! closed). The caller decides when TLS and a token are required; this module serves what it
//! is given.
//!
//! Errors are [`WebError::Tls`] (a certificate or key that cannot be used) and
//! [`WebError::Token`] (a token too short or with whitespace or control characters).

use crate::WebError;
use axum::Router;
use axum::body::Body;
use axum::http::{HeaderValue, Request, Response, StatusCode, header};
use hyper::body::Incoming;
use hyper_util::rt::{TokioIo, TokioTimer};
use std::net::IpAddr;
use std::sync::Arc;
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite};
use tokio::net::TcpListener;
use tokio::sync::Semaphore;
use tokio::task::JoinSet;
use tower_service::Service;

/// A server certificate chain and its private key, for serving over TLS (TLS 1.2 and 1.3).
#[derive(Clone)]
pub struct Tls(Arc<rustls::ServerConfig>);

impl std::fmt::Debug for Tls {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tls").finish_non_exhaustive()
    }
}

impl Tls {
    /// A TLS configuration from PEM text: `cert_pem` holds the certificate chain (the server's
    /// certificate first), `key_pem` its private key (PKCS#8, PKCS#1 or SEC1).
    ///
    /// # Errors
    /// [`WebError::Tls`] when there is no certificate or no key, or they do not match.
    pub fn from_pem(cert_pem: &[u8], key_pem: &[u8]) -> Result<Tls, WebError> {
        use rustls::pki_types::pem::PemObject;
        use rustls::pki_types::{CertificateDer, PrivateKeyDer};
        let tls = |message: String| WebError::Tls { message };
        let certs = CertificateDer::pem_slice_iter(cert_pem)
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| tls(format!("certificate: {e}")))?;
        if certs.is_empty() {
            return Err(tls(
                "certificate: no CERTIFICATE block in the PEM text".into()
            ));
        }
        let key =
            PrivateKeyDer::from_pem_slice(key_pem).map_err(|e| tls(format!("private key: {e}")))?;
        let provider = Arc::new(rustls::crypto::ring::default_provider());
        let config = rustls::ServerConfig::builder_with_provider(provider)
            .with_safe_default_protocol_versions()
            .map_err(|e| tls(e.to_string()))?
            .with_no_client_auth()
            .with_single_cert(certs, key)
            .map_err(|e| tls(format!("certificate and key: {e}")))?;
        Ok(Tls(Arc::new(config)))
    }
}

/// The secret every request must present as `Authorization: Bearer TOKEN`.
#[derive(Clone)]
pub struct BearerToken(Arc<[u8]>);

impl std::fmt::Debug for BearerToken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("BearerToken(…)")
    }
}

impl BearerToken {
    /// The shortest token accepted, characters.
    pub const MIN_LEN: usize = 16;

    /// A token: at least [`Self::MIN_LEN`] visible ASCII characters (no spaces; as a header
    /// value carries it). Leading and trailing whitespace (a file's final newline) is dropped.
    ///
    /// # Errors
    /// [`WebError::Token`] naming what is wrong (never the token itself).
    pub fn new(token: &str) -> Result<BearerToken, WebError> {
        let t = token.trim();
        if let Some(c) = t.chars().find(|c| !c.is_ascii_graphic()) {
            return Err(WebError::Token {
                message: format!(
                    "a token holds visible ASCII characters only (found U+{:04X})",
                    c as u32
                ),
            });
        }
        if t.len() < Self::MIN_LEN {
            return Err(WebError::Token {
                message: format!(
                    "{} characters; at least {} are needed",
                    t.len(),
                    Self::MIN_LEN
                ),
            });
        }
        Ok(BearerToken(Arc::from(t.as_bytes())))
    }

    /// Whether `header` (an `Authorization` value) is `Bearer` and this token, compared in
    /// time that does not depend on where they differ.
    fn admits(&self, header: Option<&HeaderValue>) -> bool {
        let Some(v) = header.map(HeaderValue::as_bytes) else {
            return false;
        };
        let Some(given) = v
            .get(..7)
            .filter(|p| p.eq_ignore_ascii_case(b"bearer "))
            .map(|_| &v[7..])
        else {
            return false;
        };
        let given = given.trim_ascii();
        let mine = &self.0[..];
        let mut diff = u8::from(given.len() != mine.len());
        for (i, &b) in mine.iter().enumerate() {
            diff |= b ^ given.get(i).copied().unwrap_or(0);
        }
        diff == 0
    }
}

/// How the dashboard is served: limits, names, and TLS and a token when wanted.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct ServeOptions {
    /// Time a connection has to send a request's headers (and to finish a TLS handshake).
    pub header_read_timeout: Duration,
    /// Longest request line and headers together, bytes (at least 8192).
    pub max_header_bytes: usize,
    /// Connections open at once; more wait until one closes.
    pub max_connections: usize,
    /// Host names served besides the connection's own address (and `localhost` on loopback).
    pub host_names: Vec<String>,
    /// Serve over TLS.
    pub tls: Option<Tls>,
    /// Require this bearer token on every request.
    pub token: Option<BearerToken>,
}

impl Default for ServeOptions {
    /// 10 s and 16 KiB for the headers, 256 connections, no TLS, no token.
    fn default() -> Self {
        ServeOptions {
            header_read_timeout: Duration::from_secs(10),
            max_header_bytes: 16 << 10,
            max_connections: 256,
            host_names: Vec::new(),
            tls: None,
            token: None,
        }
    }
}

/// Whether `host` (a `Host` header's value: name or address, optionally `:port`) names this
/// dashboard reached at `local`.
fn host_allowed(host: &str, local: IpAddr, names: &[String]) -> bool {
    let name = if let Some(rest) = host.strip_prefix('[') {
        // [v6]:port
        match rest.split_once(']') {
            Some((ip, tail)) if tail.is_empty() || tail.starts_with(':') => ip,
            _ => return false,
        }
    } else {
        match host.rsplit_once(':') {
            Some((h, port)) if !h.contains(':') && port.bytes().all(|b| b.is_ascii_digit()) => h,
            Some(_) if host.parse::<IpAddr>().is_ok() => host,
            Some(_) => return false,
            None => host,
        }
    };
    if let Ok(ip) = name.parse::<IpAddr>() {
        return ip == local || ip.to_canonical() == local.to_canonical();
    }
    let name = name.trim_end_matches('.');
    let localhost = local.to_canonical().is_loopback() && name.eq_ignore_ascii_case("localhost");
    localhost || names.iter().any(|n| n.eq_ignore_ascii_case(name))
}

fn refuse(status: StatusCode, message: &str) -> Response<Body> {
    let mut r = Response::new(Body::from(
        serde_json::json!({ "error": message }).to_string(),
    ));
    *r.status_mut() = status;
    r.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("application/json"),
    );
    if status == StatusCode::UNAUTHORIZED {
        r.headers_mut().insert(
            header::WWW_AUTHENTICATE,
            HeaderValue::from_static("Bearer realm=\"gonio\""),
        );
    }
    r
}

/// Checks a request's host and token, then hands it to the router.
#[derive(Clone)]
struct Gate {
    router: Router,
    local: IpAddr,
    names: Arc<[String]>,
    token: Option<BearerToken>,
}

impl Gate {
    async fn handle(
        mut self,
        req: Request<Incoming>,
    ) -> Result<Response<Body>, std::convert::Infallible> {
        let host = req
            .headers()
            .get(header::HOST)
            .and_then(|h| h.to_str().ok())
            .map(str::to_string)
            .or_else(|| req.uri().authority().map(|a| a.as_str().to_string()));
        match host {
            None => {
                return Ok(refuse(StatusCode::BAD_REQUEST, "no Host header"));
            }
            Some(h) if !host_allowed(&h, self.local, &self.names) => {
                return Ok(refuse(
                    StatusCode::MISDIRECTED_REQUEST,
                    "the Host header names no host this dashboard serves",
                ));
            }
            Some(_) => {}
        }
        if let Some(t) = &self.token
            && !t.admits(req.headers().get(header::AUTHORIZATION))
        {
            return Ok(refuse(
                StatusCode::UNAUTHORIZED,
                "this dashboard needs Authorization: Bearer TOKEN (the token of --token-file)",
            ));
        }
        self.router.call(req).await
    }
}

async fn serve_connection<I>(io: I, gate: Gate, header_read_timeout: Duration, max_header: usize)
where
    I: AsyncRead + AsyncWrite + Unpin + Send + 'static,
{
    let service = hyper::service::service_fn(move |req| gate.clone().handle(req));
    let conn = hyper::server::conn::http1::Builder::new()
        .timer(TokioTimer::new())
        .header_read_timeout(header_read_timeout)
        .max_header_size(max_header)
        .serve_connection(TokioIo::new(io), service);
    // A client that goes away or times out is not the server's error.
    let _ = conn.await;
}

/// Serves `router` on `listener` with `options` until `shutdown` completes.
pub(crate) async fn run(
    listener: TcpListener,
    router: Router,
    options: ServeOptions,
    shutdown: impl std::future::Future<Output = ()>,
) -> Result<(), WebError> {
    let limit = Arc::new(Semaphore::new(options.max_connections.max(1)));
    let acceptor = options
        .tls
        .as_ref()
        .map(|t| tokio_rustls::TlsAcceptor::from(t.0.clone()));
    let names: Arc<[String]> = options.host_names.clone().into();
    let timeout = options.header_read_timeout;
    let max_header = options.max_header_bytes.max(8192);
    let mut tasks = JoinSet::new();
    tokio::pin!(shutdown);
    loop {
        while tasks.try_join_next().is_some() {}
        let permit = tokio::select! {
            () = &mut shutdown => break,
            p = limit.clone().acquire_owned() => p.map_err(|e| WebError::Serve { message: e.to_string() })?,
        };
        let (stream, _) = tokio::select! {
            () = &mut shutdown => break,
            r = listener.accept() => match r {
                Ok(s) => s,
                // Out of descriptors and the like: wait a moment rather than spin.
                Err(_) => {
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
        };
        let _ = stream.set_nodelay(true);
        let local = match stream.local_addr() {
            Ok(a) => a.ip(),
            Err(_) => continue,
        };
        let gate = Gate {
            router: router.clone(),
            local,
            names: names.clone(),
            token: options.token.clone(),
        };
        let acceptor = acceptor.clone();
        tasks.spawn(async move {
            let _permit = permit;
            match acceptor {
                None => serve_connection(stream, gate, timeout, max_header).await,
                Some(a) => {
                    if let Ok(Ok(tls)) = tokio::time::timeout(timeout, a.accept(stream)).await {
                        serve_connection(tls, gate, timeout, max_header).await;
                    }
                }
            }
        });
    }
    tasks.abort_all();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hosts_are_the_connections_address_localhost_on_loopback_and_the_given_names() {
        let lo: IpAddr = "127.0.0.1".parse().unwrap();
        let lo6: IpAddr = "::1".parse().unwrap();
        let names = vec!["station.example".to_string()];
        for h in [
            "127.0.0.1",
            "127.0.0.1:8080",
            "localhost",
            "LOCALHOST:80",
            "localhost.",
            "station.example:443",
        ] {
            assert!(host_allowed(h, lo, &names), "{h}");
        }
        for h in [
            "evil.example",
            "evil.example:8080",
            "127.0.0.2:8080",
            "127.0.0.1:80x",
            "localhost.evil.example",
            "",
            "[::1]:8080",
        ] {
            assert!(!host_allowed(h, lo, &names), "{h}");
        }
        assert!(host_allowed("[::1]:8080", lo6, &[]));
        assert!(host_allowed("localhost:8080", lo6, &[]));
        assert!(!host_allowed("[::1", lo6, &[]));
        // Off loopback, `localhost` is not this dashboard.
        let doc: IpAddr = "203.0.113.5".parse().unwrap();
        assert!(!host_allowed("localhost:8443", doc, &[]));
        assert!(host_allowed("203.0.113.5:8443", doc, &[]));
    }

    #[test]
    fn a_token_is_compared_whole() {
        let t = BearerToken::new("0123456789abcdef\n").unwrap();
        let ok = HeaderValue::from_static("Bearer 0123456789abcdef");
        assert!(t.admits(Some(&ok)));
        assert!(t.admits(Some(&HeaderValue::from_static("bearer 0123456789abcdef"))));
        for bad in [
            "Bearer 0123456789abcde",
            "Bearer 0123456789abcdefg",
            "Bearer 0123456789abcdeF",
            "Basic 0123456789abcdef",
            "Bearer",
            "",
        ] {
            assert!(!t.admits(Some(&HeaderValue::from_static(bad))), "{bad}");
        }
        assert!(!t.admits(None));
        assert!(matches!(
            BearerToken::new("short"),
            Err(WebError::Token { .. })
        ));
        assert!(matches!(
            BearerToken::new("0123456789 abcdef"),
            Err(WebError::Token { .. })
        ));
        assert!(matches!(BearerToken::new(""), Err(WebError::Token { .. })));
    }

    #[test]
    fn tls_needs_a_certificate_and_its_key() {
        let a = rcgen::generate_simple_self_signed(vec!["localhost".into()]).unwrap();
        let b = rcgen::generate_simple_self_signed(vec!["localhost".into()]).unwrap();
        let (cert, key) = (a.cert.pem(), a.signing_key.serialize_pem());
        assert!(Tls::from_pem(cert.as_bytes(), key.as_bytes()).is_ok());
        let other_key = b.signing_key.serialize_pem();
        for (c, k) in [
            (cert.as_str(), other_key.as_str()),
            ("", key.as_str()),
            (cert.as_str(), ""),
            (key.as_str(), cert.as_str()),
        ] {
            assert!(
                matches!(
                    Tls::from_pem(c.as_bytes(), k.as_bytes()),
                    Err(WebError::Tls { .. })
                ),
                "{c:.30} / {k:.30}"
            );
        }
    }
}
