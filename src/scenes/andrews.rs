//! Andrews' squeezing mechanism: seven rigid bodies in a plane, closed into loops by six
//! holonomic constraints (Hairer & Wanner, *Solving ODEs II*, §VII.7; the IVP Test Set of
//! Mazzia, Magherini & Iavernaro, release 2.4, problem `andrews`, source `andrews.f`).
//!
//! Stated here through the public API alone: T from the bodies' motion, U from the spring and
//! the driving torque, the loop closures as [`Constraints`]. The Test Set's own hand-written
//! M, f, G and γ (`test_set_*`) are kept beside them, generic over the scalar, for the tests that
//! check the derivation and for the benches' hand-written index-1 right-hand side, the limit a
//! derived model is measured against. Parameters, initial values and the reference solution at
//! t = 0.03 are the Test Set's (`andrews.f`: `andpar`, `andini`, `andsoln`; the reference was
//! computed by PSIDE with rtol = atol = 1e-14 in Cray double precision).
//!
//! Not in the scene registry ([`super::registry`]): the registry builds unconstrained systems.

// The Test Set's values keep the digits it prints (more than an f64 holds).
#![allow(clippy::excessive_precision)]

use crate::constrained::Constrained;
use crate::energies::{Constraints, KineticEnergy, Potential};
use crate::routes::System;
use crate::scalar::Scalar;

// The Test Set's masses, inertias and geometry (`andrews.f`, `andpar`), SI units.
const M1: f64 = 0.043_25;
const M2: f64 = 0.003_65;
const M3: f64 = 0.023_73;
const M4: f64 = 0.007_06;
const M5: f64 = 0.070_50;
const M6: f64 = 0.007_06;
const M7: f64 = 0.054_98;
const I1: f64 = 2.194e-6;
const I2: f64 = 4.410e-7;
const I3: f64 = 5.255e-6;
const I4: f64 = 5.667e-7;
const I5: f64 = 1.169e-5;
const I6: f64 = 5.667e-7;
const I7: f64 = 1.912e-5;
const XA: f64 = -0.069_34;
const YA: f64 = -0.002_27;
const XB: f64 = -0.036_35;
const YB: f64 = 0.032_73;
const XC: f64 = 0.014;
const YC: f64 = 0.072;
const D: f64 = 28e-3;
const DA: f64 = 115e-4;
const E: f64 = 2e-2;
const EA: f64 = 1421e-5;
const RR: f64 = 7e-3;
const RA: f64 = 92e-5;
const SS: f64 = 35e-3;
const SA: f64 = 1874e-5;
const SB: f64 = 1043e-5;
const SC: f64 = 18e-3;
const SD: f64 = 2e-2;
const TA: f64 = 2308e-5;
const TB: f64 = 916e-5;
const U: f64 = 4e-2;
const UA: f64 = 1228e-5;
const UB: f64 = 449e-5;
const ZF: f64 = 2e-2;
const ZT: f64 = 4e-2;
const FA: f64 = 1421e-5;

/// The squeezer's seven angles q = (β, Θ, γ, Φ, δ, Ω, ε), in the Test Set's order.
pub const ANDREWS_COORDINATES: [&str; 7] =
    ["beta", "theta", "gamma", "phi", "delta", "omega", "epsilon"];

/// Andrews' squeezing mechanism (Hairer & Wanner II §VII.7, the IVP Test Set's `andrews`):
/// seven bodies turning in a plane, a crank driven by a constant torque `mom` and a spring of
/// stiffness `c0` and rest length `l0` between the fixed point C and the point D of body 3. The
/// seven angles are tied by six holonomic loop closures, so the mechanism has one degree of
/// freedom and an index-3 DAE as equations of motion.
///
/// - T: each body's ½ m v² + ½ I ω², its centre's velocity from the angles (bodies 2, 4 and 6
///   hang on bodies 1, 5 and 7), which is the Test Set's ½ q̇ᵀ M(q) q̇;
/// - U = ½ c0 (L − l0)² − mom β, L the spring's length (the torque is constant, so it has a
///   potential);
/// - constraints: the chain through body 3 closes at B, the chains through bodies 4–5 and 6–7
///   close at A (two rows each).
///
/// ```
/// use lagrangian::scenes::Andrews;
/// let squeezer = Andrews::default();
/// let model = squeezer.model();
/// let (q0, qd0) = Andrews::initial_state();
/// model.check_consistent(0.0, &q0, &qd0, None)?;
/// // The Test Set's consistent accelerations at t = 0 (its λ has the opposite sign).
/// let a = model.evaluate(0.0, &q0, &qd0)?;
/// assert!((a.accelerations[0] / Andrews::initial_accelerations()[0] - 1.0).abs() < 1e-10);
/// # Ok::<(), lagrangian::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Andrews {
    /// Driving torque on β (N m); the Test Set's 0.033.
    pub mom: f64,
    /// Spring stiffness (N/m); the Test Set's 4530.
    pub c0: f64,
    /// Spring rest length (m); the Test Set's 0.07785.
    pub l0: f64,
}

