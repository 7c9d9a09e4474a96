//! rerun's web viewer, served by seespot so that it asks no host but this
//! machine.
//!
//! rerun's own server (`rerun::web_viewer`) serves the viewer's files as
//! they are built, and the viewer then reports to rerun: its WebAssembly
//! sends usage analytics to `tel.rerun.io` (there is no switch for that in
//! a browser: `rerun analytics disable` writes a file the native viewer
//! reads, not the web one), its welcome screen fetches a manifest from
//! `app.rerun.io`, and its page loads a font from `fonts.googleapis.com`.
//! seespot serves the same files itself instead, with two changes:
//!
//! - the page's links to Google Fonts (and their preconnects) are left out
//!   ([`local_index_html`]): the viewer draws with its own fonts;
//! - every response carries a Content-Security-Policy that allows this
//!   server's own files and the gRPC stream on 127.0.0.1, nothing else
//!   ([`content_security_policy`]), so the browser refuses every other
//!   request before it leaves the machine, whatever the viewer tries.
//!
//! Headers, not a setting of rerun's: they hold for every request the
//! viewer's code may make, today's and a later version's, and a browser
//! test can check them (`web/tests/offline.test.js`).

use std::net::SocketAddr;
use std::sync::Arc;

use axum::Router;
use axum::extract::State;
use axum::http::{HeaderValue, StatusCode, Uri, header};
use axum::response::{IntoResponse, Response};

use crate::error::Context as _;

/// The viewer's files and the headers they are served with.
struct Files {
    data: re_web_viewer_server::WebViewerData,
    index_html: String,
    csp: HeaderValue,
}

/// The Content-Security-Policy of every file of the viewer: scripts,
/// styles, images, fonts and workers from this server only (inline ones
/// and WebAssembly compilation included, as the viewer's page needs), and
/// connections to this server and the gRPC stream at `grpc_origin`
/// (`http://127.0.0.1:PORT`) only.
pub fn content_security_policy(grpc_origin: &str) -> String {
    format!(
        "default-src 'self'; \
         script-src 'self' 'unsafe-inline' 'wasm-unsafe-eval'; \
         style-src 'self' 'unsafe-inline'; \
         img-src 'self' data: blob:; \
         font-src 'self' data:; \
         media-src 'self' blob:; \
         worker-src 'self' blob:; \
         connect-src 'self' {grpc_origin}; \
         base-uri 'none'; \
         form-action 'none'"
    )
}

/// rerun's `index.html` without its `<link>` tags to Google Fonts (the
/// stylesheet and its preconnects), which fetch from outside hosts.
pub fn local_index_html(html: &str) -> String {
    let mut out = String::with_capacity(html.len());
    let mut rest = html;
    while let Some(start) = rest.find("<link") {
        out.push_str(&rest[..start]);
        let Some(len) = rest[start..].find('>') else {
            rest = &rest[start..];
            break;
        };
        let tag = &rest[start..start + len + 1];
        if !(tag.contains("fonts.googleapis.com") || tag.contains("fonts.gstatic.com")) {
            out.push_str(tag);
        }
        rest = &rest[start + len + 1..];
    }
    out.push_str(rest);
    out
}

/// The origin of a `rerun+http://HOST:PORT/proxy` stream address.
fn grpc_origin(grpc_url: &str) -> String {
    let url = grpc_url.trim_start_matches("rerun+");
    match url.find("://").map(|i| i + 3) {
        Some(i) => {
            let end = url[i..].find('/').map_or(url.len(), |j| i + j);
            url[..end].to_owned()
        }
        None => url.to_owned(),
    }
}

/// rerun's web viewer, served while this lives.
pub struct WebViewer(tokio::task::AbortHandle);

impl Drop for WebViewer {
    fn drop(&mut self) {
        self.0.abort();
    }
}

