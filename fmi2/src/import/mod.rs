//! Import side: open a .fmu, load its binary, call it through one choke point.
