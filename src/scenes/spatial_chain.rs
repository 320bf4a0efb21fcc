//! A spatial arm: N rigid links (solid cylinders) in a chain from a fixed pivot, each joint a
//! hinge — q1, q3, … about the x axis of the frame before it, q2, q4, … about its y axis —,
//! hanging in gravity g along −z.
//! The rigid-body route's scene (issue 50).

use super::registry::{Arguments, Coordinates, Drawing, Parameter, Route, Scene, SceneInfo};
use crate::error::{Error, Result};
use crate::rigid::{Axis, Pose, Rotation};
use crate::routes::{BodySystem, RigidBodies};
use crate::scalar::Scalar;

/// N solid cylinders of masses m_k, lengths l_k and common radius a, joined end to end.
///
/// Link k turns by q_k about its parent's axis x (k even) or y (k odd), R_k = R_{k−1} R_x|y(q_k);
/// its axis is body −z, its centre l_k/2 below its joint, and its inertia about the centre
/// diag(m(3a² + l²)/12, m(3a² + l²)/12, m a²/2). At q = 0 the arm hangs straight down.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialChain {
    /// Link masses, from the pivot out.
    pub masses: Vec<f64>,
    /// Link lengths.
    pub lengths: Vec<f64>,
    /// The links' radius.
    pub radius: f64,
    /// Gravitational acceleration (along −z).
    pub g: f64,
}

impl SpatialChain {
    /// A chain with these masses and lengths (one per link).
    ///
    /// # Panics
    /// If the lists are empty or of different lengths.
    pub fn new(masses: Vec<f64>, lengths: Vec<f64>, radius: f64, g: f64) -> Self {
        assert!(!masses.is_empty(), "a chain needs at least one link");
        assert_eq!(masses.len(), lengths.len(), "one length per mass");
        Self {
            masses,
            lengths,
            radius,
            g,
        }
    }

    /// `n` equal links.
    pub fn uniform(n: usize, m: f64, l: f64, radius: f64, g: f64) -> Self {
        Self::new(vec![m; n], vec![l; n], radius, g)
    }

    /// Number of links.
    pub fn links(&self) -> usize {
        self.masses.len()
    }

    /// The rigid-body system in gravity (0, 0, −g).
    pub fn system(self) -> BodySystem<Self> {
        let g = self.g;
        BodySystem::new(self).with_gravity([0.0, 0.0, -g])
    }

    /// The axis of joint `k`.
    pub fn axis(k: usize) -> Axis {
        if k.is_multiple_of(2) {
            Axis::X
        } else {
            Axis::Y
        }
    }
}

impl RigidBodies for SpatialChain {
    fn dof(&self) -> usize {
        self.links()
    }
    fn count(&self) -> usize {
        self.links()
    }
    fn mass(&self, j: usize) -> f64 {
        self.masses[j]
    }
    fn inertia(&self, j: usize) -> [[f64; 3]; 3] {
        let (m, l, a) = (self.masses[j], self.lengths[j], self.radius);
        let side = m * (3.0 * a * a + l * l) / 12.0;
        [
            [side, 0.0, 0.0],
            [0.0, side, 0.0],
            [0.0, 0.0, 0.5 * m * a * a],
        ]
    }
    fn poses<D: Scalar>(&self, _t: D, q: &[D], out: &mut [Pose<D>]) {
        let mut r = Rotation::identity();
        let mut joint = [D::zero(); 3];
        for (k, (&qk, pose)) in q.iter().zip(out.iter_mut()).enumerate() {
            r = r * Rotation::about(Self::axis(k), qk);
            let down = r.column(2);
            let l = self.lengths[k];
            let centre = [0, 1, 2].map(|d| joint[d] - down[d] * (0.5 * l));
            *pose = Pose::new(centre, r);
            joint = [0, 1, 2].map(|d| joint[d] - down[d] * l);
        }
    }
    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Scene for SpatialChain {
    type System = BodySystem<Self>;
    const INFO: SceneInfo = SceneInfo {
        name: "spatial_chain",
        doc: "A spatial arm of N rigid links (solid cylinders of ``radius``) hanging from a fixed \
              pivot in gravity ``g`` along −z; coordinates ``q1`` … ``qN``, the hinges ``q1``, \
              ``q3``, … about the x axis of the frame before them (the world's for ``q1``), \
              ``q2``, ``q4``, … about its y axis; N is the number of ``masses`` (one \
              length per mass). The rigid-body route: T = Σ ½ m ‖ṙ‖² + ½ ΩᵀIΩ.",
        parameters: &[
            Parameter::list(
                "masses",
                &[1.0, 1.0, 1.0],
                "link masses, from the pivot out",
            ),
            Parameter::list(
                "lengths",
                &[1.0, 1.0, 1.0],
                "link lengths, from the pivot out",
            ),
            Parameter::number("radius", 0.05, "the links' radius"),
            Parameter::number("g", 9.81, "gravitational acceleration"),
        ],
        coordinates: Coordinates::Numbered {
            prefix: "q",
            per: "masses",
        },
        route: Route::Body,
        exact: false,
    };
    fn build(a: &Arguments) -> Result<Self::System> {
        let (masses, lengths) = (a.list("masses"), a.list("lengths"));
        if masses.is_empty() || masses.len() != lengths.len() {
            return Err(Error::SceneArgument {
                scene: Self::INFO.name,
                parameter: "lengths".into(),
                why: format!(
                    "one length per mass (at least one): got {} masses and {} lengths",
                    masses.len(),
                    lengths.len()
                ),
            });
        }
        Ok(Self::new(
            masses.to_vec(),
            lengths.to_vec(),
            a.number("radius"),
            a.number("g"),
        )
        .system())
    }
    fn drawing(a: &Arguments) -> Option<Drawing> {
        Some(Drawing::chain(a.list("masses").len(), false))
    }
}
