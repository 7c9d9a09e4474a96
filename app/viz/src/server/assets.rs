//! The page's files, embedded in the binary when it is built, so that nothing
//! else on disk can be served.

/// The page's files, embedded at compile time: `(url path, content type, body)`.
pub const ASSETS: &[(&str, &str, &str)] = &[
    (
        "/",
        "text/html; charset=utf-8",
        include_str!("../../../../web/index.html"),
    ),
    (
        "/index.html",
        "text/html; charset=utf-8",
        include_str!("../../../../web/index.html"),
    ),
    (
        "/app.js",
        "text/javascript; charset=utf-8",
        include_str!("../../../../web/app.js"),
    ),
    (
        "/render.js",
        "text/javascript; charset=utf-8",
        include_str!("../../../../web/render.js"),
    ),
    (
        "/style.css",
        "text/css; charset=utf-8",
        include_str!("../../../../web/style.css"),
    ),
    (
        "/review",
        "text/html; charset=utf-8",
        include_str!("../../../../web/review.html"),
    ),
    (
        "/review.js",
        "text/javascript; charset=utf-8",
        include_str!("../../../../web/review.js"),
    ),
    (
        "/difference",
        "text/html; charset=utf-8",
        include_str!("../../../../web/difference.html"),
    ),
    (
        "/difference.js",
        "text/javascript; charset=utf-8",
        include_str!("../../../../web/difference.js"),
    ),
    (
        "/favicon.svg",
        "image/svg+xml",
        include_str!("../../../../web/favicon.svg"),
    ),
];
