//! `report.md` and `report.html`. The prose is the template `report.md` beside this file;
//! this module only fills in its `{{key}}` values, all computed from the study's CSVs by
//! [`claims`](super::claims), and renders the HTML page with every figure inline.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use ckcm::TrajectoryKind;
use pulldown_cmark::{CowStr, Event, Options, Parser, Tag, TagEnd, html};

use super::cases::{Scheme, TRAJECTORIES, traj_slug};
use super::claims::{Tables, grade, mm};
use super::{PaperError, PaperOptions};
use crate::output::write_atomic;

/// The report's prose, with `{{key}}` placeholders.
pub const TEMPLATE: &str = include_str!("report.md");

/// Writes `report.md` and `report.html` from the CSVs in the study directory.
pub fn write_report(opts: &PaperOptions) -> Result<(), PaperError> {
    let tables = Tables::load(&opts.out_dir)?;
    let mut values = values(opts, &tables)?;
    values.extend(super::robust::values(&super::robust::load(&opts.out_dir)?));
    let md = fill(TEMPLATE, &values)?;
    write_atomic(&opts.out_dir.join("report.md"), |w| {
        w.write_all(md.as_bytes())
    })?;
    let page = html_page(&md, &opts.out_dir)?;
    write_atomic(&opts.out_dir.join("report.html"), |w| {
        w.write_all(page.as_bytes())
    })?;
    Ok(())
}

/// Every template value: study settings, the per-trial tables and the graded claims.
pub fn values(opts: &PaperOptions, t: &Tables) -> Result<BTreeMap<String, String>, PaperError> {
    let g = ckcm::Gains::default();
    let mut v = grade(t)?.values;
    let mut set = |k: &str, x: String| {
        v.insert(k.to_owned(), x);
    };
    set("trials", t.trials.to_string());
    set("line_duration", opts.line_duration.to_string());
    set("circle_duration", opts.circle_duration.to_string());
    set("kp", g.kp.to_string());
    set("kd", g.kd.to_string());
    set("ki", g.ki.to_string());
    set("phi", g.phi.to_string());
    set("gamma", g.gamma.to_string());
    set("psi", g.psi.to_string());
    let longest = opts.line_duration.max(opts.circle_duration);
    set("longest", longest.to_string());
    set("psi_share", format!("{:.1e}", g.psi * longest / g.phi));
    for kind in TRAJECTORIES {
        let s = traj_slug(kind);
        set(&format!("{s}.table"), table(t, kind)?);
        let last = t.trials - 1;
        for (key, k) in [("first", 2), ("last", last)] {
            let m = t.metrics(kind, Scheme::Hlcs, k)?;
            set(
                &format!("spec.{s}.{key}"),
                format!(
                    "{:.1} Hz in trial {k} ({:.0} % of it above 5 Hz)",
                    m.median_hz,
                    100.0 * m.above_high
                ),
            );
        }
    }
    Ok(v)
}

fn table(t: &Tables, kind: TrajectoryKind) -> Result<String, PaperError> {
    let mut s = String::from(
        "| trial | PID max | PD-ILC max | HLCS max | PD-ILC λ₁ | HLCS λ₁ | HLCS λ₅ | PID path | HLCS path | HLCS median frequency | HLCS share > 5 Hz |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for k in 0..t.trials {
        let c = |sch| t.conv(kind, sch, k);
        let (p, d, h) = (c(Scheme::Pid)?, c(Scheme::PdIlc)?, c(Scheme::Hlcs)?);
        let hm = t.metrics(kind, Scheme::Hlcs, k)?;
        // Writing into a String cannot fail.
        let _ = writeln!(
            s,
            "| {k} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1} Hz | {:.0} % |",
            mm(p.max),
            mm(d.max),
            mm(h.max),
            mm(d.lambda),
            mm(h.lambda),
            mm(hm.lambda[1]),
            mm(p.path_max),
            mm(h.path_max),
            hm.median_hz,
            100.0 * hm.above_high,
        );
    }
    Ok(s)
}

/// Replaces every `{{key}}` of `template`; a key without a value is an error naming it.
pub fn fill(template: &str, values: &BTreeMap<String, String>) -> Result<String, PaperError> {
    let mut out = String::with_capacity(template.len() * 2);
    let mut rest = template;
    while let Some(i) = rest.find("{{") {
        out.push_str(&rest[..i]);
        let after = &rest[i + 2..];
        let j = after.find("}}").ok_or_else(|| {
            PaperError::Invalid("report template: unclosed {{ placeholder".into())
        })?;
        let key = &after[..j];
        let value = values.get(key).ok_or_else(|| {
            PaperError::Invalid(format!("report template: no value for {{{{{key}}}}}"))
        })?;
        out.push_str(value);
        rest = &after[j + 2..];
    }
    out.push_str(rest);
    Ok(out)
}

