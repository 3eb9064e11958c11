//! Storage of an FMU's variable values, indexed directly by value reference.
//!
//! Our value references are small dense integers, so a flat array per base type gives
//! O(1) get/set with no hashing and lets a model be `Clone` for FMU-state snapshots.
//! The arrays are allocated once per instance; nothing here allocates per step.

use crate::{ModelError, ModelResult, VarSpec, VarType};

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
    /// named, as by [`Values::set_finite_real`]).
    #[inline]
    pub fn set_finite_reals(
        &mut self,
        variables: &[VarSpec],
        vrs: &[u32],
        values: &[f64],
    ) -> ModelResult<()> {
        // One branch-free scan for the common case; the culprit is looked up only on failure.
        if !values.iter().fold(true, |ok, v| ok & v.is_finite()) {
            if let Some((&vr, &value)) = vrs.iter().zip(values).find(|(_, v)| !v.is_finite()) {
                return Err(not_finite(variables, vr, value));
            }
        }
        for (&vr, &value) in vrs.iter().zip(values) {
            self.set_real(vr, value);
        }
        Ok(())
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
            None => {
                self.ensure(vr);
                self.reals[vr as usize] = value;
            }
        }
    }

    /// Six consecutive Reals starting at `first` (an array variable `x[1]..x[6]`).
    #[inline]
    pub fn real6(&self, first: u32) -> [f64; 6] {
        std::array::from_fn(|i| self.real(first + i as u32))
    }

    /// Stores six consecutive Reals starting at `first`.
    #[inline]
    pub fn set_real6(&mut self, first: u32, values: &[f64; 6]) {
        let start = first as usize;
        // One bounds check and one copy instead of six: about 0.9 % of a trial's
        // instructions (BENCHMARKS.md, round 7).
        if let Some(slots) = self.reals.get_mut(start..start + 6) {
            slots.copy_from_slice(values);
        } else {
            for (i, &x) in values.iter().enumerate() {
                self.set_real(first + i as u32, x);
            }
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

/// The error of [`Values::set_finite_real`], kept out of line: it runs once per failed run,
/// the setter once per scalar per step.
#[cold]
fn not_finite(variables: &[VarSpec], vr: u32, value: f64) -> ModelError {
    let name = variables
        .iter()
        .find(|v| v.value_reference == vr && v.var_type == VarType::Real);
    ModelError::error(format!(
        "{} = {value} is not finite",
        name.map_or("?", |v| v.name)
    ))
}
