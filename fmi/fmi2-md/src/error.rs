//! Errors of parsing and problems of validation, each saying where.

use std::fmt;
use std::path::{Path, PathBuf};

/// A model description that could not be parsed: what is wrong and where.
///
/// Displays as `file:line: message` (or `line N: message` when the file is unknown),
/// e.g. `modelDescription.xml:42: ScalarVariable 'force[1]': invalid causality 'inptu'`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MdError {
    /// The file, when parsed with `from_file`.
    pub file: Option<PathBuf>,
    /// 1-based line of the offending markup, when known.
    pub line: Option<usize>,
    /// What is wrong (boxed to keep `Result<_, MdError>` small).
    pub kind: Box<MdErrorKind>,
}

impl MdError {
    pub(crate) fn new(line: Option<usize>, kind: MdErrorKind) -> Self {
        Self {
            file: None,
            line,
            kind: Box::new(kind),
        }
    }

    /// The same error, attributed to `path`.
    pub fn in_file(mut self, path: &Path) -> Self {
        self.file = Some(path.to_path_buf());
        self
    }
}

impl fmt::Display for MdError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (&self.file, self.line) {
            (Some(file), Some(line)) => write!(f, "{}:{line}: ", file.display())?,
            (Some(file), None) => write!(f, "{}: ", file.display())?,
            (None, Some(line)) => write!(f, "line {line}: ")?,
            (None, None) => {}
        }
        write!(f, "{}", self.kind)
    }
}

/// No `source`: the Display already includes the kind, and chains would repeat it.
impl std::error::Error for MdError {}

/// The kinds of parse failure.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MdErrorKind {
    /// The file could not be read.
    #[error("cannot read the file: {0}")]
    Io(String),
    /// Not well-formed XML.
    #[error("malformed XML: {0}")]
    Xml(String),
    /// The root element is not `fmiModelDescription`.
    #[error("root element is <{0}>, expected <fmiModelDescription>")]
    WrongRoot(String),
    /// An FMI 1.0 description.
    #[error("FMI 1.0 model descriptions are not supported (fmiVersion=\"{0}\")")]
    Fmi1(String),
    /// Any other version than 2.0 (e.g. FMI 3.0).
    #[error("unsupported fmiVersion \"{0}\": only FMI 2.0 is supported")]
    UnsupportedVersion(String),
    /// A Model Exchange only FMU.
    #[error("no <CoSimulation> element: this FMU is Model Exchange only")]
    ModelExchangeOnly,
    /// Neither `<CoSimulation>` nor `<ModelExchange>`.
    #[error("no <CoSimulation> element (and no <ModelExchange> either)")]
    NoCoSimulation,
    /// A required attribute is absent.
    #[error("{element}: missing required attribute '{attribute}'")]
    MissingAttribute {
        /// The element concerned.
        element: String,
        /// The attribute that is absent.
        attribute: String,
    },
    /// An attribute whose value cannot be read.
    #[error("{element}: invalid {attribute} '{value}'{}", expected_suffix(.expected))]
    InvalidAttribute {
        /// The element concerned.
        element: String,
        /// The attribute concerned.
        attribute: String,
        /// The text that was given.
        value: String,
        /// What a legal value looks like.
        expected: String,
    },
    /// An element with a structural problem (e.g. a ScalarVariable without a type element).
    #[error("{element}: {message}")]
    InvalidElement {
        /// The element concerned.
        element: String,
        /// What is wrong.
        message: String,
    },
}

fn expected_suffix(expected: &str) -> String {
    if expected.is_empty() {
        String::new()
    } else {
        format!(" (expected {expected})")
    }
}

/// One violation of the FMI 2.0 rules found by `validate`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Problem {
    /// 1-based source line, when known.
    pub line: Option<usize>,
    /// The element concerned, e.g. `ScalarVariable 'force[1]'` or `ModelStructure/Outputs`.
    pub element: String,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(line) = self.line {
            write!(f, "line {line}: ")?;
        }
        write!(f, "{}: {}", self.element, self.message)
    }
}

/// A string that names none of an enumeration's values.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("invalid {what} '{value}' (expected one of {expected})")]
pub struct ParseEnumError {
    /// What was parsed, e.g. `causality`.
    pub what: &'static str,
    /// The text that was given.
    pub value: String,
    /// The legal values, comma-separated.
    pub expected: &'static str,
}