/// One self-contained HTML page: the Markdown rendered, each image replaced by the SVG it
/// points to, inline, so the page needs no other file and no network.
pub fn html_page(md: &str, dir: &Path) -> Result<String, PaperError> {
    let mut events = Vec::new();
    let mut in_image = false;
    for ev in Parser::new_ext(md, Options::ENABLE_TABLES) {
        match ev {
            Event::Start(Tag::Image { dest_url, .. }) => {
                in_image = true;
                events.push(Event::Html(CowStr::from(inline_svg(dir, &dest_url)?)));
            }
            Event::End(TagEnd::Image) => in_image = false,
            _ if in_image => {}
            other => events.push(other),
        }
    }
    let mut body = String::new();
    html::push_html(&mut body, events.into_iter());
    let title = md
        .lines()
        .next()
        .unwrap_or("Paper study")
        .trim_start_matches('#')
        .trim();
    Ok(format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"/>\n\
         <title>{}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>\n{body}</body>\n</html>\n",
        escape(title)
    ))
}

const STYLE: &str = "body { font-family: sans-serif; max-width: 1150px; margin: 2em auto; padding: 0 1em; line-height: 1.45; }
table { border-collapse: collapse; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; }
blockquote { color: #444; border-left: 4px solid #ccc; margin-left: 0; padding-left: 1em; }
figure, svg { display: block; max-width: 100%; height: auto; margin: 1em 0; }
";

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The SVG file `src` (relative to `dir`) without its XML declaration, scaled to the page
/// width by a viewBox.
fn inline_svg(dir: &Path, src: &str) -> Result<String, PaperError> {
    if src.contains("://") || src.starts_with('/') {
        return Err(PaperError::Invalid(format!(
            "report template: figure {src} must be a relative path"
        )));
    }
    let path = dir.join(src);
    let svg = std::fs::read_to_string(&path)
        .map_err(|e| PaperError::Invalid(format!("cannot read {}: {e}", path.display())))?;
    let start = svg
        .find("<svg")
        .ok_or_else(|| PaperError::Invalid(format!("{} is not an SVG", path.display())))?;
    let svg = &svg[start..];
    // plotters writes `<svg width="W" height="H" viewBox="0 0 W H" ...>`; the viewBox lets the
    // browser scale it down to the column.
    Ok(format!("<figure>{}</figure>\n", svg.trim_end()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_replaces_keys_and_names_a_missing_one() {
        let v: BTreeMap<String, String> = [
            ("a".to_string(), "1".to_string()),
            ("b.c".into(), "x".into()),
        ]
        .into();
        assert_eq!(fill("{{a}} and {{b.c}}.", &v).unwrap(), "1 and x.");
        let e = fill("{{a}} {{nope}}", &v).unwrap_err().to_string();
        assert!(e.contains("{{nope}}"), "{e}");
        assert!(fill("{{a", &v).is_err());
    }

    /// The paper's figures keep their numbers and panels a–d; the extra ones are E1–E8. The
    /// claim quotes the paper as printed and says which norm is measured; the robust section
    /// says which case changes the controller and which table its numbers come from.
    #[test]
    fn the_template_keeps_the_papers_figures_and_words_apart_from_ours() {
        for fig in ['6', '7'] {
            for panel in 'a'..='h' {
                let name = format!("Fig. {fig}{panel}");
                assert_eq!(TEMPLATE.contains(&name), panel <= 'd', "{name}");
            }
        }
        for e in 1..=8 {
            assert!(TEMPLATE.contains(&format!("![Fig. E{e}](")), "Fig. E{e}");
        }
        assert!(TEMPLATE.contains("represented by the q -norm [sic; "));
        assert!(TEMPLATE.contains("not the norm of the paper's eqs. (20)–(21)"));
        assert!(TEMPLATE.contains("sets the controller's learning gains Φ, Γ and Ψ"));
        assert!(!TEMPLATE.contains("which keeps its nominal model and gains"));
        assert!(TEMPLATE.contains("\"Beyond the paper\" comes from `robust.csv`"));
        assert!(!TEMPLATE.contains("Per trial, mm"));
        assert!(!TEMPLATE.contains("keeps converging"));
    }

    #[test]
    fn the_template_names_every_figure_and_claim() {
        for f in super::super::figures::figure_files() {
            assert!(TEMPLATE.contains(&format!("(figures/{f})")), "{f}");
        }
        for c in 1..=4 {
            assert!(
                TEMPLATE.contains(&format!("{{{{c{c}.verdict}}}}")),
                "claim {c}"
            );
        }
    }
}
