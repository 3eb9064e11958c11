//! Storage of an FMU's variable values, indexed directly by value reference.
//!
//! Our value references are small dense integers, so a flat array per base type gives
//! O(1) get/set with no hashing and lets a model be `Clone` for FMU-state snapshots.
//! The arrays are allocated once per instance; nothing here allocates per step.

use crate::{ModelError, ModelResult, VarSpec, VarType, VrRun};

/// Values of every Real, Integer/Enumeration and Boolean variable, by value reference.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Values {
    reals: Vec<f64>,
    integers: Vec<i32>,
    booleans: Vec<bool>,
}

impl Values {
    /// Values at the start values of a generated `START` table.
    pub fn from_start(start: &[(u32, VarType, f64)]) -> Self {
        let size = start
            .iter()
            .map(|&(vr, _, _)| vr as usize + 1)
            .max()
            .unwrap_or(0);
        let mut v = Self {
            reals: vec![0.0; size],
            integers: vec![0; size],
            booleans: vec![false; size],
        };
        for &(vr, ty, value) in start {
            v.ensure(vr);
            let i = vr as usize;
            match ty {
                VarType::Real => v.reals[i] = value,
                VarType::Integer | VarType::Enumeration => v.integers[i] = value as i32,
                VarType::Boolean => v.booleans[i] = value != 0.0,
                VarType::String => {}
            }
        }
        v
    }

    /// Values at the start values, with room for every declared variable (outputs have no
    /// start value). What an FMU's `Model::new` needs.
    pub fn for_variables(start: &[(u32, VarType, f64)], variables: &[VarSpec]) -> Self {
        let mut v = Self::from_start(start);
        for var in variables {
            v.ensure(var.value_reference);
        }
        v
    }

    /// Stores a Real, refusing NaN and infinities with an error naming the variable: no
    /// model here has a use for them, and they would poison every later step.
    #[inline]
    pub fn set_finite_real(
        &mut self,
        variables: &[VarSpec],
        vr: u32,
        value: f64,
    ) -> ModelResult<()> {
        if !value.is_finite() {
            return Err(not_finite(variables, vr, value));
        }
        self.set_real(vr, value);
        Ok(())
    }

    /// Stores several Reals, or none when one of them is not finite (the first such one is
    /// named, as by [`Values::set_finite_real`]). `runs` is `vrs` cut by [`VrRun::split`].
    #[inline]
    pub fn set_finite_reals(
        &mut self,
        variables: &[VarSpec],
        vrs: &[u32],
        runs: &[VrRun],
        values: &[f64],
    ) -> ModelResult<()> {
        // One branch-free scan for the common case; the culprit is looked up only on failure.
        if !all_finite(values) {
            if let Some((&vr, &value)) = vrs.iter().zip(values).find(|(_, v)| !v.is_finite()) {
                return Err(not_finite(variables, vr, value));
            }
        }
        for r in runs {
            let start = r.first as usize;
            match (
                self.reals.get_mut(start..start + r.len),
                values.get(r.at..r.at + r.len),
            ) {
                (Some(slots), Some(src)) => copy_run(slots, src),
                _ => self.set_reals_one_by_one(vrs, values, r),
            }
        }
        Ok(())
    }

    /// Reads the Reals of `vrs` into `out`, as [`Values::real`] one by one would; `runs` is
    /// `vrs` cut by [`VrRun::split`].
    #[inline]
    pub fn reals_into(&self, vrs: &[u32], runs: &[VrRun], out: &mut [f64]) {
        for r in runs {
            let start = r.first as usize;
            match (
                out.get_mut(r.at..r.at + r.len),
                self.reals.get(start..start + r.len),
            ) {
                (Some(dst), Some(src)) => copy_run(dst, src),
                (Some(dst), None) => self.reals_one_by_one(&vrs[r.at..], dst),
                (None, _) => {}
            }
        }
    }

    // The fallbacks below run only for value references past the storage, which the
    // FMUs' declared variables never are. Out of line and cold, they stay out of the
    // cache lines of the step's own code (BENCHMARKS.md, round 33).

    #[cold]
    #[inline(never)]
    fn set_reals_one_by_one(&mut self, vrs: &[u32], values: &[f64], r: &VrRun) {
        for (&vr, &value) in vrs.iter().zip(values).skip(r.at).take(r.len) {
            self.set_real(vr, value);
        }
    }

