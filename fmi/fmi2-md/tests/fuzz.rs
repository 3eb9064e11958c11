//! Fuzzing of the model-description parser as an ordinary test: mutations of a kept corpus
//! (the repository's own model descriptions, the test fixtures, and the hand-made seeds in
//! `fuzz/corpus/model_description/`) must never panic, never take long, and a refusal must
//! be an `MdError`; whatever parses must also validate and generate code without panicking.
//!
//! Bounded: `FUZZ_CASES` mutated inputs (default 10,000, about a second in release); raise it
//! for a longer campaign, e.g. `FUZZ_CASES=200000 cargo test --release -p fmi2-md --test fuzz`.
//! A failing case is shrunk by proptest and its seed kept in `fuzz.regressions` beside
//! this file (replayed first on every run); a new seed file goes into the corpus folder.

use std::path::{Path, PathBuf};

use fmi2_md::ModelDescription;
use fmi2_md::codegen::codegen_rust;
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, TestRunner};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The corpus: every seed file, as bytes.
fn corpus() -> Vec<(String, Vec<u8>)> {
    let r = root();
    let mut files = vec![
        r.join("modelDescription/CkcmPlant.xml"),
        r.join("modelDescription/HlcsController.xml"),
        r.join("fmi/fmi2-md/tests/fixtures/valid.xml"),
        r.join("tests/fixtures/foreign-fmu/modelDescription.xml"),
    ];
    let mut extra: Vec<PathBuf> = std::fs::read_dir(r.join("fuzz/corpus/model_description"))
        .expect("the kept corpus exists")
        .map(|e| e.unwrap().path())
        .collect();
    extra.sort();
    files.extend(extra);
    files
        .into_iter()
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (p.display().to_string(), bytes)
        })
        .collect()
}

fn cases() -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000)
}

/// One edit of the input: the operations that break XML in interesting ways.
#[derive(Debug, Clone)]
enum Edit {
    /// Overwrite the byte at a position (taken modulo the length) with a value.
    Set(usize, u8),
    /// Insert a token likely to matter to the parser.
    Insert(usize, &'static str),
    /// Delete a run of bytes.
    Delete(usize, usize),
    /// Duplicate a run of bytes (repeated elements, attributes).
    Duplicate(usize, usize),
    /// Truncate.
    Truncate(usize),
}

const TOKENS: &[&str] = &[
    "<",
    ">",
    "/>",
    "</ScalarVariable>",
    "<ScalarVariable name=\"z\" valueReference=\"1\">",
    "\"",
    "=",
    "&amp;",
    "&#0;",
    "&#xD800;",
    "<![CDATA[",
    "]]>",
    "<!--",
    "-->",
    "\n",
    "\0",
    " min=\"-1e308\"",
    " max=\"nan\"",
    " start=\"1e999\"",
    " valueReference=\"-1\"",
    " causality=\"output\"",
    " initial=\"exact\"",
    " index=\"0\"",
    " declaredType=\"Nope\"",
    "\u{feff}",
    "\u{1b}[31m",
    "é",
    "\u{10ffff}",
];

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        4 => (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Edit::Set(i, b)),
        3 => (any::<usize>(), 0..TOKENS.len()).prop_map(|(i, t)| Edit::Insert(i, TOKENS[t])),
        2 => (any::<usize>(), 1usize..64).prop_map(|(i, n)| Edit::Delete(i, n)),
        1 => (any::<usize>(), 1usize..256).prop_map(|(i, n)| Edit::Duplicate(i, n)),
        1 => any::<usize>().prop_map(Edit::Truncate),
    ]
}

fn apply(mut bytes: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    for e in edits {
        let n = bytes.len().max(1);
        match *e {
            Edit::Set(i, b) => {
                if !bytes.is_empty() {
                    bytes[i % n] = b;
                }
            }
            Edit::Insert(i, t) => {
                let at = i % (bytes.len() + 1);
                bytes.splice(at..at, t.bytes());
            }
            Edit::Delete(i, k) => {
                let at = i % n;
                let end = (at + k).min(bytes.len());
                bytes.drain(at.min(end)..end);
            }
            Edit::Duplicate(i, k) => {
                let at = i % n;
                let end = (at + k).min(bytes.len());
                let run = bytes[at.min(end)..end].to_vec();
                bytes.splice(end..end, run);
            }
            Edit::Truncate(i) => bytes.truncate(i % n),
        }
    }
    bytes
}

/// The property: parse (and, if that succeeds, validate and generate code) without panic.
fn check(bytes: &[u8]) {
    // The parser takes text; a file that is not UTF-8 is refused by `from_file` before it.
    let text = String::from_utf8_lossy(bytes);
    match ModelDescription::parse(&text) {
        Ok(md) => {
            let _ = md.validate();
            let _ = codegen_rust(&md);
            for v in &md.model_variables {
                let _ = md.range_of(v);
            }
        }
        Err(e) => {
            let _ = e.to_string();
        }
    }
}

#[test]
fn corpus_seeds_parse_or_fail_cleanly() {
    let seeds = corpus();
    assert!(seeds.len() >= 8, "the kept corpus is missing");
    let mut parsed = 0;
    for (_, bytes) in &seeds {
        check(bytes);
        parsed += usize::from(ModelDescription::parse(&String::from_utf8_lossy(bytes)).is_ok());
    }
    // The repository's own descriptions and the fixtures are valid seeds.
    assert!(parsed >= 4, "{parsed}");
}

#[test]
fn mutated_model_descriptions_never_panic() {
    let seeds = corpus();
    let mut runner = TestRunner::new(Config {
        cases: cases(),
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("regressions"))),
        source_file: Some(file!()),
        ..Config::default()
    });
    let strategy = (0..seeds.len(), prop::collection::vec(edit(), 1..12));
    runner
        .run(&strategy, |(seed, edits)| {
            let input = apply(seeds[seed].1.clone(), &edits);
            check(&input);
            Ok(())
        })
        .unwrap();
}
