//! The stability verdict of an equilibrium, and its classification from the stiffness alone
//! (the energy criterion, where M is singular).

use nalgebra::{DMatrix, DVector};

/// The character of an equilibrium.
///
/// Decided from the eigenvalues of the linearized equations of motion ([`crate::modes`]; the reason
/// is stated in [`Equilibrium::reason`](super::Equilibrium::reason)): an eigenvalue with a positive
/// real part makes it unstable, a zero eigenvalue neutral, and it is stable when every eigenvalue
/// has a negative real part, or when K is positive definite (a strict minimum of the effective
/// potential U − T₀) with the rest on the imaginary axis, or when gyroscopic forces hold every
/// eigenvalue on the imaginary axis although K is not. Where M is singular (a model for statics
/// only) the eigenvalues λ of the symmetric part of K decide, the energy criterion of seed §3.2
/// (3): all λ > 0 stable, some λ < 0 unstable, else neutral.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stability {
    /// Small disturbances stay small.
    Stable,
    /// Some small disturbance grows.
    Unstable,
    /// The linearization does not decide (a zero eigenvalue, such as a lever whose loads
    /// balance at every angle, or eigenvalues on the imaginary axis under circulatory forces).
    Neutral,
}

/// Eigenvalues of the symmetric part of K, ascending, and the stability they imply with the
/// reason.
pub(crate) fn classify(k: &DMatrix<f64>, tol: f64) -> (DVector<f64>, (Stability, String)) {
    let sym = (k + k.transpose()) * 0.5;
    let mut values: Vec<f64> = sym.symmetric_eigenvalues().iter().copied().collect();
    values.sort_by(f64::total_cmp);
    let scale = values.iter().fold(0.0_f64, |s, v| s.max(v.abs()));
    let zero = tol * scale;
    let verdict = if let Some(&v) = values.iter().find(|&&v| v < -zero) {
        (
            Stability::Unstable,
            format!("K has the negative eigenvalue {v:.6e} (a maximum or saddle of the potential)"),
        )
    } else if scale > 0.0 && values.iter().all(|&v| v > zero) {
        (
            Stability::Stable,
            "K is positive definite (a strict minimum of the potential)".to_string(),
        )
    } else {
        (
            Stability::Neutral,
            "K has a zero eigenvalue (higher-order terms decide)".to_string(),
        )
    };
    (DVector::from_vec(values), verdict)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn classify_signs() {
        let tol = 1e-9;
        let m = |v: &[f64]| DMatrix::from_row_slice(2, 2, v);
        assert_eq!(
            classify(&m(&[2.0, 1.0, 1.0, 2.0]), tol).1.0,
            Stability::Stable
        );
        assert_eq!(
            classify(&m(&[1.0, 2.0, 2.0, 1.0]), tol).1.0,
            Stability::Unstable
        );
        assert_eq!(
            classify(&m(&[1.0, 1.0, 1.0, 1.0]), tol).1.0,
            Stability::Neutral
        );
        assert_eq!(classify(&m(&[0.0; 4]), tol).1.0, Stability::Neutral);
        // Only the symmetric part counts: a pure rotation generator is neutral.
        assert_eq!(
            classify(&m(&[0.0, 1.0, -1.0, 0.0]), tol).1.0,
            Stability::Neutral
        );
        let (values, _) = classify(&m(&[3.0, 1.0, 1.0, 3.0]), tol);
        assert_relative_eq!(values[0], 2.0, epsilon = 1e-14);
        assert_relative_eq!(values[1], 4.0, epsilon = 1e-14);
    }
}