    #[cold]
    #[inline(never)]
    fn reals_one_by_one(&self, vrs: &[u32], out: &mut [f64]) {
        for (o, &vr) in out.iter_mut().zip(vrs) {
            *o = self.real(vr);
        }
    }

    #[cold]
    #[inline(never)]
    fn set_real_growing(&mut self, vr: u32, value: f64) {
        self.ensure(vr);
        self.reals[vr as usize] = value;
    }

    #[cold]
    #[inline(never)]
    fn set_reals_growing(&mut self, first: u32, values: &[f64]) {
        for (vr, &x) in (first..).zip(values) {
            self.set_real(vr, x);
        }
    }

    #[cold]
    #[inline(never)]
    fn real6_one_by_one(&self, first: u32) -> [f64; 6] {
        std::array::from_fn(|i| self.real(first + i as u32))
    }

    /// Makes room for `vr` (outputs have no start value and may lie past the last one).
    pub fn ensure(&mut self, vr: u32) {
        let n = vr as usize + 1;
        if self.reals.len() < n {
            self.reals.resize(n, 0.0);
            self.integers.resize(n, 0);
            self.booleans.resize(n, false);
        }
    }

    /// A Real value (0 for a value reference never stored).
    #[inline]
    pub fn real(&self, vr: u32) -> f64 {
        self.reals.get(vr as usize).copied().unwrap_or(0.0)
    }

    /// Stores a Real value.
    #[inline]
    pub fn set_real(&mut self, vr: u32, value: f64) {
        match self.reals.get_mut(vr as usize) {
            Some(slot) => *slot = value,
            None => self.set_real_growing(vr, value),
        }
    }

    /// Six consecutive Reals starting at `first` (an array variable `x[1]..x[6]`).
    #[inline]
    pub fn real6(&self, first: u32) -> [f64; 6] {
        let start = first as usize;
        // One bounds check instead of six, as in `set_reals_at`.
        match self.reals.get(start..start + 6) {
            Some(slots) => std::array::from_fn(|i| slots[i]),
            None => self.real6_one_by_one(first),
        }
    }

    /// Stores six consecutive Reals starting at `first` (an array variable `x[1]..x[6]`).
    #[inline(always)]
    pub fn set_real6(&mut self, first: u32, values: &[f64; 6]) {
        self.set_reals_at(first, values);
    }

    /// Stores `N` consecutive Reals starting at `first`. Always inlined: as a call (nine
    /// per co-simulation step) its prologue and epilogue cost more than the copy.
    #[inline(always)]
    pub fn set_reals_at<const N: usize>(&mut self, first: u32, values: &[f64; N]) {
        let start = first as usize;
        // One bounds check and one copy instead of N: about 0.9 % of a trial's
        // instructions for the arrays of six (BENCHMARKS.md, round 7).
        if let Some(slots) = self.reals.get_mut(start..start + N) {
            slots.copy_from_slice(values);
        } else {
            self.set_reals_growing(first, values);
        }
    }

    /// An Integer or Enumeration value.
    #[inline]
    pub fn integer(&self, vr: u32) -> i32 {
        self.integers.get(vr as usize).copied().unwrap_or(0)
    }

    /// Stores an Integer or Enumeration value.
    #[inline]
    pub fn set_integer(&mut self, vr: u32, value: i32) {
        self.ensure(vr);
        self.integers[vr as usize] = value;
    }

    /// A Boolean value.
    #[inline]
    pub fn boolean(&self, vr: u32) -> bool {
        self.booleans.get(vr as usize).copied().unwrap_or(false)
    }

    /// Stores a Boolean value.
    #[inline]
    pub fn set_boolean(&mut self, vr: u32, value: bool) {
        self.ensure(vr);
        self.booleans[vr as usize] = value;
    }

    /// Appends all values, little-endian, length-prefixed.
    pub fn save(&self, out: &mut ByteWriter<'_>) {
        out.u64(self.reals.len() as u64);
        for &x in &self.reals {
            out.f64(x);
        }
        for &x in &self.integers {
            out.i32(x);
        }
        for &x in &self.booleans {
            out.u8(u8::from(x));
        }
    }

