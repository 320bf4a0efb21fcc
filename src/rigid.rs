//! Rotations and quaternions over any [`Scalar`], for the rigid-body route
//! ([`RigidBodies`](crate::routes::RigidBodies)): written once, they run on `f64` and on the dual
//! numbers the route differentiates with, so a body's orientation R(t, q) is stated as plainly as
//! a particle's position.
//!
//! Conventions (those of `lg.Body` in Python): R's columns are the body axes in world
//! coordinates (v_world = R v_body); a sequence of turns about moving axes multiplies on the
//! right (R = R_a(α) R_b(β) R_c(γ)); quaternions are scalar first, q = w + x i + y j + z k.
//!
//! ```
//! use lagrangian::rigid::{Axis, Quaternion, Rotation};
//! let r = Rotation::<f64>::from_euler([Axis::Z, Axis::X, Axis::Z], [0.3, 0.4, 0.5]);
//! let q = Quaternion::about_axis([0.0, 0.0, 1.0], 0.3)
//!     * Quaternion::about_axis([1.0, 0.0, 0.0], 0.4)
//!     * Quaternion::about_axis([0.0, 0.0, 1.0], 0.5);
//! let s = q.rotation();
//! for i in 0..3 {
//!     for j in 0..3 {
//!         assert!((r.m[i][j] - s.m[i][j]).abs() < 1e-15);
//!     }
//! }
//! assert!(r.orthonormality_error() < 1e-15);
//! ```

use crate::scalar::Scalar;
use std::ops::Mul;

/// How far RᵀR may be from I (largest entry) before the rigid-body route refuses a body's
/// orientation: far above round-off (1e-16 for the constructors of [`Rotation`]), far below any
/// real error.
pub const ORTHONORMAL_TOLERANCE: f64 = 1e-9;

/// A 3-vector over any scalar.
pub type Vector3<D> = [D; 3];

/// One of the three coordinate axes, for [`Rotation::about`] and [`Rotation::from_euler`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// The first axis.
    X,
    /// The second axis.
    Y,
    /// The third axis.
    Z,
}

/// A 3×3 rotation matrix, row-major (`m[i][j]` is row i, column j).
///
/// The constructors give orthonormal matrices; [`Rotation::from_matrix`] takes any, and the
/// rigid-body route refuses one that is not orthonormal
/// ([`orthonormality_error`](Self::orthonormality_error)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rotation<D> {
    /// The entries, row after row.
    pub m: [[D; 3]; 3],
}

impl<D: Scalar> Rotation<D> {
    /// The identity.
    pub fn identity() -> Self {
        let (o, l) = (D::zero(), D::one());
        Self {
            m: [[l, o, o], [o, l, o], [o, o, l]],
        }
    }

    /// The matrix with these rows, as given (not checked here).
    pub fn from_matrix(m: [[D; 3]; 3]) -> Self {
        Self { m }
    }

    /// The turn by `angle` (right-handed) about the coordinate axis `axis`.
    pub fn about(axis: Axis, angle: D) -> Self {
        let (s, c) = angle.sin_cos();
        let (o, l) = (D::zero(), D::one());
        let m = match axis {
            Axis::X => [[l, o, o], [o, c, -s], [o, s, c]],
            Axis::Y => [[c, o, s], [o, l, o], [-s, o, c]],
            Axis::Z => [[c, -s, o], [s, c, o], [o, o, l]],
        };
        Self { m }
    }

    /// The turn by `angle` about the first axis.
    pub fn about_x(angle: D) -> Self {
        Self::about(Axis::X, angle)
    }

    /// The turn by `angle` about the second axis.
    pub fn about_y(angle: D) -> Self {
        Self::about(Axis::Y, angle)
    }

    /// The turn by `angle` about the third axis.
    pub fn about_z(angle: D) -> Self {
        Self::about(Axis::Z, angle)
    }