impl Default for Andrews {
    /// The Test Set's mechanism.
    fn default() -> Self {
        Self {
            mom: 0.033,
            c0: 4530.0,
            l0: 0.077_85,
        }
    }
}

/// The Test Set's state at t = 0.03 (`andsoln`, PSIDE at rtol = atol = 1e-14).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AndrewsReference {
    /// The angles q.
    pub q: [f64; 7],
    /// Their rates q̇.
    pub qd: [f64; 7],
    /// The accelerations q̈.
    pub qdd: [f64; 7],
    /// The multipliers in the Test Set's convention, M q̈ = f − Gᵀλ (this crate's λ is −λ).
    pub lambda: [f64; 6],
}

impl Andrews {
    /// The energy-route system, without the constraints.
    pub fn system(self) -> System<Self, Self> {
        System::new(7, self).with_potential(self)
    }

    /// The six loop closures.
    pub fn constraints(self) -> Self {
        self
    }

    /// The system under its constraints.
    pub fn model(self) -> Constrained<System<Self, Self>, Self> {
        Constrained::new(self.system(), self)
    }

    /// The Test Set's consistent initial state (q, q̇) at t = 0: at rest.
    pub fn initial_state() -> ([f64; 7], [f64; 7]) {
        (
            [
                -0.061_713_890_014_276_449_635_894_845_800_1,
                0.0,
                0.455_279_819_163_070_380_255_912_382_449,
                0.222_668_390_165_885_884_674_473_185_609,
                0.487_364_979_543_842_550_225_598_953_530,
                -0.222_668_390_165_885_884_674_473_185_609,
                1.230_547_444_549_821_192_497_351_155_68,
            ],
            [0.0; 7],
        )
    }

    /// The Test Set's consistent q̈ at t = 0.
    pub fn initial_accelerations() -> [f64; 7] {
        [
            14_222.443_919_954_113_870_591_162_588_7,
            -10_666.832_939_965_585_402_943_371_941_5,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
        ]
    }

    /// The Test Set's consistent λ at t = 0, in its convention M q̈ = f − Gᵀλ.
    pub fn initial_multipliers() -> [f64; 6] {
        [
            98.566_870_396_241_089_605_765_498_217_0,
            -6.122_688_344_255_662_655_031_143_931_22,
            0.0,
            0.0,
            0.0,
            0.0,
        ]
    }

    /// The Test Set's reference state at t = 0.03.
    pub fn reference_at_0_03() -> AndrewsReference {
        AndrewsReference {
            q: [
                0.158_107_711_962_990_4e2,
                -0.157_563_710_598_429_8e2,
                0.408_222_401_307_310_1e-1,
                -0.534_730_116_322_694_8,
                0.524_409_965_880_530_4,
                0.534_730_116_322_694_8,
                0.104_808_074_104_226_3e1,
            ],
            qd: [
                0.113_992_030_215_120_8e4,
                -0.142_437_929_499_411_1e4,
                0.110_329_122_193_713_4e2,
                0.192_933_746_442_138_5e2,
                0.573_569_928_479_080_8,
                -0.192_933_746_442_138_5e2,
                0.323_179_165_802_695_5,
            ],
            qdd: [
                -0.246_317_631_694_519_6e5,
                0.518_503_770_161_032_9e5,
                0.324_102_568_641_378_1e6,
                0.566_749_364_517_621_3e6,
                0.167_436_292_947_936_1e5,
                -0.566_749_364_517_622_2e6,
                0.982_652_079_145_842_2e4,
            ],
            lambda: [
                0.199_175_333_373_191_0e3,
                -0.297_553_122_801_505_2e2,
                0.230_665_411_909_839_9e2,
                0.314_527_136_547_592_7e2,
                0.226_424_923_208_273_9e2,
                0.116_174_070_001_967_3e2,
            ],
        }
    }

