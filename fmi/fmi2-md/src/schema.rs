//! Which elements the FMI 2.0 schema (`fmiModelDescription.xsd` and the files it includes)
//! allows inside which, in which order and how often, which attributes each may carry, and
//! that none holds text (a `<Tool>`'s content aside).
//!
//! The typed parse reads the elements and attributes it knows in any order and skips the
//! rest, so without this check what the schema forbids (`<Foo>` among the
//! `<ScalarVariable>`s, a `<LogCategories>` after `<DefaultExperiment>`, a `causality` on a
//! `<Real>`) passed unnoticed although FMPy's schema validation refuses such a file. The
//! attributes' values are the typed parse's and `validate`'s.
//! A table rather than an XSD validator: the schema's content models are these few rows,
//! and the crates that validate against an XSD bind libxml2, a C library the FMU build and
//! the Windows cross-build would then need.

/// The content model of an element, named by the element that holds it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Content {
    /// Before the root element: the root's name is checked by the parse itself.
    Document,
    Root,
    Implementation,
    SourceFiles,
    UnitDefinitions,
    Unit,
    TypeDefinitions,
    SimpleType,
    TypeEnumeration,
    LogCategories,
    Annotations,
    /// A `<Tool>`: at most one element of any name (`xs:any`), whose content is free.
    Tool,
    ModelVariables,
    ScalarVariable,
    ModelStructure,
    Unknowns,
    /// An element with attributes only.
    Empty,
    /// Inside a `<Tool>`'s element: anything.
    Free,
    /// Inside an element already reported: its content is not reported again.
    Refused,
}

/// One place in a content model: elements that may stand there (more than one for a
/// choice), each with its own content, and how often the place may be filled.
pub(crate) struct Slot {
    names: &'static [(&'static str, Content)],
    required: bool,
    repeats: bool,
}

/// A [`Slot`] literal, which (unlike a `const fn`'s result) the compiler promotes to a
/// static, so the content models below are tables without allocation.
macro_rules! slot {
    ($names:expr, $required:expr, $repeats:expr $(,)?) => {
        Slot {
            names: $names,
            required: $required,
            repeats: $repeats,
        }
    };
}

/// The content models, each a sequence of slots.
fn model(content: Content) -> &'static [Slot] {
    use Content::*;
    const TYPES_OF_VARIABLE: &[(&str, Content)] = &[
        ("Real", Empty),
        ("Integer", Empty),
        ("Boolean", Empty),
        ("String", Empty),
        ("Enumeration", Empty),
    ];
    match content {
        // `<ModelExchange>` and `<CoSimulation>` in either order (the schema repeats their
        // sequence twice); a second one of either is the typed parse's error.
        Root => &[
            slot!(
                &[
                    ("ModelExchange", Implementation),
                    ("CoSimulation", Implementation)
                ],
                false,
                true,
            ),
            slot!(&[("UnitDefinitions", UnitDefinitions)], false, false),
            slot!(&[("TypeDefinitions", TypeDefinitions)], false, false),
            slot!(&[("LogCategories", LogCategories)], false, false),
            slot!(&[("DefaultExperiment", Empty)], false, false),
            slot!(&[("VendorAnnotations", Annotations)], false, false),
            slot!(&[("ModelVariables", ModelVariables)], true, false),
            slot!(&[("ModelStructure", ModelStructure)], true, false),
        ],
        Implementation => &[slot!(&[("SourceFiles", SourceFiles)], false, false)],
        SourceFiles => &[slot!(&[("File", Empty)], true, true)],
        UnitDefinitions => &[slot!(&[("Unit", Unit)], true, true)],
        Unit => &[
            slot!(&[("BaseUnit", Empty)], false, false),
            slot!(&[("DisplayUnit", Empty)], false, true),
        ],
        TypeDefinitions => &[slot!(&[("SimpleType", SimpleType)], true, true)],
        SimpleType => &[slot!(
            &[
                ("Real", Empty),
                ("Integer", Empty),
                ("Boolean", Empty),
                ("String", Empty),
                ("Enumeration", TypeEnumeration),
            ],
            true,
            false,
        )],
        TypeEnumeration => &[slot!(&[("Item", Empty)], true, true)],
        LogCategories => &[slot!(&[("Category", Empty)], true, true)],
        Annotations => &[slot!(&[("Tool", Tool)], true, true)],
        ModelVariables => &[slot!(&[("ScalarVariable", ScalarVariable)], true, true)],
        ScalarVariable => &[
            slot!(TYPES_OF_VARIABLE, true, false),
            slot!(&[("Annotations", Annotations)], false, false),
        ],
        ModelStructure => &[
            slot!(&[("Outputs", Unknowns)], false, false),
            slot!(&[("Derivatives", Unknowns)], false, false),
            slot!(&[("InitialUnknowns", Unknowns)], false, false),
        ],
        Unknowns => &[slot!(&[("Unknown", Empty)], true, true)],
        Document | Tool | Empty | Free | Refused => &[],
    }
}

