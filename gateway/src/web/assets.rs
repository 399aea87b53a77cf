//! The page, compressed at build time (`build.rs` gzips
//! `gateway/web/index.html`): one file with its style and script inline,
//! no external resource (a plant network has no internet).

/// `index.html`, gzip-compressed.
pub(crate) static INDEX_HTML_GZ: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/index.html.gz"));
