//! Which elements the FMI 2.0 schema (`fmiModelDescription.xsd` and the files it includes)
//! allows inside which.
//!
//! The typed parse reads the elements it knows and skips the rest, so without this table
//! an element the schema forbids (`<Foo>` between two `<ScalarVariable>`s, a second level of
//! `<Real>`) passed unnoticed although FMPy's schema validation refuses such a file. Only
//! nesting is checked here: order and counts are the typed parse's and `validate`'s.
//! A table rather than an XSD validator: the schema's nesting is these few rows, and the
//! crates that validate against an XSD bind libxml2, a C library the FMU build and the
//! Windows cross-build would then need.

/// The kind of content an element may hold, named by the element that holds it.
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
    ModelVariables,
    ScalarVariable,
    ModelStructure,
    Unknowns,
    /// An element with attributes only.
    Empty,
    /// A `<Tool>`'s content, which the schema leaves free (`xs:any`).
    Free,
    /// Inside an element already reported: its content is not reported again.
    Refused,
}

/// (parent's content, child element, child's content): every nesting the schema allows.
const ALLOWED: &[(Content, &str, Content)] = {
    use Content::*;
    &[
        (Root, "ModelExchange", Implementation),
        (Root, "CoSimulation", Implementation),
        (Root, "UnitDefinitions", UnitDefinitions),
        (Root, "TypeDefinitions", TypeDefinitions),
        (Root, "LogCategories", LogCategories),
        (Root, "DefaultExperiment", Empty),
        (Root, "VendorAnnotations", Annotations),
        (Root, "ModelVariables", ModelVariables),
        (Root, "ModelStructure", ModelStructure),
        (Implementation, "SourceFiles", SourceFiles),
        (SourceFiles, "File", Empty),
        (UnitDefinitions, "Unit", Unit),
        (Unit, "BaseUnit", Empty),
        (Unit, "DisplayUnit", Empty),
        (TypeDefinitions, "SimpleType", SimpleType),
        (SimpleType, "Real", Empty),
        (SimpleType, "Integer", Empty),
        (SimpleType, "Boolean", Empty),
        (SimpleType, "String", Empty),
        (SimpleType, "Enumeration", TypeEnumeration),
        (TypeEnumeration, "Item", Empty),
        (LogCategories, "Category", Empty),
        (Annotations, "Tool", Free),
        (ModelVariables, "ScalarVariable", ScalarVariable),
        (ScalarVariable, "Real", Empty),
        (ScalarVariable, "Integer", Empty),
        (ScalarVariable, "Boolean", Empty),
        (ScalarVariable, "String", Empty),
        (ScalarVariable, "Enumeration", Empty),
        (ScalarVariable, "Annotations", Annotations),
        (ModelStructure, "Outputs", Unknowns),
        (ModelStructure, "Derivatives", Unknowns),
        (ModelStructure, "InitialUnknowns", Unknowns),
        (Unknowns, "Unknown", Empty),
    ]
};

/// The content of `child` inside an element holding `parent`, or `Err` with the elements
/// the schema allows there (empty when it allows none).
pub(crate) fn child(parent: Content, child: &str) -> Result<Content, Vec<&'static str>> {
    match parent {
        Content::Document => return Ok(Content::Root),
        Content::Free => return Ok(Content::Free),
        Content::Refused => return Ok(Content::Refused),
        _ => {}
    }
    ALLOWED
        .iter()
        .find(|(p, name, _)| *p == parent && *name == child)
        .map(|&(_, _, content)| content)
        .ok_or_else(|| {
            ALLOWED
                .iter()
                .filter(|(p, _, _)| *p == parent)
                .map(|&(_, name, _)| name)
                .collect()
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nesting_follows_the_schema() {
        assert_eq!(
            child(Content::Root, "ModelVariables"),
            Ok(Content::ModelVariables)
        );
        assert_eq!(
            child(Content::ModelVariables, "Foo"),
            Err(vec!["ScalarVariable"])
        );
        assert_eq!(child(Content::Empty, "Real"), Err(vec![]));
        // A type's Enumeration lists items; a variable's holds attributes only.
        assert_eq!(
            child(Content::SimpleType, "Enumeration"),
            Ok(Content::TypeEnumeration)
        );
        assert_eq!(
            child(Content::ScalarVariable, "Enumeration"),
            Ok(Content::Empty)
        );
        assert_eq!(child(Content::Free, "Anything"), Ok(Content::Free));
        assert_eq!(child(Content::Refused, "Inner"), Ok(Content::Refused));
    }
}