    /// The spring's end D on body 3 and its length L from C.
    fn spring<S: Scalar>(gamma: S) -> (S, S, S) {
        let (s, c) = (gamma.sin(), gamma.cos());
        let xd = c * SD + s * SC + XB;
        let yd = s * SD - c * SC + YB;
        let (dx, dy) = (xd - XC, yd - YC);
        (dx, dy, (dx * dx + dy * dy).sqrt())
    }

    /// The Test Set's mass matrix M(q), transcribed from `andrews.f` (row-major 7 × 7).
    pub fn test_set_mass_matrix<S: Scalar>(q: &[S]) -> [[S; 7]; 7] {
        let z = S::from(0.0);
        let mut m = [[z; 7]; 7];
        let (coth, siph, siom) = (q[1].cos(), q[3].sin(), q[5].sin());
        let ee = E - EA;
        let zz = ZF - FA;
        m[0][0] = (coth * (-2.0 * DA * RR) + (RR * RR + DA * DA)) * M2 + (M1 * RA * RA + I1 + I2);
        m[1][0] = (coth * (-DA * RR) + DA * DA) * M2 + I2;
        m[1][1] = S::from(M2 * DA * DA + I2);
        m[2][2] = S::from(M3 * (SA * SA + SB * SB) + I3);
        m[3][3] = S::from(M4 * ee * ee + I4);
        m[4][3] = (siph * (ZT * ee) + ee * ee) * M4 + I4;
        m[4][4] = (siph * (2.0 * ZT * ee) + (ZT * ZT + ee * ee)) * M4
            + (M5 * (TA * TA + TB * TB) + I4 + I5);
        m[5][5] = S::from(M6 * zz * zz + I6);
        m[6][5] = (siom * (-U * zz) + zz * zz) * M6 + I6;
        m[6][6] = (siom * (-2.0 * U * zz) + (zz * zz + U * U)) * M6
            + (M7 * (UA * UA + UB * UB) + I6 + I7);
        for j in 1..7 {
            for i in 0..j {
                m[i][j] = m[j][i];
            }
        }
        m
    }

    /// The Test Set's f(q, q̇) (`andrews.f`'s `ff`): the driving torque, the spring's
    /// generalized force and the Coriolis and centrifugal terms, so that M q̈ = f − Gᵀλ.
    pub fn test_set_forces<S: Scalar>(&self, q: &[S], qd: &[S]) -> [S; 7] {
        let (sith, coga, siga, coph, coom) =
            (q[1].sin(), q[2].cos(), q[2].sin(), q[3].cos(), q[5].cos());
        let (bep, thp, php, dep, omp, epp) = (qd[0], qd[1], qd[3], qd[4], qd[5], qd[6]);
        let (dx, dy, lang) = Self::spring(q[2]);
        let force = -(lang - self.l0) / lang * self.c0;
        let (fx, fy) = (force * dx, force * dy);
        [
            -(thp * (thp + bep * 2.0) * sith * (M2 * DA * RR)) + self.mom,
            bep * bep * sith * (M2 * DA * RR),
            fx * (coga * SC - siga * SD) + fy * (coga * SD + siga * SC),
            dep * dep * coph * (M4 * ZT * (E - EA)),
            -(php * (php + dep * 2.0) * coph * (M4 * ZT * (E - EA))),
            -(epp * epp * coom * (M6 * U * (ZF - FA))),
            omp * (omp + epp * 2.0) * coom * (M6 * U * (ZF - FA)),
        ]
    }

    /// The Test Set's constraint Jacobian G = ∂g/∂q (`andrews.f`'s `gp`, 6 × 7).
    pub fn test_set_jacobian<S: Scalar>(q: &[S]) -> [[S; 7]; 6] {
        let z = S::from(0.0);
        let mut g = [[z; 7]; 6];
        let (sibe, cobe) = (q[0].sin(), q[0].cos());
        let (siga, coga) = (q[2].sin(), q[2].cos());
        let (side, code) = (q[4].sin(), q[4].cos());
        let (siep, coep) = (q[6].sin(), q[6].cos());
        let (sibeth, cobeth) = ((q[0] + q[1]).sin(), (q[0] + q[1]).cos());
        let (siphde, cophde) = ((q[3] + q[4]).sin(), (q[3] + q[4]).cos());
        let (siomep, coomep) = ((q[5] + q[6]).sin(), (q[5] + q[6]).cos());
        // Rows 1, 3, 5 (x) and 2, 4, 6 (y) share the crank's columns β, Θ.
        for r in [0, 2, 4] {
            g[r][0] = sibeth * D - sibe * RR;
            g[r][1] = sibeth * D;
            g[r + 1][0] = cobe * RR - cobeth * D;
            g[r + 1][1] = -(cobeth * D);
        }
        g[0][2] = -(coga * SS);
        g[1][2] = -(siga * SS);
        g[2][3] = -(cophde * E);
        g[2][4] = side * ZT - cophde * E;
        g[3][3] = -(siphde * E);
        g[3][4] = -(siphde * E) - code * ZT;
        g[4][5] = siomep * ZF;
        g[4][6] = siomep * ZF - coep * U;
        g[5][5] = -(coomep * ZF);
        g[5][6] = -(coomep * ZF) - siep * U;
        g
    }