    /// Reads values written by [`Values::save`].
    pub fn restore(&mut self, input: &mut ByteReader<'_>) -> ModelResult<()> {
        let n = input.u64()? as usize;
        if n > 1 << 20 {
            return Err(ModelError::error(format!(
                "implausible variable count {n} in saved state"
            )));
        }
        let mut reals = Vec::with_capacity(n);
        for _ in 0..n {
            reals.push(input.f64()?);
        }
        let mut integers = Vec::with_capacity(n);
        for _ in 0..n {
            integers.push(input.i32()?);
        }
        let mut booleans = Vec::with_capacity(n);
        for _ in 0..n {
            booleans.push(input.u8()? != 0);
        }
        *self = Self {
            reals,
            integers,
            booleans,
        };
        Ok(())
    }
}

/// Little-endian writer for model state payloads (pointer-free by construction).
#[derive(Debug)]
pub struct ByteWriter<'a>(pub &'a mut Vec<u8>);

impl ByteWriter<'_> {
    /// Appends one byte.
    pub fn u8(&mut self, x: u8) {
        self.0.push(x);
    }
    /// Appends an i32.
    pub fn i32(&mut self, x: i32) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    /// Appends a u64.
    pub fn u64(&mut self, x: u64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    /// Appends an f64 bit-exactly.
    pub fn f64(&mut self, x: f64) {
        self.0.extend_from_slice(&x.to_le_bytes());
    }
    /// Appends several f64.
    pub fn f64s(&mut self, xs: &[f64]) {
        for &x in xs {
            self.f64(x);
        }
    }
}

/// Reader matching [`ByteWriter`]; running past the end is an error, never a panic.
#[derive(Debug)]
pub struct ByteReader<'a>(pub &'a [u8]);

impl ByteReader<'_> {
    fn take<const N: usize>(&mut self) -> ModelResult<[u8; N]> {
        if self.0.len() < N {
            return Err(ModelError::error(format!(
                "saved model state is truncated: needed {N} more bytes, {} left",
                self.0.len()
            )));
        }
        let (head, rest) = self.0.split_at(N);
        self.0 = rest;
        let mut out = [0u8; N];
        out.copy_from_slice(head);
        Ok(out)
    }
    /// Reads one byte.
    pub fn u8(&mut self) -> ModelResult<u8> {
        Ok(self.take::<1>()?[0])
    }
    /// Reads an i32.
    pub fn i32(&mut self) -> ModelResult<i32> {
        Ok(i32::from_le_bytes(self.take()?))
    }
    /// Reads a u64.
    pub fn u64(&mut self) -> ModelResult<u64> {
        Ok(u64::from_le_bytes(self.take()?))
    }
    /// Reads an f64.
    pub fn f64(&mut self) -> ModelResult<f64> {
        Ok(f64::from_le_bytes(self.take()?))
    }
    /// Fills `out` with f64s.
    pub fn f64s(&mut self, out: &mut [f64]) -> ModelResult<()> {
        for x in out {
            *x = self.f64()?;
        }
        Ok(())
    }
    /// Errors unless everything was consumed.
    pub fn finish(self) -> ModelResult<()> {
        if self.0.is_empty() {
            Ok(())
        } else {
            Err(ModelError::error(format!(
                "saved model state has {} unexpected trailing bytes",
                self.0.len()
            )))
        }
    }
}

/// Copies one run of values: the six elements of a leg array as one fixed-size copy (no
/// `memcpy` call), anything else as a slice.
#[inline]
fn copy_run(dst: &mut [f64], src: &[f64]) {
    match (
        <&mut [f64; 6]>::try_from(&mut *dst),
        <&[f64; 6]>::try_from(src),
    ) {
        (Ok(d), Ok(s)) => *d = *s,
        _ => dst.copy_from_slice(src),
    }
}

/// Whether every value is finite: an exponent field of all ones (NaN or infinity) plus one
/// carries into the sign bit, any other does not, so the compiler vectorises the scan
/// (`is_finite` value by value ran three instructions per value in the setters and the
/// controller's output check, BENCHMARKS.md, round 33). The master checks the outputs it
/// reads the same way; the FMU side and the master's share no crate for such helpers.
#[inline]
pub fn all_finite(values: &[f64]) -> bool {
    const EXPONENT: u64 = 0x7ff0_0000_0000_0000;
    const ONE: u64 = 1 << 52;
    let carry = values
        .iter()
        .fold(0, |acc, x| acc | ((x.to_bits() & EXPONENT) + ONE));
    carry >> 63 == 0
}

