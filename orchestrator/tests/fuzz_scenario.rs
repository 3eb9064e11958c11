//! Fuzzing the scenario parser: the files of `tests/corpus/scenario/` (the kept corpus; add
//! any input that ever broke the parser), mutated at random (bytes flipped, spans deleted or
//! duplicated, TOML and number tokens inserted), must each parse into a scenario that keeps
//! the validation's promises, or fail with an error naming the file and an existing line,
//! never panic. Runs 1500 cases (a few seconds in release), reproducibly: a failure is
//! stored by proptest under `proptest-regressions/` and replayed first.

use std::path::{Path, PathBuf};

use fmi2_md::ModelDescription;
use orchestrator::campaign::memory_estimate;
use orchestrator::scenario::Scenario;
use orchestrator::variables::{Value, check_value};
use proptest::prelude::*;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn md(path: &str) -> ModelDescription {
    let text = std::fs::read_to_string(root().join(path)).unwrap();
    ModelDescription::parse(&text).unwrap()
}

/// The model descriptions the corpus refers to, by FMU file name.
struct Models {
    plant: ModelDescription,
    controller: ModelDescription,
    foreign: ModelDescription,
}

impl Models {
    fn load() -> Models {
        Models {
            plant: md("modelDescription/CkcmPlant.xml"),
            controller: md("modelDescription/HlcsController.xml"),
            foreign: md("tests/fixtures/foreign-fmu/modelDescription.xml"),
        }
    }

    fn describe(&self, fmu: &Path) -> Result<ModelDescription, String> {
        let name = fmu.file_name().unwrap_or_default().to_string_lossy();
        if name.contains("Plant") {
            Ok(self.plant.clone())
        } else if name.contains("Controller") {
            Ok(self.controller.clone())
        } else if name.contains("Oscillator") {
            Ok(self.foreign.clone())
        } else {
            Err(format!("no such FMU {name}"))
        }
    }
}

fn corpus() -> Vec<(String, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/scenario");
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    files.sort();
    assert!(files.len() >= 3, "the corpus is in {}", dir.display());
    files
}

/// Tokens that reach deep into the parser: numbers at the edges of f64 and i32, TOML syntax,
/// names of real variables and sections.
const TOKENS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "-0",
    "0",
    "1e308",
    "1e-320",
    "2147483648",
    "-2147483649",
    "1e999",
    "\"",
    "'",
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "}",
    "=",
    ",",
    "\n",
    "#",
    ".",
    "\\u0000",
    "\u{1b}",
    "[[fmu]]\n",
    "[[connection]]\n",
    "[[memory]]\n",
    "[record]\n",
    "[metrics]\n",
    "[fmu.parameters]\n",
    "substeps = 0\n",
    "mass = -1\n",
    "trials = 0\n",
    "step_size = 1e-12\n",
    "stop_time = 1e300\n",
    "variables = [\"osc.x\", \"osc.x\"]\n",
    "plant.",
    "controller.",
    "osc.",
    "force[7]",
    "length[0]",
    "memory_limit_mib = 0\n",
];

#[derive(Debug, Clone)]
enum Mutation {
    Flip(usize, u8),
    Delete(usize, usize),
    Duplicate(usize, usize),
    Insert(usize, usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(p, b)| Mutation::Flip(p, b)),
        (any::<usize>(), 1..40usize).prop_map(|(p, n)| Mutation::Delete(p, n)),
        (any::<usize>(), 1..80usize).prop_map(|(p, n)| Mutation::Duplicate(p, n)),
        (any::<usize>(), 0..TOKENS.len()).prop_map(|(p, t)| Mutation::Insert(p, t)),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    let len = bytes.len().max(1);
    match *m {
        Mutation::Flip(p, b) => {
            if !bytes.is_empty() {
                let p = p % bytes.len();
                bytes[p] ^= b;
            }
        }
        Mutation::Delete(p, n) => {
            let p = p % len;
            let end = (p + n).min(bytes.len());
            if p < end {
                bytes.drain(p..end);
            }
        }
        Mutation::Duplicate(p, n) => {
            let p = p % len;
            let end = (p + n).min(bytes.len());
            if p < end {
                let span = bytes[p..end].to_vec();
                bytes.splice(end..end, span);
            }
        }
        Mutation::Insert(p, t) => {
            let p = p % (bytes.len() + 1);
            bytes.splice(p..p, TOKENS[t].bytes());
        }
    }
}

/// What a scenario that passed validation promises.
fn check_valid(scenario: &Scenario, models: &Models) {
    assert!(scenario.step_size.is_finite() && scenario.step_size > 0.0);
    assert!(scenario.stop_time.is_finite() && scenario.stop_time > scenario.start_time);
    assert!(scenario.steps >= 1 && scenario.trials >= 1);
    assert!(scenario.record.interval >= 1);
    let _ = memory_estimate(scenario);
    for fmu in &scenario.fmus {
        let md = models.describe(&fmu.path).unwrap();
        for s in &fmu.settings {
            let var = md.variable_by_name(&s.name).unwrap();
            if let Value::Real(x) = s.value {
                assert!(x.is_finite(), "{} = {x}", s.name);
            }
            check_value(&md, var, &s.value).unwrap();
        }
    }
    let mut names: Vec<&String> = scenario
        .record
        .ports
        .iter()
        .flat_map(|p| &p.names)
        .collect();
    let n = names.len();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), n, "a variable recorded twice");
}

#[test]
fn the_corpus_is_valid() {
    let models = Models::load();
    for (name, bytes) in corpus() {
        let text = String::from_utf8(bytes).unwrap();
        let s = Scenario::parse(&text, Path::new(&name), |p| models.describe(p))
            .unwrap_or_else(|e| panic!("corpus file {name}: {e}"));
        check_valid(&s, &models);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1500, ..ProptestConfig::default() })]

    #[test]
    fn mutated_scenarios_validate_or_fail_with_file_and_line(
        pick in any::<usize>(),
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let models = Models::load();
        let corpus = corpus();
        let (name, seed) = &corpus[pick % corpus.len()];
        let mut bytes = seed.clone();
        for m in &mutations {
            apply(&mut bytes, m);
        }
        let text = String::from_utf8_lossy(&bytes);
        let file = Path::new("fuzz").join(name);
        match Scenario::parse(&text, &file, |p| models.describe(p)) {
            Ok(s) => check_valid(&s, &models),
            Err(e) => {
                prop_assert_eq!(&e.file, &file);
                prop_assert!(!e.message.is_empty());
                if let Some(line) = e.line {
                    prop_assert!(line >= 1 && line <= text.lines().count() + 1, "{}", e);
                }
                prop_assert!(e.to_string().starts_with(&file.display().to_string()));
            }
        }
    }
}
