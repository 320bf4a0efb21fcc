//! The `repr(C)` layouts and argument bundles shared by the interpreted expansion and the
//! compiled kernels: the step's rule and control that the compiled step reads at fixed
//! offsets, the status codes it returns, and the buffers it reads and writes.

/// What a Taylor step needs besides the expansion and the state (`Expansion::step`); the
/// compiled step reads it at the offsets of this layout.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepRule {
    /// The relative tolerance: the error is held to atol + rtol |yᵢ| per component.
    pub rtol: f64,
    /// The absolute tolerance.
    pub atol: f64,
    /// The largest step.
    pub h_max: f64,
    /// The smallest step before the run is given up (the floor is at least 10 ε |t|).
    pub min_step: f64,
    /// Where the run ends.
    pub t_end: f64,
    /// The direction of the run, ±1.
    pub dir: f64,
    /// How many leading coordinates (with their velocities) size the step: all of them when
    /// this is at least the number of coordinates (∞ by default); fewer leave the others out
    /// of error control, as a variational system's sensitivities can be
    /// ([`Options::error_coordinates`](crate::Options)). A float, read as the others are.
    pub controlled: f64,
}

impl Default for StepRule {
    /// Zero tolerances and span, every coordinate controlled.
    fn default() -> Self {
        Self {
            rtol: 0.0,
            atol: 0.0,
            h_max: 0.0,
            min_step: 0.0,
            t_end: 0.0,
            dir: 0.0,
            controlled: f64::INFINITY,
        }
    }
}

/// What a step needs besides the expansion and the state, read and written by the compiled
/// step (`ExpansionKernel::step`) at the offsets of this layout: the rule of
/// `Expansion::step`, then its outcome.
#[cfg(feature = "jit")]
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct StepControl {
    /// The time of the state.
    pub t: f64,
    pub rule: StepRule,
    /// Written: the time the step reaches.
    pub t_new: f64,
    /// Written: the step size refused as too small.
    pub h: f64,
}

/// What the compiled expansion returns.
#[cfg(feature = "jit")]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum KernelStatus {
    /// The expansion alone, done.
    Expanded = 0,
    /// A step, taken (`last`: to t_end).
    Step = 1,
    Last = 2,
    /// A coefficient of q̈ is not finite.
    Coefficient = 3,
    /// The step size is not above the floor (refused, the step size in `StepControl::h`).
    TooSmall = 4,
    /// A value of the new state is not finite.
    State = 5,
    /// M₀ did not factor (only from `ExpansionKernel::steps`, which does not say why: the
    /// step is to be taken again by `Expansion::step`, whose error names the failure).
    Unfactored = 6,
}

#[cfg(feature = "jit")]
impl KernelStatus {
    pub(crate) fn from_code(code: i32) -> Self {
        [
            Self::Expanded,
            Self::Step,
            Self::Last,
            Self::Coefficient,
            Self::TooSmall,
            Self::State,
            Self::Unfactored,
        ][code as usize]
    }
}

/// A step's control, the state it starts from, the compensation (read and written) and the new
/// state, as `ExpansionKernel::step` reads and writes them.
#[cfg(feature = "jit")]
pub(crate) struct StepArgs<'a> {
    pub control: &'a mut StepControl,
    pub y: &'a [f64],
    pub lost: &'a mut [f64],
    pub y_new: &'a mut [f64],
}

/// The work space of an expansion, as `ExpansionKernel::run` reads and writes it.
#[cfg(feature = "jit")]
pub(crate) struct Buffers<'a> {
    pub table: &'a mut [f64],
    pub q: &'a mut [f64],
    pub v: &'a mut [f64],
    pub qdd: &'a mut [f64],
    pub m0: &'a mut [f64],
    pub reversed: &'a mut [f64],
}
