//! Export side: the C ABI of an FMI 2.0 co-simulation FMU over a safe [`Model`].

mod model;

pub use model::{Causality, Model, ModelError, ModelResult, VarSpec, VarType, Variability};
