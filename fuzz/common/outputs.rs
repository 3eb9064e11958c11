//! The check both model targets make after every successful call.
use fmi2_md::{Causality, VarType};
use fmu_core::Model;

/// Panics, naming the variable and `when`, if a Real output of `m` is not finite.
pub fn outputs_finite<M: Model>(m: &M, when: &str) {
    for spec in M::VARIABLES {
        if spec.var_type == VarType::Real && spec.causality == Causality::Output {
            let x = m.get_real(spec.value_reference);
            assert!(x.is_finite(), "{} = {x} {when}", spec.name);
        }
    }
}
