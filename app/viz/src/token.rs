//! The per-run access token of a page server bound to a non-loopback address
//! (`seespot view --bind 0.0.0.0 --allow-remote`), as Jupyter does it: the
//! printed URL carries `?token=…`; the server accepts the token from the query
//! string or from the cookie it sets on the first such request (`HttpOnly`,
//! `SameSite=Strict`, so the page's own `fetch` and WebSocket requests carry it
//! and a page of another site cannot). Loopback binds need no token.

use rand::Rng;

/// A random token of 256 bits, as 64 hex digits. `Debug` does not show it.
#[derive(Clone, PartialEq, Eq)]
pub struct AccessToken {
    hex: String,
}

impl std::fmt::Debug for AccessToken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("AccessToken(…)")
    }
}

impl AccessToken {
    /// A fresh token from the thread's cryptographically secure generator
    /// (ChaCha, seeded by the operating system).
    pub fn random() -> Self {
        let bytes: [u8; 32] = rand::rng().random();
        Self {
            hex: bytes.iter().map(|b| format!("{b:02x}")).collect(),
        }
    }

    /// The token's text, for the URL.
    pub fn as_str(&self) -> &str {
        &self.hex
    }

    /// Whether `candidate` is this token, in time independent of where they
    /// differ (the length, 64, is no secret).
    pub fn matches(&self, candidate: &str) -> bool {
        let (a, b) = (self.hex.as_bytes(), candidate.as_bytes());
        if a.len() != b.len() {
            return false;
        }
        let diff = a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y));
        std::hint::black_box(diff) == 0
    }

    /// Name of the cookie holding the token of the server on `port` (cookies
    /// are not kept apart by port, so two servers on one host need two names).
    pub fn cookie_name(port: u16) -> String {
        format!("seespot-token-{port}")
    }

    /// The `Set-Cookie` value for the server on `port`.
    pub fn set_cookie(&self, port: u16) -> String {
        format!(
            "{}={}; Path=/; HttpOnly; SameSite=Strict",
            Self::cookie_name(port),
            self.hex
        )
    }

    /// Whether a request with this query string and these `Cookie` header
    /// values carries the token: `(in the query, in a cookie)`.
    pub fn found_in<'a>(
        &self,
        port: u16,
        query: Option<&str>,
        cookies: impl IntoIterator<Item = &'a str>,
    ) -> (bool, bool) {
        let in_query = query.is_some_and(|q| {
            q.split('&')
                .filter_map(|kv| kv.strip_prefix("token="))
                .any(|t| self.matches(t))
        });
        let name = Self::cookie_name(port);
        let in_cookie = cookies.into_iter().any(|header| {
            header
                .split(';')
                .filter_map(|c| c.trim().split_once('='))
                .any(|(k, v)| k == name && self.matches(v))
        });
        (in_query, in_cookie)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn token_is_found_in_the_query_or_its_cookie_only() {
        let t = AccessToken::random();
        assert_eq!(t.as_str().len(), 64);
        assert_ne!(t, AccessToken::random());
        assert!(!format!("{t:?}").contains(t.as_str()));
        let q = format!("a=1&token={}", t.as_str());
        assert_eq!(t.found_in(80, Some(&q), []), (true, false));
        let c = format!("x=y; seespot-token-80={}", t.as_str());
        assert_eq!(t.found_in(80, None, [c.as_str()]), (false, true));
        // Another port's cookie, a prefix, a wrong token: not found.
        assert_eq!(t.found_in(81, None, [c.as_str()]), (false, false));
        let short = format!("token={}", &t.as_str()[..63]);
        assert_eq!(t.found_in(80, Some(&short), []), (false, false));
        assert_eq!(t.found_in(80, Some("token="), []), (false, false));
        assert!(!t.matches(&"0".repeat(64)) || t.as_str() == "0".repeat(64));
    }
}
