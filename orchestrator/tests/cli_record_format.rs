//! `[record] format` and `run --record-format`: a campaign recorded as Parquet holds the same
//! columns and the same f64 bits as the same campaign recorded as CSV; an unknown format is
//! refused with the scenario's file and line before anything runs.

mod common;

use std::path::Path;

use common::{CLOSED_LOOP, fmu_path_text, orchestrator, read_csv, run_scenario, tree};
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::Field;

/// A 0.3 s HLCS line, 2 trials, both recorded; `format` is the `[record]` line for it.
fn scenario(dir: &Path, format: &str) -> std::path::PathBuf {
    let path = dir.join("line.toml");
    std::fs::write(
        &path,
        format!(
            r#"step_size = 0.001
stop_time = 0.3
trials = 2

[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "line"
duration = 0.3
learning = true

[[fmu]]
name = "plant"
path = "{plant}"
{CLOSED_LOOP}
[record]
variables = ["controller.error", "controller.force", "plant.pose"]
{format}
"#,
            controller = fmu_path_text("HlcsController"),
            plant = fmu_path_text("CkcmPlant"),
        ),
    )
    .unwrap();
    path
}

/// Column names and every value's bits, column by column, of a Parquet recording.
fn read_parquet(path: &Path) -> (Vec<String>, Vec<Vec<u64>>) {
    let reader = SerializedFileReader::new(std::fs::File::open(path).unwrap()).unwrap();
    let schema = reader.metadata().file_metadata().schema_descr();
    let names: Vec<String> = schema
        .columns()
        .iter()
        .map(|c| c.name().to_owned())
        .collect();
    let mut columns = vec![Vec::new(); names.len()];
    for row in reader.get_row_iter(None).unwrap() {
        for (i, (_, field)) in row.unwrap().get_column_iter().enumerate() {
            match field {
                Field::Double(x) => columns[i].push(x.to_bits()),
                other => panic!("column {} holds {other:?}", names[i]),
            }
        }
    }
    (names, columns)
}

#[test]
fn parquet_holds_the_csv_bits_from_the_scenario_and_from_the_command_line() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |scenario: &Path, out: &str, extra: &[&str]| {
        orchestrator()
            .arg("run")
            .arg(scenario)
            .arg("--out")
            .arg(tmp.path().join(out))
            .args(extra)
            .assert()
            .success();
        tmp.path().join(out).join("trials")
    };
    let csv = run(&scenario(tmp.path(), ""), "csv", &[]);
    let by_flag = run(
        &scenario(tmp.path(), ""),
        "flag",
        &["--record-format", "parquet"],
    );
    let by_table = run(&scenario(tmp.path(), "format = \"parquet\""), "table", &[]);
    for k in 0..2 {
        let rec = read_csv(&csv.join(format!("trial_00{k}.csv")));
        let mut names = vec!["time".to_owned()];
        names.extend(rec.names.iter().cloned());
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let mut want = vec![bits(&rec.time)];
        want.extend(rec.columns.iter().map(|c| bits(c)));
        assert_eq!(rec.len(), 300);
        for dir in [&by_flag, &by_table] {
            let file = dir.join(format!("trial_00{k}.parquet"));
            assert!(!dir.join(format!("trial_00{k}.csv")).exists());
            let (got_names, got) = read_parquet(&file);
            assert_eq!(got_names, names, "{}", file.display());
            assert_eq!(got, want, "{}", file.display());
        }
    }
}

#[test]
fn an_unknown_format_is_refused_with_file_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    let path = scenario(tmp.path(), "format = \"hdf5\"");
    let line = std::fs::read_to_string(&path)
        .unwrap()
        .lines()
        .position(|l| l.contains("hdf5"))
        .unwrap()
        + 1;
    let o = orchestrator()
        .arg("run")
        .arg(&path)
        .arg("--out")
        .arg(tmp.path().join("out"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(&format!("line.toml:{line}")), "{err}");
    assert!(
        err.contains("record.format \"hdf5\" is not \"csv\" or \"parquet\""),
        "{err}"
    );
    assert!(!tmp.path().join("out").exists());
}

/// A campaign keeps one format: resuming a CSV campaign with `--record-format parquet` is
/// refused, naming a kept file, and changes nothing; resumed in its own format it records
/// the rest as CSV too. Before, the resumed trials came out as Parquet beside the CSV ones.
#[test]
fn a_resume_in_another_format_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let path = scenario(tmp.path(), "");
    let out = tmp.path().join("out");
    let run = |args: &[&str]| run_scenario(&path, &out, args);
    assert!(run(&["--trials", "1"]).status.success());
    let o = run(&["--resume", "--record-format", "parquet"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(
            "its recorded trials are in another format (trial_000.csv) than this run would \
             write (parquet)"
        ),
        "{err}"
    );
    assert_eq!(trial_files(&out), ["trial_000.csv"]);
    assert!(run(&["--resume"]).status.success());
    assert_eq!(trial_files(&out), ["trial_000.csv", "trial_001.csv"]);
}

/// The files in the campaign folder `out`'s `trials`, sorted.
fn trial_files(out: &Path) -> Vec<String> {
    tree(&out.join("trials"))
        .into_keys()
        .map(|p| p.display().to_string())
        .collect()
}

/// Only the trials a resume keeps bind its format: a file of the trial that was running
/// when the campaign stopped (renamed into place before the progress was saved) is a
/// leftover the resume replaces, whatever its format.
#[test]
fn a_leftover_of_the_interrupted_trial_does_not_bind_the_format() {
    let tmp = tempfile::tempdir().unwrap();
    let path = scenario(tmp.path(), "trials = [1]");
    let out = tmp.path().join("out");
    let run = |args: &[&str]| run_scenario(&path, &out, args);
    assert!(run(&["--trials", "1"]).status.success());
    std::fs::create_dir_all(out.join("trials")).unwrap();
    std::fs::write(out.join("trials/trial_001.csv"), "time\n0\n").unwrap();
    let o = run(&["--resume", "--record-format", "parquet"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(trial_files(&out), ["trial_001.parquet"]);
}
