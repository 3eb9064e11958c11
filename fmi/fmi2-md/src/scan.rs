//! The streaming pass over a model description's XML: well-formedness (quick-xml's reader
//! errors carry a byte offset, serde's do not), where each element starts (for the lines in
//! the typed conversion's errors), and the FMI 2.0 schema's structure (`schema.rs`).

use std::collections::HashMap;

use quick_xml::Reader;
use quick_xml::events::Event;
use quick_xml::events::attributes::AttrError;

use super::Problem;
use super::error::{MdError, MdErrorKind};
use super::schema::{self, Content, Place};

/// Byte offsets of element starts, keyed by `parent/name`, in document order.
pub(super) struct Positions<'a> {
    xml: &'a str,
    starts: HashMap<String, Vec<usize>>,
    /// Byte offset of every `\n`, ascending, so a line lookup is a binary search: every
    /// variable records its line, and counting from the start each time made parsing
    /// quadratic in the file size.
    newlines: Vec<usize>,
}

impl<'a> Positions<'a> {
    fn new(xml: &'a str) -> Self {
        Self {
            xml,
            starts: HashMap::new(),
            newlines: xml
                .bytes()
                .enumerate()
                .filter_map(|(i, b)| (b == b'\n').then_some(i))
                .collect(),
        }
    }

    /// 1-based line of a byte offset.
    pub(super) fn line_at(&self, offset: usize) -> usize {
        let end = offset.min(self.xml.len());
        self.newlines.partition_point(|&n| n < end) + 1
    }

    /// Offset of the `i`-th element with this `parent/name` key.
    pub(super) fn offset(&self, key: &str, i: usize) -> Option<usize> {
        self.starts.get(key).and_then(|v| v.get(i)).copied()
    }

    /// Line of the `i`-th element with this key.
    pub(super) fn line(&self, key: &str, i: usize) -> Option<usize> {
        self.offset(key, i).map(|o| self.line_at(o))
    }

    /// Line of `attribute` in the start tag between these offsets, else the tag's first.
    fn attribute_line(&self, start: usize, end: usize, attribute: &str) -> usize {
        let tag = self.xml.get(start..end).unwrap_or("");
        let found = [' ', '\n', '\t', '\r']
            .iter()
            .filter_map(|c| tag.find(&format!("{c}{attribute}=")))
            .min();
        self.line_at(start + found.map_or(0, |f| f + 1))
    }

    /// Line of `attribute` at or after the `i`-th element with this key, falling back to
    /// the element's own line (attributes may sit on continuation lines or in a child).
    pub(super) fn attr_line(&self, key: &str, i: usize, attribute: &str) -> Option<usize> {
        let start = self.offset(key, i)?;
        let rest = &self.xml[start..];
        let found = [
            format!(" {attribute}="),
            format!("\n{attribute}="),
            format!("\t{attribute}="),
        ]
        .iter()
        .filter_map(|pat| rest.find(pat.as_str()))
        .min();
        Some(self.line_at(start + found.map_or(0, |f| f + 1)))
    }
}

/// At most this many schema problems are reported one by one; a generated file with
/// thousands would otherwise bury the first under the rest.
const SCHEMA_REPORTED: usize = 100;

/// What the streaming pass finds: the root's name, where elements start, and what the
/// schema does not allow (see `schema.rs`).
pub(super) struct Scan<'a> {
    pub(super) root: String,
    pub(super) positions: Positions<'a>,
    pub(super) schema_problems: Vec<Problem>,
}

/// The schema problems found so far: the first [`SCHEMA_REPORTED`], then a count.
#[derive(Default)]
struct Reports {
    listed: Vec<Problem>,
    unlisted: usize,
}

impl Reports {
    fn push(&mut self, line: usize, element: &str, message: String) {
        if self.listed.len() < SCHEMA_REPORTED {
            self.listed.push(Problem {
                line: Some(line),
                element: element.to_owned(),
                message,
            });
        } else {
            self.unlisted += 1;
        }
    }

    fn into_problems(mut self) -> Vec<Problem> {
        if self.unlisted > 0 {
            self.listed.push(Problem {
                line: None,
                element: "fmiModelDescription".into(),
                message: format!("{} more problems with the schema", self.unlisted),
            });
        }
        self.listed
    }
}

/// Text other than whitespace at `offset`, inside the innermost open element: a problem
/// where the schema allows elements only (every FMI 2.0 element but a `<Tool>`'s content),
/// reported once per element.
fn text_inside(
    stack: &mut [(String, usize, Place)],
    reports: &mut Reports,
    positions: &Positions<'_>,
    offset: usize,
) {
    if let Some((name, _, place)) = stack.last_mut() {
        if let Some(message) = place.text() {
            reports.push(positions.line_at(offset), name, message);
        }
    }
}