/// The attributes the schema defines for `child` standing in an element of content
/// `parent`, in groups as the schema shares them (`fmi2RealAttributes` and the like);
/// `None` where the schema leaves them free (a `<Tool>`'s content) or the element was
/// refused. Namespace declarations and `xsi:` attributes are every element's.
pub(crate) fn attributes(
    parent: Content,
    child: &str,
) -> Option<&'static [&'static [&'static str]]> {
    use Content::*;
    const REAL: &[&str] = &[
        "quantity",
        "unit",
        "displayUnit",
        "relativeQuantity",
        "min",
        "max",
        "nominal",
        "unbounded",
    ];
    const INTEGER: &[&str] = &["quantity", "min", "max"];
    /// Both implementations' flags.
    const IMPLEMENTATION: &[&str] = &[
        "modelIdentifier",
        "needsExecutionTool",
        "canBeInstantiatedOnlyOncePerProcess",
        "canNotUseMemoryManagementFunctions",
        "canGetAndSetFMUstate",
        "canSerializeFMUstate",
        "providesDirectionalDerivative",
    ];
    Some(match (parent, child) {
        (Document, _) => &[&[
            "fmiVersion",
            "modelName",
            "guid",
            "description",
            "author",
            "version",
            "copyright",
            "license",
            "generationTool",
            "generationDateAndTime",
            "variableNamingConvention",
            "numberOfEventIndicators",
        ]],
        (Root, "ModelExchange") => &[IMPLEMENTATION, &["completedIntegratorStepNotNeeded"]],
        (Root, "CoSimulation") => &[
            IMPLEMENTATION,
            &[
                "canHandleVariableCommunicationStepSize",
                "canInterpolateInputs",
                "maxOutputDerivativeOrder",
                "canRunAsynchronuously",
            ],
        ],
        (Root, "DefaultExperiment") => &[&["startTime", "stopTime", "tolerance", "stepSize"]],
        (SourceFiles, "File") | (UnitDefinitions, "Unit") | (Annotations, "Tool") => &[&["name"]],
        (Unit, "BaseUnit") => &[&[
            "kg", "m", "s", "A", "K", "mol", "cd", "rad", "factor", "offset",
        ]],
        (Unit, "DisplayUnit") => &[&["name", "factor", "offset"]],
        (TypeDefinitions, "SimpleType") => &[&["name", "description"]],
        (SimpleType, "Real") => &[REAL],
        (SimpleType, "Integer") => &[INTEGER],
        (SimpleType, "Enumeration") => &[&["quantity"]],
        (TypeEnumeration, "Item") => &[&["name", "value", "description"]],
        (LogCategories, "Category") => &[&["name", "description"]],
        (ModelVariables, "ScalarVariable") => &[&[
            "name",
            "valueReference",
            "description",
            "causality",
            "variability",
            "initial",
            "canHandleMultipleSetPerTimeInstant",
        ]],
        (ScalarVariable, "Real") => &[&["declaredType", "start", "derivative", "reinit"], REAL],
        (ScalarVariable, "Integer" | "Enumeration") => &[&["declaredType", "start"], INTEGER],
        (ScalarVariable, "Boolean" | "String") => &[&["declaredType", "start"]],
        (Unknowns, "Unknown") => &[&["index", "dependencies", "dependenciesKind"]],
        (Tool | Free | Refused, _) => return None,
        // Elements that hold elements only, and the root's children of no attributes.
        _ => &[],
    })
}

/// "<a>, <b> or <c>".
fn names(slot: &Slot) -> String {
    let all: Vec<String> = slot.names.iter().map(|(n, _)| format!("<{n}>")).collect();
    match all.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => all.concat(),
    }
}

