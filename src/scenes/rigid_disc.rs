//! A rolling disc (cylinder, ball) on the particle route: three point masses with the body's
//! mass, centroid and moment of inertia, so they have its kinetic energy in plane motion.

use crate::scalar::Scalar;

/// Mass of point `k` of a disc of mass `m` and moment of inertia `j` about its centre, radius
/// `radius`: m − J/r² at the centre (k = 0) and J/(2r²) at each of two opposite rim points — total
/// m, centroid the centre, second moment J. (J > m r² makes the centre mass negative; T stays
/// exact.)
pub(super) fn mass(m: f64, j: f64, radius: f64, k: usize) -> f64 {
    let rim = j / (radius * radius);
    if k == 0 { m - rim } else { 0.5 * rim }
}

/// The three points in `r[..6]`: the centre (cx, cy), then (cx, cy) ± radius (sin ψ, cos ψ),
/// where ψ is the disc's rotation angle.
pub(super) fn points<D: Scalar>(cx: D, cy: D, psi: D, radius: f64, r: &mut [D]) {
    let (s, c) = psi.sin_cos();
    let (ux, uy) = (s * radius, c * radius);
    r[..6].copy_from_slice(&[cx, cy, cx + ux, cy + uy, cx - ux, cy - uy]);
}
