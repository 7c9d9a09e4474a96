//! Who may use the page server: the host names it answers to, and the
//! run's token off loopback, checked on every request.

use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::State;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};

use crate::token::AccessToken;

/// The host names a request may carry in `Host` (and, as `http://` + it, in
/// `Origin`): a loopback name or the bound address, on the served port.
#[derive(Clone, Debug)]
pub struct AllowedHosts {
    hosts: Vec<String>,
    /// Any host name on this port (a token-protected server bound to every
    /// interface, reached under names it cannot know); `Origin` must then be
    /// the request's own `Host`.
    any_host_on: Option<u16>,
}

impl AllowedHosts {
    /// For a server bound to `addr`.
    pub fn for_addr(addr: SocketAddr) -> Self {
        let port = addr.port();
        let mut hosts: Vec<String> = ["127.0.0.1", "localhost", "[::1]"]
            .iter()
            .map(|h| format!("{h}:{port}"))
            .collect();
        if !addr.ip().is_unspecified() && !addr.ip().is_loopback() {
            hosts.push(addr.to_string());
        }
        Self {
            hosts,
            any_host_on: None,
        }
    }

    /// For a server bound to `addr` that checks a token: as [`Self::for_addr`],
    /// and, when `addr` is unspecified (`0.0.0.0`, `::`), any host name on its
    /// port, with `Origin` (when present) equal to `http://` + that `Host`. The
    /// token, not the name, then keeps other sites out: their pages get no
    /// `SameSite=Strict` cookie and do not know the token.
    pub fn for_token_server(addr: SocketAddr) -> Self {
        let mut a = Self::for_addr(addr);
        if addr.ip().is_unspecified() {
            a.any_host_on = Some(addr.port());
        }
        a
    }

    /// Whether a request with these `Host` and `Origin` headers may be served:
    /// `Host` must be one of the allowed hosts, and `Origin`, when present, must
    /// be `http://` + one of them (a page of another site, `null` included,
    /// cannot drive the debugger; a rebound DNS name fails the `Host` check).
    pub fn allows(&self, host: Option<&str>, origin: Option<&str>) -> bool {
        if let (Some(port), Some(host)) = (self.any_host_on, host) {
            let on_port = host
                .rsplit_once(':')
                .is_some_and(|(name, p)| !name.is_empty() && p == port.to_string());
            let same_origin = origin.is_none_or(|o| {
                o.strip_prefix("http://")
                    .is_some_and(|h| h.eq_ignore_ascii_case(host))
            });
            return on_port && same_origin;
        }
        let ok_host = |h: &str| self.hosts.iter().any(|a| a.eq_ignore_ascii_case(h));
        let host_ok = host.is_some_and(ok_host);
        let origin_ok = origin.is_none_or(|o| o.strip_prefix("http://").is_some_and(ok_host));
        host_ok && origin_ok
    }
}

/// Who may use the page server: the names it answers to and, off loopback,
/// the run's token.
#[derive(Debug)]
pub(super) struct Access {
    pub(super) allowed: AllowedHosts,
    pub(super) token: Option<AccessToken>,
    pub(super) port: u16,
}

/// Refuses (403) a request whose `Host` or `Origin` is not one of `allowed`,
/// or, on a token-protected server, that carries no valid token. A request
/// whose token came in the query string gets the token's cookie, so the
/// page's own requests carry it from then on.
pub(super) async fn guard(
    State(access): State<Arc<Access>>,
    request: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    let headers = request.headers();
    let value = |name: header::HeaderName| -> Option<String> {
        headers
            .get(name)
            .and_then(|v| v.to_str().ok())
            .map(str::to_owned)
    };
    let (host, origin) = (value(header::HOST), value(header::ORIGIN));
    if !access.allowed.allows(host.as_deref(), origin.as_deref()) {
        return (
            StatusCode::FORBIDDEN,
            format!(
                "seespot serves only its own page: Host {host:?} / Origin {origin:?} is not this server (127.0.0.1 or localhost on its port)"
            ),
        )
            .into_response();
    }
    let Some(token) = &access.token else {
        return next.run(request).await;
    };
    let cookies = headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok());
    let (in_query, in_cookie) = token.found_in(access.port, request.uri().query(), cookies);
    if !in_query && !in_cookie {
        return (
            StatusCode::FORBIDDEN,
            "this seespot page needs its token: open the URL `seespot view` printed (…/?token=…)",
        )
            .into_response();
    }
    let mut response = next.run(request).await;
    if in_query
        && !in_cookie
        && let Ok(v) = header::HeaderValue::from_str(&token.set_cookie(access.port))
    {
        response.headers_mut().append(header::SET_COOKIE, v);
    }
    response
}