    /// The turn by `angle` about the fixed direction `axis` (normalized here; Rodrigues'
    /// formula R = I + sin a K + (1 − cos a) K², K the cross-product matrix of the unit axis).
    /// A zero axis gives a matrix of NaN, which the route reports as not finite.
    pub fn about_axis(axis: [f64; 3], angle: D) -> Self {
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        let [x, y, z] = axis.map(|a| a / n);
        let (s, c) = angle.sin_cos();
        let v = D::one() - c;
        let k = [[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]];
        let k2 = [
            [x * x - 1.0, x * y, x * z],
            [x * y, y * y - 1.0, y * z],
            [x * z, y * z, z * z - 1.0],
        ];
        let mut m = Self::identity().m;
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += s * k[i][j] + v * k2[i][j];
            }
        }
        Self { m }
    }

    /// Three turns about moving axes, R = R_a(α) R_b(β) R_c(γ) for `sequence` = [a, b, c]:
    /// proper Euler angles ([Z, X, Z], …) and Tait–Bryan angles ([Z, Y, X], …) alike.
    pub fn from_euler(sequence: [Axis; 3], angles: [D; 3]) -> Self {
        Self::about(sequence[0], angles[0])
            * Self::about(sequence[1], angles[1])
            * Self::about(sequence[2], angles[2])
    }

    /// The rotation of a quaternion (see [`Quaternion::rotation`]).
    pub fn from_quaternion(q: Quaternion<D>) -> Self {
        q.rotation()
    }

    /// Rᵀ, the inverse rotation.
    pub fn transpose(&self) -> Self {
        let m = &self.m;
        Self {
            m: [
                [m[0][0], m[1][0], m[2][0]],
                [m[0][1], m[1][1], m[2][1]],
                [m[0][2], m[1][2], m[2][2]],
            ],
        }
    }

    /// R v.
    pub fn apply(&self, v: Vector3<D>) -> Vector3<D> {
        self.m
            .map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
    }

    /// Rᵀ v.
    pub fn apply_transpose(&self, v: Vector3<D>) -> Vector3<D> {
        let m = &self.m;
        [0, 1, 2].map(|j| m[0][j] * v[0] + m[1][j] * v[1] + m[2][j] * v[2])
    }

    /// Column `j`: body axis j in world coordinates.
    pub fn column(&self, j: usize) -> Vector3<D> {
        [self.m[0][j], self.m[1][j], self.m[2][j]]
    }

    /// The largest entry of |RᵀR − I| (at the real parts): 0 up to round-off for a rotation.
    pub fn orthonormality_error(&self) -> f64 {
        let mut worst: f64 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let dot: f64 = (0..3).map(|k| self.m[k][i].re() * self.m[k][j].re()).sum();
                let e = (dot - if i == j { 1.0 } else { 0.0 }).abs();
                worst = if e.is_nan() { f64::NAN } else { worst.max(e) };
            }
        }
        worst
    }
}

impl<D: Scalar> Mul for Rotation<D> {
    type Output = Self;
    /// The product A B: first B, then A in the fixed axes (B about A's turned axes).
    fn mul(self, b: Self) -> Self {
        let (a, b) = (&self.m, &b.m);
        let m = [0, 1, 2]
            .map(|i| [0, 1, 2].map(|j| a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j]));
        Self { m }
    }
}

/// The vector of a skew matrix, (w₂₁, w₀₂, w₁₀) (as `lg.Body` reads Ω from RᵀṘ).
#[inline]
pub fn vee<D: Scalar>(w: &[[D; 3]; 3]) -> Vector3<D> {
    [w[2][1], w[0][2], w[1][0]]
}

/// a × b.
#[inline]
pub fn cross<D: Scalar>(a: Vector3<D>, b: Vector3<D>) -> Vector3<D> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A quaternion w + x i + y j + z k (scalar first).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quaternion<D> {
    /// The scalar part.
    pub w: D,
    /// The i part.
    pub x: D,
    /// The j part.
    pub y: D,
    /// The k part.
    pub z: D,
}

impl<D: Scalar> Quaternion<D> {
    /// w + x i + y j + z k.
    pub fn new(w: D, x: D, y: D, z: D) -> Self {
        Self { w, x, y, z }
    }

    /// The quaternion of four consecutive coordinates, scalar first.
    pub fn from_slice(q: &[D]) -> Self {
        Self::new(q[0], q[1], q[2], q[3])
    }

    /// The unit quaternion of the turn by `angle` about the fixed direction `axis` (normalized
    /// here).
    pub fn about_axis(axis: [f64; 3], angle: D) -> Self {
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        let (s, c) = (angle * 0.5).sin_cos();
        Self::new(c, s * (axis[0] / n), s * (axis[1] / n), s * (axis[2] / n))
    }

    /// ‖q‖² = w² + x² + y² + z².
    pub fn norm_squared(&self) -> D {
        self.w * self.w + self.x * self.x + self.y * self.y + self.z * self.z
    }

    /// q / ‖q‖.
    pub fn normalized(&self) -> Self {
        let n = self.norm_squared().sqrt();
        Self::new(self.w / n, self.x / n, self.y / n, self.z / n)
    }

    /// The conjugate w − x i − y j − z k (the inverse of a unit quaternion).
    pub fn conjugate(&self) -> Self {
        Self::new(self.w, -self.x, -self.y, -self.z)
    }

