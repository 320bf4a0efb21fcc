//! What a tape may read ([`Inputs`]): shared by the compiler and its analysis, below both.

/// What a tape may read: the number of coordinates and parameters, and which of t, q and q̇.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Inputs {
    /// Number of coordinates (and velocities).
    pub dof: usize,
    /// Number of parameters.
    pub params: usize,
    /// Whether the time may appear.
    pub time: bool,
    /// Whether the coordinates may appear.
    pub position: bool,
    /// Whether the velocities may appear.
    pub velocity: bool,
}

impl Inputs {
    /// Everything: T(t, q, q̇), Φ(t, q, q̇), Q″(t, q, q̇).
    pub fn kinetic(dof: usize, params: usize) -> Self {
        Self {
            dof,
            params,
            time: true,
            position: true,
            velocity: true,
        }
    }

    /// No velocities: U(t, q), positions r(t, q).
    pub fn potential(dof: usize, params: usize) -> Self {
        Self {
            velocity: false,
            ..Self::kinetic(dof, params)
        }
    }

    /// Numbers and parameters only: masses.
    pub fn constant(params: usize) -> Self {
        Self {
            dof: 0,
            params,
            time: false,
            position: false,
            velocity: false,
        }
    }
}
