//! Model-description parsing at scale: a generated description with 200,000 Real variables
//! (inputs, outputs and parameters, every output listed in `ModelStructure`) must parse in
//! well under 2 s; the cost must grow linearly with the number of variables (the 50,000
//! case is there to read the growth off the same run).
//!
//! `cargo bench -p fmi2-md --bench parse`

use std::fmt::Write;
use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use fmi2_md::ModelDescription;

/// A valid co-simulation model description with `n` scalar variables, one per line as
/// the FMUs of this repository write them.
fn model_description(n: usize) -> String {
    let mut xml = String::with_capacity(n * 200 + 1000);
    xml.push_str(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiModelDescription fmiVersion=\"2.0\" \
         modelName=\"Big\" guid=\"{00000000-0000-0000-0000-000000000001}\">\n  \
         <CoSimulation modelIdentifier=\"Big\"/>\n  <ModelVariables>\n",
    );
    let mut outputs = Vec::new();
    for i in 0..n {
        let (causality, body) = match i % 3 {
            0 => ("input", "<Real start=\"0.0\"/>"),
            1 => ("output", "<Real/>"),
            _ => (
                "parameter\" variability=\"fixed\" initial=\"exact",
                "<Real start=\"1.0\" min=\"0\" max=\"10\"/>",
            ),
        };
        if i % 3 == 1 {
            outputs.push(i + 1);
        }
        let _ = writeln!(
            xml,
            "    <ScalarVariable name=\"x[{}]\" valueReference=\"{i}\" causality=\"{causality}\">\n      {body}\n    </ScalarVariable>",
            i + 1
        );
    }
    xml.push_str("  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n");
    for index in &outputs {
        let _ = writeln!(xml, "      <Unknown index=\"{index}\"/>");
    }
    xml.push_str("    </Outputs>\n    <InitialUnknowns>\n");
    for index in &outputs {
        let _ = writeln!(xml, "      <Unknown index=\"{index}\"/>");
    }
    xml.push_str("    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n");
    xml
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("md_parse");
    group.sample_size(10);
    group.measurement_time(Duration::from_secs(20));
    for n in [50_000, 200_000] {
        let xml = model_description(n);
        let parsed = ModelDescription::parse(&xml).expect("the generated description is valid");
        assert_eq!(parsed.model_variables.len(), n);
        let problems = parsed.validate();
        assert!(
            problems.is_empty(),
            "{} problems, first {:?}",
            problems.len(),
            problems.first()
        );
        group.bench_function(format!("parse/{n}"), |b| {
            b.iter(|| ModelDescription::parse(black_box(&xml)))
        });
        group.bench_function(format!("parse_and_validate/{n}"), |b| {
            b.iter(|| ModelDescription::parse(black_box(&xml)).map(|md| md.validate()))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