/// Where an element stands in its parent's content model, child by child.
pub(crate) struct Place {
    content: Content,
    /// The slot the last child filled, and how many children filled it.
    slot: usize,
    filled: usize,
    /// Whether a `<Tool>`'s one element has been seen.
    any_seen: bool,
    /// Whether a child broke the content model. The rest of this element's children are
    /// then not checked against it, as FMPy's schema validation (libxml2) reports one such
    /// error per element: a misplaced element would otherwise put every later sibling out
    /// of order too.
    failed: bool,
    /// Whether text inside this element has been reported.
    text_seen: bool,
}

impl Place {
    pub fn new(content: Content) -> Self {
        Self {
            content,
            slot: 0,
            filled: 0,
            any_seen: false,
            failed: false,
            text_seen: false,
        }
    }

    /// The content model this place follows.
    pub fn content(&self) -> Content {
        self.content
    }

    /// Admits `child` here: its content, or why the schema does not allow it here (it is
    /// then `Refused`, and the place stays as it was).
    pub fn admit(&mut self, child: &str) -> Result<Content, String> {
        let admitted = self.check(child);
        if self.failed {
            return Ok(admitted.unwrap_or(Content::Refused));
        }
        self.failed = admitted.is_err();
        admitted
    }

    fn check(&mut self, child: &str) -> Result<Content, String> {
        match self.content {
            Content::Document => return Ok(Content::Root),
            Content::Free => return Ok(Content::Free),
            Content::Refused => return Ok(Content::Refused),
            Content::Tool => {
                if self.any_seen {
                    return Err(format!(
                        "<{child}> is not allowed here: a <Tool> holds at most one element"
                    ));
                }
                self.any_seen = true;
                return Ok(Content::Free);
            }
            _ => {}
        }
        let slots = model(self.content);
        let found = slots.iter().enumerate().find_map(|(i, s)| {
            s.names
                .iter()
                .find(|(n, _)| *n == child)
                .map(|&(_, c)| (i, c))
        });
        let Some((at, content)) = found else {
            return Err(if slots.is_empty() {
                format!("<{child}> is not allowed here: this element holds no elements")
            } else {
                let allowed: Vec<String> = slots.iter().map(names).collect();
                format!(
                    "<{child}> is not allowed here (the FMI 2.0 schema allows {})",
                    allowed.join(", ")
                )
            });
        };
        if self.failed {
            // Known, so its own content is still checked; its place here no longer is.
            return Ok(content);
        }
        if at < self.slot {
            return Err(format!(
                "<{child}> is out of order: it must come before {}",
                names(&slots[self.slot])
            ));
        }
        if at == self.slot && self.filled > 0 && !slots[at].repeats {
            return Err(if slots[at].names.len() > 1 {
                format!(
                    "<{child}> is one too many: only one of {} may stand here",
                    names(&slots[at])
                )
            } else {
                format!("<{child}> is one too many: only one may stand here")
            });
        }
        if let Some(missing) = self.first_missing(at) {
            return Err(format!(
                "<{child}> is not allowed here: {} must come first",
                names(missing)
            ));
        }
        if at != self.slot {
            self.slot = at;
            self.filled = 0;
        }
        self.filled += 1;
        Ok(content)
    }

    /// Text (other than whitespace) inside this element: why the schema does not allow it,
    /// the first time only.
    pub fn text(&mut self) -> Option<String> {
        match self.content {
            Content::Document | Content::Free | Content::Refused => None,
            _ if self.text_seen => None,
            _ => {
                self.text_seen = true;
                Some(
                    "text is not allowed here: this element holds elements and attributes only"
                        .into(),
                )
            }
        }
    }

    /// At the element's end: a required slot left empty, if any.
    pub fn missing_at_end(&self) -> Option<String> {
        if self.failed {
            return None;
        }
        let slots = model(self.content);
        self.first_missing(slots.len())
            .map(|s| format!("misses {}", names(s)))
    }

