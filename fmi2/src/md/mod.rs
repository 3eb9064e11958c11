//! modelDescription.xml: typed structs, parsing and validation.