    /// γ for the Test Set's constraints: g̈ = G q̈ + γ along the motion, γ = (∂(G q̇)/∂q) q̇,
    /// derived by hand from `andrews.f`'s g (Hairer & Wanner II §VII.7).
    pub fn test_set_gamma<S: Scalar>(q: &[S], qd: &[S]) -> [S; 6] {
        let (sibe, cobe) = (q[0].sin(), q[0].cos());
        let (siga, coga) = (q[2].sin(), q[2].cos());
        let (side, code) = (q[4].sin(), q[4].cos());
        let (siep, coep) = (q[6].sin(), q[6].cos());
        let (sibeth, cobeth) = ((q[0] + q[1]).sin(), (q[0] + q[1]).cos());
        let (siphde, cophde) = ((q[3] + q[4]).sin(), (q[3] + q[4]).cos());
        let (siomep, coomep) = ((q[5] + q[6]).sin(), (q[5] + q[6]).cos());
        let b2 = qd[0] * qd[0];
        let bt2 = (qd[0] + qd[1]) * (qd[0] + qd[1]);
        let g2 = qd[2] * qd[2];
        let pd2 = (qd[3] + qd[4]) * (qd[3] + qd[4]);
        let d2 = qd[4] * qd[4];
        let oe2 = (qd[5] + qd[6]) * (qd[5] + qd[6]);
        let e2 = qd[6] * qd[6];
        // The crank's part of the x rows and of the y rows.
        let cx = cobeth * bt2 * D - cobe * b2 * RR;
        let cy = sibeth * bt2 * D - sibe * b2 * RR;
        [
            cx + siga * g2 * SS,
            cy - coga * g2 * SS,
            cx + siphde * pd2 * E + code * d2 * ZT,
            cy - cophde * pd2 * E + side * d2 * ZT,
            cx + coomep * oe2 * ZF + siep * e2 * U,
            cy + siomep * oe2 * ZF - coep * e2 * U,
        ]
    }

    /// The Test Set's index-1 formulation solved by hand: q̈ and λ (its convention) from the
    /// augmented system [M Gᵀ; G 0] (q̈, λ) = (f, −γ), by Gaussian elimination with partial
    /// pivoting on the 13 × 13 matrix, generic over the scalar and without allocation. The limit
    /// a model derived from its energies is measured against.
    pub fn test_set_index1<S: Scalar>(&self, q: &[S], qd: &[S]) -> ([S; 7], [S; 6]) {
        let m = Self::test_set_mass_matrix(q);
        let f = self.test_set_forces(q, qd);
        let g = Self::test_set_jacobian(q);
        let gamma = Self::test_set_gamma(q, qd);
        let z = S::from(0.0);
        // Rows of [A | b].
        let mut a = [[z; 14]; 13];
        for i in 0..7 {
            a[i][..7].copy_from_slice(&m[i]);
            for r in 0..6 {
                a[i][7 + r] = g[r][i];
            }
            a[i][13] = f[i];
        }
        for r in 0..6 {
            a[7 + r][..7].copy_from_slice(&g[r]);
            a[7 + r][13] = -gamma[r];
        }
        for col in 0..13 {
            let pivot = (col..13)
                .max_by(|&i, &j| a[i][col].re().abs().total_cmp(&a[j][col].re().abs()))
                .unwrap_or(col);
            a.swap(col, pivot);
            let p = a[col][col];
            for row in col + 1..13 {
                let factor = a[row][col] / p;
                if factor.re() != 0.0 {
                    for k in col..14 {
                        let sub = a[col][k] * factor;
                        a[row][k] -= sub;
                    }
                }
            }
        }
        let mut x = [z; 13];
        for row in (0..13).rev() {
            let mut s = a[row][13];
            for k in row + 1..13 {
                s -= a[row][k] * x[k];
            }
            x[row] = s / a[row][row];
        }
        let mut qdd = [z; 7];
        let mut lambda = [z; 6];
        qdd.copy_from_slice(&x[..7]);
        lambda.copy_from_slice(&x[7..]);
        (qdd, lambda)
    }
}

