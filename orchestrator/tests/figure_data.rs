//! The paper's figures plot the recorded data: every data line of a figure is a recorded
//! series (same number of points, pixel positions an affine map of the values to within
//! pixel rounding), checked generically on the SVG so that it holds whatever the layout.

mod common;

use std::collections::BTreeMap;
use std::path::Path;

/// The `points` of every `<polyline>` in an SVG, as (x, y) pixel pairs.
fn polylines(svg: &str) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    for chunk in svg.split("<polyline").skip(1) {
        let Some(start) = chunk.find("points=\"") else {
            continue;
        };
        let rest = &chunk[start + 8..];
        let points = &rest[..rest.find('"').expect("closed points attribute")];
        out.push(
            points
                .split_whitespace()
                .map(|p| {
                    let (x, y) = p.split_once(',').expect("x,y point");
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect(),
        );
    }
    out
}

/// Largest residual (px) of the least-squares affine map value → pixel.
fn affine_residual(values: &[f64], pixels: &[f64]) -> f64 {
    let n = values.len() as f64;
    let mv = values.iter().sum::<f64>() / n;
    let mp = pixels.iter().sum::<f64>() / n;
    let svv: f64 = values.iter().map(|v| (v - mv) * (v - mv)).sum();
    let svp: f64 = values
        .iter()
        .zip(pixels)
        .map(|(v, p)| (v - mv) * (p - mp))
        .sum();
    let slope = if svv > 0.0 { svp / svv } else { 0.0 };
    values
        .iter()
        .zip(pixels)
        .map(|(v, p)| (mp + slope * (v - mv) - p).abs())
        .fold(0.0, f64::max)
}

/// A line of a figure is the series (x, y) when it has one point per value and both pixel
/// coordinates are affine in the values to within rounding to whole pixels (plus the
/// least-squares fit's own share, hence 1 px), and the series is not flat (a flat series
/// would match any horizontal line).
fn plots(line: &[(f64, f64)], x: &[f64], y: &[f64]) -> bool {
    let (px, py): (Vec<f64>, Vec<f64>) = line.iter().copied().unzip();
    let spread = |v: &[f64]| {
        v.iter().copied().fold(f64::MIN, f64::max) - v.iter().copied().fold(f64::MAX, f64::min)
    };
    line.len() == x.len()
        && spread(y) > 0.0
        && spread(&py) >= 10.0
        && affine_residual(x, &px) <= 1.0
        && affine_residual(y, &py) <= 1.0
}

/// Columns of a CSV by header name, `time` included.
fn columns(path: &Path) -> BTreeMap<String, Vec<f64>> {
    let rec = common::read_csv(path);
    let mut out: BTreeMap<String, Vec<f64>> = rec
        .names
        .iter()
        .map(|n| (n.clone(), common::column(&rec, n).to_vec()))
        .collect();
    out.insert("time".to_string(), rec.time.clone());
    out
}

/// Recorded trials of one campaign directory, in trial order.
fn trials(campaign: &Path) -> Vec<BTreeMap<String, Vec<f64>>> {
    let mut files: Vec<_> = std::fs::read_dir(campaign.join("trials"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "csv"))
        .collect();
    files.sort();
    files.iter().map(|p| columns(p)).collect()
}

#[test]
fn figures_plot_the_recorded_data() {
    let fmus = common::built_fmu("CkcmPlant");
    common::built_fmu("HlcsController");
    let out = tempfile::tempdir().unwrap();
    common::orchestrator()
        .args([
            "paper",
            "--trials",
            "5",
            "--line-duration",
            "0.5",
            "--circle-duration",
            "0.5",
        ])
        .arg("--fmu-dir")
        .arg(fmus.parent().unwrap())
        .arg("--out")
        .arg(out.path())
        .assert()
        .success();
    let root = out.path();
    let mut leg_figures = 0;
    let mut path_figures = 0;
    for entry in std::fs::read_dir(root.join("figures")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        let svg = std::fs::read_to_string(&path).unwrap();
        // Data lines: longer than any axis, tick or legend stroke.
        let lines: Vec<_> = polylines(&svg)
            .into_iter()
            .filter(|l| l.len() > 10)
            .collect();
        let (trajectory, rest) = name.split_once('_').unwrap();
        if let Some(scheme) = rest.strip_suffix("_leg_errors.svg") {
            // Every line is one leg's error over one recorded trial, and all six legs of
            // every panel are drawn.
            leg_figures += 1;
            let recorded = trials(&root.join(trajectory).join(scheme));
            assert!(
                !lines.is_empty() && lines.len() % 6 == 0,
                "{name}: {} lines",
                lines.len()
            );
            for (i, line) in lines.iter().enumerate() {
                let found = recorded.iter().any(|t| {
                    (1..=6)
                        .any(|leg| plots(line, &t["time"], &t[&format!("controller.error[{leg}]")]))
                });
                assert!(
                    found,
                    "{name}: line {i} ({} points) is no recorded leg error",
                    line.len()
                );
            }
        } else if rest == "path.svg" {
            // Some lines are the recorded platform path of a scheme (the others the desired
            // path); each has one point per sample.
            path_figures += 1;
            let mut matched = 0;
            for scheme in ["pid", "pd_ilc", "hlcs"] {
                for t in trials(&root.join(trajectory).join(scheme)) {
                    let pose = |j: usize| &t[&format!("plant.pose[{j}]")];
                    for line in &lines {
                        if [(1, 2), (1, 3), (2, 3), (2, 1), (3, 1), (3, 2)]
                            .iter()
                            .any(|&(a, b)| plots(line, pose(a), pose(b)))
                            || (1..=3).any(|j| plots(line, &t["time"], pose(j)))
                        {
                            matched += 1;
                        }
                    }
                }
            }
            assert!(
                matched > 0,
                "{name}: no line is a recorded path ({} lines)",
                lines.len()
            );
        }
    }
    assert_eq!(
        (leg_figures, path_figures),
        (6, 2),
        "leg-error and path figures"
    );
}
