//! Every vector of `host-tests/vectors/*.txt` through the codec.
//!
//! Set `HANS_BLESS=<dir>` to also write, for each corpus file, what the codec
//! does with it in the same format (`<dir>/<file>`): diff it against the
//! corpus to review a change. The test still fails on any difference.

use std::path::{Path, PathBuf};

use hans_host_tests::corpus::{differences, Corpus, Kind, Source};

fn corpus_files() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("vectors");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("vectors directory")
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
        .collect();
    files.sort();
    files
}

fn load(name: &str) -> Corpus {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("vectors")
        .join(name);
    Corpus::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn every_vector_behaves_as_the_corpus_says() {
    let files = corpus_files();
    assert!(files.len() >= 2, "corpus files missing: {files:?}");
    let mut report = Vec::new();
    let mut total = 0;
    for path in &files {
        let corpus = Corpus::load(path).unwrap_or_else(|e| panic!("{e}"));
        let outcomes = corpus.evaluate();
        if let Some(dir) = std::env::var_os("HANS_BLESS") {
            let out = Path::new(&dir).join(path.file_name().expect("file name"));
            std::fs::write(&out, corpus.render(&outcomes)).expect("write rendition");
        }
        for (v, o) in corpus.vectors.iter().zip(&outcomes) {
            total += 1;
            for d in differences(v, o) {
                report.push(format!("{}: {d}", path.display()));
            }
        }
    }
    assert!(total > 500, "only {total} vectors");
    assert!(
        report.is_empty(),
        "{} differences:\n{}",
        report.len(),
        report.join("\n")
    );
}

/// Every command of the catalogue has a request and a reply in the corpus
/// that parse, and every section of chapter 4 has its document examples.
#[test]
fn corpus_covers_every_command() {
    let corpus = load("chapter4.txt");
    let outcomes = corpus.evaluate();
    for id in hans_codec::CommandId::ALL {
        let mine = || {
            corpus
                .vectors
                .iter()
                .zip(&outcomes)
                .filter(move |(v, _)| v.command == id.name())
        };
        assert!(
            mine().any(|(v, _)| v.source == Source::Doc),
            "{id}: no example line of the document"
        );
        for kind in [Kind::Req, Kind::Ok, Kind::Fail] {
            assert!(
                mine().any(|(v, o)| v.kind == kind && o.error.is_none()),
                "{id}: no {} vector that parses",
                kind.as_str()
            );
        }
    }
}
