//! What an error about a text file must say, for the targets that parse files: the file it
//! was given, a message, and a line (when it names one) that exists in the text.

use std::path::Path;

/// Asserts the promises of an error `shown` about `text`, read as `given`.
pub fn check(
    text: &str,
    given: &Path,
    file: &Path,
    line: Option<usize>,
    message: &str,
    shown: &str,
) {
    assert_eq!(file, given);
    assert!(!message.is_empty());
    if let Some(line) = line {
        assert!(line >= 1 && line <= text.lines().count() + 1, "{shown}");
    }
}