impl KineticEnergy for Andrews {
    const FIXED_DOF: Option<usize> = Some(7);

    /// The bodies' ½ m v² + ½ I ω²: bodies 1, 3, 5, 7 turn about fixed points (their centres at
    /// ra, √(sa² + sb²), √(ta² + tb²), √(ua² + ub²)); body 2 hangs on body 1 at rr (its centre
    /// at da from the joint), body 4 on body 5 at zt, body 6 on body 7 at u.
    fn kinetic<S: Scalar>(&self, _t: S, q: &[S], qd: &[S]) -> S {
        let (bep, thp, gap, php, dep, omp, epp) = (qd[0], qd[1], qd[2], qd[3], qd[4], qd[5], qd[6]);
        let bt = bep + thp;
        let pd = php + dep;
        let oe = omp + epp;
        let ee = E - EA;
        let zz = ZF - FA;
        // |v|² of the centres of bodies 2, 4 and 6.
        let v2 =
            bep * bep * (RR * RR) + bt * bt * (DA * DA) - q[1].cos() * bep * bt * (2.0 * RR * DA);
        let v4 =
            dep * dep * (ZT * ZT) + pd * pd * (ee * ee) + q[3].sin() * dep * pd * (2.0 * ZT * ee);
        let v6 = epp * epp * (U * U) + oe * oe * (zz * zz) - q[5].sin() * epp * oe * (2.0 * U * zz);
        let twice = bep * bep * (M1 * RA * RA + I1)
            + v2 * M2
            + bt * bt * I2
            + gap * gap * (M3 * (SA * SA + SB * SB) + I3)
            + v4 * M4
            + pd * pd * I4
            + dep * dep * (M5 * (TA * TA + TB * TB) + I5)
            + v6 * M6
            + oe * oe * I6
            + epp * epp * (M7 * (UA * UA + UB * UB) + I7);
        twice * 0.5
    }

    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Potential for Andrews {
    /// The spring's ½ c0 (L − l0)² and the driving torque's −mom β.
    fn potential<S: Scalar>(&self, _t: S, q: &[S]) -> S {
        let (_, _, lang) = Self::spring(q[2]);
        let stretch = lang - self.l0;
        stretch * stretch * (0.5 * self.c0) - q[0] * self.mom
    }

    fn depends_on_time(&self) -> bool {
        false
    }
}

impl Constraints for Andrews {
    fn holonomic_count(&self) -> usize {
        6
    }

    /// `andrews.f`'s g: the crank's end (β, Θ) meets body 3 at B (rows 0, 1), the chain of
    /// bodies 5 and 4 at A (rows 2, 3) and the chain of bodies 7 and 6 at A (rows 4, 5).
    fn holonomic<S: Scalar>(&self, _t: S, q: &[S], out: &mut [S]) {
        let (sibe, cobe) = (q[0].sin(), q[0].cos());
        let (sibeth, cobeth) = ((q[0] + q[1]).sin(), (q[0] + q[1]).cos());
        let cx = cobe * RR - cobeth * D;
        let cy = sibe * RR - sibeth * D;
        out[0] = cx - q[2].sin() * SS - XB;
        out[1] = cy + q[2].cos() * SS - YB;
        out[2] = cx - (q[3] + q[4]).sin() * E - q[4].cos() * ZT - XA;
        out[3] = cy + (q[3] + q[4]).cos() * E - q[4].sin() * ZT - YA;
        out[4] = cx - (q[5] + q[6]).cos() * ZF - q[6].sin() * U - XA;
        out[5] = cy - (q[5] + q[6]).sin() * ZF + q[6].cos() * U - YA;
    }

    fn depends_on_time(&self) -> bool {
        false
    }

    fn name(&self, row: usize) -> String {
        const NAMES: [&str; 6] = [
            "closure at B (x)",
            "closure at B (y)",
            "closure at A through bodies 4-5 (x)",
            "closure at A through bodies 4-5 (y)",
            "closure at A through bodies 6-7 (x)",
            "closure at A through bodies 6-7 (y)",
        ];
        NAMES
            .get(row)
            .map_or_else(|| format!("constraint {row}"), |s| (*s).into())
    }
}