    /// The rotation matrix of q, divided by ‖q‖² so that it is a rotation for every q ≠ 0 and
    /// the usual one on ‖q‖ = 1 (as `lg.quaternion_rotation`): the orientation is then blind to
    /// q's length, which the route's regularizing term makes up for
    /// ([`Pose::from_quaternion`]).
    pub fn rotation(&self) -> Rotation<D> {
        let Self { w, x, y, z } = *self;
        let n = self.norm_squared();
        let two = |a: D| a * 2.0;
        let m = [
            [
                w * w + x * x - y * y - z * z,
                two(x * y - w * z),
                two(x * z + w * y),
            ],
            [
                two(x * y + w * z),
                w * w - x * x + y * y - z * z,
                two(y * z - w * x),
            ],
            [
                two(x * z - w * y),
                two(y * z + w * x),
                w * w - x * x - y * y + z * z,
            ],
        ];
        Rotation {
            m: m.map(|row| row.map(|e| e / n)),
        }
    }
}

impl<D: Scalar> Mul for Quaternion<D> {
    type Output = Self;
    /// The Hamilton product: the rotation of `self * b` is `self.rotation() * b.rotation()`.
    fn mul(self, b: Self) -> Self {
        let a = self;
        Self::new(
            a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
            a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
            a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
            a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
        )
    }
}

/// Where a body is: its centre of mass in world coordinates and its orientation, and the
/// quaternion the orientation was made from, if any.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose<D> {
    /// The centre of mass r in world coordinates.
    pub centre: Vector3<D>,
    /// The orientation R (v_world = R v_body).
    pub rotation: Rotation<D>,
    /// The quaternion of [`from_quaternion`](Self::from_quaternion): the route adds
    /// ½ c (q·q̇)², c = 4 tr(I)/3, to T for it.
    pub quaternion: Option<Quaternion<D>>,
}

impl<D: Scalar> Pose<D> {
    /// At `centre`, turned by `rotation`.
    pub fn new(centre: Vector3<D>, rotation: Rotation<D>) -> Self {
        Self {
            centre,
            rotation,
            quaternion: None,
        }
    }

    /// At `centre`, turned by the quaternion `q` (its [`Quaternion::rotation`]). That R does
    /// not see ‖q‖, so T alone would leave M singular along q; the route adds ½ c (q·q̇)² with
    /// c = 4 tr(I)/3 (as `lg.Body`), which vanishes with its force on ‖q‖ = 1 (q·q̇ = 0 and
    /// q·q̈ + ‖q̇‖² = 0 there): the motion from a unit q with q·q̇ = 0 is unchanged, and M is
    /// regular.
    pub fn from_quaternion(centre: Vector3<D>, q: Quaternion<D>) -> Self {
        Self {
            centre,
            rotation: q.rotation(),
            quaternion: Some(q),
        }
    }

    /// At the origin, not turned.
    pub fn identity() -> Self {
        Self::new([D::zero(); 3], Rotation::identity())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_product_is_rotation_product() {
        let a = Quaternion::<f64>::new(0.3, -0.5, 0.7, 0.2);
        let b = Quaternion::<f64>::new(-0.4, 0.1, 0.9, -0.6);
        let (ab, rr) = ((a * b).rotation(), a.rotation() * b.rotation());
        for i in 0..3 {
            for j in 0..3 {
                assert!((ab.m[i][j] - rr.m[i][j]).abs() < 1e-15, "{i} {j}");
            }
        }
        assert!(a.rotation().orthonormality_error() < 1e-15);
        let n = a.normalized();
        assert!((n.norm_squared() - 1.0).abs() < 1e-15);
        let c = (n * n.conjugate()).normalized();
        assert!((c.w - 1.0).abs() < 1e-15 && c.x.abs() < 1e-15);
    }

    #[test]
    fn about_axis_matches_coordinate_turns() {
        for (axis, e) in [(Axis::X, [2.0, 0.0, 0.0]), (Axis::Z, [0.0, 0.0, -1.0])] {
            let a = Rotation::<f64>::about(axis, 0.7);
            let sign = if e[2] < 0.0 { -1.0 } else { 1.0 };
            let b = Rotation::<f64>::about_axis(e, 0.7 * sign);
            let q = Quaternion::<f64>::about_axis(e, 0.7 * sign).rotation();
            for i in 0..3 {
                for j in 0..3 {
                    assert!((a.m[i][j] - b.m[i][j]).abs() < 1e-15);
                    assert!((a.m[i][j] - q.m[i][j]).abs() < 1e-15);
                }
            }
        }
        let r = Rotation::<f64>::about_y(0.4);
        let v = r.apply([1.0, 2.0, 3.0]);
        let back = r.apply_transpose(v);
        assert!((back[2] - 3.0).abs() < 1e-15);
        assert_eq!(r.transpose().m[0][2], r.m[2][0]);
        assert!(
            Rotation::from_matrix([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
                .orthonormality_error()
                > 0.09
        );
        assert_eq!(cross([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
    }
}