/// The error of [`Values::set_finite_real`], kept out of line: it runs once per failed run,
/// the setter once per scalar per step.
#[cold]
fn not_finite(variables: &[VarSpec], vr: u32, value: f64) -> ModelError {
    let name = variables
        .iter()
        .find(|v| v.value_reference == vr && v.var_type == VarType::Real);
    ModelError::error(format!(
        "{} = {} is not finite",
        name.map_or("?", |v| v.name),
        crate::Shown(value)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Causality, Variability};

    #[test]
    fn all_finite_agrees_with_is_finite() {
        let special = [
            0.0,
            -0.0,
            5e-324,
            f64::MAX,
            f64::MIN,
            f64::NAN,
            -f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::from_bits(0x7ff0_0000_0000_0001),
        ];
        for (k, &x) in special.iter().enumerate() {
            for len in [1, 2, 7, 30] {
                let mut values = vec![1.5; len];
                values[(k * 5) % len] = x;
                assert_eq!(all_finite(&values), x.is_finite(), "{x:?} in {len}");
            }
        }
        assert!(all_finite(&[]));
    }

    /// The one variable the setters' checks are given: a Real input without bounds.
    const SPEC: VarSpec = VarSpec {
        name: "x",
        value_reference: 0,
        var_type: VarType::Real,
        causality: Causality::Input,
        variability: Variability::Continuous,
        min: None,
        max: None,
    };

    fn batch(vrs: &[u32]) -> Vec<VrRun> {
        let mut runs = vec![VrRun {
            at: 9,
            first: 9,
            len: 9,
        }];
        VrRun::split(vrs, &mut runs);
        runs
    }

    #[test]
    fn runs_are_maximal_and_cover_the_batch_in_order() {
        let r = |at, first, len| VrRun { at, first, len };
        assert_eq!(batch(&[]), vec![]);
        assert_eq!(
            batch(&[11, 12, 13, 21, 22, 5, 5, 6, u32::MAX, 0]),
            vec![
                r(0, 11, 3),
                r(3, 21, 2),
                r(5, 5, 1),
                r(6, 5, 2),
                r(8, u32::MAX, 1),
                r(9, 0, 1),
            ]
        );
    }

    /// The run copies read and write exactly what the scalar accessors do, for batches
    /// with runs of six, single values, repeats, descending references and references
    /// past the stored values.
    #[test]
    fn run_copies_agree_with_scalar_access() {
        let batches: [&[u32]; 5] = [
            &[11, 12, 13, 14, 15, 16, 21, 22, 23, 24, 25, 26, 1],
            &[3, 2, 1, 0],
            &[7, 7, 8, 8],
            &[30, 31, 32, 33, 34, 35, 36, 37, 60],
            &[],
        ];
        for vrs in batches {
            let runs = batch(vrs);
            let values: Vec<f64> = (0..vrs.len()).map(|i| 0.5 + i as f64).collect();
            let mut by_runs = Values::from_start(&[(40, VarType::Real, -1.0)]);
            let mut by_scalar = by_runs.clone();
            by_runs
                .set_finite_reals(&[SPEC], vrs, &runs, &values)
                .unwrap();
            for (&vr, &v) in vrs.iter().zip(&values) {
                by_scalar.set_real(vr, v);
            }
            assert_eq!(by_runs, by_scalar, "set {vrs:?}");
            let probe: Vec<u32> = vrs.iter().map(|&vr| vr + 1).chain([99, 40]).collect();
            let mut out = vec![f64::NAN; probe.len()];
            by_runs.reals_into(&probe, &batch(&probe), &mut out);
            let expected: Vec<f64> = probe.iter().map(|&vr| by_scalar.real(vr)).collect();
            assert_eq!(out, expected, "get {probe:?}");
        }
    }

    /// Each way of storing a Real reaches past the storage and makes room.
    #[test]
    fn values_past_the_storage_grow_it() {
        let mut v = Values::from_start(&[(2, VarType::Real, -1.0)]);
        v.set_real(10, 1.5);
        v.set_reals_at(20, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let vrs = [30, 31, 40];
        v.set_finite_reals(&[SPEC], &vrs, &batch(&vrs), &[7.0, 8.0, 9.0])
            .unwrap();
        assert_eq!(v.real(2), -1.0);
        assert_eq!(v.real(10), 1.5);
        assert_eq!(v.real6(20), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(v.real6(38), [0.0, 0.0, 9.0, 0.0, 0.0, 0.0]);
        assert_eq!([v.real(30), v.real(31), v.real(40)], [7.0, 8.0, 9.0]);
    }

    #[test]
    fn a_refused_batch_writes_nothing() {
        let mut v = Values::from_start(&[(5, VarType::Real, 1.0)]);
        let before = v.clone();
        let vrs = [0, 1, 2, 3, 4, 5];
        let e = v
            .set_finite_reals(
                &[],
                &vrs,
                &batch(&vrs),
                &[2.0, 2.0, 2.0, f64::NAN, 2.0, 2.0],
            )
            .unwrap_err();
        assert_eq!(e.message, "? = NaN is not finite");
        assert_eq!(v, before);
    }

    /// The error names the Real with that value reference, not a variable of another type
    /// that shares it, nor another Real.
    #[test]
    fn a_value_that_is_not_finite_is_named_by_its_real_variable() {
        let spec = |name, value_reference, var_type| VarSpec {
            name,
            value_reference,
            var_type,
            ..SPEC
        };
        let variables = [
            spec("n", 0, VarType::Integer),
            spec("x", 0, VarType::Real),
            spec("y", 1, VarType::Real),
        ];
        let mut v = Values::from_start(&[(1, VarType::Real, 0.0)]);
        let e = v.set_finite_real(&variables, 0, f64::NAN).unwrap_err();
        assert_eq!(e.message, "x = NaN is not finite");
        let vrs = [1, 0];
        let e = v
            .set_finite_reals(&variables, &vrs, &batch(&vrs), &[1.0, f64::INFINITY])
            .unwrap_err();
        assert_eq!(e.message, "x = inf is not finite");
    }

    /// Two values that are not finite are still caught: the scan's bits must not cancel.
    #[test]
    fn several_values_that_are_not_finite_are_caught() {
        for pair in [
            [f64::NAN, f64::NAN],
            [f64::INFINITY, f64::NEG_INFINITY],
            [f64::NAN, f64::INFINITY],
        ] {
            assert!(!all_finite(&pair), "{pair:?}");
            assert!(!all_finite(&[1.0, pair[0], 2.0, pair[1], 3.0]), "{pair:?}");
        }
    }

    /// Booleans are stored by value reference, false until set, and kept by a saved state.
    #[test]
    fn booleans_are_stored_and_saved() {
        let mut v = Values::from_start(&[(1, VarType::Boolean, 1.0), (2, VarType::Boolean, 0.0)]);
        assert_eq!(
            [v.boolean(0), v.boolean(1), v.boolean(2)],
            [false, true, false]
        );
        v.set_boolean(2, true);
        v.set_boolean(1, false);
        v.set_boolean(9, true);
        assert_eq!(
            (0..11).map(|vr| v.boolean(vr)).collect::<Vec<_>>(),
            [
                false, false, true, false, false, false, false, false, false, true, false
            ]
        );
        let mut bytes = Vec::new();
        v.save(&mut ByteWriter(&mut bytes));
        let mut restored = Values::default();
        let mut input = ByteReader(&bytes);
        restored.restore(&mut input).unwrap();
        input.finish().unwrap();
        assert_eq!(restored, v);
    }

    /// A saved state may hold up to 2^20 variables of each type; a count beyond is refused
    /// before anything is allocated for it.
    #[test]
    fn a_saved_state_holds_at_most_a_million_variables() {
        let limit: usize = 1 << 20;
        let mut bytes = Vec::new();
        let mut w = ByteWriter(&mut bytes);
        w.u64(limit as u64);
        bytes.resize(8 + limit * (8 + 4 + 1), 0);
        let mut v = Values::default();
        let mut input = ByteReader(&bytes);
        v.restore(&mut input).unwrap();
        input.finish().unwrap();
        assert_eq!(v.real(limit as u32 - 1), 0.0);
        for n in [limit as u64 + 1, u64::MAX] {
            let mut bytes = Vec::new();
            ByteWriter(&mut bytes).u64(n);
            let e = Values::default()
                .restore(&mut ByteReader(&bytes))
                .unwrap_err();
            assert_eq!(
                e.message,
                format!("implausible variable count {n} in saved state")
            );
        }
    }
}
