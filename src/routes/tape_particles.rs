//! [`TapeParticles`]: point masses whose positions are a tape, the particle route for models
//! stated at run time.

use crate::error::{Error, Result};
use crate::program::eval::Function;
use crate::routes::Particles;
use crate::scalar::Scalar;

/// Point masses whose positions are a tape: the particle route for models stated at run time.
#[derive(Debug, Clone, PartialEq)]
pub struct TapeParticles {
    dof: usize,
    dim: usize,
    positions: Function,
    masses: Vec<f64>,
}

impl TapeParticles {
    /// `masses.len()` particles in `dim` = 2 or 3 dimensions whose positions r(t, q) are the
    /// outputs of `positions`, particle after particle.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] for a dimension other than 2 or 3, a position tape that reads
    /// velocities or has not `dim` outputs per particle, or a mass that is negative or not
    /// finite; [`Error::DimensionMismatch`] when `dof` differs from the tape's.
    pub fn new(dof: usize, dim: usize, positions: Function, masses: Vec<f64>) -> Result<Self> {
        let bad = |why: String| {
            Err(Error::InvalidInput {
                what: "particles",
                why,
            })
        };
        if dim != 2 && dim != 3 {
            return bad(format!("positions are 2-D or 3-D, not {dim}-D"));
        }
        if masses.is_empty() {
            return bad("there are no particles".into());
        }
        let tape = positions.tape();
        if tape.inputs().dof != dof {
            return Err(Error::DimensionMismatch {
                what: "position tape coordinates",
                expected: dof,
                got: tape.inputs().dof,
            });
        }
        if tape.depends_on_velocity() {
            return bad("positions may not depend on the velocities".into());
        }
        if tape.outputs() != dim * masses.len() {
            return bad(format!(
                "{} position components for {} particles in {dim}-D",
                tape.outputs(),
                masses.len()
            ));
        }
        if let Some(m) = masses.iter().find(|m| !(m.is_finite() && **m >= 0.0)) {
            return bad(format!("the mass {m} is not a finite non-negative number"));
        }
        Ok(Self {
            dof,
            dim,
            positions,
            masses,
        })
    }

    /// The position tape.
    pub fn positions(&self) -> &Function {
        &self.positions
    }

    /// The masses.
    pub fn masses(&self) -> &[f64] {
        &self.masses
    }
}

impl Particles for TapeParticles {
    fn dof(&self) -> usize {
        self.dof
    }
    fn dim(&self) -> usize {
        self.dim
    }
    fn count(&self) -> usize {
        self.masses.len()
    }
    fn mass(&self, j: usize) -> f64 {
        self.masses[j]
    }
    #[inline]
    fn positions<D: Scalar>(&self, t: D, q: &[D], r: &mut [D]) {
        self.positions.eval_into(t, q, &[], r)
    }
    fn depends_on_time(&self) -> bool {
        self.positions.tape().depends_on_time()
    }
}
