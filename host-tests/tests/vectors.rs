//! Every vector of `host-tests/vectors/` through the codec.
//!
//! * `vectors/*.txt`: HR-TCP V1.0.0.3's examples and the variants, the same
//!   whatever the codec's features.
//! * `vectors/v5-only/*.txt`: what reads otherwise without the `v6` feature
//!   (the V6 names pass through as unknown, `MovePathJ` is an alias).
//! * `vectors/v6/*.txt`: the V6 document's examples and variants, with the
//!   `v6` feature (`cargo test -p hans-host-tests --features v6`).
//!
//! Set `HANS_BLESS=<dir>` to also write, for each corpus file, what the codec
//! does with it in the same format (`<dir>/<path under vectors/>`): diff it
//! against the corpus to review a change. The test still fails on any
//! difference.

use std::path::{Path, PathBuf};

use hans_codec::CommandId;
use hans_host_tests::corpus::{differences, Corpus, Kind, Source};

fn vectors() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("vectors")
}

/// The corpus files of `dir` (under `vectors/`), sorted.
fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
        .collect();
    files.sort();
    files
}

/// The corpus files this build runs.
fn corpus_files() -> Vec<PathBuf> {
    let mut files = files_in(&vectors());
    let extra = if cfg!(feature = "v6") {
        "v6"
    } else {
        "v5-only"
    };
    files.extend(files_in(&vectors().join(extra)));
    files
}

fn load(name: &str) -> Corpus {
    Corpus::load(&vectors().join(name)).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn every_vector_behaves_as_the_corpus_says() {
    let files = corpus_files();
    assert!(files.len() >= 3, "corpus files missing: {files:?}");
    let mut report = Vec::new();
    let mut total = 0;
    for path in &files {
        let corpus = Corpus::load(path).unwrap_or_else(|e| panic!("{e}"));
        let outcomes = corpus.evaluate();
        if let Some(dir) = std::env::var_os("HANS_BLESS") {
            let relative = path.strip_prefix(vectors()).expect("under vectors/");
            let out = Path::new(&dir).join(relative);
            std::fs::create_dir_all(out.parent().expect("a directory")).expect("create");
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

/// Every command of `commands` has a request, a success and a failure reply
/// in `corpus` that parse (but the failures of `no_failure`), and an example
/// line of the document (but those of `no_example`, for which the document
/// prints none).
fn covers(
    corpus: &Corpus,
    commands: &[CommandId],
    no_example: &[CommandId],
    no_failure: &[CommandId],
) {
    let outcomes = corpus.evaluate();
    for id in commands {
        let mine = || {
            corpus
                .vectors
                .iter()
                .zip(&outcomes)
                .filter(move |(v, _)| v.command == id.name())
        };
        if !no_example.contains(id) {
            assert!(
                mine().any(|(v, _)| v.source == Source::Doc),
                "{id}: no example line of the document"
            );
        }
        for kind in [Kind::Req, Kind::Ok, Kind::Fail] {
            if kind == Kind::Fail && no_failure.contains(id) {
                continue;
            }
            assert!(
                mine().any(|(v, o)| v.kind == kind && o.error.is_none()),
                "{id}: no {} vector that parses",
                kind.as_str()
            );
        }
    }
}

/// Every command of HR-TCP V1.0.0.3 has its document examples in the corpus.
#[test]
fn corpus_covers_every_command() {
    let v5: Vec<CommandId> = CommandId::ALL
        .iter()
        .copied()
        .filter(|id| id.section_v5().is_some())
        .collect();
    assert_eq!(v5.len(), 139);
    covers(&load("chapter4.txt"), &v5, &[], &[]);
}

/// Every command of the V6 document has its document examples in the V6
/// corpus; `EnterSafetyGuard` (the old name, in a signature only) and
/// `UpdatePathName` (a section without examples) have vectors of their own.
/// The document prints no failure for four commands (`GetErrorCodeStr`
/// never fails).
#[cfg(feature = "v6")]
#[test]
fn v6_corpus_covers_every_command() {
    let v6: Vec<CommandId> = CommandId::ALL
        .iter()
        .copied()
        .filter(|id| id.section_v6().is_some())
        .collect();
    // The document's 209 sections (`4.2.9` describes both names).
    assert_eq!(v6.len(), 210);
    covers(
        &load("v6/chapter4.txt"),
        &v6,
        &[CommandId::EnterSafetyGuard, CommandId::UpdatePathName],
        &[
            CommandId::GetErrorCodeStr,
            CommandId::ReadRobotModel,
            CommandId::PackageVersion,
            CommandId::ReadFastCmdPort,
        ],
    );
}