    /// The first required slot before `upto` that no child filled.
    fn first_missing(&self, upto: usize) -> Option<&'static Slot> {
        let slots = model(self.content);
        (self.slot..upto.min(slots.len()))
            .find(|&i| slots[i].required && !(i == self.slot && self.filled > 0))
            .map(|i| &slots[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn admit_all(content: Content, children: &[&str]) -> Vec<Result<Content, String>> {
        let mut place = Place::new(content);
        children.iter().map(|c| place.admit(c)).collect()
    }

    #[test]
    fn nesting_order_and_counts_follow_the_schema_content_models() {
        use Content::*;
        assert_eq!(
            admit_all(
                Root,
                &[
                    "CoSimulation",
                    "ModelExchange",
                    "ModelVariables",
                    "ModelStructure"
                ]
            ),
            [
                Ok(Implementation),
                Ok(Implementation),
                Ok(ModelVariables),
                Ok(ModelStructure)
            ]
        );
        let r = admit_all(ModelVariables, &["ScalarVariable", "Foo"]);
        assert_eq!(r[0], Ok(ScalarVariable));
        assert!(
            r[1].as_ref()
                .unwrap_err()
                .contains("allows <ScalarVariable>"),
            "{r:?}"
        );
        assert!(
            admit_all(Empty, &["Real"])[0]
                .as_ref()
                .unwrap_err()
                .contains("holds no elements")
        );
        // A type's Enumeration lists items; a variable's holds attributes only.
        assert_eq!(
            admit_all(SimpleType, &["Enumeration"]),
            [Ok(TypeEnumeration)]
        );
        assert_eq!(admit_all(ScalarVariable, &["Enumeration"]), [Ok(Empty)]);
        let r = admit_all(Root, &["DefaultExperiment", "LogCategories"]);
        assert!(
            r[1].as_ref()
                .unwrap_err()
                .contains("must come before <DefaultExperiment>"),
            "{r:?}"
        );
        // A slot of several names names them; a slot of one needs no list.
        let r = admit_all(ScalarVariable, &["Real", "Integer"]);
        assert!(
            r[1].as_ref().unwrap_err().contains(
                "<Integer> is one too many: only one of <Real>, <Integer>, <Boolean>, <String> \
                 or <Enumeration> may stand here"
            ),
            "{r:?}"
        );
        let r = admit_all(Root, &["DefaultExperiment", "DefaultExperiment"]);
        assert_eq!(
            r[1],
            Err("<DefaultExperiment> is one too many: only one may stand here".into()),
        );
        let r = admit_all(ScalarVariable, &["Annotations"]);
        assert!(
            r[0].as_ref().unwrap_err().contains(
                "<Real>, <Integer>, <Boolean>, <String> or <Enumeration> must come first"
            ),
            "{r:?}"
        );
        let r = admit_all(Root, &["ModelStructure"]);
        assert!(
            r[0].as_ref()
                .unwrap_err()
                .contains("<ModelVariables> must come first"),
            "{r:?}"
        );
        assert_eq!(admit_all(Tool, &["Any"]), [Ok(Free)]);
        assert!(admit_all(Tool, &["Any", "Other"])[1].is_err());
        assert_eq!(admit_all(Free, &["A", "B"]), [Ok(Free), Ok(Free)]);
        assert_eq!(admit_all(Refused, &["Inner"]), [Ok(Refused)]);
    }

    #[test]
    fn attributes_by_element_and_place() {
        use Content::*;
        let of = |parent, child| attributes(parent, child).map(|groups| groups.concat());
        assert_eq!(
            of(ScalarVariable, "Boolean"),
            Some(vec!["declaredType", "start"])
        );
        // A type's <Real> has no start; a variable's has.
        assert!(!of(SimpleType, "Real").unwrap().contains(&"start"));
        assert!(of(ScalarVariable, "Real").unwrap().contains(&"start"));
        assert!(of(ScalarVariable, "Real").unwrap().contains(&"nominal"));
        assert!(
            of(Root, "CoSimulation")
                .unwrap()
                .contains(&"canRunAsynchronuously")
        );
        assert!(
            !of(Root, "ModelExchange")
                .unwrap()
                .contains(&"canRunAsynchronuously")
        );
        assert!(
            of(Root, "ModelExchange")
                .unwrap()
                .contains(&"modelIdentifier")
        );
        assert_eq!(of(Root, "ModelVariables"), Some(vec![]));
        assert_eq!(of(Tool, "Anything"), None);
        assert_eq!(of(Free, "Deeper"), None);
    }

    #[test]
    fn required_content_is_missed_at_the_end() {
        let mut place = Place::new(Content::Unit);
        assert_eq!(place.missing_at_end(), None);
        place = Place::new(Content::UnitDefinitions);
        assert_eq!(place.missing_at_end().as_deref(), Some("misses <Unit>"));
        place.admit("Unit").unwrap();
        assert_eq!(place.missing_at_end(), None);
        place = Place::new(Content::Root);
        place.admit("ModelVariables").unwrap();
        assert_eq!(
            place.missing_at_end().as_deref(),
            Some("misses <ModelStructure>")
        );
    }
}
