//! Native code generation with Cranelift (the `jit` feature): the plumbing every compiled
//! kernel shares — a module for the host with the maths library's `f64` functions registered
//! ([`jit_module`], plus whatever symbols the caller hands in), declaring, entering and linking
//! a function, and [`Code`], the owner of generated machine code. It names no caller: the tape
//! compiler ([`tape`]) and the Taylor kernels (`crate::taylor`) each bring their own code and
//! symbols.
//!
//! Anything the compiler cannot handle (no Cranelift backend for the host, a malformed input, a
//! Cranelift error) is an [`Error::InvalidInput`] ([`fail`]), on which the caller keeps the
//! interpreter.

pub(crate) mod tape;

use crate::error::{Error, Result};
use cranelift_codegen::ir::{self, AbiParam, Value};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::FunctionBuilder;
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{FuncId, Linkage, Module, default_libcall_names};

/// The largest tape (instructions) given Cranelift's backtracking register allocator; larger
/// ones get the single-pass allocator. Measured (release, 2-core machine): backtracking
/// compiles ~6.5 µs per instruction (a 10 200-instruction tape in 66 ms), single-pass ~1.6 µs
/// (16 ms), and its code is 0–25 % slower (the double pendulum's T: 21.8 against 17.5 ns; a
/// 32-link chain's T: 733 against 674 ns). So small tapes get the better code, and large ones
/// a compile time that stays within the model-build budget.
///
/// Cranelift's own optimizer (`opt_level`) is off: the tape is already shared (hash-consed),
/// folded and scheduled, and `speed` compiled ~30 % slower to code no faster (the chain's T:
/// 741 against 674 ns).
pub(crate) const BACKTRACKING_UP_TO: usize = 10_000;

/// Machine code and the Cranelift module that owns its memory: freed on drop, never changed
/// after compilation. The home of the `unsafe` ownership of generated code, for [`NativeTape`]
/// and the Taylor kernels.
pub(crate) struct Code<E: Copy> {
    /// `None` only while dropping.
    module: Option<JITModule>,
    entry: E,
}

// SAFETY: after `Code::new` the module is never mutated or read again except to free it in
// `drop` (which needs `&mut self`, so no call can be running); the machine code is immutable, so
// calling it from several threads at once is sound (each caller passes its own buffers).
unsafe impl<E: Copy> Send for Code<E> {}
// SAFETY: as for `Send`: `&self` gives access to nothing but the immutable code.
unsafe impl<E: Copy> Sync for Code<E> {}

impl<E: Copy> Code<E> {
    /// The function `define` emits into `module` and returns the entry of; on failure the
    /// module's memory is freed and the error returned.
    pub(crate) fn new(
        mut module: JITModule,
        define: impl FnOnce(&mut JITModule) -> Result<E>,
    ) -> Result<Self> {
        match define(&mut module) {
            Ok(entry) => Ok(Self {
                module: Some(module),
                entry,
            }),
            Err(e) => {
                // SAFETY: no pointer into the module was handed out.
                unsafe { module.free_memory() };
                Err(e)
            }
        }
    }

    /// The compiled function.
    pub(crate) fn entry(&self) -> E {
        self.entry
    }
}

impl<E: Copy> Drop for Code<E> {
    fn drop(&mut self) {
        if let Some(module) = self.module.take() {
            // SAFETY: `entry` is only reachable through `&self`, which cannot outlive this call.
            unsafe { module.free_memory() };
        }
    }
}

/// A Cranelift failure or unsupported tape.
pub(crate) fn fail(why: impl std::fmt::Display) -> Error {
    Error::InvalidInput {
        what: "native code",
        why: why.to_string(),
    }
}

macro_rules! wrappers {
    ($($name:ident: $f:ident($($x:ident: $t:ty),*);)*) => {
        $(
            extern "C" fn $name($($x: $t),*) -> f64 {
                f64::$f($($x),*)
            }
        )*
        /// Register the `f64` functions the generated code calls, by symbol name.
        fn register(jit: &mut JITBuilder) {
            $(jit.symbol(stringify!($name), $name as *const u8);)*
            register_unary(jit);
            jit.symbol("lagrangian_powi", lagrangian_powi as *const u8);
            jit.symbol("lagrangian_sin_cos", lagrangian_sin_cos as *const u8);
        }
    };
}

wrappers! {
    lagrangian_powf: powf(x: f64, y: f64);
    lagrangian_atan2: atan2(x: f64, y: f64);
}

