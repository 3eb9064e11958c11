//! The 34 FMI 2.0 functions of a co-simulation FMU (common + CS), resolved up front; their
//! signatures come from the one table in `crate::sys`.

crate::__fmi2_functions!(import);