/// Checks well-formedness, records element positions and checks the schema (`schema.rs`).
pub(super) fn scan(xml: &str) -> Result<Scan<'_>, MdError> {
    let mut reader = Reader::from_str(xml);
    let mut positions = Positions::new(xml);
    let mut stack: Vec<(String, usize, Place)> = Vec::new();
    let mut document = Place::new(Content::Document);
    let mut root: Option<String> = None;
    let mut reports = Reports::default();
    loop {
        let before = usize::try_from(reader.buffer_position()).unwrap_or(usize::MAX);
        let event = match reader.read_event() {
            Ok(e) => e,
            Err(e) => {
                let at = usize::try_from(reader.error_position()).unwrap_or(usize::MAX);
                let line = positions.line_at(at);
                return Err(MdError::new(Some(line), MdErrorKind::Xml(e.to_string())));
            }
        };
        match event {
            Event::Start(ref s) | Event::Empty(ref s) => {
                let name = s.name().as_ref().to_owned();
                if stack.is_empty() && root.is_some() {
                    let line = positions.line_at(before);
                    return Err(MdError::new(
                        Some(line),
                        MdErrorKind::Xml(format!("second root element <{name}>")),
                    ));
                }
                let depth = stack.len();
                let (parent, place) = match stack.last_mut() {
                    Some((p, _, place)) => (p.as_str(), place),
                    None => ("", &mut document),
                };
                let content = place.admit(&name).unwrap_or_else(|message| {
                    reports.push(positions.line_at(before), parent, message);
                    Content::Refused
                });
                let defined = match content {
                    Content::Refused => None,
                    _ => schema::attributes(place.content(), &name),
                };
                let after = usize::try_from(reader.buffer_position()).unwrap_or(usize::MAX);
                for attribute in s.attributes() {
                    let attribute = match attribute {
                        Ok(a) => a,
                        // A malformed attribute makes the file malformed; the error names the
                        // line of the faulty one (serde would say only "position 25" within
                        // its tag).
                        Err(e) => {
                            let at = match e {
                                AttrError::ExpectedEq(p)
                                | AttrError::ExpectedValue(p)
                                | AttrError::UnquotedValue(p)
                                | AttrError::ExpectedQuote(p, _)
                                | AttrError::Duplicated(p, _) => p,
                            };
                            // Positions count from the tag's name, one byte after its `<`.
                            let line = positions.line_at(before.saturating_add(1 + at));
                            return Err(MdError::new(
                                Some(line),
                                MdErrorKind::Xml(format!("<{name}>: {e}")),
                            ));
                        }
                    };
                    let key = attribute.key.into_inner();
                    let undefined = defined.is_some_and(|groups| {
                        !(groups.iter().any(|g| g.contains(&key))
                            || key.starts_with("xmlns")
                            || key.starts_with("xsi:"))
                    });
                    if undefined {
                        reports.push(
                            positions.attribute_line(before, after, key),
                            &name,
                            format!(
                                "attribute '{key}' is not defined for <{name}> by the FMI 2.0 schema"
                            ),
                        );
                    }
                }
                let starts = positions
                    .starts
                    .entry(format!("{parent}/{name}"))
                    .or_default();
                starts.push(before);
                // The schema repeats the pair of implementations, so it allows a second
                // <CoSimulation>; a description holds one of each.
                if starts.len() == 2
                    && depth == 1
                    && matches!(name.as_str(), "CoSimulation" | "ModelExchange")
                {
                    reports.push(
                        positions.line_at(before),
                        parent,
                        format!("a second <{name}>; there may be only one"),
                    );
                }
                root.get_or_insert_with(|| name.clone());
                let place = Place::new(content);
                if matches!(event, Event::Start(_)) {
                    stack.push((name, before, place));
                } else if let Some(message) = place.missing_at_end() {
                    reports.push(positions.line_at(before), &name, message);
                }
            }
            Event::End(_) => {
                if let Some((name, at, place)) = stack.pop() {
                    if let Some(message) = place.missing_at_end() {
                        reports.push(positions.line_at(at), &name, message);
                    }
                }
            }
            Event::Text(ref t) if !t.trim().is_empty() => {
                let skipped = t.len() - t.trim_start().len();
                text_inside(&mut stack, &mut reports, &positions, before + skipped);
            }
            Event::CData(_) | Event::GeneralRef(_) => {
                text_inside(&mut stack, &mut reports, &positions, before);
            }
            Event::Eof => break,
            _ => {}
        }
    }
    if let Some((name, at, _)) = stack.last() {
        return Err(MdError::new(
            Some(positions.line_at(*at)),
            MdErrorKind::Xml(format!("<{name}> is not closed before the end of the file")),
        ));
    }
    match root {
        Some(root) => Ok(Scan {
            root,
            positions,
            schema_problems: reports.into_problems(),
        }),
        None => Err(MdError::new(
            None,
            MdErrorKind::Xml("no root element".into()),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::Positions;

    /// A newline ends its own line; an offset past the end is on the last line.
    #[test]
    fn a_newline_belongs_to_the_line_it_ends() {
        let p = Positions::new("a\nb\n");
        let lines: Vec<usize> = (0..6).map(|o| p.line_at(o)).collect();
        assert_eq!(lines, [1, 1, 2, 2, 3, 3]);
    }
}