/// The maths library's functions of one argument that the generated code calls, from the table
/// of `expr/functions.rs` (a function with no entry there is an instruction of its own).
macro_rules! unary_wrappers {
    ($($name:ident {
        doc: $doc:expr,
        name: $($py:literal)?,
        value: |$x:ident| $value:expr,
        tangent: |$d:ident, $a:ident, $y:ident, $da:ident| $tangent:expr,
        num: |$nx:ident| $num:expr,
        jet: |$jx:ident| $jet:expr,
        series: $series:expr,
        libm: $($sym:ident = $f:ident)?,
        ins: $u:ident, $ua:ident: $m:ident,
        dual_num: $($dn:ident)?,
    })*) => {
        $($(
            extern "C" fn $sym(x: f64) -> f64 {
                f64::$f(x)
            }
        )?)*

        /// Register them by symbol name.
        fn register_unary(jit: &mut JITBuilder) {
            $($(jit.symbol(stringify!($sym), $sym as *const u8);)?)*
        }
    };
}

crate::expr::functions::unary_functions!(unary_wrappers);

extern "C" fn lagrangian_powi(x: f64, n: i32) -> f64 {
    x.powi(n)
}

/// `f64::sin_cos`: the sine, and the cosine written to `cos`.
///
/// # Safety
/// `cos` is valid for a write of an `f64` (the generated code passes a slot of its frame).
unsafe extern "C" fn lagrangian_sin_cos(x: f64, cos: *mut f64) -> f64 {
    let (s, c) = x.sin_cos();
    // SAFETY: see the function's contract.
    unsafe { cos.write(c) };
    s
}

/// A Cranelift module for the host, with the `f64` functions the generated code calls
/// registered and the caller's own `symbols` (name, address), with the backtracking register
/// allocator or the single-pass one ([`BACKTRACKING_UP_TO`]).
pub(crate) fn jit_module(backtracking: bool, symbols: &[(&str, *const u8)]) -> Result<JITModule> {
    let mut flags = settings::builder();
    let regalloc = if backtracking {
        "backtracking"
    } else {
        "single_pass"
    };
    for (k, v) in [
        ("opt_level", "none"),
        ("regalloc_algorithm", regalloc),
        ("enable_probestack", "true"),
        ("probestack_strategy", "inline"),
        // The IR checker: on in debug builds (the tests), off in release, where it was a
        // seventh of compiling (perf of first runs of the double pendulum: 4.4 of 32 %).
        (
            "enable_verifier",
            if cfg!(debug_assertions) {
                "true"
            } else {
                "false"
            },
        ),
    ] {
        flags.set(k, v).map_err(fail)?;
    }
    let isa = cranelift_native::builder()
        .map_err(fail)?
        .finish(settings::Flags::new(flags))
        .map_err(fail)?;
    let mut jit = JITBuilder::with_isa(isa, default_libcall_names());
    register(&mut jit);
    for &(name, address) in symbols {
        jit.symbol(name, address);
    }
    Ok(JITModule::new(jit))
}

/// A function with parameters `params` and no result (the host's default calling convention),
/// declared in `module` as `name`, and the context to build it in.
pub(crate) fn declare(
    module: &mut JITModule,
    name: &str,
    params: &[ir::Type],
) -> Result<(FuncId, cranelift_codegen::Context)> {
    let mut ctx = module.make_context();
    let sig = &mut ctx.func.signature;
    sig.params.extend(params.iter().map(|&t| AbiParam::new(t)));
    let id = module
        .declare_function(name, Linkage::Local, &ctx.func.signature)
        .map_err(fail)?;
    Ok((id, ctx))
}

/// Open the entry block of the function `b` builds (sealed: nothing jumps back to it) and give
/// its parameters.
pub(crate) fn enter(b: &mut FunctionBuilder<'_>) -> Vec<Value> {
    let entry = b.create_block();
    b.append_block_params_for_function_params(entry);
    b.switch_to_block(entry);
    b.seal_block(entry);
    b.block_params(entry).to_vec()
}

/// Compile the function built in `ctx`, declared as `id`, link the module, and give the
/// function's address.
pub(crate) fn link(
    module: &mut JITModule,
    id: FuncId,
    ctx: &mut cranelift_codegen::Context,
) -> Result<*const u8> {
    module.define_function(id, ctx).map_err(fail)?;
    module.clear_context(ctx);
    module.finalize_definitions().map_err(fail)?;
    Ok(module.get_finalized_function(id))
}
