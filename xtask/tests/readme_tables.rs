//! The README's FMU variable tables name exactly the variables of the model descriptions:
//! every row refers to real variables, and every variable appears in a row.

use std::collections::BTreeSet;
use std::path::Path;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

/// Variable names of the first column of the table under `### {heading}`, expanded:
/// `x[1..6]` → x[1]…x[6]; `model.*` → every name with that prefix in `all`.
fn table_names(readme: &str, heading: &str, all: &BTreeSet<String>) -> BTreeSet<String> {
    let start = readme
        .find(&format!("### {heading}\n"))
        .unwrap_or_else(|| panic!("no ### {heading}"));
    let mut names = BTreeSet::new();
    for line in readme[start..]
        .lines()
        .skip(1)
        .skip_while(|l| !l.starts_with('|'))
    {
        if !line.starts_with('|') {
            break;
        }
        let first = line.split('|').nth(1).unwrap_or("");
        for part in first.split('`').skip(1).step_by(2) {
            if let Some(prefix) = part.strip_suffix('*') {
                let matched: Vec<_> = all
                    .iter()
                    .filter(|n| n.starts_with(prefix))
                    .cloned()
                    .collect();
                assert!(!matched.is_empty(), "{heading}: `{part}` matches nothing");
                names.extend(matched);
            } else if let Some((base, range)) =
                part.split_once('[').filter(|(_, r)| r.contains(".."))
            {
                let (a, b) = range.trim_end_matches(']').split_once("..").unwrap();
                for i in a.parse::<usize>().unwrap()..=b.parse::<usize>().unwrap() {
                    names.insert(format!("{base}[{i}]"));
                }
            } else {
                names.insert(part.to_string());
            }
        }
    }
    names
}

#[test]
fn readme_tables_match_model_descriptions() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    for id in ["CkcmPlant", "HlcsController"] {
        let md =
            fmi2_md::ModelDescription::from_file(root().join(format!("modelDescription/{id}.xml")))
                .unwrap();
        let all: BTreeSet<String> = md.model_variables.iter().map(|v| v.name.clone()).collect();
        let documented = table_names(&readme, id, &all);
        let unknown: Vec<_> = documented.difference(&all).collect();
        let missing: Vec<_> = all.difference(&documented).collect();
        assert!(
            unknown.is_empty(),
            "README documents {id} variables that do not exist: {unknown:?}"
        );
        assert!(
            missing.is_empty(),
            "README does not document {id} variables: {missing:?}"
        );
    }
}
