//! Variable names under the two naming conventions of FMI 2.0 (§2.2.9).
//!
//! `flat` names may hold any character but carriage return, line feed and tab; `structured`
//! names follow the standard's grammar:
//!
//! ```text
//! name        = identifier | "der(" identifier ["," unsigned] ")"
//! identifier  = b-name [indices] { "." b-name [indices] }
//! b-name      = nondigit { digit | nondigit } | q-name
//! q-name      = "'" ( q-char | escape ) { q-char | escape } "'"
//! indices     = "[" unsigned { "," unsigned } "]"
//! ```
//!
//! A hand-written descent over the characters: the grammar is these five rules, and a
//! parser generator would be a dependency for less code than its grammar file.

/// Why `name` is not a valid flat name, if it is not.
pub(crate) fn flat_error(name: &str) -> Option<String> {
    let (at, c) = name
        .char_indices()
        .find(|&(_, c)| matches!(c, '\r' | '\n' | '\t'))?;
    let what = match c {
        '\r' => "a carriage return",
        '\n' => "a line feed",
        _ => "a tab",
    };
    Some(format!(
        "name holds {what} at character {}, which flat names may not",
        name[..at].chars().count() + 1
    ))
}

/// Why `name` is not a valid structured name, if it is not.
pub(crate) fn structured_error(name: &str) -> Option<String> {
    let chars: Vec<char> = name.chars().collect();
    let mut p = Descent {
        chars: &chars,
        at: 0,
    };
    let result = if name.starts_with("der(") {
        p.at = 4;
        p.identifier().and_then(|()| {
            if p.eat(',') {
                p.unsigned()?;
            }
            p.expect(')', "')' closing der(")
        })
    } else {
        p.identifier()
    };
    let result = result.and_then(|()| match p.peek() {
        None => Ok(()),
        Some(c) => Err(format!("unexpected '{c}'")),
    });
    result.err().map(|why| {
        format!(
            "name is not a structured name (FMI 2.0 §2.2.9): {why} at character {}",
            p.at + 1
        )
    })
}

struct Descent<'a> {
    chars: &'a [char],
    at: usize,
}

impl Descent<'_> {
    fn peek(&self) -> Option<char> {
        self.chars.get(self.at).copied()
    }

    fn eat(&mut self, c: char) -> bool {
        let hit = self.peek() == Some(c);
        if hit {
            self.at += 1;
        }
        hit
    }

    fn expect(&mut self, c: char, what: &str) -> Result<(), String> {
        if self.eat(c) {
            Ok(())
        } else {
            Err(match self.peek() {
                Some(found) => format!("expected {what}, found '{found}'"),
                None => format!("expected {what} at the end"),
            })
        }
    }

    fn identifier(&mut self) -> Result<(), String> {
        loop {
            self.b_name()?;
            if self.peek() == Some('[') {
                self.indices()?;
            }
            if !self.eat('.') {
                return Ok(());
            }
        }
    }

    fn b_name(&mut self) -> Result<(), String> {
        match self.peek() {
            Some('\'') => self.q_name(),
            Some(c) if c == '_' || c.is_ascii_alphabetic() => {
                while self
                    .peek()
                    .is_some_and(|c| c == '_' || c.is_ascii_alphanumeric())
                {
                    self.at += 1;
                }
                Ok(())
            }
            Some(c) => Err(format!("a name cannot start with '{c}'")),
            None => Err("a name is missing".into()),
        }
    }

    fn q_name(&mut self) -> Result<(), String> {
        self.at += 1;
        let start = self.at;
        loop {
            match self.peek() {
                Some('\'') if self.at > start => {
                    self.at += 1;
                    return Ok(());
                }
                Some('\'') => return Err("an empty quoted name".into()),
                Some('\\') => {
                    self.at += 1;
                    match self.peek() {
                        Some('\'' | '"' | '?' | '\\' | 'a' | 'b' | 'f' | 'n' | 'r' | 't' | 'v') => {
                            self.at += 1;
                        }
                        _ => return Err("an unknown escape".into()),
                    }
                }
                Some(c)
                    if c.is_ascii_alphanumeric() || "_!#$%&()*+,-./:;<>=?@[]^{}|~ ".contains(c) =>
                {
                    self.at += 1;
                }
                Some(c) => return Err(format!("'{c}' cannot stand in a quoted name")),
                None => return Err("the quoted name is not closed".into()),
            }
        }
    }

    fn indices(&mut self) -> Result<(), String> {
        self.expect('[', "'['")?;
        loop {
            self.unsigned()?;
            if !self.eat(',') {
                return self.expect(']', "']'");
            }
        }
    }

    fn unsigned(&mut self) -> Result<(), String> {
        let start = self.at;
        while self.peek().is_some_and(|c| c.is_ascii_digit()) {
            self.at += 1;
        }
        if self.at > start {
            Ok(())
        } else {
            Err("expected an unsigned integer".into())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn structured_names_follow_the_grammar() {
        for good in [
            "x",
            "_a1",
            "force[1]",
            "model.base_radius",
            "a[1,2].b[3].c",
            "der(x)",
            "der(a.b[2],2)",
            "'quoted name (m/s)'",
            "'it\\'s'.x",
            "'a.b'[1]",
        ] {
            assert_eq!(structured_error(good), None, "{good}");
        }
        for (bad, why) in [
            ("", "a name is missing at character 1"),
            ("1x", "a name cannot start with '1' at character 1"),
            ("x[1, 2]", "expected an unsigned integer at character 5"),
            ("x[]", "expected an unsigned integer at character 3"),
            ("x[1", "expected ']' at the end at character 4"),
            ("a..b", "a name cannot start with '.' at character 3"),
            ("a b", "unexpected ' ' at character 2"),
            (
                "der(x",
                "expected ')' closing der( at the end at character 6",
            ),
            ("der(x,)", "expected an unsigned integer at character 7"),
            ("''", "an empty quoted name at character 2"),
            ("'a", "the quoted name is not closed at character 3"),
            ("'a\\q'", "an unknown escape at character 4"),
            ("'a\"'", "'\"' cannot stand in a quoted name at character 3"),
            ("x-y", "unexpected '-' at character 2"),
            ("é", "a name cannot start with 'é' at character 1"),
        ] {
            let text = structured_error(bad).unwrap_or_else(|| panic!("{bad:?} passed"));
            assert!(text.ends_with(why), "{bad:?}: {text}");
        }
    }

    #[test]
    fn flat_names_refuse_three_characters() {
        assert_eq!(flat_error("any name: é, [1], spaces."), None);
        assert_eq!(
            flat_error("a\tb").as_deref(),
            Some("name holds a tab at character 2, which flat names may not")
        );
        assert!(
            flat_error("é\n")
                .unwrap()
                .contains("a line feed at character 2")
        );
        assert!(flat_error("x\r").unwrap().contains("a carriage return"));
    }
}
