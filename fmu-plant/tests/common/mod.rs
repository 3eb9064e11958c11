//! Value references of the plant's variables by name, for the tests that drive it through
//! the safe `fmu_core::Model` trait.

// Each test binary includes this module and uses a different subset of it.
#![allow(dead_code)]

use ckcm_plant::md::VARIABLES;

/// Value reference of a variable by name.
pub fn vr(name: &str) -> u32 {
    VARIABLES
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("CkcmPlant has no variable {name}"))
        .value_reference
}

/// Value references of `base[1]` .. `base[6]`.
pub fn array(base: &str) -> [u32; 6] {
    std::array::from_fn(|i| vr(&format!("{base}[{}]", i + 1)))
}
