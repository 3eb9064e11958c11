//! The 34 FMI 2.0 functions of a co-simulation FMU (common + CS), resolved up front; their
//! signatures come from the one table in `fmi2-sys`.

/// The importer's reader of the signature table: the struct of typed function pointers and
/// the list of symbols.
macro_rules! functions_from_table {
    ([] $($cname:ident => $wrapper:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty;)*) => {
        /// Typed pointers to every function; valid while the `Library` they came from is loaded.
        #[allow(non_snake_case)] // Field names are the C symbol names, for grep-ability.
        #[derive(Debug, Clone, Copy)]
        pub(crate) struct Functions {
            $(pub(crate) $cname: unsafe extern "C" fn($($ty),*) -> $ret,)*
        }

        /// Every symbol `Functions::load` resolves, in the order of the standard's header.
        pub const SYMBOLS: &[&str] = &[$(stringify!($cname)),*];

        impl Functions {
            /// Resolves every symbol; the first missing one is returned by name.
            ///
            /// # Safety
            /// `library` must be an FMI 2.0 binary: each symbol, if present, must have the
            /// signature of the standard's header, which is what the pointer is typed as.
            pub(crate) unsafe fn load(
                library: &libloading::Library,
            ) -> Result<Self, (&'static str, libloading::Error)> {
                Ok(Self {
                    $($cname: {
                        // SAFETY: per this function's contract, the symbol has this signature.
                        let symbol = unsafe {
                            library.get::<unsafe extern "C" fn($($ty),*) -> $ret>(stringify!($cname))
                        };
                        *symbol.map_err(|e| (stringify!($cname), e))?
                    },)*
                })
            }
        }
    };
}

fmi2_sys::__fmi2_functions!({functions_from_table} []);
