//! The paper's figures plot the recorded data, checked generically on the SVG so that it
//! holds whatever the layout: every figure has data lines inside its canvas, and the figures
//! of recorded signals (actuator forces, learned input) draw recorded series: one point per
//! recorded sample (one more for the state after the last sample), pixel coordinates an affine
//! map of time and the recorded values to within pixel rounding.

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
    // A line may have one extra point (the state after the last sample), at either end.
    if line.len() != x.len() && line.len() != x.len() + 1 {
        return false;
    }
    let extra = line.len() - x.len();
    (0..=extra).any(|skip| {
        let (px, py) = (&px[skip..skip + x.len()], &py[skip..skip + x.len()]);
        spread(y) > 0.0
            && spread(py) >= 10.0
            && affine_residual(x, px) <= 1.0
            && affine_residual(y, py) <= 1.0
    })
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

/// The canvas size of an SVG from its `width` and `height` attributes.
fn canvas(svg: &str) -> (f64, f64) {
    let attr = |name: &str| -> f64 {
        let key = format!("{name}=\"");
        let start = svg.find(&key).expect("svg size") + key.len();
        svg[start..start + svg[start..].find('"').unwrap()]
            .parse()
            .unwrap()
    };
    (attr("width"), attr("height"))
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
    let mut series_figures = Vec::new();
    let mut figures = 0;
    for entry in std::fs::read_dir(root.join("figures")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        let svg = std::fs::read_to_string(&path).unwrap();
        figures += 1;
        let (width, height) = canvas(&svg);
        // Data lines: longer than any axis, tick or legend stroke (2 or 3 points); a
        // convergence line has one point per trial.
        let lines: Vec<_> = polylines(&svg)
            .into_iter()
            .filter(|l| l.len() > 3)
            .collect();
        assert!(!lines.is_empty(), "{name} draws no data line");
        for line in &lines {
            for &(x, y) in line {
                assert!(
                    x.is_finite()
                        && y.is_finite()
                        && (0.0..=width).contains(&x)
                        && (0.0..=height).contains(&y),
                    "{name}: point ({x}, {y}) outside the {width}x{height} canvas"
                );
            }
        }
        let Some((trajectory, _)) = name.split_once('_') else {
            continue;
        };
        let Ok(schemes) = std::fs::read_dir(root.join(trajectory)) else {
            continue;
        };
        let recorded: Vec<_> = schemes.flat_map(|s| trials(&s.unwrap().path())).collect();
        // The figures of recorded signals (the path figure draws a magnified deviation
        // from the desired path, a derived quantity).
        if !(name.contains("forces") || name.contains("learned_input")) {
            continue;
        }
        // A per-sample figure: some line is a recorded series, against time or (a path) a
        // pair of pose coordinates.
        let found = lines.iter().any(|line| {
            recorded.iter().any(|t| {
                t.iter().any(|(name, y)| {
                    plots(line, &t["time"], y)
                        || (name.starts_with("plant.pose")
                            && (1..=3).any(|j| plots(line, &t[&format!("plant.pose[{j}]")], y)))
                })
            })
        });
        assert!(
            found,
            "{name}: no line is a recorded series ({} lines)",
            lines.len()
        );
        series_figures.push(name);
    }
    assert!(figures >= 8, "only {figures} figures");
    assert_eq!(
        series_figures.len(),
        4,
        "forces and learned input, line and circle: {series_figures:?}"
    );
}
