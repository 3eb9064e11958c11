//! The co-simulation master for the CKCM FMUs (and any FMI 2.0 co-simulation FMU):
//! scenario files, the Gauss–Seidel master loop with iteration memory, campaigns with
//! atomic persistence and resume, outputs and plots, and the paper study.
#![deny(unsafe_code)]

pub mod campaign;
pub mod master;
pub mod output;
pub mod paper;
pub mod scenario;
pub mod simulate;
pub mod sweep;
pub mod variables;
