//! Compresses the web page (`web/index.html`) for the firmware's flash
//! when the `web` feature is on: gzip at the best level, with no time
//! stamp, so that the same page gives the same bytes.

use std::io::Write;

fn main() {
    println!("cargo::rerun-if-changed=web/index.html");
    if std::env::var_os("CARGO_FEATURE_WEB").is_none() {
        return;
    }
    let out = std::path::PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let page = std::fs::read("web/index.html").expect("web/index.html is part of the crate");
    let mut gz = flate2::GzBuilder::new()
        .mtime(0)
        .write(Vec::new(), flate2::Compression::best());
    gz.write_all(&page).expect("compressing in memory");
    let bytes = gz.finish().expect("compressing in memory");
    std::fs::write(out.join("index.html.gz"), bytes).expect("writing to OUT_DIR");
}