impl WebViewer {
    /// rerun's web viewer on `bind:port` (0: any free port), showing the
    /// gRPC stream at `grpc_url`, and the address that opens it. Runs on
    /// the current tokio runtime.
    pub fn serve(bind: &str, port: u16, grpc_url: &str) -> crate::error::Result<(Self, String)> {
        let data = re_web_viewer_server::WebViewerData::load(None)
            .files(|| "cannot load rerun's web viewer".into())?;
        let index = String::from_utf8_lossy(data.index_html()).into_owned();
        let csp = HeaderValue::from_str(&content_security_policy(&grpc_origin(grpc_url)))
            .files(|| format!("the gRPC address {grpc_url} cannot be put in a header"))?;
        let files = Arc::new(Files {
            index_html: local_index_html(&index),
            data,
            csp,
        });
        let ip: std::net::IpAddr = bind
            .parse()
            .files(|| format!("bad address for the rerun web viewer: {bind}"))?;
        let listener = std::net::TcpListener::bind(SocketAddr::new(ip, port))
            .files(|| format!("cannot bind the rerun web viewer to {bind}:{port}"))?;
        listener
            .set_nonblocking(true)
            .files(|| "cannot set up the rerun web viewer's socket".into())?;
        let addr = listener
            .local_addr()
            .files(|| "the rerun web viewer's socket has no address".into())?;
        let runtime = tokio::runtime::Handle::try_current()
            .files(|| "the rerun web viewer needs a tokio runtime".into())?;
        let listener = {
            let _entered = runtime.enter();
            tokio::net::TcpListener::from_std(listener)
                .files(|| "cannot set up the rerun web viewer's socket".into())?
        };
        let app = Router::new().fallback(file).with_state(files);
        let task = runtime.spawn(async move {
            // A failed accept loop ends the viewer only; the page goes on.
            if let Err(e) = axum::serve(listener, app).await {
                eprintln!("warning: the rerun web viewer stopped: {e}");
            }
        });
        let url = format!(
            "http://{addr}/?url={}",
            super::rerun_log::percent_encode(grpc_url)
        );
        Ok((Self(task.abort_handle()), url))
    }
}

/// One of the viewer's files by exact path, with the policy; else 404.
async fn file(State(files): State<Arc<Files>>, uri: Uri) -> Response {
    let d = &files.data;
    let (mime, body): (&str, Vec<u8>) = match uri.path() {
        "/" | "/index.html" => (
            "text/html; charset=utf-8",
            files.index_html.clone().into_bytes(),
        ),
        "/favicon.ico" => ("image/x-icon", d.favicon().to_vec()),
        "/apple-touch-icon.png" => ("image/png", d.apple_touch_icon().to_vec()),
        "/sw.js" => ("text/javascript", d.sw_js().to_vec()),
        "/re_viewer.js" => ("text/javascript", d.viewer_js().to_vec()),
        "/re_viewer_bg.wasm" => ("application/wasm", d.viewer_wasm().to_vec()),
        "/signed-in" => ("text/html; charset=utf-8", d.signed_in_html().to_vec()),
        "/signed-out" => ("text/html; charset=utf-8", d.signed_out_html().to_vec()),
        _ => return (StatusCode::NOT_FOUND, "not found").into_response(),
    };
    // The viewer's page shows its download's progress from this header.
    let length = HeaderValue::from(body.len());
    (
        [
            (header::CONTENT_TYPE, HeaderValue::from_static(mime)),
            (header::CONTENT_SECURITY_POLICY, files.csp.clone()),
            (
                header::HeaderName::from_static("rerun-final-length"),
                length,
            ),
        ],
        body,
    )
        .into_response()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_viewers_page_links_to_no_outside_host() {
        let data = re_web_viewer_server::WebViewerData::load(None).expect("assets");
        let html = local_index_html(&String::from_utf8_lossy(data.index_html()));
        for host in ["fonts.googleapis.com", "fonts.gstatic.com"] {
            assert!(!html.contains(host), "{host} is still linked");
        }
        // Only those links go: the icons stay, the page is otherwise rerun's.
        assert!(html.contains(r#"<link rel="icon" href="favicon.ico""#));
        assert!(html.contains(r#"<script src="re_viewer.js"></script>"#));
    }

    #[test]
    fn the_policy_allows_the_grpc_stream_and_nothing_else_outside() {
        assert_eq!(
            grpc_origin("rerun+http://127.0.0.1:9876/proxy"),
            "http://127.0.0.1:9876"
        );
        let csp = content_security_policy("http://127.0.0.1:9876");
        assert!(
            csp.contains("connect-src 'self' http://127.0.0.1:9876;"),
            "{csp}"
        );
        assert!(csp.starts_with("default-src 'self';"));
        assert!(!csp.contains('*') && !csp.contains("https:"), "{csp}");
    }
}
