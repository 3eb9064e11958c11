//! `export_fmu!`: the C entry points of an FMU crate.
//!
//! This macro body is where the FMU crates' only `unsafe` text comes from: each FMU
//! crate can `#![deny(unsafe_code)]` (not `forbid`, which an `allow` cannot lift) and
//! still export the FMI functions, because every shim carries `#[allow(unsafe_code)]`
//! and merely forwards its raw arguments to a wrapper in [`crate::export::abi`], which
//! does all checking.

/// Exports the 34 FMI 2.0 Co-Simulation functions for a [`Model`](fmu_core::Model).
///
/// Invoke once, at the root of the FMU's `cdylib` crate:
///
/// ```ignore
/// fmi2_export::export_fmu!(MyModel);
/// ```
///
/// It expands to `#[unsafe(no_mangle)] pub unsafe extern "C" fn fmi2DoStep(...)` and the
/// rest: the 25 common functions and the 9 Co-Simulation ones, with the exact names and
/// signatures of `fmi2Functions.h`. Each body is one call of the generic wrapper in
/// [`fmi2_export::abi`](crate::abi), which validates the component, the
/// allowed-states table and every pointer, and converts panics into fmi2Fatal.
#[macro_export]
macro_rules! export_fmu {
    ($model:ty) => {
        // SAFETY (whole expansion): the FMI 2.0 master guarantees the C calling contract of
        // fmi2Functions.h; each shim forwards its arguments unchanged to the wrapper in
        // `fmi2_export::abi`, which checks the component, every pointer and every length
        // before use and catches every panic, so no unchecked dereference happens here.
        $crate::__private::fmi2_sys::__fmi2_functions!({ $crate::__fmi2_shims }[$model]);
    };
}

/// The exported shims of [`export_fmu!`], one per row of the signature table; not for
/// direct use.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi2_shims {
    ([$model:ty] $($cname:ident => $wrapper:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty;)*) => {$(
        #[doc = concat!("FMI 2.0 `", stringify!($cname), "` (forwards to `fmi2_export::abi::", stringify!($wrapper), "`).")]
        #[doc = ""]
        #[doc = "# Safety"]
        #[doc = "The FMI 2.0 calling contract: the component comes from fmi2Instantiate and is used by one thread at a time; pointers are NULL or valid for the lengths passed."]
        #[allow(unsafe_code, non_snake_case)]
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $cname($($arg: $ty),*) -> $ret {
            // SAFETY: the arguments are forwarded unchanged under the same contract; the
            // wrapper checks the component, every pointer and every length before use.
            // (fmi2GetTypesPlatform and fmi2GetVersion have safe wrappers.)
            #[allow(unused_unsafe)]
            unsafe {
                $crate::abi::$wrapper::<$model>($($arg),*)
            }
        }
    )*};
}
